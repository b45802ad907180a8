"""Writing recordings in the DAQ formats squealkit reads (WAV, TDMS, MDF4, UFF 58, CSV, netCDF).

Used by ``squealkit synth`` so every reader can be tried without a DAQ. Channels are written
in physical units where the format has them (TDMS, MDF4, UFF 58, netCDF); a WAV file holds
32-bit float samples, which ``open_recording`` returns unscaled (give ``scale`` for integer
WAVs from a real DAQ).
"""

from __future__ import annotations

import os
import struct
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import NDArray

from ..._optional import require
from ..._validation import InputError, check_memory

__all__ = ["FORMATS", "write_recording", "write_recording_blocks"]

Block = tuple[int, Mapping[str, NDArray[np.float64]]]

#: Output suffixes :func:`write_recording` understands.
FORMATS = (".nc", ".csv", ".wav", ".tdms", ".mf4", ".mdf", ".uff", ".unv")


def write_recording(rec: xr.Dataset, path: str | Path) -> Path:
    """Write the 1-D channels of a recording (a Dataset on ``time`` with ``fs``) to ``path``.

    The format follows the suffix (see :data:`FORMATS`); the file is staged and moved into
    place when complete (:func:`squealkit.io.atomic_path`). A SYNTHETIC recording is labelled
    as such in the file (netCDF/TDMS/MDF4 attributes or comment; UFF 58 ``id2``).

    Parameters
    ----------
    rec : xarray.Dataset
        Channels on ``time``, attribute ``fs`` [Hz]; channel ``units`` in their attributes.
    path : path-like
        The output file; its suffix picks the format.

    Returns
    -------
    pathlib.Path
        ``path`` as a ``Path``.
    """
    from ...io import save_dataset

    if Path(path).suffix.lower() == ".nc":  # in memory already: the Dataset as it is (its own time axis)
        return save_dataset(rec, Path(path))
    names = [str(n) for n in rec.data_vars if rec[n].dims == ("time",)]
    units = {n: str(rec[n].attrs.get("units", "")) for n in names}
    # the recording's own time axis goes where the format stores one (CSV, MDF4)
    block = (0, {"time": rec["time"].values, **{n: rec[n].values for n in names}})
    return write_recording_blocks([block], path, fs=float(rec.attrs["fs"]), n_samples=rec.sizes["time"],
                                  units=units, attrs=dict(rec.attrs))


def write_recording_blocks(blocks: Iterable[Block], path: str | Path, *, fs: float, n_samples: int,
                           units: Mapping[str, str], attrs: Mapping[str, Any] | None = None) -> Path:
    """Write a recording that arrives block by block, holding one block at a time.

    netCDF, CSV, WAV, TDMS and MDF4 are written as the blocks come (memory bounded whatever the
    length); UFF 58 (one ASCII record per channel) is gathered in memory first, refused up
    front when it will not fit. Staged and moved into place when complete, as
    :func:`write_recording`; an error or an interrupt leaves nothing behind.

    Parameters
    ----------
    blocks : iterable of (int, dict)
        ``(first sample, {channel: samples})`` in order, e.g.
        :meth:`~squealkit.measurement.synthetic.SyntheticSource.iter_blocks`; an entry ``"time"``
        [s], if given, is the time axis where the format stores one (CSV, MDF4), else
        ``sample / fs``.
    path : path-like
        The output file; its suffix picks the format (:data:`FORMATS`).
    fs : float
        Sample rate [Hz].
    n_samples : int
        Samples in all (the WAV header is written first).
    units : mapping
        Unit of each channel, in the order the channels are written.
    attrs : mapping, optional
        Attributes of the recording (``synthetic``, ``title``, truth...).

    Returns
    -------
    pathlib.Path
        ``path`` as a ``Path``.
    """
    from ...io import atomic_path, deferred_interrupts, save_blocks

    p = Path(path)
    suffix = p.suffix.lower()
    if suffix not in FORMATS:
        raise InputError(f"Recording {str(p)!r} must end in {', '.join(FORMATS)}.")
    names, attrs = list(units), dict(attrs or {})
    attrs.setdefault("fs", float(fs))
    if suffix == ".nc":
        return save_blocks(_datasets(blocks, fs, units, attrs), p)
    synthetic = bool(attrs.get("synthetic", 0))
    if suffix in (".uff", ".unv"):
        check_memory(8.0 * n_samples * (len(names) + 1) * 4, f"A UFF 58 file of {n_samples} samples",
                     "UFF 58 is written whole; choose .nc, .csv, .wav, .tdms or .mf4 for long recordings.")
    with atomic_path(p) as tmp:
        if suffix == ".csv":
            with open(tmp, "w", encoding="utf-8") as fh:
                fh.write(",".join(["time [s]"] + [f"{n} [{units[n]}]" for n in names]) + "\n")
                for start, data in blocks:
                    cols = np.column_stack([_block_time(start, data, names, fs)] + [data[n] for n in names])
                    np.savetxt(fh, cols, delimiter=",", fmt="%.8g")
        elif suffix == ".wav":
            _write_wav(tmp, blocks, fs, n_samples, names)
        elif suffix == ".tdms":
            from nptdms import ChannelObject, RootObject, TdmsWriter

            root = RootObject(properties={"synthetic": int(synthetic), "title": str(attrs.get("title", ""))})
            with TdmsWriter(tmp) as w:
                for start, data in blocks:
                    with deferred_interrupts():
                        w.write_segment(([root] if start == 0 else []) + [
                            ChannelObject("rig", n, np.asarray(data[n]), properties={
                                "unit_string": units[n], "wf_increment": 1.0 / fs} if start == 0 else {})
                            for n in names])
        elif suffix in (".mf4", ".mdf"):
            asammdf = require("asammdf", "Writing MDF4")
            MDF, Signal = asammdf.MDF, asammdf.Signal

            mdf = MDF(version="4.10")
            mdf.header.comment = "SYNTHETIC recording (squealkit), not a measurement" if synthetic else ""
            for start, data in blocks:
                t = _block_time(start, data, names, fs)
                if start == 0:
                    mdf.append([Signal(np.asarray(data[n]), t, name=n, unit=units[n]) for n in names],
                               comment="squealkit recording")
                else:
                    mdf.extend(0, [(t, None)] + [(np.asarray(data[n]), None) for n in names])
            inner = tmp.parent / (tmp.name + ".mf4")  # asammdf insists on its suffix
            try:
                mdf.save(inner, overwrite=True)
                mdf.close()
                os.replace(inner, tmp)
            finally:
                inner.unlink(missing_ok=True)
        else:
            _write_uff(tmp, blocks, fs, n_samples, names, units, synthetic)
    return p


def _block_time(start: int, data: Mapping[str, NDArray], names: list[str], fs: float) -> NDArray:
    """The block's time axis [s]: its own ``"time"`` entry, else ``sample / fs``."""
    if "time" in data:
        return np.asarray(data["time"], dtype=np.float64)
    return np.arange(start, start + len(data[names[0]])) / fs


def _datasets(blocks: Iterable[Block], fs: float, units: Mapping[str, str], attrs: Mapping[str, Any]
              ) -> Iterator[xr.Dataset]:
    from .readers import recording_dataset

    for start, data in blocks:
        ds = recording_dataset({n: data[n] for n in units}, fs, units, attrs)
        yield ds.assign_coords(time=("time", np.arange(start, start + ds.sizes["time"]) / fs, {"units": "s"}))


def _write_wav(tmp: Path, blocks: Iterable[Block], fs: float, n_samples: int, names: list[str]) -> None:
    """32-bit float WAV, the header first (scipy's, with the sizes of ``n_samples`` frames)."""
    import io as _io

    from scipy.io import wavfile

    data_bytes = n_samples * len(names) * 4
    if data_bytes + 100 > 0xFFFFFFFF:
        raise InputError(f"A WAV file holds at most 4 GiB; {n_samples} samples of {len(names)} channels are "
                         f"{data_bytes / 2**30:.1f} GiB. Choose .nc, .tdms or .mf4.")
    head = _io.BytesIO()
    wavfile.write(head, round(fs), np.zeros((0, len(names)), dtype=np.float32))
    h = bytearray(head.getvalue())
    struct.pack_into("<I", h, 4, len(h) - 8 + data_bytes)
    fact = h.find(b"fact")
    if fact >= 0:
        struct.pack_into("<I", h, fact + 8, n_samples)
    struct.pack_into("<I", h, h.rfind(b"data") + 4, data_bytes)
    written = 0
    with open(tmp, "wb") as fh:
        fh.write(h)
        for _start, data in blocks:
            frames = np.column_stack([data[n] for n in names]).astype("<f4")
            fh.write(frames.tobytes())
            written += frames.shape[0]
    if written != n_samples:
        raise InputError(f"WAV: {written} samples arrived, {n_samples} were announced.")


def _write_uff(tmp: Path, blocks: Iterable[Block], fs: float, n_samples: int, names: list[str],
               units: Mapping[str, str], synthetic: bool) -> None:
    """UFF 58, one function per channel (ASCII; pyuff 2.5's binary 58b did not read back)."""
    pyuff = require("pyuff", "Writing UFF 58")

    parts: dict[str, list] = {n: [] for n in names}
    for _start, data in blocks:
        for n in names:
            parts[n].append(np.asarray(data[n]))
    values = {n: np.concatenate(v) for n, v in parts.items()}
    t = np.arange(n_samples) / fs
    inner = tmp.parent / (tmp.name + ".uff")
    uff = pyuff.UFF(str(inner))
    sets = [pyuff.prepare_58(
        binary=0, id1=n, id2="SYNTHETIC" if synthetic else "", func_type=1, rsp_node=i + 1, rsp_dir=0,
        ref_node=0, ref_dir=0, ord_data_type=4, num_pts=n_samples, abscissa_spacing=1,
        abscissa_min=0.0, abscissa_inc=1.0 / fs, abscissa_axis_units_lab="s",
        ordinate_axis_units_lab=units[n], data=values[n], x=t,
        rsp_ent_name=n, ref_ent_name="",
        abscissa_spec_data_type=17, ordinate_spec_data_type=0, orddenom_spec_data_type=0,
        z_axis_spec_data_type=0, orddenom_axis_units_lab="", z_axis_axis_units_lab="", z_axis_value=0.0,
        id3="", id4="", id5="", ver_num=0, load_case_id=0,
        **{f"{ax}_{u}_unit_exp": 0 for ax in ("abscissa", "ordinate", "orddenom", "z_axis")
           for u in ("len", "force", "temp")})
        for i, n in enumerate(names)]
    try:
        uff.write_sets(sets, mode="overwrite")
        os.replace(inner, tmp)
    except Exception as e:
        # pyuff wraps the OS's error (a full disk) in a bare Exception: report the OS's error
        if isinstance(e.__context__, OSError) and not isinstance(e, OSError):
            raise e.__context__ from None
        raise
    finally:
        inner.unlink(missing_ok=True)

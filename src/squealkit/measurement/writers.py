"""Writing recordings in the DAQ formats squealkit reads (WAV, TDMS, MDF4, UFF 58, CSV, netCDF).

Used by ``squealkit synth`` so every reader can be tried without a DAQ. Channels are written
in physical units where the format has them (TDMS, MDF4, UFF 58, netCDF); a WAV file holds
32-bit float samples, which ``open_recording`` returns unscaled (give ``scale`` for integer
WAVs from a real DAQ).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import xarray as xr

from .._validation import InputError

__all__ = ["FORMATS", "write_recording"]

#: Output suffixes :func:`write_recording` understands.
FORMATS = (".nc", ".csv", ".wav", ".tdms", ".mf4", ".mdf", ".uff", ".unv")


def write_recording(rec: xr.Dataset, path: str | Path) -> Path:
    """Write the 1-D channels of a recording (a Dataset on ``time`` with ``fs``) to ``path``.

    The format follows the suffix (see :data:`FORMATS`); the file is staged and moved into
    place when complete (:func:`squealkit.io.atomic_path`). A SYNTHETIC recording is labelled
    as such in the file (netCDF/TDMS/MDF4 attributes or comment; UFF 58 ``id2``).
    """
    from ..io import atomic_path, save_dataset

    p = Path(path)
    suffix = p.suffix.lower()
    if suffix not in FORMATS:
        raise InputError(f"Recording {str(p)!r} must end in {', '.join(FORMATS)}.")
    if suffix == ".nc":
        return save_dataset(rec, p)
    fs = float(rec.attrs["fs"])
    names = [str(n) for n in rec.data_vars if rec[n].dims == ("time",)]
    units = {n: str(rec[n].attrs.get("units", "")) for n in names}
    synthetic = bool(rec.attrs.get("synthetic", 0))
    with atomic_path(p) as tmp:
        if suffix == ".csv":
            cols = np.column_stack([rec["time"].values] + [rec[n].values for n in names])
            header = ",".join(["time [s]"] + [f"{n} [{units[n]}]" for n in names])
            np.savetxt(tmp, cols, delimiter=",", header=header, comments="", fmt="%.8g")
        elif suffix == ".wav":
            from scipy.io import wavfile

            wavfile.write(tmp, round(fs), np.column_stack([rec[n].values for n in names]).astype(np.float32))
        elif suffix == ".tdms":
            from nptdms import ChannelObject, RootObject, TdmsWriter

            root = RootObject(properties={"synthetic": int(synthetic), "title": str(rec.attrs.get("title", ""))})
            with TdmsWriter(tmp) as w:
                w.write_segment([root] + [
                    ChannelObject("rig", n, rec[n].values, properties={"unit_string": units[n],
                                                                         "wf_increment": 1.0 / fs})
                    for n in names])
        elif suffix in (".mf4", ".mdf"):
            from asammdf import MDF, Signal

            t = rec["time"].values
            mdf = MDF(version="4.10")
            mdf.header.comment = "SYNTHETIC recording (squealkit), not a measurement" if synthetic else ""
            mdf.append([Signal(rec[n].values, t, name=n, unit=units[n]) for n in names],
                       comment="squealkit recording")
            inner = tmp.parent / (tmp.name + ".mf4")  # asammdf insists on its suffix
            mdf.save(inner, overwrite=True)
            mdf.close()
            os.replace(inner, tmp)
        else:  # UFF 58: one function per channel (ASCII; pyuff 2.5's binary 58b did not read back)
            import pyuff

            inner = tmp.parent / (tmp.name + ".uff")
            uff = pyuff.UFF(str(inner))
            sets = [pyuff.prepare_58(
                binary=0, id1=n, id2="SYNTHETIC" if synthetic else "", func_type=1, rsp_node=i + 1, rsp_dir=0,
                ref_node=0, ref_dir=0, ord_data_type=4, num_pts=rec.sizes["time"], abscissa_spacing=1,
                abscissa_min=0.0, abscissa_inc=1.0 / fs, abscissa_axis_units_lab="s",
                ordinate_axis_units_lab=units[n], data=rec[n].values, x=rec["time"].values,
                rsp_ent_name=n, ref_ent_name="",
                abscissa_spec_data_type=17, ordinate_spec_data_type=0, orddenom_spec_data_type=0,
                z_axis_spec_data_type=0, orddenom_axis_units_lab="", z_axis_axis_units_lab="", z_axis_value=0.0,
                id3="", id4="", id5="", ver_num=0, load_case_id=0,
                **{f"{ax}_{u}_unit_exp": 0 for ax in ("abscissa", "ordinate", "orddenom", "z_axis")
                   for u in ("len", "force", "temp")})
                for i, n in enumerate(names)]
            uff.write_sets(sets, mode="overwrite")
            os.replace(inner, tmp)
    return p

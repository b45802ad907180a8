"""The block source every reader returns: channels, units, sample rate and checked blocks of samples."""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..._validation import InputError, validate_int
from ._common import _TIME, DEFAULT_BLOCK, _as_samples, _check_finite, _fail, _library_error, _TimeAxis


@dataclass(frozen=True)
class RecordingSource:
    """A recording on disk: channel names, units, sample rate, and a block reader.

    Attributes
    ----------
    path : Path
        The recording file.
    fmt : str
        ``"csv"``, ``"wav"``, ``"netcdf"``, ``"tdms"``, ``"mdf4"`` or ``"uff"``.
    fs : float
        Sample rate [Hz].
    n_samples : int
        Samples per channel.
    channels : tuple of str
        Channel names in file order.
    units : dict
        Unit of each channel (``""`` when the file does not say).
    scales : dict of str to float
        Factor from file values to physical units, per channel name (absent: 1).
    """

    path: Path
    fmt: str
    fs: float
    n_samples: int
    channels: tuple[str, ...]
    units: dict[str, str]
    scales: dict[str, float] = field(default_factory=dict)
    _extra: dict[str, Any] = field(default_factory=dict, repr=False)

    @property
    def synthetic(self) -> bool:
        """Whether the file says it is a synthetic recording (attribute ``synthetic``)."""
        return bool(self._extra.get("synthetic", False))

    @property
    def duration(self) -> float:
        """Length of the recording [s]."""
        return self.n_samples / self.fs

    def resolve(self, channel: str | int) -> str:
        """Channel name for a name or a 0-based index (also given as a digit string).

        Parameters
        ----------
        channel : str or int
            A channel name (for TDMS also the channel part of ``group/channel`` when unique) or
            a 0-based index.

        Returns
        -------
        str
            The channel's name in the file.

        Raises
        ------
        InputError
            If there is no such channel (the message lists the available ones).
        """
        if isinstance(channel, str) and channel in self.channels:
            return channel
        if isinstance(channel, str) and self.fmt == "tdms":
            matches = [c for c in self.channels if c.split("/")[-1] == channel]
            if len(matches) == 1:
                return matches[0]
        idx: int | None = None
        if isinstance(channel, int | np.integer) and not isinstance(channel, bool):
            idx = int(channel)
        elif isinstance(channel, str) and channel.strip().lstrip("-").isdigit():
            idx = int(channel)
        if idx is not None and 0 <= idx < len(self.channels):
            return self.channels[idx]
        other = getattr(self, "_extra", {}).get("non_numeric", {})  # (also lent to in-memory sources)
        hit = [n for n in other if channel in (n, n.split("/")[-1])]
        if hit:
            raise _fail(self.path, f"holds {other[hit[0]]}, not numeric samples; numeric channels: "
                                   f"{', '.join(repr(c) for c in self.channels)}.", channel=hit[0])
        raise InputError(
            f"Channel {channel!r} is not in {str(self.path)!r}; available: "
            f"{', '.join(repr(c) for c in self.channels)} (or an index 0-{len(self.channels) - 1})."
        )

    def _where(self, k: int) -> str:
        """Where sample ``k`` is in the file: a CSV line (the header is line 1) or a sample index."""
        return f"line {k + 2}" if self.fmt == "csv" else f"sample {k}"

    def iter_blocks(
        self, channels: Sequence[str | int], *, block: int = DEFAULT_BLOCK
    ) -> Iterator[tuple[int, dict[str, NDArray[np.float64]]]]:
        """Yield ``(start_sample, {name: samples})`` in order, in physical units, checked.

        Every sample must be finite; where the file has its own time axis (a CSV time column,
        a netCDF time coordinate, MDF4 time stamps) every step of it must be one sample
        interval. Anything wrong, and any failure of the format's library (a corrupted
        compressed chunk, a truncated file), raises :class:`~squealkit.InputError` naming the
        file, the channel and the sample (or CSV line). The time axis is read and checked
        until one pass has gone through the whole recording; later passes over the same
        source (an analysis with a tacho reads the file twice) skip it.

        Parameters
        ----------
        channels : sequence of str or int
            The channels to read (names or indices, see :meth:`resolve`).
        block : int, optional
            Samples per block (default 2**18, about 6.5 s at 40 kHz); the last block is shorter.

        Yields
        ------
        start_sample : int
            Index of the block's first sample.
        data : dict of str to ndarray
            Channel name -> samples (float64, physical units).
        """
        names = [self.resolve(c) for c in channels]
        block = validate_int("block", block, 1)
        spec = self._extra.get("time_axis")
        checked = self._extra.get("time_axis_checked", False)
        axis = _TimeAxis(self.path, spec[0], spec[1], self._where) if spec and not checked else None
        blocks = _block_reader(self.fmt)(self, names, int(block), axis is not None)
        done = 0
        while True:
            try:
                start, data = next(blocks)
            except StopIteration:
                break
            except InputError:
                raise
            except Exception as e:  # the format's library failed on the file: a damaged or truncated file
                raise _fail(self.path, f"could not be read after {self._where(done)}: {_library_error(e)}",
                            channel=names[0] if len(names) == 1 else None) from e
            out = {}
            for n in names:
                v = _as_samples(self.path, n, data[n])
                if n in self.scales:
                    v = v * self.scales[n]
                _check_finite(self.path, n, v, start, self._where)
                out[n] = v
            if axis is not None:
                axis.check(start, data[_TIME])
            done = start + len(out[names[0]]) if names else done
            yield start, out
        if names and done != self.n_samples:
            raise _fail(self.path, f"ends after {done} samples where {self.n_samples} were announced; the file "
                                   "looks truncated.")
        if names and axis is not None:
            self._extra["time_axis_checked"] = True  # every step of the whole axis passed


#: The module of each format's block reader (``blocks(src, names, block, with_time)``), imported when
#: first read: each yields ``(start, {name: values})`` and the time axis under ``_TIME``.
_FORMAT_MODULES = {"csv": "delimited", "wav": "wav", "netcdf": "netcdf", "tdms": "tdms", "mdf4": "mdf", "uff": "uff"}


def _block_reader(fmt: str) -> Callable[..., Iterator[tuple[int, dict[str, NDArray]]]]:
    """The block reader of format ``fmt`` (its module's ``blocks``)."""
    import importlib

    return importlib.import_module(f".{_FORMAT_MODULES[fmt]}", __package__).blocks

"""Results saved to and loaded from netCDF (``.nc``, h5netcdf) and zarr (``.zarr``), whole or a block at a time."""

from __future__ import annotations

import contextlib
import errno
import os
import re
from collections.abc import Iterable, Iterator
from pathlib import Path

import xarray as xr

from .. import _accessor  # noqa: F401  (registers ds.squeal.plot(), also on loaded results)
from .._validation import InputError, validate_dataset
from ._interrupts import deferred_interrupts
from ._ownership import _where
from ._staging import atomic_path

__all__ = ["load_dataset", "save_blocks", "save_dataset"]


_DATASET_SUFFIXES = {".nc": "h5netcdf", ".zarr": "zarr"}


def _engine_for(path: Path) -> str:
    engine = _DATASET_SUFFIXES.get(path.suffix.lower())
    if engine is None:
        raise InputError(
            f"Output {str(path)!r} has no known dataset suffix; use .nc (netCDF) or .zarr."
        )
    return engine


def save_dataset(ds: xr.Dataset, path: str | Path) -> Path:
    """Write ``ds`` to netCDF (``.nc``, h5netcdf) or zarr (``.zarr``), atomically.

    Parameters
    ----------
    ds : xarray.Dataset
        The dataset to write.
    path : path-like
        The output file (``.nc``) or store (``.zarr``, a folder); the suffix picks the
        format.

    Returns
    -------
    pathlib.Path
        ``path`` as a ``Path``.
    """
    final = Path(path)
    engine = _engine_for(final)
    with atomic_path(final, directory=engine == "zarr") as tmp, deferred_interrupts(), _hdf5_errors(tmp, final):
        if engine == "zarr":
            ds.to_zarr(tmp, mode="w", consolidated=False)
        else:
            _check_space(tmp, final, ds.nbytes)
            ds.to_netcdf(tmp, engine="h5netcdf")
    return final


def save_blocks(blocks: Iterable[xr.Dataset], path: str | Path, *, dim: str = "time") -> Path:
    """Write datasets that follow one another along ``dim`` to one file, a block at a time, atomically.

    The memory needed is that of one block, whatever the length: netCDF (``.nc``, h5netcdf)
    grows an unlimited ``dim``, zarr (``.zarr``) appends along it. Variables without ``dim``
    (a run's events) and the attributes are taken from the last block, which is how
    :func:`squealkit.transient.simulate_blocks` delivers them. The file is staged and moved
    into place only when the last block is written (:func:`atomic_path`); an error or an
    interrupt (SIGINT, SIGTERM) on the way leaves nothing behind.

    Parameters
    ----------
    blocks : iterable of xarray.Dataset
        Consecutive pieces of one dataset along ``dim``, all with the same variables on ``dim``.
    path : path-like
        The output file (``.nc``) or store (``.zarr``).
    dim : str
        The dimension the blocks follow one another along.

    Returns
    -------
    pathlib.Path
        ``path`` as a ``Path``.
    """
    final = Path(path)
    engine = _engine_for(final)
    with atomic_path(final, directory=engine == "zarr") as tmp, _hdf5_errors(tmp, final):
        last: xr.Dataset | None = None
        n = 0
        names: list[str] | None = None
        for i, block in enumerate(blocks):
            validate_dataset(block, f"block {i}")
            here = sorted(str(v) for v in block.data_vars if dim in block[v].dims)
            names = here if names is None else names
            if here != names:
                raise InputError(f"Cannot write {str(final)!r}: block {i} has the variables {here} along {dim!r}, "
                                 f"block 0 has {names}; every block needs the same ones.")
            along = block[[v for v in block.data_vars if dim in block[v].dims]]
            along = along.drop_vars([c for c in along.coords if dim not in along[c].dims])
            along.attrs = {}
            if engine != "zarr":
                _check_space(tmp, final, along.nbytes)
            with deferred_interrupts():
                n = _append_block(along, tmp, engine, dim, n)
            last = block
        if last is None:
            raise InputError(f"Nothing to write to {str(final)!r}: no blocks.")
        rest = last[[v for v in last.data_vars if dim not in last[v].dims]]
        rest = rest.drop_vars([c for c in rest.coords if dim in rest[c].dims])
        rest.attrs = dict(last.attrs)
        with deferred_interrupts():
            if engine == "zarr":
                rest.to_zarr(tmp, mode="a", consolidated=False)
            else:
                rest.to_netcdf(tmp, mode="a", engine="h5netcdf")
    return final


@contextlib.contextmanager
def _hdf5_errors(tmp: Path, final: Path) -> Iterator[None]:
    """A netCDF write that fails (a full disk): the OS's error, and no crash later.

    h5py reports a failed write when the file is closed (a ``RuntimeError`` or ``OSError``
    with HDF5's multi-line text) and leaves the file half-closed; h5netcdf's finaliser
    closes it again at some later garbage collection, which crashes the interpreter
    (SIGSEGV, exit 139). Here the failed file is closed once, for good, and an error
    carrying HDF5's ``errno = N`` becomes that one-line ``OSError`` on the output.
    """
    try:
        yield
    except Exception as e:
        _close_failed_hdf5(tmp)
        found = re.search(r"errno = (\d+)", str(e))
        if found is not None:
            code = int(found.group(1))
            raise OSError(code, os.strerror(code), str(final)) from None
        raise


def _check_space(tmp: Path, final: Path, nbytes: int) -> None:
    """ENOSPC now if the file system cannot take ``nbytes`` more (and HDF5's overhead).

    HDF5 meets a full disk in its cache, often while freeing objects, where the error
    cannot be raised (only printed) and the file is left broken; so a netCDF write is not
    started without the room for it.
    """
    try:
        st = os.statvfs(_where(tmp))
    except (OSError, AttributeError):  # pragma: no cover - not POSIX
        return
    free = st.f_bavail * st.f_frsize
    if free < 1.05 * nbytes + (1 << 20):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(final))


def _close_failed_hdf5(tmp: Path) -> None:
    """Mark the h5netcdf files still open on ``tmp`` closed, closing their HDF5 file once."""
    import gc
    import sys

    h5netcdf = sys.modules.get("h5netcdf")
    if h5netcdf is None:
        return
    target = os.path.abspath(tmp)
    for obj in gc.get_objects():
        if isinstance(obj, h5netcdf.File) and not getattr(obj, "_closed", True) \
                and os.path.abspath(str(getattr(obj, "_filename", ""))) == target:
            h5 = getattr(obj, "_File__h5file", None)
            obj._closed = True  # its __del__ (close) is a no-op from now on
            with contextlib.suppress(Exception):
                if h5 is not None:
                    h5.close()


def _append_block(block: xr.Dataset, tmp: Path, engine: str, dim: str, n: int) -> int:
    """Write one block at offset ``n`` along ``dim``; the new length."""
    k = block.sizes[dim]
    if n == 0:
        chunks = {v: max(k, 1) for v in block.variables}
        if engine == "zarr":
            block.to_zarr(tmp, mode="w", consolidated=False,
                          encoding={v: {"chunks": (chunks[v],)} for v in block.variables if block[v].ndim == 1})
        else:
            block.to_netcdf(tmp, engine="h5netcdf", unlimited_dims=[dim],
                            encoding={v: {"chunksizes": (chunks[v],)} for v in block.variables
                                      if block[v].ndim == 1})
        return k
    if engine == "zarr":
        block.to_zarr(tmp, append_dim=dim, consolidated=False)
    else:
        import h5netcdf

        with h5netcdf.File(tmp, "a") as f:
            f.resize_dimension(dim, n + k)
            for name, var in block.variables.items():
                index = tuple(slice(n, n + k) if d == dim else slice(None) for d in var.dims)
                f.variables[name][index] = var.values
    return n + k


def load_dataset(path: str | Path) -> xr.Dataset:
    """Load a dataset written by :func:`save_dataset` fully into memory.

    Parameters
    ----------
    path : path-like
        An existing netCDF file (``.nc``) or zarr store (``.zarr``).

    Returns
    -------
    xarray.Dataset
        The dataset, loaded; the file is closed.

    Raises
    ------
    InputError
        If the file does not exist or is not a readable netCDF file / zarr store (one line naming it).
    """
    p = Path(path)
    engine = _engine_for(p)
    if not p.exists():
        raise InputError(f"Dataset {str(p)!r} does not exist.")
    try:
        if engine == "zarr":
            with xr.open_zarr(p, consolidated=False) as ds:
                return ds.load()
        with xr.open_dataset(p, engine="h5netcdf") as ds:
            return ds.load()
    except (OSError, ValueError, KeyError, TypeError) as e:  # h5py, h5netcdf and zarr on a foreign or damaged file
        kind = "zarr store" if engine == "zarr" else "netCDF file"
        text = str(e).splitlines()[0] if str(e) else type(e).__name__
        raise InputError(f"Dataset {str(p)!r} is not a readable {kind}: {text}") from e

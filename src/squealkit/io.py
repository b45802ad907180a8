"""Saving and loading results: written completely or not at all.

Every file squealkit writes goes first to a temporary sibling and is moved into place only
when complete (``os.replace``), so an interrupted run or a failure never leaves a
half-written file over a good one.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import xarray as xr

from ._validation import InputError

__all__ = ["atomic_path", "load_dataset", "save_dataset", "save_figure", "write_text"]

_DATASET_SUFFIXES = {".nc": "h5netcdf", ".zarr": "zarr"}


@contextlib.contextmanager
def atomic_path(path: str | Path, *, directory: bool = False) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; move it onto ``path`` only on success.

    Parameters
    ----------
    path : path-like
        The final file (or directory, with ``directory=True``, e.g. a zarr store).
    directory : bool
        Whether the output is a directory tree.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "a.txt"
    >>> with atomic_path(out) as tmp:
    ...     _ = tmp.write_text("done")
    >>> out.read_text()
    'done'
    """
    final = Path(path)
    parent = final.parent if str(final.parent) else Path(".")
    if not parent.is_dir():
        raise InputError(f"Output folder {str(parent)!r} does not exist.")
    fd, tmp_name = tempfile.mkstemp(prefix=f".{final.name}.", suffix=".part", dir=parent)
    os.close(fd)
    tmp = Path(tmp_name)
    if directory:
        tmp.unlink()
    try:
        yield tmp
        if directory:
            backup = None
            if final.exists():
                backup = final.with_name(f".{final.name}.old-{os.getpid()}")
                final.rename(backup)
            tmp.rename(final)
            if backup is not None:
                shutil.rmtree(backup, ignore_errors=True)
        else:
            os.replace(tmp, final)
    except BaseException:
        if tmp.is_dir():
            shutil.rmtree(tmp, ignore_errors=True)
        else:
            tmp.unlink(missing_ok=True)
        raise


def _engine_for(path: Path) -> str:
    engine = _DATASET_SUFFIXES.get(path.suffix.lower())
    if engine is None:
        raise InputError(
            f"Output {str(path)!r} has no known dataset suffix; use .nc (netCDF) or .zarr."
        )
    return engine


def save_dataset(ds: xr.Dataset, path: str | Path) -> Path:
    """Write ``ds`` to netCDF (``.nc``, h5netcdf) or zarr (``.zarr``), atomically."""
    final = Path(path)
    engine = _engine_for(final)
    with atomic_path(final, directory=engine == "zarr") as tmp:
        if engine == "zarr":
            ds.to_zarr(tmp, mode="w", consolidated=False)
        else:
            ds.to_netcdf(tmp, engine="h5netcdf")
    return final


def load_dataset(path: str | Path) -> xr.Dataset:
    """Load a dataset written by :func:`save_dataset` fully into memory."""
    p = Path(path)
    engine = _engine_for(p)
    if not p.exists():
        raise InputError(f"Dataset {str(p)!r} does not exist.")
    if engine == "zarr":
        with xr.open_zarr(p, consolidated=False) as ds:
            return ds.load()
    with xr.open_dataset(p, engine="h5netcdf") as ds:
        return ds.load()


def save_figure(fig: Any, path: str | Path, **kwargs: Any) -> Path:
    """Save a matplotlib figure atomically; the format follows the suffix (.png, .svg, .pdf)."""
    final = Path(path)
    fmt = final.suffix.lstrip(".").lower()
    if fmt not in {"png", "svg", "pdf", "jpg", "jpeg"}:
        raise InputError(f"Figure {str(final)!r} needs a .png, .svg, .pdf or .jpg suffix.")
    kwargs.setdefault("dpi", 150)
    kwargs.setdefault("bbox_inches", "tight")
    with atomic_path(final) as tmp:
        fig.savefig(tmp, format=fmt, **kwargs)
    return final


def write_text(path: str | Path, text: str) -> Path:
    """Write a text file (JSON, CSV, HTML) atomically."""
    final = Path(path)
    with atomic_path(final) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return final

"""Saving and loading results: written completely or not at all, and nothing else touched.

Every file squealkit writes goes first to a temporary sibling and is moved into place only
when complete (``os.replace``), so an interrupted run or a failure never leaves a
half-written file over a good one. A new file gets the permissions the umask gives; an
overwritten one keeps its own. Folders squealkit writes (reports, zarr stores) carry a
manifest of their files, and a folder holding files squealkit did not write is never
replaced or emptied: see :func:`output_folder`.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import tempfile
import threading
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

import xarray as xr

from . import _accessor  # noqa: F401  (registers ds.squeal.plot(), also on loaded results)
from ._validation import InputError, validate_dataset

__all__ = ["atomic_path", "check_output", "load_dataset", "output_folder", "save_blocks", "save_dataset",
           "save_figure", "write_text"]

_DATASET_SUFFIXES = {".nc": "h5netcdf", ".zarr": "zarr"}
#: Written into every folder squealkit fills: the files it wrote there.
MANIFEST = ".squealkit-manifest.json"
_ZARR_MARKERS = (".zgroup", ".zarray", "zarr.json")
_umask_lock = threading.Lock()
#: Set by the CLI's signal handlers (:func:`note_interrupt`): an interrupt arrived, even if
#: a library caught the exception, so no staged output may be moved into place.
_interrupted = threading.Event()


_state = {"deferred": 0, "signal": None}


def note_interrupt(signum: int | None = None) -> None:
    """Record that the run was interrupted (SIGINT/SIGTERM): staged outputs are discarded."""
    _state["signal"] = signum
    _interrupted.set()


def interrupt_signal() -> int | None:
    """The signal that interrupted the run, if one did."""
    return _state["signal"] if _interrupted.is_set() else None


def interrupts_deferred() -> bool:
    """Whether a library write is in progress (see :func:`deferred_interrupts`)."""
    return _state["deferred"] > 0


@contextlib.contextmanager
def deferred_interrupts() -> Iterator[None]:
    """Hold an interrupt until the library write inside has returned, then raise it.

    Writers such as zarr's work in background threads: interrupted mid-write, they would
    go on writing into the staging folder after it was removed. The CLI's signal handlers
    only record the signal while this is active (one write of one output, or one piece of
    a streamed result), and the run stops right after it, cleaning up as always.
    """
    _state["deferred"] += 1
    try:
        yield
    finally:
        _state["deferred"] -= 1
    _check_not_interrupted()


def _check_not_interrupted() -> None:
    if _interrupted.is_set():
        raise KeyboardInterrupt


def _umask() -> int:
    with _umask_lock:
        mask = os.umask(0o022)
        os.umask(mask)
    return mask


def _final_mode(final: Path, directory: bool) -> int:
    """An overwritten output keeps its permissions; a new one gets those the umask gives."""
    try:
        return final.stat().st_mode & 0o7777
    except OSError:
        return (0o777 if directory else 0o666) & ~_umask()


def _where(path: Path) -> Path:
    return path.parent if str(path.parent) else Path(".")


def _owned_folder(folder: Path) -> tuple[bool, list[str]]:
    """(squealkit's, foreign files) of an existing folder: empty, a zarr store, or listed
    in squealkit's manifest."""
    names = sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*") if not p.is_dir())
    if not names or any((folder / m).exists() for m in _ZARR_MARKERS):
        return True, []
    listed = set(_read_manifest(folder)) | {MANIFEST}
    foreign = [n for n in names if n not in listed]
    return not foreign, foreign


def _read_manifest(folder: Path) -> list[str]:
    try:
        doc = json.loads((folder / MANIFEST).read_text(encoding="utf-8"))
        return [str(x) for x in doc.get("files", [])]
    except (OSError, ValueError, AttributeError):
        return []


def check_output(path: str | Path, *, directory: bool = False, force: bool = False) -> Path:
    """Check, before any work, that ``path`` can be written; one-line ``InputError`` if not.

    The folder must exist and take a new file (tried for real, so permissions, read-only
    file systems and full quotas show up now, not after the computation); a file output
    must not name a folder, a folder output not a file; an existing folder must hold only
    what squealkit wrote there (its manifest, or a zarr store), unless ``force``.

    Parameters
    ----------
    path : path-like
        The output file, or folder with ``directory=True``.
    directory : bool
        Whether the output is a folder (a report, a zarr store).
    force : bool
        Accept an existing folder holding files squealkit did not write (they are left
        alone).

    Returns
    -------
    pathlib.Path
        ``path`` as a ``Path``.
    """
    final = Path(path)
    parent = _where(final)
    if not parent.is_dir():
        raise InputError(f"Output folder {str(parent)!r} does not exist.")
    if final.is_dir() and not directory:
        raise InputError(f"Output {str(final)!r} is a folder; give a file name.")
    if final.exists() and not final.is_dir() and directory:
        raise InputError(f"Output {str(final)!r} is a file; give a folder name.")
    if directory and final.is_dir() and not force:
        ok, foreign = _owned_folder(final)
        if not ok:
            shown = ", ".join(foreign[:3]) + (f" and {len(foreign) - 3} more" if len(foreign) > 3 else "")
            raise InputError(
                f"Output folder {str(final)!r} holds files squealkit did not write ({shown}); choose a new "
                "or empty folder, or pass --force to write beside them (they are never deleted).")
    probe_dir = final if directory and final.is_dir() else parent
    try:
        fd, probe = tempfile.mkstemp(prefix=".squealkit-probe.", dir=probe_dir)
        os.close(fd)
        os.unlink(probe)
    except OSError as e:
        raise InputError(f"Cannot write in {str(probe_dir)!r}: {e.strerror or e}.") from e
    return final


@contextlib.contextmanager
def atomic_path(path: str | Path, *, directory: bool = False) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; move it onto ``path`` only on success.

    Parameters
    ----------
    path : path-like
        The final file (or directory, with ``directory=True``, e.g. a zarr store).
    directory : bool
        Whether the output is a directory tree.

    Yields
    ------
    Path
        The staging path to write to (in ``path``'s folder); it replaces ``path`` when the
        block ends without an exception and is removed otherwise.

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
    parent = _where(final)
    if not parent.is_dir():
        raise InputError(f"Output folder {str(parent)!r} does not exist.")
    if directory and final.is_dir() and not _owned_folder(final)[0]:
        raise InputError(f"Output folder {str(final)!r} holds files squealkit did not write; it is not replaced.")
    tmp: Path | None = None
    try:
        # an interrupt while the stage is set up, or while it is moved into place, is held
        # until that step is whole (then raised here, and the stage removed below)
        with deferred_interrupts():
            fd, tmp_name = tempfile.mkstemp(prefix=f".{final.name}.", suffix=".part", dir=parent)
            tmp = Path(tmp_name)
            os.close(fd)
            if directory:
                tmp.unlink()
        yield tmp
        _check_not_interrupted()
        with deferred_interrupts():
            mode = _final_mode(final, directory)
            if directory:
                tmp.chmod(mode)
                backup = None
                if final.exists():
                    backup = final.with_name(f".{final.name}.old-{os.getpid()}")
                    final.rename(backup)
                tmp.rename(final)
                if backup is not None:
                    shutil.rmtree(backup, ignore_errors=True)
            else:
                tmp.chmod(mode)
                os.replace(tmp, final)
    except BaseException:
        if tmp is not None:
            if tmp.is_dir():
                shutil.rmtree(tmp, ignore_errors=True)
            else:
                tmp.unlink(missing_ok=True)
        raise


@contextlib.contextmanager
def output_folder(path: str | Path, *, force: bool = False) -> Iterator[Path]:
    """Yield a staging folder; on success its files land in ``path``, listed in a manifest.

    A new folder, an empty one or one squealkit filled before is replaced as a whole (the
    files of the previous run that this run does not write go with it). With ``force`` a
    folder holding other files (even ``.``) gets the new files one by one, each moved into
    place complete; its other files are left alone. On failure or interrupt nothing
    changes.

    Parameters
    ----------
    path : path-like
        The output folder; its parent must exist.
    force : bool
        Write into an existing folder that holds files squealkit did not write (see
        :func:`check_output`).

    Yields
    ------
    pathlib.Path
        The staging folder to write the files into.
    """
    final = Path(path)
    check_output(final, directory=True, force=force)
    if final.is_dir() and not _owned_folder(final)[0]:
        stage: Path | None = None
        try:
            with deferred_interrupts():
                stage = Path(tempfile.mkdtemp(prefix=".squealkit-stage.", dir=final))
            yield stage
            _check_not_interrupted()
            files = sorted(p.relative_to(stage).as_posix() for p in stage.rglob("*") if not p.is_dir())
            with deferred_interrupts():  # every file moved whole, the manifest last
                _write_manifest(stage, files)
                for name in [*files, MANIFEST]:
                    (final / name).parent.mkdir(parents=True, exist_ok=True)
                    os.replace(stage / name, final / name)
        finally:
            if stage is not None:
                shutil.rmtree(stage, ignore_errors=True)
        return
    with atomic_path(final, directory=True) as stage:
        stage.mkdir()
        yield stage
        _check_not_interrupted()
        _write_manifest(stage, sorted(p.relative_to(stage).as_posix() for p in stage.rglob("*") if not p.is_dir()))


def _write_manifest(folder: Path, files: list[str]) -> None:
    from . import __version__

    doc = {"written_by": f"squealkit {__version__}", "files": files}
    (folder / MANIFEST).write_text(json.dumps(doc, indent=1), encoding="utf-8")


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
    with atomic_path(final, directory=engine == "zarr") as tmp, deferred_interrupts():
        if engine == "zarr":
            ds.to_zarr(tmp, mode="w", consolidated=False)
        else:
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
    with atomic_path(final, directory=engine == "zarr") as tmp:
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


def save_figure(fig: Any, path: str | Path, **kwargs: Any) -> Path:
    """Save a matplotlib figure atomically; the format follows the suffix (.png, .svg, .pdf).

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure to save.
    path : path-like
        The output file, ending in ``.png``, ``.svg``, ``.pdf``, ``.jpg`` or ``.jpeg``.
    **kwargs
        Passed on to ``fig.savefig``; ``dpi`` defaults to 150 and ``bbox_inches`` to
        ``"tight"``.

    Returns
    -------
    pathlib.Path
        ``path`` as a ``Path``.
    """
    final = Path(path)
    fmt = final.suffix.lstrip(".").lower()
    if fmt not in {"png", "svg", "pdf", "jpg", "jpeg"}:
        raise InputError(f"Figure {str(final)!r} needs a .png, .svg, .pdf or .jpg suffix.")
    kwargs.setdefault("dpi", 150)
    kwargs.setdefault("bbox_inches", "tight")
    with atomic_path(final) as tmp, deferred_interrupts():
        fig.savefig(tmp, format=fmt, **kwargs)
    return final


def write_text(path: str | Path, text: str) -> Path:
    """Write a text file (JSON, CSV, HTML) atomically.

    Parameters
    ----------
    path : path-like
        The output file.
    text : str
        The content, written as UTF-8.

    Returns
    -------
    pathlib.Path
        ``path`` as a ``Path``.
    """
    final = Path(path)
    with atomic_path(final) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return final

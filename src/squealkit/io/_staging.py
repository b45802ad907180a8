"""Saving and loading results: written completely or not at all, and nothing else touched.

Every file squealkit writes goes first to a temporary sibling and is moved into place only
when complete (``os.replace``), so an interrupted run or a failure never leaves a
half-written file over a good one; the CLI moves all outputs of one run together at its end
(:func:`outputs_together`). A new file gets the permissions the umask gives; an overwritten
one keeps its own. Folders squealkit writes (reports, zarr stores, campaigns) carry a
manifest of their files, and only a manifest makes a file or folder squealkit's: a folder
holding other files is never replaced or emptied (:func:`output_folder`), and a device, a
fifo or a socket is never replaced. While a run writes an output it holds a lock beside it,
so a second run writing the same output is refused in one line.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import re
import shutil
import stat
import tempfile
import threading
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

import xarray as xr

try:
    import fcntl
except ImportError:  # pragma: no cover - not POSIX: outputs are not locked
    fcntl = None  # type: ignore[assignment]

from .. import _accessor  # noqa: F401  (registers ds.squeal.plot(), also on loaded results)
from .._validation import InputError, validate_dataset

__all__ = ["atomic_path", "check_output", "load_dataset", "output_folder", "outputs_together", "save_blocks",
           "save_dataset", "save_figure", "write_text", "written_path"]

_DATASET_SUFFIXES = {".nc": "h5netcdf", ".zarr": "zarr"}
#: Written into every folder squealkit fills (reports, zarr stores, campaigns): the files it
#: wrote there. A folder, or a file in one, is squealkit's only if a manifest lists it.
MANIFEST = ".squealkit-manifest.json"
#: The manifest of a zarr store: a hidden zarr group whose attributes list the files (zarr
#: warns about any other file it finds in a store; a group it reads, and xarray ignores).
ZARR_MANIFEST = ".squealkit/zarr.json"
_MANIFESTS = (MANIFEST, ZARR_MANIFEST)
#: Staging folders inside an output folder that stays (see :func:`output_folder`).
_STAGE_PREFIX = ".squealkit-stage."
#: Beside an output while a run writes it: the lock that keeps a second run out.
_LOCK_SUFFIX = ".squealkit-lock"
#: The names :func:`tempfile.mkstemp` gives staged outputs (``.NAME.XXXXXXXX.part``).
_STAGED_NAME = re.compile(r"^\..+\.[a-z0-9_]{8}\.part$")
_umask_lock = threading.Lock()
#: Set by the CLI's signal handlers (:func:`note_interrupt`): an interrupt arrived, even if
#: a library caught the exception, so no staged output may be moved into place.
_interrupted = threading.Event()


_state: dict[str, Any] = {"deferred": 0, "signal": None}
#: This process's staging paths still in use: an output below one is part of it and is
#: committed with it (its own move is immediate, unlocked).
_stages: set[Path] = set()
#: Output -> [file descriptor, holders, lock file] of the locks this process holds.
_locks: dict[Path, list[Any]] = {}
#: The outputs of the run under way (:func:`outputs_together`): staged, committed at its end.
_run: dict[str, Any] = {"pending": None, "locks": []}


def note_interrupt(signum: int | None = None) -> None:
    """Record that the run was interrupted (a signal): staged outputs are discarded."""
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


def _resolve(path: str | Path) -> Path:
    """The output ``path`` names: a symbolic link stands for what it points to, which is
    written (staged beside it), the link kept."""
    p = Path(path)
    return Path(os.path.realpath(p)) if p.is_symlink() else p


def _kind(path: Path) -> str | None:
    """What stands at ``path``: None (nothing), ``"file"``, ``"folder"``, or what else it is."""
    try:
        mode = os.stat(path).st_mode
    except (FileNotFoundError, NotADirectoryError):
        return None
    if stat.S_ISREG(mode):
        return "file"
    if stat.S_ISDIR(mode):
        return "folder"
    return {stat.S_IFCHR: "a character device", stat.S_IFBLK: "a block device", stat.S_IFIFO: "a named pipe (fifo)",
            stat.S_IFSOCK: "a socket"}.get(stat.S_IFMT(mode), "not a regular file")


def final_name(path: str) -> str:
    """``path`` with squealkit's staging names replaced by the outputs they stand for (for
    messages: an error while writing a staged file names the output the user asked for)."""
    path = re.sub(r"(^|/)\.([^/]+)\.[a-z0-9_]{8}\.part(?=/|$)", r"\1\2", path)
    return re.sub(r"/" + re.escape(_STAGE_PREFIX) + r"[a-z0-9_]{8}(?=/|$)", "", path)


def _transient(name: str) -> bool:
    """A name squealkit gives its staged outputs and locks (left only by a killed run)."""
    base = name.rsplit("/", 1)[-1]
    return bool(_STAGED_NAME.match(base)) or base.endswith(_LOCK_SUFFIX) or base.startswith(".squealkit-probe.")


def _folder_files(folder: Path) -> tuple[list[str], set[str]]:
    """(every file below ``folder``, those squealkit's manifests list), relative posix names.

    A manifest lists the files of its own folder and below, so a squealkit output inside
    another one (a campaign's results in its recordings' folder) counts as squealkit's too.
    Symbolic links are entries, never followed.
    """
    names: list[str] = []
    listed: set[str] = set()
    for root, dirs, files in os.walk(folder):
        here = Path(root)
        rel = here.relative_to(folder)
        links = [d for d in dirs if (here / d).is_symlink()]
        dirs[:] = [d for d in dirs if d not in links and not d.startswith(_STAGE_PREFIX)]
        if MANIFEST in files or ".squealkit" in dirs:
            listed |= {(rel / n).as_posix() for n in [*_read_manifest(here), *_MANIFESTS]}
        names += [(rel / n).as_posix() for n in [*files, *links]]
    return names, listed


def _owned_folder(folder: Path) -> tuple[bool, list[str]]:
    """(squealkit's, foreign files) of an existing folder: empty, or every file in it listed
    in a squealkit manifest. A zarr store, or any other marker, does not make it squealkit's."""
    names, listed = _folder_files(folder)
    foreign = sorted(n for n in names if n not in listed and not _transient(n))
    return not foreign, foreign


def _read_manifest(folder: Path) -> list[str]:
    """The files squealkit's manifest in ``folder`` lists (none without one)."""
    for name in _MANIFESTS:
        try:
            doc = json.loads((folder / name).read_text(encoding="utf-8"))
            if name == ZARR_MANIFEST:
                doc = doc["attributes"]
            return [str(x) for x in doc["files"]]
        except (OSError, ValueError, AttributeError, KeyError, TypeError):
            continue
    return []


def _shown(names: list[str]) -> str:
    return ", ".join(names[:3]) + (f" and {len(names) - 3} more" if len(names) > 3 else "")


def _refuse_replacing(final: Path, directory: bool, *, force: bool = False) -> None:
    """One-line ``InputError`` if writing ``final`` would replace what squealkit did not write:
    anything but a regular file or folder (a device, a fifo, a socket), a file by a folder or
    a folder by a file, a folder holding files no squealkit manifest lists (unless ``force``)."""
    kind = _kind(final)
    if kind is None:
        return
    if kind not in ("file", "folder"):
        raise InputError(f"Output {str(final)!r} is {kind}, not a regular file; squealkit never replaces it.")
    if kind == "folder" and not directory:
        raise InputError(f"Output {str(final)!r} is a folder; give a file name.")
    if kind == "file" and directory:
        raise InputError(f"Output {str(final)!r} is a file; give a folder name (squealkit never replaces a file "
                         "by a folder).")
    if kind == "folder" and not force:
        ok, foreign = _owned_folder(final)
        if not ok:
            raise InputError(
                f"Output folder {str(final)!r} holds files squealkit did not write ({_shown(foreign)}); choose a "
                "new or empty folder, or pass --force to write beside them (they are never deleted).")


def _foreign_among(final: Path, names: Iterable[str]) -> list[str]:
    """Those of ``names`` (files or folders in ``final``) that are, or hold, files squealkit did not write."""
    if not final.is_dir():
        return []
    every, listed = _folder_files(final)
    out = []
    for name in names:
        inside = [n for n in every if n == name or n.startswith(name.rstrip("/") + "/")]
        out += [n for n in inside if n not in listed and not _transient(n)]
    return sorted(set(out))


def check_output(path: str | Path, *, directory: bool = False, force: bool = False,
                 names: Iterable[str] = ()) -> Path:
    """Check, before any work, that ``path`` can be written; one-line ``InputError`` if not.

    The folder must exist and take a new file (tried for real, so permissions, read-only
    file systems and full quotas show up now, not after the computation); a file output
    must not name a folder, a folder output not a file, and neither a device, a fifo or a
    socket; an existing folder must hold only what squealkit wrote there (files its
    manifest lists), unless ``force``. A symbolic link is followed: what it points to is
    written. Inside :func:`outputs_together` the output is also locked for the run: a
    second squealkit run writing it is refused.

    Parameters
    ----------
    path : path-like
        The output file, or folder with ``directory=True``.
    directory : bool
        Whether the output is a folder (a report, a zarr store).
    force : bool
        Accept an existing folder holding files squealkit did not write (they are left
        alone).
    names : iterable of str
        Files or folders the run writes in the folder: with ``force``, one that is (or
        holds) a file squealkit did not write is refused now, as it would be at the end.

    Returns
    -------
    pathlib.Path
        ``path`` as a ``Path`` (what it points to, for a symbolic link).
    """
    final = _resolve(path)
    parent = _where(final)
    if not parent.is_dir():
        raise InputError(f"Output folder {str(parent)!r} does not exist.")
    _refuse_replacing(final, directory, force=force)
    clash = _foreign_among(final, names) if directory and force else []
    if clash:
        raise InputError(_clash_message(final, clash))
    probe_dir = final if directory and final.is_dir() else parent
    try:
        fd, probe = tempfile.mkstemp(prefix=".squealkit-probe.", dir=probe_dir)
        os.close(fd)
        os.unlink(probe)
    except OSError as e:
        raise InputError(f"Cannot write in {str(probe_dir)!r}: {e.strerror or e}.") from e
    if _run["pending"] is not None and not _inside_stage(final):
        _lock(final)
        _run["locks"].append(final)
    return final


def _clash_message(final: Path, clash: list[str]) -> str:
    return (f"Output folder {str(final)!r} holds your own {_shown(clash)}; squealkit does not replace them, even "
            "with --force: move them or choose another folder.")


def _inside_stage(path: Path) -> bool:
    p = path.absolute()
    return any(s in p.parents for s in _stages)


def _lock(final: Path) -> None:
    """Hold ``final`` for this process: a second squealkit run writing it gets a one-line refusal.

    An advisory lock (``flock``) on a file beside the output, removed when released; a lock
    file left by a killed run is not held, so it is taken over.
    """
    key = final.absolute()
    held = _locks.get(key)
    if held is not None:
        held[1] += 1
        return
    if fcntl is None:  # pragma: no cover - not POSIX
        _locks[key] = [None, 1, None]
        return
    path = key.parent / f".{key.name}{_LOCK_SUFFIX}"
    for _ in range(5):
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as e:
            os.close(fd)
            if e.errno in (errno.EAGAIN, errno.EACCES, errno.EWOULDBLOCK):
                raise InputError(f"Output {str(final)!r} is being written by another squealkit run; wait until it "
                                 "has finished or choose another name.") from None
            raise
        try:
            current = os.stat(path).st_ino
        except FileNotFoundError:
            current = None
        if current == os.fstat(fd).st_ino:  # not removed by its last holder meanwhile
            _locks[key] = [fd, 1, path]
            return
        os.close(fd)
    raise InputError(f"Output {str(final)!r} is being written by another squealkit run; wait until it has finished "
                     "or choose another name.")


def _unlock(final: Path) -> None:
    key = final.absolute()
    held = _locks.get(key)
    if held is None:
        return
    held[1] -= 1
    if held[1] > 0:
        return
    del _locks[key]
    fd, _, path = held
    if fd is not None:
        with contextlib.suppress(OSError):
            os.unlink(path)
        os.close(fd)


def _files_below(folder: Path) -> list[str]:
    """Every file below ``folder`` but its own manifest, relative posix names."""
    names = (p.relative_to(folder).as_posix() for p in folder.rglob("*") if not p.is_dir())
    return sorted(n for n in names if n not in _MANIFESTS)


class _Staged:
    """A staged output and how it is moved into place (whole) or discarded."""

    def __init__(self, final: Path, tmp: Path, directory: bool):
        self.final, self.tmp, self.directory = final, tmp, directory

    def check(self) -> None:
        _refuse_replacing(self.final, self.directory)  # what stands there now (the run took a while)

    def commit(self) -> None:
        final, tmp = self.final, self.tmp
        mode = _final_mode(final, self.directory)
        tmp.chmod(mode)
        if not self.directory:
            os.replace(tmp, final)
            return
        _write_manifest(tmp, _files_below(tmp))  # a folder squealkit wrote says so
        backup = None
        if final.exists():
            backup = Path(tempfile.mkdtemp(prefix=f".{final.name}.", suffix=".part", dir=_where(final)))
            os.rename(final, backup / "old")
        tmp.rename(final)
        if backup is not None:
            shutil.rmtree(backup, ignore_errors=True)

    def discard(self) -> None:
        _remove(self.tmp)


class _Merged:
    """A staging folder inside an output folder that stays: its files are moved in one by one."""

    def __init__(self, final: Path, stage: Path, keep: tuple[str, ...]):
        self.final, self.stage, self.keep = final, stage, keep

    def check(self) -> None:
        new = _files_below(self.stage)
        listed = set(_read_manifest(self.final))
        clash = [n for n in new if os.path.lexists(self.final / n) and n not in listed]
        clash += [n for n in new for p in Path(n).parents if str(p) != "." and (self.final / p).exists()
                  and not (self.final / p).is_dir()]
        if clash:
            raise InputError(_clash_message(self.final, sorted(set(clash))))

    def commit(self) -> None:
        final, stage = self.final, self.stage
        new = _files_below(stage)
        old = set(_read_manifest(final))
        # listed first: a file moved in is squealkit's even if the run is killed half way
        _write_manifest(final, sorted(old | set(new) | set(self.keep)))
        for name in new:
            (final / name).parent.mkdir(parents=True, exist_ok=True)
            os.replace(stage / name, final / name)
        stale = old - set(new) - set(self.keep) - set(_MANIFESTS)
        for name in sorted(stale):  # what an earlier run wrote and this one did not: squealkit's, outdated
            with contextlib.suppress(OSError):
                if not (final / name).is_dir():
                    (final / name).unlink()
                for folder in Path(name).parents[:-1]:  # and the folders it leaves empty
                    (final / folder).rmdir()
        _write_manifest(final, sorted(set(new) | set(self.keep) | {n for n in stale if os.path.lexists(final / n)}))
        shutil.rmtree(stage, ignore_errors=True)

    def discard(self) -> None:
        _remove(self.stage)


def _remove(path: Path | None) -> None:
    if path is None:
        return
    _stages.discard(path.absolute())
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        with contextlib.suppress(OSError):
            path.unlink()


@contextlib.contextmanager
def outputs_together() -> Iterator[None]:
    """Stage every output written inside; move them all into place at the end, or none.

    The CLI runs each command inside it, so that a run's outputs (a result, its figures, a
    summary) appear together or not at all, whatever ends the run (an error, Ctrl-C,
    SIGTERM, SIGHUP, SIGQUIT). Each output is locked from its check (:func:`check_output`)
    or first write to the end: a second squealkit run writing it is refused in one line.
    Inside, :func:`written_path` tells where an output written so far can be read.

    Yields
    ------
    None
        Write outputs inside (:func:`save_dataset`, :func:`save_figure`, :func:`write_text`,
        :func:`output_folder`...); nested uses commit with the outermost.
    """
    if _run["pending"] is not None:  # the outer one commits
        yield
        return
    _run["pending"], _run["locks"] = [], []
    try:
        yield
        _check_not_interrupted()
        pending = _run["pending"]
        with deferred_interrupts():  # checked all, then moved all: a refusal moves none
            for item in pending:
                item.check()
            for item in pending:
                item.commit()
    finally:
        pending, locks = _run["pending"], _run["locks"]
        _run["pending"], _run["locks"] = None, []
        for item in pending:
            item.discard()
        for final in locks:
            _unlock(final)


def written_path(path: str | Path) -> Path:
    """Where the output ``path`` can be read now.

    Parameters
    ----------
    path : path-like
        An output written in this run.

    Returns
    -------
    pathlib.Path
        Its staged copy while the run's outputs wait to be moved into place together
        (:func:`outputs_together`), else ``path`` itself.
    """
    final = _resolve(path)
    for item in reversed(_run["pending"] or []):
        if isinstance(item, _Staged) and item.final.absolute() == final.absolute():
            return item.tmp
    return final


def _commit_or_defer(item: _Staged | _Merged, nested: bool, final: Path) -> bool:
    """Move ``item`` into place now, or at the end of the run; True if deferred (the run
    then owns its lock and staging)."""
    if _run["pending"] is not None and not nested:
        _run["pending"].append(item)
        _run["locks"].append(final)
        return True
    with deferred_interrupts():
        item.check()
        item.commit()
    return False


@contextlib.contextmanager
def atomic_path(path: str | Path, *, directory: bool = False) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; move it onto ``path`` only on success.

    ``path`` may be a new name, a regular file (replaced) or, with ``directory=True``, a
    folder squealkit wrote (its manifest lists every file in it; replaced whole). Anything
    else (a device, a fifo, a socket, a file where a folder goes or the reverse, a folder
    holding other files) is refused with an ``InputError`` before anything is written. A
    symbolic link is followed: what it points to is replaced, the link stays. While the
    output is staged it is locked: a second squealkit run writing it is refused. Inside
    :func:`outputs_together` the move waits for the run's end.

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
    final = _resolve(path)
    parent = _where(final)
    if not parent.is_dir():
        raise InputError(f"Output folder {str(parent)!r} does not exist.")
    nested = _inside_stage(final)  # part of a staged folder: moved with it
    if not nested:
        _refuse_replacing(final, directory)
    tmp: Path | None = None
    locked = deferred = False
    try:
        # an interrupt while the stage is set up, or while it is moved into place, is held
        # until that step is whole (then raised here, and the stage removed below)
        with deferred_interrupts():
            if not nested:
                _lock(final)
                locked = True
            fd, tmp_name = tempfile.mkstemp(prefix=f".{final.name}.", suffix=".part", dir=parent)
            tmp = Path(tmp_name)
            os.close(fd)
            if directory:
                tmp.unlink()
                _stages.add(tmp.absolute())
        yield tmp
        _check_not_interrupted()
        deferred = _commit_or_defer(_Staged(final, tmp, directory), nested, final)
    except BaseException:
        _remove(tmp)
        raise
    finally:
        if not deferred:
            if tmp is not None:
                _stages.discard(tmp.absolute())
            if locked:
                _unlock(final)


@contextlib.contextmanager
def output_folder(path: str | Path, *, force: bool = False, keep: Iterable[str] = ()) -> Iterator[Path]:
    """Yield a staging folder; on success its files land in ``path``, listed in a manifest.

    A new folder, an empty one or one squealkit filled before is replaced as a whole (the
    files of the previous run that this run does not write go with it). With ``force`` a
    folder holding other files (even ``.``) gets the new files one by one, each moved into
    place complete; its other files are left alone, and one of them named as a new file is
    never replaced (the run is refused). With ``keep`` the folder stays (a campaign's
    database, updated in place): the names in ``keep`` are listed in its manifest at once,
    and the new files are moved in beside them. On failure or interrupt nothing changes.

    Parameters
    ----------
    path : path-like
        The output folder; its parent must exist.
    force : bool
        Write into an existing folder that holds files squealkit did not write (see
        :func:`check_output`).
    keep : iterable of str
        Files the caller keeps in the folder itself, across runs.

    Yields
    ------
    pathlib.Path
        The staging folder to write the files into.
    """
    keep = tuple(keep)
    final = check_output(path, directory=True, force=force)
    for name in keep:  # a kept file of the wrong kind is refused before the folder is claimed
        kind = _kind(final / name)
        if kind not in (None, "file"):
            raise InputError(f"{str(final / name)!r} is {'a ' if kind == 'folder' else ''}{kind}, not a regular file; "
                             "squealkit never replaces it.")
    if not keep and not (final.is_dir() and not _owned_folder(final)[0]) and final.name not in ("", ".", ".."):
        with atomic_path(final, directory=True) as stage:
            stage.mkdir()
            yield stage
        return
    nested = _inside_stage(final)
    stage: Path | None = None
    locked = deferred = False
    try:
        with deferred_interrupts():
            if not nested:
                _lock(final)
                locked = True
            final.mkdir(exist_ok=True)
            if keep:  # squealkit's from the start: a killed run's database is resumed, not refused
                _write_manifest(final, sorted(set(_read_manifest(final)) | set(keep)))
            stage = Path(tempfile.mkdtemp(prefix=_STAGE_PREFIX, dir=final))
            _stages.add(stage.absolute())
        yield stage
        _check_not_interrupted()
        deferred = _commit_or_defer(_Merged(final, stage, keep), nested, final)
    except BaseException:
        _remove(stage)
        raise
    finally:
        if not deferred:
            _remove(stage)
            if locked:
                _unlock(final)


def _write_manifest(folder: Path, files: list[str]) -> None:
    """List ``files`` as squealkit's in ``folder`` (replacing its manifest whole)."""
    from .. import __version__

    doc: dict[str, Any] = {"written_by": f"squealkit {__version__}", "files": [f for f in files if f not in _MANIFESTS]}
    name = MANIFEST
    if any((folder / m).is_file() for m in ("zarr.json", ".zgroup")):  # a zarr store squealkit wrote
        name = ZARR_MANIFEST
        (folder / ".squealkit").mkdir(exist_ok=True)
        doc = {"zarr_format": 3, "node_type": "group", "attributes": doc}
    part = folder / f".{Path(name).name}.{os.getpid()}.part"
    part = part if name == MANIFEST else folder / ".squealkit" / part.name
    part.write_text(json.dumps(doc, indent=1), encoding="utf-8")
    os.replace(part, folder / name)


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

"""Every output staged beside its final name and moved into place whole, or not at all.

A file or folder is written to a temporary sibling and moved into place only when complete
(:func:`atomic_path`, :func:`output_folder`); the CLI moves all outputs of one run together at its
end (:func:`outputs_together`). A new output gets the permissions the umask gives; an overwritten
one keeps its own. While a run writes an output it holds a lock beside it (``_locks``).
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
import threading
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

from .._validation import InputError
from ._interrupts import _check_not_interrupted, deferred_interrupts
from ._locks import _lock, _unlock
from ._ownership import (
    _MANIFESTS,
    _STAGE_PREFIX,
    _clash_message,
    _files_below,
    _foreign_among,
    _kind,
    _owned_folder,
    _read_manifest,
    _refuse_replacing,
    _resolve,
    _where,
    _write_manifest,
)

__all__ = ["atomic_path", "check_output", "output_folder", "outputs_together", "written_path"]


_umask_lock = threading.Lock()


#: This process's staging paths still in use: an output below one is part of it and is
#: committed with it (its own move is immediate, unlocked).
_stages: set[Path] = set()


#: The outputs of the run under way (:func:`outputs_together`): staged, committed at its end.
_run: dict[str, Any] = {"pending": None, "locks": []}


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


def _inside_stage(path: Path) -> bool:
    p = path.absolute()
    return any(s in p.parents for s in _stages)


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

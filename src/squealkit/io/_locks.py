"""The lock beside an output while a run writes it: a second squealkit run writing the same output is refused."""

from __future__ import annotations

import contextlib
import errno
import os
from pathlib import Path
from typing import Any

try:
    import fcntl
except ImportError:  # pragma: no cover - not POSIX: outputs are not locked
    fcntl = None  # type: ignore[assignment]

from .._validation import InputError
from ._ownership import _LOCK_SUFFIX

#: Output -> [file descriptor, holders, lock file] of the locks this process holds.
_locks: dict[Path, list[Any]] = {}


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

"""An interrupt (a signal) recorded for the whole run, and library writes that hold it until they return.

The CLI's signal handlers record the signal here (:func:`note_interrupt`), so that no staged output is
moved into place even if a library caught the ``KeyboardInterrupt``. A program that embeds squealkit
and handles signals itself does the same, and forgets a handled interrupt with :func:`clear_interrupt`.
"""

from __future__ import annotations

import contextlib
import threading
from collections.abc import Iterator
from typing import Any

__all__ = ["clear_interrupt", "deferred_interrupts", "interrupt_signal", "interrupts_deferred", "note_interrupt"]


#: Set by the CLI's signal handlers (:func:`note_interrupt`): an interrupt arrived, even if
#: a library caught the exception, so no staged output may be moved into place.
_interrupted = threading.Event()


_state: dict[str, Any] = {"deferred": 0, "signal": None}


def note_interrupt(signum: int | None = None) -> None:
    """Record that the run was interrupted (a signal): staged outputs are discarded.

    Call it from a signal handler: from then on no staged output is moved into place (each
    :func:`atomic_path` and :func:`outputs_together` raises ``KeyboardInterrupt`` at its end),
    even if a library caught the exception the handler raised. The record stays until
    :func:`clear_interrupt`.

    Parameters
    ----------
    signum : int or None
        The signal received (``signal.SIGTERM``...), reported by :func:`interrupt_signal`.

    Returns
    -------
    None
    """
    _state["signal"] = signum
    _interrupted.set()


def clear_interrupt() -> None:
    """Forget a recorded interrupt (:func:`note_interrupt`), so that outputs are written again.

    For a program that goes on after an interrupted run (a service, a notebook): the next
    run's outputs are moved into place as usual.

    Returns
    -------
    None
    """
    _interrupted.clear()
    _state["signal"] = None


def interrupt_signal() -> int | None:
    """The signal that interrupted the run, if one did.

    Returns
    -------
    int or None
        The signal given to :func:`note_interrupt`, or None if no interrupt is recorded.
    """
    return _state["signal"] if _interrupted.is_set() else None


def _interrupt_recorded() -> bool:
    """Whether an interrupt is recorded (:func:`note_interrupt`), whatever its signal: for writers that
    check before each chunk (thread-safe: an event)."""
    return _interrupted.is_set()


def interrupts_deferred() -> bool:
    """Whether a library write is in progress (see :func:`deferred_interrupts`).

    A signal handler that finds it True records the signal only (:func:`note_interrupt`);
    the write raises ``KeyboardInterrupt`` when it returns.

    Returns
    -------
    bool
        True inside :func:`deferred_interrupts`.
    """
    return _state["deferred"] > 0


@contextlib.contextmanager
def deferred_interrupts() -> Iterator[None]:
    """Hold an interrupt until the library write inside has returned, then raise it.

    Writers such as zarr's work in background threads: interrupted mid-write, they would
    go on writing into the staging folder after it was removed. The CLI's signal handlers
    only record the signal while this is active (one write of one output, or one piece of
    a streamed result), and the run stops right after it, cleaning up as always.

    Yields
    ------
    None
        Write inside; ``KeyboardInterrupt`` is raised at the end if an interrupt was
        recorded (:func:`note_interrupt`) meanwhile or before.
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

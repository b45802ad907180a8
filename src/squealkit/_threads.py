"""How many threads squealkit's compiled kernels use: one place that decides.

The stability and transient kernels are numba ``parallel=True`` loops (``prange``). A
parallel call costs a start-up on every core (waking the worker threads, splitting the
work, waiting for the slowest); for a small call that costs more than the work, and on a
machine whose cores are shared with other jobs a waiting call stalls until every worker
gets a core. So:

- :func:`thread_limit` is the most threads any kernel may use: the innermost
  :func:`limit_threads` block, else the environment variable ``SQUEALKIT_THREADS``, else
  numba's own pool size (``NUMBA_NUM_THREADS``, by default the number of cores); an explicit
  block (the CLI's ``--threads``) takes precedence over the environment variable;
- :func:`threads_for` gives a call of ``work_items`` independent items one thread when it
  is small (below :data:`SERIAL_BELOW` eigenvalue points; measured with
  ``benchmarks/bench_threads.py``) and the limit otherwise;
- :func:`limit_threads` runs a block with at most that many threads
  (``numba.set_num_threads``, which makes ``prange`` loops serial at 1).

numba's thread count is per calling thread, so a limit set in one thread (or one Dask
task) never changes another's.

BLAS threads (OpenBLAS, MKL: the FE engines' dense LAPACK calls) are bounded by the same
limit in every public compute entry point that calls them, through one decorator,
:func:`honour_thread_limit` (the context :func:`bounded_blas`): at most
:func:`thread_limit` threads, never more than an enclosing block (or the caller's own
``threadpoolctl`` limit) already allows. BLAS's thread count is process-wide, unlike
numba's.

Examples
--------
>>> from squealkit._threads import limit_threads, threads_for
>>> with limit_threads(1):
...     threads_for(10**9)
1
>>> threads_for(10)
1
"""

from __future__ import annotations

import contextlib
import contextvars
import functools
import numbers
import os
import sys
from collections.abc import Callable, Iterator
from typing import Any, TypeVar

from ._validation import InputError

__all__ = [
    "ENV_VAR",
    "SERIAL_BELOW",
    "bounded_blas",
    "env_threads",
    "honour_thread_limit",
    "limit_threads",
    "thread_limit",
    "threads_for",
    "validate_threads",
]

#: Environment variable with the most threads squealkit may use (an integer >= 1).
ENV_VAR = "SQUEALKIT_THREADS"
#: Eigenvalue points below which a stability call runs on one thread: on this project's
#: 2-core machine the parallel call costs 0.4-0.5 ms more than the serial one and only
#: wins from a few 10^4 points, less under a competing load (``benchmarks/bench_threads.py``).
SERIAL_BELOW = 20_000

#: The limit set by the innermost limit_threads block (None outside any).
_LIMIT: contextvars.ContextVar[int | None] = contextvars.ContextVar("squealkit_threads", default=None)


def validate_threads(name: str, value: object) -> int:
    """Return ``value`` as a thread count, an integer >= 1; anything else is an InputError."""
    text = value.strip() if isinstance(value, str) else value
    if isinstance(text, bool):
        n = None
    elif isinstance(text, numbers.Integral):
        n = int(text)
    elif isinstance(text, str) and text.lstrip("+").isdigit():
        n = int(text)
    else:
        n = None
    if n is None or n < 1:
        raise InputError(f"{name}={value!r} must be an integer >= 1 (the number of threads).")
    return n


def env_threads() -> int | None:
    """The thread count set by ``SQUEALKIT_THREADS``, or None if it is unset or empty.

    Returns
    -------
    int or None
        The count (an integer >= 1), or None.

    Raises
    ------
    InputError
        If it is set to anything but an integer >= 1.
    """
    value = os.environ.get(ENV_VAR)
    if value is None or value.strip() == "":
        return None
    return validate_threads(f"Environment variable {ENV_VAR}", value)


def _pool_size() -> int:
    import numba

    return int(numba.config.NUMBA_NUM_THREADS)


def thread_limit() -> int:
    """The most threads a kernel may use now (at least 1, at most numba's pool size).

    The innermost :func:`limit_threads` block, else ``SQUEALKIT_THREADS``, else numba's pool.

    Returns
    -------
    int
        The limit in force in this thread.

    Raises
    ------
    InputError
        If ``SQUEALKIT_THREADS`` is set to anything but an integer >= 1.
    """
    n = _LIMIT.get()
    if n is None:
        n = env_threads()
    pool = _pool_size()
    return pool if n is None else max(1, min(n, pool))


def threads_for(work_items: int, *, serial_below: int = SERIAL_BELOW) -> int:
    """Threads for a parallel kernel over ``work_items`` independent items.

    One thread when ``work_items < serial_below`` (the parallel start-up would cost more
    than it saves), else :func:`thread_limit`.

    Parameters
    ----------
    work_items : int
        How many independent items the kernel works on (eigenvalue points, runs).
    serial_below : int
        Below this many items, one thread (default :data:`SERIAL_BELOW`).

    Returns
    -------
    int
        The number of threads to use.
    """
    return 1 if work_items < serial_below else thread_limit()


@contextlib.contextmanager
def limit_threads(n: int) -> Iterator[int]:
    """Run a block with numba's kernels on at most ``n`` threads (in this thread).

    ``n`` is capped by an enclosing ``limit_threads`` block and by numba's pool size (not
    by ``SQUEALKIT_THREADS``: an explicit limit takes precedence over the environment);
    blocks nest, an inner block can only lower the count, and each restores the previous
    count on exit.

    Parameters
    ----------
    n : int
        The most threads, an integer >= 1 (else an ``InputError``).

    Yields
    ------
    int
        The count in force inside the block.

    Examples
    --------
    >>> from squealkit.scale import limit_threads
    >>> with limit_threads(1) as n:   # e.g. one Dask task per core
    ...     n
    1
    """
    import numba

    outer = _LIMIT.get()
    n = min(validate_threads("threads", n), _pool_size() if outer is None else outer)
    before = numba.get_num_threads()
    token = _LIMIT.set(n)
    numba.set_num_threads(n)
    try:
        yield n
    finally:
        _LIMIT.reset(token)
        numba.set_num_threads(before)


#: threadpoolctl's controller of the BLAS libraries loaded, and ``len(sys.modules)`` when it was made.
#: A new controller costs ~3 ms of library scanning, so it is reused while no module has been imported
#: since; a BLAS library comes with an import (scipy.linalg's own OpenBLAS, MKL with PARDISO), and one
#: loaded after the controller was made would otherwise keep its own thread count.
_BLAS_CONTROLLER: Any = None
_BLAS_SCANNED_AT = -1


def _blas_controller() -> Any:
    global _BLAS_CONTROLLER, _BLAS_SCANNED_AT
    if _BLAS_CONTROLLER is None or len(sys.modules) != _BLAS_SCANNED_AT:
        from threadpoolctl import ThreadpoolController

        _BLAS_SCANNED_AT = len(sys.modules)  # before: the import itself may add modules
        _BLAS_CONTROLLER = ThreadpoolController().select(user_api="blas")
        _BLAS_SCANNED_AT = len(sys.modules)
    return _BLAS_CONTROLLER


@contextlib.contextmanager
def bounded_blas() -> Iterator[int]:
    """Run a block with BLAS on at most :func:`thread_limit` threads; yields that limit.

    A BLAS library already at or below the limit (an enclosing block, or the caller's own
    ``threadpoolctl`` limit) is left alone: this only ever lowers the count, and restores
    it on exit.

    Raises
    ------
    InputError
        If ``SQUEALKIT_THREADS`` is set to anything but an integer >= 1.
    """
    n = thread_limit()
    blas = _blas_controller()
    if all(lib.num_threads <= n for lib in blas.lib_controllers):
        yield n
        return
    with blas.limit(limits=n):
        yield n


_F = TypeVar("_F", bound=Callable[..., Any])


def honour_thread_limit(fn: _F) -> _F:
    """Decorate a public compute entry point: its BLAS calls run under :func:`bounded_blas`."""

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        with bounded_blas():
            return fn(*args, **kwargs)

    return wrapper  # type: ignore[return-value]

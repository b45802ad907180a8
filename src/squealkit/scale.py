"""Run squealkit's work on a Dask cluster (``dask.distributed``), or in this process.

Every job that can outgrow one machine (stability sweeps, batches of transient runs,
Monte Carlo samples, test campaigns) is cut into independent tasks that each write or
return a small piece. :func:`map_tasks` runs them: in this process when ``client`` is
None, on the cluster otherwise, yielding results as they complete. The same function
computes each piece either way, so a cluster run gives the same numbers as a local one.

A lost worker is handled by the scheduler: its tasks are run again on the others
(every task here is a pure function of its arguments, and zarr regions are rewritten
whole), so a job survives workers that die mid-run.

Install the optional part with ``pip install "squealkit[distributed]"``.

On one machine, :func:`limit_threads` (or ``SQUEALKIT_THREADS``) bounds the threads of the
compiled kernels: :func:`thread_limit` is the limit in force, :func:`threads_for` what a call
of a given size uses.
"""

from __future__ import annotations

import contextlib
import functools
import gc
import json
import logging
import os
import shutil
import tempfile
import threading
import time
import traceback
import weakref
from collections.abc import Callable, Iterable, Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from ._optional import require
from ._threads import ENV_VAR, SERIAL_BELOW, env_threads, limit_threads, thread_limit, threads_for
from ._validation import InputError
from .io import atomic_path, deferred_interrupts, written_path
from .io._interrupts import _interrupt_recorded

__all__ = [
    "ENV_VAR",
    "LOCAL_WORKER_CONFIG",
    "SERIAL_BELOW",
    "ZARR_CHUNK_BYTES",
    "cluster_client",
    "env_threads",
    "get_client",
    "lazy_template",
    "limit_threads",
    "map_tasks",
    "stream_to_zarr",
    "thread_limit",
    "threads_for",
]

Progress = Callable[[int, int], None]


def _distributed():
    return require("distributed", "Running on a Dask cluster")


#: Dask configuration in force while :func:`get_client` starts a local cluster's workers.
#: Dask starts every worker process with ``MALLOC_TRIM_THRESHOLD_=65536``
#: (``distributed.nanny.pre-spawn-environ``) so that freed memory goes back to the system at
#: once. Setting it also turns off glibc's adaptive mmap threshold: every array above 128 KiB
#: is then mapped fresh and unmapped when freed, and its pages are faulted in again on each
#: use. An application's analysis allocates such arrays throughout (blocks, spectrograms),
#: which cost 10-15 ms more CPU (system time) per 10 s, 48 kHz application in a worker than
#: in this process (15,000 page faults instead of 3,500); without the variable a worker frees
#: memory as this process does (glibc's defaults: at most a few tens of MB kept for reuse).
#: A value set in this process's environment is still passed on (the workers inherit it).
LOCAL_WORKER_CONFIG = {"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None}
#: Seconds a local cluster's worker process may take to start (numba and SciPy imports under load take
#: tens of seconds; one that is not up by then is stuck).
LOCAL_START_TIMEOUT = 180.0
#: Local cluster -> removal of its scratch folder (see :func:`get_client`).
_SCRATCH: dict[int, weakref.finalize] = {}


def get_client(scheduler: str, *, n_workers: int | None = None, dashboard_address: str | None = None):
    """A ``distributed.Client`` for ``scheduler``.

    Parameters
    ----------
    scheduler : str
        ``"local"`` starts a local cluster of worker processes (one thread each, one per
        core unless ``n_workers`` says otherwise; with glibc's own memory settings, see
        :data:`LOCAL_WORKER_CONFIG`); anything else is a scheduler address,
        e.g. ``"tcp://10.0.0.5:8786"`` or a scheduler file ``*.json``.
    n_workers : int, optional
        Workers of a local cluster.
    dashboard_address : str, optional
        Where a local cluster serves Dask's dashboard, e.g. ``":8787"`` or ``":0"`` (a free
        port; ``client.dashboard_link`` tells which). None (the default): no dashboard, and the
        scheduler's HTTP endpoints on a free port, so that several clusters (parallel tests,
        a user's own cluster on 8787) start side by side without a word about a port in use.

    Returns
    -------
    distributed.Client
        Close it (and with it a local cluster) when done, or use :func:`cluster_client`.
    """
    distributed = _distributed()
    if not isinstance(scheduler, str) or not scheduler.strip():
        raise InputError(f"Scheduler {scheduler!r} must be 'local' or an address like tcp://HOST:8786.")
    scheduler = scheduler.strip()
    if scheduler == "local":
        import dask

        n = n_workers or os.cpu_count() or 1
        # the cluster's scratch space (dask-scratch-space/ with its lock files) in a folder of its own, removed
        # when the cluster is closed (cluster_client) or collected, never left in the temporary folder
        scratch = tempfile.mkdtemp(prefix="squealkit-dask-")
        # a failing task reaches the caller as its exception; the workers need not log it too
        t0 = time.monotonic()
        try:
            with dask.config.set({**LOCAL_WORKER_CONFIG, "temporary-directory": scratch}):
                # each worker's nanny gives up on a worker process that has not started within the bound,
                # and the cluster's start then fails instead of waiting for ever
                with _collection_paused():
                    # (None would mean Dask's default, 8787, and a warning where that port is taken)
                    cluster = distributed.LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                                       dashboard_address=dashboard_address or ":0",
                                                       scheduler_kwargs={"dashboard": dashboard_address is not None},
                                                       silence_logs=logging.CRITICAL,
                                                       local_directory=scratch,
                                                       death_timeout=f"{LOCAL_START_TIMEOUT:g}s")
        except Exception as e:
            shutil.rmtree(scratch, ignore_errors=True)
            if time.monotonic() - t0 >= LOCAL_START_TIMEOUT:
                why = f"its {n} worker processes did not start within {LOCAL_START_TIMEOUT:g} s"
            else:
                why = f"{type(e).__name__}: {str(e).splitlines()[0] if str(e) else 'no message'}"
            raise InputError(f"The local Dask cluster could not be started ({why}); run without --scheduler, "
                             "or start a cluster and give its address.") from e
        except BaseException:
            shutil.rmtree(scratch, ignore_errors=True)
            raise
        _SCRATCH[id(cluster)] = weakref.finalize(cluster, shutil.rmtree, scratch, ignore_errors=True)
        with _collection_paused():
            client = distributed.Client(cluster)
        return client
    if scheduler.endswith(".json"):
        if not os.path.isfile(scheduler):
            raise InputError(f"Scheduler file {scheduler!r} does not exist "
                             "(dask scheduler --scheduler-file writes it).")
        try:
            with open(scheduler, encoding="utf-8") as f:
                address = json.load(f).get("address")
        except (OSError, ValueError, AttributeError) as e:
            raise InputError(f"Scheduler file {scheduler!r} is not a Dask scheduler file: {e}") from e
        if not isinstance(address, str) or "://" not in address:
            raise InputError(f"Scheduler file {scheduler!r} is not a Dask scheduler file: its 'address' is "
                             f"{address!r}, not an address like tcp://HOST:8786.")
        scheduler = address
    return _connect(distributed, scheduler)


#: Seconds to wait for a scheduler's answer. A service that accepts the connection but is
#: not a Dask scheduler would otherwise keep the handshake waiting forever.
CONNECT_TIMEOUT = 20.0


_PAUSE_LOCK = threading.Lock()
_PAUSE = {"depth": 0, "was_enabled": True}


@contextlib.contextmanager
def _collection_paused() -> Iterator[None]:
    """No automatic garbage collection while a Dask client or local cluster starts.

    ``distributed`` starts every client's and cluster's event loop under one class-wide lock
    (``LoopRunner._lock``), and a Client that is collected closes itself by taking the same lock. A
    collection that runs in the starting thread, while it holds the lock, and finds an unclosed
    client among the garbage, makes the thread wait for itself for ever (a whole test run hung so in
    ``LocalCluster``'s start-up). Explicit ``gc.collect()`` calls still run; nested and concurrent
    pauses count.
    """
    with _PAUSE_LOCK:
        if _PAUSE["depth"] == 0:
            _PAUSE["was_enabled"] = gc.isenabled()
            gc.disable()
        _PAUSE["depth"] += 1
    try:
        yield
    finally:
        with _PAUSE_LOCK:
            _PAUSE["depth"] -= 1
            if _PAUSE["depth"] == 0 and _PAUSE["was_enabled"]:
                gc.enable()


def _close_quietly(client) -> None:
    with contextlib.suppress(Exception):
        client.close()


def _close_half_made_client(distributed, error: BaseException) -> None:
    """Close the Client whose constructor raised ``error`` (found in the traceback's frames).

    A Client that failed to connect is left half made; garbage collection later runs its
    ``__del__``, which closes it by taking ``distributed``'s class-wide loop-runner lock. When
    that collection happens in a thread that already holds the lock (starting another client or a
    local cluster), the thread waits for itself for ever: whole test runs hung so. Closed here, in
    this thread and holding no lock, its ``__del__`` has nothing left to do.
    """
    for frame, _ in traceback.walk_tb(error.__traceback__):
        candidate = frame.f_locals.get("self")
        if isinstance(candidate, distributed.Client):
            _close_quietly(candidate)
            return


def _connect(distributed, address: str):
    """A client of the scheduler at ``address``, or a one-line InputError within the timeout."""
    import dask

    result: dict[str, Any] = {}
    # a Client makes itself dask's scheduler and default client before it connects, and one that failed
    # to connect never undoes it: later dask and xarray work in this process would go to the refused address
    scheduler = dask.config.get("scheduler", None)
    defaults = set(distributed.client._global_clients)

    def forget_the_client() -> None:
        if scheduler is None:
            dask.config.config.pop("scheduler", None)
        else:
            dask.config.set(scheduler=scheduler)
        for k in set(distributed.client._global_clients) - defaults:
            distributed.client._global_clients.pop(k, None)

    abandoned = threading.Event()

    def attempt() -> None:
        try:
            # not paused: a scheduler that never answers would keep collection off for ever; the
            # half-made clients this thread leaves are closed here instead (the lock's other half)
            client = distributed.Client(address, timeout=f"{CONNECT_TIMEOUT / 2:g}s")
        except BaseException as e:  # reported below, in the caller's thread
            _close_half_made_client(distributed, e)
            result["error"] = e
            return
        if abandoned.is_set():  # answered after the caller gave up: nobody will close it
            _close_quietly(client)
        else:
            result["client"] = client

    worker = threading.Thread(target=attempt, name="squealkit-connect", daemon=True)
    worker.start()
    worker.join(CONNECT_TIMEOUT)
    if worker.is_alive():
        abandoned.set()
        forget_the_client()
        raise InputError(f"No Dask scheduler answered at {address!r} within {CONNECT_TIMEOUT:g} s "
                         "(is a Dask scheduler listening there?).")
    error = result.get("error")
    if error is not None:
        forget_the_client()
        if isinstance(error, OSError | TimeoutError | ValueError | TypeError):
            raise InputError(f"Cannot reach the Dask scheduler {address!r}: {error}") from error
        if isinstance(error, Exception):  # e.g. a frame length read from another service's bytes: MemoryError
            raise InputError(f"The server at {address!r} does not speak Dask's protocol (is a Dask scheduler "
                             f"listening there?): {type(error).__name__}: {error}") from error
        raise error
    return result["client"]


@contextlib.contextmanager
def cluster_client(scheduler: str | None, *, n_workers: int | None = None,
                   dashboard_address: str | None = None) -> Iterator[Any]:
    """Context manager: a client for ``scheduler`` (None yields None), closed on exit.

    Parameters
    ----------
    scheduler : str or None
        ``"local"``, a scheduler address or a scheduler file, as in :func:`get_client`;
        None runs without a cluster.
    n_workers : int, optional
        Workers of a local cluster.
    dashboard_address : str, optional
        A local cluster's dashboard (:func:`get_client`; default none).

    Yields
    ------
    distributed.Client or None
        The client; on exit it is closed, and with ``"local"`` its cluster too.
    """
    if scheduler is None:
        yield None
        return
    client = get_client(scheduler, n_workers=n_workers, dashboard_address=dashboard_address)
    try:
        yield client
    finally:
        cluster = client.cluster if scheduler.strip() == "local" else None
        client.close()
        if cluster is not None:
            cluster.close()
            remove_scratch = _SCRATCH.pop(id(cluster), None)
            if remove_scratch is not None:
                remove_scratch()


def _in_worker(fn: Callable[..., Any], item: Any) -> Any:
    """Run one task on a worker, with numba's threads limited to the worker's share."""
    from ._threads import limit_threads

    try:
        nthreads = require("distributed", "A Dask task").get_worker().state.nthreads
    except (InputError, ValueError):  # pragma: no cover - outside a worker
        return fn(item)
    with limit_threads(max(1, nthreads)):
        return fn(item)


def map_tasks(
    fn: Callable[[Any], Any],
    items: Sequence[Any] | Iterable[Any],
    *,
    client: Any = None,
    progress: Progress | None = None,
    weights: Sequence[int] | None = None,
    name: str = "squealkit",
) -> Iterator[tuple[int, Any]]:
    """Apply ``fn`` to every item; yield ``(index, result)`` as the tasks complete.

    Parameters
    ----------
    fn : callable
        A module-level function of one argument (it is pickled to the workers).
    items : sequence
        The tasks' arguments. Keep them small: each is sent to a worker.
    client : distributed.Client, optional
        Run on this cluster; without it, run here one after another, in order.
    progress : callable, optional
        ``progress(done, total)`` after each task, in units of ``weights``.
    weights : sequence of int, optional
        Work per task for the progress report (default 1 each).
    name : str
        Prefix of the Dask task keys (shown on the dashboard).

    Yields
    ------
    (int, object)
        Task index and its result; on a cluster each result is released once yielded.

    Examples
    --------
    >>> sorted(map_tasks(abs, [-2, 3]))
    [(0, 2), (1, 3)]
    """
    items = list(items)
    w = [1] * len(items) if weights is None else [int(x) for x in weights]
    total = sum(w)
    done = 0
    if client is None:
        for i, item in enumerate(items):
            result = fn(item)
            done += w[i]
            if progress is not None:
                progress(done, total)
            yield i, result
        return
    distributed = _distributed()
    keys = [f"{name}-{i}-{_token(fn, it)}" for i, it in enumerate(items)]
    futures = client.map(_in_worker, [fn] * len(items), items, key=keys)
    index = {f.key: i for i, f in enumerate(futures)}
    try:
        for fut in distributed.as_completed(futures):
            i = index[fut.key]
            result = fut.result()
            fut.release()
            done += w[i]
            if progress is not None:
                progress(done, total)
            yield i, result
    finally:
        for fut in futures:
            fut.release()


def _token(fn: Callable[..., Any], item: Any) -> str:
    from dask.base import tokenize

    return tokenize(fn, item)


def lazy_template(sample: xr.Dataset, dim: str, index: np.ndarray, chunk: int) -> xr.Dataset:
    """A full-size, dask-backed dataset shaped like ``sample`` but ``len(index)`` long in ``dim``.

    ``sample`` is one computed piece of the result (e.g. one row); every variable along
    ``dim`` becomes lazy zeros chunked ``chunk`` along ``dim`` (whole along the others), so
    writing the template stores only the metadata and the coordinates. ``index`` is the
    coordinate of ``dim``.

    Parameters
    ----------
    sample : xarray.Dataset
        One computed piece of the result.
    dim : str
        The dimension the result is split along.
    index : array_like, 1-D
        The full coordinate of ``dim``; its length is the result's along ``dim``.
    chunk : int
        Chunk length along ``dim`` (the length of a piece).

    Returns
    -------
    xarray.Dataset
        Shaped like ``sample`` but ``len(index)`` long in ``dim``: the variables and
        coordinates along ``dim`` are lazy zeros (``dim`` itself is ``index``), the rest and
        the attributes are ``sample``'s.
    """
    import dask.array as da

    n = len(index)

    def full(v: xr.Variable) -> xr.Variable:
        shape = tuple(n if d == dim else s for d, s in zip(v.dims, v.shape, strict=True))
        chunks = tuple(chunk if d == dim else s for d, s in zip(v.dims, v.shape, strict=True))
        return xr.Variable(v.dims, da.zeros(shape, dtype=v.dtype, chunks=chunks), v.attrs)

    data_vars = {k: (full(v.variable) if dim in v.dims else v.variable) for k, v in sample.data_vars.items()}
    coords = {}
    for k, v in sample.coords.items():
        if k == dim:
            coords[k] = xr.Variable((dim,), np.asarray(index), v.attrs)
        elif dim in v.dims:
            coords[k] = full(v.variable)
        else:
            coords[k] = v.variable
    return xr.Dataset(data_vars, coords, attrs=sample.attrs)


def _text_as_object(ds: xr.Dataset) -> xr.Dataset:
    """``ds`` with its text variables as variable-length strings.

    Fixed-width text (numpy ``<U``) takes its width from the data, so a piece whose statuses
    are all ``"diverged"`` (``<U8``) does not fit a store laid out from a ``"completed"`` one
    (``<U9``), and zarr v3 has no stable specification for fixed-width text (it warns on every
    write); variable-length strings have neither problem.
    """
    text = [k for k, v in ds.variables.items() if v.dtype.kind == "U"]
    return ds.assign({k: ds[k].astype(object) for k in text if k in ds.data_vars}).assign_coords(
        {k: ds[k].astype(object) for k in text if k in ds.coords and k not in ds.dims})


#: Largest chunk of a streamed zarr store [bytes, before compression]. A piece is written chunk by chunk
#: and a stop request (SIGTERM, Ctrl-C) is honoured before each chunk (:func:`_stop_aware`): a run stops
#: after the chunks in flight (at most zarr's ``async.concurrency``, 10), not after a whole piece. A tile
#: of a 3000 x 3000 stability map is 149 MB (one chunk per variable of up to 25 MB before), which took
#: 1.7-2.5 s to write on a loaded machine: the signal waited that long.
ZARR_CHUNK_BYTES = 4 << 20


class _StopRequested(RuntimeError):
    """A chunk write refused because the run was interrupted (raised inside zarr's writer)."""


@functools.cache
def _stop_aware_store() -> type | None:
    """A zarr store class that refuses every chunk once an interrupt is recorded (None with zarr 2)."""
    try:
        from zarr.storage import WrapperStore
    except ImportError:  # pragma: no cover - zarr 2: a piece is written whole
        return None

    class StopAwareStore(WrapperStore):
        async def set(self, key: str, value: Any) -> None:
            if _interrupt_recorded():
                raise _StopRequested(key)
            await self._store.set(key, value)

    return StopAwareStore


def _stop_aware(path: str) -> Any:
    """The zarr store at ``path``, written through :func:`_stop_aware_store` where zarr has it."""
    store = _stop_aware_store()
    if store is None:  # pragma: no cover - zarr 2
        return path
    from zarr.storage import LocalStore

    return store(LocalStore(path))


def _bounded_chunks(v: xr.Variable, dim: str, step: int) -> tuple[int, ...]:
    """Chunks of ``v``: ``step`` along ``dim`` (a piece's length), the other dimensions cut (the longest
    first) so that a chunk holds at most :data:`ZARR_CHUNK_BYTES`. Text (variable length) stays whole."""
    shape = [step if d == dim else n for d, n in zip(v.dims, v.shape, strict=True)]
    if v.dtype.kind == "O":
        return tuple(shape)
    for i in sorted((i for i, d in enumerate(v.dims) if d != dim), key=lambda i: -shape[i]):
        rest = v.dtype.itemsize * int(np.prod([n for j, n in enumerate(shape) if j != i]))
        if rest * shape[i] <= ZARR_CHUNK_BYTES:
            break
        shape[i] = max(1, ZARR_CHUNK_BYTES // rest)
    return tuple(shape)


def _write_region(item: tuple) -> int:
    """Compute one piece and write it into its region of the zarr store, chunk by chunk until a stop request."""
    fn, arg, path, dim, start, stop = item
    piece: xr.Dataset = _text_as_object(fn(arg))
    drop = [k for k, v in piece.variables.items() if dim not in v.dims]
    # the write returns (no background writer outlives an interrupt), but refuses every chunk after one
    with deferred_interrupts():
        try:
            piece.drop_vars(drop).to_zarr(_stop_aware(path), region={dim: slice(start, stop)}, consolidated=False)
        except _StopRequested:
            pass  # deferred_interrupts raises the interrupt itself
    return stop - start


def stream_to_zarr(
    store: str | Path,
    template: xr.Dataset,
    dim: str,
    pieces: Sequence[tuple[Callable[[Any], xr.Dataset], Any, int, int]],
    *,
    client: Any = None,
    progress: Progress | None = None,
    weights: Sequence[int] | None = None,
    name: str = "squealkit-piece",
) -> xr.Dataset:
    """Write a result piece by piece into a zarr store; never hold it whole in one process.

    Parameters
    ----------
    store : path
        The zarr store (a folder; replaced only when every piece is written). On a
        multi-machine cluster it must lie on a file system every worker sees.
    template : xarray.Dataset
        The full result, lazily (see :func:`lazy_template`); its chunks along ``dim``
        must match the pieces.
    dim : str
        The dimension the pieces split.
    pieces : sequence of (fn, arg, start, stop)
        ``fn(arg)`` computes the piece ``start:stop`` along ``dim`` (module-level fn).
    client, progress, weights, name
        As in :func:`map_tasks` (weights default to the pieces' lengths).

    Returns
    -------
    xarray.Dataset
        The store opened lazily (dask-backed).
    """
    final = Path(store)
    with atomic_path(final, directory=True) as tmp:
        # every variable along dim (text too, and coordinates) chunked as the pieces are: pieces
        # written at once by different workers must never share a chunk (each write rewrites
        # its whole chunk, so one piece would silently undo the other's)
        # (dask chunks alone do not decide it: xarray lays variable-length text out as one chunk)
        step = max(b - a for *_, a, b in pieces)
        if any(a % step for *_, a, _b in pieces):
            raise ValueError(f"stream_to_zarr: pieces along {dim!r} must start at multiples of {step}.")
        layout = _text_as_object(template)
        encoding = {k: {"chunks": _bounded_chunks(v, dim, step)} for k, v in layout.variables.items() if dim in v.dims}
        with deferred_interrupts():
            layout.to_zarr(tmp, mode="w", compute=False, consolidated=False, encoding=encoding)
        path = str(tmp.resolve())
        items = [(fn, arg, path, dim, a, b) for fn, arg, a, b in pieces]
        w = weights if weights is not None else [b - a for *_, a, b in pieces]
        for _ in map_tasks(_write_region, items, client=client, progress=progress, weights=w, name=name):
            pass
    return xr.open_zarr(written_path(final), consolidated=False)

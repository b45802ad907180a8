"""Compile the kernels a long run will need later on the other core, while it works on the first.

numba compiles each kernel on its first call and keeps it in its on-disk cache
(``cache=True``); a later run loads it in milliseconds. On a fresh install the first
``squealkit reproduce`` therefore spends most of its time compiling, one kernel after the
other, on one core. :func:`start` hands the kernels of the later steps (the transient
integrator, the limit-cycle and the measurement kernels) to a child process that compiles
them into the same cache while this process compiles and runs the stability steps;
:func:`wait` blocks a step until the child has finished its group, so the two never
compile the same kernel, and the step then loads the kernel from the cache. A group the
child has not begun when a step needs it is the step's: the step claims it (a file
created exclusively, the child claims each group the same way before it begins it) and
compiles it itself, the child skips it, and neither process waits for the other. After
the transient integrator (the largest kernel, the child's longest group) the child compiles
the stability grid's later kernels (verdicts, mode selection, tracking) this process has
not reached yet: on a loaded machine the Fig. 2 step is still compiling when the child is
done with the integrator (on an idle one it is past them, and the child merely loads them).

Nothing is started when it would not pay: on one core, with ``SQUEALKIT_THREADS=1`` or
``--threads 1`` (the user capped squealkit to one thread), or when a stamp file says this
cache already holds the kernels of this version of squealkit. A child that fails or dies
costs nothing but time: the step compiles the kernel itself, as without the child.

Private: started and waited for by the report's runner (:func:`squealkit.report.runner.run_report`);
it imports nothing of the report: the operating points it compiles for are the report's, from
:mod:`squealkit._operating_point`.
"""

from __future__ import annotations

import atexit
import contextlib
import hashlib
import os
import shutil
import subprocess
import sys
import tempfile
import threading
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

__all__ = ["GROUPS", "compiling", "start", "stop", "wait"]


def _lapack_eigenvalues(model, mu, tan_theta=0.0, *, damped=False, **_ignored):
    """Stand-in for :func:`squealkit.stability.eigenvalues` in the child (LAPACK, one point at a time).

    The integrator's set-up asks for the linear model's eigenvalues (its step-size bound and
    the summary's growth rates); the parent is compiling the stability kernels that compute
    them at that very moment, so the child takes them from LAPACK instead of compiling them
    a second time. Only the child's throw-away run sees these values.
    """
    import numpy as np

    mu, t = np.broadcast_arrays(np.asarray(mu, float), np.asarray(tan_theta, float))
    M = model.mass_matrix()
    n = M.shape[0]
    C = model.damping_matrix() if damped else np.zeros_like(M)
    out = np.empty((*mu.shape, n), complex)
    for idx in np.ndindex(mu.shape):
        K = model.stiffness_matrix(mu[idx], t[idx])
        A = np.block([[np.zeros((n, n)), np.eye(n)], [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
        lam = np.linalg.eigvals(A)
        out[idx] = lam[np.argsort(-lam.imag, kind="stable")[:n]]
    return out


def _stability() -> None:
    """The kernels a stability grid needs after its roots, compiled for the types the grid passes.

    The parent compiles the roots' kernels (:func:`~squealkit.solvers.small.charpoly_table`,
    :func:`~squealkit.solvers.small.quadratic_eigvals`, the largest) in the Fig. 2 step;
    the child compiles, in the order the grid calls them, the root finder's error radii (the
    engine, :mod:`squealkit.solvers.small`), the verdicts and the mode selection (the analysis,
    :mod:`squealkit.stability._verdicts`), the tracking along mu and theta and the derived
    quantities, and the parent loads those the child got to first from the cache. Measured:
    first in the child, this group delays the integrator, the child's critical path, more
    than it saves the parent (an idle machine: 64.7 s against 55.8 s); after it, it helps
    only where the parent is slower (a loaded machine). Compiled by
    signature, without a call: a kernel the parent reaches first it compiles itself, as
    without the child. ``tests/test_warmup_stability.py`` checks these are the grid's types.
    """
    import numba as nb

    from .solvers import small
    from .stability import _verdicts, tracking

    c2, f2, i2 = nb.complex128[:, ::1], nb.float64[:, ::1], nb.int64[:, ::1]
    i1, f1 = nb.int8[::1], nb.float64[::1]
    # the root finder's error radii, the second half of quadratic_eigvals (M, C, K0, Kn, Kf, g,
    # e, perms, signs, table, Knx, Kfx, st, roots, radii, even, start, stop)
    small._radii_range.compile((f2, f2, f2, f2, f2, f1, f1, i2, f1, nb.float64[:, :, ::1], f2, f2, f1, c2, f2,
                                nb.boolean[::1], nb.int64, nb.int64))
    _verdicts.classify_points.compile((c2, f2, nb.boolean[::1], nb.float64, i1, f1))
    _verdicts.select_modes.compile((c2, f2, c2, f2))
    tracking._track_column.compile((c2, i2))
    tracking._track_rows.compile((nb.complex128[:, :, ::1], c2, i2))
    tracking._carry.compile((c2, f2, c2, f2))
    _verdicts.derived_quantities.compile((c2, f2, f1, i1, nb.float64))


def _transient() -> None:
    import importlib

    from ._operating_point import SPEED
    from .models import get_preset
    from .transient import SineRunOut, simulate

    for name in ("_step", "_result"):  # where a run calls eigenvalues: its step bound and its growth rate
        importlib.import_module(f"squealkit.transient.{name}").eigenvalues = _lapack_eigenvalues
    simulate(get_preset("lv2013"), mu=0.4, profile=SineRunOut(0.08e-3, 1e-3), speed=SPEED, duration=2e-4)


def _nonlinear() -> None:
    from ._operating_point import CYCLE_HARMONICS, CYCLE_MU_RANGE, SPEED
    from .models import get_preset
    from .nonlinear import limit_cycle_branch

    limit_cycle_branch(get_preset("lv2013"), CYCLE_MU_RANGE, harmonics=CYCLE_HARMONICS, n_points=2, speed=SPEED)
    # the branch's Floquet multipliers (one RK4 step over samples of A, the report's types): the
    # two points above end before any cycle needs them
    import numpy as np

    from .solvers import ode

    ode.monodromy_rk4(ode.sampled_rhs, np.zeros((3, 2, 2)), 1, 0.5, 2)


def _measurement() -> None:
    from ._operating_point import RIG_FS, RIG_RADIUS, RIG_RPM
    from .measurement import analyze_recording, synthetic_recording

    rec = synthetic_recording(duration=0.25, fs=RIG_FS, rpm=RIG_RPM, radius=RIG_RADIUS, freq=2400.0, seed=1)
    analyze_recording(rec, mic="mic", displacement="displacement", rpm=RIG_RPM, radius=RIG_RADIUS)


#: Kernel groups the child can compile, in the order a report needs them.
GROUPS: dict[str, Callable[[], None]] = {
    "transient": _transient,
    "stability": _stability,
    "nonlinear": _nonlinear,
    "measurement": _measurement,
}

_child: dict[str, object] = {"proc": None, "pending": set(), "lock": threading.Lock(), "claims": None}


def _claim(claims: str, name: str) -> bool:
    """True for the first of the two processes to claim group ``name`` (an exclusive create)."""
    try:
        os.close(os.open(os.path.join(claims, name), os.O_CREAT | os.O_EXCL | os.O_WRONLY))
    except FileExistsError:
        return False
    except OSError:  # the folder is gone (the parent's run is over) or unwritable: the other one has it
        return False
    return True


def _kernel_sources() -> list[Path]:
    root = Path(__file__).parent
    return sorted(p for p in root.rglob("*.py") if "njit" in p.read_text(encoding="utf-8", errors="replace"))


def _stamp() -> Path | None:
    """The file that says this numba cache holds every group's kernels for these sources."""
    try:
        import numba
        from numba.core.config import CACHE_DIR
    except ImportError:  # pragma: no cover - numba is a dependency
        return None
    h = hashlib.sha256(numba.__version__.encode())
    for p in _kernel_sources():
        st = p.stat()  # numba's own cache is keyed by the source files' mtime and size
        h.update(f"{p}:{st.st_mtime_ns}:{st.st_size}".encode())
    base = Path(CACHE_DIR) if CACHE_DIR else Path(__file__).parent / "__pycache__"
    return base / f"squealkit-kernels-{h.hexdigest()[:16]}.stamp"


def _worth_starting() -> bool:
    from ._threads import thread_limit

    if (os.cpu_count() or 1) < 2 or thread_limit() < 2:
        return False
    stamp = _stamp()
    return stamp is not None and not stamp.exists()


def start(groups: Iterable[str]) -> bool:
    """Compile ``groups`` (names in :data:`GROUPS`) in a child process; True if one was started."""
    names = [g for g in groups if g in GROUPS]
    if not names or not _worth_starting():
        return False
    proc = _child["proc"]
    if proc is not None and proc.poll() is None:  # one child at a time
        return False
    claims = None
    try:
        claims = tempfile.mkdtemp(prefix="squealkit-warmup-")
        proc = subprocess.Popen(
            [sys.executable, "-m", "squealkit._warmup", claims, *names], stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
        )
    except OSError:  # no process to spare: the steps compile their kernels themselves
        if claims is not None:
            shutil.rmtree(claims, ignore_errors=True)
        return False
    _child["proc"] = proc
    _child["pending"] = set(names)
    _child["claims"] = claims
    return True


@contextlib.contextmanager
def compiling(groups: Iterable[str]) -> Iterator[None]:
    """:func:`start` on entry, :func:`stop` on the way out (done, failed or interrupted)."""
    start(groups)
    try:
        yield
    finally:
        stop()


def wait(groups: Iterable[str]) -> None:
    """Return once the child has compiled ``groups``, at once if there is no child, it died, or it
    has not begun them (then they are the caller's to compile, and the child skips them)."""
    proc = _child["proc"]
    if proc is None:
        return
    want = set(groups) & _child["pending"]
    with _child["lock"]:
        for name in sorted(want):
            if _claim(_child["claims"], name):  # not begun: compiling it here beats waiting for it
                _child["pending"].discard(name)
                want.discard(name)
        while want and proc.stdout is not None:
            line = proc.stdout.readline()
            if not line:  # the child ended (done or failed): the steps compile what is left
                _child["pending"].clear()
                break
            done = line.strip()
            _child["pending"].discard(done)
            want.discard(done)


def stop() -> None:
    """End the child, if one is still compiling (the run that started it is over)."""
    proc = _child["proc"]
    if proc is not None and proc.poll() is None:
        proc.kill()
        proc.wait()
    if _child["claims"] is not None:
        shutil.rmtree(_child["claims"], ignore_errors=True)
    _child["proc"] = None
    _child["pending"] = set()
    _child["claims"] = None


atexit.register(stop)


def _main(claims: str, names: list[str]) -> int:
    import warnings

    warnings.simplefilter("ignore")
    for name in names:
        if not _claim(claims, name):  # the parent got there first and compiles it into the same cache
            continue
        GROUPS[name]()
        print(name, flush=True)
    if set(names) == set(GROUPS):
        stamp = _stamp()
        if stamp is not None:
            try:
                stamp.parent.mkdir(parents=True, exist_ok=True)
                stamp.touch()
            except OSError:  # a read-only install: the child runs again next time, as now
                pass
    return 0


if __name__ == "__main__":  # pragma: no cover - run as the child
    sys.exit(_main(sys.argv[1], sys.argv[2:]))

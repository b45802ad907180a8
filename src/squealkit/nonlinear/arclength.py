"""Pseudo-arclength continuation of harmonic-balance cycles from a Hopf point, and each cycle's
Floquet stability: the algorithm under :mod:`squealkit.nonlinear.continuation` (whose functions
run it on a squealkit model), for any :class:`~squealkit.nonlinear.harmonic_balance.SecondOrderSystem`.

The branch starts on the onset mode at a small amplitude (the mode shape and frequency of
the Hopf point, :mod:`squealkit.nonlinear.hopf`), where the parameter is solved for at a
fixed amplitude, and is followed by pseudo-arclength continuation (predictor along the
tangent, Newton corrector orthogonal to it, step adapted to the corrector's effort; the
next tangent comes from the corrector's last bordered Jacobian, oriented along the step
taken). A contact that opens makes the residual piecewise smooth: each AFT sample where it
opens is a kink, where the branch turns (sharply next to the vertical onset of a piecewise-
linear law). A turn that does not shrink with the step is such a corner and is stepped
over; where the corrector fails for every step down to 1/64 of the nominal one, it is
restarted from the last cycle with the amplitude or the parameter fixed a small step on
(``_restart``); and the branch stops only when that fails too, saying where and why
(``stop_reason``, ``stop_detail``). A fold is where the branch turns back in the parameter
(the parameter's component of the tangent changes sign and the parameter itself turns).
Each cycle's stability comes from its
Floquet multipliers: the monodromy matrix of the variational equations along the
harmonic-balance solution (compiled classical RK4 over one period, the step set by the
variational system's fastest rate), or Hill's method (:mod:`squealkit.nonlinear.hill`); the
trivial multiplier (near 1, the phase shift) is set aside, and its distance from 1 (the
error of the truncated cycle and of the integration) is the margin a multiplier must clear
to call the cycle unstable.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from threadpoolctl import threadpool_limits

from .._validation import InputError, validate_int, validate_positive
from .harmonic_balance import (
    HBProblem,
    LimitCycle,
    SecondOrderSystem,
    _newton,
    n_time_samples,
    solve_fixed_p,
)
from .hopf import HopfPoint

__all__ = ["Branch", "continue_branch", "floquet_multipliers"]

#: How the Floquet multipliers of a branch's cycles are computed.
STABILITY_METHODS = ("monodromy", "hill")
#: A non-trivial Floquet multiplier above 1 + max(this, 3 |trivial multiplier - 1|) marks an unstable cycle.
FLOQUET_TOL = 1e-7


#: RK4 step of the monodromy integration: ``dt`` times the largest rate of the variational matrix
#: (local error ~ 0.1^5 / 120 per step: ~3e-5 over a period of the paper's model, below the
#: harmonic-balance cycle's own error, which the trivial multiplier's distance from 1 shows).
_FLOQUET_STEP = 0.1


def _sample(Z: NDArray, n_samples: int) -> NDArray:
    """The Fourier series ``[a_0, a_1..a_H, b_1..b_H]`` (2H+1, n) at ``tau_j = 2 pi j / n_samples``,
    by inverse real FFT (on a finer grid of m n_samples > 2H + 1 points when n_samples is too few
    to carry H harmonics, of which every m-th point is these instants: exact, no aliasing)."""
    H = (Z.shape[0] - 1) // 2
    m = -(-(2 * H + 2) // n_samples)
    N = m * n_samples
    c = np.zeros((N // 2 + 1, Z.shape[1]), complex)
    c[0] = Z[0]
    c[1:H + 1] = 0.5 * (Z[1:H + 1] - 1j * Z[H + 1:])
    return np.fft.irfft(c, N, axis=0, norm="forward")[::m]


def _variational(system: SecondOrderSystem, cycle: LimitCycle, n_samples: int) -> NDArray:
    """The variational matrix ``A(t)`` (n_samples, 2n, 2n) along the cycle at ``t_j = j T / n_samples``."""
    n = system.n_dof
    Z = cycle.coefficients
    H = cycle.harmonics
    k = np.arange(1, H + 1)[:, None]
    X = _sample(Z, n_samples)
    Xd = cycle.omega * _sample(np.r_[np.zeros((1, n)), k * Z[H + 1:], -k * Z[1:H + 1]], n_samples)  # a_k' = k b_k
    _, dfdx, dfdv, _ = system.force(X, Xd, cycle.p)
    Minv = np.linalg.inv(system.M)
    A = np.zeros((n_samples, 2 * n, 2 * n))
    A[:, :n, n:] = np.eye(n)
    A[:, n:, :n] = Minv @ (dfdx - system.K)
    A[:, n:, n:] = Minv @ (dfdv - system.C)
    return A


def floquet_steps(system: SecondOrderSystem, cycle: LimitCycle, A: NDArray | None = None) -> int:
    """RK4 steps per period for :func:`floquet_multipliers`: ``T rho / 0.1`` (a multiple of 16, at least 64),
    with ``rho`` the largest of ``sqrt(|M^-1 (K - df/dx)|)`` and ``|M^-1 (C - df/dv)|``
    (Frobenius norms) over 64 instants of the cycle: the fastest rate of the variational system."""
    n = system.n_dof
    A = _variational(system, cycle, 64) if A is None else A
    stiff = np.sqrt(np.linalg.norm(A[:, n:, :n], axis=(1, 2)).max())
    damp = np.linalg.norm(A[:, n:, n:], axis=(1, 2)).max()
    rho = max(float(stiff), float(damp), cycle.omega)
    return 16 * max(4, math.ceil(2 * math.pi / cycle.omega * rho / _FLOQUET_STEP / 16))


def floquet_multipliers(system: SecondOrderSystem, cycle: LimitCycle, *, n_floquet: int | None = None) -> NDArray:
    """Floquet multipliers (2n,) of a cycle by the monodromy matrix, largest modulus first,
    the trivial one last.

    The monodromy matrix integrates the variational equations ``Phi' = A(t) Phi`` over one
    period with ``n_floquet`` classical RK4 steps (compiled; default :func:`floquet_steps`),
    ``A(t)`` from the harmonic-balance solution and the force's analytic derivatives.

    Parameters
    ----------
    system : SecondOrderSystem
        The equations the cycle solves.
    cycle : LimitCycle
        The periodic solution.
    n_floquet : int, optional
        RK4 steps per period.

    Returns
    -------
    ndarray, shape (2n,), complex
        All 2n multipliers, sorted by decreasing modulus, with the one nearest 1 (the
        trivial multiplier, the phase shift along the cycle) moved last.
    """
    from ..solvers import ode

    S = floquet_steps(system, cycle) if n_floquet is None else validate_int("n_floquet", n_floquet, 1)
    A = _variational(system, cycle, 2 * S)
    A = np.concatenate([A, A[:1]], axis=0)  # A(T) = A(0)
    Phi = ode.monodromy_rk4(ode.sampled_rhs, np.ascontiguousarray(A), S, 2 * math.pi / cycle.omega / S, A.shape[1])
    rho = np.linalg.eigvals(Phi)
    i = int(np.argmin(np.abs(rho - 1.0)))
    rest = np.delete(rho, i)
    rest = rest[np.argsort(-np.abs(rest))]
    return np.r_[rest, rho[i]]


@dataclass(frozen=True)
class Branch:
    """A continued branch of limit cycles (see :func:`continue_branch`).

    Attributes
    ----------
    cycles : tuple of LimitCycle
        The limit cycles along the branch, in continuation order (``n_points`` of them).
    multipliers : ndarray of complex, shape (n_points, 2 n)
        Floquet multipliers of each cycle (:func:`floquet_multipliers`: largest modulus first,
        the trivial one last).
    stable : ndarray of bool, shape (n_points,)
        Whether every non-trivial multiplier lies in the unit circle (within the error that the
        trivial multiplier's distance from 1 shows).
    tangent_p : ndarray, shape (n_points,)
        ``dp/ds`` of the arclength tangent at each point; a sign change marks a fold.
    folds : tuple of int
        Indices of the points nearest to each fold.
    hopf : HopfPoint
        The Hopf point the branch starts from.
    stop_reason : {"max_points", "corrector_failed", "left_range", "max_amplitude"}
        Why the continuation stopped.
    stop_detail : str
        Where it stopped and why, in one sentence (the parameter, amplitude and contact state of
        the last point; for ``"corrector_failed"`` the smallest residual the correctors reached).
    """

    cycles: tuple[LimitCycle, ...]
    multipliers: NDArray[np.complex128]  # (points, 2n)
    stable: NDArray[np.bool_]
    tangent_p: NDArray[np.float64]  # d p / d s at each point (sign change: fold)
    folds: tuple[int, ...]  # indices of the points nearest to each fold
    hopf: HopfPoint
    stop_reason: str
    stop_detail: str = ""


def _fold_indices(tp: NDArray, p: NDArray, thresh: float = 1e-3, min_turn: float = 0.0) -> tuple[int, ...]:
    """Points of extreme ``p`` between consecutive tangents whose ``dp/ds`` changes sign
    (tangents with ``abs(dp/ds)`` below ``thresh``, e.g. a vertical start, are skipped).

    A fold turns the branch back in ``p``: the point must be an extreme of ``p`` against both its
    neighbours (at a kink of the residual, where an AFT sample opens, the one-sided tangent can change
    sign while ``p`` goes on the same way). Two opposite folds closer in ``p`` than ``min_turn`` (a
    zigzag of the sampled branch, not a turn of the branch) are dropped together.
    """
    sig = [(i, np.sign(t)) for i, t in enumerate(tp) if abs(t) > thresh]
    out: list[int] = []
    for (i, s0), (j, s1) in itertools.pairwise(sig):
        if s0 != s1:
            seg = p[i:j + 1]
            k = i + int(np.argmax(seg) if s0 > 0 else np.argmin(seg))
            turns = 0 < k < p.size - 1 and (min(p[k] - p[k - 1], p[k] - p[k + 1]) > 0 if s0 > 0
                                             else max(p[k] - p[k - 1], p[k] - p[k + 1]) < 0)
            if turns and (not out or out[-1] != k):
                out.append(k)
    kept: list[int] = []
    for k in out:
        if kept and abs(p[k] - p[kept[-1]]) < min_turn:
            kept.pop()
        else:
            kept.append(k)
    return tuple(kept)


def continue_branch(
    system: SecondOrderSystem,
    hopf: HopfPoint,
    p_range: tuple[float, float],
    *,
    harmonics: int = 10,
    step: float | None = None,
    max_points: int = 400,
    amplitude_start: float = 0.05,
    n_floquet: int | None = None,
    max_amplitude: float = 1e3,
    max_turn: float = 0.3,
    stability: str = "monodromy",
) -> Branch:
    """Follow the limit cycles born at ``hopf`` by pseudo-arclength continuation.

    Parameters
    ----------
    system : SecondOrderSystem
    hopf : HopfPoint
        The onset (:func:`~squealkit.nonlinear.hopf.hopf_point`).
    p_range : (float, float)
        The branch is followed while the parameter stays in this range.
    harmonics : int
        Harmonics H of every cycle.
    step : float, optional
        Nominal parameter step (default 1/50 of the range); the arclength unit is this
        step in ``p`` and ``system.length_scale`` in the Fourier coefficients.
    max_points : int
        Largest number of points.
    amplitude_start : float
        First cycle's amplitude, in ``length_scale`` units, on the onset mode.
    n_floquet : int, optional
        RK4 steps of the monodromy matrix per period (default :func:`floquet_steps`).
    max_amplitude : float
        Stop when an amplitude exceeds this many ``length_scale``.
    max_turn : float
        Largest angle [rad] between consecutive tangents (the step is halved otherwise).
    stability : {"monodromy", "hill"}
        How each cycle's Floquet multipliers are computed: the monodromy matrix
        (:func:`floquet_multipliers`) or Hill's method on the harmonic-balance Jacobian
        (:func:`~squealkit.nonlinear.hill.hill_exponents`, symmetry criterion).

    Returns
    -------
    Branch
        With ``stop_reason`` ``"left_range"`` when the branch reached a bound of ``p_range``
        (its last cycle solved on the bound; beyond it, by less than a step, only when no
        fixed-parameter solve on the bound converges), and ``stop_detail`` saying where and why
        it stopped. Every cycle solves the harmonic-balance equations to a scaled residual of
        at most 1e-8.
    """
    lo, hi = (float(v) for v in p_range)
    if not hi > lo:
        raise InputError(f"Parameter range {p_range!r} must be increasing.")
    if stability not in STABILITY_METHODS:
        raise InputError(f"Parameter stability={stability!r} must be one of {', '.join(map(repr, STABILITY_METHODS))}.")
    # small dense solves (n_u ~ 60-130): BLAS threads only wait for each other on shared cores
    with threadpool_limits(1, user_api="blas"):
        return _continue(system, hopf, lo, hi, harmonics=harmonics, step=step, max_points=max_points,
                         amplitude_start=amplitude_start, n_floquet=n_floquet, max_amplitude=max_amplitude,
                         max_turn=max_turn, stability=stability)


#: AFT samples per period, at least, of a branch whose contact may open. Each sample where the contact
#: opens or closes puts a kink in the harmonic-balance residual, of a size ~ 1/samples; next to a
#: vertical onset (a piecewise-linear law) the branch turns at each, and with the default 8 per
#: harmonic (128 at H = 10) the turns defeat the corrector on lightly damped rigs.
CONTACT_SAMPLES = 512
#: Arclength steps, in units of the nominal step: the largest; the one at and below which a corrector
#: that fails is restarted with another constraint (:func:`_restart`); the one below which the branch stops.
_H_MAX, _H_RESTART, _H_MIN = 1.0, 1.0 / 64, 1e-4
#: Steps of a restart (units of the nominal step: ``length_scale`` in the amplitude, ``step`` in p), smallest first.
_RESTART_STEPS = (1.0 / 64, 1.0 / 16, 1.0 / 4)
#: A point is a cycle when the scaled residual (``HBProblem.residual``, per ``k_ref length_scale``) is at most this.
_TOL = 1e-8


def _converged(z: NDArray, nr: float) -> bool:
    return bool(nr <= _TOL and np.all(np.isfinite(z)))


def _arclength_corrector(prob: HBProblem, y0: NDArray, t0: NDArray, h: float, W: NDArray):
    """Newton from ``y0 + h t0`` on the hyperplane orthogonal to ``t0`` (weighted metric ``W^2``)."""
    y_pred = y0 + h * t0
    tw = t0 * W * W

    def fun(z):
        r, J = prob.residual(z)
        return np.append(r, tw @ (z - y_pred)), np.vstack([J, tw])

    return _newton(fun, y_pred, max_iter=12)


def _restart(prob: HBProblem, y0: NDArray, ahead: NDArray, W: NDArray, ia: int, dp_nom: float):
    """A point past a non-smooth spot where the arclength corrector fails for every step.

    Where the contact starts to open at one more AFT sample the residual has a kink; the branch
    turns there (most sharply next to a Hopf point whose cycles are vertical, as a piecewise-linear
    law's are), and the hyperplane orthogonal to the incoming tangent may miss the outgoing piece at
    any step. A fresh Newton from ``y0`` with another constraint, the amplitude ``a_1`` of the phase
    DOF (index ``ia``) or the parameter fixed a small step on, crosses it: each in the direction the
    branch was going, then against it, smallest step first. A candidate is taken if it converges,
    lies ahead (``(z - y0) W^2 ahead > 0``, so it is not the piece already followed) and within two
    nominal steps of ``y0``.

    Returns
    -------
    (z, iterations, residual, Jacobian) or None
    """
    n_u = prob.n_u
    Wa = W * W * ahead
    for d in _RESTART_STEPS:
        for k, delta in ((ia, d), (n_u + 1, d * dp_nom)):
            first = 1.0 if ahead[k] >= 0 else -1.0
            for sign in (first, -first):
                row = np.zeros(n_u + 2)
                row[k] = 1.0
                target = y0[k] + sign * delta

                def fun(z, row=row, target=target, k=k):
                    r, J = prob.residual(z)
                    return np.append(r, z[k] - target), np.vstack([J, row])

                start = y0.copy()
                start[k] = target
                z, it, nr, J = _newton(fun, start, max_iter=20)
                if (_converged(z, nr) and (z - y0) @ Wa > 0
                        and float(np.linalg.norm((z - y0) * W)) <= 2.0):
                    return z, it, nr, J
    return None


def _tangent_at(Jc: NDArray, secant: NDArray, W: NDArray) -> NDArray:
    """Unit tangent (weighted norm) from a bordered Jacobian ``[J; c]``, oriented along ``secant``.

    ``[J; c] t = e_last`` gives the null vector of ``J``; its sign follows the step just taken
    (the secant), not the previous tangent: past a corner of the branch (a kink of the residual)
    the previous tangent may point against the way the branch goes on.
    """
    e_last = np.zeros(Jc.shape[0])
    e_last[-1] = 1.0
    try:
        t = np.linalg.solve(Jc, e_last)
    except np.linalg.LinAlgError:
        t = np.linalg.svd(Jc[:-1] / W[None, :])[2][-1] / W
    t = t / np.linalg.norm(t * W)
    return t if (t * W * W) @ secant >= 0 else -t


def _continue(system, hopf, lo, hi, *, harmonics, step, max_points, amplitude_start, n_floquet, max_amplitude,
              max_turn, stability) -> Branch:
    from .hill import hill_multipliers

    H = validate_int("harmonics", harmonics, 1)
    n = system.n_dof
    dp_nom = (hi - lo) / 50 if step is None else validate_positive("step", step)
    j = int(np.argmax(np.abs(hopf.shape)))
    n_time = n_time_samples(H) if system.contact_open is None else max(n_time_samples(H), CONTACT_SAMPLES)
    prob = HBProblem(system, H, hopf.omega, j, n_time=n_time)
    n_u = prob.n_u
    W = np.r_[np.ones(n_u + 1), 1.0 / dp_nom]  # arclength weights on [u, w, p]
    ia = 1 * n + j  # index of a_1 of the phase DOF in u

    # first point: amplitude fixed on the onset mode, parameter and frequency solved for
    Z = np.zeros((2 * H + 1, n))
    Z[0] = hopf.x_eq
    amp0 = amplitude_start * system.length_scale
    Z[1] = amp0 * hopf.shape.real
    Z[H + 1] = -amp0 * hopf.shape.imag
    y = prob.pack(Z, hopf.omega, hopf.p)
    a_fix = y[ia]

    def fun_amp(z):
        r, J = prob.residual(z)
        row = np.zeros(n_u + 2)
        row[ia] = 1.0
        return np.append(r, z[ia] - a_fix), np.vstack([J, row])

    y, _, nr, _ = _newton(fun_amp, y)
    if not nr <= 1e-8:
        raise InputError(f"No limit cycle found next to the Hopf point (residual {nr:.3g}).")

    r, J = prob.residual(y)
    # null vector of J (n_u+1, n_u+2) in the weighted metric, growing in amplitude
    t = np.linalg.svd(J / W[None, :])[2][-1] / W
    t = t / np.linalg.norm(t * W)
    ys, ts, nrs = [y], [t if t[ia] > 0 else -t], [float(np.linalg.norm(r))]
    h = _H_MAX
    reason = "max_points"
    restarted = False  # a restart was tried since the last point
    best_failed = math.inf  # the smallest residual of the correctors that failed since the last point
    last_turn = math.inf  # the turn of the tangent [rad] at the last step refused for turning too far
    while len(ys) < max_points:
        z, it, nr, Jc = _arclength_corrector(prob, ys[-1], ts[-1], h, W)
        fresh = False
        if not _converged(z, nr):
            best_failed = min(best_failed, nr) if math.isfinite(nr) else best_failed
            if h > _H_RESTART or (restarted and h > _H_MIN):
                h *= 0.5
                continue
            if restarted:
                reason = "corrector_failed"
                break
            restarted = True
            ahead = ys[-1] - ys[max(0, len(ys) - 5)] if len(ys) > 1 else ts[-1]
            out = _restart(prob, ys[-1], ahead, W, ia, dp_nom)
            if out is None:
                h *= 0.5
                continue
            z, it, nr, Jc = out
            fresh = True
        t_new = _tangent_at(Jc, z - ys[-1], W)
        turn = math.acos(min(1.0, max(-1.0, float((t_new * W * W) @ ts[-1]))))
        # the branch turns sharply (a fold, contact loss setting in): smaller steps, unless the turn
        # does not shrink with the step (a corner, where an AFT sample opens: no step rounds it)
        if not fresh and turn > max_turn and h > 1e-3 and not turn > 0.75 * last_turn:
            h *= 0.5
            last_turn = turn
            continue
        restarted, best_failed, last_turn = False, math.inf, math.inf
        p = z[-1]
        if p < lo or p > hi:
            # end exactly on the range's bound: a fixed-parameter solve from the interpolated guess, or from
            # the points on either side; where none converges, a shorter step that stops short of the bound
            # and a solve from nearer; where even that fails, the cycle just found beyond the bound
            edge = hi if p > hi else lo
            frac = (edge - ys[-1][-1]) / (p - ys[-1][-1])
            for guess in (ys[-1] + frac * (z - ys[-1]), ys[-1], z):
                y_e, _, nr_e = solve_fixed_p(prob, np.r_[guess[:-1], edge])
                ok = _converged(y_e, nr_e)
                if ok:
                    break
            if not ok and not fresh and h * frac > _H_RESTART:
                h *= 0.9 * frac
                continue
            ys.append(y_e if ok else z)
            ts.append(t_new)
            nrs.append(nr_e if ok else nr)
            reason = "left_range"
            break
        ys.append(z)
        ts.append(t_new)
        nrs.append(nr)
        h = 4 * _H_RESTART if fresh else min(h * (1.5 if it <= 4 else 1.0 if it <= 7 else 0.6), _H_MAX)
        if np.abs(z[:n_u]).max() > max_amplitude:
            reason = "max_amplitude"
            break
    detail = _stop_detail(system, prob, reason, ys[-1], (lo, hi), max_points=max_points,
                          max_amplitude=max_amplitude, residual=best_failed)
    cycles = []
    mult = []
    for y_i, r in zip(ys, nrs, strict=True):
        c = prob.cycle(y_i, residual=r)
        cycles.append(c)
        mult.append(hill_multipliers(system, c) if stability == "hill"
                    else floquet_multipliers(system, c, n_floquet=n_floquet))
    mult_a = np.array(mult)
    # the trivial multiplier's distance from 1 measures the error of the cycle and of the
    # monodromy product: a non-trivial multiplier must exceed 1 by more than that to count
    err = np.abs(mult_a[:, -1] - 1.0)
    stable = np.abs(mult_a[:, :-1]).max(axis=1) <= 1 + np.maximum(FLOQUET_TOL, 3 * err)
    tp = np.array([t_i[-1] * W[-1] for t_i in ts])
    folds = _fold_indices(tp, np.array([c.p for c in cycles]), min_turn=0.1 * dp_nom)
    return Branch(tuple(cycles), mult_a, stable, tp, folds, hopf, reason, detail)


def _stop_detail(system, prob: HBProblem, reason: str, y: NDArray, p_range: tuple[float, float], *,
                 max_points: int, max_amplitude: float, residual: float) -> str:
    """Where the continuation stopped and why, in one sentence (the attribute ``stop_detail``)."""
    c = prob.cycle(y)
    where = (f"{system.param} = {c.p:.6g} (amplitude {float(np.max(c.amplitude)):.4g} m"
             + (f", contact open over {100 * c.contact_loss_fraction:.1f} % of the period)"
                if math.isfinite(c.contact_loss_fraction) else ")"))
    if reason == "left_range":
        return f"reached the end of the range [{p_range[0]:g}, {p_range[1]:g}] at {where}"
    if reason == "max_points":
        return f"stopped after max_points = {max_points} points at {where}, inside the range"
    if reason == "max_amplitude":
        return f"stopped at {where}: an amplitude exceeded max_amplitude = {max_amplitude:g} length scales"
    return (f"the corrector did not converge beyond {where}: neither arclength steps down to {_H_MIN:g} of the "
            f"nominal step nor a restart with the amplitude or {system.param} fixed a step on "
            f"(smallest residual {residual:.2g}, tolerance {_TOL:g})")

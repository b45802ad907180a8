"""Complex eigenvalue analysis of FE brake models over disc speed and friction.

The FE counterpart of :func:`~squealkit.stability.stability_map`: eigenvalues of an
:class:`~squealkit.fe.model.FEModel` over a grid of disc speed (rpm, ``omega = 2 pi rpm/60``)
and friction ``mu`` (the run-out slope enters as ``mu_e = mu + tan(theta)``), the critical
friction at each speed, and the modes at one operating point with their shapes. Solvers
(``method``): ``dense`` (all modes, LAPACK), ``sparse`` (a frequency band by shift-invert),
``modal`` and ``pod`` (a reduced basis from :mod:`squealkit.solvers.reduction`, every
eigenpair checked by its backward error in the full model), ``subspace`` (the commercial codes'
projection on the real modes of ``(M, K_sym)`` to 1.5 times the band's top, for the largest
models: :mod:`squealkit.solvers.subspace`, also checked in the full model); ``auto`` is dense up
to :data:`DENSE_MAX_DOF` DOFs, sparse above, and subspace where the band solve's estimated
memory does not fit (:mod:`squealkit.solvers.memory`). A reduced basis is built once per sweep
and serves every point; on a Dask cluster it is sent to each worker once.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray
from threadpoolctl import threadpool_limits

from .. import __version__
from .._optional import require
from .._threads import honour_thread_limit, thread_limit
from .._validation import (
    InputError,
    check_budget,
    validate_angle,
    validate_array_finite,
    validate_int,
    validate_model,
    validate_plausible,
    validate_positive,
)
from ..fe.model import FEModel, rpm_to_disc_speed
from ..solvers import reduction
from ..solvers.band import (
    BAND_HZ,
    DENSE_MAX_DOF,
    RESIDUAL_TOL,
    EigenSolution,
    band_eigs,
    dense_eigs,
    dense_parts,
    validate_band,
)
from ..solvers.mac import MacTracker
from ..solvers.subspace import FREQ_MAX_FACTOR, SubspaceBasis, subspace_basis, subspace_eigs
from ._schema import UNSTABLE_RTOL, derived_variables, eigen_variables
from ._solve import VERDICTS

__all__ = ["DENSE_MAX_DOF", "METHODS", "FESolver", "fe_critical_friction", "fe_modes", "fe_stability_map",
           "modes_to_vtk"]

#: Solvers for FE models.
METHODS = ("auto", "dense", "sparse", "modal", "pod", "subspace")
#: Safety factor on backward error x |lambda| for a well-conditioned eigenvalue's error radius.
_ERR_C = 16.0


@dataclass
class FESolver:
    """One FE model prepared for repeated solves by one method (reduced basis, dense parts).

    Parameters
    ----------
    model : FEModel
    method : {"auto", "dense", "sparse", "modal", "pod"}
    band : (float, float) or None
        Frequency band [Hz] of interest; ``sparse`` needs one (default 1-16 kHz), the
        others keep all modes without one.
    n_modes : int, optional
        Basis size for ``modal``/``pod``.
    samples : (omegas, mus), optional
        Operating points the ``pod`` basis is built from (``mus`` with the run-out slope added:
        the friction the friction matrices see).
    sigma_reach : float
        For ``sparse``: find every mode in the band with ``|sigma|`` up to this [1/s].
    band_workers : int, optional
        For ``sparse``: sub-bands solved at once (:func:`~squealkit.solvers.band.band_eigs`'s
        ``workers``); 1 where operating points are already solved in parallel.
    """

    model: FEModel
    method: str = "auto"
    band: tuple[float, float] | None = None
    n_modes: int | None = None
    samples: tuple[NDArray, NDArray] | None = None
    sigma_reach: float = 0.0
    band_workers: int | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.model, FEModel):
            raise InputError(f"An FE solver needs an FEModel, got {type(self.model).__name__}.")
        if self.method not in METHODS:
            raise InputError(f"Parameter method={self.method!r}; known: {', '.join(METHODS)}.")
        if self.method == "auto":
            self.method = "dense" if self.model.n_dof <= DENSE_MAX_DOF else _sparse_or_subspace(self.model)
        if self.band is not None:
            self.band = validate_band(self.band)
        elif self.method in ("sparse", "modal", "pod", "subspace"):
            # a band solve, and a reduced basis (built for the band: outside it the reduced
            # eigenvalues are not the brake's), look at the squeal band unless told otherwise
            self.band = BAND_HZ
        if self.n_modes is not None:
            self.n_modes = validate_int("n_modes", self.n_modes, 1)
        self.sigma_reach = validate_positive("sigma_reach", self.sigma_reach, allow_zero=True)
        self.reduced = reduction.reduce(self.model, self._basis()) if self.method in ("modal", "pod") else None
        self.subspace = None
        if self.method == "subspace":
            basis = subspace_basis(self.model, freq_max=FREQ_MAX_FACTOR * self.band[1])
            if self.n_modes is not None:  # the lowest n_modes of them (the projected matrices are their blocks)
                r = min(int(self.n_modes), basis.n_modes)
                top = float(basis.frequency_hz[r - 1]) if r else 0.0
                basis = SubspaceBasis(basis.V[:, :r], basis.frequency_hz[:r], top,
                                      {k: v[:r, :r] for k, v in basis.mats.items()}, basis.backend)
            self.subspace = basis
        self.parts = dense_parts(self.model) if self.method == "dense" else None

    def _basis(self) -> NDArray[np.float64]:
        """The reduced basis of ``modal`` (real modes of (M, K1) up to 1.5 times the band's top,
        or ``n_modes`` of them) or ``pod`` (real modes, eigenvectors at the sample points and
        left corrections, compressed: :func:`~squealkit.solvers.reduction.pod_basis`)."""
        if self.method == "modal":
            fmax = None if self.n_modes is not None else 1.5 * self.band[1]
            return np.asarray(reduction.modal_basis(self.model, n_modes=self.n_modes, freq_max=fmax))
        if self.samples is None:
            raise InputError("method 'pod' needs sample operating points (omegas, mus).")
        # the recipe of benchmarks/bench_fe_reduction.py: real modes to 1.25x the band's top, the
        # samples' eigenvectors and the left corrections, compressed together
        modal = reduction.modal_basis(self.model, freq_max=1.25 * self.band[1])
        V = np.asarray(reduction.pod_basis(self.model, *self.samples, band=self.band, extra=modal))
        return V if self.n_modes is None else V[:, : self.n_modes]

    def solve(self, omega: float, mu: float, tan_theta: float = 0.0, *, vectors: bool = True) -> EigenSolution:
        """Eigenvalues (and right eigenvectors in the full model's DOFs) at one operating point.

        Reduced methods solve the projected model and check each pair in the full model by its
        backward error, from the basis' residual factor (no full-size product per point).
        """
        if self.method == "sparse":
            return band_eigs(self.model, omega, mu, tan_theta=tan_theta, band=self.band, sigma_reach=self.sigma_reach,
                             workers=self.band_workers)
        if self.subspace is not None:
            return subspace_eigs(self.model, omega, mu, tan_theta=tan_theta, band=self.band, basis=self.subspace,
                                 vectors=vectors)
        if self.reduced is not None:
            self.model.factors(omega, mu, tan_theta)  # the same checks of omega, mu and tan_theta
            lam, Y, res = reduction.reduced_solve(self.reduced, omega, mu + tan_theta, *self.band)
            return EigenSolution(lam, self.reduced.V @ Y if vectors else None, res)
        sol = dense_eigs(self.model, omega, mu, tan_theta=tan_theta, vectors=vectors, parts=self.parts)
        if self.band is None:
            return sol
        f = sol.eigenvalues.imag / (2 * math.pi)
        keep = (f >= self.band[0]) & (f <= self.band[1])
        return EigenSolution(sol.eigenvalues[keep], sol.vectors[:, keep] if vectors else None, sol.residuals[keep])


def _sparse_or_subspace(model: FEModel) -> str:
    """``"sparse"``, or ``"subspace"`` where even one walk of the band solve would not fit in memory."""
    from ..solvers.memory import band_memory, memory_limit

    nnz = max(getattr(getattr(model, name), "nnz", model.n_dof**2) for name in model.present)  # ~ the union
    fits = band_memory(model.n_dof, nnz, k=24, workers=1) <= memory_limit()
    return "sparse" if fits else "subspace"


def _validate_grid(name: str, values: ArrayLike) -> NDArray[np.float64]:
    a = np.atleast_1d(validate_array_finite(name, values))
    if a.ndim != 1:
        raise InputError(f"Parameter {name} must be a 1-D grid (or a number).")
    return a


def _check_work(model: FEModel, method: str, what: str, points: float, solves: float) -> None:
    """Refuse an FE sweep beyond the run's budget before any solve (:func:`~squealkit._validation.check_budget`).

    A lower bound of one operating point's cost: a dense solve of the 2n x 2n pencil (about
    25 (2n)^3 flops at 1e11 flop/s), at least 1 ms for a sparse band solve, 0.1 ms for a
    reduced one; at least 200 bytes of results per point.
    """
    n = model.n_dof
    if method == "auto":
        method = "dense" if n <= DENSE_MAX_DOF else "sparse"
    per = {"dense": max(1e-5, 2.5e-10 * (2 * n) ** 3), "sparse": 1e-3}.get(method, 1e-4)
    check_budget(what, points=points, nbytes=200.0 * points, seconds=solves * per / thread_limit(),
                 hint="Use fewer points (--rpm/--mu START:STOP:N).")


def _tan_theta(theta: float) -> float:
    return math.tan(validate_angle("theta", theta))


@honour_thread_limit
def fe_stability_map(
    model: FEModel,
    rpm: ArrayLike,
    mu: ArrayLike | None = None,
    theta: float = 0.0,
    *,
    method: str = "auto",
    band: tuple[float, float] | None = None,
    n_modes: int | None = None,
    sigma_reach: float = 0.0,
    track: bool = True,
    lock_in_rtol: float = 1e-3,
    workers: int | None = None,
    client: Any = None,
    progress: Callable[[int, int], None] | None = None,
) -> xr.Dataset:
    """Complex eigenvalues of an FE brake model over disc speed and friction.

    Parameters
    ----------
    model : FEModel
    rpm : array_like, 1-D
        Disc speeds [rev/min]; ``omega = 2 pi rpm / 60`` [rad/s] enters the model.
    mu : array_like, 1-D, optional
        Friction coefficients (default: the model's ``mu_ref``).
    theta : float
        Run-out incline [rad]: ``mu_e = mu + tan(theta)`` replaces mu in ``KR`` and ``DR``.
    method : {"auto", "dense", "sparse", "modal", "pod", "subspace"}
        Solver (module docstring). ``pod`` builds its basis from the middle speed at the first and
        last friction (plus the real modes and left corrections).
    band : (float, float), optional
        Frequency band [Hz]: only modes in it are reported (``sparse``: default 1-16 kHz).
    n_modes : int, optional
        Reduced basis size for ``modal``/``pod``.
    sigma_reach : float
        ``sparse`` only: see :func:`~squealkit.solvers.band.band_eigs`.
    track : bool
        Follow each mode across the grid by MAC on its right eigenvector; otherwise modes
        are ordered by frequency at each point and no eigenvectors are computed (faster).
    lock_in_rtol : float
        Relative frequency tolerance for the ``lock_in`` flag (as for
        :func:`~squealkit.stability.stability_map`).
    workers : int, optional
        Points solved at once (threads; LAPACK and SuperLU release the GIL); default: the
        thread limit of :mod:`squealkit._threads`.
    client : distributed.Client, optional
        Solve the rpm rows on this Dask cluster (one task per row, after the first column
        here): the same numbers as the local run. The solver, with its reduced basis, is
        built here once and sent to each worker once (scattered), shared by all rows.
    progress : callable, optional
        ``progress(done, total)`` with point counts.

    Returns
    -------
    xarray.Dataset
        Dims ``(rpm, mu, mode)``, with the variables of
        :func:`~squealkit.stability.stability_map` (``growth_rate``, ``omega``, ``frequency_hz``,
        ``damping_ratio``, ``growth_rate_error``, ``unstable``, ``verdict``,
        ``max_growth_rate``, ``any_unstable``, ``lock_in``) and ``residual`` (backward error
        of each eigenpair; above ``residual_tol`` the reduced answer is not to be trusted),
        ``trusted``. Coordinates ``rpm``, ``disc_speed`` [rad/s], ``mu``, ``mu_e``, scalar
        ``theta``, ``theta_deg``, ``tan_theta``. Modes are tracked across the grid by MAC
        on the right eigenvectors (first column along rpm, then each row along mu); a mode
        that enters the band gets a new index, and is NaN where it is outside.

    Examples
    --------
    >>> from squealkit.fe import load_fe_model
    >>> from squealkit.data import nlevp_path
    >>> ds = fe_stability_map(load_fe_model(nlevp_path()), rpm=[60.0, 120.0], mu=[0.5, 1.0])
    >>> sorted(ds.sizes.items())
    [('mode', 100), ('mu', 2), ('rpm', 2)]
    """
    validate_model(model, kind="fe")
    rpm_a = _validate_grid("rpm", rpm)
    mu_a = _validate_grid("mu", model.mu_ref if mu is None else mu)
    t = _tan_theta(theta)
    n_r, n_m = rpm_a.size, mu_a.size
    _check_work(model, method, f"An FE map of {n_r} speeds x {n_m} frictions", float(n_r) * n_m, float(n_r) * n_m)
    omegas = rpm_to_disc_speed(rpm_a)
    samples = None
    if method == "pod":
        # benchmarks/bench_fe_reduction.py's samples: the middle speed, the first and last friction
        # (with the real modes and left corrections: 1e-7 over 200-1500 rpm x mu 0.3-0.6 on the
        # built-in brake); the residuals say where a grid reaches further than that
        samples = (omegas[[len(omegas) // 2]], np.unique(mu_a[[0, len(mu_a) - 1]]) + t)  # pod_basis takes mu_e
    n_r, n_m = rpm_a.size, mu_a.size
    workers = thread_limit() if workers is None else max(1, int(workers))
    # points in parallel, or a single point's sub-bands in parallel: never both
    solver = FESolver(model, method, band, n_modes, samples, sigma_reach, band_workers=1 if n_r * n_m > 1 else None)
    results: dict[tuple[int, int], tuple[NDArray, NDArray, NDArray]] = {}
    tracker = MacTracker()
    total, done = n_r * n_m, 0

    def solve(ij):
        return solver.solve(omegas[ij[0]], mu_a[ij[1]], t, vectors=track)

    def record(ij, sol, prev):
        if not track:
            slots = np.arange(sol.eigenvalues.size)
            tracker.n_slots = max(tracker.n_slots, slots.size)
        else:
            lam = sol.eigenvalues
            slots = tracker.first(lam.size) if prev is None else tracker.match(prev, lam, sol.vectors)
        results[ij] = (slots, sol.eigenvalues, sol.residuals)
        return slots, sol.eigenvalues, sol.vectors

    # one BLAS thread per point: parallel points beat threaded LAPACK on 2n <= a few thousand,
    # and threaded BLAS on busy cores stalls (measured 10x slower on a loaded 2-core machine)
    with ThreadPoolExecutor(max_workers=workers) as pool, threadpool_limits(1, user_api="blas"):
        column = list(pool.map(solve, [(i, 0) for i in range(n_r)]))
        firsts = []
        prev = None
        for i, sol in enumerate(column):
            prev = record((i, 0), sol, prev)
            firsts.append(prev)
        done += n_r
        if progress is not None:
            progress(done, total)
        if client is not None:
            from ..scale import map_tasks

            # the solver with its basis (and the model) goes to every worker once, not once per row
            shared = client.scatter(solver, broadcast=True, hash=False)
            items = [(shared, omegas[i], mu_a, t, firsts[i], track) for i in range(n_r)]
            rows = dict(map_tasks(_row_task, items, client=client, name="squealkit-fe-rows",
                                  progress=None if progress is None else lambda d, _t: progress(n_r + d, total),
                                  weights=[n_m - 1] * n_r))
            for i in range(n_r):  # new modes numbered in row order: the numbers of the local run
                fresh: dict[int, int] = {}
                for j, (slots, lam, res) in enumerate(rows[i], start=1):
                    if track:
                        for k in np.flatnonzero(slots >= _PROVISIONAL):
                            if slots[k] not in fresh:
                                fresh[int(slots[k])] = tracker.n_slots
                                tracker.n_slots += 1
                            slots[k] = fresh[int(slots[k])]
                    else:
                        tracker.n_slots = max(tracker.n_slots, slots.size)
                    results[(i, j)] = (slots, lam, res)
        for i in range(n_r if client is None else 0):
            prev = firsts[i]
            todo = [(i, j) for j in range(1, n_m)]
            for a in range(0, len(todo), 4 * workers):  # bounded memory: a few points' vectors at a time
                chunk = todo[a:a + 4 * workers]
                for ij, sol in zip(chunk, pool.map(solve, chunk), strict=True):
                    prev = record(ij, sol, prev)
                done += len(chunk)
                if progress is not None:
                    progress(done, total)
    # at least one (NaN) mode: a band without eigenvalues gives a map that is stable everywhere
    return _fe_dataset(solver, rpm_a, omegas, mu_a, theta, t, results, max(1, tracker.n_slots), tracked=track,
                       lock_in_rtol=lock_in_rtol)


#: Provisional indices of modes that enter the band inside a row computed on a worker.
_PROVISIONAL = 1 << 40


def _row_task(item: tuple) -> list[tuple[NDArray, NDArray, NDArray]]:
    """One rpm row of an FE map after its first point (a Dask task): solved and tracked along mu.

    Modes new to the row get provisional indices from ``_PROVISIONAL`` up, renumbered by the caller.
    """
    solver, omega, mus, t, first, track = item
    tracker = MacTracker()
    tracker.n_slots = _PROVISIONAL
    out = []
    prev = first
    with threadpool_limits(1, user_api="blas"):
        for mu in mus[1:]:
            sol = solver.solve(omega, mu, t, vectors=track)
            slots = tracker.match(prev, sol.eigenvalues, sol.vectors) if track else np.arange(sol.eigenvalues.size)
            prev = (slots, sol.eigenvalues, sol.vectors)
            out.append((slots, sol.eigenvalues, sol.residuals))
    return out


def _point_arrays(lam: NDArray, res: NDArray, valid: NDArray):
    """Per-mode error radii and flags, and the point's verdict code (as in ``_solve.VERDICTS``)."""
    mag = np.where(valid, np.abs(lam), 0.0)
    thr = UNSTABLE_RTOL * np.max(mag, axis=-1, initial=0.0)
    err = _ERR_C * np.maximum(res, np.finfo(float).eps) * mag
    sigma = lam.real
    # a reduced eigenpair whose backward error in the full model is above RESIDUAL_TOL is not an
    # eigenpair of the brake: it can make a point indeterminate, never unstable
    trusted = ~(res > RESIDUAL_TOL)
    with np.errstate(invalid="ignore"):
        unstable = valid & trusted & (sigma - err > thr[..., None])
        maybe = (np.abs(sigma - thr[..., None]) <= err) | (~trusted & (sigma + err > thr[..., None]))
        unsure = valid & ~unstable & maybe
    real = np.abs(lam.imag) <= 1e-12 * mag
    flutter = np.any(unstable & ~real, axis=-1)
    diverge = np.any(unstable & real, axis=-1)
    verdict = np.where(flutter, 1, np.where(diverge, 2, np.where(np.any(unsure, axis=-1), 3, 0))).astype(np.int8)
    return err, unstable, verdict, thr


def _fe_dataset(solver, rpm, omegas, mu, theta, t, results, n_slots, *, tracked: bool,
                lock_in_rtol: float = 1e-3) -> xr.Dataset:
    n_r, n_m = rpm.size, mu.size
    lam = np.full((n_r, n_m, n_slots), np.nan + 1j * np.nan)
    res = np.full((n_r, n_m, n_slots), np.nan)
    for (i, j), (slots, ev, r) in results.items():
        lam[i, j, slots] = ev
        res[i, j, slots] = r
    valid = np.isfinite(lam)
    # no residual (eigenvalues without vectors): LAPACK's QR is backward stable, eta ~ eps
    err, _unstable, verdict, thr = _point_arrays(np.where(valid, lam, 0.0), np.where(np.isfinite(res), res, 0.0),
                                                 valid)
    err = np.where(valid, err, np.nan)
    # the small models' kernel for the derived quantities; modes outside the band (NaN) are
    # never unstable nor locked in, their damping ratio NaN and the largest growth rate skips them
    sigma, omega, zeta, unstable, _smax, any_u, locked = derived_variables(lam, err, thr, verdict, lock_in_rtol)
    zeta = np.where(valid, zeta, np.nan)
    smax = np.max(np.where(valid, sigma, -np.inf), axis=-1, initial=-np.inf)
    dims = ("rpm", "mu", "mode")
    model = solver.model
    ds = xr.Dataset(
        data_vars={
            **eigen_variables(dims, sigma, omega, zeta, err, unstable, verdict, smax, any_u, locked, lock_in_rtol,
                               err_name="error radius of the eigenvalue (16 x backward error x |lambda|)"),
            "residual": (dims, res, {"units": "1", "long_name": "backward error of the eigenpair in the full model"}),
            "trusted": (dims, valid & ~(res > RESIDUAL_TOL),
                        {"long_name": "backward error below residual_tol (or not computed: dense, no vectors)"}),
        },
        coords={
            "rpm": ("rpm", rpm, {"units": "1/min", "long_name": "disc speed"}),
            "disc_speed": ("rpm", omegas, {"units": "rad/s", "long_name": "disc speed 2 pi rpm/60"}),
            "mu": ("mu", mu, {"units": "1", "long_name": "friction coefficient"}),
            "mu_e": ("mu", mu + t, {"units": "1", "long_name": "equivalent friction mu + tan(theta)"}),
            "theta": ((), float(theta), {"units": "rad", "long_name": "run-out incline angle"}),
            "theta_deg": ((), math.degrees(theta), {"units": "deg", "long_name": "run-out incline angle"}),
            "tan_theta": ((), t, {"units": "1", "long_name": "run-out slope"}),
            "mode": ("mode", np.arange(n_slots),
                     {"long_name": "mode index (tracked by MAC)" if tracked else "mode index (by frequency)"}),
        },
        attrs={
            "kind": "fe_stability_map",
            "title": "Complex eigenvalues of an FE brake model over disc speed and friction",
            "model": model.to_json(),
            "model_kind": model.kind,
            "method": solver.method,
            "band_hz": list(solver.band) if solver.band is not None else "all",
            "basis_size": 0 if solver.reduced is None else solver.reduced.n_reduced,
            "damped": 1,
            "tracked": int(tracked),
            "unstable_rtol": UNSTABLE_RTOL,
            "residual_tol": RESIDUAL_TOL,
            "reference": "C(omega, mu) = D1 + (mu_e/mu_ref)(omega_ref/omega) DR + (omega/omega_ref) DG + D4/f_ref; "
                         "K = K1 + (mu_e/mu_ref) KR + (omega/omega_ref)^2 KGeo (Graebner et al., ZAMM 2016)",
            "squealkit_version": __version__,
        },
    )
    return ds


def _max_unstable(solver: FESolver, omega: float, mu: float, t: float) -> tuple[bool, float, float]:
    """Whether the point is unstable, its largest growth rate and that mode's frequency [Hz]."""
    sol = solver.solve(omega, mu, t, vectors=False)
    lam = sol.eigenvalues
    if lam.size == 0:
        return False, -math.inf, math.nan
    res = np.where(np.isfinite(sol.residuals), sol.residuals, 0.0)
    verdict = _point_arrays(lam, res, np.ones(lam.size, bool))[2]
    k = int(np.argmax(lam.real))
    return bool(verdict in (1, 2)), float(lam.real[k]), float(lam.imag[k] / (2 * math.pi))


def _onsets(solver: FESolver, omegas: NDArray, grid: NDArray, t: float, xtol: float):
    """Scan ``grid`` at each speed, bisect the first stable-to-unstable step."""
    mu_c = np.full(omegas.size, np.nan)
    freq = np.full(omegas.size, np.nan)
    status = []
    for i, w in enumerate(omegas):
        prev = None
        found = False
        for j, m in enumerate(grid):
            u, _s, f = _max_unstable(solver, w, m, t)
            if u:
                found = True
                if j == 0:
                    status.append("unstable_at_start")
                    mu_c[i], freq[i] = 0.0, f
                    break
                lo, hi = prev, m
                f_hi = f
                while hi - lo > xtol:
                    mid = 0.5 * (lo + hi)
                    um, _sm, fm = _max_unstable(solver, w, mid, t)
                    if um:
                        hi, f_hi = mid, fm
                    else:
                        lo = mid
                status.append("onset")
                mu_c[i], freq[i] = hi, f_hi
                break
            prev = m
        if not found:
            status.append("stable_in_range")
    return mu_c, freq, status


@honour_thread_limit
def fe_critical_friction(
    model: FEModel,
    rpm: ArrayLike,
    *,
    mu_max: float | None = None,
    theta: float = 0.0,
    mu_operating: float | None = None,
    n_scan: int = 41,
    xtol: float = 1e-6,
    method: str = "auto",
    band: tuple[float, float] | None = None,
    n_modes: int | None = None,
) -> xr.Dataset:
    """Critical friction at each disc speed: the least mu in ``[0, mu_max]`` where the brake is unstable.

    A scan of ``n_scan`` friction values, then bisection of the first stable-to-unstable
    step to ``xtol``. A window narrower than the scan step can be missed (use a finer
    ``n_scan``). With ``mu_operating`` the run-out tolerance follows from ``mu_e = mu + tan(theta)``:
    the largest slope ``tan_theta_max = mu_e_critical - mu_operating`` the brake stays stable with.

    Parameters
    ----------
    model : FEModel
        The FE brake model.
    rpm : array_like, 1-D
        Disc speeds [rev/min].
    mu_max : float, optional
        Upper end of the friction range searched (default ``2 mu_ref`` of the model).
    theta : float, default 0.0
        Run-out incline [rad]; ``mu_e = mu + tan(theta)`` enters the model.
    mu_operating : float, optional
        Operating friction for the run-out tolerance ``tan_theta_max``.
    n_scan : int, default 41
        Friction values of the scan over ``[0, mu_max]``, >= 2.
    xtol : float, default 1e-6
        Absolute tolerance of the bisection in mu.
    method : {"auto", "dense", "sparse", "modal", "pod"}, default "auto"
        Solver (see :func:`fe_stability_map` and the module docstring); ``pod`` builds its
        basis from the middle speed at friction 0, ``mu_max / 2`` and ``mu_max``.
    band : (float, float), optional
        Frequency band [Hz]: only modes in it count (``sparse``: default 1-16 kHz).
    n_modes : int, optional
        Reduced basis size for ``modal``/``pod``.

    Returns
    -------
    xarray.Dataset
        Over ``rpm``: ``mu_critical`` (NaN if stable in range), ``mu_e_critical``
        (``mu_critical + tan(theta)``), ``omega_rad_s`` and ``frequency_hz`` of the mode that
        loses stability, ``status`` (indices into ``ONSET_STATUS``, named by its
        ``flag_meanings``: ``onset``, ``unstable_at_start``, ``stable_in_range``) and, with
        ``mu_operating``, ``tan_theta_max`` and ``theta_max_deg``: the variables of
        :func:`~squealkit.stability.critical_friction_curve` and of
        :meth:`CriticalFriction.to_dataset() <squealkit.stability.CriticalFriction.to_dataset>`.

    Examples
    --------
    >>> from squealkit.fe import FEModel
    >>> m = FEModel.from_matrices(M=np.eye(2), K1=np.diag([1.0, 1.2]), KR=[[0.0, 1.0], [-1.0, 0.0]])
    >>> float(fe_critical_friction(m, [60.0], mu_max=1.0).mu_critical[0].round(4))  # 2 |KR12| mu = 1.2 - 1
    0.1
    """
    validate_model(model, kind="fe")
    rpm_a = _validate_grid("rpm", rpm)
    mu_max = validate_plausible("mu_max", validate_positive("mu_max", 2.0 * model.mu_ref if mu_max is None else mu_max),
                                "friction")
    t = _tan_theta(theta)
    n_scan = validate_int("n_scan", n_scan, 2)
    _check_work(model, method, f"An FE onset search at {rpm_a.size} speeds", rpm_a.size, rpm_a.size * float(n_scan))
    omegas = rpm_to_disc_speed(rpm_a)
    # the middle speed, as fe_stability_map; three frictions over the search range (one band
    # solve per speed instead cost as much as the searches it was to speed up)
    samples = (omegas[[len(omegas) // 2]], np.array([0.0, mu_max / 2, mu_max]) + t) if method == "pod" else None
    solver = FESolver(model, method, band, n_modes, samples)
    grid = np.linspace(0.0, mu_max, int(n_scan))
    from ._windows import ONSET_STATUS
    from .critical import onset_status_variable

    with threadpool_limits(1, user_api="blas"):
        mu_c, freq, status = _onsets(solver, omegas, grid, t, xtol)
    ds = xr.Dataset(
        {
            "mu_critical": ("rpm", mu_c, {"units": "1", "long_name": "critical friction coefficient"}),
            "mu_e_critical": ("rpm", mu_c + t, {"units": "1", "long_name": "critical equivalent friction mu + tan"}),
            "omega_rad_s": ("rpm", 2 * math.pi * freq, {"units": "rad/s", "long_name": "frequency at onset"}),
            "frequency_hz": ("rpm", freq, {"units": "Hz", "long_name": "frequency at onset"}),
            "status": onset_status_variable("rpm", [ONSET_STATUS.index(s) for s in status]),
        },
        coords={"rpm": ("rpm", rpm_a, {"units": "1/min", "long_name": "disc speed"}),
                "disc_speed": ("rpm", omegas, {"units": "rad/s", "long_name": "disc speed 2 pi rpm/60"}),
                "theta": ((), float(theta), {"units": "rad"}), "tan_theta": ((), t)},
        attrs={"kind": "fe_critical_friction", "method": solver.method, "mu_max": mu_max, "n_scan": int(n_scan),
               "xtol": xtol,
               "model": model.to_json(), "model_kind": model.kind},
    )
    if mu_operating is not None:
        tmax = mu_c + t - mu_operating
        ds["tan_theta_max"] = ("rpm", tmax, {"units": "1", "long_name": "largest run-out slope tolerated at mu"})
        ds["theta_max_deg"] = ("rpm", np.degrees(np.arctan(tmax)), {"units": "deg"})
        ds.attrs["mu_operating"] = float(mu_operating)
    return ds


@honour_thread_limit
def fe_modes(
    model: FEModel,
    rpm: float,
    mu: float | None = None,
    theta: float = 0.0,
    *,
    method: str = "auto",
    band: tuple[float, float] | None = None,
    n_modes: int | None = None,
    unstable_only: bool = False,
) -> xr.Dataset:
    """Modes of an FE model at one operating point, with their right eigenvectors (shapes).

    Parameters
    ----------
    model : FEModel
        The FE brake model.
    rpm : float
        Disc speed [rev/min].
    mu : float, optional
        Friction coefficient (default: the model's ``mu_ref``).
    theta : float, default 0.0
        Run-out incline [rad]; ``mu_e = mu + tan(theta)`` enters the model.
    method : {"auto", "dense", "sparse", "modal", "pod"}, default "auto"
        Solver (see :func:`fe_stability_map` and the module docstring).
    band : (float, float), optional
        Frequency band [Hz]: only modes in it count (``sparse``: default 1-16 kHz).
    n_modes : int, optional
        Reduced basis size for ``modal``/``pod``.
    unstable_only : bool, default False
        Keep only the unstable modes.

    Returns
    -------
    xarray.Dataset
        Over ``mode``: ``eigenvalue_real``, ``eigenvalue_imag`` [1/s], ``growth_rate``,
        ``frequency_hz`` [Hz], ``damping_ratio``, ``unstable``, ``residual``; over
        ``(dof, mode)``: ``shape_real``, ``shape_imag`` (largest amplitude 1, real there).
        Attributes ``verdict``, ``rpm``, ``mu``, ``theta``.
    """
    validate_model(model, kind="fe")
    rpm = float(_validate_grid("rpm", rpm)[0])
    mu = float(model.mu_ref if mu is None else mu)
    t = _tan_theta(theta)
    omega = float(rpm_to_disc_speed(rpm))
    samples = (np.array([omega]), np.array([mu + t])) if method == "pod" else None
    solver = FESolver(model, method, band, n_modes, samples)
    with threadpool_limits(1, user_api="blas"):
        sol = solver.solve(omega, mu, t)
    lam, X, res = sol.eigenvalues, sol.vectors, sol.residuals
    err, unstable, verdict, _ = _point_arrays(lam, res, np.ones(lam.size, bool))
    if unstable_only:
        lam, X, res, unstable, err = lam[unstable], X[:, unstable], res[unstable], unstable[unstable], err[unstable]
    if X.shape[1]:
        peak = X[np.argmax(np.abs(X), axis=0), np.arange(X.shape[1])]
        X = X / peak
    mag = np.abs(lam)
    return xr.Dataset(
        {
            "eigenvalue_real": ("mode", lam.real, {"units": "1/s"}),
            "eigenvalue_imag": ("mode", lam.imag, {"units": "1/s"}),
            "growth_rate": ("mode", lam.real, {"units": "1/s"}),
            "frequency_hz": ("mode", lam.imag / (2 * math.pi), {"units": "Hz"}),
            "damping_ratio": ("mode", np.where(mag > 0, -lam.real / np.where(mag > 0, mag, 1), 0.0), {"units": "1"}),
            "unstable": ("mode", unstable),
            "residual": ("mode", res, {"long_name": "backward error in the full model"}),
            "growth_rate_error": ("mode", err, {"units": "1/s"}),
            "shape_real": (("dof", "mode"), X.real),
            "shape_imag": (("dof", "mode"), X.imag),
        },
        coords={"mode": np.arange(lam.size), "dof": list(model.dof_names)},
        attrs={"kind": "fe_modes", "verdict": VERDICTS[int(verdict)], "rpm": rpm, "disc_speed": omega, "mu": mu,
               "theta": float(theta),
               "tan_theta": t, "method": solver.method, "model": model.to_json(), "model_kind": model.kind},
    )


def modes_to_vtk(ds: xr.Dataset, model: FEModel, path: Any, *, energy: xr.Dataset | None = None,
                 n_frames: int = 16) -> None:
    """Write mode shapes with the model's mesh (a ``meshio.Mesh``) to a VTK file (needs meshio).

    The model's DOFs are the mesh points' displacement components in order (``n_dof = 3 x
    points`` or ``= points``), or are named ``node{k}.x``/``.y``/``.z`` (as the FE demo names
    them): such a DOF goes to point k, DOFs on other nodes (mid-side nodes) are left out and
    points without DOFs (clamped) are at rest. Each mode k (its number in ``ds``) becomes point
    data ``mode{k}_re``/``_im`` (the phase animation in ParaView: warp by
    ``mode{k}_re * cos(phi) - mode{k}_im * sin(phi)``) and, with ``energy`` (its
    :func:`~squealkit.fe.energy.mode_energy`), ``mode{k}_friction_work``: the friction work per
    cycle through each node [J].

    A path ending in ``.pvd`` writes the phase animation as a time series instead: a ParaView
    collection whose time is the phase [deg], over ``n_frames`` files in the folder
    ``<stem>_frames`` beside it, each with the displacement ``mode{k}`` = Re(phi e^{j phase})
    of every mode (and its friction work): open the ``.pvd``, Warp By Vector, press play.

    Parameters
    ----------
    ds : xarray.Dataset
        Mode shapes: :func:`fe_modes` (``shape_real``, ``shape_imag`` over ``(dof, mode)``), or a
        selection of its modes.
    model : FEModel
        The model the modes are of, with a mesh (``model.mesh``).
    path : str or Path
        A ``.vtu`` (or any VTK file meshio writes), or a ``.pvd`` for the phase animation.
    energy : xarray.Dataset, optional
        :func:`~squealkit.fe.energy.mode_energy` of the same modes: adds the friction work per node.
    n_frames : int, default 16
        Frames per cycle of a ``.pvd`` animation.

    Returns
    -------
    None
        The file (and for ``.pvd`` its frames' folder) is written atomically.
    """
    from ..io import atomic_path

    if model.mesh is None:
        raise InputError("The model has no mesh: mode shapes can be exported only with one.")
    from ..fe.mesh import FEMesh
    from ..fe.surface import dof_places

    fe_mesh = model.mesh if isinstance(model.mesh, FEMesh) else None
    mesh = fe_mesh.to_meshio() if fe_mesh is not None else model.mesh
    n_pts = len(mesh.points)
    dof, point, c = dof_places(model)  # one placement for every view of the modes on the mesh
    meshio = require("meshio", "Writing mode shapes to VTK")

    data = {} if fe_mesh is None else {"node_label": fe_mesh.node_labels}  # the FE code's labels, for lookups
    numbers = ds["mode"].values
    for k in range(ds.sizes["mode"]):
        for part in ("real", "imag"):
            v = np.zeros((n_pts, 3))
            v[point, c] = ds[f"shape_{part}"].values[dof, k]
            data[f"mode{numbers[k]}_{part[:2]}"] = v
        if energy is not None:
            work = np.nan_to_num(energy["friction_work_dof"].sel(mode=numbers[k]).values)
            w = np.zeros(n_pts)
            np.add.at(w, point, work[dof])
            data[f"mode{numbers[k]}_friction_work"] = w
    from pathlib import Path

    target = Path(path)
    if target.suffix.lower() != ".pvd":
        out = meshio.Mesh(mesh.points, mesh.cells, point_data=data)
        with atomic_path(target) as tmp:
            out.write(tmp, file_format="vtu")
        return
    n_frames = validate_int("n_frames", n_frames, 2)
    from ..io import outputs_together

    frames = target.with_name(f"{target.stem}_frames")
    phases = 360.0 * np.arange(int(n_frames)) / int(n_frames)
    rows = []
    with outputs_together():
        with atomic_path(frames, directory=True) as stage:
            stage.mkdir()
            for i, phase in enumerate(phases):
                turn = np.exp(1j * math.radians(phase))
                frame = {k: v for k, v in data.items() if not k.endswith(("_re", "_im"))}
                for k in numbers:
                    frame[f"mode{k}"] = (data[f"mode{k}_re"] + 1j * data[f"mode{k}_im"]).__mul__(turn).real
                meshio.Mesh(mesh.points, mesh.cells, point_data=frame).write(stage / f"frame{i:03d}.vtu",
                                                                            file_format="vtu")
                rows.append(f'    <DataSet timestep="{phase:g}" part="0" file="{frames.name}/frame{i:03d}.vtu"/>')
        text = ('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n  <Collection>\n'
                + "\n".join(rows) + "\n  </Collection>\n</VTKFile>\n")
        with atomic_path(target) as tmp:
            Path(tmp).write_text(text)

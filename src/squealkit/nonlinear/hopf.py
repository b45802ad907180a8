"""The Hopf point of a nonlinear system and its first Lyapunov coefficient.

At the Hopf point the equilibrium's linearisation ``A`` has a pair of eigenvalues
``+-i omega_0``. The first Lyapunov coefficient (Kuznetsov, *Elements of Applied
Bifurcation Theory*, 3rd ed., eq. 3.20)::

    l1 = 1/(2 omega_0) Re[ <p, C(q,q,qbar)> - 2 <p, B(q, A^-1 B(q,qbar))>
                           + <p, B(qbar, (2 i omega_0 I - A)^-1 B(q,q))> ]

with ``A q = i omega_0 q``, ``A^T p = -i omega_0 p``, ``<p, q> = pbar^T q = 1``,
``<q, q> = 1``, and ``B``, ``C`` the second and third derivatives of the vector field,
here by central finite differences of the force's analytic Jacobian along the directions
(the regularised contact force is smooth away from contact loss). ``l1 < 0``: supercritical
(soft onset, small stable cycles beyond the threshold); ``l1 > 0``: subcritical (hard onset,
cycles below the threshold, hysteresis).

Everything is computed on the state scaled by ``D = diag(L, omega_0 L)`` (``L`` the
system's ``length_scale``), so ``l1`` is per ``L^2``: the normal form's radius ``r``
gives a displacement amplitude ``2 |q_x| r L`` per DOF (:meth:`HopfPoint.amplitude`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .._validation import InputError
from .harmonic_balance import SecondOrderSystem

__all__ = ["HopfPoint", "hopf_point", "lyapunov_coefficient"]

#: abs(l1) below this (per L^2) is reported as degenerate: no smooth cubic term at onset. The
#: rounding of the finite differences is about 1e-10 for the paper's model; with Stribeck friction
#: (mu_static 0.6, v_stribeck 0.01 m/s) l1 = 1.489e-6, the same to 5 digits for steps 1e-1 to 1e-4.
DEGENERATE_L1 = 1e-9


@dataclass(frozen=True)
class HopfPoint:
    """Hopf point of ``system`` along its parameter.

    Attributes
    ----------
    p : float
        Parameter value at onset (``mu_crit`` for a squealkit model).
    omega : float
        Angular frequency [rad/s] at onset.
    x_eq : ndarray, shape (n,)
        Static equilibrium [m] at onset.
    shape : ndarray, shape (n,), complex
        Displacement part of the critical eigenvector (largest entry 1, real).
    lyapunov_coefficient : float
        First Lyapunov coefficient l1 (scaled state, see the module).
    growth_slope : float
        d Re(lambda) / dp at onset [1/s per unit p] (transversality).
    q_scaled : ndarray, shape (2n,), complex
        Critical eigenvector of the scaled state, ``<q, q> = 1``.
    length_scale : float
        ``L`` [m] of the scaling.
    """

    p: float
    omega: float
    x_eq: NDArray[np.float64]
    shape: NDArray[np.complex128]
    lyapunov_coefficient: float
    growth_slope: float
    q_scaled: NDArray[np.complex128]
    length_scale: float

    @property
    def frequency_hz(self) -> float:
        return self.omega / (2 * math.pi)

    @property
    def kind(self) -> str:
        """``"supercritical"``, ``"subcritical"`` or ``"degenerate"`` (``abs(l1) < DEGENERATE_L1``)."""
        if not abs(self.lyapunov_coefficient) >= DEGENERATE_L1:
            return "degenerate"
        return "supercritical" if self.lyapunov_coefficient < 0 else "subcritical"

    def amplitude(self, p: float | NDArray) -> NDArray[np.float64]:
        """Normal-form amplitude per DOF [m] at parameter(s) ``p`` (square-root law).

        ``r^2 = -sigma'(p_c) (p - p_c) / (omega_0 l1)``, amplitude ``2 |q_x| r L``; NaN where
        ``r^2 < 0`` (no small cycle on that side).

        Parameters
        ----------
        p : float or ndarray
            Parameter value(s) near the Hopf point.

        Returns
        -------
        ndarray, shape ``p.shape + (n,)``
            Peak-to-peak half amplitude [m] per DOF.
        """
        p = np.asarray(p, float)
        r2 = -self.growth_slope * (p - self.p) / (self.omega * self.lyapunov_coefficient)
        r = np.sqrt(np.where(r2 >= 0, r2, np.nan))
        n = self.x_eq.size
        return 2 * r[..., None] * np.abs(self.q_scaled[:n]) * self.length_scale


def _critical_pair(A: NDArray) -> tuple[complex, NDArray, NDArray]:
    """Eigenvalue with Im > 0 of largest real part, its right and left eigenvectors."""
    lam, V = np.linalg.eig(A)
    cand = np.flatnonzero(lam.imag > 1e-9 * np.abs(lam).max())
    i = cand[np.argmax(lam.real[cand])]
    lamT, W = np.linalg.eig(A.T)
    j = np.argmin(np.abs(lamT - lam[i]))
    return lam[i], V[:, i], W[:, j]


def _growth(system: SecondOrderSystem, p: float) -> tuple[float, complex]:
    A = system.jacobian(system.static_equilibrium(p), p)
    lam = _critical_pair(A)[0]
    return float(lam.real), lam


def hopf_point(system: SecondOrderSystem, p_guess: float, *, dp: float | None = None, tol: float = 1e-12,
               fd_step: float = 1e-3) -> HopfPoint:
    """Refine the Hopf point near ``p_guess`` (secant on the growth rate) and compute l1.

    Parameters
    ----------
    system : SecondOrderSystem
    p_guess : float
        Parameter near onset (e.g. :func:`squealkit.stability.critical_friction` of the damped model).
    dp : float, optional
        Parameter step of the secant and of ``growth_slope`` (default ``1e-4 max(1, |p|)``).
    tol : float
        Tolerance on the parameter.
    fd_step : float
        Finite-difference step of l1 in the scaled state.

    Returns
    -------
    HopfPoint
    """
    dp = 1e-4 * max(1.0, abs(p_guess)) if dp is None else dp
    p0, p1 = float(p_guess), float(p_guess) + dp
    g0, g1 = _growth(system, p0)[0], _growth(system, p1)[0]
    for _ in range(60):
        if g1 == g0:
            break
        p2 = p1 - g1 * (p1 - p0) / (g1 - g0)
        p0, g0 = p1, g1
        p1, g1 = p2, _growth(system, p2)[0]
        if abs(p1 - p0) <= tol * max(1.0, abs(p1)):
            break
    if not abs(g1) <= 1e-6 * abs(_growth(system, p1)[1]):
        raise InputError(f"No Hopf point found near {system.param}={p_guess!r} (growth rate {g1:.3g} 1/s).")
    p_c = p1
    slope = (_growth(system, p_c + dp)[0] - _growth(system, p_c - dp)[0]) / (2 * dp)
    x_eq = system.static_equilibrium(p_c)
    l1, omega, q_s, _ = lyapunov_coefficient(system, p_c, x_eq, fd_step=fd_step)
    n = system.n_dof
    phi = q_s[:n] * system.length_scale
    phi = phi / phi[np.argmax(np.abs(phi))]
    return HopfPoint(p_c, omega, x_eq, phi, l1, slope, q_s, system.length_scale)


def lyapunov_coefficient(system: SecondOrderSystem, p: float, x_eq: NDArray, *, fd_step: float = 1e-3):
    """First Lyapunov coefficient at the equilibrium ``x_eq`` of ``system`` at ``p``.

    Kuznetsov's eq. (3.20), on the state scaled by ``D = diag(L, omega_0 L)`` (see the module).

    Parameters
    ----------
    system : SecondOrderSystem
        The nonlinear system.
    p : float
        The parameter at the Hopf point (e.g. from :func:`hopf_point`).
    x_eq : ndarray, shape (n,)
        The static equilibrium [m] at ``p``.
    fd_step : float, default 1e-3
        Step of the central differences of the force's Jacobian, on the scaled state (in
        units of the system's ``length_scale``).

    Returns
    -------
    l1 : float
        The first Lyapunov coefficient (per ``L^2``): < 0 supercritical, > 0 subcritical.
    omega_0 : float
        The critical pair's frequency [rad/s].
    q, p_left : ndarray of complex, shape (2 n,)
        The critical eigenvector (``<q, q> = 1``) and the adjoint one (``<p, q> = 1``) of
        the scaled linearisation.
    """
    n = system.n_dof
    A_phys = system.jacobian(x_eq, p)
    lam0 = _critical_pair(A_phys)[0]
    omega = abs(lam0.imag)
    L = system.length_scale
    D = np.r_[np.full(n, L), np.full(n, omega * L)]
    A = A_phys * D[None, :] / D[:, None]
    y0 = np.r_[x_eq, np.zeros(n)]

    lam, q, w = _critical_pair(A)
    A_c = A - lam.real * np.eye(2 * n)  # exactly on the axis at the refined point
    q = q / np.linalg.norm(q)
    pl = np.conj(w) / np.conj(w @ q)  # A^T p = -i omega p, <p, q> = conj(p) . q = 1
    Minv = np.linalg.inv(system.M)

    def JF(ys: NDArray, u: NDArray) -> NDArray:
        """Nonlinear part of the scaled Jacobian at ``y0 + D ys`` applied to ``u`` (analytic
        force derivatives; the linear structure, exact in both, is left out)."""
        y = y0 + ys * D
        _, dfdx, dfdv, _ = system.force(y[:n], y[n:], p)
        uy = u * D
        acc = Minv @ (dfdx @ uy[:n] + dfdv @ uy[n:])
        return np.r_[np.zeros(n), acc] / D

    h = fd_step

    def quad(u: NDArray) -> NDArray:  # B(u, u) = d/ds J(y0 + s u) u
        return (JF(h * u, u) - JF(-h * u, u)) / (2 * h)

    def cubic(u: NDArray) -> NDArray:  # C(u, u, u) = d2/ds2 J(y0 + s u) u
        return (JF(h * u, u) - 2 * JF(0 * u, u) + JF(-h * u, u)) / h**2

    def B(x: NDArray, y: NDArray) -> NDArray:
        """Symmetric bilinear form for complex vectors, by polarisation of real quadratics."""
        xr, xi, yr, yi = x.real, x.imag, y.real, y.imag

        def br(a, b):
            return (quad(a + b) - quad(a - b)) / 4

        return br(xr, yr) - br(xi, yi) + 1j * (br(xr, yi) + br(xi, yr))

    a, b = q.real, q.imag
    ca, cb, cp, cm = cubic(a), cubic(b), cubic(a + b), cubic(a - b)
    c_aab = (cp - cm - 2 * cb) / 6
    c_abb = (cp + cm - 2 * ca) / 6
    C_qqqb = ca + c_abb + 1j * (c_aab + cb)
    B_qqb = B(q, np.conj(q))
    B_qq = B(q, q)
    t1 = np.conj(pl) @ C_qqqb
    t2 = np.conj(pl) @ B(q, np.linalg.solve(A_c, B_qqb))
    t3 = np.conj(pl) @ B(np.conj(q), np.linalg.solve(2j * omega * np.eye(2 * n) - A_c, B_qq))
    l1 = float(np.real(t1 - 2 * t2 + t3) / (2 * omega))
    return l1, omega, q, pl

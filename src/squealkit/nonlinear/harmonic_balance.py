"""Harmonic balance of a nonlinear friction model: periodic squeal limit cycles.

A periodic solution of ``M x'' + C x' + K x = F0 + f_nl(x, x', p)`` with unknown angular
frequency ``omega`` is written as a truncated Fourier series in ``tau = omega t``::

    x(tau) = a_0 + sum_{k=1..H} a_k cos(k tau) + b_k sin(k tau)

and the equations are balanced harmonic by harmonic. The nonlinear force is evaluated by
the alternating frequency-time (AFT) scheme: the series is sampled at ``N`` points of one
period, the force is computed in the time domain and its Fourier coefficients are taken by
FFT. The Jacobian is analytic: the time-domain derivatives of the force projected onto the
Fourier basis (vectorised, no finite differences). The frequency is fixed by a phase
condition (``b_1`` of one DOF is zero) and the system is solved by Newton's method.

For a squealkit model the nonlinear force is the contact law of the transient solver
(:mod:`squealkit.solvers.ode`): ``N_c = -kc (b.x - q)`` clipped at ``N_c >= 0`` when
contact may open, friction ``mu(w) tanh(w / v_reg)`` with the sliding speed
``w = v - s fhat.x'`` and the slope terms ``g = 1 - mu_e t``, ``e = s (mu_e + t)`` of eq. (4).
:func:`contact_system` builds it from the model's public parts only (``stiffness_parts``,
``load_parts``, :func:`~squealkit.transient.contact_geometry`, ``sliding_direction``), so a
model whose stiffness parts carry other contact kinematics is followed without change here.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from .._validation import InputError, validate_finite, validate_int, validate_model, validate_positive

__all__ = [
    "LimitCycle",
    "SecondOrderSystem",
    "contact_system",
    "harmonic_balance",
]

#: force(x, xd, p) -> (f, df/dx, df/dxd, df/dp), shapes (..., n), (..., n, n), (..., n, n), (..., n)
ForceFn = Callable[[NDArray, NDArray, float], tuple[NDArray, NDArray, NDArray, NDArray]]


@dataclass(frozen=True)
class SecondOrderSystem:
    """``M x'' + C x' + K x = F0 + force(x, x', p)``: a linear structure and a nonlinear force.

    Parameters
    ----------
    M, C, K : ndarray, shape (n, n)
        Mass [kg], damping [N s/m] and stiffness [N/m] of the linear part.
    F0 : ndarray, shape (n,)
        Constant load [N].
    force : callable
        ``force(x, xd, p)`` for arrays of states ``(..., n)``; returns the force [N] and its
        derivatives with respect to ``x``, ``xd`` and the parameter ``p``.
    dof_names : tuple of str
        Names of the DOFs.
    param : str
        Name of the continuation parameter ``p`` (``"mu"`` for a squealkit model).
    length_scale : float
        Typical displacement [m] (scales the unknowns of the Newton solve).
    contact_open : callable, optional
        ``contact_open(x, p)`` -> boolean array ``(...)``: True where contact is lost.
    equilibrium : callable, optional
        ``equilibrium(p)`` -> static equilibrium ``(n,)`` [m] (default: solve ``K x = F0 + f``).
    description : str, optional
        One line saying what the system is (stored with the results).
    """

    M: NDArray[np.float64]
    C: NDArray[np.float64]
    K: NDArray[np.float64]
    F0: NDArray[np.float64]
    force: ForceFn
    dof_names: tuple[str, ...]
    param: str = "p"
    length_scale: float = 1.0
    contact_open: Callable[[NDArray, float], NDArray] | None = None
    equilibrium: Callable[[float], NDArray] | None = None
    description: str = ""

    @property
    def n_dof(self) -> int:
        return len(self.dof_names)

    def static_equilibrium(self, p: float) -> NDArray[np.float64]:
        """Static equilibrium at parameter ``p``: ``K x = F0 + force(x, 0, p)`` (Newton).

        Parameters
        ----------
        p : float
            The parameter (e.g. mu).

        Returns
        -------
        ndarray, shape (n,)
            Displacements [m].
        """
        if self.equilibrium is not None:
            return np.asarray(self.equilibrium(p), float)
        x = np.zeros(self.n_dof)
        v = np.zeros(self.n_dof)
        for _ in range(50):
            f, dfdx, _, _ = self.force(x, v, p)
            r = self.K @ x - self.F0 - f
            dx = np.linalg.solve(self.K - dfdx, -r)
            x = x + dx
            if np.linalg.norm(dx) <= 1e-13 * max(np.linalg.norm(x), self.length_scale):
                break
        return x

    def jacobian(self, x: NDArray, p: float) -> NDArray[np.float64]:
        """First-order state matrix ``A`` (2n, 2n) of the linearisation about ``(x, 0)``.

        Parameters
        ----------
        x : ndarray, shape (n,)
            Displacements [m] (at rest).
        p : float
            The parameter (e.g. mu).

        Returns
        -------
        ndarray, shape (2n, 2n)
        """
        n = self.n_dof
        _, dfdx, dfdv, _ = self.force(np.asarray(x, float), np.zeros(n), p)
        Minv = np.linalg.inv(self.M)
        return np.block([[np.zeros((n, n)), np.eye(n)], [Minv @ (dfdx - self.K), Minv @ (dfdv - self.C)]])

    def vector_field(self, y: NDArray, p: float) -> NDArray[np.float64]:
        """First-order vector field ``y' = F(y)``, ``y = [x, x']``, for arrays ``(..., 2n)``.

        Parameters
        ----------
        y : ndarray, shape (..., 2n)
            States: displacements [m] and velocities [m/s].
        p : float
            The parameter (e.g. mu).

        Returns
        -------
        ndarray, shape (..., 2n)
            ``[x', x'']``.
        """
        n = self.n_dof
        x, v = y[..., :n], y[..., n:]
        f = self.force(x, v, p)[0]
        acc = np.linalg.solve(self.M, (self.F0 + f - x @ self.K.T - v @ self.C.T)[..., None])[..., 0]
        return np.concatenate([v, acc], axis=-1)


def contact_system(model, contact=None, *, speed: float = 0.02, tan_theta: float = 0.0, mu: float = 0.0,
                   param: str = "mu") -> SecondOrderSystem:
    """The nonlinear pin-on-disc system of the transient solver, for harmonic balance.

    Reproduces the contact force of :mod:`squealkit.solvers.ode` (``_rhs``,
    structured branch) on the mean surface ``q = 0`` with a frozen slope ``tan_theta``::

        f_nl = N_c (g b + e f),  N_c = -kc (b_t.x)  (>= 0 if contact may open)
        mu_e = mu(w) phi(w),  w = v - s fhat.x',  g = 1 - mu_e t,  e = s (mu_e + t)

    with ``K = K0`` (structure only) and ``F0`` from the model's ``load_parts``; ``b_t = b``
    for the paper's kinematics and ``b + s t fhat`` for a model whose ``kinematics_option`` is
    ``"consistent"`` (the transient kernel's gap; models without the option are the paper's).

    Parameters
    ----------
    model : FrictionModel
        A model with one point contact (``Kn = kc b b^T``, ``Kf = kc f b^T``).
    contact : Contact or str, optional
        Contact law (default ``Contact.nonlinear()``).
    speed : float
        Sliding speed v [m/s] (paper: 0.02 m/s).
    tan_theta : float
        Run-out slope tan(theta) [1] (fixed when ``param="mu"``).
    mu : float
        Kinetic friction coefficient (fixed when ``param="tan_theta"``).
    param : {"mu", "tan_theta"}
        Which of the two is the system's parameter ``p``.

    Returns
    -------
    SecondOrderSystem
        With parameter ``mu`` (the kinetic friction coefficient) or ``tan_theta``.

    Examples
    --------
    >>> from squealkit.models import get_preset
    >>> sys = contact_system(get_preset("lv2013"))
    >>> sys.dof_names, sys.param
    (('x1', 'y1', 'y2'), 'mu')
    """
    validate_model(model, kind="friction")
    from ..transient.contact import Contact, as_contact, contact_geometry

    contact = Contact.nonlinear() if contact is None else as_contact(contact)
    speed = validate_positive("speed", speed)
    t_fixed = validate_finite("tan_theta", tan_theta)
    mu_fixed = validate_finite("mu", mu)
    if param not in ("mu", "tan_theta"):
        raise InputError(f"Parameter param={param!r} must be 'mu' or 'tan_theta'.")
    ok, kc, b, f = contact_geometry(model)
    if not ok:
        raise InputError(
            f"Harmonic balance needs a model with one point contact (Kn = kc b b^T, Kf = kc f b^T); "
            f"this {model.kind!r} model has none."
        )
    K0 = np.asarray(model.stiffness_parts()[0], float)
    F0 = np.asarray(model.load_parts()[0], float)
    s = float(model.sliding_direction)
    fhat = f / max(float(np.linalg.norm(f)), 1e-300)
    # consistent contact kinematics (a model option on newer squealkit): the gap is b_t.x - q with
    # b_t = b + s t fhat, as in the transient kernel; the paper's (and older models'): b_t = b
    kin = 1.0 if getattr(model, "kinematics_option", "paper") == "consistent" else 0.0
    sep, sign, strib = contact.separation, contact.sign_friction, contact.mu_static is not None
    v_reg, mu_s, v_s = contact.v_reg, (contact.mu_static or 0.0), contact.v_stribeck

    from . import _kernels

    geometry = (np.ascontiguousarray(b, float), np.ascontiguousarray(f, float), np.ascontiguousarray(fhat, float),
                float(kc), s, kin, float(speed), bool(sep), bool(sign), bool(strib), float(v_reg), float(mu_s),
                float(v_s))

    def force_mu_t(x: NDArray, xd: NDArray, mu: float, t: float):
        """The contact force and its derivatives (compiled, :func:`._kernels.contact_force`)."""
        x, xd = np.asarray(x, float), np.asarray(xd, float)
        shape = np.broadcast_shapes(x.shape, xd.shape)
        n = shape[-1]
        X = np.ascontiguousarray(np.broadcast_to(x, shape).reshape(-1, n))
        V = np.ascontiguousarray(np.broadcast_to(xd, shape).reshape(-1, n))
        res = _kernels.contact_force(X, V, float(mu), float(t), *geometry)
        lead = shape[:-1]
        return (res[0].reshape(*lead, n), res[1].reshape(*lead, n, n), res[2].reshape(*lead, n, n),
                res[3].reshape(*lead, n), res[4].reshape(*lead, n))

    if param == "mu":
        def force(x: NDArray, xd: NDArray, p: float):
            out, dfdx, dfdv, dfdmu, _ = force_mu_t(x, xd, p, t_fixed)
            return out, dfdx, dfdv, dfdmu

        def equilibrium(p: float) -> NDArray:
            return model.static_equilibrium(contact.sliding_mu(p, speed), t_fixed, 0.0)
    else:
        def force(x: NDArray, xd: NDArray, p: float):
            out, dfdx, dfdv, _, dfdt = force_mu_t(x, xd, mu_fixed, p)
            return out, dfdx, dfdv, dfdt

        def equilibrium(p: float) -> NDArray:
            return model.static_equilibrium(contact.sliding_mu(mu_fixed, speed), p, 0.0)

    def contact_open(x: NDArray, p: float) -> NDArray:
        bt = b + kin * s * (t_fixed if param == "mu" else p) * fhat
        return (-kc * (x @ bt)) <= 0.0

    approach = float(model.static_equilibrium(0.0, 0.0, 0.0) @ b)  # the static approach of the contact (< 0: pressed)
    if not approach < 0.0:
        raise InputError(
            f"The contact is not pressed in the static equilibrium (approach b.x = {approach:.3g} m >= 0): "
            "there is no steady sliding to squeal about; give the model a load (P > 0)."
        )
    L = -approach
    return SecondOrderSystem(
        M=np.asarray(model.mass_matrix(), float), C=np.asarray(model.damping_matrix(), float), K=K0, F0=F0,
        force=force, dof_names=tuple(model.dof_names), param=param, length_scale=L,
        contact_open=contact_open if sep else None, equilibrium=equilibrium,
        description=f"{model.kind}: {contact.describe()}; v = {speed:g} m/s, "
        + (f"tan(theta) = {t_fixed:g}" if param == "mu" else f"mu = {mu_fixed:g}"),
    )


# -- the Fourier basis ---------------------------------------------------------------------------

def n_time_samples(harmonics: int) -> int:
    """AFT samples per period: a power of two, at least 8 per highest harmonic and 64."""
    return int(2 ** math.ceil(math.log2(max(64, 8 * harmonics + 1))))


@dataclass(frozen=True)
class _Basis:
    H: int
    N: int
    E: NDArray = field(repr=False)  # (N, 2H+1): x(tau_j) = E @ Z
    dE: NDArray = field(repr=False)  # d/dtau of E
    P: NDArray = field(repr=False)  # (2H+1, N): coefficients of a sampled signal (exact up to H)
    k: NDArray = field(repr=False)  # harmonic number of each coefficient row
    D: NDArray = field(repr=False)  # (2H+1, 2H+1): d/dtau on the coefficients (dE = E @ D)

    @classmethod
    def make(cls, H: int, N: int) -> _Basis:
        """The basis of ``H`` harmonics sampled at ``N`` points (cached: the arrays are read-only)."""
        return _basis(int(H), int(N))

    def coefficients(self, f: NDArray) -> NDArray:
        """Fourier coefficients (..., 2H+1, n) of signals sampled (..., N, n)."""
        return self.P @ f


@functools.lru_cache(maxsize=64)
def _basis(H: int, N: int) -> _Basis:
    tau = 2 * np.pi * np.arange(N) / N
    k = np.arange(1, H + 1)
    c, s = np.cos(np.outer(tau, k)), np.sin(np.outer(tau, k))
    E = np.hstack([np.ones((N, 1)), c, s])
    dE = np.hstack([np.zeros((N, 1)), -s * k, c * k])
    P = E.T * np.r_[1.0, np.full(2 * H, 2.0)][:, None] / N
    kk = np.r_[0, k, k].astype(float)
    D = np.zeros((2 * H + 1, 2 * H + 1))
    D[k, H + k] = k  # a_k' = k b_k
    D[H + k, k] = -k  # b_k' = -k a_k
    for a in (E, dE, P, kk, D):
        a.flags.writeable = False
    return _Basis(H, N, E, dE, P, kk, D)


def _linear_operators(sys: SecondOrderSystem, basis: _Basis) -> tuple[NDArray, NDArray, NDArray]:
    """``(L0, L1, L2)`` with the linear residual ``(L0 + omega L1 + omega^2 L2) vec(Z) - F0 e_0``.

    ``vec`` is row-major over ``(harmonic row, dof)``: ``L0 = I (x) K``, ``L1 = D (x) C``,
    ``L2 = D^2 (x) M`` with ``D`` the derivative on the coefficients.
    """
    m = 2 * basis.H + 1
    return np.kron(np.eye(m), sys.K), np.kron(basis.D, sys.C), np.kron(basis.D @ basis.D, sys.M)


def _aft_jacobian(basis: _Basis, dfdx: NDArray, dfdv: NDArray, omega: float) -> NDArray:
    """d(P f)/dZ (n_u, n_u) of the AFT force: ``P diag(df/dx) E + omega P diag(df/dv) E D``.

    For ``N >= 4H`` from the FFT of the sampled derivatives: products of cosines and sines
    turn ``P diag(a) E`` into sums and differences of the Fourier coefficients ``c_{k-l}`` and
    ``c_{k+l}`` of ``a`` (the same discrete sums, exactly; :func:`._kernels.aft_jacobian`);
    otherwise by the matrix products themselves.
    """
    H, N = basis.H, basis.N
    m, n = 2 * H + 1, dfdx.shape[-1]
    if N < 4 * H:
        G = dfdx[:, :, None, :] * basis.E[:, None, :, None]
        G += dfdv[:, :, None, :] * (omega * basis.dE)[:, None, :, None]
        return (basis.P @ G.reshape(N, -1)).reshape(m * n, m * n)
    from . import _kernels

    q = 2 * H + 1
    ca = np.fft.rfft(dfdx, axis=0)[:q] / N
    cb = np.fft.rfft(dfdv, axis=0)[:q] / N
    out = np.empty((m, n, m, n))
    _kernels.aft_jacobian(ca, cb, float(omega), out)
    return out.reshape(m * n, m * n)


def hb_residual(sys: SecondOrderSystem, basis: _Basis, Z: NDArray, omega: float, p: float, *, jacobian: bool = True,
                operators: tuple[NDArray, NDArray, NDArray] | None = None):
    """Residual R (2H+1, n) of harmonic balance and, optionally, dR/dZ, dR/domega, dR/dp.

    AFT: the force is sampled at N points of the period and projected on the basis; its
    derivatives are projected the same way (``P diag(df/dx) E``), which is the exact
    Jacobian of the AFT residual. ``dR/dZ`` is returned as ``(n_u, n_u)`` with
    ``n_u = (2H+1) n`` (row-major over harmonic row and DOF), ``dR/domega`` and ``dR/dp``
    as ``(2H+1, n)``.
    """
    m, n = Z.shape
    L0, L1, L2 = _linear_operators(sys, basis) if operators is None else operators
    z = Z.ravel()
    X = basis.E @ Z
    ZD = basis.D @ Z  # coefficients of dx/dtau
    Xd = omega * (basis.E @ ZD)
    f, dfdx, dfdv, dfdp = sys.force(X, Xd, p)
    JL = L0 + omega * L1 + (omega * omega) * L2
    R = (JL @ z).reshape(m, n) - basis.P @ f
    R[0] -= sys.F0
    if not jacobian:
        return R
    Jnl = _aft_jacobian(basis, dfdx, dfdv, omega)
    JZ = JL - Jnl
    Rw = (L1 @ z + 2 * omega * (L2 @ z)).reshape(m, n) - basis.P @ np.einsum("jim,jm->ji", dfdv, basis.E @ ZD)
    Rp = -basis.P @ dfdp
    return R, JZ, Rw, Rp


# -- the result -----------------------------------------------------------------------------------

@dataclass(frozen=True)
class LimitCycle:
    """A periodic solution found by harmonic balance.

    Attributes
    ----------
    p : float
        Parameter value (the friction coefficient ``mu`` for a squealkit model).
    omega : float
        Angular frequency [rad/s] of the cycle.
    coefficients : ndarray, shape (2H+1, n)
        ``[a_0, a_1..a_H, b_1..b_H]`` per DOF [m].
    dof_names : tuple of str
    amplitude : ndarray, shape (n,)
        Half the peak-to-peak displacement over one period [m], per DOF.
    contact_loss_fraction : float
        Fraction of the period with the contact open (NaN if the system has no contact).
    harmonics_change : float
        Largest relative change of ``amplitude`` when the number of harmonics is raised
        (NaN if not checked).
    residual : float
        Norm of the scaled residual at the solution.
    iterations : int
        Newton iterations.
    """

    p: float
    omega: float
    coefficients: NDArray[np.float64]
    dof_names: tuple[str, ...]
    amplitude: NDArray[np.float64]
    contact_loss_fraction: float
    harmonics_change: float = float("nan")
    residual: float = float("nan")
    iterations: int = 0

    @property
    def harmonics(self) -> int:
        return (self.coefficients.shape[0] - 1) // 2

    @property
    def frequency_hz(self) -> float:
        return self.omega / (2 * math.pi)

    def signal(self, n_samples: int = 256) -> tuple[NDArray, NDArray]:
        """One period sampled at ``n_samples`` points: time [s] (n_samples,) and x [m] (n_samples, n).

        Parameters
        ----------
        n_samples : int, default 256
            Samples per period.

        Returns
        -------
        t : ndarray, shape (n_samples,)
            Times [s] from 0 to one period (excluded).
        x : ndarray, shape (n_samples, n)
            Displacements [m].
        """
        b = _Basis.make(self.harmonics, n_samples)
        return np.arange(n_samples) / n_samples * 2 * math.pi / self.omega, b.E @ self.coefficients


def _amplitude(sys: SecondOrderSystem, Z: NDArray, H: int, p: float) -> tuple[NDArray, float]:
    b = _Basis.make(H, max(512, 16 * H))
    X = b.E @ Z
    amp = 0.5 * (X.max(axis=0) - X.min(axis=0))
    loss = float(np.mean(sys.contact_open(X, p))) if sys.contact_open is not None else float("nan")
    return amp, loss


def _newton(fun, y0: NDArray, *, tol: float = 1e-10, max_iter: int = 30) -> tuple[NDArray, int, float, NDArray]:
    """Newton's method for a square system ``fun(y) -> (r, J)``; damped by halving on growth.

    Returns the solution, the iterations, the residual norm and the Jacobian at the solution.
    """
    y = y0.copy()
    r, J = fun(y)
    nr = float(np.linalg.norm(r))
    for it in range(1, max_iter + 1):
        try:
            dy = np.linalg.solve(J, -r)
        except np.linalg.LinAlgError:
            dy = np.linalg.lstsq(J, -r, rcond=None)[0]
        lam = 1.0
        for _ in range(12):
            y_new = y + lam * dy
            r_new, J_new = fun(y_new)
            n_new = float(np.linalg.norm(r_new))
            if (np.isfinite(n_new) and n_new < max(nr, 1e-300) * (1 - 1e-4 * lam)) or n_new <= tol:
                break
            lam *= 0.5
        else:  # no step along the Newton direction lowers the residual: stuck, give up now
            return y, it, nr, J
        y, r, J, nr = y_new, r_new, J_new, n_new
        if nr <= tol or float(np.linalg.norm(lam * dy)) <= 1e-12 * max(1.0, float(np.linalg.norm(y))):
            return y, it, nr, J
    return y, max_iter, nr, J


class HBProblem:
    """Scaled harmonic-balance equations: unknowns ``y = [u, w, p]`` with
    ``Z = Z_ref + L u``, ``omega = omega_ref w``; the residual is divided by ``k_ref L``.

    ``phase`` is the index ``(row, dof)`` of the coefficient fixed to zero (``b_1`` of one DOF).
    """

    def __init__(self, sys: SecondOrderSystem, H: int, omega_ref: float, phase_dof: int, *, n_time: int | None = None):
        self.sys, self.H = sys, H
        self.basis = _Basis.make(H, n_time or n_time_samples(H))
        self.omega_ref = omega_ref
        self.L = sys.length_scale
        self.k_ref = float(np.abs(np.diag(sys.K)).max())
        self.phase = (H + 1, phase_dof)
        self.n_u = (2 * H + 1) * sys.n_dof
        self.operators = _linear_operators(sys, self.basis)

    def unpack(self, y: NDArray) -> tuple[NDArray, float, float]:
        Z = self.L * y[: self.n_u].reshape(2 * self.H + 1, self.sys.n_dof)
        return Z, self.omega_ref * y[self.n_u], y[self.n_u + 1]

    def pack(self, Z: NDArray, omega: float, p: float) -> NDArray:
        return np.r_[Z.ravel() / self.L, omega / self.omega_ref, p]

    def residual(self, y: NDArray) -> tuple[NDArray, NDArray]:
        """Scaled residual (n_u + 1,) and its Jacobian (n_u + 1, n_u + 2) over ``[u, w, p]``."""
        Z, omega, p = self.unpack(y)
        R, JZ, Rw, Rp = hb_residual(self.sys, self.basis, Z, omega, p, operators=self.operators)
        s = 1.0 / (self.k_ref * self.L)
        n_u = self.n_u
        J = np.zeros((n_u + 1, n_u + 2))
        J[:n_u, :n_u] = JZ * (self.L * s)
        J[:n_u, n_u] = Rw.ravel() * (self.omega_ref * s)
        J[:n_u, n_u + 1] = Rp.ravel() * s
        ip = self.phase[0] * self.sys.n_dof + self.phase[1]
        J[n_u, ip] = 1.0
        return np.append(R.ravel() * s, y[ip]), J

    def cycle(self, y: NDArray, *, residual: float = float("nan"), iterations: int = 0,
              harmonics_change: float = float("nan")) -> LimitCycle:
        Z, omega, p = self.unpack(y)
        amp, loss = _amplitude(self.sys, Z, self.H, p)
        return LimitCycle(float(p), float(omega), Z, self.sys.dof_names, amp, loss, harmonics_change,
                          residual, iterations)


def _resize(Z: NDArray, H_old: int, H_new: int) -> NDArray:
    """Coefficients for another number of harmonics (truncated or zero-padded)."""
    n = Z.shape[1]
    out = np.zeros((2 * H_new + 1, n))
    m = min(H_old, H_new)
    out[0] = Z[0]
    out[1:m + 1] = Z[1:m + 1]
    out[H_new + 1:H_new + 1 + m] = Z[H_old + 1:H_old + 1 + m]
    return out


def solve_fixed_p(problem: HBProblem, y0: NDArray, *, tol: float = 1e-10, max_iter: int = 40):
    """Newton solve of the HB equations at the parameter in ``y0`` (unknowns ``u`` and ``w``)."""
    n = problem.n_u + 1
    p = y0[-1]

    def fun(z):
        r, J = problem.residual(np.append(z, p))
        return r, J[:, :n]

    z, it, nr, _ = _newton(fun, y0[:n], tol=tol, max_iter=max_iter)
    return np.append(z, p), it, nr


def harmonic_balance(
    system: SecondOrderSystem,
    p: float,
    *,
    omega: float,
    guess: NDArray | None = None,
    harmonics: int = 10,
    n_time: int | None = None,
    check_harmonics: bool = True,
    tol: float = 1e-10,
) -> LimitCycle:
    """Limit cycle of ``system`` at parameter ``p`` by harmonic balance (AFT, Newton).

    Parameters
    ----------
    system : SecondOrderSystem
        The equations, e.g. :func:`contact_system` of a squealkit model.
    p : float
        Parameter value (``mu``).
    omega : float
        Initial guess of the angular frequency [rad/s].
    guess : ndarray, shape (2K+1, n), optional
        Initial Fourier coefficients ``[a_0, a_1..a_K, b_1..b_K]`` [m] (any K; resized).
        Default: the static equilibrium plus ``system.length_scale`` on the first cosine of every DOF.
    harmonics : int
        Number of harmonics H.
    n_time : int, optional
        AFT samples per period (default :func:`n_time_samples`).
    check_harmonics : bool
        Also solve with ``2 H`` harmonics and state the relative change of the amplitude
        in ``harmonics_change``.
    tol : float
        Newton tolerance on the scaled residual.

    Returns
    -------
    LimitCycle

    Raises
    ------
    InputError
        If Newton's method does not converge.

    Examples
    --------
    Van der Pol's oscillator ``x'' - eps (1 - x^2) x' + x = 0`` has a cycle of amplitude
    close to 2 at small ``eps``:

    >>> import numpy as np
    >>> def vdp(x, v, eps):
    ...     f = eps * (1 - x**2) * v
    ...     return f, (-2 * eps * x * v)[..., None], (eps * (1 - x**2))[..., None], (1 - x**2) * v
    >>> sys = SecondOrderSystem(np.eye(1), np.zeros((1, 1)), np.eye(1), np.zeros(1), vdp, ("x",))
    >>> lc = harmonic_balance(sys, 0.1, omega=1.0, harmonics=5)
    >>> round(float(lc.amplitude[0]), 3)
    2.0
    """
    H = validate_int("harmonics", harmonics, 1)
    omega = validate_positive("omega", omega)
    n = system.n_dof
    if guess is None:
        Z = np.zeros((2 * H + 1, n))
        Z[0] = system.static_equilibrium(p)
        Z[1] = system.length_scale
    else:
        G = np.asarray(guess, float)
        Z = _resize(G, (G.shape[0] - 1) // 2, H)
    phase_dof = int(np.argmax(np.abs(Z[1]) + np.abs(Z[H + 1])))
    Z = _rotate_phase(Z, H, phase_dof)
    prob = HBProblem(system, H, omega, phase_dof, n_time=n_time)
    y, it, nr = solve_fixed_p(prob, prob.pack(Z, omega, p), tol=tol)
    if not nr <= tol * 10:
        raise InputError(f"Harmonic balance did not converge at {system.param}={p!r} (residual {nr:.3g}).")
    change = float("nan")
    if check_harmonics:
        lc2 = harmonic_balance(system, p, omega=prob.unpack(y)[1], guess=prob.unpack(y)[0], harmonics=2 * H,
                               check_harmonics=False, tol=tol)
        amp = prob.cycle(y).amplitude
        change = float(np.max(np.abs(lc2.amplitude - amp)) / max(float(np.max(np.abs(lc2.amplitude))), 1e-300))
    return prob.cycle(y, residual=nr, iterations=it, harmonics_change=change)


def _rotate_phase(Z: NDArray, H: int, j: int) -> NDArray:
    """Shift the time origin so that ``b_1`` of DOF ``j`` is zero (and ``a_1`` >= 0)."""
    phi = math.atan2(Z[H + 1, j], Z[1, j])
    out = Z.copy()
    for k in range(1, H + 1):
        c, s = math.cos(k * phi), math.sin(k * phi)
        a, b = Z[k], Z[H + k]
        out[k] = a * c + b * s
        out[H + k] = -a * s + b * c
    return out

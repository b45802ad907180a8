"""Stability of a harmonic-balance cycle by Hill's method: Floquet exponents from the HB Jacobian.

A perturbation of the periodic solution ``x(t)`` is sought as ``e^{lambda t} p(t)`` with ``p``
periodic and written in the cycle's own Fourier basis (H harmonics). The variational
equation ``M y'' + (C - df/dv) y' + (K - df/dx) y = 0`` then becomes the quadratic
eigenvalue problem (von Groll & Ewins, 2001; Detroux et al., 2015; NLvib)::

    (Delta_0 + lambda Delta_1 + lambda^2 Delta_2) p = 0,
    Delta_0 = dR/dZ                                      (the harmonic-balance Jacobian)
    Delta_1 = 2 omega D (x) M + I (x) C - P diag(df/dv) E
    Delta_2 = I (x) M

with ``D`` the derivative on the Fourier coefficients and ``P diag(.) E`` the AFT projection
of the sampled force derivative. Its ``2 (2H+1) n`` eigenvalues are the ``2n`` Floquet
exponents, each repeated at ``lambda + i k omega`` for the harmonics the truncation holds;
only the ``2n`` copies whose eigenvectors are best resolved are physical. Two criteria pick
them:

- ``"imaginary"``: the ``2n`` exponents with the smallest ``|Im lambda|`` (Moore, 2005);
- ``"symmetry"``: the ``2n`` whose eigenvectors' energy is centred on the zeroth harmonic
  (the weighted mean harmonic index ``sum k |c_k|^2 / sum |c_k|^2`` of the complex
  coefficients nearest 0; Lazarus & Thomas, 2010), robust where the exponents' imaginary
  parts approach ``omega / 2``.

The multipliers are ``exp(lambda T)``. One exponent is trivial (``0``: the phase shift along
the cycle); its distance from 0 measures the truncation error.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from .._validation import InputError
from .harmonic_balance import LimitCycle, SecondOrderSystem, _aft_jacobian, _Basis, hb_residual, n_time_samples

__all__ = ["hill_exponents"]

_SORTS = ("imaginary", "symmetry")


def hill_matrices(system: SecondOrderSystem, cycle: LimitCycle, *, n_time: int | None = None):
    """``(Delta_0, Delta_1, Delta_2)``, each ``(n_u, n_u)``, of Hill's quadratic eigenvalue problem."""
    H = cycle.harmonics
    basis = _Basis.make(H, n_time or n_time_samples(H))
    Z, omega, p = cycle.coefficients, cycle.omega, cycle.p
    _, D0, _, _ = hb_residual(system, basis, Z, omega, p)
    X = basis.E @ Z
    Xd = omega * (basis.dE @ Z)
    _, _, dfdv, _ = system.force(X, Xd, p)
    m = 2 * H + 1
    Jv = _aft_jacobian(basis, dfdv, np.zeros_like(dfdv), 0.0)  # P diag(df/dv) E
    D1 = 2 * omega * np.kron(basis.D, system.M) + np.kron(np.eye(m), system.C) - Jv
    D2 = np.kron(np.eye(m), system.M)
    return D0, D1, D2


def hill_exponents(system: SecondOrderSystem, cycle: LimitCycle, *, sort: str = "symmetry",
                   n_time: int | None = None) -> NDArray[np.complex128]:
    """Floquet exponents (2n,) of a harmonic-balance cycle by Hill's method [1/s].

    Parameters
    ----------
    system : SecondOrderSystem
        The equations the cycle solves.
    cycle : LimitCycle
        The periodic solution (its harmonics set the size of Hill's matrix).
    sort : {"symmetry", "imaginary"}
        How the ``2n`` physical exponents are picked from the ``2 (2H+1) n`` eigenvalues:
        eigenvectors centred on the zeroth harmonic, or the smallest imaginary parts.
    n_time : int, optional
        AFT samples per period (default :func:`~squealkit.nonlinear.harmonic_balance.n_time_samples`).

    Returns
    -------
    ndarray, shape (2n,), complex
        The non-trivial exponents by decreasing real part, then the trivial one (nearest 0)
        last; the multipliers are ``exp(lambda 2 pi / omega)``.

    Examples
    --------
    Van der Pol's cycle: the non-trivial exponent is the period mean of the divergence
    ``eps (1 - x^2)`` (Liouville's formula, the trivial exponent being 0):

    >>> import numpy as np
    >>> from squealkit.nonlinear import SecondOrderSystem, harmonic_balance
    >>> def vdp(x, v, eps):
    ...     return eps * (1 - x**2) * v, (-2 * eps * x * v)[..., None], (eps * (1 - x**2))[..., None], (1 - x**2) * v
    >>> sys = SecondOrderSystem(np.eye(1), np.zeros((1, 1)), np.eye(1), np.zeros(1), vdp, ("x",))
    >>> lc = harmonic_balance(sys, 0.1, omega=1.0, harmonics=8, check_harmonics=False)
    >>> x = lc.signal(512)[1][:, 0]
    >>> bool(abs(hill_exponents(sys, lc)[0].real - 0.1 * np.mean(1 - x**2)) < 1e-12)
    True
    """
    if sort not in _SORTS:
        raise InputError(f"Parameter sort={sort!r} must be one of {', '.join(map(repr, _SORTS))}.")
    n = system.n_dof
    H = cycle.harmonics
    m = 2 * H + 1
    n_u = m * n
    D0, D1, _ = hill_matrices(system, cycle, n_time=n_time)  # Delta_2 = I (x) M: inverted blockwise below
    Minv = np.linalg.inv(system.M)
    iD2 = np.kron(np.eye(m), Minv)
    A = np.zeros((2 * n_u, 2 * n_u))
    A[:n_u, n_u:] = np.eye(n_u)
    A[n_u:, :n_u] = -iD2 @ D0
    A[n_u:, n_u:] = -iD2 @ D1
    if sort == "imaginary":
        lam = np.linalg.eigvals(A)
        pick = np.argsort(np.abs(lam.imag), kind="stable")[: 2 * n]
    else:
        lam, V = np.linalg.eig(A)
        P = V[:n_u].reshape(m, n, -1)  # [a_0, a_1..a_H, b_1..b_H] of the periodic part
        a, b = P[1:H + 1], P[H + 1:]
        w_pos = np.sum(np.abs(0.5 * (a - 1j * b)) ** 2, axis=1)  # |c_{+k}|^2, (H, 2 n_u)
        w_neg = np.sum(np.abs(0.5 * (a + 1j * b)) ** 2, axis=1)  # |c_{-k}|^2
        w0 = np.sum(np.abs(P[0]) ** 2, axis=0)
        k = np.arange(1, H + 1)[:, None]
        centre = (k * (w_pos - w_neg)).sum(axis=0) / (w0 + w_pos.sum(axis=0) + w_neg.sum(axis=0))
        pick = np.argsort(np.abs(centre), kind="stable")[: 2 * n]
    sel = lam[pick]
    i = int(np.argmin(np.abs(sel)))
    rest = np.delete(sel, i)
    rest = rest[np.argsort(-rest.real, kind="stable")]
    return np.r_[rest, sel[i]]


def hill_multipliers(system: SecondOrderSystem, cycle: LimitCycle, *, sort: str = "symmetry") -> NDArray:
    """Floquet multipliers ``exp(lambda T)`` from :func:`hill_exponents`, ordered as
    :func:`~squealkit.nonlinear.floquet_multipliers` (largest modulus first, trivial last)."""
    lam = hill_exponents(system, cycle, sort=sort)
    rho = np.exp(lam * (2 * math.pi / cycle.omega))
    return np.r_[rho[:-1][np.argsort(-np.abs(rho[:-1]), kind="stable")], rho[-1]]

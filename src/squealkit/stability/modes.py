"""Mode shapes at one operating point: eigenvectors, friction work and d lambda / d p.

At friction ``mu`` and run-out incline ``theta`` the free vibration
``M x'' + C x' + K(mu, tan theta) x = 0`` (paper eqs. 4, 7) has the modes
``x = Re(phi e^{lambda t})`` of the quadratic eigenproblem

    (lambda^2 M + lambda C + K) phi = 0,      psi^H (lambda^2 M + lambda C + K) = 0,

with right eigenvectors (mode shapes) ``phi`` and left eigenvectors ``psi``. Both come from
LAPACK's generalized eigensolver on the companion linearisation of the problem scaled as
Fan, Lin and Van Dooren (2004) propose (so that its backward error is that of the
quadratic problem), for any number of degrees of freedom.

Friction makes K non-symmetric. Its skew-symmetric part ``K_a = (K - K^T) / 2`` is a
circulatory force that can feed energy into a mode; the damping removes it. Over one cycle
of a mode ``x = Re(phi e^{j omega t})`` (frequency omega > 0):

    friction work  W_f = -pi Im(phi^H K phi)        (the work of -K_a x; J for phi in m)
    damping work   W_d =  pi omega Re(phi^H C phi)   (dissipated by C, >= 0)

and the imaginary part of ``phi^H (lambda^2 M + lambda C + K) phi = 0`` gives, for a
symmetric C, the exact balance

    sigma = (W_f - W_d) / (2 pi omega m),   m = phi^H M phi > 0,

so the net work per cycle has the sign of the growth rate: a mode grows exactly when
friction feeds in more energy per cycle than damping removes.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.linalg
import xarray as xr
from numpy.typing import NDArray

from .. import __version__
from .._threads import honour_thread_limit
from .._validation import InputError, validate_dataset, validate_finite, validate_model
from ..models import FrictionModel
from ..models._base import resolve_damped

__all__ = ["eigenvalue_sensitivity", "mode_shapes", "modes", "modes_summary", "onset_modes"]

#: Relative step of the central difference that gives d(M, C, K)/dp for a model parameter:
#: eps^(1/3) balances truncation (h^2) against rounding (eps / h); the matrices are
#: polynomials in the stiffnesses, masses and dampers and trigonometric in the angles.
_MATRIX_STEP = float(np.finfo(float).eps) ** (1.0 / 3.0)
#: Parameters whose stiffness derivative is taken in closed form from (K0, Kn, Kf).
_OPERATING = {"mu": "1", "tan_theta": "1", "theta": "rad"}


# -- the eigenproblem ---------------------------------------------------------------------


def _validate_point(mu: object, theta: object) -> tuple[float, float]:
    mu = validate_finite("mu", mu)
    theta = validate_finite("theta", theta)
    if not abs(theta) < math.pi / 2:
        raise InputError(f"Parameter theta={theta!r} rad must lie strictly between -90 and 90 deg.")
    return mu, theta


def _parts(model: FrictionModel, damped: bool) -> tuple[NDArray, ...]:
    """``M, C, K0, Kn, Kf`` as float arrays (C zero when undamped)."""
    M = np.asarray(model.mass_matrix(), dtype=float)
    C = np.asarray(model.damping_matrix(), dtype=float) if damped else np.zeros_like(M)
    K0, Kn, Kf = (np.asarray(a, dtype=float) for a in model.stiffness_parts())
    return M, C, K0, Kn, Kf


def _stiffness(model: FrictionModel, K0: NDArray, Kn: NDArray, Kf: NDArray, mu: float, t: float) -> NDArray:
    """K = K0 + (1 - mu t) Kn(t) + s (mu + t) Kf(t) (paper eq. 4; ``Kn(t) = Kn + s t Knx`` and
    ``Kf(t) = Kf + s t Kfx`` with consistent kinematics, ``FrictionModel.slope_parts``)."""
    s = model.sliding_direction
    Knx, Kfx = model.slope_parts()
    return K0 + (1.0 - mu * t) * (Kn + s * t * Knx) + s * (mu + t) * (Kf + s * t * Kfx)


def _quadratic_eig(M: NDArray, C: NDArray, K: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    """All 2n eigenvalues of ``lambda^2 M + lambda C + K`` with right and left eigenvectors.

    The problem is scaled (lambda = gamma mu, Fan, Lin & Van Dooren 2004) so that the
    companion pencil ``A - mu B`` with ``A = [[0, I], [-K', -C']]``, ``B = diag(I, M')`` has
    O(1) blocks. Its right eigenvector is ``[phi; mu phi]`` and the lower block of its left
    eigenvector is the left eigenvector ``psi`` of the quadratic problem. The eigenvalues
    of real data come from LAPACK as exact conjugate pairs and exactly real roots.

    Returns
    -------
    lam : ndarray, shape (2n,)
    phi, psi : ndarray, shape (n, 2n)
        Right and left eigenvectors, column k for ``lam[k]``.
    """
    n = M.shape[0]
    norm_m = np.linalg.norm(M, 2)
    norm_c = np.linalg.norm(C, 2)
    norm_k = np.linalg.norm(K, 2)
    if norm_k == 0.0:
        gamma, delta = 1.0, 1.0 / (norm_m + norm_c)
    else:
        gamma = math.sqrt(norm_k / norm_m)
        delta = 2.0 / (norm_k + gamma * norm_c)
    A = np.zeros((2 * n, 2 * n))
    B = np.eye(2 * n)
    A[:n, n:] = np.eye(n)
    A[n:, :n] = -delta * K
    A[n:, n:] = -gamma * delta * C
    B[n:, n:] = gamma * gamma * delta * M
    w, vl, vr = scipy.linalg.eig(A, B, left=True, right=True)
    return gamma * w, vr[:n], vl[n:]


def _kept(lam: NDArray) -> NDArray[np.intp]:
    """One root per conjugate pair (omega > 0) and every real root, lowest frequency first.

    Real roots (omega = 0) come first, the largest growth rate first; a real pair such as
    +a and -b are two modes, and a growing real root is never dropped.
    """
    keep = np.flatnonzero(lam.imag >= 0.0)
    order = np.lexsort((-lam.real[keep], lam.imag[keep]))
    return keep[order]


def _unit_largest(v: NDArray) -> NDArray:
    """Columns of ``v`` scaled so that their largest-amplitude entry is exactly 1 + 0j."""
    k = np.argmax(np.abs(v), axis=0)
    cols = np.arange(v.shape[1])
    out = v / v[k, cols]
    out[k, cols] = 1.0  # exactly: a complex z / z may round to 0.9999999999999999
    return out


def _solve(model: FrictionModel, mu: float, t: float, damped: bool):
    """``(M, C, K, lam, phi, psi)`` of the kept modes, shapes unit-normalised."""
    M, C, K0, Kn, Kf = _parts(model, damped)
    K = _stiffness(model, K0, Kn, Kf, mu, t)
    lam, phi, psi = _quadratic_eig(M, C, K)
    idx = _kept(lam)
    return M, C, K, lam[idx], _unit_largest(phi[:, idx]), _unit_largest(psi[:, idx])


# -- derived per-mode quantities ----------------------------------------------------------


def _quad(A: NDArray, phi: NDArray) -> NDArray:
    """``phi_k^H A phi_k`` for every column k of ``phi``."""
    return np.einsum("ik,ij,jk->k", phi.conj(), A, phi)


def _work_per_cycle(M: NDArray, C: NDArray, K: NDArray, lam: NDArray, phi: NDArray):
    """Friction and damping work per cycle and modal mass of each mode (NaN for real roots)."""
    omega = lam.imag
    osc = omega > 0.0
    w_f = np.where(osc, -math.pi * _quad(K, phi).imag, np.nan) + 0.0  # + 0.0: no negative zeros
    w_d = np.where(osc, math.pi * omega * _quad(C, phi).real, np.nan) + 0.0
    return w_f, w_d, _quad(M, phi).real


def _participation(M: NDArray, phi: NDArray) -> NDArray:
    """Share of each DOF in the mode's kinetic energy, ``Re(conj(phi_i) (M phi)_i) / phi^H M phi``.

    Shape (n, modes); each column sums to 1. For a diagonal M (every built-in model) it is
    ``|phi_i|^2 m_ii / sum_j |phi_j|^2 m_jj``, in [0, 1].
    """
    contrib = (phi.conj() * (M @ phi)).real
    return contrib / contrib.sum(axis=0)


def _point_verdict(model: FrictionModel, mu: float, t: float, damped: bool) -> tuple[str, float]:
    """The stability engine's verdict at the point and its growth-rate threshold [1/s]."""
    from ._solve import VERDICTS
    from .eigen import _solve_grid

    _lam, _err, verdict, thr = _solve_grid(model, np.array([mu]), np.array([t]), damped)
    return VERDICTS[int(verdict[0])], float(thr[0])


@honour_thread_limit
def modes(model: FrictionModel, mu: float, theta: float = 0.0, *, damped: bool | None = None) -> xr.Dataset:
    """Complex modes of the model at friction ``mu`` and run-out incline ``theta``.

    Solves ``(lambda^2 M + lambda C + K(mu, tan theta)) phi = 0`` (paper eqs. 4, 7) for its
    right and left eigenvectors. Of each conjugate pair the mode with omega > 0 is kept;
    every real root (overdamped, divergent) is a mode of its own.

    Parameters
    ----------
    model : FrictionModel
        The system, e.g. ``get_preset("lv2013")``.
    mu : float
        Friction coefficient.
    theta : float
        Run-out incline [rad], strictly inside (-90, 90) deg.
    damped : bool, optional
        Include the damping matrix C. Not given: left out (paper eq. 7 is undamped), with a
        warning when the model has damping.

    Returns
    -------
    xarray.Dataset
        Dims ``mode`` (real roots first, then by frequency) and ``dof`` (the model's
        ``dof_names``). Per mode: ``growth_rate`` sigma [1/s], ``omega`` [rad/s],
        ``frequency_hz`` = omega / 2 pi, ``damping_ratio`` = ``-sigma / |lambda|`` (0 at
        lambda = 0), ``unstable``, ``real_root``, ``modal_mass`` phi^H M phi [kg],
        ``friction_work``, ``damping_work`` and ``net_work`` per cycle [J] for the shape
        as stored (largest amplitude 1 m; they scale with amplitude squared; NaN for real
        roots, which have no cycle). Per mode and DOF: ``shape_real``, ``shape_imag`` (the
        right eigenvector phi, its largest-amplitude entry exactly 1 + 0j),
        ``left_shape_real``, ``left_shape_imag`` (psi, scaled the same way) and
        ``participation`` (kinetic-energy share, sums to 1 over the DOFs). netCDF has no
        complex type, hence the split; :func:`mode_shapes` joins them. The attributes hold
        the operating point, the stability verdict of the point and the model as JSON.

    Notes
    -----
    ``unstable`` marks modes with ``sigma > 1e-9 |lambda|_max`` at a point that the
    stability engine calls unstable (:func:`~squealkit.stability.eigen.stability_verdict`,
    which bounds rounding errors); so a mode at the rounding-level splitting of a double
    root is not called unstable. ``net_work`` has the sign of sigma exactly when C is
    symmetric (see the module notes: ``sigma = net_work / (2 pi omega modal_mass)``).

    Examples
    --------
    >>> from squealkit.models import get_preset
    >>> ds = modes(get_preset("lv2013"), 0.6)
    >>> ds.sizes["mode"], ds.dof.values.tolist()
    (3, ['x1', 'y1', 'y2'])
    >>> k = int(ds.growth_rate.argmax("mode"))
    >>> bool(ds.unstable[k]), bool(ds.friction_work[k] > 0)
    (True, True)
    """
    validate_model(model)
    damped = resolve_damped(model, damped)
    mu, theta = _validate_point(mu, theta)
    t = math.tan(theta)
    verdict, thr = _point_verdict(model, mu, t, damped)  # validates the model's magnitudes first
    M, C, K, lam, phi, psi = _solve(model, mu, t, damped)
    w_f, w_d, m_modal = _work_per_cycle(M, C, K, lam, phi)
    mag = np.abs(lam)
    zeta = np.divide(-lam.real, mag, out=np.zeros_like(mag), where=mag > 0) + 0.0
    unstable = (lam.real > thr) & (verdict in ("flutter", "divergence"))
    names = _dof_names(model, M.shape[0])
    md, dd = ("mode",), ("mode", "dof")
    shape_note = "right eigenvector phi, largest-amplitude entry 1 + 0j"
    work_note = "per cycle of the mode with the stored shape (largest amplitude 1 m); NaN for a real root"
    return xr.Dataset(
        data_vars={
            "growth_rate": (md, lam.real, {"units": "1/s", "long_name": "growth rate sigma (real part)"}),
            "omega": (md, lam.imag, {"units": "rad/s", "long_name": "damped circular frequency omega_d"}),
            "frequency_hz": (md, lam.imag / (2 * math.pi), {"units": "Hz", "long_name": "frequency"}),
            "damping_ratio": (md, zeta, {"units": "1", "long_name": "damping ratio -sigma/|lambda|"}),
            "unstable": (md, unstable, {"long_name": "mode unstable (sigma > 1e-9 |lambda|_max, point unstable)"}),
            "real_root": (md, lam.imag == 0.0, {"long_name": "real eigenvalue (no oscillation)"}),
            "modal_mass": (md, m_modal, {"units": "kg", "long_name": "modal mass phi^H M phi"}),
            "friction_work": (md, w_f, {"units": "J", "long_name": "energy fed in by friction",
                                        "formula": "-pi Im(phi^H K phi)", "note": work_note}),
            "damping_work": (md, w_d, {"units": "J", "long_name": "energy dissipated by damping",
                                       "formula": "pi omega Re(phi^H C phi)", "note": work_note}),
            "net_work": (md, w_f - w_d, {"units": "J", "long_name": "friction work minus damping work",
                                         "note": "sign of sigma; sigma = net_work / (2 pi omega modal_mass)"}),
            "shape_real": (dd, phi.real.T, {"units": "1", "long_name": f"mode shape, real part ({shape_note})"}),
            "shape_imag": (dd, phi.imag.T, {"units": "1", "long_name": f"mode shape, imaginary part ({shape_note})"}),
            "left_shape_real": (dd, psi.real.T, {"units": "1", "long_name": "left eigenvector psi, real part"}),
            "left_shape_imag": (dd, psi.imag.T, {"units": "1", "long_name": "left eigenvector psi, imaginary part"}),
            "participation": (dd, _participation(M, phi).T,
                              {"units": "1", "long_name": "share of the DOF in the mode's kinetic energy",
                               "formula": "Re(conj(phi_i) (M phi)_i) / (phi^H M phi)"}),
        },
        coords={
            "mode": ("mode", np.arange(lam.size), {"long_name": "mode index (real roots, then by frequency)"}),
            "dof": ("dof", np.array(names, dtype=str), {"long_name": "degree of freedom"}),
            "dof_description": ("dof", np.array(_dof_descriptions(model, names), dtype=str)),
        },
        attrs={
            "kind": "modes",
            "title": "Complex modes at one operating point",
            "mu": mu, "theta": theta, "theta_deg": math.degrees(theta), "tan_theta": t, "mu_e": mu + t,
            "damped": int(damped), "verdict": verdict, "unstable_threshold": thr,
            "model": model.to_json(), "model_kind": model.kind,
            "reference": "Lv, Zhang & Yu, J. Vibroeng. 15(2) 2013, eqs. (4), (7), (8)",
            "squealkit_version": __version__,
        },
    )


def _dof_names(model: FrictionModel, n: int) -> tuple[str, ...]:
    names = tuple(getattr(model, "dof_names", ()) or ())
    return names if len(names) == n else tuple(f"x{i + 1}" for i in range(n))


def _dof_descriptions(model: FrictionModel, names: tuple[str, ...]) -> tuple[str, ...]:
    desc = tuple(getattr(model, "dof_descriptions", ()) or ())
    return desc if len(desc) == len(names) else names


@honour_thread_limit
def mode_shapes(ds: xr.Dataset, *, left: bool = False) -> NDArray[np.complex128]:
    """The complex mode shapes of a :func:`modes` result, shape (mode, dof).

    ``left=True`` gives the left eigenvectors psi.

    Parameters
    ----------
    ds : xarray.Dataset
        A result of :func:`modes` or :func:`onset_modes` (``shape_real``, ``shape_imag``,
        ``left_shape_real``, ``left_shape_imag`` over ``(mode, dof)``).
    left : bool
        Return the left eigenvectors psi instead of the right eigenvectors phi.

    Returns
    -------
    ndarray of complex, shape (mode, dof)
        ``*_real + 1j * *_imag``: row k is the shape of mode k, its largest-amplitude entry
        1 + 0j.
    """
    validate_dataset(ds, what="modes")
    pre = "left_shape" if left else "shape"
    return ds[f"{pre}_real"].values + 1j * ds[f"{pre}_imag"].values


@honour_thread_limit
def onset_modes(
    model: FrictionModel, theta: float = 0.0, *, damped: bool | None = None, mu_max: float = 2.0
) -> xr.Dataset:
    """The modes at the critical friction, with the mode that loses stability marked.

    The critical friction comes from :func:`~squealkit.stability.critical_friction`; the
    modes are those of :func:`modes` at it. ``loses_stability`` marks the root that grows just
    above mu_crit (1e-6 relative): the mode that crosses the imaginary axis (damped), or both
    roots of the pair that merges (undamped mode coupling: at the coalescence they are one
    double root with one shape, and which of the two carries a round-off sigma of +1e-9 or
    -1e-9 says nothing about which branch grows). The attribute ``onset_kind`` says which:
    ``"crossing"`` or ``"coalescence"``.

    Parameters
    ----------
    model : FrictionModel
        The system, e.g. ``get_preset("lv2013")``.
    theta : float
        Run-out incline [rad], strictly inside (-90, 90) deg.
    damped : bool, optional
        Include the damping matrix C. Not given: left out (paper eq. 7 is undamped), with a
        warning when the model has damping.
    mu_max : float
        Upper end of the friction search range ``[0, mu_max]`` for the critical friction
        (> 0).

    Returns
    -------
    xarray.Dataset
        The :func:`modes` result at ``mu = mu_critical`` with the boolean variable
        ``loses_stability`` over ``mode`` (True for one mode, or for the two roots of a
        coalescing pair) and the attributes ``mu_critical``, ``mu_e_critical``,
        ``onset_frequency_hz`` [Hz] and ``onset_kind``.

    Raises
    ------
    InputError
        If the model has no friction onset at ``theta`` within ``mu_max``.

    Examples
    --------
    >>> from squealkit.models import get_preset
    >>> ds = onset_modes(get_preset("lv2013"))
    >>> round(float(ds.frequency_hz.where(ds.loses_stability, drop=True)[0]), 1)
    2436.2
    """
    validate_model(model)
    damped = resolve_damped(model, damped)
    from .critical import critical_friction

    crit = critical_friction(model, theta, damped=damped, mu_max=mu_max)
    if crit.status != "onset":
        raise InputError(
            f"No friction onset at theta = {crit.theta_deg:g} deg within |mu| <= {mu_max:g} "
            f"(status: {crit.status}); there is no mode that loses stability."
        )
    t = math.tan(crit.theta)
    mu_c = crit.mu_critical
    ds = modes(model, mu_c, crit.theta, damped=damped)
    _, _, _, lam_up, _, _ = _solve(model, mu_c + 1e-6 * max(1.0, abs(mu_c)), t, damped)
    grow = lam_up[np.argmax(lam_up.real)]
    lam = ds.growth_rate.values + 1j * ds.omega.values
    dist = np.abs(lam - grow)
    # the root the growing one continues: at a coalescence the two roots of the pair are equally near
    # (their split at mu_crit is round-off, far below the square-root split 1e-6 past it)
    flag = dist <= 2.0 * dist.min()
    ds["loses_stability"] = ("mode", flag, {"long_name": "mode that loses stability at mu_crit (both roots of a "
                                                         "coalescing pair)"})
    ds.attrs.update(mu_critical=mu_c, mu_e_critical=crit.mu_e_critical, onset_frequency_hz=crit.frequency_hz,
                    onset_kind="coalescence" if int(flag.sum()) > 1 else "crossing",
                    title="Complex modes at the critical friction")
    return ds


def modes_summary(ds: xr.Dataset) -> dict[str, object]:
    """A :func:`modes` result as plain Python (what ``squealkit modes --json`` prints).

    Parameters
    ----------
    ds : xarray.Dataset
        A result of :func:`modes` or :func:`onset_modes`.

    Returns
    -------
    dict
        ``mu``, ``theta_deg``, ``tan_theta``, ``damped``, ``verdict``, ``dof_names``,
        ``model`` (kind and parameters) and ``modes``: one object per mode with
        ``mode``, ``eigenvalue`` [re, im] [1/s], ``frequency_hz``, ``omega_rad_s``,
        ``growth_rate`` [1/s], ``damping_ratio``, ``unstable``, ``real_root``,
        ``dof_names``, ``shape`` and ``left_shape`` ([re, im] per DOF, largest amplitude
        1), ``participation`` (per DOF), ``modal_mass`` [kg], ``friction_work``,
        ``damping_work``, ``net_work`` [J per cycle at 1 m largest amplitude; null for a
        real root]; ``loses_stability`` for a result of :func:`onset_modes`, which also
        adds ``mu_critical`` at the top level.
    """
    validate_dataset(ds, what="modes")
    import json

    names = [str(d) for d in ds.dof.values]
    phi, psi = mode_shapes(ds), mode_shapes(ds, left=True)
    rows = []
    for k in range(ds.sizes["mode"]):
        r = ds.isel(mode=k)
        row: dict[str, object] = {
            "mode": k,
            "eigenvalue": [float(r.growth_rate), float(r.omega)],
            "frequency_hz": float(r.frequency_hz),
            "omega_rad_s": float(r.omega),
            "growth_rate": float(r.growth_rate),
            "damping_ratio": float(r.damping_ratio),
            "unstable": bool(r.unstable),
            "real_root": bool(r.real_root),
            "dof_names": names,
            "shape": [[float(z.real), float(z.imag)] for z in phi[k]],
            "left_shape": [[float(z.real), float(z.imag)] for z in psi[k]],
            "participation": [float(p) for p in r.participation.values],
            "modal_mass": float(r.modal_mass),
            "friction_work": _finite_or_none(r.friction_work),
            "damping_work": _finite_or_none(r.damping_work),
            "net_work": _finite_or_none(r.net_work),
        }
        if "loses_stability" in ds:
            row["loses_stability"] = bool(r.loses_stability)
        rows.append(row)
    out: dict[str, object] = {
        "mu": float(ds.attrs["mu"]),
        "theta_deg": float(ds.attrs["theta_deg"]),
        "tan_theta": float(ds.attrs["tan_theta"]),
        "damped": bool(ds.attrs["damped"]),
        "verdict": str(ds.attrs["verdict"]),
        "model": json.loads(ds.attrs["model"]),
        "dof_names": names,
        "modes": rows,
    }
    if "mu_critical" in ds.attrs:
        out["mu_critical"] = float(ds.attrs["mu_critical"])
    return out


def _finite_or_none(x: xr.DataArray) -> float | None:
    v = float(x)
    return v if math.isfinite(v) else None


# -- eigenvalue derivatives ---------------------------------------------------------------


def _matrix_derivatives(
    model: FrictionModel, parameter: str, mu: float, t: float, damped: bool
) -> tuple[NDArray, NDArray, NDArray, str, float]:
    """``(dM, dC, dK, unit, value)``: derivatives of the matrices with respect to ``parameter``.

    ``mu``, ``tan_theta`` and ``theta`` in closed form from (K0, Kn, Kf); a model parameter by
    a central difference of the matrices (one-sided where a step would leave the
    parameter's range, exact for matrices linear in it).
    """
    M, _C, _K0, Kn, Kf = _parts(model, damped)
    zero = np.zeros_like(M)
    s = model.sliding_direction
    Knx, Kfx = model.slope_parts()
    Kn_t, Kf_t = Kn + s * t * Knx, Kf + s * t * Kfx
    if parameter == "mu":
        return zero, zero, -t * Kn_t + s * Kf_t, "1", mu
    if parameter in ("tan_theta", "theta"):
        # d/dt of g Kn(t) + e Kf(t): the contact factors' and the slope parts' share
        dK = -mu * Kn_t + s * Kf_t + s * ((1.0 - mu * t) * Knx + s * (mu + t) * Kfx)
        if parameter == "theta":  # d tan(theta) / d theta = 1 + tan^2
            return zero, zero, (1.0 + t * t) * dK, "rad", math.atan(t)
        return zero, zero, dK, "1", t
    info = model.parameter_info()
    if parameter not in info:
        known = ", ".join(["mu", "tan_theta", "theta", *sorted(info)])
        raise InputError(f"Unknown parameter {parameter!r} for model {model.kind!r}; known: {known}.")
    if info[parameter]["kind"] not in ("positive", "nonnegative", "angle", "finite"):
        raise InputError(f"Parameter {parameter!r} ({info[parameter]['kind']}) has no derivative.")
    value = float(getattr(model, parameter))
    h = _MATRIX_STEP * (abs(value) or 1.0)

    def at(v: float) -> tuple[NDArray, ...] | None:
        try:
            m = model.replace(**{parameter: v})
        except InputError:
            return None
        Mv, Cv, K0v, Knv, Kfv = _parts(m, damped)
        return Mv, Cv, _stiffness(m, K0v, Knv, Kfv, mu, t)

    up, dn = at(value + h), at(value - h)
    if up is not None and dn is not None:
        lo, hi, span = dn, up, 2 * h
    elif up is not None:
        lo, hi, span = at(value), up, h
    elif dn is not None:
        lo, hi, span = dn, at(value), h
    else:
        raise InputError(f"Parameter {parameter}={value!r} cannot be stepped by +-{h:.3g} within its range.")
    dM, dC, dK = ((b - a) / span for a, b in zip(lo, hi, strict=True))  # type: ignore[arg-type]
    return dM, dC, dK, info[parameter]["unit"], value


def _dlambda(
    M: NDArray, C: NDArray, dM: NDArray, dC: NDArray, dK: NDArray, lam: NDArray, phi: NDArray, psi: NDArray
) -> NDArray[np.complex128]:
    """``d lambda / d p = -psi^H (lambda^2 dM + lambda dC + dK) phi / psi^H (2 lambda M + C) phi``."""
    num = np.einsum("ik,kij,jk->k", psi.conj(), lam[:, None, None] ** 2 * dM + lam[:, None, None] * dC + dK, phi)
    den = np.einsum("ik,kij,jk->k", psi.conj(), 2 * lam[:, None, None] * M + C, phi)
    return -num / den


@honour_thread_limit
def eigenvalue_sensitivity(
    model: FrictionModel, mu: float, theta: float, parameter: str, *, damped: bool | None = None
) -> xr.Dataset:
    """Exact derivative d lambda / d p of every eigenvalue at one operating point.

    First-order perturbation of the quadratic eigenproblem with right and left
    eigenvectors phi, psi:

        d lambda / d p = -psi^H (lambda^2 dM + lambda dC + dK) phi / psi^H (2 lambda M + C) phi

    ``dK`` is closed-form for ``mu``, ``tan_theta`` and ``theta`` (from ``K0, Kn, Kf``); for
    a model parameter (any scalar name of ``model.parameter_info()``) ``dM, dC, dK`` come
    from a central difference of the matrices, which are cheap and smooth (relative step
    eps^(1/3)). Undefined at a double (defective) eigenvalue, e.g. at the exact
    coalescence of mode coupling, where the denominator vanishes.

    Parameters
    ----------
    model : FrictionModel
    mu : float
        Friction coefficient.
    theta : float
        Run-out incline [rad].
    parameter : str
        ``"mu"``, ``"tan_theta"``, ``"theta"`` [per rad] or a model parameter name.
    damped : bool, optional
        Include the damping matrix C. Not given: left out (paper eq. 7 is undamped), with a
        warning when the model has damping.

    Returns
    -------
    xarray.Dataset
        Over ``mode`` (the modes of :func:`modes`, same order): ``growth_rate``, ``omega``,
        ``frequency_hz`` and their derivatives ``dgrowth_rate_dp`` [1/s per unit of p],
        ``domega_dp`` [rad/s per unit] and ``dfrequency_hz_dp`` [Hz per unit]. Attributes:
        ``parameter``, ``parameter_unit``, ``parameter_value`` and the operating point.

    Examples
    --------
    >>> from squealkit.models import get_preset
    >>> s = eigenvalue_sensitivity(get_preset("lv2013"), 0.6, 0.0, "mu")
    >>> bool(s.dgrowth_rate_dp[int(s.growth_rate.argmax("mode"))] > 0)   # more friction, faster growth
    True
    """
    validate_model(model)
    damped = resolve_damped(model, damped)
    mu, theta = _validate_point(mu, theta)
    if not isinstance(parameter, str):
        raise InputError(f"Parameter parameter={parameter!r} must be a parameter name.")
    t = math.tan(theta)
    M, C, _K, lam, phi, psi = _solve(model, mu, t, damped)
    dM, dC, dK, unit, value = _matrix_derivatives(model, parameter, mu, t, damped)
    d = _dlambda(M, C, dM, dC, dK, lam, phi, psi)
    per = f"per {unit}" if unit != "1" else "per unit"
    md = ("mode",)
    return xr.Dataset(
        data_vars={
            "growth_rate": (md, lam.real, {"units": "1/s"}),
            "omega": (md, lam.imag, {"units": "rad/s"}),
            "frequency_hz": (md, lam.imag / (2 * math.pi), {"units": "Hz"}),
            "dgrowth_rate_dp": (md, d.real, {"units": f"1/s {per}", "long_name": f"d sigma / d {parameter}"}),
            "domega_dp": (md, d.imag, {"units": f"rad/s {per}", "long_name": f"d omega / d {parameter}"}),
            "dfrequency_hz_dp": (md, d.imag / (2 * math.pi),
                                 {"units": f"Hz {per}", "long_name": f"d frequency / d {parameter}"}),
        },
        coords={"mode": ("mode", np.arange(lam.size))},
        attrs={
            "kind": "eigenvalue_sensitivity",
            "parameter": parameter, "parameter_unit": unit, "parameter_value": value,
            "mu": mu, "theta": theta, "theta_deg": math.degrees(theta), "damped": int(damped),
            "model": model.to_json(), "squealkit_version": __version__,
        },
    )

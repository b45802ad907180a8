"""Floquet analysis of a periodic run-out: the exact growth rate of the periodic linear system.

The paper explains intermittent squeal by frozen-time growth rates: at each instant the
eigenvalues of eq. (4) with the slope tan(theta(t)) of that instant. For a run-out that repeats
with period ``T = lambda / v`` the linear system ``M x'' + C x' + K(mu, tan(theta(t))) x = F(t)``
has periodic coefficients, and its exact asymptotic growth rate is the Floquet exponent

    rho = ln |Lambda_max| / T,   Lambda = eigenvalues of the monodromy matrix Phi(T),

with ``Phi' = A(t) Phi``, ``Phi(0) = I``, ``A = [[0, I], [-M^-1 K, -M^-1 C]]`` (the load F does not
change stability). When the run-out is slow against the vibration (T omega >> 1) rho tends to the
period average of the frozen-time sigma(t); it departs from it for long periods relative to the
growth (fast discs, short wavelengths make the modes see the slope change within a few cycles).

The monodromy matrix is integrated by compiled RK4 with ``steps_per_period`` steps (default:
0.05 / omega_max per step), the slope sampled at 8192 points per period and interpolated.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from .. import __version__
from .._threads import limit_threads, thread_limit, threads_for
from .._validation import (
    InputError,
    check_budget,
    validate_array_finite,
    validate_plausible,
    validate_positive,
)
from ..models import FrictionModel
from ..solvers import ode
from ..stability.eigen import eigenvalues
from .profiles import SineRunOut

__all__ = ["FloquetResult", "floquet", "floquet_map"]

#: Slope samples per period (periodic linear interpolation between them).
_SLOPE_SAMPLES = 8192
#: RK4 step of the monodromy integration as a fraction of 1 / omega_max.
_STEP_FACTOR = 0.05
#: Samples per period of the frozen-time average.
_FROZEN_SAMPLES = 512
#: A lower bound of one RK4 step of one case's monodromy matrix (3 DOF) [s], for the work budget.
_SECONDS_PER_STEP = 1e-7


@dataclass(frozen=True)
class FloquetResult:
    """Floquet exponent of a periodic run-out against the period average of frozen-time sigma.

    Attributes
    ----------
    mu : float
    amplitude, wavelength, speed : float
        Sine run-out q0 [m], lambda [m] and the sliding speed v [m/s].
    period : float
        T = lambda / v [s].
    floquet_exponent : float
        ``ln |Lambda_max| / T`` [1/s]: the exact growth rate of the periodic linear system.
    frozen_mean : float
        Period average of max Re(lambda) of the frozen-time system [1/s] (paper §4).
    frozen_max : float
        Largest frozen-time sigma over the period [1/s].
    multipliers : tuple of complex
        Eigenvalues of the monodromy matrix (largest modulus first).
    steps : int
        RK4 steps per period.
    damped : bool
    """

    mu: float
    amplitude: float
    wavelength: float
    speed: float
    period: float
    floquet_exponent: float
    frozen_mean: float
    frozen_max: float
    multipliers: tuple[complex, ...]
    steps: int
    damped: bool

    @property
    def relative_difference(self) -> float:
        """``(rho - mean sigma) / |mean sigma|``: the Floquet exponent against the frozen-time average."""
        return (self.floquet_exponent - self.frozen_mean) / abs(self.frozen_mean) if self.frozen_mean else math.nan

    def to_dict(self) -> dict[str, object]:
        d = asdict(self)
        d["multipliers"] = [[float(z.real), float(z.imag)] for z in self.multipliers]
        d["relative_difference"] = self.relative_difference
        return d


def _model_arrays(model: FrictionModel, damped: bool, B: int) -> tuple[np.ndarray, ...]:
    Minv = np.linalg.inv(model.mass_matrix())
    C = model.damping_matrix() if damped else np.zeros_like(Minv)
    K0, Kn, Kf = model.stiffness_parts()
    Knx, Kfx = model.slope_parts()
    return tuple(np.ascontiguousarray(np.broadcast_to(Minv @ a, (B, *Minv.shape))) for a in (C, K0, Kn, Kf, Knx, Kfx))


def _steps(model: FrictionModel, mu: np.ndarray, period: float, damped: bool, steps: int | None) -> int:
    if steps is not None:
        if isinstance(steps, bool) or not isinstance(steps, int) or steps < 16:
            raise InputError(f"Parameter steps_per_period={steps!r} must be an integer >= 16.")
        return steps
    wmax = float(np.abs(eigenvalues(model, np.unique(mu), tan_theta=0.0, damped=damped)).max())
    need = period * wmax / _STEP_FACTOR
    return max(64, math.ceil(need)) if math.isfinite(need) else need  # infinite: refused by the work budget


def _exponents(model, mu, amplitude, wavelength, speed, damped, steps):
    """Floquet exponents, multipliers and frozen-time statistics over flat arrays mu, amplitude."""
    period = wavelength / speed
    B = mu.size
    n = model.n_dof
    check_budget(f"A Floquet analysis of {B} cases", points=B,
                 nbytes=B * (8.0 * (4 * n * n + 6 * n) + 8.0 * (_SLOPE_SAMPLES + 4 * _FROZEN_SAMPLES * n)))
    n_steps = _steps(model, mu, period, damped, steps)
    check_budget(f"A Floquet analysis of {B} cases of {n_steps:.3g} steps per period (period {period:.3g} s)",
                 seconds=B * n_steps * _SECONDS_PER_STEP * (n / 3) ** 3 / thread_limit(),
                 hint="Raise the sliding speed or shorten the run-out wavelength (the period is wavelength/speed).")
    phase = np.arange(_SLOPE_SAMPLES) / _SLOPE_SAMPLES
    unit = SineRunOut(1.0, wavelength).evaluate(phase * wavelength)[1]  # slope of q0 = 1 m
    tg = np.ascontiguousarray(amplitude[:, None] * unit[None, :])
    arrays = _model_arrays(model, damped, B)
    s = np.full(B, float(model.sliding_direction))
    kin = np.full(B, float(model.slope_coupled))
    out = np.empty((B, 2 * model.n_dof, 2 * model.n_dof))
    with limit_threads(threads_for(B, serial_below=2)):
        ode.monodromy(tg, np.ascontiguousarray(mu, dtype=float), s, kin, *arrays, period, n_steps, out)
    bad = ~np.all(np.isfinite(out), axis=(-2, -1))
    if np.any(bad):
        i = int(np.flatnonzero(bad)[0])
        raise InputError(f"The motion at mu={mu[i]:g}, amplitude={amplitude[i]:g} m grows beyond double precision "
                         f"within one period ({period:.3g} s): no Floquet exponent; use a smaller run-out amplitude.")
    mult = np.linalg.eigvals(out)
    order = np.argsort(-np.abs(mult), axis=-1)
    mult = np.take_along_axis(mult, order, axis=-1)
    rho = np.log(np.abs(mult[:, 0])) / period
    fz = np.arange(_FROZEN_SAMPLES) / _FROZEN_SAMPLES * wavelength
    slope1 = SineRunOut(1.0, wavelength).evaluate(fz)[1]
    sig = eigenvalues(model, mu[:, None], tan_theta=amplitude[:, None] * slope1[None, :],
                      damped=damped).real.max(axis=-1)
    return rho, mult, sig.mean(axis=-1), sig.max(axis=-1), n_steps, period


def _validate(model, wavelength, speed):
    if not isinstance(model, FrictionModel):
        raise InputError(f"Parameter model must be a squealkit FrictionModel; got {type(model).__name__}.")
    speed = validate_positive("speed", speed)
    return validate_positive("wavelength", wavelength), validate_plausible("speed", speed)


def floquet(model: FrictionModel, *, mu: float, amplitude: float, wavelength: float, speed: float,
            damped: bool = True, steps_per_period: int | None = None) -> FloquetResult:
    """Floquet exponent of the paper's model on a sine run-out ``q0 sin(2 pi x / lambda)`` (eqs. 9-11).

    Parameters
    ----------
    model : FrictionModel
    mu : float
        Friction coefficient.
    amplitude, wavelength : float
        Run-out amplitude q0 [m] and wavelength lambda [m].
    speed : float
        Sliding speed v [m/s] (> 0): the period is lambda / v.
    damped : bool
        Include the damping matrix (the paper's transient runs are damped).
    steps_per_period : int, optional
        RK4 steps over one period (default from the fastest mode: 0.05 / omega_max each).

    Returns
    -------
    FloquetResult

    Examples
    --------
    The paper's Fig. 4 case: the exact rate and the frozen-time average agree to 1 %.

    >>> from squealkit.models import get_preset
    >>> r = floquet(get_preset("lv2013"), mu=0.4, amplitude=0.08e-3, wavelength=1e-3, speed=0.02)
    >>> round(r.floquet_exponent, 3), round(r.frozen_mean, 3)
    (-0.322, -0.324)
    """
    wavelength, speed = _validate(model, wavelength, speed)
    mu_a = np.array([float(validate_array_finite("mu", mu))])
    amp = np.array([validate_plausible("amplitude", amplitude, "runout_amplitude")])
    rho, mult, mean, top, n_steps, period = _exponents(model, mu_a, amp, wavelength, speed, damped, steps_per_period)
    return FloquetResult(float(mu_a[0]), float(amp[0]), wavelength, speed, period, float(rho[0]), float(mean[0]),
                         float(top[0]), tuple(complex(z) for z in mult[0]), n_steps, damped)


def floquet_map(model: FrictionModel, *, mu: ArrayLike, amplitude: ArrayLike, wavelength: float, speed: float,
                damped: bool = True, steps_per_period: int | None = None) -> xr.Dataset:
    """Floquet exponent and frozen-time average over a grid of friction and run-out amplitude.

    :func:`floquet` at every ``(mu, amplitude)`` of the grid; the cases run in parallel (numba
    ``prange``).

    Parameters
    ----------
    model : FrictionModel
    mu : array_like, 1-D
        Friction coefficients.
    amplitude : array_like, 1-D
        Run-out amplitudes q0 [m] (>= 0).
    wavelength : float
        Run-out wavelength lambda [m].
    speed : float
        Sliding speed v [m/s] (> 0): the period is lambda / v.
    damped : bool
        Include the damping matrix (the paper's transient runs are damped).
    steps_per_period : int, optional
        RK4 steps over one period (default from the fastest mode: 0.05 / omega_max each).

    Returns
    -------
    xarray.Dataset
        Over ``(mu, amplitude)``: ``floquet_exponent``, ``frozen_mean`` and ``frozen_max``
        [1/s] and ``difference`` (exponent minus mean) [1/s]; coordinate ``max_slope`` =
        2 pi q0 / lambda; ``kind`` ``"floquet_map"`` (drawn by
        :func:`~squealkit.plotting.transient.floquet_plot`).

    Examples
    --------
    >>> from squealkit.models import get_preset
    >>> ds = floquet_map(get_preset("lv2013"), mu=[0.3, 0.4], amplitude=[0.0, 8e-5], wavelength=1e-3,
    ...                  speed=0.02, steps_per_period=2000)
    >>> sorted(ds.sizes.items())
    [('amplitude', 2), ('mu', 2)]
    """
    wavelength, speed = _validate(model, wavelength, speed)
    mu_a = np.atleast_1d(validate_array_finite("mu", mu)).astype(float)
    amp = np.atleast_1d(validate_array_finite("amplitude", amplitude)).astype(float)
    if mu_a.ndim != 1 or amp.ndim != 1 or np.any(amp < 0):
        raise InputError("mu and amplitude must be 1-D grids, amplitude >= 0.")
    for a in amp:
        validate_plausible("amplitude", a, "runout_amplitude")
    check_budget(f"A Floquet map of {mu_a.size} x {amp.size} cases", points=float(mu_a.size) * amp.size)
    M, Q = np.meshgrid(mu_a, amp, indexing="ij")
    rho, _mult, mean, top, n_steps, period = _exponents(model, M.ravel(), Q.ravel(), wavelength, speed, damped,
                                                        steps_per_period)
    shape = M.shape
    dims = ("mu", "amplitude")
    return xr.Dataset(
        {
            "floquet_exponent": (dims, rho.reshape(shape), {"units": "1/s", "long_name": "Floquet exponent"}),
            "frozen_mean": (dims, mean.reshape(shape),
                            {"units": "1/s", "long_name": "period average of frozen-time sigma"}),
            "frozen_max": (dims, top.reshape(shape), {"units": "1/s", "long_name": "largest frozen-time sigma"}),
            "difference": (dims, (rho - mean).reshape(shape),
                           {"units": "1/s", "long_name": "Floquet exponent minus frozen-time average"}),
        },
        coords={
            "mu": ("mu", mu_a, {"units": "1", "long_name": "friction coefficient"}),
            "amplitude": ("amplitude", amp, {"units": "m", "long_name": "run-out amplitude q0"}),
            "max_slope": ("amplitude", 2 * math.pi * amp / wavelength,
                          {"units": "1", "long_name": "largest run-out slope 2 pi q0 / lambda (eq. 11)"}),
        },
        attrs={"kind": "floquet_map",
               "title": "Floquet exponent of a sine run-out", "model": model.to_json(), "wavelength": wavelength,
               "speed": speed, "period": period, "steps_per_period": n_steps, "damped": int(damped),
               "reference": "Lv, Zhang & Yu 2013, eqs. 4, 9-11; Floquet theory of periodic linear systems",
               "squealkit_version": __version__},
    )

"""Robust margins: the probability that a brake squeals when its parameters scatter, two ways.

A brake that is stable at its nominal parameters may squeal when a part is a little stiffer,
a pad a little softer or the friction material a little more aggressive. Given the scatter of
some parameters (independent, each a distribution), :func:`robust_margins` estimates the squeal
propensity at one operating point: the probability that some mode in the band has a positive
growth rate. Two methods, side by side, each with its interval and its cost:

``montecarlo``
    Seeded samples of the parameters; each sample is a small dense eigenproblem
    (:mod:`squealkit.design.montecarlo`). An FE model is reduced once, for its nominal
    parameters (:func:`~squealkit.solvers.reduction.reduce` on a POD basis, as
    :func:`~squealkit.stability.fe_stability_map` builds it): each scattered matrix part ``A``
    enters as ``V^T A V``, so a sample costs an eigen solve of ``2 r`` unknowns. Each sample's
    modes are matched to the nominal ones by shape (MAC) and eigenvalue in one assignment, a
    match between near-equal candidates reported as indeterminate, never picked; the eigenpairs
    of every sample are checked by their backward error in the FULL model (from the basis'
    residual factor, no full-size product), which says whether the basis still holds the
    scattered models. The interval is the Clopper-Pearson (exact binomial) one, as in
    :func:`~squealkit.uncertainty.squeal_propensity`.

``perturbation``
    The second-order perturbation estimate (Nobari, Ouyang & Bannister, J. Sound Vib. 338,
    2015) at the parameters' mean: each growth rate a quadratic in the parameters, its mean and
    variance from their moments (:mod:`squealkit.design.perturbation`, with when it holds).

Scatter
-------
``scatter`` maps a name to its distribution:

- FE models (:class:`~squealkit.fe.model.FEModel`): a name is a matrix part (``M``, ``D1``,
  ``DG``, ``DR``, ``D4``, ``K1``, ``KR``, ``KGeo``), the scattered quantity its scale factor,
  nominal 1 (``KR`` scatters the friction coupling, ``K1`` the structure's stiffness).
- Small models (presets, model files): a name is a scalar parameter (``k3``, ``kc``,
  ``alpha_deg``...) as in :mod:`squealkit.uncertainty`.

A value is either a coefficient of variation (``{"KR": 0.05}``: normal, mean the nominal value,
standard deviation 5 % of it), a table ``{"dist": "normal" | "uniform" | "lognormal", "cov": c}``
(a uniform of that coefficient of variation spans ``nominal (1 +- sqrt(3) c)``), or a table in
the form of :mod:`squealkit.uncertainty` (``{"dist": "normal", "mean": ..., "std": ...}``, in
the parameter's unit). The parameters are independent; the nominal point of the perturbation
estimate is their mean.
"""

from __future__ import annotations

import json
import math
import time
import warnings
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import NDArray
from threadpoolctl import threadpool_limits

from .. import __version__
from .._threads import honour_thread_limit
from .._validation import InputError, validate_angle, validate_finite, validate_int, validate_model
from ..uncertainty import UncertainParameter, parse_uncertain, sample_parameters
from ._pencil import _gamma, _linear_matrices, _model_matrices, _modes_in_band, _state_eig, _threshold
from ._scatter import _moments, _scatter_table, _uncertain
from ._study import operating_point
from .montecarlo import _check_scatter_samples, _montecarlo, _montecarlo_summary, _nominal_residual, _residual_check
from .perturbation import (
    _FD_STEP,
    COUPLING_MAX,
    PERTURBATION_STATUS,
    PerturbationWarning,
    _fd_derivatives,
    _perturbation,
)

__all__ = ["COUPLING_MAX", "METHODS", "PERTURBATION_STATUS", "PerturbationWarning", "robust_margins"]

#: The methods of :func:`robust_margins`.
METHODS = ("montecarlo", "perturbation")
#: FE models up to this many DOFs are solved whole (basis: the identity) unless a basis is given.
_FULL_MAX_DOF = 200
#: Samples per Monte Carlo task (results never depend on it).
_BATCH = 256


# ----------------------------------------------------------------------------- an FE model's reduced parts


def _fe_setup(model: Any, disc_speed: float, mu_e: float, unc: Sequence[UncertainParameter],
              band: tuple[float, float] | None, basis: Any) -> dict[str, Any]:
    """Reduced parts of an FE model at the operating point, and its basis."""
    from ..solvers import reduction
    from ..solvers.band import BAND_HZ

    f = model.factors(disc_speed, mu_e)
    f["M"] = 1.0
    scattered = [p.name for p in unc]
    if isinstance(basis, str) and basis == "auto":
        basis = "identity" if model.n_dof <= _FULL_MAX_DOF else "pod"
    if isinstance(basis, str):
        if basis not in ("identity", "pod"):
            raise InputError(f"Parameter basis={basis!r} must be 'auto', 'identity', 'pod' or an (n, r) array.")
        kind = basis
    else:
        kind = "given"
    if band is None:
        band = (0.0, math.inf) if kind == "identity" else BAND_HZ
    if kind == "identity":
        V = np.eye(model.n_dof)
    elif kind == "pod":
        if not math.isfinite(band[1]):
            raise InputError("A POD basis needs a finite band=(lo, hi) [Hz].")
        # friction samples spanning three standard deviations of the friction parts' scale
        spread = max([3 * p.distribution.std() for p in unc if p.name in ("KR", "DR")] + [0.0])
        mus = np.unique([mu_e * (1 - spread), mu_e, mu_e * (1 + spread)])
        modal = reduction.modal_basis(model, freq_max=1.25 * band[1])
        V = np.asarray(reduction.pod_basis(model, [disc_speed], mus, band=band, extra=modal))
    else:
        V = np.asarray(basis, dtype=float)
        if V.ndim != 2 or V.shape[0] != model.n_dof or not np.all(np.isfinite(V)):
            raise InputError(f"Parameter basis must be a finite {model.n_dof} x r array, got shape {V.shape}.")
    reduced = reduction.reduce(model, V)
    r = reduced.n_reduced
    power = {name: 2 if name == "M" else (1 if name in ("D1", "DG", "DR", "D4") else 0) for name in reduced.order}
    slot = {2: 0, 1: 1, 0: 2}
    fixed = np.zeros((3, r, r))
    parts = np.zeros((len(scattered), 3, r, r))
    for name in reduced.order:
        term = f[name] * reduced.mats[name]
        if name in scattered:
            parts[scattered.index(name), slot[power[name]]] = term
        else:
            fixed[slot[power[name]]] += term
    return {"payload": (fixed, parts), "reduced": reduced, "factors": f, "power": power, "band": band,
            "basis": kind}


def _methods(method: str | Sequence[str]) -> tuple[str, ...]:
    chosen = (method,) if isinstance(method, str) else tuple(method)
    bad = [m for m in chosen if m not in METHODS]
    if not chosen or bad:
        raise InputError(f"Parameter method={method!r}: give one or both of {', '.join(map(repr, METHODS))}.")
    return tuple(m for m in METHODS if m in chosen)


# ----------------------------------------------------------------------------- entry point


@honour_thread_limit
def robust_margins(
    model: Any,
    rpm: float | None = None,
    mu: float | None = None,
    theta: float = 0.0,
    *,
    disc_speed: float | None = None,
    scatter: Mapping[str, Any],
    samples: int = 1000,
    method: str | Sequence[str] = METHODS,
    band: tuple[float, float] | None = None,
    damped: bool | None = None,
    basis: Any = "auto",
    seed: int = 0,
    confidence: float = 0.95,
    eta_max: float | None = None,
    batch_size: int = _BATCH,
    client: Any = None,
) -> xr.Dataset:
    """Squeal propensity under parameter scatter: Monte Carlo and second-order perturbation.

    See the module notes for the two methods and the forms of ``scatter``, and
    :mod:`squealkit.design.perturbation` for when the perturbation estimate holds.

    Parameters
    ----------
    model : FEModel or FrictionModel
        An FE brake (its matrix parts scatter) or a small model (its parameters scatter).
    rpm : float, optional
        Disc speed [rev/min] of an FE model (or ``disc_speed``); not for small models.
    mu : float, optional
        Friction coefficient; default the FE model's ``mu_ref`` (required for small models).
    theta : float
        Run-out incline [rad]: ``mu_e = mu + tan(theta)`` (paper eq. 6).
    disc_speed : float, optional
        Disc speed [rad/s] of an FE model, instead of ``rpm``.
    scatter : mapping
        Name -> coefficient of variation, or ``{dist, cov}``, or ``{dist, mean, std | lower, upper}``
        (module notes). FE: matrix parts (scale factors, nominal 1); small models: parameters.
    samples : int
        Monte Carlo samples (>= 2).
    method : str or sequence of str
        ``"montecarlo"``, ``"perturbation"`` or both (default).
    band : (float, float), optional
        Frequency band [Hz] of the modes that count. Default: every mode of a model solved whole
        (a small model, an FE model up to 200 DOFs), 1-16 kHz for a reduced FE model.
    damped : bool, optional
        Small models: include the damping matrix (as :func:`~squealkit.uncertainty.squeal_propensity`).
    basis : {"auto", "identity", "pod"} or ndarray (n, r)
        FE models: the reduction basis. ``"auto"``: the whole model up to 200 DOFs, else a POD
        basis at the operating point (the real modes to 1.25 times the band's top, the complex modes
        at the nominal friction and three standard deviations of the ``KR``/``DR`` scale either
        side, and the left corrections).
    seed : int
        Seed of the draw (``numpy.random.SeedSequence``): the same result whatever ``batch_size``
        or ``client``.
    confidence : float
        Level of the Monte Carlo interval, in (0, 1).
    eta_max : float, optional
        Full-model backward error up to which a reduced eigenpair is trusted (default
        :data:`~squealkit.solvers.band.RESIDUAL_TOL`).
    batch_size : int
        Monte Carlo samples per task.
    client : distributed.Client, optional
        Run the Monte Carlo batches on this Dask cluster (:mod:`squealkit.scale`); a single batch,
        or work estimated under 2 s, runs here (shipping it would cost more than solving it).

    Returns
    -------
    xarray.Dataset
        ``kind = "robust_margins"``. Over ``mode`` (the nominal modes in the band, by frequency):
        ``frequency_hz`` [Hz], ``growth_rate`` [1/s] (at the parameters' mean); over
        ``(estimator, mode)`` (``estimator`` the methods run, named as in ``method``; not called
        ``method``, which is a keyword of ``Dataset.sel``): ``growth_rate_mean``, ``growth_rate_std``
        [1/s] and ``probability_unstable`` (Monte Carlo: each sample's mode matched to the nominal
        one by shape and eigenvalue; NaN where a match is indeterminate, see
        :mod:`squealkit.design.montecarlo`); over ``estimator``: ``propensity``, ``propensity_ci_lower``,
        ``propensity_ci_upper`` and ``cost_seconds``. With the perturbation estimate:
        ``growth_rate_sensitivity`` (mode, parameter) [1/s per unit], ``perturbation_status``
        (codes of :data:`PERTURBATION_STATUS`) and ``coupling_ratio`` (mode). With Monte Carlo:
        ``parameter_value`` (sample, parameter), ``max_growth_rate`` and ``unstable`` (sample),
        ``sampled_growth_rate`` and ``match_indeterminate`` (sample, mode), for an FE model
        ``sample_residual`` (sample). ``attrs``: the operating point, band, scatter, seed, basis,
        ``n_reduced``, ``residual_checked`` (the nominal and every sample of an FE model; 0 for a
        small model, solved whole), the largest full-model backward error ``max_residual`` and
        ``trusted``.

    Raises
    ------
    InputError
        For an unknown name in ``scatter``, an option that does not apply to the model's kind,
        a sampled value outside its range (a scale <= 0), or a bad number.

    Warns
    -----
    PerturbationWarning
        A mode is beyond the perturbation estimate's reach (its propensity is NaN).
    UserWarning
        The reduced basis does not hold the scattered models (``trusted`` is 0); a Monte Carlo
        match is indeterminate in some samples.

    Examples
    --------
    The paper's pin-on-disc rig (Lv et al. 2013) at mu = 0.35, just below its onset, with the
    contact stiffness and two dampers scattering by 10 %: the two estimates agree.

    >>> from squealkit.models import get_preset
    >>> ds = robust_margins(get_preset("lv2013"), mu=0.35, scatter={"kc": 0.1, "c1": 0.1, "c2": 0.1},
    ...                     samples=2000, damped=True, seed=1)
    >>> ds.propensity.values.round(2).tolist()   # Monte Carlo, perturbation
    [0.16, 0.15]
    """
    from ..fe.model import FEModel
    from ..solvers.band import RESIDUAL_TOL, validate_band

    validate_model(model)
    methods = _methods(method)
    samples = validate_int("samples", samples, 2)
    batch_size = validate_int("batch_size", batch_size, 1)
    seed = validate_int("seed", seed, 0)
    theta = validate_angle("theta", theta)
    tan_t = math.tan(theta)
    confidence = validate_finite("confidence", confidence)
    if not 0.0 < confidence < 1.0:
        raise InputError(f"Parameter confidence={confidence!r} must lie strictly between 0 and 1.")
    eta_max = RESIDUAL_TOL if eta_max is None else validate_finite("eta_max", eta_max)
    if band is not None:
        band = validate_band(band)
    is_fe = isinstance(model, FEModel)
    t_setup = time.perf_counter()
    if is_fe:
        if damped is not None:
            raise InputError("Parameter damped applies to small models; an FE model's damping is its D parts.")
        pt = operating_point(model, rpm, mu, theta, disc_speed=disc_speed)
        rpm, disc_speed, mu, mu_e = pt.rpm, pt.disc_speed, pt.mu, pt.mu_e
        known = {name: 1.0 for name in model.present}
        for name in scatter if isinstance(scatter, Mapping) else ():
            if name not in known:
                raise InputError(f"Unknown scatter name {name!r} for an FE model; its matrix parts: "
                                 f"{', '.join(model.present)}.")
        unc = _uncertain(_scatter_table(scatter, known))
        setup = _fe_setup(model, disc_speed, mu_e, unc, band, basis)
        band = setup["band"]
        builder, payload = _linear_matrices, setup["payload"]
        units = ["1"] * len(unc)
    else:
        from ..models._base import resolve_damped

        mu = operating_point(model, rpm, mu, theta, disc_speed=disc_speed).mu
        if not (isinstance(basis, str) and basis == "auto"):
            raise InputError("Parameter basis applies to FE models; a small model is solved whole.")
        damped = resolve_damped(model, damped)
        info = model.parameter_info()
        nominal = {}
        for name in scatter if isinstance(scatter, Mapping) else ():
            base = name[:-4] if name.endswith("_deg") and name not in info else name
            if base in info:
                v = float(getattr(model, base))
                nominal[name] = math.degrees(v) if base != name else v
        table = _scatter_table(scatter, nominal)
        unc = parse_uncertain({k: table.get(k, v) for k, v in scatter.items()}, model)
        names = [(p.model_parameter, p.is_degrees) for p in unc]
        builder, payload = _model_matrices, (model, names, mu, tan_t, damped)
        setup = {"basis": "identity", "reduced": None}
        band = (0.0, math.inf) if band is None else band
        units = ["deg" if p.is_degrees else info[p.model_parameter]["unit"] for p in unc]
    lo, hi = band
    mean_p, std_p, m3, m4 = _moments(unc)
    nominal_mats = builder(payload, mean_p[None])[0]
    gamma = _gamma(nominal_mats)
    lam_all, vec_all = (a[0] for a in _state_eig(nominal_mats[None], gamma))
    modes = _modes_in_band(lam_all, lo, hi)
    lam0, X0 = lam_all[modes], vec_all[:, modes]
    tol = float(_threshold(lam_all[None])[0])
    setup_seconds = time.perf_counter() - t_setup

    # small dense solves one after another: serial BLAS (threads on busy cores: 12x slower, measured)
    with threadpool_limits(1, user_api="blas"):
        results: dict[str, dict[str, Any]] = {}
        X = None
        names = [p.name for p in unc]
        check = _residual_check(setup, names)
        checked = np.zeros(0) if check is None else np.array([_nominal_residual(setup, names, mean_p, gamma, lo, hi)])
        if "montecarlo" in methods:
            t0 = time.perf_counter()
            X = sample_parameters(unc, samples, np.random.default_rng(np.random.SeedSequence(seed)))
            _check_scatter_samples(unc, X, model, is_fe)
            mc = _montecarlo(builder, payload, X, lam0, X0, tol, lo, hi, gamma, check, batch_size, client)
            if check is not None:
                checked = np.concatenate([checked, mc["residual"]])
            results["montecarlo"] = _montecarlo_summary(mc, lam0, confidence)
            results["montecarlo"]["seconds"] = time.perf_counter() - t0
        if "perturbation" in methods:
            t0 = time.perf_counter()
            if is_fe:
                first, second = setup["payload"][1], None
            else:
                first, second = _fd_derivatives(builder, payload, mean_p, _FD_STEP * std_p)
            pert = _perturbation(nominal_mats, first, second, gamma, lam0, std_p, m3, m4, tol, seed)
            pert["seconds"] = time.perf_counter() - t0
            results["perturbation"] = pert
            bad = np.flatnonzero(pert["status"] == 2)
            if bad.size:
                freqs = ", ".join(f"{x:.6g}" for x in lam0[bad].imag / (2 * math.pi))
                warnings.warn(f"The perturbation estimate does not hold for the modes at {freqs} Hz: they lie "
                              f"near a coalescence of eigenvalues (coupling ratio above {COUPLING_MAX:g}); their "
                              "probability and the system's perturbation propensity are NaN. Use the Monte Carlo "
                              "result.",
                              PerturbationWarning, stacklevel=2)
    max_res = float(checked.max(initial=0.0))
    trusted = bool(max_res <= eta_max)
    if not trusted:
        warnings.warn(f"The reduced basis does not hold the scattered models: the largest full-model backward "
                      f"error of the nominal model and the samples is {max_res:.3g} (above eta_max={eta_max:g}); "
                      "pass a richer basis= or a narrower scatter.", UserWarning, stacklevel=2)
    return _dataset(model, unc, units, methods, results, lam0, X, mean_p, std_p, attrs={
        "rpm": rpm if is_fe else math.nan, "disc_speed": disc_speed if is_fe else math.nan, "mu": mu,
        "theta": theta, "tan_theta": tan_t, "band_hz": [lo, hi], "seed": seed,
        "samples": samples if "montecarlo" in methods else 0,
        "confidence": confidence, "basis": setup["basis"],
        "n_reduced": int(nominal_mats.shape[-1]),
        "n_full": int(model.n_dof),
        "residual_checked": int(checked.size), "max_residual": max_res, "eta_max": eta_max,
        "residual_scope": ("the nominal model and every sample" if is_fe else
                           "none: a small model is solved whole, with no reduced basis to check"),
        "trusted": int(trusted), "setup_seconds": setup_seconds, "damped": int(bool(damped)) if not is_fe else 1})


def _dataset(model: Any, unc: Sequence[UncertainParameter], units: Sequence[str], methods: tuple[str, ...],
             results: dict[str, dict[str, Any]], lam0: NDArray, X: NDArray | None, mean_p: NDArray,
             std_p: NDArray, *, attrs: dict[str, Any]) -> xr.Dataset:
    m = lam0.size
    per_mode = {k: np.array([results[meth][k] for meth in methods]).reshape(len(methods), m)
                for k in ("mean", "std", "probability")}
    ci = np.array([results[meth]["ci"] for meth in methods], dtype=float).reshape(len(methods), 2)
    data: dict[str, Any] = {
        "frequency_hz": ("mode", lam0.imag / (2 * math.pi), {"units": "Hz", "long_name": "frequency (nominal)"}),
        "growth_rate": ("mode", lam0.real, {"units": "1/s", "long_name": "growth rate (nominal: the mean "
                                                                         "parameters)"}),
        "growth_rate_mean": (("estimator", "mode"), per_mode["mean"],
                             {"units": "1/s", "long_name": "mean growth rate"}),
        "growth_rate_std": (("estimator", "mode"), per_mode["std"],
                            {"units": "1/s", "long_name": "standard deviation of the growth rate"}),
        "probability_unstable": (("estimator", "mode"), per_mode["probability"],
                                 {"units": "1", "long_name": "probability that the mode grows"}),
        "propensity": ("estimator", [results[meth]["propensity"] for meth in methods],
                       {"units": "1", "long_name": "probability that some mode in the band grows"}),
        "propensity_ci_lower": ("estimator", ci[:, 0], {"units": "1", "long_name": "lower end of the interval"}),
        "propensity_ci_upper": ("estimator", ci[:, 1], {"units": "1", "long_name": "upper end of the interval"}),
        "cost_seconds": ("estimator", [results[meth]["seconds"] for meth in methods],
                         {"units": "s", "long_name": "wall time of the method (after the common set-up)"}),
        "distribution_mean": ("parameter", mean_p, {"long_name": "distribution mean (unit: parameter_unit)"}),
        "distribution_std": ("parameter", std_p, {"long_name": "distribution standard deviation"}),
    }
    if "perturbation" in results:
        pert = results["perturbation"]
        data |= {
            "growth_rate_sensitivity": (("mode", "parameter"), pert["grad"],
                                        {"units": "1/s per unit of the parameter",
                                         "long_name": "first derivative of the growth rate"}),
            "perturbation_status": ("mode", pert["status"],
                                    {"flag_values": " ".join(str(i) for i in range(len(PERTURBATION_STATUS))),
                                     "flag_meanings": " ".join(PERTURBATION_STATUS)}),
            "coupling_ratio": ("mode", pert["ratio"],
                               {"units": "1", "long_name": "three-sigma coupling to the nearest eigenvalue "
                                f"(the estimate holds up to {COUPLING_MAX:g})"}),
        }
    if "montecarlo" in results:
        mc = results["montecarlo"]
        data |= {
            "parameter_value": (("sample", "parameter"), X, {"long_name": "sampled value (unit: parameter_unit)"}),
            "unstable": ("sample", mc["unstable"], {"long_name": "some mode in the band grows"}),
            "max_growth_rate": ("sample", mc["top"], {"units": "1/s", "long_name": "largest growth rate in the band"}),
            "sampled_growth_rate": (("sample", "mode"), mc["growth"],
                                    {"units": "1/s", "long_name": "growth rate of the nominal mode in the sample "
                                                                  "(NaN: match indeterminate)"}),
            "match_indeterminate": (("sample", "mode"), mc["ambiguous"],
                                    {"long_name": "the nominal mode could not be told apart in the sample (two "
                                                  "candidates of near-equal shape and eigenvalue)"}),
        }
        if np.isfinite(mc["residual"]).any():
            data["sample_residual"] = ("sample", mc["residual"], {
                "units": "1", "long_name": "largest full-model backward error of the sample's pairs in the band"})
    ci_method = {"montecarlo": "clopper-pearson", "perturbation": "bounds of the per-mode probabilities"}
    ds = xr.Dataset(
        data,
        coords={
            "estimator": ("estimator", np.array(methods, dtype=object)),
            "mode": ("mode", np.arange(m)),
            "parameter": ("parameter", np.array([p.name for p in unc], dtype=object)),
            "parameter_unit": ("parameter", np.array(units, dtype=object)),
            **({"sample": ("sample", np.arange(X.shape[0]))} if X is not None else {}),
        },
        attrs={
            "kind": "robust_margins",
            "title": "Robust margins: squeal propensity under parameter scatter",
            **attrs,
            "theta_deg": math.degrees(attrs["theta"]),
            "ci_method": json.dumps({meth: ci_method[meth] for meth in methods}),
            "coupling_max": COUPLING_MAX,
            "scatter": json.dumps([p.to_dict() for p in unc]),
            "model": model.to_json(),
            "model_kind": model.kind,
            "reference": "Nobari, Ouyang & Bannister, J. Sound Vib. 338 (2015): second-order perturbation of "
                         "complex eigenvalues; Clopper-Pearson interval of the Monte Carlo share",
            "squealkit_version": __version__,
        },
    )
    return ds

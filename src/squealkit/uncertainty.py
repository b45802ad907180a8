"""Uncertain parameters and the probability of squeal: Monte Carlo over the stability analysis.

Parameters of a rig scatter: stiffnesses from part to part, contact stiffness with wear,
the pin's incline with assembly. Describe them by distributions in the model file::

    [uncertain]
    k3 = {dist = "normal", mean = 9.452e8, std = 4.7e7}        # N/m
    kc = {dist = "lognormal", mean = 4.632e7, std = 4.6e6}     # mean and std of kc itself
    alpha_deg = {dist = "uniform", lower = 1.5, upper = 2.5}   # an angle in degrees

and :func:`squeal_propensity` draws seeded samples of them, runs the paper's stability
analysis (eqs. 7-8) on every sample over a grid of friction coefficients, and returns the
probability of instability against mu (a squeal-propensity curve) with a binomial
confidence band, and Sobol' global sensitivity indices saying which parameters drive the
critical friction.

Distributions (each backed by a frozen ``scipy.stats`` distribution):

- ``normal``: ``mean``, ``std`` (> 0).
- ``uniform``: ``lower`` < ``upper``.
- ``lognormal``: either ``mean`` and ``std`` of the variable itself (converted to the
  underlying normal: ``sigma^2 = ln(1 + (std/mean)^2)``, ``median = mean / sqrt(1 +
  (std/mean)^2)``), or ``median`` and ``sigma`` (the standard deviation of ``ln x``).

A name is any scalar parameter of the model (``squealkit presets`` lists them), in SI
units, or ``NAME_deg`` for an angle in degrees. With a ``[rig]`` table it may also be any
quantity of the rig (``disc_freq = {dist = "normal", mean = 2346.0, std = 30.0}``, pin sizes,
its material): each sample's model is then derived anew from its rig (paper §5.1). Every sampled value must lie in the
parameter's allowed range (a stiffness > 0, an angle within +-90 deg): a draw outside it
is an error naming the parameter, never silently clipped (choose a lognormal for a
positive quantity with a large scatter).
"""

from __future__ import annotations

import json
import math
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray

from . import __version__
from ._validation import (
    InputError,
    check_memory,
    validate_angle,
    validate_dataset,
    validate_finite,
    validate_int,
    validate_model,
)
from .models import FrictionModel, RigModel, load_model
from .models._base import resolve_damped
from .models.config import _read_toml
from .stability import ONSET_STATUS

__all__ = [
    "DISTRIBUTIONS",
    "CensoredWarning",
    "UncertainParameter",
    "load_uncertain",
    "parse_uncertain",
    "propensity_summary",
    "sample_parameters",
    "squeal_propensity",
]


class CensoredWarning(UserWarning):
    """Some samples' critical friction lies outside the friction grid (censored)."""


#: Distribution name -> the accepted sets of keys.
DISTRIBUTIONS: dict[str, tuple[tuple[str, ...], ...]] = {
    "normal": (("mean", "std"),),
    "uniform": (("lower", "upper"),),
    "lognormal": (("mean", "std"), ("median", "sigma")),
}
#: Parameter kinds that can be uncertain (not the sliding sign, not matrices).
_UNCERTAIN_KINDS = ("positive", "nonnegative", "angle", "finite")
#: Rows of the sample matrix per task (results never depend on it).
_BATCH = 2048
#: Bootstrap resamples for the confidence intervals of the Sobol' indices.
_BOOTSTRAP_RESAMPLES = 999


def _keys_text(dist: str) -> str:
    return " or ".join("+".join(keys) for keys in DISTRIBUTIONS[dist])


@dataclass(frozen=True)
class UncertainParameter:
    """One model parameter described by a probability distribution.

    Parameters
    ----------
    name : str
        The model parameter (SI units), or ``NAME_deg`` for an angle in degrees.
    dist : str
        ``"normal"``, ``"uniform"`` or ``"lognormal"`` (:data:`DISTRIBUTIONS`).
    params : dict of str to float
        ``mean``/``std`` (normal); ``lower``/``upper`` (uniform); ``mean``/``std`` of the
        variable or ``median``/``sigma`` of its logarithm (lognormal).

    Examples
    --------
    >>> p = UncertainParameter("kc", "lognormal", {"mean": 4.632e7, "std": 4.6e6})
    >>> print(f"{p.distribution.mean():.6g} {p.distribution.std():.6g}")   # kc's own mean and std
    4.632e+07 4.6e+06
    """

    name: str
    dist: str
    params: dict[str, float] = field(hash=False)

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise InputError(f"Uncertain parameter name {self.name!r} must be a non-empty string.")
        if self.dist not in DISTRIBUTIONS:
            raise InputError(
                f"Uncertain parameter {self.name}: unknown dist={self.dist!r}; known: {', '.join(DISTRIBUTIONS)}."
            )
        if not isinstance(self.params, Mapping):
            raise InputError(f"Uncertain parameter {self.name}: params must be a table of NAME = VALUE.")
        given = set(self.params)
        if not any(given == set(keys) for keys in DISTRIBUTIONS[self.dist]):
            raise InputError(
                f"Uncertain parameter {self.name}: a {self.dist} distribution takes {_keys_text(self.dist)}, "
                f"got {', '.join(sorted(given)) or 'nothing'}."
            )
        values = {k: validate_finite(f"{self.name}.{k}", self.params[k]) for k in self.params}
        for k in ("std", "sigma"):
            if k in values and not values[k] > 0:
                raise InputError(f"Uncertain parameter {self.name}: {k}={values[k]!r} must be > 0.")
        if self.dist == "uniform" and not values["lower"] < values["upper"]:
            raise InputError(
                f"Uncertain parameter {self.name}: lower={values['lower']!r} must be < upper={values['upper']!r}."
            )
        if self.dist == "lognormal":
            for k in ("mean", "median"):
                if k in values and not values[k] > 0:
                    raise InputError(
                        f"Uncertain parameter {self.name}: a lognormal {k}={values[k]!r} must be > 0."
                    )
            # sigma of the log beyond 10 spans e^20 ~ 1e9 between -1 and +1 sigma: no scatter a
            # real part has, and its samples would overflow
            if "std" in values and values["std"] / values["mean"] > 1e4:
                raise InputError(
                    f"Uncertain parameter {self.name}: a lognormal std={values['std']!r} is "
                    f"{values['std'] / values['mean']:.3g} times its mean; a physical scatter is far below 1e4 times.")
            if "sigma" in values and values["sigma"] > 10.0:
                raise InputError(f"Uncertain parameter {self.name}: a lognormal sigma={values['sigma']!r} (of the "
                                 "log) above 10 spans more than 1e8 within one sigma; no physical scatter is that "
                                 "wide.")
        object.__setattr__(self, "params", values)

    @property
    def distribution(self) -> Any:
        """The frozen ``scipy.stats`` distribution."""
        from scipy import stats

        p = self.params
        if self.dist == "normal":
            return stats.norm(loc=p["mean"], scale=p["std"])
        if self.dist == "uniform":
            return stats.uniform(loc=p["lower"], scale=p["upper"] - p["lower"])
        if "median" in p:
            return stats.lognorm(s=p["sigma"], scale=p["median"])
        s2 = math.log1p((p["std"] / p["mean"]) ** 2)
        return stats.lognorm(s=math.sqrt(s2), scale=p["mean"] / math.sqrt(1.0 + (p["std"] / p["mean"]) ** 2))

    @property
    def is_degrees(self) -> bool:
        """Whether the name is ``NAME_deg`` (values in degrees, the model takes radians)."""
        return self.name.endswith("_deg")

    @property
    def model_parameter(self) -> str:
        """The model's parameter name (``alpha`` for ``alpha_deg``)."""
        return self.name[:-4] if self.is_degrees else self.name

    def to_dict(self) -> dict[str, Any]:
        """``{"name": ..., "dist": ..., **params}``: the file's entry."""
        return {"name": self.name, "dist": self.dist, **self.params}


def _resolve_name(name: str, info: Mapping[str, Mapping[str, str]], kind: str) -> None:
    from .models import PinOnDiscRig

    uncertain = [k for k, v in info.items() if v["kind"] in _UNCERTAIN_KINDS]
    known = ", ".join(uncertain + [f"{k}_deg" for k in uncertain if info[k]["kind"] == "angle"])
    base = name[:-4] if name.endswith("_deg") and name not in info else name
    if base not in info and base in PinOnDiscRig.parameter_info():
        raise InputError(f"Uncertain parameter {name!r} is a rig quantity: it needs a model file with a [rig] table "
                         f"(the model is derived from the rig for every sample); model {kind!r} knows: {known}.")
    if base not in info or (base != name and info[base]["kind"] != "angle"):
        raise InputError(f"Unknown uncertain parameter {name!r} for model {kind!r}; known: {known}.")
    if info[base]["kind"] not in _UNCERTAIN_KINDS:
        raise InputError(f"Parameter {name!r} of model {kind!r} cannot be uncertain; these can: {known}.")


def parse_uncertain(
    table: Mapping[str, Any], model: FrictionModel | type[FrictionModel] | RigModel
) -> tuple[UncertainParameter, ...]:
    """Parse an ``[uncertain]`` table for ``model``: ``NAME = {dist = ..., ...}`` entries.

    Parameters
    ----------
    table : mapping
        Parameter name -> ``{"dist": ..., <distribution keys>}`` (see the module docstring).
    model : FrictionModel or its class, or RigModel
        Names are checked against its parameters; a :class:`~squealkit.models.RigModel` (a
        model file with a ``[rig]`` table) also takes every quantity of the rig (``disc_freq``,
        ``pin_diameter``, ``pin_bending_freq``, ...).

    Returns
    -------
    tuple of UncertainParameter
        In the table's order (which fixes the order of the sample matrix's columns).

    Examples
    --------
    >>> from squealkit.models import PinOnDisc3DOF
    >>> parse_uncertain({"k3": {"dist": "normal", "mean": 9.452e8, "std": 4.7e7}}, PinOnDisc3DOF)
    (UncertainParameter(name='k3', dist='normal', params={'mean': 945200000.0, 'std': 47000000.0}),)
    """
    if not isinstance(table, Mapping) or not table:
        raise InputError(
            'The [uncertain] table is empty; add e.g. k3 = {dist = "normal", mean = 9.452e8, std = 4.7e7}.'
        )
    info = model.parameter_info()
    out = []
    seen: dict[str, str] = {}
    for name, spec in table.items():
        _resolve_name(name, info, model.kind)
        if not isinstance(spec, Mapping):
            raise InputError(
                f"Uncertain parameter {name}: give a table like {{dist = \"normal\", mean = ..., std = ...}}, "
                f"not {spec!r}."
            )
        spec = dict(spec)
        dist = spec.pop("dist", None)
        if dist is None:
            raise InputError(f"Uncertain parameter {name}: missing dist (one of {', '.join(DISTRIBUTIONS)}).")
        p = UncertainParameter(name, dist, spec)
        if p.model_parameter in seen:
            raise InputError(f"Uncertain parameter {name}: {seen[p.model_parameter]} is already uncertain.")
        seen[p.model_parameter] = name
        out.append(p)
    return tuple(out)


def load_uncertain(
    path: str | Path, model: FrictionModel | type[FrictionModel] | RigModel | None = None
) -> tuple[UncertainParameter, ...]:
    """Read the ``[uncertain]`` table of a TOML file.

    Parameters
    ----------
    path : path-like
        The file (usually the model file; other tables are ignored here).
    model : FrictionModel or its class, or RigModel, optional
        The model the names refer to (a RigModel: also the rig's quantities); default the
        model the file itself describes.

    Returns
    -------
    tuple of UncertainParameter
    """
    p = Path(path)
    doc = _read_toml(p)
    if "uncertain" not in doc:
        raise InputError(
            f"{p.name} has no [uncertain] table; add one, e.g. "
            'k3 = {dist = "normal", mean = 9.452e8, std = 4.7e7}.'
        )
    if model is None:
        from .models import load_rig_model

        model = load_rig_model(p) or load_model(p)
    try:
        return parse_uncertain(doc["uncertain"], model)
    except InputError as e:
        raise InputError(f"{p.name}: {e}") from e


def sample_parameters(
    uncertain: Sequence[UncertainParameter], n: int, rng: np.random.Generator
) -> NDArray[np.float64]:
    """Draw ``n`` independent samples of every uncertain parameter.

    Columns in the order of ``uncertain``, each drawn in turn from ``rng`` (so the draw is
    reproducible from the generator's seed), in the parameters' own units (degrees for
    ``*_deg``).

    Parameters
    ----------
    uncertain : sequence of UncertainParameter
        The parameters, one column each.
    n : int
        Number of samples (rows).
    rng : numpy.random.Generator
        The generator drawn from, e.g. ``np.random.default_rng(seed)``.

    Returns
    -------
    ndarray, shape (n, len(uncertain))
        The samples; column j holds those of ``uncertain[j]``.

    Examples
    --------
    >>> x = sample_parameters([UncertainParameter("k3", "uniform", {"lower": 1.0, "upper": 2.0})], 1000,
    ...                       np.random.default_rng(0))
    >>> x.shape, bool(((1 <= x) & (x < 2)).all())
    ((1000, 1), True)
    """
    out = np.empty((int(n), len(uncertain)))
    for j, p in enumerate(uncertain):
        out[:, j] = p.distribution.rvs(size=int(n), random_state=rng)
    return out


def _check_samples(uncertain: Sequence[UncertainParameter], values: NDArray, model: FrictionModel | RigModel) -> None:
    """Every sampled value inside its parameter's allowed range, or one line saying which is not."""
    info = model.parameter_info()
    for j, p in enumerate(uncertain):
        x = values[:, j]
        kind = info[p.model_parameter]["kind"]
        if kind == "positive":
            bad, need = ~(x > 0), "> 0"
        elif kind == "nonnegative":
            bad, need = ~(x >= 0), ">= 0"
        elif kind == "angle":
            lim = 90.0 if p.is_degrees else math.pi / 2
            unit = "deg" if p.is_degrees else "rad"
            bad, need = ~(np.abs(x) < lim), f"strictly between -{lim:g} and {lim:g} {unit}"
        else:
            bad, need = ~np.isfinite(x), "finite"
        if bad.any():
            shown = ", ".join(f"{k}={v}" for k, v in p.params.items())
            raise InputError(
                f"Uncertain parameter {p.name}: {int(bad.sum())} of {x.size} sampled values are outside the "
                f"allowed range ({need}), e.g. {x[bad][0]:.6g} ({p.dist} {shown}); use a narrower distribution"
                + (" or a lognormal." if kind == "positive" else ".")
            )


def _sample_models(model: FrictionModel | RigModel, names: Sequence[tuple[str, bool]],
                   values: NDArray) -> list[FrictionModel]:
    """One model per row of ``values``: with a rig, derived anew from the sampled rig."""
    out = []
    for row in values:
        changes = {name: (math.radians(v) if deg else float(v)) for (name, deg), v in zip(names, row, strict=True)}
        out.append(model.to_model(**changes) if isinstance(model, RigModel) else model.replace(**changes))
    return out


def _evaluate(task: tuple) -> tuple[NDArray[np.bool_], NDArray[np.float64], NDArray[np.int8]]:
    """One batch of samples: stability over the mu grid and the critical friction of each."""
    from .stability import ModelEnsemble, ensemble_onset, ensemble_unstable

    model, names, values, mu, tan_theta, damped = task
    ens = ModelEnsemble.from_models(_sample_models(model, names, values), damped=damped)
    unstable = ensemble_unstable(ens, mu, tan_theta=tan_theta)
    mu_c, status = ensemble_onset(ens, mu, tan_theta=tan_theta)
    return unstable, mu_c, status


def _binomial_band(count: NDArray, n: int, confidence: float) -> tuple[NDArray, NDArray]:
    from scipy import stats

    ci = [stats.binomtest(int(k), n).proportion_ci(confidence_level=confidence, method="exact") for k in count]
    return np.array([c.low for c in ci]), np.array([c.high for c in ci])


def _sobol(f_A: NDArray, f_B: NDArray, f_AB: NDArray, confidence: float, rng: np.random.Generator):
    """First-order and total Sobol' indices (Saltelli 2010) with percentile-bootstrap intervals."""
    from scipy import stats

    d, n = f_AB.shape
    nan = np.full(d, np.nan)
    if n < 2 or np.ptp(np.concatenate([f_A, f_B])) == 0.0:
        return nan, nan, (nan, nan), (nan, nan)

    def indices(idx: NDArray) -> tuple[NDArray, NDArray]:
        # resamples as extra outputs of one call: shapes (s, n) and (d, s, n)
        idx2 = np.atleast_2d(idx)
        res = stats.sobol_indices(func={"f_A": f_A[idx2], "f_B": f_B[idx2], "f_AB": f_AB[:, idx2]}, n=n)
        s = idx2.shape[0]
        # two outputs keep scipy's arrays 2-D when d == 1
        return np.reshape(res.first_order, (s, d)), np.reshape(res.total_order, (s, d))

    whole = np.arange(n)
    first, total = (x[0] for x in indices(np.stack([whole, whole])))

    def statistic(idx: NDArray, axis: int = -1) -> NDArray:
        lead = idx.shape[:-1]
        s1, st = indices(idx.reshape(-1, n))
        return np.concatenate([s1.T, st.T]).reshape((2 * d, *lead))

    batch = max(1, 8_000_000 // (n * (d + 2)))
    boot = stats.bootstrap((whole,), statistic, n_resamples=_BOOTSTRAP_RESAMPLES, vectorized=True, batch=batch,
                           confidence_level=confidence, method="percentile", rng=rng)
    low, high = boot.confidence_interval.low, boot.confidence_interval.high
    return first, total, (low[:d], high[:d]), (low[d:], high[d:])


def _spearman(x: NDArray, y: NDArray) -> NDArray:
    from scipy import stats

    out = np.full(x.shape[1], np.nan)
    for j in range(x.shape[1]):
        if np.ptp(x[:, j]) > 0 and np.ptp(y) > 0:
            out[j] = stats.spearmanr(x[:, j], y).statistic
    return out


def squeal_propensity(
    model: FrictionModel,
    uncertain: Sequence[UncertainParameter] | Mapping[str, Any],
    mu: ArrayLike,
    *,
    samples: int,
    theta: float = 0.0,
    damped: bool | None = None,
    seed: int = 0,
    confidence: float = 0.95,
    sensitivity: bool = True,
    batch_size: int = _BATCH,
    client: Any = None,
    progress: Callable[[int, int], None] | None = None,
    rig: RigModel | None = None,
) -> xr.Dataset:
    """Probability of instability against friction, for parameters with given distributions.

    Every sample is a model (``model`` with the sampled values); it is unstable at ``mu``
    when some mode of ``M x'' + (C x') + K(mu, tan theta) x = 0`` grows (paper eqs. 7-8,
    the criterion of :func:`~squealkit.stability.eigenvalues`). The share of unstable
    samples at each ``mu`` is the squeal propensity; its band is the Clopper-Pearson
    ("exact") binomial interval, which covers the true probability at least ``confidence``
    of the time at each mu.

    The global sensitivity is of each sample's critical friction ``mu_critical`` (the
    start of its first unstable window, found as by
    :func:`~squealkit.stability.critical_friction`; NaN, a censored sample, where it lies
    outside ``[mu[0], mu[-1]]``, with a :class:`CensoredWarning`; the indices use it clipped
    to the range):
    Sobol' first-order and total indices (``scipy.stats.sobol_indices``, Saltelli 2010
    estimators) with percentile-bootstrap intervals, and Spearman's rank correlation. The
    first ``2 n_base`` samples double as Saltelli's two base matrices A and B, with
    ``n_base`` the largest power of two <= ``samples / 2`` (scipy's requirement; choose
    ``samples`` a power of two to use them all), so the indices cost
    ``len(uncertain) * n_base`` further model evaluations.

    Parameters
    ----------
    model : FrictionModel
        The nominal model; uncertain parameters replace its values sample by sample.
    uncertain : sequence of UncertainParameter, or an ``[uncertain]`` table
        See :func:`parse_uncertain` and the module docstring.
    mu : array_like, 1-D
        Friction coefficients, strictly increasing.
    samples : int
        Independent Monte Carlo samples (>= 2).
    theta : float
        Run-out incline [rad] (tan(theta) enters as in eq. 6).
    damped : bool, optional
        Include the damping matrix C. Not given: left out (paper eq. 7 is undamped), with a
        warning when the model has damping.
    seed : int
        Seed of the draw (``numpy.random.SeedSequence``); the same seed gives the same
        result whatever ``batch_size`` or ``client``.
    confidence : float
        Level of the confidence band and of the indices' intervals, in (0, 1).
    sensitivity : bool
        Compute the Sobol' indices (and the extra evaluations they need).
    batch_size : int
        Samples per task.
    client : distributed.Client, optional
        Run the batches on this Dask cluster (see :mod:`squealkit.scale`); the numbers are
        identical to the local run.
    progress : callable, optional
        ``progress(done, total)`` in model evaluations.
    rig : RigModel, optional
        The rig ``model`` is derived from (:func:`~squealkit.models.config.load_rig_model`):
        then every quantity of the rig can be uncertain (``disc_freq``, ``pin_diameter``, ...),
        and each sample's model is derived anew from its sampled rig (``rig.to_model(...)``).

    Returns
    -------
    xarray.Dataset
        Over ``mu``: ``probability_unstable``, ``ci_lower``, ``ci_upper``,
        ``unstable_count`` and ``nominal_unstable`` (the nominal model). Over ``sample``:
        ``mu_critical``, ``onset_status`` (codes of
        :data:`~squealkit.stability.ONSET_STATUS`: 0 onset, 1 unstable at mu[0], 2 stable
        over the range, 3 indeterminate) and ``parameter_value`` (sample, parameter) in each parameter's unit. Over
        ``parameter``: ``sobol_first_order``, ``sobol_total`` and their ``*_ci_lower`` /
        ``*_ci_upper``, ``spearman``, ``distribution_mean``, ``distribution_std``.
        ``attrs``: seed, samples, confidence, ci_method, theta, damped, the model and the
        uncertain parameters as JSON, ``nominal_mu_critical``.

    Examples
    --------
    Hoffmann's model (flutter above mu = 0.2165) with an uncertain contact spring and a
    mass, which does not change the undamped threshold:

    >>> from squealkit.models import Hoffmann2002
    >>> unc = {"k3": {"dist": "normal", "mean": 8e5, "std": 4e4},
    ...        "m": {"dist": "uniform", "lower": 0.5, "upper": 2.0}}
    >>> ds = squeal_propensity(Hoffmann2002(), unc, np.linspace(0.19, 0.25, 7), samples=256, seed=1)
    >>> ds.probability_unstable.values.round(2).tolist()
    [0.0, 0.0, 0.22, 0.6, 0.8, 0.95, 0.98]
    >>> ds.sobol_total.values.round(2).tolist()          # k3 drives mu_critical, m does not
    [1.03, 0.0]
    """
    validate_model(model, kind="friction")
    damped = resolve_damped(model, damped)
    from .scale import map_tasks
    from .stability import ModelEnsemble, ensemble_onset, ensemble_unstable
    from .stability.ensemble import _grid

    if rig is not None and not isinstance(rig, RigModel):
        raise InputError(f"rig must be a squealkit RigModel (load_rig_model), not {type(rig).__name__}.")
    source = model if rig is None else rig  # what the samples change
    unc = parse_uncertain(uncertain, source) if isinstance(uncertain, Mapping) else tuple(uncertain)
    if not unc or not all(isinstance(p, UncertainParameter) for p in unc):
        raise InputError("uncertain must be a non-empty sequence of UncertainParameter (or an [uncertain] table).")
    parse_uncertain({p.name: {"dist": p.dist, **p.params} for p in unc}, source)  # names valid for this model
    mu_a = _grid(mu)
    samples = validate_int("samples", samples, 2)
    batch_size = validate_int("batch_size", batch_size, 1)
    seed = validate_int("seed", seed, 0)
    theta = validate_angle("theta", theta)
    confidence = validate_finite("confidence", confidence)
    if not 0.0 < confidence < 1.0:
        raise InputError(f"Parameter confidence={confidence!r} must lie strictly between 0 and 1.")
    tan_t = math.tan(theta)
    d = len(unc)

    # before drawing: the samples and their results, and one batch's eigenvalues over the grid
    # Saltelli's base matrices A and B: the first 2 n_base samples (scipy needs n_base = 2^k)
    n_base = 1 << ((samples // 2).bit_length() - 1) if sensitivity else 0
    n_rows = samples + d * n_base
    check_memory(n_rows * (d + 4) * 24.0 + min(batch_size, n_rows) * mu_a.size * (48.0 * model.n_dof + 40.0),
                 f"Monte Carlo of {samples} samples over {mu_a.size} mu points",
                 "Use fewer samples or mu points (or a smaller batch_size).")
    sample_seq, boot_seq = np.random.SeedSequence(seed).spawn(2)
    X = sample_parameters(unc, samples, np.random.default_rng(sample_seq))
    _check_samples(unc, X, source)
    rows = X
    if n_base:
        A, B = X[:n_base], X[n_base:2 * n_base]
        AB = np.repeat(A[None], d, axis=0)
        for i in range(d):
            AB[i, :, i] = B[:, i]
        rows = np.concatenate([X, AB.reshape(d * n_base, d)])

    names = [(p.model_parameter, p.is_degrees) for p in unc]
    starts = list(range(0, rows.shape[0], batch_size))
    tasks = [(source, names, rows[a:a + batch_size], mu_a, tan_t, damped) for a in starts]
    weights = [min(batch_size, rows.shape[0] - a) for a in starts]
    count = np.zeros(mu_a.size, dtype=np.int64)
    mu_c = np.empty(rows.shape[0])
    status = np.empty(rows.shape[0], dtype=np.int8)
    for i, (unstable, mc, st) in map_tasks(_evaluate, tasks, client=client, progress=progress, weights=weights,
                                           name="squealkit-montecarlo"):
        a = starts[i]
        mu_c[a:a + mc.size] = mc
        status[a:a + mc.size] = st
        count += unstable[: max(0, min(mc.size, samples - a))].sum(axis=0)

    nominal = ModelEnsemble.from_models([model], damped=damped)
    nom_unstable = ensemble_unstable(nominal, mu_a, tan_theta=tan_t)
    nom_mu_c, nom_status = ensemble_onset(nominal, mu_a, tan_theta=tan_t, rtol=0.0)  # one model: exactly
    censored = int(np.sum(status[:samples] == 2))
    below = int(np.sum(status[:samples] == 1))
    if censored or below:
        warnings.warn(
            f"{censored} of {samples} samples are stable up to mu = {mu_a[-1]:g} and {below} unstable "
            f"already at mu = {mu_a[0]:g}: their mu_critical lies outside the grid (censored, NaN); "
            "widen the mu range to resolve them.", CensoredWarning, stacklevel=2)
    lower, upper = _binomial_band(count, samples, confidence)

    info = source.parameter_info()
    units = ["deg" if p.is_degrees else info[p.model_parameter]["unit"] for p in unc]
    dists = [p.distribution for p in unc]
    data_vars: dict[str, Any] = {
        "probability_unstable": ("mu", count / samples,
                                 {"units": "1", "long_name": "share of samples with an unstable mode"}),
        "ci_lower": ("mu", lower, {"units": "1", "long_name": f"lower end of the {confidence:g} confidence band",
                                   "method": "Clopper-Pearson (exact binomial)"}),
        "ci_upper": ("mu", upper, {"units": "1", "long_name": f"upper end of the {confidence:g} confidence band",
                                   "method": "Clopper-Pearson (exact binomial)"}),
        "unstable_count": ("mu", count, {"units": "1", "long_name": "unstable samples"}),
        "nominal_unstable": ("mu", nom_unstable[0], {"long_name": "nominal model unstable"}),
        "mu_critical": ("sample", mu_c[:samples],
                        {"units": "1", "long_name": "critical friction of the sample (NaN: outside the mu "
                         "range, censored; see onset_status)"}),
        "onset_status": ("sample", status[:samples],
                         {"flag_values": " ".join(str(i) for i in range(len(ONSET_STATUS))),
                          "flag_meanings": " ".join(ONSET_STATUS)}),
        "parameter_value": (("sample", "parameter"), X, {"long_name": "sampled value (unit: parameter_unit)"}),
        "distribution_mean": ("parameter", [float(x.mean()) for x in dists], {"long_name": "distribution mean"}),
        "distribution_std": ("parameter", [float(x.std()) for x in dists],
                             {"long_name": "distribution standard deviation"}),
    }
    if sensitivity:
        # Sobol' indices need a value per sample: a censored onset counts at the range's end
        f = np.where(status == 2, mu_a[-1], np.where(status == 1, mu_a[0], mu_c))
        f_AB = f[samples:].reshape(d, n_base)
        s1, st, ci1, cit = _sobol(f[:n_base], f[n_base:2 * n_base], f_AB, confidence,
                                  np.random.default_rng(boot_seq))
        ci_attrs = {"units": "1", "method": "percentile bootstrap", "confidence": confidence}
        data_vars |= {
            "sobol_first_order": ("parameter", s1,
                                  {"units": "1", "long_name": "Sobol' first-order index of mu_critical"}),
            "sobol_total": ("parameter", st, {"units": "1", "long_name": "Sobol' total index of mu_critical"}),
            "sobol_first_order_ci_lower": ("parameter", ci1[0], ci_attrs),
            "sobol_first_order_ci_upper": ("parameter", ci1[1], ci_attrs),
            "sobol_total_ci_lower": ("parameter", cit[0], ci_attrs),
            "sobol_total_ci_upper": ("parameter", cit[1], ci_attrs),
            "spearman": ("parameter", _spearman(X, f[:samples]),
                         {"units": "1", "long_name": "Spearman rank correlation with mu_critical"}),
        }
    return xr.Dataset(
        data_vars,
        coords={
            "mu": ("mu", mu_a, {"units": "1", "long_name": "friction coefficient"}),
            "sample": ("sample", np.arange(samples)),
            # variable-length strings (zarr has no stable fixed-width string type)
            "parameter": ("parameter", np.array([p.name for p in unc], dtype=object)),
            "parameter_unit": ("parameter", np.array(units, dtype=object)),
        },
        attrs={
            "kind": "propensity",
            "title": "Squeal propensity: probability of instability over friction (Monte Carlo)",
            "seed": seed,
            "samples": samples,
            "confidence": confidence,
            "ci_method": "clopper-pearson",
            "theta": theta,
            "theta_deg": math.degrees(theta),
            "tan_theta": tan_t,
            "damped": int(damped),
            "sensitivity": int(sensitivity),
            "sobol_method": "saltelli_2010 (scipy.stats.sobol_indices), output mu_critical",
            "sobol_base_samples": n_base,
            "bootstrap_resamples": _BOOTSTRAP_RESAMPLES if sensitivity else 0,
            "model_evaluations": int(rows.shape[0]),
            "nominal_mu_critical": float(nom_mu_c[0]),
            "nominal_onset_status": int(nom_status[0]),
            "model": model.to_json(),
            "model_kind": model.kind,
            "uncertain": json.dumps([p.to_dict() for p in unc]),
            "reference": "Lv, Zhang & Yu, J. Vibroeng. 15(2) 2013, eqs. (4), (6)-(8): stability per sample",
            "squealkit_version": __version__,
        },
    )


_STATUS_NAMES = ONSET_STATUS


def _num(x: Any) -> float | None:
    x = float(x)
    return x if math.isfinite(x) else None


def propensity_summary(ds: xr.Dataset) -> dict[str, Any]:
    """The headline numbers of :func:`squeal_propensity` (``squealkit montecarlo --json``).

    Parameters
    ----------
    ds : xarray.Dataset
        A result of :func:`squeal_propensity` (with or without the Sobol' indices).

    Returns
    -------
    dict
        ``mu``, ``probability_unstable``, ``ci_lower``, ``ci_upper``, ``unstable_count``,
        ``nominal_unstable`` (lists over mu); ``samples``, ``seed``, ``confidence``,
        ``ci_method``, ``theta_deg``, ``damped``, ``nominal_mu_critical``; ``mu_critical``
        (``mean`` and ``std`` over the samples with an onset in the range; ``p05``, ``p50``,
        ``p95`` over all samples, censored ones counted beyond the range's ends, None where a
        percentile falls among censored samples; ``censored``, the number of samples whose
        onset lies outside the range; and the share of each ``onset_status``);
        ``parameters`` (the distributions); ``sensitivity``: per
        parameter ``first_order``, ``first_order_ci``, ``total``, ``total_ci``,
        ``spearman`` and ``unit`` (None without sensitivity).
    """
    validate_dataset(ds, what="squeal_propensity")
    mc = ds["mu_critical"].values
    st = ds["onset_status"].values
    # order statistics with the censored samples at -inf (below the range) / +inf (above):
    # a percentile that falls among censored samples is unknown (None)
    ranked = np.where(st == 1, -np.inf, np.where(st == 2, np.inf, mc))
    p05, p50, p95 = (_num(np.percentile(ranked, q, method="inverted_cdf")) for q in (5, 50, 95))
    inside = mc[np.isfinite(mc)]
    out: dict[str, Any] = {
        "mu": ds.mu.values.tolist(),
        "probability_unstable": ds.probability_unstable.values.tolist(),
        "ci_lower": ds.ci_lower.values.tolist(),
        "ci_upper": ds.ci_upper.values.tolist(),
        "unstable_count": ds.unstable_count.values.tolist(),
        "nominal_unstable": ds.nominal_unstable.values.astype(bool).tolist(),
        "samples": int(ds.attrs["samples"]),
        "seed": int(ds.attrs["seed"]),
        "confidence": float(ds.attrs["confidence"]),
        "ci_method": ds.attrs["ci_method"],
        "theta_deg": float(ds.attrs["theta_deg"]),
        "damped": bool(ds.attrs["damped"]),
        "nominal_mu_critical": _num(ds.attrs["nominal_mu_critical"]),
        "nominal_status": _STATUS_NAMES[int(ds.attrs["nominal_onset_status"])],
        "mu_critical": {
            "mean": _num(inside.mean()) if inside.size else None,
            "std": _num(inside.std()) if inside.size else None,
            "p05": p05, "p50": p50, "p95": p95,
            "censored": int(np.sum((st == 1) | (st == 2))),
            **{f"{name}_fraction": float(np.mean(st == k)) for k, name in enumerate(_STATUS_NAMES)},
        },
        "parameters": json.loads(ds.attrs["uncertain"]),
        "sensitivity": None,
    }
    if "sobol_total" in ds:
        out["sensitivity"] = {
            str(name): {
                "first_order": _num(ds.sobol_first_order[j]),
                "first_order_ci": [_num(ds.sobol_first_order_ci_lower[j]), _num(ds.sobol_first_order_ci_upper[j])],
                "total": _num(ds.sobol_total[j]),
                "total_ci": [_num(ds.sobol_total_ci_lower[j]), _num(ds.sobol_total_ci_upper[j])],
                "spearman": _num(ds.spearman[j]),
                "unit": str(ds.parameter_unit.values[j]),
            }
            for j, name in enumerate(ds.parameter.values)
        }
    return out


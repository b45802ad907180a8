"""A campaign's conditions and how they become model parameters (step 1 of a correlation).

Each analysed application of a campaign (``squealkit campaign --out DIR``) has its conditions:
brake pressure [bar], temperature [degC], vehicle speed [km/h], disc speed [rpm] and the
friction coefficient the dynamometer reports (the matrix's ``mu`` column). A
:class:`ConditionMap` says how they map onto a model; in a model file it is the table::

    [correlate]
    mu = "measured"          # the matrix's mu column; "law": a friction law mu(p, T, v) fitted
                             # from the campaign's own mu; "torque": T / (n_faces p A r_eff)
    # mu_law = {mu0 = 0.4, pressure_bar = -0.002, temperature_c = 1e-4}   # a given law instead
    mu_law_terms = ["pressure_bar", "temperature_c", "disc_speed"]        # terms of a fitted law
    mu_offset = 0.0          # the model's mu = mu_scale * mu + mu_offset
    mu_scale = 1.0
    theta_deg = 0.0          # run-out incline (mu_e = mu + tan theta)
    disc_speed = "auto"      # "rpm" (the campaign's disc speed), "vehicle" (speed_kmh / rolling_radius)
    rolling_radius = 0.31    # [m], for disc_speed = "vehicle"
    effective_radius = 0.11  # [m], mu = "torque"
    piston_area = 1.6e-3     # [m^2], mu = "torque"
    n_faces = 2              # friction faces per caliper, mu = "torque"
    torque_channel = "torque"        # [N m] in the recordings, mu = "torque"
    pressure_channel = "pressure"    # [bar]; else the application's pressure_bar
    [correlate.laws]         # a model parameter scaled linearly with a condition
    k1 = {of = "temperature_c", ref = 20.0, slope = -5e-4}   # k1 (1 + slope (T - ref))
    damping = {of = "pressure_bar", ref = 20.0, slope = 0.01}  # "damping": every damping of the model

Any model parameter may be set (``NAME = value``) or scaled (``NAME_scale = factor``) with
:func:`apply_quantities`; ``damping_scale`` scales every damping of the model.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from .._validation import InputError, validate_angle, validate_finite, validate_positive

__all__ = ["CONDITIONS", "ConditionMap", "FrictionLaw", "ParameterLaw", "campaign_conditions", "condition_values",
           "fit_friction_law", "operating_points"]

#: Conditions a friction or parameter law may depend on, and their units.
CONDITIONS = {"pressure_bar": "bar", "temperature_c": "degC", "disc_speed": "rad/s", "speed_kmh": "km/h"}
_MU_SOURCES = ("measured", "law", "torque")
_SPEED_SOURCES = ("auto", "rpm", "vehicle")
_KEYS = {"mu", "mu_law", "mu_law_terms", "mu_offset", "mu_scale", "theta", "theta_deg", "disc_speed",
         "rolling_radius", "effective_radius", "piston_area", "n_faces", "torque_channel", "pressure_channel",
         "laws"}


def _condition_name(name: Any, where: str) -> str:
    if name not in CONDITIONS:
        raise InputError(f"{where}: condition {name!r} is not one of {', '.join(CONDITIONS)}.")
    return str(name)


@dataclass(frozen=True)
class FrictionLaw:
    """A friction law ``mu = mu0 + sum_k a_k (x_k - ref_k)``, linear in the conditions ``x_k``.

    Parameters
    ----------
    mu0 : float
        Friction coefficient at the reference conditions [1].
    coefficients : dict of str to float
        ``a_k`` per condition of :data:`CONDITIONS` (per its unit: 1/bar, 1/degC, s/rad, h/km).
    reference : dict of str to float
        ``ref_k`` per condition (default 0).
    residual_std : float
        Standard deviation of the measured mu about the law [1] (NaN for a given law).
    n_fit : int
        Applications it was fitted to (0: given).

    Examples
    --------
    >>> law = FrictionLaw(0.4, {"temperature_c": 1e-3}, {"temperature_c": 100.0})
    >>> float(law.mu({"temperature_c": np.array([200.0])})[0])
    0.5
    """

    mu0: float
    coefficients: dict[str, float] = field(default_factory=dict)
    reference: dict[str, float] = field(default_factory=dict)
    residual_std: float = math.nan
    n_fit: int = 0

    def mu(self, conditions: Mapping[str, Any]) -> np.ndarray:
        """The law's mu at ``conditions`` (arrays by condition name; they broadcast).

        Parameters
        ----------
        conditions : mapping of str to array_like
            Values of every condition the law uses.

        Returns
        -------
        ndarray
        """
        out = np.asarray(self.mu0, float)
        for k, a in self.coefficients.items():
            if k not in conditions:
                raise InputError(f"The friction law uses {k!r}, which the campaign does not give.")
            out = out + a * (np.asarray(conditions[k], float) - self.reference.get(k, 0.0))
        return np.asarray(out, float)

    def describe(self) -> str:
        """The law as one line, with its residual when fitted."""
        terms = "".join(f" {'+' if a >= 0 else '-'} {abs(a):.4g} ({k} - {self.reference.get(k, 0.0):.4g})"
                        for k, a in self.coefficients.items())
        fit = (f"; fitted to {self.n_fit} applications, residual std {self.residual_std:.4f}" if self.n_fit
               else " (given)")
        return f"mu = {self.mu0:.4f}{terms}{fit}"


def fit_friction_law(conditions: Mapping[str, Any], mu: Any,
                     terms: tuple[str, ...] = ("pressure_bar", "temperature_c")) -> FrictionLaw:
    """Least-squares fit of a linear friction law to measured mu (applications with every value finite).

    Parameters
    ----------
    conditions : mapping of str to array_like
        Each term's values per application.
    mu : array_like
        Measured friction coefficient per application [1].
    terms : tuple of str
        Conditions the law depends on (of :data:`CONDITIONS`); each is centred on its mean.

    Returns
    -------
    FrictionLaw
        With its residual standard deviation (``n - p`` degrees of freedom) and ``n_fit``.

    Raises
    ------
    InputError
        With fewer applications with every value than coefficients + 1, or a term that does not vary.

    Examples
    --------
    >>> T = np.array([100.0, 200.0, 300.0])
    >>> fit_friction_law({"temperature_c": T}, 0.3 + 1e-3 * T, ("temperature_c",)).mu({"temperature_c": 250.0})
    array(0.55)
    """
    for t in terms:
        _condition_name(t, "mu_law_terms")
        if t not in conditions:
            raise InputError(f"The friction law's term {t!r} is not among the campaign's conditions.")
    y = np.asarray(mu, float)
    X = np.stack([np.asarray(conditions[t], float) for t in terms], axis=-1) if terms else np.empty((y.size, 0))
    ok = np.isfinite(y) & np.all(np.isfinite(X), axis=-1)
    n, p = int(ok.sum()), len(terms) + 1
    if n < p + 1:
        raise InputError(f"A friction law of {p} coefficients needs at least {p + 1} applications with a measured mu "
                         f"and every term ({', '.join(terms) or 'none'}); the campaign has {n}.")
    X, y = X[ok], y[ok]
    ref = X.mean(axis=0)
    for t, col in zip(terms, X.T, strict=True):
        if np.ptp(col) == 0:
            raise InputError(f"The friction law's term {t!r} does not vary over the campaign ({col[0]:g}); "
                             "leave it out of mu_law_terms.")
    A = np.column_stack([np.ones(n), X - ref])
    coef, *_ = np.linalg.lstsq(A, y, rcond=None)
    resid = y - A @ coef
    std = float(np.sqrt(resid @ resid / (n - p)))
    return FrictionLaw(float(coef[0]), {t: float(c) for t, c in zip(terms, coef[1:], strict=True)},
                       {t: float(r) for t, r in zip(terms, ref, strict=True)}, std, n)


@dataclass(frozen=True)
class ParameterLaw:
    """A model parameter scaled linearly with a condition: ``value (1 + slope (x - ref))``.

    Parameters
    ----------
    name : str
        The model parameter (for an FE model: a matrix, e.g. ``"D1"``).
    of : str
        The condition (of :data:`CONDITIONS`).
    slope : float
        Relative change per unit of the condition.
    ref : float
        Condition at which the scale is 1.
    """

    name: str
    of: str
    slope: float
    ref: float = 0.0

    def scale(self, x: Any) -> np.ndarray:
        """The scale ``1 + slope (x - ref)`` at condition values ``x``.

        Parameters
        ----------
        x : array_like
            Values of the condition ``of``.

        Returns
        -------
        ndarray
        """
        return 1.0 + self.slope * (np.asarray(x, float) - self.ref)


@dataclass(frozen=True)
class ConditionMap:
    """How a campaign's conditions map onto a model (the ``[correlate]`` table; module docstring).

    Parameters
    ----------
    mu : {"measured", "law", "torque"}
        Source of each application's friction coefficient.
    mu_law : FrictionLaw, optional
        A given law (then ``mu = "law"`` uses it instead of fitting one).
    mu_law_terms : tuple of str
        Terms of a fitted law.
    mu_offset, mu_scale : float
        The model's mu is ``mu_scale * mu + mu_offset``.
    theta : float
        Run-out incline [rad].
    disc_speed : {"auto", "rpm", "vehicle"}
        Source of the disc speed: the campaign's rpm, or ``speed_kmh / rolling_radius``;
        ``auto``: rpm where the campaign has it, else the vehicle speed when ``rolling_radius`` is given.
    rolling_radius : float, optional
        Tyre rolling radius [m].
    effective_radius : float, optional
        Effective friction radius of the brake [m] (``mu = "torque"``).
    piston_area : float, optional
        Piston area [m^2] (``mu = "torque"``).
    n_faces : int
        Friction faces (``mu = T / (n_faces p A r_eff)``).
    torque_channel, pressure_channel : str, optional
        Channels of the recordings for ``mu = "torque"``: brake torque [N m], pressure [bar].
    laws : tuple of ParameterLaw
        Parameter laws.
    """

    mu: str = "measured"
    mu_law: FrictionLaw | None = None
    mu_law_terms: tuple[str, ...] = ("pressure_bar", "temperature_c")
    mu_offset: float = 0.0
    mu_scale: float = 1.0
    theta: float = 0.0
    disc_speed: str = "auto"
    rolling_radius: float | None = None
    effective_radius: float | None = None
    piston_area: float | None = None
    n_faces: int = 2
    torque_channel: str | None = None
    pressure_channel: str | None = None
    laws: tuple[ParameterLaw, ...] = ()

    def __post_init__(self) -> None:
        if self.mu not in _MU_SOURCES:
            raise InputError(f"[correlate] mu={self.mu!r} must be one of {', '.join(map(repr, _MU_SOURCES))}.")
        if self.disc_speed not in _SPEED_SOURCES:
            raise InputError(f"[correlate] disc_speed={self.disc_speed!r} must be one of "
                             f"{', '.join(map(repr, _SPEED_SOURCES))}.")
        object.__setattr__(self, "mu_offset", validate_finite("mu_offset", self.mu_offset))
        object.__setattr__(self, "mu_scale", validate_positive("mu_scale", self.mu_scale))
        object.__setattr__(self, "theta", validate_angle("theta", self.theta))
        for name in ("rolling_radius", "effective_radius", "piston_area"):
            if getattr(self, name) is not None:
                object.__setattr__(self, name, validate_positive(name, getattr(self, name)))
        if isinstance(self.n_faces, bool) or not isinstance(self.n_faces, int) or self.n_faces < 1:
            raise InputError(f"[correlate] n_faces={self.n_faces!r} must be a whole number >= 1.")
        if self.disc_speed == "vehicle" and self.rolling_radius is None:
            raise InputError("[correlate] disc_speed = \"vehicle\" needs rolling_radius [m].")
        if self.mu == "torque":
            missing = [k for k in ("effective_radius", "piston_area", "torque_channel") if getattr(self, k) is None]
            if missing:
                raise InputError(f"[correlate] mu = \"torque\" needs {', '.join(missing)}.")
        for t in self.mu_law_terms:
            _condition_name(t, "[correlate] mu_law_terms")

    @classmethod
    def from_dict(cls, table: Mapping[str, Any] | None) -> ConditionMap:
        """The map of a model file's ``[correlate]`` table (None or empty: the defaults).

        Parameters
        ----------
        table : mapping or None
            The parsed table (see the module docstring).

        Returns
        -------
        ConditionMap

        Raises
        ------
        InputError
            On an unknown key (naming it and the known ones) or a bad value.
        """
        table = dict(table or {})
        unknown = sorted(set(table) - _KEYS)
        if unknown:
            raise InputError(f"Unknown [correlate] key {unknown[0]!r}; known: {', '.join(sorted(_KEYS))}.")
        kw: dict[str, Any] = {k: v for k, v in table.items() if k not in ("mu_law", "laws", "theta_deg")}
        if "theta_deg" in table:
            kw["theta"] = math.radians(validate_finite("theta_deg", table["theta_deg"]))
        if "mu_law_terms" in table:
            terms = table["mu_law_terms"]
            if isinstance(terms, str) or not isinstance(terms, list | tuple):
                raise InputError(f"[correlate] mu_law_terms={terms!r} must be a list of condition names.")
            kw["mu_law_terms"] = tuple(terms)
        if "mu_law" in table:
            law = table["mu_law"]
            if not isinstance(law, Mapping) or "mu0" not in law:
                raise InputError("[correlate] mu_law must be a table with mu0 and a coefficient per condition, "
                                 "e.g. {mu0 = 0.4, temperature_c = 1e-4}.")
            coef = {_condition_name(k, "[correlate] mu_law"): validate_finite(f"mu_law.{k}", v)
                    for k, v in law.items() if k != "mu0" and not k.endswith("_ref")}
            ref = {k[:-4]: validate_finite(f"mu_law.{k}", v) for k, v in law.items() if k.endswith("_ref")}
            kw["mu_law"] = FrictionLaw(validate_finite("mu_law.mu0", law["mu0"]), coef, ref)
            kw.setdefault("mu", "law")
        laws = []
        for name, spec in dict(table.get("laws", {})).items():
            if not isinstance(spec, Mapping) or set(spec) - {"of", "slope", "ref"} or "of" not in spec \
                    or "slope" not in spec:
                raise InputError(f"[correlate.laws] {name} must be a table {{of = CONDITION, slope = S, ref = R}}.")
            laws.append(ParameterLaw(str(name), _condition_name(spec["of"], f"[correlate.laws] {name}"),
                                     validate_finite(f"{name}.slope", spec["slope"]),
                                     validate_finite(f"{name}.ref", spec.get("ref", 0.0))))
        kw["laws"] = tuple(laws)
        try:
            return cls(**kw)
        except TypeError as e:
            raise InputError(f"Bad [correlate] table: {e}") from e

    def with_quantities(self, **values: float) -> ConditionMap:
        """A copy with ``mu_offset`` and/or ``mu_scale`` changed (validated).

        Parameters
        ----------
        **values : float
            ``mu_offset``, ``mu_scale``.

        Returns
        -------
        ConditionMap
        """
        return replace(self, **values)


def campaign_conditions(campaign_dir: str | Path) -> tuple[xr.Dataset, Any]:
    """The analysed applications of a campaign folder and their squeal events.

    Parameters
    ----------
    campaign_dir : path
        What ``squealkit campaign --out`` (:func:`squealkit.campaign.run_campaign`) wrote:
        the folder holding ``campaign.duckdb``.

    Returns
    -------
    applications : xarray.Dataset
        Over ``application`` (failed ones left out): ``pressure_bar``, ``temperature_c``,
        ``speed_kmh``, ``rpm`` (the disc speed the analysis used), ``mu`` (the matrix's
        column; NaN where none), ``squeal``, ``file``.
    events : pandas.DataFrame
        ``application``, ``frequency_hz``, ``peak_dba`` of every squeal event.

    Raises
    ------
    InputError
        If the folder holds no campaign store or no analysed application.
    """
    from ..campaign.store import CampaignStore

    d = Path(campaign_dir)
    if not d.is_dir():
        raise InputError(f"Campaign folder {str(d)!r} does not exist (give what 'squealkit campaign --out' wrote).")
    db = d / "campaign.duckdb"
    if not db.is_file():
        raise InputError(f"{str(d)!r} holds no campaign.duckdb: give the folder 'squealkit campaign --out' wrote.")
    with CampaignStore(db) as store:
        apps = store.query("SELECT * FROM applications WHERE error IS NULL ORDER BY application")
        ev = store.query("SELECT application, frequency_hz, peak_dba FROM events ORDER BY application, event")
    if not len(apps):
        raise InputError(f"{str(db)!r} holds no analysed application.")
    ev = ev[ev["application"].isin(set(apps["application"]))].reset_index(drop=True)

    def col(name: str) -> np.ndarray:
        return np.asarray(apps[name], dtype=float) if name in apps else np.full(len(apps), np.nan)

    ds = xr.Dataset(
        {
            "pressure_bar": ("application", col("pressure_bar"), {"units": "bar", "long_name": "brake pressure"}),
            "temperature_c": ("application", col("temperature_c"), {"units": "degC", "long_name": "temperature"}),
            "speed_kmh": ("application", col("speed_kmh"), {"units": "km/h", "long_name": "vehicle speed"}),
            "rpm": ("application", col("mean_rpm"), {"units": "1/min", "long_name": "disc speed"}),
            "mu_measured": ("application", col("mu"), {"units": "1", "long_name": "measured friction coefficient"}),
            "squeal": ("application", np.asarray(apps["squeal"], dtype=bool), {"long_name": "squeal measured"}),
            "file": ("application", np.asarray(apps["file"], dtype=str)),
        },
        coords={"application": np.asarray(apps["application"], dtype=str)},
        attrs={"campaign": str(d), "criteria": str(apps["criteria"].iloc[0]),
               "synthetic": int(bool(apps["synthetic"].fillna(False).astype(bool).all()))},
    )
    return ds, ev


def _torque_mu(apps: xr.Dataset, cmap: ConditionMap) -> np.ndarray:
    """mu = T / (n_faces p A r_eff) from the recordings' mean torque [N m] and pressure [bar]."""
    from ..measurement import open_recording

    out = np.full(apps.sizes["application"], np.nan)
    for i, f in enumerate(apps["file"].values):
        src = open_recording(str(f))
        names = [src.resolve(cmap.torque_channel)]
        if cmap.pressure_channel is not None:
            names.append(src.resolve(cmap.pressure_channel))
        sums = dict.fromkeys(names, 0.0)
        for _, blk in src.iter_blocks(names):
            for n in names:
                sums[n] += float(blk[n].sum())
        torque = sums[names[0]] / src.n_samples
        if cmap.pressure_channel is not None:
            p_pa = sums[names[1]] / src.n_samples
            if names[1] not in src._extra.get("file_units", {}):  # a channel in bar, as the option says
                p_pa *= 1e5
        else:
            p_pa = float(apps["pressure_bar"].values[i]) * 1e5
        force = cmap.n_faces * p_pa * cmap.piston_area
        out[i] = torque / (force * cmap.effective_radius) if force > 0 else np.nan
    return out


def condition_values(apps: xr.Dataset, cmap: ConditionMap) -> dict[str, np.ndarray]:
    """Each condition of :data:`CONDITIONS` per application, the disc speed [rad/s] as ``cmap`` says.

    Parameters
    ----------
    apps : xarray.Dataset
        :func:`campaign_conditions`'s applications.
    cmap : ConditionMap
        Where the disc speed comes from.

    Returns
    -------
    dict of str to ndarray
    """
    rpm = apps["rpm"].values
    v = apps["speed_kmh"].values / 3.6
    vehicle = v / cmap.rolling_radius if cmap.rolling_radius is not None else np.full(v.shape, np.nan)
    if cmap.disc_speed == "rpm":
        w = rpm * (2 * math.pi / 60)
    elif cmap.disc_speed == "vehicle":
        w = vehicle
    else:
        w = np.where(np.isfinite(rpm), rpm * (2 * math.pi / 60), vehicle)
    return {"pressure_bar": apps["pressure_bar"].values, "temperature_c": apps["temperature_c"].values,
            "speed_kmh": apps["speed_kmh"].values, "disc_speed": w}


def operating_points(apps: xr.Dataset, cmap: ConditionMap, *, mu_law: FrictionLaw | None = None) -> xr.Dataset:
    """Each application's model conditions: friction, disc speed and parameter scales.

    Parameters
    ----------
    apps : xarray.Dataset
        :func:`campaign_conditions`'s applications.
    cmap : ConditionMap
        How conditions map onto the model.
    mu_law : FrictionLaw, optional
        A law already fitted (calibration re-uses it); else ``cmap.mu_law`` or one fitted here.

    Returns
    -------
    xarray.Dataset
        ``apps`` with ``disc_speed`` [rad/s], ``mu_source`` (the measured, law or torque mu),
        ``mu`` (the model's: ``mu_scale mu_source + mu_offset``) and ``scale_NAME`` per
        parameter law; attribute ``friction_law`` (its description) when a law gave mu.

    Raises
    ------
    InputError
        When an application lacks what the map needs (a mu, a disc speed for a law on it).
    """
    cond = condition_values(apps, cmap)
    attrs: dict[str, Any] = {"mu_source": cmap.mu}
    if cmap.mu == "measured":
        mu_src = apps["mu_measured"].values
    elif cmap.mu == "torque":
        mu_src = _torque_mu(apps, cmap)
    else:
        law = mu_law or cmap.mu_law or fit_friction_law(cond, apps["mu_measured"].values, cmap.mu_law_terms)
        mu_src = law.mu(cond)
        attrs["friction_law"] = law.describe()
        attrs["friction_law_residual_std"] = law.residual_std
    bad = ~np.isfinite(mu_src)
    if np.any(bad):
        first = str(apps["application"].values[np.argmax(bad)])
        what = {"measured": "a mu in the matrix (column mu)", "torque": "a torque and pressure",
                "law": "every condition of the friction law"}[cmap.mu]
        raise InputError(f"{int(bad.sum())} applications (first {first!r}) lack {what}; mu = {cmap.mu!r} needs it "
                         "for every application.")
    mu = cmap.mu_scale * mu_src + cmap.mu_offset
    out = apps.assign(
        disc_speed=("application", cond["disc_speed"], {"units": "rad/s", "long_name": "disc speed"}),
        mu_source=("application", mu_src, {"units": "1", "long_name": f"friction coefficient ({cmap.mu})"}),
        mu=("application", mu, {"units": "1", "long_name": "the model's friction coefficient "
                                f"{cmap.mu_scale:g} mu + {cmap.mu_offset:g}"}),
    )
    for law in cmap.laws:
        x = cond[law.of]
        if not np.all(np.isfinite(x)):
            raise InputError(f"The law of {law.name!r} needs {law.of} for every application.")
        out[f"scale_{law.name}"] = ("application", law.scale(x), {"units": "1", "long_name": f"scale of {law.name}"})
    out.attrs.update(attrs, mu_offset=cmap.mu_offset, mu_scale=cmap.mu_scale, theta=cmap.theta)
    return out

"""Report steps for the paper's §2-3: parameters (Table 1), Fig. 2, critical friction, tolerance."""

from __future__ import annotations

import contextlib
import contextvars
import math
import re
import warnings
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from ..io import save_dataset
from ..models import FrictionModel, PinOnDiscRig, cantilever_bending_frequency, rod_axial_frequency
from ..models._base import damping_names
from ..stability import (
    REALISTIC_MU_MAX,
    UnrealisticFrictionWarning,
    critical_friction,
    critical_friction_curve,
    critical_friction_sensitivity,
    mode_shapes,
    onset_modes,
    runout_tolerance,
    stability_map,
    stability_summary,
)
from .context import ReportContext, flat_onset
from .document import Comparison, FigureRef, Section, Table
from .settings import ReportSettings

# Published values, with where they stand in the paper.
PAPER_PARAMETERS = {  # §3
    "m1": (0.033, "kg"), "m2": (4.35, "kg"), "k1": (8.545e6, "N/m"), "k2": (9.755e7, "N/m"),
    "k3": (9.452e8, "N/m"), "kc": (4.632e7, "N/m"),
}
TABLE1_FEA_HZ = {"pin bending": 2561.0, "pin tensile": 8653.0, "disc 3rd nodal diameter": 2346.0}
FIG2_BAND_RAD_S = (14997.0, 15317.0)  # §3, Fig. 2


#: The formats each report figure is saved in: PNG (which the HTML embeds) and SVG; a quick
#: preview saves PNG only (drawing each figure a second time for its SVG was a third of its time).
FIGURE_FORMATS: contextvars.ContextVar[tuple[str, ...]] = contextvars.ContextVar(
    "squealkit_report_figure_formats", default=("png", "svg"))


@contextlib.contextmanager
def figure_formats(formats: tuple[str, ...]) -> Iterator[None]:
    """Save the report's figures in ``formats`` inside the block."""
    token = FIGURE_FORMATS.set(formats)
    try:
        yield
    finally:
        FIGURE_FORMATS.reset(token)


def _save_fig(fig, figures: Path, stem: str) -> None:
    from ..io import save_figure

    for fmt in FIGURE_FORMATS.get():
        save_figure(fig, figures / f"{stem}.{fmt}")


def _cell(value):
    """A parameter's value as a table cell: numbers as they are, matrices and lists as short text."""
    if isinstance(value, int | float | str) or value is None:
        return value
    arr = np.asarray(value)
    if arr.dtype.kind in "fiuc" and arr.ndim >= 1:
        return f"{arr.shape[0]}x{arr.shape[1]} matrix" if arr.ndim == 2 else f"{arr.size} values"
    return ", ".join(map(str, value)) if isinstance(value, list | tuple) else str(value)


def operating_point_text(settings: ReportSettings) -> str:
    """The report's operating point in one sentence, with where it comes from."""
    s = settings
    return (f"Operating point of this report ({s.source}): run-out tolerance at mu = {s.mu_design:g}; transients at "
            f"mu = {s.mu_transient:g} and {s.mu_unstable:g}, v = {s.speed:g} m/s; the Fig. 4 sine run-out has "
            f"q0 = {s.sro_amplitude * 1e6:.3g} um and lambda = {s.sro_wavelength * 1e3:.3g} mm (steepest slope "
            f"tan(theta) = {s.sro_slope:.3g})."
            + ("" if s.is_paper or "[report]" in s.source else
               " A [report] table in the model file sets them (mu_design, mu_transient, mu_unstable, mu_cycle, "
               "sro_amplitude, sro_wavelength, speed)."))


def parameters_step(model: FrictionModel, rig: PinOnDiscRig | None, figures: Path, data: Path, *,
                    settings: ReportSettings | None = None) -> Section:
    """Table 1 and §3: every parameter derived from the rig (beside the paper's value for the paper's rig)."""
    paragraphs = [
        "The paper derives each modal stiffness from a modal frequency, k = m (2 pi f)^2, the contact "
        "stiffness from the pin's axial stiffness E A / L, and weighs the masses (§3, Table 1)."
        + (" squealkit derives them again from the rig's geometry, materials and the FEA frequencies of Table 1."
           if rig is not None and rig == PinOnDiscRig.paper() else
           " squealkit derives them the same way from your rig's geometry, materials and frequencies."
           if rig is not None else
           f" This report's model ({model.kind}) is not derived from a rig: its parameters are used as given."),
    ]
    comparisons: list[Comparison] = []
    tables: list[Table] = []
    if rig is not None:
        derived = rig.to_model()
        tables.append(Table(
            "Modal frequencies the model is built from, and where each came from",
            ("mode", "frequency [Hz]", "source"),
            tuple((name.replace("_", " "), v["frequency_hz"], v["source"])
                  for name, v in rig.frequency_sources().items()),
        ))
        n_static = float(derived.static_contact_force(0.0))
        paragraphs.append(
            f"Choices of the derivation (the paper's unless changed in the rig): k = m1 (2 pi f)^2 with m1 = "
            f"{rig.pin_mass_factor:g} x the pin's mass (the tip modal mass of a cantilever's first bending mode is "
            "about 0.25 of it: pin_mass_factor); kc = E A / L is the pin's own axial stiffness, which k2 also "
            f"represents; the load P = {rig.P:g} N is "
            + ("the static contact force (preload = \"contact_force\")." if rig.preload == "contact_force" else
               f"applied to the pin while k2 is grounded, so the static contact force is {n_static:.2f} N "
               "(preload = \"contact_force\" makes P the contact force).")
        )
        paper_rig = rig == PinOnDiscRig.paper()
        if paper_rig:  # another rig's parameters are not the paper's: no comparison with them
            for name, (value, unit) in PAPER_PARAMETERS.items():
                got = float(getattr(derived, name))
                comparisons.append(Comparison(f"{name} from the rig", value, got, unit,
                                              abs(got / value - 1) < 5e-3, "within 0.5 %"))
        d, L, E, rho, nu = (rig.pin_diameter, rig.pin_length, rig.pin_youngs_modulus, rig.pin_density,
                            rig.pin_poisson)
        eb = cantilever_bending_frequency(d, L, E, rho, theory="euler_bernoulli")
        ti = cantilever_bending_frequency(d, L, E, rho, poisson=nu, theory="timoshenko")
        ax = rod_axial_frequency(L, E, rho)
        src = rig.frequency_sources()
        if paper_rig:
            fea_b, fea_t = TABLE1_FEA_HZ["pin bending"], TABLE1_FEA_HZ["pin tensile"]
            ref_head = "Table 1 FEA [Hz]"
        else:  # the rig's own frequencies (given, or from beam theory), not the paper's
            fea_b, fea_t = src["pin_bending"]["frequency_hz"], src["pin_axial"]["frequency_hz"]
            ref_head = "your rig [Hz]"
        slender = L / d
        ref_text = "the FEA of Table 1" if paper_rig else (
            f"your rig's values (bending: {src['pin_bending']['source']}; tensile: {src['pin_axial']['source']})")
        tables.append(Table(
            f"Pin frequencies from beam theory against {ref_text} (L/d = {slender:.3g}"
            + (": a stubby pin)" if slender < 3 else ")"),
            ("mode", ref_head, "theory", "squealkit [Hz]", "difference [%]"),
            (
                ("bending", fea_b, "Euler-Bernoulli", eb, 100 * (eb / fea_b - 1)),
                ("bending", fea_b, "Timoshenko (shear, rotary inertia)", ti, 100 * (ti / fea_b - 1)),
                ("tensile", fea_t, "quarter-wave rod", ax, 100 * (ax / fea_t - 1)),
            ),
        ))
    info = model.parameter_info()
    docs = {k: v.get("doc", "") for k, v in info.items()}
    if rig is not None and rig != PinOnDiscRig.paper():  # the docs quote the paper's frequencies; use the rig's
        f = {k: v["frequency_hz"] for k, v in rig.frequency_sources().items()}
        for k, mode in (("k1", "pin_bending"), ("k2", "pin_axial"), ("k3", "disc")):
            if k in docs:
                docs[k] = re.sub(r"\(2 pi [\d.]+ Hz\)", f"(2 pi {f[mode]:.0f} Hz)", docs[k])
    tables.append(Table(
        "Model used for this report",
        ("parameter", "value", "unit", "meaning"),
        tuple((k, _cell(v), info.get(k, {}).get("unit", ""), docs.get(k, ""))
              for k, v in model.parameters().items()),
    ))
    paragraphs.append(operating_point_text(settings or ReportSettings.paper()))
    title = "Table 1 and §3: model parameters from the rig" if rig is not None else "Model parameters (no rig)"
    return Section("parameters", title, tuple(paragraphs),
                   tuple(comparisons), tuple(tables))


def fig2_step(model: FrictionModel, figures: Path, data: Path, *, n_mu: int = 161, n_theta: int = 161,
              published: bool = True, context: ReportContext | None = None) -> Section:
    """Fig. 2: eigenvalues over mu in [0, 0.8] and theta in [-8, 8] deg, undamped (eq. 7)."""
    from ..plotting.stability import fig2_plot, root_locus_plot, stability_map_plot

    mu = np.linspace(0.0, 0.8, n_mu)
    theta = np.radians(np.linspace(-8.0, 8.0, n_theta))
    ds = stability_map(model, mu, theta, damped=False)
    with onset_said_in_words():
        crit = critical_friction_curve(model, theta[:: max(1, n_theta // 40)], damped=False)
    save_dataset(ds, data / "fig2_eigenvalues.nc")
    save_dataset(crit, data / "critical_friction_curve.nc")
    _save_fig(fig2_plot(ds), figures, "fig2_eigenvalues")
    _save_fig(stability_map_plot(ds, critical=crit), figures, "stability_map")
    _save_fig(root_locus_plot(ds), figures, "root_locus")
    s = stability_summary(ds)
    band = tuple(s["unstable_omega_rad_s"]) if s["unstable_omega_rad_s"] else None
    comps = []
    if published:  # another model's band is not the paper's: no comparison with it
        ok = band is not None and abs(band[0] - FIG2_BAND_RAD_S[0]) < 10 and abs(band[1] - FIG2_BAND_RAD_S[1]) < 10
        comps.append(Comparison("coupled (lock-in) frequency band", FIG2_BAND_RAD_S, band, "rad/s", ok,
                                "over mu 0-0.8, theta -8..8 deg; within 10 rad/s"))
        hz = (band[0] / (2 * math.pi), band[1] / (2 * math.pi)) if band else None
        comps.append(Comparison("coupled frequency band", (2387.0, 2438.0), hz, "Hz", ok, ""))
    first = "Complex eigenvalues of M x'' + K(mu, tan theta) x = 0 (eq. 7) over the paper's grid."
    if published:
        first += (" As mu and theta grow the pin-bending and disc modes lock in: their frequencies coalesce and the "
                  "real parts split into a growing and a decaying branch (Fig. 2). The stability boundary is a line "
                  "of nearly constant mu + tan(theta).")
    elif band is None:
        first += " No mode loses stability anywhere on the grid."
    else:
        first += (f" Unstable modes appear between {band[0]:.0f} and {band[1]:.0f} rad/s "
                  f"({band[0] / (2 * math.pi):.0f}-{band[1] / (2 * math.pi):.0f} Hz).")
    if damping_names(model):  # the map leaves the dampers out: say so, and where they put the onset
        cd = flat_onset(model, context)
        damp = f" ({damping_text(model)})" if damping_text(model) else ""
        first += (f" The map is undamped, as the paper's; with the model's damping{damp} "
                  + (f"a flat disc loses stability from mu_crit = {cd.mu_critical:.4f} ({cd.frequency_hz:.0f} Hz; §3)."
                     if math.isfinite(cd.mu_critical) else "a flat disc stays stable over the friction range searched "
                     "(§3)."))
    paragraphs = (
        first,
        f"Grid {n_mu} x {n_theta}; unstable at {100 * s['unstable_fraction']:.1f} % of the points; largest "
        f"growth rate {s['max_growth_rate']:.1f} 1/s.",
    )
    return Section(
        "fig2", "Fig. 2: complex eigenvalues over friction and SRO incline", paragraphs, tuple(comps), (),
        (FigureRef("fig2_eigenvalues", "Real (a) and imaginary (b) parts of the coupled modes' eigenvalues"),
         FigureRef("stability_map", "Largest growth rate with the critical-friction curve mu_crit(theta)"),
         FigureRef("root_locus", "Root locus over mu_e at theta = 0")),
        ("fig2_eigenvalues.nc", "critical_friction_curve.nc"),
        numbers={"band_low": band[0] if band else math.nan, "band_high": band[1] if band else math.nan,
                 "unstable_fraction": s["unstable_fraction"], "max_growth_rate": s["max_growth_rate"]},
    )


def critical_step(model: FrictionModel, figures: Path, data: Path, *,
                  settings: ReportSettings | None = None, context: ReportContext | None = None) -> Section:
    """Critical friction, mu_e = mu + tan(theta), the run-out tolerance and sensitivities.

    A model without an onset on a flat disc gets no sensitivities and no onset mode, and the
    text says so. Onset beyond brake friction materials is said in the text, and warned once
    when the model's damping does not bring it within them."""
    with onset_said_in_words():
        section = _critical_step(model, figures, data, settings=settings or ReportSettings.paper(), context=context)
    if section.numbers.get("onset_unrealistic"):
        warnings.warn(UnrealisticFrictionWarning.for_onset(section.numbers["onset_unrealistic"],
                                                          "with or without the model's damping"), stacklevel=2)
    return section


def _critical_step(model: FrictionModel, figures: Path, data: Path, *, settings: ReportSettings,
                   context: ReportContext | None) -> Section:
    mu_design, wavelength = settings.mu_design, settings.sro_wavelength
    thetas = np.radians([-8.0, -4.0, 0.0, 4.0, 8.0])
    curve = critical_friction_curve(model, thetas, damped=False)
    c0 = critical_friction(model, 0.0, damped=False)
    cd = flat_onset(model, context)
    mu_e = curve.mu_e_critical.values
    unrealistic, beyond = _unrealistic(curve.mu_critical.values, cd)
    tol = runout_tolerance(model, mu_design, wavelength=wavelength, damped=False)
    # the report's operating point is placed from the damped onset: with dampers the tolerance that binds
    # there is the damped one, stated beside the paper's undamped one (eq. 7)
    tol_d = runout_tolerance(model, mu_design, wavelength=wavelength, damped=True) if damping_names(model) else None
    fin = mu_e[np.isfinite(mu_e)]
    spread = float(np.ptp(fin) / np.mean(fin)) if fin.size == mu_e.size else math.nan
    rows = tuple((float(np.degrees(t)), float(m), float(me), float(f)) for t, m, me, f in zip(
        thetas, curve.mu_critical.values, mu_e, curve.frequency_hz.values, strict=True))
    comps: tuple[Comparison, ...] = ()
    if math.isfinite(spread):  # eqs. 5-6 are checked where there is an onset at every incline
        comps = (Comparison("spread of critical mu + tan(theta) over theta = -8..8 deg", None, 100 * spread, "%",
                            spread < 0.01, "eqs. 5-6 predict the SRO incline acts exactly like friction (0 % spread)"),)
    paragraphs = (_onset_text(model, c0, cd) + unrealistic, _tolerance_text(tol, settings, tol_d))
    tables = [Table("Critical friction over the SRO incline", ("theta [deg]", "mu_crit", "mu_crit + tan(theta)",
                                                             "onset frequency [Hz]"), rows)]
    if c0.status == "onset":  # a sensitivity of mu_crit needs a mu_crit
        sens = critical_friction_sensitivity(model, damped=False)
        tables.append(Table(
            "Which parameter buys the most margin (elasticity = % change of mu_crit per % change)",
            ("parameter", "value", "unit", "d mu_crit / d p", "elasticity"),
            tuple((r["parameter"], r["value"], r["unit"], r["dmu_dp"], r["elasticity"]) for r in sens)))
    else:
        paragraphs += ("With no undamped onset on a flat disc there is no critical friction to be sensitive: no "
                       "sensitivities and no onset mode shape are computed.",)
    numbers = {"mu_crit": c0.mu_critical, "mu_crit_damped": cd.mu_critical,
               "mu_e_spread": spread, "tan_theta_max": tol.tan_theta_max,
               "q0_max": tol.q0_max if tol.q0_max is not None else math.nan,
               "mu_e_crit": float(np.mean(mu_e)), "mu_design": mu_design, "wavelength": wavelength,
               "tolerance_flat_unstable": float(tol.limiting_side == "flat" or tol.tan_theta_max <= 0),
               "onset_unrealistic": beyond,
               "tan_theta_max_damped": tol_d.tan_theta_max if tol_d is not None else math.nan,
               "q0_max_damped": (tol_d.q0_max if tol_d is not None and tol_d.q0_max is not None else math.nan),
               "tolerance_flat_unstable_damped": (float(tol_d.limiting_side == "flat" or tol_d.tan_theta_max <= 0)
                                                  if tol_d is not None else math.nan)}
    refs: tuple[FigureRef, ...] = ()
    files: tuple[str, ...] = ()
    if c0.status == "onset":
        shape_text, shape_numbers = _onset_mode(model, figures, data)
        paragraphs += (shape_text,)
        numbers.update(shape_numbers)
        refs = (FigureRef("onset_mode", "Shapes of the modes at mu_crit (undamped, flat disc), the ones that lose "
                                           "stability marked: amplitude and phase of each degree of freedom"),)
        files = ("onset_modes.nc",)
    return Section("critical", "§3: critical friction and the run-out tolerance", paragraphs, comps, tuple(tables),
                   refs, files, numbers=numbers)


def damping_text(model: FrictionModel) -> str:
    """The model's own dampers as text, e.g. 'c1 = c2 = c3 = 220 N s/m' ('' if it has none by name)."""
    p = model.parameters()
    cs = {k: p[k] for k in ("c1", "c2", "c3", "c") if isinstance(p.get(k), int | float)}
    if not cs:
        return ""
    vals = set(cs.values())
    if len(vals) == 1:
        return " = ".join(cs) + f" = {next(iter(vals)):g} N s/m"
    return ", ".join(f"{k} = {v:g}" for k, v in cs.items()) + " N s/m"


def _onset_text(model: FrictionModel, c0, cd) -> str:
    """The flat-disc onset, undamped and damped, in words that follow the computed numbers."""
    if not math.isfinite(c0.mu_critical):
        first = "On a flat disc the undamped model stays stable over the friction range searched."
    else:
        first = (f"On a flat disc the undamped model loses stability at mu_crit = {c0.mu_critical:.5f} "
                 f"({c0.frequency_hz:.1f} Hz).")
    damp = damping_text(model)
    p = model.parameters()
    if damp and all(p[k] == 0 for k in ("c1", "c2", "c3", "c") if isinstance(p.get(k), int | float)):
        return first + f" The model has no damping ({damp}): the damped analysis is the same."
    with_damping = f"With the model's damping ({damp})" if damp else "With the model's damping"
    if not math.isfinite(cd.mu_critical):
        return first + f" {with_damping} it stays stable over the friction range searched."
    if not math.isfinite(c0.mu_critical):
        return first + f" {with_damping} it loses stability at mu_crit = {cd.mu_critical:.5f}."
    rel = cd.mu_critical / c0.mu_critical - 1
    if abs(rel) < 1e-4:
        return first + f" {with_damping} onset is the same, mu_crit = {cd.mu_critical:.5f}."
    if rel < 0:
        return first + (f" {with_damping} onset comes earlier, at mu_crit = {cd.mu_critical:.5f}: damping that "
                        "differs between the coupled modes destabilises, a known effect of mode-coupling instability.")
    return first + f" {with_damping} onset comes later, at mu_crit = {cd.mu_critical:.5f}."


@contextlib.contextmanager
def onset_said_in_words() -> Iterator[None]:
    """Within: no :class:`UnrealisticFrictionWarning` from the report's undamped analyses.

    The critical-friction section says in words whether onset needs friction beyond brake
    materials, with and without the model's damping (:func:`_unrealistic_text`), and warns once
    when both are beyond; each undamped analysis of the report warned on its own before, even
    where the model's damping brings onset down to a realistic friction."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UnrealisticFrictionWarning)
        yield


def _unrealistic(mu_undamped: np.ndarray, cd) -> tuple[str, float]:
    """A sentence when the undamped onsets all need friction beyond brake materials ('' otherwise), and
    the lowest such onset when the damped onset is beyond them too (0.0 otherwise: nothing to warn)."""
    fin = mu_undamped[np.isfinite(mu_undamped)]
    if not fin.size or fin.min() <= REALISTIC_MU_MAX:
        return "", 0.0
    text = (f" Undamped, mode coupling needs mu_crit = {fin.min():.4g} or more over the inclines searched, beyond "
            f"brake friction materials (about 0.3-0.7, at most {REALISTIC_MU_MAX:g}): the modes that couple are far "
            "apart in frequency.")
    if math.isfinite(cd.mu_critical) and cd.mu_critical <= REALISTIC_MU_MAX:
        return text + (f" With the model's damping onset comes at mu_crit = {cd.mu_critical:.4f}, within that "
                       "range."), 0.0
    return text, float(fin.min())


def _tolerance_clause(tol, mu_design: float, wavelength: float) -> str:
    """One tolerance in words, without its subject: "none; ...", "every slope ...", "slopes up to ..."."""
    if tol.limiting_side == "flat" or tol.tan_theta_max <= 0:
        return "none; the model is already unstable on a flat disc there, so no run-out slope is tolerated"
    if math.isinf(tol.tan_theta_max):
        return "every slope searched stays stable, so the run-out does not limit this model there"
    text = (f"slopes up to tan(theta) = {tol.tan_theta_max:.4f} ({tol.theta_max_deg:.2f} deg) stay stable, limited "
            f"by the {tol.limiting_side} run-out")
    if tol.q0_max is not None and math.isfinite(tol.q0_max):
        text += (f"; for a run-out wavelength of {wavelength * 1e3:g} mm this allows an amplitude of "
                 f"q0 = {tol.q0_max * 1e6:.2f} um (eq. 11)")
    return text


def _tolerance_text(tol, settings: ReportSettings, tol_damped=None) -> str:
    """The run-out tolerance at the design friction, and how the report's Fig. 4 SRO compares with it.

    ``tol_damped`` (a model with dampers): the tolerance with its damping, stated after the
    undamped one (the paper's eq. 7) and the one the Fig. 4 SRO is compared with."""
    mu_design, wavelength = settings.mu_design, settings.sro_wavelength
    fig4_slope = settings.sro_slope
    whose = "paper" if settings.is_paper else "report"
    sro = f"The {whose}'s Fig. 4 SRO (q0 = {settings.sro_amplitude * 1e6:.3g} um, lambda = {wavelength * 1e3:.3g} mm"
    if tol_damped is None:
        text = f"Run-out tolerance at mu = {mu_design}: {_tolerance_clause(tol, mu_design, wavelength)}."
        binding = tol
    else:
        text = (f"Run-out tolerance at mu = {mu_design}, undamped (eq. 7, as the paper): "
                f"{_tolerance_clause(tol, mu_design, wavelength)}. With the model's damping: "
                f"{_tolerance_clause(tol_damped, mu_design, wavelength)}.")
        binding = tol_damped
    if binding.limiting_side == "flat" or binding.tan_theta_max <= 0 or math.isinf(binding.tan_theta_max):
        return text
    against = " the damped tolerance" if tol_damped is not None else " it"
    if binding.tan_theta_max < fig4_slope:
        text += f" {sro}) has slopes up to {fig4_slope:.3f}: beyond{against}."
    else:
        text += f" {sro}, slopes up to {fig4_slope:.3f}) is within{against}."
    return text


def _onset_mode(model: FrictionModel, figures: Path, data: Path) -> tuple[str, dict[str, float]]:
    """The shape of the mode that loses stability on a flat disc (undamped, as Fig. 2): a figure,
    its data and one sentence from its numbers."""
    from ..plotting.modes import modes_plot

    ds = onset_modes(model, damped=False)
    save_dataset(ds, data / "onset_modes.nc")
    _save_fig(modes_plot(ds), figures, "onset_mode")
    k = int(np.argmax(ds.loses_stability.values))
    phi = mode_shapes(ds)[k]
    amp, phase = np.abs(phi), np.degrees(np.angle(phi))
    phase[phase <= -180.0 + 1e-6] = 180.0  # (-180, 180]
    order = np.argsort(-amp)
    names = [f"{n} ({d})" if d != n else str(n) for n, d in zip(ds.dof.values, ds.dof_description.values,
                                                                  strict=True)]
    lead = int(order[0])
    moves = [f"{names[i]} moves {amp[i]:.3g} of it at {round(phase[i]):+d} deg" for i in order[1:] if amp[i] >= 1e-3]
    share = ds.participation.values[k]
    top = int(np.argmax(share))
    freq = float(ds.frequency_hz[k])
    who = ("the two modes that merge (one double root with one shape: at the coalescence neither is the stable or "
           "the growing one) vibrate" if ds.attrs.get("onset_kind") == "coalescence" else
           "the mode that loses stability vibrates")
    text = (f"At onset (mu_crit = {ds.attrs['mu']:.5f}, undamped, flat disc) {who} "
            f"at {freq:.1f} Hz, mostly in {names[lead]}"
            + (f"; {' and '.join(moves)}" if moves else "")
            + f"; {ds.dof.values[top]} carries {100 * share[top]:.1f} % of the mode's "
            "kinetic energy.")
    return text, {"onset_mode_frequency_hz": freq, "onset_mode_top_energy_share": float(share[top])}

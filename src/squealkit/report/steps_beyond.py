"""Beyond the paper: the paper's contact kinematics beside the consistent ones.

The paper's gap (eq. 2) leaves out that the contact point moves along the inclined surface with
the pin; :meth:`squealkit.models.FrictionModel.slope_parts` derives what keeping it changes.
This step puts the two side by side: critical friction and mu + tan(theta) over the incline,
the run-out tolerance, and a frictionless check, with the prose written from the numbers.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import xarray as xr
from numpy.typing import NDArray

from ..io import save_dataset
from ..models import FrictionModel
from ..stability import critical_friction_curve, runout_tolerance, stability_verdict
from .document import FigureRef, Section, Table
from .settings import ReportSettings
from .steps_stability import onset_said_in_words

__all__ = []

#: Incline grid of the comparison [deg]: the paper's range (§3).
THETA_DEG = np.linspace(-8.0, 8.0, 17)
#: Slope of the frictionless check: the steepest slope of the paper's Fig. 4 run-out is 0.503.
FRICTIONLESS_SLOPE = 0.5


def _curves(models: dict[str, FrictionModel]) -> xr.Dataset:
    """Critical-friction curves of each model over THETA_DEG, stacked along ``kinematics``."""
    keep = ["mu_critical", "mu_e_critical", "frequency_hz", "status"]
    parts = [critical_friction_curve(m, np.radians(THETA_DEG), damped=False)[keep] for m in models.values()]
    ds = xr.concat(parts, dim="kinematics", combine_attrs="drop_conflicts")
    ds = ds.assign_coords(kinematics=("kinematics", list(models)))
    ds.attrs.update(kind="kinematics", title="Critical friction over the run-out incline for two contact kinematics",
                    reference="Lv, Zhang & Yu 2013, eqs. 2, 4-6; consistent gap: squealkit issue 12")
    return ds


def _ratio_text(q_paper: float | None, q_cons: float | None) -> str:
    """How much more or less run-out the consistent kinematics tolerates, in words true to the numbers."""
    qp, qc = (math.nan if q is None else float(q) for q in (q_paper, q_cons))
    if not (math.isfinite(qp) and math.isfinite(qc)) or qp <= 0 or qc <= 0:
        if math.isinf(qc) and math.isfinite(qp):
            return "with consistent kinematics every slope searched is tolerated."
        return "the two tolerances cannot be compared as a ratio."
    if qc < qp:
        return f"{qp / qc:.1f} times less run-out is tolerated."
    if qc > qp:
        return f"{qc / qp:.1f} times more run-out is tolerated."
    return "the same run-out is tolerated."


def _sides(mu_c: NDArray[np.float64], i0: int) -> str:
    """What each sign of the incline does to the critical friction against the flat disc's, in words.

    Read from the whole grid, not its ends: an incline destabilises where mu_crit falls below the
    flat disc's (nan: stable up to mu = 2, i.e. stabilised)."""
    flat = float(mu_c[i0])
    m = np.where(np.isfinite(mu_c), mu_c, np.inf)
    words = []
    for name, part in (("negative", m[:i0]), ("positive", m[i0 + 1:])):
        lower, higher = bool(np.any(part < flat)), bool(np.any(part > flat))
        words.append(f"the {name} incline " + ("destabilises (lowers mu_crit)" if lower and not higher else
                                               "stabilises (raises mu_crit)" if higher and not lower else
                                               "lowers mu_crit at some angles and raises it at others"
                                               if lower else "leaves mu_crit unchanged"))
    return "; ".join(words)


def _tolerance_words(t) -> str:
    """One kinematics' run-out tolerance in words true to its numbers."""
    if t.limiting_side == "flat" or t.tan_theta_max <= 0:
        return "none (already unstable on a flat disc at this friction)"
    if math.isinf(t.tan_theta_max):
        return "every slope searched"
    q0 = f", q0 <= {t.q0_max * 1e6:.2f} um" if t.q0_max is not None and math.isfinite(t.q0_max) else ""
    return (f"slopes up to {t.tan_theta_max:.4f} ({t.theta_max_deg:.2f} deg{q0}), limited by the {t.limiting_side} "
            "run-out")


def _meaning(pc: NDArray, cc: NDArray, i0: int, q_paper: float, q_cons: float, sliding: int) -> str:
    """What the comparison means for the paper's conclusions, decided from the numbers."""
    def lower(x: float) -> bool:
        return math.isfinite(x) and x < cc[i0]

    one_edge = lower(cc[0]) != lower(cc[-1])
    both_raise = not lower(cc[0]) and not lower(cc[-1])
    text = ("What it means for the paper's conclusions: that the run-out incline changes the stability of the "
            "brake, and so can make squeal intermittent once per disc turn, survives. That it acts exactly like "
            "friction (mu_e = mu + tan(theta), eqs. 5-6) depends on the paper's linearisation of the gap: with "
            "the contact point's motion kept, ")
    text += ("only one edge of the run-out destabilises while the other stabilises"
             if one_edge else "both edges of the run-out raise the threshold, by unequal amounts" if both_raise
             else "both edges lower the threshold, by unequal amounts")
    qp, qc = (math.nan if q is None else float(q) for q in (q_paper, q_cons))
    if math.isfinite(qp) and math.isfinite(qc) and 0 < qc < qp:
        text += (", and run-out tolerances computed with eq. (6) are not conservative (they allow "
                 f"{qp / qc:.1f} times the amplitude).")
    elif math.isfinite(qp) and math.isfinite(qc) and qc > qp > 0:
        text += ", though here the paper's tolerance is the stricter one."
    else:
        text += "."
    if not one_edge:
        return text
    return text + (" Which edge destabilises depends on the sliding direction relative to the slope (this model "
                   f"has sliding = {sliding:+d}).")


def _fmt(x: float) -> str:
    return f"{x:.4f}" if math.isfinite(x) else "none up to mu = 2 (stable)"


def beyond_step(model: FrictionModel, figures: Path, data: Path, *,
                settings: ReportSettings | None = None) -> Section:
    """The section "Beyond the paper": both kinematics side by side, computed from ``model``.

    ``model`` must have the ``kinematics`` option (the pin-on-disc model); its other parameters
    are used unchanged for both. ``settings`` gives the tolerance's friction and wavelength.
    """
    with onset_said_in_words():  # the critical-friction section says it
        return _beyond_step(model, figures, data, settings=settings or ReportSettings.paper())


def _beyond_step(model: FrictionModel, figures: Path, data: Path, *, settings: ReportSettings) -> Section:
    mu_design, wavelength = settings.mu_design, settings.sro_wavelength
    from ..plotting.stability import kinematics_plot
    from .steps_stability import _save_fig

    models = {k: model.replace(kinematics=k) for k in ("paper", "consistent")}
    ds = _curves(models)
    save_dataset(ds, data / "critical_kinematics.nc")
    tol = {k: runout_tolerance(m, mu_design, wavelength=wavelength, damped=False) for k, m in models.items()}
    frictionless = {k: str(stability_verdict(m, 0.0, tan_theta=FRICTIONLESS_SLOPE).item()) for k, m in models.items()}

    mu_c = {k: ds.mu_critical.sel(kinematics=k).values for k in models}
    mu_e = {k: ds.mu_e_critical.sel(kinematics=k).values for k in models}
    spread = {}
    for k in models:
        fin = mu_e[k][np.isfinite(mu_e[k])]
        spread[k] = float(np.ptp(fin) / np.mean(fin)) if fin.size else math.nan
    i0 = int(np.argmin(np.abs(THETA_DEG)))
    pc, cc = mu_c["paper"], mu_c["consistent"]
    stable_c = THETA_DEG[~np.isfinite(cc)]
    worst = int(np.argmin(np.where(np.isfinite(cc), cc, np.inf)))
    if not (math.isfinite(pc[i0]) and math.isfinite(cc[i0])):  # no onset on a flat disc: nothing to set beside
        return _beyond_stable(ds, tol, frictionless, mu_design, wavelength, data)
    _save_fig(kinematics_plot(ds), figures, "critical_kinematics")

    paragraphs = [
        "The paper's gap (eq. 2) is y1 - y2 - q: the run-out is read at the contact's rest position. But the "
        "contact point moves with the pin along the inclined surface, q(v t + x1) ~ q + tan(theta) x1. Keeping "
        "that term (kinematics = \"consistent\"; the derivation is in FrictionModel.slope_parts) makes the "
        "normal force the gradient of the contact potential kc delta^2 / 2, so the frictionless stiffness is "
        "symmetric, and the skew part that drives mode coupling is friction's alone, mu kc (1 + tan^2 theta).",
        f"Frictionless check at tan(theta) = {FRICTIONLESS_SLOPE:g}, mu = 0: the paper's matrices give "
        f"\"{frictionless['paper']}\", the consistent ones \"{frictionless['consistent']}\". "
        + ("A frictionless elastic contact cannot flutter, so the paper's verdict there is an artefact of the "
           "dropped term." if frictionless["paper"] != "stable" and frictionless["consistent"] == "stable" else
           "Here both kinematics agree."),
        f"On a flat disc both give mu_crit = {pc[i0]:.4f}. Over theta = {THETA_DEG[0]:g}..{THETA_DEG[-1]:g} deg "
        f"the paper's mu_crit + tan(theta) varies by {100 * spread['paper']:.2f} %: eq. (6), mu_e = mu + "
        + ("tan(theta), holds in its model" if spread["paper"] < 0.01 else
           "tan(theta), holds only approximately in its model for this rig")
        + f" (mu_crit from {_fmt(pc[0])} at {THETA_DEG[0]:g} deg to {_fmt(pc[-1])} at "
        f"{THETA_DEG[-1]:g} deg). With consistent kinematics mu_crit runs from {_fmt(cc[0])} at {THETA_DEG[0]:g} "
        f"deg to {_fmt(cc[-1])} at {THETA_DEG[-1]:g} deg, lowest ({cc[worst]:.4f}) at {THETA_DEG[worst]:g} deg"
        + (f"; from {stable_c.min():g} deg up it stays stable for every mu up to 2" if stable_c.size else "")
        + (f". Against the flat disc {_sides(cc, i0)}, instead of the slope adding to friction: "
           f"mu_crit + tan(theta) varies by {100 * spread['consistent']:.1f} %."
           if spread["consistent"] > max(0.05, 3 * spread["paper"]) else
           f"; there mu_crit + tan(theta) varies by {100 * spread['consistent']:.2f} %."),
        f"Run-out tolerance at mu = {mu_design:g} (undamped, wavelength {wavelength * 1e3:g} mm): the paper's "
        f"model allows {_tolerance_words(tol['paper'])}; the consistent one allows "
        f"{_tolerance_words(tol['consistent'])}"
        + ("." if min(tol["paper"].tan_theta_max, tol["consistent"].tan_theta_max) <= 0
           or math.isinf(max(tol["paper"].tan_theta_max, tol["consistent"].tan_theta_max)) else
           ": " + _ratio_text(tol["paper"].q0_max, tol["consistent"].q0_max)),
        _meaning(pc, cc, i0, tol["paper"].q0_max, tol["consistent"].q0_max, getattr(model, "sliding", 1)),
    ]
    rows = tuple((float(t), float(a), float(b), float(c), float(d)) for t, a, b, c, d in zip(
        THETA_DEG, pc, mu_e["paper"], cc, mu_e["consistent"], strict=True))
    tables = (
        Table("Critical friction over the run-out incline (undamped; a dash: stable up to mu = 2)",
              ("theta [deg]", "paper mu_crit", "paper mu_crit + tan(theta)", "consistent mu_crit",
               "consistent mu_crit + tan(theta)"), rows),
        Table(f"Run-out tolerance at mu = {mu_design:g}, wavelength {wavelength * 1e3:g} mm",
              ("kinematics", "largest stable slope", "theta [deg]", "q0 max [um]", "limited by"),
              tuple((k, t.tan_theta_max, t.theta_max_deg, _um(t.q0_max), t.limiting_side) if math.isfinite(
                  t.tan_theta_max) else (k, "every slope searched", None, None, "nothing") for k, t in tol.items())),
    )
    numbers = {
        "mu_crit_flat": float(pc[i0]),
        "paper_mu_crit_theta_min": float(pc[0]), "paper_mu_crit_theta_max": float(pc[-1]),
        "consistent_mu_crit_theta_min": float(cc[0]), "consistent_mu_crit_theta_max": float(cc[-1]),
        "paper_mu_e_spread": spread["paper"], "consistent_mu_e_spread": spread["consistent"],
        "paper_tan_theta_max": tol["paper"].tan_theta_max, "consistent_tan_theta_max": tol["consistent"].tan_theta_max,
        "paper_q0_max": _m(tol["paper"].q0_max), "consistent_q0_max": _m(tol["consistent"].q0_max),
        "paper_frictionless_stable": float(frictionless["paper"] == "stable"),
        "consistent_frictionless_stable": float(frictionless["consistent"] == "stable"),
    }
    fig = FigureRef("critical_kinematics", "Critical friction (solid) and mu_crit + tan(theta) (dashed) over the "
                    "run-out incline, with the paper's contact kinematics and with the consistent ones")
    return Section("beyond", "Beyond the paper: contact kinematics", tuple(paragraphs), (), tables, (fig,),
                   ("critical_kinematics.nc",), numbers=numbers)


def _m(q0: float | None) -> float:
    return math.nan if q0 is None else float(q0)


def _um(q0: float | None) -> float:
    return _m(q0) * 1e6


def _beyond_stable(ds: xr.Dataset, tol: dict, frictionless: dict, mu_design: float, wavelength: float,
                   data: Path) -> Section:
    """The section for a model with no onset on a flat disc: the checks that need none, and that it has none."""
    pc, cc = (ds.mu_critical.sel(kinematics=k).values for k in ("paper", "consistent"))
    fin = [f"{t:g} deg" for t, a, b in zip(THETA_DEG, pc, cc, strict=True) if math.isfinite(a) or math.isfinite(b)]
    paragraphs = (
        f"Frictionless check at tan(theta) = {FRICTIONLESS_SLOPE:g}, mu = 0: the paper's matrices give "
        f"\"{frictionless['paper']}\", the consistent ones \"{frictionless['consistent']}\".",
        "On a flat disc this model has no onset up to mu = 2 with either kinematics, so there is no critical "
        "friction to compare over the incline"
        + (f"; an onset appears only at {', '.join(fin)}." if fin else
           f" at any incline of {THETA_DEG[0]:g}..{THETA_DEG[-1]:g} deg either."),
        f"Run-out tolerance at mu = {mu_design:g} (undamped, wavelength {wavelength * 1e3:g} mm): the paper's model "
        f"allows {_tolerance_words(tol['paper'])}; the consistent one allows {_tolerance_words(tol['consistent'])}.",
    )
    rows = tuple((float(t), float(a), float(b)) for t, a, b in zip(THETA_DEG, pc, cc, strict=True))
    table = Table("Critical friction over the run-out incline (undamped; a dash: stable up to mu = 2)",
                  ("theta [deg]", "paper mu_crit", "consistent mu_crit"), rows)
    return Section("beyond", "Beyond the paper: contact kinematics", paragraphs, (), (table,), (),
                   ("critical_kinematics.nc",),
                   numbers={"mu_crit_flat": math.nan, "paper_tan_theta_max": tol["paper"].tan_theta_max,
                            "consistent_tan_theta_max": tol["consistent"].tan_theta_max,
                            "paper_frictionless_stable": float(frictionless["paper"] == "stable"),
                            "consistent_frictionless_stable": float(frictionless["consistent"] == "stable")})

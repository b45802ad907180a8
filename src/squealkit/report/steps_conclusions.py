"""The paper's conclusions (§6), each restated with the number squealkit computed for it."""

from __future__ import annotations

import math
from collections.abc import Sequence

from .document import Section, Table
from .settings import ReportSettings
from .steps_transient import NEUTRAL


def _um(x: float) -> str:
    """A run-out amplitude [m] in um, or in mm from 1 mm up."""
    if not math.isfinite(x):
        return "no finite amplitude"
    return f"{x * 1e6:.1f} um" if x < 1e-3 else f"{x * 1e3:.3g} mm"


def _events(n: float) -> str:
    """A count of squeal events as words: "1 event", "3 events"."""
    return f"{n:.0f} event" + ("" if round(n) == 1 else "s")


def conclusions_step(sections: Sequence[Section], *, settings: ReportSettings | None = None,
                     published: bool = True) -> Section:
    """Build the conclusions from the numbers of the sections computed before.

    ``settings`` is the report's operating point; ``published`` puts the paper's measured squeal
    frequency beside the synthetic one (the paper's model only)."""
    st = settings or ReportSettings.paper()
    n = {s.key: s.numbers for s in sections}
    rows = []
    fig2, crit = n.get("fig2", {}), n.get("critical", {})
    if fig2 and crit:
        lo, hi = fig2["band_low"], fig2["band_high"]
        rows.append((
            "Friction makes the stiffness matrix asymmetric; modal coupling gives an eigenvalue a positive real "
            "part and the system becomes unstable.",
            (f"Undamped, on a flat disc, the coupled modes lock in at mu_crit = {crit['mu_crit']:.4f}; "
             if math.isfinite(crit["mu_crit"]) else "Undamped, on a flat disc, no mode loses stability; ")
            + (f"over the grid (mu up to 0.8) the unstable mode grows at up to {fig2['max_growth_rate']:.0f} 1/s."
               if fig2["max_growth_rate"] > 0 else "no point of the grid (mu up to 0.8) is unstable."),
        ))
        rows.append((
            "As friction increases the system couples and becomes unstable, while the frequency changes only "
            "slightly.",
            f"Over mu 0-0.8 and theta -8..8 deg the unstable mode stays at {lo:.0f}-{hi:.0f} rad/s "
            f"({lo / (2 * math.pi):.0f}-{hi / (2 * math.pi):.0f} Hz): a spread of {100 * (hi / lo - 1):.1f} %."
            if math.isfinite(lo) and math.isfinite(hi) else
            "No unstable mode over mu 0-0.8 and theta -8..8 deg"
            + ((" undamped; with the model's damping a flat disc loses stability from mu_crit = "
                f"{crit['mu_crit_damped']:.4f}." if math.isfinite(crit["mu_crit_damped"]) else
                " undamped, and none with the model's damping on a flat disc.")
               if not math.isnan(crit.get("tan_theta_max_damped", math.nan)) else "."),
        ))
        spread = crit["mu_e_spread"]
        lam = st.sro_wavelength
        damped = not math.isnan(crit.get("tan_theta_max_damped", math.nan))  # the model has dampers
        sfx = "_damped" if damped else ""  # with dampers the damped tolerance binds at the report's friction
        with_damping = " (with the model's damping)" if damped else ""
        if crit.get("tolerance_flat_unstable" + sfx):
            tol = (f"no run-out is tolerated at mu = {st.mu_design:g}{with_damping}: the model is already unstable "
                   "on a flat disc there.")
        elif math.isinf(crit["tan_theta_max" + sfx]):
            tol = f"every run-out slope searched stays stable at mu = {st.mu_design:g}{with_damping}."
        elif math.isfinite(crit["q0_max" + sfx]):
            tol = (f"the run-out tolerance is a slope (tan(theta) <= {crit['tan_theta_max' + sfx]:.4f} at mu = "
                   f"{st.mu_design:g}{with_damping}), met by q0 = {_um(crit['q0_max' + sfx])} at lambda = "
                   f"{lam * 1e3:g} mm or {_um(crit['q0_max' + sfx] * 100)} at lambda = {lam * 1e5:g} mm alike.")
        else:
            tol = (f"the run-out tolerance is a slope: tan(theta) <= {crit['tan_theta_max' + sfx]:.4f} at "
                   f"mu = {st.mu_design:g}{with_damping}.")
        rows.append((
            "Stability is not related to the SRO amplitude directly; its incline angle acts like friction.",
            ("Without an onset at every incline the spread of the critical mu + tan(theta) is not defined; "
             if not math.isfinite(spread) else
             f"The critical mu + tan(theta) varies by only {100 * spread:.2f} % over theta -8..8 deg; "
             if spread < 0.01 else
             f"The critical mu + tan(theta) varies by {100 * spread:.2f} % over theta -8..8 deg: "
             "here the incline does not act exactly like friction; ") + tol,
        ))
        md, mu0 = crit.get("mu_crit_damped", math.nan), crit["mu_crit"]
        if math.isfinite(md) and math.isfinite(mu0) and abs(md / mu0 - 1) >= 1e-4:
            rows.append((
                "(Beyond the paper) Damping and the onset of squeal.",
                f"With the model's damping onset comes at mu_crit = {md:.4f}, "
                + (f"below the undamped {mu0:.4f}: unequal modal damping destabilises mode coupling."
                   if md < mu0 else f"above the undamped {mu0:.4f}: here damping delays onset."),
            ))
    tr = n.get("transient", {})
    if tr:
        up, nr = int(tr.get("rising_stages_growing", 0)), int(tr.get("rising_stages", 0))
        down, nf = int(tr.get("falling_stages_decaying", 0)), int(tr.get("falling_stages", 0))
        stable_run = tr.get("fig4_sigma_max", math.nan) <= NEUTRAL
        rows.append((
            "With SRO the response grows while the SRO rises and decays while it falls: squeal is intermittent.",
            (f"With the Fig. 4 sine SRO (q0 = {st.sro_amplitude * 1e6:.3g} um, lambda = {st.sro_wavelength * 1e3:g} "
             f"mm, mu = {st.mu_transient:g}) the model stays stable all through the run (frozen-time growth rate at "
             f"most {tr['fig4_sigma_max']:+.2f} 1/s): no self-excited squeal starts or stops; what the envelope "
             "does is the run-out's own excitation (§4).") if stable_run and nr and nf else
            (f"With the Fig. 4 sine SRO (q0 = {st.sro_amplitude * 1e6:.3g} um, lambda = {st.sro_wavelength * 1e3:g} "
             f"mm, mu = {st.mu_transient:g}) the vibration envelope grows on {up} of {nr} rising stages (the last at "
             f"{tr['rise_rate']:+.1f} 1/s) and decays on {down} of {nf} falling stages (the last at "
             f"{tr['fall_rate']:+.1f} 1/s)"
             + ("" if tr.get("fig4_self_excited", 1.0) else
                ", but far faster than the frozen-time growth rates of those stages: the run-out's own excitation, "
                "not self-excited squeal (§4)") + ".") if nr and nf else
            "The Fig. 4 run holds no whole rising and falling stage to measure the envelope on.",
        ))
    ms = n.get("measurement", {})
    if ms:
        claim = ("In the rig, squeal recurs once per disc turn on the rising SRO, and its sound pressure follows "
                 "the disc vibration.")
        f_txt = (f"squeal at {ms['squeal_frequency_hz']:.1f} Hz" + (" (paper: 2388 Hz)" if published else "")
                 if math.isfinite(ms["squeal_frequency_hz"]) else "no squeal found")
        rf_txt = (f"{ms['rising_fraction']:.1%} of its energy on rising run-out"
                  if math.isfinite(ms["rising_fraction"]) else "no rising-run-out share (no squeal)")
        if "truth_rising_fraction" in ms:
            rows.append((claim, f"SYNTHETIC: the analysis recovers {f_txt}, {rf_txt} "
                                f"(truth {ms['truth_rising_fraction']:.1%}), {_events(ms['events'])}."))
        else:
            rows.append((claim, f"Your recording: {f_txt}, {rf_txt}, {_events(ms['events'])}."))
    return Section(
        "conclusions", "§6: the paper's conclusions with squealkit's numbers",
        ("Each conclusion of the paper beside the number squealkit computed for it in the sections above.",),
        tables=(Table("Conclusions", ("the paper concludes", "squealkit computes"), tuple(rows)),),
    )

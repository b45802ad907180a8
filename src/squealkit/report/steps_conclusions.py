"""The paper's conclusions (§6), each restated with the number squealkit computed for it."""

from __future__ import annotations

import math
from collections.abc import Sequence

from .document import Section, Table


def conclusions_step(sections: Sequence[Section]) -> Section:
    """Build the conclusions from the numbers of the sections computed before."""
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
            if math.isfinite(lo) and math.isfinite(hi) else "No unstable mode over mu 0-0.8 and theta -8..8 deg.",
        ))
        rows.append((
            "Stability is not related to the SRO amplitude directly; its incline angle acts like friction.",
            (f"The critical mu + tan(theta) varies by only {100 * crit['mu_e_spread']:.2f} % over theta -8..8 deg; "
             if crit["mu_e_spread"] < 0.01 else
             f"The critical mu + tan(theta) varies by {100 * crit['mu_e_spread']:.2f} % over theta -8..8 deg: "
             "here the incline does not act exactly like friction; ")
            + f"the run-out tolerance is a slope (tan(theta) <= {crit['tan_theta_max']:.4f} at mu = 0.3), met by "
            f"q0 = {crit['q0_max'] * 1e6:.1f} um at lambda = 1 mm or {crit['q0_max'] * 1e5:.2f} mm at "
            "lambda = 100 mm alike.",
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
        rows.append((
            "With SRO the response grows while the SRO rises and decays while it falls: squeal is intermittent.",
            "With the Fig. 4 sine SRO the vibration envelope "
            + ("grows" if tr["rise_rate"] > 0 else "changes") + f" at {tr['rise_rate']:+.1f} 1/s on rising stages and "
            + ("decays" if tr["fall_rate"] < 0 else "changes") + f" at {tr['fall_rate']:+.1f} 1/s on falling stages "
            "(mu = 0.4).",
        ))
    ms = n.get("measurement", {})
    if ms:
        claim = ("In the rig, squeal recurs once per disc turn on the rising SRO, and its sound pressure follows "
                 "the disc vibration.")
        f_txt = (f"squeal at {ms['squeal_frequency_hz']:.1f} Hz (paper: 2388 Hz)"
                 if math.isfinite(ms["squeal_frequency_hz"]) else "no squeal found")
        rf_txt = (f"{ms['rising_fraction']:.1%} of its energy on rising run-out"
                  if math.isfinite(ms["rising_fraction"]) else "no rising-run-out share (no squeal)")
        if "truth_rising_fraction" in ms:
            rows.append((claim, f"SYNTHETIC: the analysis recovers {f_txt}, {rf_txt} "
                                f"(truth {ms['truth_rising_fraction']:.1%}), {ms['events']:.0f} events."))
        else:
            rows.append((claim, f"Your recording: {f_txt}, {rf_txt}, {ms['events']:.0f} events."))
    return Section(
        "conclusions", "§6: the paper's conclusions with squealkit's numbers",
        ("Each conclusion of the paper beside the number squealkit computed for it in the sections above.",),
        tables=(Table("Conclusions", ("the paper concludes", "squealkit computes"), tuple(rows)),),
    )

"""Issue 27, "reports true for the user's rig": a rig with dampers whose damped onset comes far below its
undamped one (unequal modal damping destabilises mode coupling).

The report places its operating point from the damped onset (``ReportSettings.for_model``), so its
run-out tolerance, its Fig. 2 sentence and its conclusions must not speak of the undamped model alone:
before this test the report said the Fig. 4 run-out "is within" an undamped tolerance of tan(theta) = 1.34
while the same report's transient grew on every rising stage (its damped tolerance is 0.057).
The reference numbers come from :func:`squealkit.stability.runout_tolerance` and
:func:`squealkit.stability.critical_friction` themselves (damped=True), which their own tests check
against LAPACK; here the report's words are checked against them.
"""

import math
import re

import numpy as np
import pytest

from squealkit.models import model_from_dict
from squealkit.report.settings import ReportSettings
from squealkit.report.steps_conclusions import conclusions_step
from squealkit.report.steps_stability import critical_step, fig2_step
from squealkit.stability import critical_friction, runout_tolerance

# a rig of one's own: 25 mm PA6 pin, given frequencies in kHz, dampers measured; undamped onset at
# mu = 1.565, damped at mu = 0.229
RIG = {
    "rig": {"pin_diameter": "25 mm", "pin_length": "50 mm", "pin_youngs_modulus": "2.95 GPa",
            "pin_density": 1040.0, "disc_mass": 4.1, "disc_freq": "2.9 kHz", "pin_bending_freq": "3.3 kHz",
            "pin_axial_freq": "rod"},
    "parameters": {"alpha_deg": 2.5, "c1": 8.0, "c2": 8.0, "c3": 5.0},
}


@pytest.fixture(scope="module")
def damped_rig(tmp_path_factory):
    model = model_from_dict(RIG)
    settings = ReportSettings.for_model(model)
    d = tmp_path_factory.mktemp("damped_rig")
    crit = critical_step(model, d, d, settings=settings)
    fig2 = fig2_step(model, d, d, n_mu=21, n_theta=9, published=False)
    return model, settings, crit, fig2


def test_tolerance_of_a_damped_rig_is_the_damped_one(damped_rig):
    model, settings, crit, _ = damped_rig
    undamped = runout_tolerance(model, settings.mu_design, wavelength=settings.sro_wavelength, damped=False)
    damped = runout_tolerance(model, settings.mu_design, wavelength=settings.sro_wavelength, damped=True)
    assert damped.tan_theta_max < settings.sro_slope < undamped.tan_theta_max  # the case the report got wrong
    text = " ".join(crit.paragraphs)
    assert f"{damped.tan_theta_max:.4f}" in text
    assert "is within" not in text  # the report's own run-out exceeds the damped tolerance
    assert "beyond the damped tolerance" in text
    assert crit.numbers["tan_theta_max_damped"] == pytest.approx(damped.tan_theta_max)
    assert crit.numbers["tan_theta_max"] == pytest.approx(undamped.tan_theta_max)


def test_fig2_of_a_damped_rig_says_the_map_is_undamped_and_where_damping_puts_onset(damped_rig):
    model, _, _, fig2 = damped_rig
    cd = critical_friction(model, 0.0, damped=True)
    text = " ".join(fig2.paragraphs)
    assert "undamped" in text
    assert f"{cd.mu_critical:.4f}" in text


def test_conclusions_of_a_damped_rig_qualify_the_undamped_grid_and_use_the_damped_tolerance(damped_rig):
    _, settings, crit, fig2 = damped_rig
    concl = conclusions_step([fig2, crit], settings=settings, published=False)
    said = " ".join(row[1] for t in concl.tables for row in t.rows)
    assert "No unstable mode over mu 0-0.8" not in said or "undamped" in said.split("No unstable mode")[1][:80]
    assert f"{crit.numbers['tan_theta_max_damped']:.4f}" in said


def test_undamped_model_keeps_one_tolerance(tmp_path):
    """The paper's undamped analysis: no damped tolerance to add (the preset's own damping is checked in the
    paper report's tests); a model without dampers states the tolerance once."""
    doc = {**RIG, "parameters": {"alpha_deg": 2.5, "c1": 0.0, "c2": 0.0, "c3": 0.0}}
    model = model_from_dict(doc)
    crit = critical_step(model, tmp_path, tmp_path, settings=ReportSettings.for_model(model))
    assert math.isnan(crit.numbers["tan_theta_max_damped"])
    assert "With the model's damping" not in " ".join(crit.paragraphs[1:2])


@pytest.mark.slow
def test_unrealistic_undamped_onset_is_said_once_in_words_not_warned_when_damping_makes_it_realistic(tmp_path):
    """The rig's undamped onset (mu 1.565) is beyond friction materials, its damped one (0.229) is not: the
    report warned three times (once per undamped analysis) that mode coupling "needs mu_crit = 1.383 or
    more", false for the rig as built. Now the critical section says it in words, with the damped onset, and
    nothing is warned; a rig whose damped onset is unrealistic too is warned once."""
    import warnings

    from squealkit.report.steps_beyond import beyond_step
    from squealkit.stability import UnrealisticFrictionWarning

    model = model_from_dict(RIG)
    settings = ReportSettings.for_model(model)
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        crit = critical_step(model, tmp_path, tmp_path, settings=settings)
        fig2_step(model, tmp_path, tmp_path, n_mu=11, n_theta=5, published=False)
        beyond_step(model, tmp_path, tmp_path, settings=settings)
    assert not [w for w in seen if issubclass(w.category, UnrealisticFrictionWarning)]
    text = " ".join(crit.paragraphs)
    assert "beyond brake friction materials" in text and "0.2291" in text

    stiff = model_from_dict({**RIG, "parameters": {"alpha_deg": 2.5, "c1": 0.0, "c2": 0.0, "c3": 0.0}})
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        critical_step(stiff, tmp_path, tmp_path, settings=ReportSettings.for_model(stiff))
        fig2_step(stiff, tmp_path, tmp_path, n_mu=11, n_theta=5, published=False)
    assert len([w for w in seen if issubclass(w.category, UnrealisticFrictionWarning)]) == 1


def test_how_loud_says_how_far_the_slope_branch_got_instead_of_an_amplitude_of_no_cycle(tmp_path):
    """On this rig the continuation of the cycles over the run-out slope stops (its corrector fails) at
    tan(theta) = 0.0233, short of the Fig. 4 run-out's steepest slope 0.069: the report said "the cycle's x1
    amplitude is no cycle". It now says how far the branch got and why (the full report's branch, whose finer
    steps stop there; the quick report's coarser ones get past)."""
    from squealkit.report.steps_nonlinear import nonlinear_step

    model = model_from_dict(RIG)
    sec = nonlinear_step(model, tmp_path, tmp_path, quick=False, settings=ReportSettings.for_model(model))
    text = " ".join(sec.paragraphs)
    assert "is no cycle" not in text
    if "followed only up to tan(theta) = " in text:  # the branch stopped short: the reason is given
        assert "is not computed" in text
        # and the Fig. 4 comparison leaves out the slopes beyond the branch's end (it repeated the last
        # amplitude there, a value nothing computed)
        from squealkit.io import load_dataset

        reached = float(re.search(r"followed only up to tan\(theta\) = ([0-9.]+)", text).group(1))
        env = load_dataset(tmp_path / "fig4_nonlinear_envelope.nc")
        beyond = env["tan_theta"].values > reached + 1e-4
        assert beyond.any() and np.isnan(env["limit_cycle"].values[beyond]).all()
        assert "is not known at" in text
    else:  # the branch got there: an amplitude in um
        assert re.search(r"the cycle's x1 amplitude is \d+\.\d+ um", text)

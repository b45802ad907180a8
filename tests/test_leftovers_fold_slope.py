"""Leftovers: a limit-cycle branch that folds, read along its arclength (the report's "How loud")."""

import dataclasses
import math

import numpy as np
import pytest
import xarray as xr

# A branch with a fold, built by hand (no solver): the onset at mu = 0.40 with a vertical start (as the
# piecewise-linear contact law gives), then up in mu to a fold at 0.4538 and back down to 0.41, the x1
# amplitude growing all along the arclength. Every cycle is marked stable, as on the paper's rig where both
# sides of a fold came out stable: the case where sorting the points by mu mixes the two sides.
MU = np.array([0.40, 0.40, 0.41, 0.43, 0.45, 0.4538, 0.45, 0.43, 0.41])
AMP = 1e-7 * np.arange(MU.size)  # 0, 0.1 ... 0.8 um
FOLD = 5


def folded_branch(stable=None) -> xr.Dataset:
    n = MU.size
    dofs = ["x1", "x2", "x3"]
    amp = np.outer(AMP, [1.0, 0.5, 0.2])
    coef = np.zeros((n, 3, 3))  # one harmonic: [a0, a1, b1]
    coef[:, 1, :] = amp
    fold = np.zeros(n, bool)
    fold[FOLD] = True
    return xr.Dataset(
        {"frequency_hz": ("point", np.linspace(2400.0, 2420.0, n)),
         "omega_rad_s": ("point", 2 * np.pi * np.linspace(2400.0, 2420.0, n)),
         "amplitude": (("point", "dof"), amp),
         "contact_loss_fraction": ("point", np.zeros(n)),
         "stable": ("point", np.ones(n, bool) if stable is None else np.asarray(stable)),
         "fold": ("point", fold),
         "fold_mu": ("fold", MU[[FOLD]]),
         "coefficients": (("point", "harmonic_row", "dof"), coef)},
        coords={"point": np.arange(n), "dof": dofs, "harmonic_row": np.arange(3), "mu": ("point", MU)},
        attrs={"kind": "limit_cycle_branch", "param": "mu", "hopf_mu": 0.40, "hopf_frequency_hz": 2400.0,
               "lyapunov_coefficient": 0.0, "hopf_kind": "supercritical", "hopf_kind_from": "branch",
               "harmonics": 1, "harmonics_change": 1e-4, "stop_reason": "left_range",
               "stop_detail": "reached the end of the range [0.3, 1] at mu = 0.41"})


def test_a_branch_is_read_along_its_arclength_never_across_a_fold():
    from squealkit.report.steps_nonlinear import _at, _cycles_at

    ds = folded_branch()
    # reference: linear interpolation by hand between the points of the rising run, (0.43, 0.3 um) and
    # (0.45, 0.4 um), at 0.44: 0.35 um; and on the returning run between (0.45, 0.6 um) and (0.43, 0.7 um)
    assert _at(ds, "mu", 0.44) == pytest.approx(0.35e-6, rel=1e-12)
    cycles = _cycles_at(ds, "mu", 0.44)
    assert [round(a * 1e9, 6) for a, _ in cycles] == [350.0, 650.0]
    # at the fold itself one cycle (the fold point), beyond it none
    assert _cycles_at(ds, "mu", 0.4538) == [(pytest.approx(0.5e-6), True)]
    assert _cycles_at(ds, "mu", 0.46) == [] and math.isnan(_at(ds, "mu", 0.46))
    # a returning side that is unstable: the stable cycle is still the rising run's
    st = np.arange(MU.size) <= FOLD
    assert _at(folded_branch(st), "mu", 0.42) == pytest.approx(0.25e-6, rel=1e-12)
    # no stable cycle at all: nan, not the nearest stable one
    assert math.isnan(_at(folded_branch(np.arange(MU.size) < 2), "mu", 0.42))


def test_a_branch_saved_without_fold_flags_splits_where_mu_turns_back():
    from squealkit.report.steps_nonlinear import _cycles_at, _segments

    ds = folded_branch().drop_vars(["fold", "fold_mu"])
    assert [list(r) for r in _segments(ds, "mu")] == [list(range(FOLD + 1)), list(range(FOLD, MU.size))]
    assert len(_cycles_at(ds, "mu", 0.44)) == 2


@pytest.fixture(scope="module")
def folded_section(tmp_path_factory):
    """The report's "How loud" section on the paper's rig, with the flat-disc branch replaced by the folded one
    (and no slope branch): only the text is under test; the run-out transient is the quick one."""
    import squealkit.nonlinear as nl
    from squealkit import InputError
    from squealkit.models import get_preset
    from squealkit.report.settings import ReportSettings
    from squealkit.report.steps_nonlinear import nonlinear_step

    def no_slope(*a, **k):
        raise InputError("no onset")

    d = tmp_path_factory.mktemp("fold")
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(nl, "limit_cycle_branch", lambda *a, **k: folded_branch())
        mp.setattr(nl, "limit_cycle_branch_slope", no_slope)
        settings = dataclasses.replace(ReportSettings.paper(), mu_cycle=0.42)
        return nonlinear_step(get_preset("lv2013"), d, d, quick=True, settings=settings)


def test_the_report_says_the_branch_folds_and_quotes_the_cycle_before_the_fold(folded_section):
    text = folded_section.paragraphs[0]
    n = folded_section.numbers
    # the rising run, by hand: 0.2 um at 0.41, 0.3 um at 0.43: 0.25 um at 0.42; the fold point 0.5 um
    assert n["amplitude_mu05"] == pytest.approx(0.25e-6, rel=1e-9)
    assert n["amplitude_mu_max"] == pytest.approx(0.5e-6, rel=1e-9)
    assert n["fold_mu"] == pytest.approx(0.4538) and n["cycles_at_mu_cycle"] == 2
    assert "The branch folds at mu = 0.4538" in text
    assert "At mu = 0.42 this branch has 2 limit cycles (x1: 0.250 um (stable), 0.750 um (stable)" in text
    assert "reached the end of the range [0.3, 1] at mu = 0.41" in text  # where the continuation stopped


# --- the flat-disc onset, once per report ---------------------------------------------------------------


@pytest.mark.slow
def test_a_report_computes_the_damped_flat_disc_onset_once(tmp_path, monkeypatch):
    """The operating point, Fig. 2, the critical-friction and the measurement sections each computed
    critical_friction(model, 0, damped=True) (4 times per report on main); a report's steps now share one.
    A damped Hoffmann model of one's own: a quick report in seconds that has every one of those readers
    (the limit-cycle section, whose engine finds its own Hopf point, is for pin-on-disc models only)."""
    import traceback

    import squealkit.stability.critical as critical
    from squealkit.models import Hoffmann2002
    from squealkit.report import reproduce

    curve = critical.critical_friction_curve
    by_report = []

    def counting(model, theta, *args, damped=None, **kwargs):
        # who called critical_friction: a module of squealkit.report (the engines' own calls are not counted)
        stack = [f for f in traceback.extract_stack()[:-1] if not f.filename.endswith("_threads.py")]
        i = max(k for k, f in enumerate(stack) if f.name == "critical_friction")
        if damped and "/report/" in stack[i - 1].filename.replace("\\", "/"):
            by_report.append(stack[i - 1].name)
        return curve(model, theta, *args, damped=damped, **kwargs)

    monkeypatch.setattr(critical, "critical_friction_curve", counting)
    reproduce(tmp_path / "out", quick=True, model=Hoffmann2002(c=5.0))
    assert len(by_report) == 1, by_report

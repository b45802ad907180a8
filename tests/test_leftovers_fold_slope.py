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



def test_an_s_shaped_branch_has_three_cycles_between_its_folds_and_goes_on_past_them():
    from squealkit.report.steps_nonlinear import _cycles_at, _fold_text

    ds = folded_branch()
    mu = np.array([0.40, 0.40, 0.42, 0.45, 0.43, 0.42, 0.44, 0.48, 0.50])  # folds at 0.45 (point 3), 0.42 (5)
    fold = np.zeros(mu.size, bool)
    fold[[3, 5]] = True
    s = ds.assign_coords(mu=("point", mu)).assign(fold=("point", fold), fold_mu=("fold", mu[[3, 5]]))
    # by hand: 0.43 is crossed on the way up (points 2-3: 0.2 + 0.1 / 3 um), at point 4 (0.4 um) and on
    # the way up again (points 5-6: 0.5 + 0.05 um)
    a = [round(v * 1e9, 6) for v, _ in _cycles_at(s, "mu", 0.43)]
    assert a == pytest.approx([200 + 100 / 3, 400.0, 550.0])
    text = _fold_text(s, "mu", 0.43)
    assert "3 limit cycles" in text and "folds at mu = 0.45, 0.42, turning back and forth" in text
    assert "none beyond" not in text

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


# --- a transient at a fixed incline -------------------------------------------------------------------


def _envelope_rate(ds, t0, t1):
    from squealkit.transient import response_envelope

    env = response_envelope(ds, "x1", highpass_freq=1000.0)
    t = env["time"].values
    keep = (t > t0) & (t < t1)
    return float(np.polyfit(t[keep], np.log(env.values[keep]), 1)[0])


@pytest.mark.parametrize(("mu", "tan_theta", "method"), [(0.35, 0.15, "dopri5"), (0.30, 0.02, "dopri5"),
                                                          (0.35, 0.15, "rosenbrock")])
def test_a_run_at_a_fixed_incline_grows_at_the_eigenvalue_of_that_incline(mu, tan_theta, method):
    # reference: the real part of the rightmost eigenvalue of the damped linear model at (mu, tan theta)
    # (squealkit.stability.eigenvalues, LAPACK); the linear contact never opens, so the run is a linear ODE
    # whose vibration about the equilibrium grows (or decays) at that rate. mu + tan(theta) = 0.5 lies above
    # the paper rig's damped onset 0.3977, 0.32 below it.
    from squealkit.models import get_preset
    from squealkit.stability import eigenvalues
    from squealkit.transient import ConstantIncline, simulate

    model = get_preset("lv2013")
    sigma = float(eigenvalues(model, mu=mu, tan_theta=tan_theta, damped=True).real.max())
    ds = simulate(model, mu=mu, profile=ConstantIncline(tan_theta), duration=0.04, perturbation=1e-9,
                  rng=np.random.default_rng(1), method=method)
    assert np.all(ds["tan_theta"].values == tan_theta) and np.all(ds["q"].values == 0.0)
    # after the other modes have decayed (their rates are below -200 1/s: e^-2 by 10 ms)
    assert _envelope_rate(ds, 0.01, 0.035) == pytest.approx(sigma, rel=0.01)


def test_the_incline_from_its_angle_and_on_the_cli(tmp_path, run):
    from squealkit import InputError
    from squealkit.io import load_dataset
    from squealkit.transient import ConstantIncline

    assert ConstantIncline.from_theta(math.radians(4.0)).tan_theta == pytest.approx(math.tan(math.radians(4.0)))
    with pytest.raises(InputError, match="theta"):
        ConstantIncline.from_theta(math.pi / 2)
    out = tmp_path / "run.nc"
    r = run("simulate", "--mu", "0.35", "--theta", "4", "--duration", "0.002", "--out", str(out), "--json")
    assert r.exit_code == 0, r.output
    ds = load_dataset(out)
    assert np.allclose(ds["tan_theta"].values, math.tan(math.radians(4.0)), rtol=1e-12)
    assert np.all(ds["q"].values == 0.0)
    r = run("simulate", "--theta", "4", "--sro", "sine", "--duration", "0.002")
    assert r.exit_code == 2 and "without --sro" in r.output
    r = run("simulate", "--theta", "90", "--duration", "0.002")
    assert r.exit_code == 2 and "--theta" in r.output


# --- UFF 58's six significant digits ------------------------------------------------------------------


@pytest.mark.parametrize(("fs", "written"), [(48_000.0, "2.08333e-05"), (44_100.0, "2.26757e-05"),
                                             (1_000.0, "1.00000e-03")])
def test_a_uff_file_of_a_whole_rate_reads_that_rate(tmp_path, fs, written):
    # pyuff writes the abscissa increment in E13.5 (its own file, as written, is the reference): 1/48000 s as
    # 2.08333e-05, whose inverse is 48000.077 Hz; 48000 Hz lies within half a unit of the last digit
    from squealkit.measurement import read_recording, recording_dataset
    from squealkit.measurement.formats import write_recording

    n = 480
    rec = recording_dataset({"mic": np.sin(np.arange(n) * 0.3), "probe": np.zeros(n)}, fs)
    f = write_recording(rec, tmp_path / "r.uff")
    assert f" {written} " in f.read_text().splitlines()[8]
    ds = read_recording(f)
    assert ds.attrs["fs"] == fs
    assert ds["time"].values[-1] == (n - 1) / fs
    if 1.0 / float(written) != fs:
        assert ds.attrs["fs_from_file"] == 1.0 / float(written)
        assert "whole rate" in ds.attrs["fs_rounding"] and written in ds.attrs["fs_rounding"]
    else:  # nothing was rounded: nothing to say
        assert "fs_from_file" not in ds.attrs


def test_a_uff_rate_that_is_not_whole_within_the_precision_is_read_as_written(tmp_path):
    # 1/3.33337e-05 = 29999.64 Hz; the text stands for 29999.59-29999.69 Hz, no whole number of Hz
    from squealkit.measurement import read_recording, recording_dataset
    from squealkit.measurement.formats import write_recording

    f = write_recording(recording_dataset({"mic": np.zeros(64)}, 30_000.0), tmp_path / "r.uff")
    f.write_text(f.read_text().replace("3.33333e-05", "3.33337e-05"))
    ds = read_recording(f)
    assert ds.attrs["fs"] == 1.0 / 3.33337e-05 and "fs_from_file" not in ds.attrs


# --- one way to ask whether an optional package is there ----------------------------------------------


@pytest.fixture()
def broken_package(tmp_path, monkeypatch):
    """A package found on the path whose import fails as pypardiso's does without MKL (an OSError from the
    shared library loader): installed, but broken."""
    pkg = tmp_path / "sk_broken_pkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("raise OSError('libmkl_rt.so.2: cannot open shared object file')\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    return "sk_broken_pkg"


def test_a_broken_install_is_not_available(broken_package):
    from squealkit._optional import available

    assert not available(broken_package)
    assert not available("sk_no_such_pkg") and not available("sk_no_such_pkg.sub")
    assert available("numpy")


def test_an_lu_backend_whose_module_does_not_import_is_refused_in_one_line(broken_package):
    # main asked importlib.util.find_spec, which finds the broken package: the backend was handed out and
    # failed when used, with the loader's OSError
    from squealkit import InputError
    from squealkit.solvers.lu import LU_BACKENDS, DenseLU, get_lu_backend, register_lu_backend

    register_lu_backend("sk-broken", lambda P, perm: DenseLU(P), requires=(broken_package,), install="reinstall it")
    try:
        with pytest.raises(InputError, match=f"needs {broken_package} .*does not import.*reinstall it"):
            get_lu_backend("sk-broken")
    finally:
        del LU_BACKENDS["sk-broken"]


def test_every_is_it_installed_question_goes_through_available():
    # the static rule: importlib.util.find_spec (or a bare try-import) to test for a package appears only
    # in squealkit._optional
    import ast
    from pathlib import Path

    src = Path(__file__).resolve().parents[1] / "src" / "squealkit"
    uses = []
    for f in src.rglob("*.py"):
        if f.name == "_optional.py":
            continue
        for node in ast.walk(ast.parse(f.read_text())):
            if isinstance(node, ast.Attribute) and node.attr == "find_spec":
                uses.append(f"{f.relative_to(src)}:{node.lineno}")
    assert not uses, uses


def test_the_limit_cycle_branch_takes_the_onset_a_report_has_already(monkeypatch):
    # the report's limit-cycle section handed its onset over, and the branch computed it again: now the
    # branch from a given onset is the branch it computes itself (same Hopf point, same cycles), without a
    # second critical_friction
    import squealkit.stability.critical as critical
    from squealkit.models import get_preset
    from squealkit.nonlinear import limit_cycle_branch
    from squealkit.stability import critical_friction

    model = get_preset("lv2013")
    kw = dict(n_points=11, max_points=4, check_harmonics=False, harmonics=4)
    own = limit_cycle_branch(model, (0.3, 1.0), **kw)
    onset = critical_friction(model, 0.0, damped=True)
    calls = []
    curve = critical.critical_friction_curve
    monkeypatch.setattr(critical, "critical_friction_curve", lambda *a, **k: calls.append(1) or curve(*a, **k))
    given = limit_cycle_branch(model, (0.3, 1.0), onset=onset, **kw)
    assert not calls
    assert given.attrs["hopf_mu"] == own.attrs["hopf_mu"]
    np.testing.assert_array_equal(given["amplitude"].values, own["amplitude"].values)
    # an onset of another incline is not taken: computed as without it
    other = critical_friction(model, 0.05, damped=True)
    limit_cycle_branch(model, (0.3, 1.0), onset=other, **kw)
    assert calls

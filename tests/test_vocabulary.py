"""One vocabulary for the API and the CLI (issue 28, item 2): each defect below failed on main.

- ``eigenvalues(model, mu, tan_theta)`` took tan(theta) third where ``stability_map`` takes
  theta [rad]: ``tan_theta`` is keyword-only (positional use warns for one release).
- Results name their quantities alike: ``frequency_hz`` (``fe_modes`` and the maps said
  ``frequency``), ``disc_speed``/``rpm`` for the disc (never ``omega``, which is an eigenfrequency),
  one critical-friction schema for the small and the FE models, and a ``kind`` attribute the plot
  accessor reads instead of guessing from variable names (files saved before still plot).
- The CLI: one meaning and one type per option name (the registry of ``cli/_options.py``, checked
  by ``tests/test_naming.py``), old spellings kept as hidden aliases that print one deprecation line.
"""

from __future__ import annotations

import dataclasses
import inspect
import math
import warnings

import numpy as np
import pytest
import scipy.sparse as sp

from squealkit.models import FEModel, get_preset
from squealkit.stability import (
    ONSET_STATUS,
    critical_friction,
    critical_friction_curve,
    eigenvalues,
    fe_critical_friction,
    fe_modes,
    fe_stability_map,
    modes,
    stability_map,
    stability_verdict,
)
from test_api_docs import public_objects

LV = get_preset("lv2013")


# -- tan_theta is keyword-only ------------------------------------------------------------------


def test_tan_theta_by_position_warns_and_the_swap_is_visible():
    # The numbers: at mu = 0.5, theta = 0.1 rad the map's growth rate is that of
    # tan_theta = tan(0.1) (301.697 1/s); 0.1 passed third to eigenvalues meant tan_theta = 0.1
    # (301.400 1/s) without a word. Both values from the engine itself, checked against LAPACK
    # in test_stability.py; here what matters is that the two are told apart.
    mu, theta = 0.5, 0.1
    ref = float(stability_map(LV, [mu], [theta], damped=False).max_growth_rate[0, 0])
    assert ref == pytest.approx(301.697, abs=1e-3)
    new = eigenvalues(LV, mu, tan_theta=math.tan(theta)).real.max()
    assert new == pytest.approx(ref, rel=1e-12)
    with pytest.warns(DeprecationWarning, match=r"eigenvalues\(\.\.\., tan_theta\) by position is deprecated; "
                                                r"use tan_theta=.*theta in radians"):
        old = eigenvalues(LV, mu, theta).real.max()
    assert old == pytest.approx(301.400, abs=1e-3)  # what a caller swapping them silently got
    with pytest.warns(DeprecationWarning, match="tan_theta="):
        assert stability_verdict(LV, 0.0, 0.5).item() == stability_verdict(LV, 0.0, tan_theta=0.5).item()
    with pytest.raises(TypeError, match="both by position and as tan_theta="):
        eigenvalues(LV, mu, 0.1, tan_theta=0.1)
    with pytest.raises(TypeError, match="at most 3 positional"):
        eigenvalues(LV, mu, 0.1, True)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        eigenvalues(LV, mu, tan_theta=0.1, damped=False)


#: Functions whose positional tan_theta is the swept axis their name announces (not a trap).
SWEEPS_OVER_SLOPE = {"squealkit.nonlinear.continuation.limit_cycle_branch_slope"}


def test_no_analysis_takes_tan_theta_by_position():
    """Every public function with a ``tan_theta`` takes it by keyword (model-matrix methods,
    ``model.stiffness_matrix(mu, tan_theta)``, keep the equations' order: docs/api.md)."""
    offenders = []
    for name, obj in public_objects().items():
        if not inspect.isfunction(obj) or name in SWEEPS_OVER_SLOPE:
            continue
        p = inspect.signature(obj).parameters.get("tan_theta")
        if p is not None and p.kind is not p.KEYWORD_ONLY:
            offenders.append(name)
        if p is not None and p.kind is p.KEYWORD_ONLY and name.rsplit(".", 1)[1] in ("eigenvalues",):
            assert getattr(obj, "__keyword_only__", ()) == ("tan_theta",), name  # the one-release path
    assert not offenders, offenders
    assert {"squealkit.stability.eigen.eigenvalues", "squealkit.stability.eigen.stability_verdict",
            "squealkit.stability.ensemble.ensemble_onset"} <= set(public_objects())


# -- result schema ------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def fe_small():
    """Three doublets, the first two coupled by friction (KR): a flutter onset near mu = 0.3."""
    w = 2 * np.pi * np.array([1000, 1000, 1200, 1200, 5000, 5000.0])
    KR = sp.lil_matrix((6, 6))
    KR[0, 2], KR[2, 0] = 3e7, -3e7
    return FEModel.from_matrices(M=sp.eye(6), K1=sp.diags(w**2), KR=KR.tocsr(), D1=sp.diags(1e-4 * w))


@pytest.fixture(scope="module")
def results(fe_small):
    from squealkit.transient import SineRunOut, simulate
    from squealkit.transient.floquet import floquet_map

    return {
        "stability_map": stability_map(LV, np.linspace(0, 0.8, 5), np.radians([0.0, 2.0]), damped=False),
        "modes": modes(LV, 0.5, 0.0, damped=False),
        "critical_friction": critical_friction_curve(LV, np.radians([0.0, 2.0]), damped=False),
        "fe_stability_map": fe_stability_map(fe_small, [100.0, 200.0], [0.0, 0.5, 1.0]),
        "fe_modes": fe_modes(fe_small, 100.0, 0.5),
        "fe_critical_friction": fe_critical_friction(fe_small, [100.0, 200.0], mu_max=1.0),
        "simulation": simulate(LV, mu=0.4, profile=SineRunOut(0.08e-3, 1e-3), duration=0.002),
        "floquet_map": floquet_map(LV, mu=[0.2], amplitude=[1e-5], wavelength=1e-3, speed=0.02),
    }


#: Names a result never uses, and the one it uses instead.
FORBIDDEN_RESULT_NAMES = {"frequency": "frequency_hz", "freq_hz": "frequency_hz", "omega_disc": "disc_speed",
                          "frequency_rad_s": "omega_rad_s", "theta_rad": "theta"}


def schema_problems(ds) -> list[str]:
    """How the variables and coordinates of a result Dataset break the shared schema (DESIGN.md)."""
    from squealkit.io import RESULT_KINDS

    out = []
    if ds.attrs.get("kind") not in RESULT_KINDS:
        out.append(f"attrs['kind'] = {ds.attrs.get('kind')!r} is not one of RESULT_KINDS")
    for name, v in {**ds.coords, **ds.data_vars}.items():
        units = v.attrs.get("units")
        text = f"{name} [{units}] {v.attrs.get('long_name', '')}"
        if name in FORBIDDEN_RESULT_NAMES:
            out.append(f"{text}: name it {FORBIDDEN_RESULT_NAMES[name]}")
        if units == "Hz" and not (name.endswith("_hz") or name == "freq" or name.startswith("freq_")
                                  or name.endswith("_freq")):
            out.append(f"{text}: a frequency in Hz is named *_hz (frequency_hz)")
        if "theta" in name and not name.startswith("tan_theta") and units is not None:
            want = "deg" if name.endswith("_deg") else "rad"
            if units != want:
                out.append(f"{text}: {name} must be in {want}")
        if name == "omega" and (units != "rad/s" or "disc" in str(v.attrs.get("long_name", ""))):
            out.append(f"{text}: omega is an eigen (circular) frequency [rad/s], never the disc speed")
        if "disc speed" in str(v.attrs.get("long_name", "")) and name not in ("rpm", "disc_speed"):
            out.append(f"{text}: the disc speed is rpm [1/min] or disc_speed [rad/s]")
    return out


def test_schema_check_catches_a_breach():
    import xarray as xr

    ds = xr.Dataset({"frequency": ("m", [1.0], {"units": "Hz"}), "omega": ("m", [1.0], {"units": "rad/s",
                     "long_name": "disc speed"}), "theta": ((), 2.0, {"units": "deg"})})
    assert len(schema_problems(ds)) == 6  # no kind; frequency twice; omega as disc speed twice; theta in deg


@pytest.mark.parametrize("kind", ["stability_map", "modes", "critical_friction", "fe_stability_map", "fe_modes",
                                  "fe_critical_friction", "simulation", "floquet_map"])
def test_results_follow_one_schema_and_say_their_kind(results, kind):
    from squealkit.io import result_kind

    ds = results[kind]
    assert schema_problems(ds) == []
    assert ds.attrs["kind"] == kind and result_kind(ds) == kind
    if kind in ("stability_map", "modes", "fe_stability_map", "fe_modes"):
        assert {"growth_rate", "frequency_hz", "damping_ratio", "unstable"} <= set(ds.data_vars)
        assert ds.frequency_hz.attrs["units"] == "Hz"


def test_small_and_fe_critical_friction_share_one_schema(results):
    """critical_friction returns a dataclass (one point), the sweeps a Dataset; the three speak
    the same names, units and status flags, and the dataclass converts with ``to_dataset()``."""
    one = critical_friction(LV, 0.0, damped=False)
    small = one.to_dataset()
    curve = results["critical_friction"].isel(theta=[0])
    fe = results["fe_critical_friction"]
    shared = ("mu_critical", "mu_e_critical", "omega_rad_s", "frequency_hz", "status")
    for ds in (small, curve, fe):
        assert set(shared) <= set(ds.data_vars), sorted(ds.data_vars)
        assert ds.status.attrs["flag_meanings"].split() == list(ONSET_STATUS)
        assert ds.status.dtype == np.int8
        assert schema_problems(ds) == []
    for name in shared:
        assert small[name].attrs.get("units") == fe[name].attrs.get("units") == curve[name].attrs.get("units")
        np.testing.assert_array_equal(small[name].values, curve[name].values)
    assert ONSET_STATUS[int(small.status[0])] == one.status
    np.testing.assert_allclose(fe.omega_rad_s.values, 2 * np.pi * fe.frequency_hz.values, rtol=1e-15)
    assert fe.status.values.tolist() == [ONSET_STATUS.index("onset")] * 2


def test_modes_and_fe_modes_name_their_variables_alike(results):
    small, fe = results["modes"], results["fe_modes"]
    shared = {"growth_rate", "frequency_hz", "damping_ratio", "unstable", "shape_real", "shape_imag"}
    assert shared <= set(small.data_vars) and shared <= set(fe.data_vars)
    np.testing.assert_allclose(fe.frequency_hz.values, fe.eigenvalue_imag.values / (2 * np.pi), rtol=1e-15)


def test_result_dataclasses_use_the_vocabulary():
    """Fields and properties of the public result dataclasses use the result names (a property kept
    one release under its old name warns: EigenSolution.frequency)."""
    from squealkit.solvers.band import EigenSolution

    problems = []
    classes = {n: o for n, o in public_objects().items() if inspect.isclass(o) and dataclasses.is_dataclass(o)}
    classes["squealkit.stability.sparse.EigenSolution"] = EigenSolution
    for name, obj in classes.items():
        props = [n for n, v in vars(obj).items() if isinstance(v, property)]
        for field in [f.name for f in dataclasses.fields(obj)] + props:
            if field in FORBIDDEN_RESULT_NAMES:
                if field in props and "deprecated" in (getattr(obj, field).__doc__ or "").lower():
                    continue
                problems.append(f"{name}.{field}: name it {FORBIDDEN_RESULT_NAMES[field]}")
    assert not problems, problems
    sol = EigenSolution(np.array([1j * 2 * np.pi]), None, np.array([0.0]))
    with pytest.warns(DeprecationWarning, match="frequency_hz"):
        np.testing.assert_array_equal(sol.frequency, sol.frequency_hz)


def test_files_saved_before_the_kind_attribute_still_plot(results, tmp_path):
    """An older result (``frequency``, ``omega_disc``, no ``kind``) is recognised and plots alike."""
    pytest.importorskip("matplotlib")
    from squealkit.io import result_kind, upgrade_result

    new = results["fe_stability_map"]
    old = new.rename({"frequency_hz": "frequency", "disc_speed": "omega_disc"})
    old.attrs = {k: v for k, v in new.attrs.items() if k != "kind"}
    assert result_kind(old) == "fe_stability_map"
    up = upgrade_result(old)
    assert up.attrs["kind"] == "fe_stability_map" and "frequency_hz" in up and "frequency" not in up
    assert upgrade_result(new) is new
    fig_old, fig_new = old.squeal.plot(kind="fe_growth"), new.squeal.plot(kind="fe_growth")
    assert [line.get_xydata().tolist() for a in fig_old.axes for line in a.get_lines()] == \
           [line.get_xydata().tolist() for a in fig_new.axes for line in a.get_lines()]
    sm = results["stability_map"]
    old_map = sm.rename({"frequency_hz": "frequency"})
    old_map.attrs = {k: v for k, v in sm.attrs.items() if k != "kind"}
    assert result_kind(old_map) == "stability_map"
    old_map.squeal.plot(kind="root_locus")


def test_limit_cycle_onset_kind_moved_out_of_the_result_kind():
    import xarray as xr

    from squealkit.io import upgrade_result
    from squealkit.nonlinear.continuation import _old_or_new

    old = xr.Dataset({"amplitude": (("point", "dof"), np.zeros((2, 1))), "stable": ("point", [True, False]),
                      "coefficients": (("point", "harmonic_row", "dof"), np.zeros((2, 3, 1)))},
                     attrs={"kind": "supercritical", "kind_from": "lyapunov"})
    up = upgrade_result(old)
    assert up.attrs["kind"] == "limit_cycle_branch"
    assert (up.attrs["hopf_kind"], up.attrs["hopf_kind_from"]) == ("supercritical", "lyapunov")
    assert _old_or_new(old.attrs, "hopf_kind", "kind") == "supercritical"


# -- the CLI: one meaning per option name, old spellings for one release ----------------------------


def _one_line(r) -> str:
    lines = r.stderr.strip().splitlines()
    assert r.exit_code == 2 and len(lines) == 1, (r.exit_code, r.stderr)
    return lines[0]


@pytest.mark.parametrize(("args", "words"), [
    (["analyze", "x.nc", "--mic", "mic", "--displacement", "d", "--radius", "0.05", "--rpm", "100:900:5"],
     "--rpm '100:900:5' is a range; squealkit analyze takes one disc speed"),
    (["synth", "--out", "r.nc", "--rpm", "300:900:3"], "--rpm '300:900:3' is a range; squealkit synth takes one disc"),
    (["modes", "--mu", "0.1:0.5:3"], "--mu '0.1:0.5:3' is a range; squealkit modes takes one friction coefficient"),
    (["montecarlo", "--theta", "0:2:3"], "--theta '0:2:3' is a range; squealkit montecarlo takes one run-out"),
    (["simulate", "--sro-amplitude", "1e-5:8e-5:3"], "--sro-amplitude '1e-5:8e-5:3' is a range; squealkit simulate"),
    # the same type everywhere: a range is a range in the command that sweeps it (and is checked there)
    (["stability", "--rpm", "100:200:x"], "the point count N='x' is not a whole number"),
    (["stability", "--rpm", "100:900:5"], "--rpm applies to FE models only"),
])
def test_one_value_commands_refuse_a_range_in_one_line(run, tmp_path, monkeypatch, args, words):
    monkeypatch.chdir(tmp_path)
    assert words in _one_line(run(*args))


def test_the_fe_eigenvalue_band_has_its_own_name(run):
    # --band is the squeal band (analyze, report, campaign); the FE search band is --eigen-band, and
    # --band on an FE command is its deprecated alias: the same option, so the same refusal
    assert "--eigen-band applies to FE models only" in _one_line(run("critical", "--eigen-band", "1000:2000"))
    assert "--eigen-band applies to FE models only" in _one_line(run("critical", "--band", "1000:2000"))
    assert "--band" not in run("critical", "--help").output  # hidden: the help shows one spelling


def test_old_spellings_work_for_one_release_with_one_line(run, tmp_path):
    from squealkit.io import load_dataset

    new = run("synth", "--out", str(tmp_path / "a.nc"), "--duration", "0.05", "--pulses-per-rev", "4")
    assert new.exit_code == 0 and "deprecated" not in new.stderr, new.stderr
    old = run("synth", str(tmp_path / "b.nc"), "--duration", "0.05", "--tacho-ppr", "4")
    assert old.exit_code == 0, old.stderr
    notes = [line for line in old.stderr.splitlines() if "deprecated" in line]
    assert notes == ["squealkit: warning: --tacho-ppr is deprecated in 'squealkit synth'; use --pulses-per-rev "
                     "(tacho pulses per revolution).",
                     "squealkit: warning: the output as an argument is deprecated in 'squealkit synth'; use --out "
                     f"{tmp_path / 'b.nc'}."]
    a, b = load_dataset(tmp_path / "a.nc"), load_dataset(tmp_path / "b.nc")
    np.testing.assert_array_equal(a.tacho.values, b.tacho.values)  # the alias gave its value: 4 pulses
    assert "--tacho-ppr" in _one_line(run("synth", "--out", str(tmp_path / "c.nc"), "--pulses-per-rev", "2",
                                          "--tacho-ppr", "2"))
    assert "--out-dir" in _one_line(run("synth", "--out", str(tmp_path / "d"), "--campaign", "2"))
    assert "--out FILE" in _one_line(run("synth"))


def test_folder_outputs_are_out_dir(run, tmp_path):
    """--out is a file in every command; the four that write a folder take --out-dir (--out stays,
    hidden, for one release)."""
    for cmd in ("campaign", "fe-demo", "report", "reproduce"):
        text = run(cmd, "--help").output
        assert "--out-dir" in text and "--out " not in text, cmd
    r = run("fe-demo", "--size", "15", "--out", str(tmp_path / "b"))  # the alias reaches the same checks
    assert "--size=15 must be even" in _one_line(r)
    assert "Missing option '--out-dir'" in _one_line(run("fe-demo", "--size", "16"))

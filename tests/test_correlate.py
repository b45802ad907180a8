"""Test meets model (issue 24): a SYNTHETIC campaign made from a known model and friction law.

Truth comes from :func:`squealkit.correlate.synthetic.synthetic_correlation_campaign`: the
``lv2013`` preset (damped) at the measured mu plus a hidden offset of 0.05 decides which
applications have an unstable mode (public :func:`squealkit.stability.eigenvalues`, one call);
the recordings squeal at that mode's frequency (hit), stay quiet (over-prediction), or squeal at
6.3 kHz, a line the model never predicts (miss), by a known design. The campaign is analysed
by ``run_campaign`` as a user would; the correlation must recover every outcome exactly.
"""

import json
import math

import numpy as np
import pytest
from click.testing import CliRunner

from squealkit import InputError
from squealkit.campaign import read_matrix, run_campaign
from squealkit.cli.main import cli
from squealkit.correlate import (
    ConditionMap,
    FrictionLaw,
    ParameterLaw,
    campaign_conditions,
    correlate,
    fit_friction_law,
    operating_points,
    predict_modes,
)
from squealkit.correlate.synthetic import synthetic_correlation_campaign
from squealkit.models import get_preset
from squealkit.stability import eigenvalues

HIDDEN_OFFSET = 0.05


@pytest.fixture(scope="module")
def camp(tmp_path_factory):
    d = tmp_path_factory.mktemp("corr")
    truth = synthetic_correlation_campaign(d / "camp", n_applications=35, mu_offset=HIDDEN_OFFSET, duration=0.4,
                                           fs=20000.0, seed=0)
    summary = run_campaign(d / "camp" / "matrix.csv", d / "out", mic="mic", displacement="displacement", radius=0.05,
                           band=(2000.0, 8000.0), report=False)
    assert not summary["failed"]
    (d / "model.toml").write_text('preset = "lv2013"\n[correlate]\nmu = "measured"\n')
    return d, truth


def test_outcomes_recovered_exactly(camp):
    d, truth = camp
    counts = truth["counts"]
    assert all(counts[k] >= 1 for k in ("hit", "miss", "over_prediction", "quiet")), counts  # every kind is tested
    ds = correlate(d / "out", get_preset("lv2013"), ConditionMap(mu_offset=HIDDEN_OFFSET))
    got = dict(zip(ds["application"].values, ds["outcome"].values, strict=True))
    want = {a: t["outcome"] for a, t in truth["by_application"].items()}
    assert got == want
    assert (ds.attrs["hits"], ds.attrs["misses"], ds.attrs["over_predictions"], ds.attrs["quiet"]) == \
        (counts["hit"], counts["miss"], counts["over_prediction"], counts["quiet"])
    assert ds.attrs["tolerance_percent"] == 3.0 and "3 %" in ds.attrs["matching"]
    # the predicted frequency is the truth's (public eigenvalues, one application at a time)
    for a, t in truth["by_application"].items():
        f = ds["predicted_hz"].sel(application=a).values
        f = f[np.isfinite(f)]
        if t["predicted_hz"] is None:
            assert f.size == 0
        else:
            assert f.size == 1 and f[0] == pytest.approx(t["predicted_hz"], rel=1e-9)
    assert ds["frequency_hz"].attrs["units"] == "Hz" and ds["growth_rate"].attrs["units"] == "1/s"
    assert set(ds["frequency_hz"].dims) == {"application", "mode"}
    # occurrence matrices: measured and predicted in the 2.5 kHz band agree where the outcome does
    b = int(np.argmin(np.abs(ds["band_center_hz"].values - 2512)))
    assert np.nansum(ds["measured_by_temperature"].values) > 0 and ds["band_predicted"].values[b] == \
        counts["hit"] + counts["over_prediction"] + sum(
            1 for t in truth["by_application"].values() if t["outcome"] == "miss" and t["predicted_hz"] is not None)


def test_correlation_results_follow_the_result_schema(camp):
    """correlate and its public steps return results in the shared schema (tests/test_vocabulary.py):
    a kind of RESULT_KINDS and every frequency in Hz named *_hz (the band edges were band_lo/band_hi)."""
    from squealkit.correlate import match_modes, measured_components
    from squealkit.io import RESULT_KINDS
    from test_vocabulary import schema_problems

    d, _ = camp
    apps, events = campaign_conditions(d / "out")
    points = operating_points(apps, ConditionMap(mu_offset=HIDDEN_OFFSET))
    measured = measured_components(apps["application"].values, events)
    predicted = predict_modes(get_preset("lv2013"), points)
    results = {"correlation": correlate(d / "out", get_preset("lv2013"), ConditionMap(mu_offset=HIDDEN_OFFSET)),
               "measured_components": measured, "predicted_modes": predicted,
               "mode_match": match_modes(predicted, measured, points)}
    for kind, ds in results.items():
        assert schema_problems(ds) == [], kind
        assert ds.attrs["kind"] == kind and kind in RESULT_KINDS


def test_calibration_recovers_the_hidden_offset(camp):
    d, truth = camp
    ds = correlate(d / "out", get_preset("lv2013"), ConditionMap(), fit={"mu_offset": (-0.01, 0.11)})
    cal = json.loads(ds.attrs["calibration"])
    q = cal["quantities"]["mu_offset"]
    lo, hi = q["interval"]
    assert lo <= HIDDEN_OFFSET <= hi and lo <= q["value"] <= hi
    assert hi - lo < 0.03 and q["identifiable"]  # the applications near the limit bracket it
    # the bracket the data allow, by hand: the offset must lift the lowest hit above mu_c and
    # keep the highest quiet application below it (critical friction of the damped preset)
    mu_c = truth["mu_critical"]
    apps = truth["by_application"].values()
    assert lo == pytest.approx(mu_c - min(t["mu"] for t in apps if t["outcome"] == "hit"), abs=2e-4)
    assert hi == pytest.approx(mu_c - max(t["mu"] for t in apps if t["outcome"] == "quiet"), abs=2e-4)
    assert cal["after"]["hits"] == truth["counts"]["hit"] and cal["before"]["hits"] < cal["after"]["hits"]


def test_damping_scale_is_reported_unidentifiable_when_the_data_cannot_see_it(camp):
    d, _ = camp
    # with mu given right, a small change of damping moves no application across the limit: the
    # whole bounds fit equally well
    ds = correlate(d / "out", get_preset("lv2013"), ConditionMap(mu_offset=HIDDEN_OFFSET),
                   fit=["damping_scale=0.999:1.001"])
    q = json.loads(ds.attrs["calibration"])["quantities"]["damping_scale"]
    assert not q["identifiable"] and q["interval"] == [0.999, 1.001]


def test_friction_law_fitted_from_the_campaign(camp):
    d, truth = camp
    apps, _ = campaign_conditions(d / "out")
    law = fit_friction_law({k: apps[k].values for k in ("pressure_bar", "temperature_c")}, apps["mu_measured"].values)
    t = truth["law"]
    # least squares on 35 points with noise 0.003: coefficients within a few standard errors
    assert law.coefficients["temperature_c"] == pytest.approx(t["temperature_c"], abs=3e-5)
    assert law.coefficients["pressure_bar"] == pytest.approx(t["pressure_bar"], abs=3e-4)
    assert law.residual_std == pytest.approx(t["noise_std"], rel=0.4)
    assert law.mu({"pressure_bar": 20.0, "temperature_c": 200.0}) == pytest.approx(t["mu0"], abs=0.003)
    ds = correlate(d / "out", get_preset("lv2013"), ConditionMap(mu="law", mu_offset=HIDDEN_OFFSET))
    assert "fitted to 35 applications" in ds.attrs["friction_law"]


def test_identical_conditions_solved_once_and_parameter_laws(camp):
    d, _ = camp
    apps, _ = campaign_conditions(d / "out")
    model = get_preset("lv2013")
    law = FrictionLaw(0.45, {"temperature_c": 5e-4}, {"temperature_c": 200.0})
    # temperatures rounded to 100 C: few distinct operating points
    apps = apps.assign(temperature_c=np.round(apps["temperature_c"] / 100) * 100)
    cmap = ConditionMap(mu="law", mu_law=law, laws=(ParameterLaw("k1", "temperature_c", -1e-3, 200.0),))
    pts = operating_points(apps, cmap)
    pred = predict_modes(model, pts)
    n_distinct = np.unique(apps["temperature_c"].values).size
    assert pred.attrs["distinct_points"] == n_distinct < apps.sizes["application"]
    # reference: the public eigenvalues of each application's own model, one by one
    for a in apps["application"].values[:6]:
        T = float(apps["temperature_c"].sel(application=a))
        m = model.replace(k1=model.k1 * (1 - 1e-3 * (T - 200.0)))
        lam = eigenvalues(m, law.mu({"temperature_c": T}), damped=True)
        assert np.allclose(pred["frequency_hz"].sel(application=a).values, lam.imag / (2 * math.pi), rtol=1e-9)


def test_cli_json_keys_and_report(camp):
    d, _ = camp
    out = d / "corr_out"
    res = CliRunner().invoke(cli, ["correlate", str(d / "out"), "--config", str(d / "model.toml"), "--fit",
                                   "mu_offset=-0.01:0.11", "--tolerance", "3", "--out-dir", str(out), "--json"])
    assert res.exit_code == 0, res.output
    j = json.loads(res.stdout)
    for k in ("applications", "hits", "misses", "over_predictions", "quiet", "per_application", "calibration",
              "tolerance_percent"):
        assert k in j
    assert set(j["per_application"][0]) == {"application", "mu", "predicted_hz", "measured_hz", "outcome"}
    assert set(j["calibration"]["mu_offset"]) >= {"value", "interval"}
    assert (out / "report.html").is_file() and (out / "correlation.nc").is_file()
    html = (out / "report.html").read_text()
    assert "over-prediction" in html and "SYNTHETIC" in html and "mu_offset" in html
    assert {p.name for p in (out / "figures").glob("*.png")} >= {"noise_matrices_temperature.png",
                                                                "noise_map_temperature.png"}


@pytest.mark.parametrize(("args", "match"), [
    (["--fit", "mu_offset=0.2"], "NAME=LO:HI"),
    (["--fit", "mu_offset=0.2:0.1"], "LO < HI"),
    (["--fit", "stiffness=0:1"], "no quantity"),
    (["--tolerance", "0"], "tolerance"),
    (["--tolerance", "80"], "tolerance"),
])
def test_bad_inputs_exit_2(camp, args, match):
    d, _ = camp
    res = CliRunner().invoke(cli, ["correlate", str(d / "out"), "--config", str(d / "model.toml"), *args])
    assert res.exit_code == 2, res.output
    assert match in res.output and len(res.output.strip().splitlines()) == 1


def test_bad_campaign_folder_and_table_exit_2(camp, tmp_path):
    d, _ = camp
    res = CliRunner().invoke(cli, ["correlate", str(tmp_path), "--config", str(d / "model.toml")])
    assert res.exit_code == 2 and "campaign.duckdb" in res.output and len(res.output.strip().splitlines()) == 1
    (tmp_path / "m.toml").write_text('preset = "lv2013"\n[correlate]\nmu = "measurd"\n')
    res = CliRunner().invoke(cli, ["correlate", str(d / "out"), "--config", str(tmp_path / "m.toml")])
    assert res.exit_code == 2 and "measured" in res.output and len(res.output.strip().splitlines()) == 1
    with pytest.raises(InputError, match="mu_scale"):
        ConditionMap(mu_scale=-1.0)


def test_matrix_mu_column(tmp_path):
    (tmp_path / "m.csv").write_text("application,file,mu\nA,a.nc,0.42\nB,b.nc,\n")
    a, b = read_matrix(tmp_path / "m.csv")
    assert a.mu == 0.42 and math.isnan(b.mu) and "mu" not in a.extra
    (tmp_path / "m.csv").write_text("application,file,mu\nA,a.nc,-0.1\n")
    with pytest.raises(InputError, match="mu"):
        read_matrix(tmp_path / "m.csv")


def _write_store(out, rows):
    """A campaign store as ``squealkit campaign`` leaves it: (application, mu, rpm, squeal frequency or None)."""
    from squealkit.campaign.store import CampaignStore

    out.mkdir(parents=True, exist_ok=True)
    results = []
    for app, mu, rpm, f in rows:
        row = {"application": app, "file": f"{app}.nc", "pressure_bar": 20.0, "temperature_c": 100.0,
               "speed_kmh": 50.0, "synthetic": True, "squeal": f is not None, "mean_rpm": rpm, "criteria": "test",
               "mu": mu, "error": None}
        ev = [] if f is None else [{"application": app, "event": 0, "frequency_hz": f, "peak_dba": 80.0}]
        results.append((row, ev))
    with CampaignStore(out / "campaign.duckdb") as store:
        store.put_many(results)


@pytest.mark.slow
def test_fe_demo_with_one_reduced_basis(tmp_path):
    """The built-in FE brake (small), one POD basis for the campaign; reference: a dense solve of the
    full model (LAPACK) at each distinct operating point."""
    from squealkit.fe.demo import build_fe_demo
    from squealkit.models import FEModel
    from squealkit.stability.fe_sweep import FESolver

    demo = build_fe_demo(n_theta=8, n_r=2)
    fe = FEModel.from_matrices(**{k: demo[k] for k in ("M", "D1", "DG", "K1", "KR", "KGeo")},
                               disc_speed_ref=demo["disc_speed_ref"], mu_ref=demo["mu_ref"])
    band = (4000.0, 5000.0)
    dense = FESolver(fe, "dense", band)
    ref = {}
    for mu in (0.2, 0.4):
        lam = dense.solve(2 * math.pi * 900 / 60, mu, vectors=False).eigenvalues
        ref[mu] = lam.imag[lam.real > 1e-6 * np.abs(lam)] / (2 * math.pi)
    assert ref[0.2].size == 0 and ref[0.4].size == 1  # one mode of the band goes unstable between them
    f = float(ref[0.4][0])
    _write_store(tmp_path, [("H", 0.4, 900.0, f * 1.01), ("O", 0.4, 900.0, None), ("M1", 0.2, 900.0, 4700.0),
                            ("M2", 0.4, 900.0, f * 1.06), ("Q", 0.2, 900.0, None)])
    ds = correlate(tmp_path, fe, method="pod", band=band)
    assert dict(zip(ds["application"].values, ds["outcome"].values, strict=True)) == \
        {"H": "hit", "O": "over_prediction", "M1": "miss", "M2": "miss", "Q": "quiet"}
    assert ds.attrs["distinct_points"] == 2 and ds.attrs["basis_size"] > 0 and ds.attrs["method"] == "pod"
    got = ds["predicted_hz"].sel(application="H").values
    assert got[np.isfinite(got)] == pytest.approx([f], rel=1e-6)
    assert np.nanmax(ds["residual"].values) < 1e-6  # the basis' backward error: trusted


def test_mu_from_torque_and_pressure(tmp_path):
    """mu = T / (n_faces p A r_eff): a recording whose torque channel is the brake torque of mu = 0.42
    at 20 bar on a 40 mm piston with a 0.11 m effective radius (two friction faces)."""
    from squealkit.measurement import synthetic_recording
    from squealkit.measurement.formats.writers import write_recording

    area, r_eff, p_bar = math.pi * 0.02**2, 0.11, 20.0
    torque = 0.42 * 2 * p_bar * 1e5 * area * r_eff  # [N m]
    rec = synthetic_recording(duration=0.05, fs=20000.0, squeal_on="none", seed=1)
    rec = rec.assign(torque=("time", np.full(rec.sizes["time"], torque), {"units": "N m"}))
    write_recording(rec, tmp_path / "A.nc")
    _write_store(tmp_path / "out", [("A", math.nan, 900.0, None)])
    apps, _ = campaign_conditions(tmp_path / "out")
    apps = apps.assign(file=("application", [str(tmp_path / "A.nc")]))
    cmap = ConditionMap(mu="torque", torque_channel="torque", piston_area=area, effective_radius=r_eff)
    assert float(operating_points(apps, cmap)["mu"][0]) == pytest.approx(0.42, rel=1e-9)
    with pytest.raises(InputError, match="piston_area"):
        ConditionMap(mu="torque", torque_channel="torque", effective_radius=r_eff)


def test_rows_on_a_dask_client_give_the_same_numbers(camp, monkeypatch):
    distributed = pytest.importorskip("distributed")
    import squealkit.correlate.predict as predict

    d, _ = camp
    monkeypatch.setattr(predict, "_CHUNK_SMALL", 8)  # several tasks
    here = correlate(d / "out", get_preset("lv2013"), ConditionMap(mu_offset=HIDDEN_OFFSET))
    with distributed.Client(processes=False, n_workers=1, threads_per_worker=2, dashboard_address=":0") as client:
        there = correlate(d / "out", get_preset("lv2013"), ConditionMap(mu_offset=HIDDEN_OFFSET), client=client)
    np.testing.assert_array_equal(here["frequency_hz"].values, there["frequency_hz"].values)
    assert list(here["outcome"].values) == list(there["outcome"].values)

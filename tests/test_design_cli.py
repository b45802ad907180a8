"""``squealkit design``, driven in-process on NLEVP disk_brake100 (issue #26 item 5).

Reference values: the Python API (:func:`squealkit.design.eigen_derivatives`) on the same model,
whose derivatives tests/test_design.py checks against central differences.
"""

from __future__ import annotations

import json

import pytest

DESIGN = '[design]\nstiffness = "K1"\nfriction = "KR"\ndamping = "D1"\n'


@pytest.fixture(scope="module")
def brake(tmp_path_factory):
    from squealkit.data import nlevp_path

    folder = tmp_path_factory.mktemp("nlevp")
    path = folder / "brake.toml"
    path.write_text(f'model = "fe"\n[fe]\nfile = "{nlevp_path().as_posix()}"\n\n{DESIGN}')
    return path


@pytest.fixture(scope="module")
def study(brake):
    from click.testing import CliRunner

    from squealkit.cli.main import cli

    r = CliRunner().invoke(cli, ["design", "--config", str(brake), "--rpm", "60", "--json"])
    assert r.exit_code == 0, r.output
    return json.loads(r.stdout)


def test_json_gives_the_unstable_modes_with_their_sensitivities(brake, study):
    from squealkit.data import nlevp_path
    from squealkit.design import eigen_derivatives, load_design
    from squealkit.fe import load_fe_model

    model = load_fe_model(nlevp_path())
    ref = eigen_derivatives(model, load_design(brake, model), 60.0)
    assert study["rpm"] == 60.0 and study["mu"] == 1.0 and study["method"] == "dense"
    assert [p["name"] for p in study["parameters"]] == ["stiffness", "friction", "damping"]
    (mode,) = study["modes"]
    assert mode["frequency_hz"] == pytest.approx(float(ref.frequency_hz[0]), rel=1e-12)
    assert mode["growth_rate"] == pytest.approx(float(ref.growth_rate[0]), rel=1e-12)
    for name in ("stiffness", "friction", "damping"):
        s = mode["sensitivity"][name]
        assert s["growth_rate"] == pytest.approx(float(ref.dgrowth_rate_dp.sel(parameter=name)[0]), rel=1e-9)
        assert s["frequency_hz"] == pytest.approx(float(ref.dfrequency_hz_dp.sel(parameter=name)[0]), rel=1e-9)
    rows = study["countermeasures"]
    assert [r["rank"] for r in rows] == [1, 2, 3]
    # this low-frequency mode of the (scaled) NLEVP brake is not removed by any one of these changes: less
    # friction or more stiffness turn it into a diverging real root, more damping only slows it
    # (a dense solve at 2x D1 still has sigma = 5.3e-4 1/s); the study says so rather than claim a fix
    from squealkit.design import COUNTERMEASURE_STATUS

    assert {r["status"] for r in rows} <= set(COUNTERMEASURE_STATUS) - {"confirmed"}
    damping = next(r for r in rows if r["parameter"] == "damping")
    assert damping["predicted_change"] > 0 and 0 < damping["confirmed_growth_rate"] < mode["growth_rate"]


def test_out_dir_and_report_sentences(run, brake, tmp_path):
    out = tmp_path / "study"
    r = run("design", "--config", str(brake), "--rpm", "60", "--out-dir", str(out))
    assert r.exit_code == 0, r.output
    assert {p.name for p in out.iterdir()} >= {"design.nc", "design.json", "report.html", "figures"}
    assert "is not removed by any single declared change" in r.stdout
    html = (out / "report.html").read_text()
    assert "Designing the squeal out" in html and "Countermeasures" in html
    from squealkit.io import load_dataset

    ds = load_dataset(out / "design.nc")
    assert ds.attrs["kind"] == "countermeasures" and ds.squeal.plots == ("countermeasures",)


@pytest.mark.parametrize(("extra", "design", "match"), [
    ((), '[design]\npad = "K9"\n', "part = 'K9'"),
    ((), "", "no [design] table"),
    (("--mu", "0.1:0.5:3"), DESIGN, "is a range"),
    (("--rpm", "-5"), DESIGN, "must be > 0"),
])
def test_bad_input_is_one_line_and_exit_2(run, tmp_path, extra, design, match):
    from squealkit.data import nlevp_path

    path = tmp_path / "brake.toml"
    path.write_text(f'model = "fe"\n[fe]\nfile = "{nlevp_path().as_posix()}"\n\n{design}')
    args = ["design", "--config", str(path), *extra]
    if "--rpm" not in extra:
        args += ["--rpm", "60"]
    r = run(*args)
    assert r.exit_code == 2, r.output
    assert match in r.stderr and len(r.stderr.strip().splitlines()) == 1


def test_preset_without_config_and_small_model_without_mu(run, tmp_path):
    r = run("design", "--preset", "lv2013", "--mu", "0.6")
    assert r.exit_code == 2 and "needs --config" in r.stderr
    path = tmp_path / "rig.toml"
    path.write_text('preset = "lv2013"\n[design]\nsupport = "k3"\n')
    r = run("design", "--config", str(path))
    assert r.exit_code == 2 and "--mu" in r.stderr
    r = run("design", "--config", str(path), "--mu", "0.6", "--json")
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout)
    assert out["modes"] and set(out["modes"][0]["sensitivity"]) == {"support"}

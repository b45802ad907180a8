"""The CLI, driven in-process."""

import json

import numpy as np
import pytest

from squealkit.cli.main import main
from squealkit.io import load_dataset


def test_stability_json_reports_paper_band(run):
    r = run("stability", "--json")
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout)
    lo, hi = out["unstable_omega_rad_s"]
    # paper §3: 14997-15317 rad/s
    assert lo == pytest.approx(14997, abs=1) and hi == pytest.approx(15317, rel=5e-4)
    assert 0 < out["unstable_fraction"] < 1 and out["max_growth_rate"] > 0


def test_stability_writes_dataset_and_figures(run, tmp_path):
    nc, png, mp = tmp_path / "m.nc", tmp_path / "f.png", tmp_path / "map.svg"
    r = run("stability", "--mu", "0:0.8:21", "--theta", "-8:8:11", "--out", str(nc), "--plot", str(png),
            "--plot-map", str(mp))
    assert r.exit_code == 0, r.output
    ds = load_dataset(nc)
    assert ds.sizes["mu"] == 21 and ds.sizes["theta"] == 11
    np.testing.assert_allclose(ds.theta_deg.values, np.linspace(-8, 8, 11))
    assert png.read_bytes()[:4] == b"\x89PNG" and b"<svg" in mp.read_bytes()[:500]


def test_critical_json(run):
    r = run("critical", "--theta", "0", "--json")
    out = json.loads(r.stdout)
    assert out["status"] == "onset"
    assert out["mu_critical"] == pytest.approx(0.4448, abs=1e-3)
    assert out["mu_e_critical"] == pytest.approx(out["mu_critical"])
    assert 14997 <= out["omega_rad_s"] <= 15317
    assert out["frequency_hz"] == pytest.approx(out["omega_rad_s"] / (2 * np.pi))


def test_critical_curve_and_sensitivity(run):
    r = run("critical", "--theta", "-8:8:3", "--json")
    out = json.loads(r.stdout)
    assert len(out["mu_critical"]) == 3 and out["status"] == ["onset"] * 3
    r = run("critical", "--sensitivity", "--json")
    names = [row["parameter"] for row in json.loads(r.stdout)["sensitivity"]]
    assert set(names) >= {"k1", "k3", "kc", "m1", "m2"}


def test_tolerance_and_presets(run):
    r = run("tolerance", "--mu", "0.3", "--wavelength", "1e-3", "--json")
    out = json.loads(r.stdout)
    assert out["limiting_side"] == "rising" and out["q0_max"] > 0
    r = run("presets", "--json")
    assert set(json.loads(r.stdout)) == {"lv2013", "hoffmann2002"}


def test_hoffmann_preset_and_set(run):
    r = run("critical", "--preset", "hoffmann2002", "--set", "k3=1e6", "--json")
    assert r.exit_code == 0, r.output
    from squealkit.models import Hoffmann2002

    assert json.loads(r.stdout)["mu_critical"] == pytest.approx(Hoffmann2002(k3=1e6).mu_critical_closed_form())


@pytest.mark.parametrize(
    "args, message",
    [
        (["stability", "--mu", "abc"], "not a range"),
        (["stability", "--mu", "0:1:x"], "not a whole number"),
        (["stability", "--theta", "-95:0:3"], "between -90 and 90"),
        (["stability", "--set", "m1=-1"], "m1=-1.0 must be > 0"),
        (["stability", "--set", "m1=inf"], "must be finite"),
        (["stability", "--set", "m1"], "not NAME=VALUE"),
        (["stability", "--set", "q=1"], "Unknown parameter 'q'"),
        (["stability", "--config", "/no/such/file.toml"], "does not exist"),
        (["stability", "--preset", "nope"], "Unknown preset 'nope'"),
        (["stability", "--out", "result.csv"], "must end in .nc or .zarr"),
        (["critical", "--theta", "90"], "between -90 and 90"),
        (["stability", "--wrong"], "No such option"),
        (["tolerance"], "Missing option '--mu'"),
        (["frobnicate"], "No such command"),
    ],
)
def test_bad_input_is_one_line_exit_2(run, args, message):
    r = run(*args)
    assert r.exit_code == 2
    assert message in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1
    assert "Traceback" not in r.output


def test_main_returns_exit_code(capsys):
    assert main(["stability", "--mu", "bad"]) == 2
    assert "error" in capsys.readouterr().err
    assert main(["--help"]) == 0


def test_every_subcommand_help_has_an_example(run):
    from squealkit.cli.main import COMMANDS

    expected = {"stability", "critical", "tolerance", "simulate", "analyze", "synth", "reproduce", "report"}
    assert expected <= set(COMMANDS)
    for cmd in COMMANDS:
        r = run(cmd, "--help")
        assert r.exit_code == 0, cmd
        assert "Example" in r.output or "example" in r.output, cmd
        assert "squealkit " + cmd in r.output, cmd


def test_rig_command_says_where_each_frequency_comes_from(run):
    # issue 12: examples/myrig.toml leaves pin_bending_freq out -> Timoshenko, mu_crit 1.127 with a warning
    from pathlib import Path

    cfg = Path(__file__).parents[1] / "examples" / "myrig.toml"
    r = run("rig", "--config", str(cfg), "--json")
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout)
    assert out["frequencies"]["pin_bending"]["source"].startswith("Timoshenko")
    assert out["frequencies"]["pin_axial"]["source"] == "given"
    assert out["mu_crit"] == pytest.approx(1.1270, abs=1e-4)
    assert "Mode coupling needs friction" in r.stderr
    r = run("rig")
    assert r.exit_code == 0 and "2561.0 Hz  (given)" in r.output
    # every command on a rig file says it too, on stderr after its work (stdout's JSON stays clean)
    r = run("critical", "--config", str(cfg), "--json")
    assert r.exit_code == 0
    assert json.loads(r.stdout)["mu_critical"] == pytest.approx(1.1270, abs=1e-4)
    assert "rig frequencies: pin bending 2722.1 Hz (Timoshenko" in r.stderr
    r = run("montecarlo", "--config", str(cfg))   # a user error stays one line
    assert r.exit_code == 2 and len(r.stderr.strip().splitlines()) == 1

"""The CLI, driven in-process."""

import json

import numpy as np
import pytest

from squealkit.cli.main import main
from squealkit.io import load_dataset


def test_stability_json_reports_paper_band(run):
    r = run("stability", "--undamped", "--json")   # the paper's Fig. 2 is undamped (eq. 7)
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
    r = run("critical", "--theta", "0", "--undamped", "--json")
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


def test_critical_table_says_what_a_missing_onset_means(run):
    # issue 15: the consistent kinematics are stable for every mu up to 2 at theta = +8 deg (README table,
    # tests/test_kinematics.py); the table said "nan nan nan" there
    r = run("critical", "--theta", "0:8:2", "--set", "kinematics=consistent")
    assert r.exit_code == 0, r.output
    assert "nan" not in r.output
    row8 = next(line for line in r.output.splitlines() if line.split()[0] == "8")
    assert "stable for every mu up to 2 (no onset)" in row8
    r = run("critical", "--theta", "8", "--set", "kinematics=consistent")
    assert r.exit_code == 0 and "nan" not in r.output
    assert "stable for every mu up to 2 (no onset)" in r.output


def test_tolerance_words_for_inf_flat_and_unphysical(run):
    # issue 15: bare inf/nan and unphysical tolerances printed without a word
    from pathlib import Path

    # consistent kinematics at mu = 0: stable at every slope searched (runout_tolerance searches up to 80 deg)
    r = run("tolerance", "--mu", "0", "--set", "kinematics=consistent")
    assert r.exit_code == 0 and "inf" not in r.output
    assert "stable at every slope searched (up to 80 deg)" in r.output
    # Hoffmann's model at mu = 0.3 is unstable on a flat disc (tests/test_report.py)
    r = run("tolerance", "--mu", "0.3", "--preset", "hoffmann2002")
    assert "unstable on a flat disc: no run-out is tolerated" in r.output
    # examples/myrig.toml: mu_crit = 1.127 (test_rig_command...), so at mu = 0 slopes up to ~48 deg are
    # "stable": far beyond the paper's steepest slope (Fig. 4: 26.7 deg); q0 at 50 mm wavelength ~ 9 mm
    cfg = Path(__file__).parents[1] / "examples" / "myrig.toml"
    r = run("tolerance", "--config", str(cfg), "--mu", "0", "--wavelength", "0.05", "--json")
    out = json.loads(r.stdout)
    assert out["theta_max_deg"] > 26.7 and out["q0_max"] > 80e-6
    kinds = {c["kind"] for c in out["caveats"]}
    assert kinds == {"slope", "amplitude"}
    r = run("tolerance", "--config", str(cfg), "--mu", "0", "--wavelength", "0.05")
    assert "26.7 deg" in r.output and "80 um" in r.output
    # the paper's own case (mu = 0.3, lambda = 1 mm: 8.28 deg, 23.2 um, README) carries no caveat
    r = run("tolerance", "--mu", "0.3", "--wavelength", "1e-3", "--json")
    assert json.loads(r.stdout)["caveats"] == []


def test_critical_and_tolerance_write_dataset_and_figure(run, tmp_path):
    nc, png = tmp_path / "c.nc", tmp_path / "c.png"
    r = run("critical", "--theta", "-8:8:3", "--undamped", "--out", str(nc), "--plot", str(png))
    assert r.exit_code == 0, r.output
    ds = load_dataset(nc)
    np.testing.assert_allclose(ds.theta_deg.values, [-8, 0, 8])
    assert ds.mu_critical.values[1] == pytest.approx(0.4448, abs=1e-3)  # paper model, theta = 0 (README)
    assert png.read_bytes()[:4] == b"\x89PNG"
    nc1 = tmp_path / "c1.nc"
    r = run("critical", "--theta", "0", "--out", str(nc1), "--plot", str(tmp_path / "c1.svg"))
    assert r.exit_code == 0, r.output
    assert load_dataset(nc1).sizes["theta"] == 1 and b"<svg" in (tmp_path / "c1.svg").read_bytes()[:500]
    nc, pdf = tmp_path / "t.nc", tmp_path / "t.pdf"
    r = run("tolerance", "--mu", "0:0.6:4", "--wavelength", "1e-3", "--out", str(nc), "--plot", str(pdf))
    assert r.exit_code == 0, r.output
    ds = load_dataset(nc)
    assert ds.sizes["mu"] == 4 and list(ds.limiting_side.values)[-1] == "flat"
    assert ds.q0_max.attrs["units"] == "m" and pdf.read_bytes()[:4] == b"%PDF"
    for cmd in (["critical"], ["tolerance", "--mu", "0.3"]):
        r = run(*cmd, "--plot", str(tmp_path / "x.txt"))
        assert r.exit_code == 2 and len(r.stderr.strip().splitlines()) == 1
        r = run(*cmd, "--out", str(tmp_path / "x.csv"))
        assert r.exit_code == 2 and "must end in .nc or .zarr" in r.stderr


def test_analyze_plot_takes_a_file_like_every_other_plot(run, tmp_path):
    # issue 15: `analyze --plot` took a folder where every other --plot takes a file
    rec = tmp_path / "r.nc"
    assert run("synth", "--out", str(rec), "--duration", "0.3").exit_code == 0
    args = ["analyze", str(rec), "--mic", "mic", "--displacement", "displacement", "--rpm", "900", "--radius", "0.05"]
    r = run(*args, "--plot", str(tmp_path / "figs.svg"))
    assert r.exit_code == 0, r.output
    names = sorted(p.name for p in tmp_path.glob("figs_*"))
    assert len(names) == 8 and "figs_spectrogram.svg" in names and "figs_event_phase.svg" in names
    r = run(*args, "--plot", str(tmp_path / "figs.txt"))
    assert r.exit_code == 2 and "must end in .png or .svg or .pdf" in r.stderr
    # a folder still works, with a note that it is deprecated
    r = run(*args, "--plot", str(tmp_path / "old"))
    assert r.exit_code == 0 and "deprecated" in r.stderr and len(list((tmp_path / "old").glob("r_*.png"))) == 8

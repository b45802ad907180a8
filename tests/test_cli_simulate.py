"""``squealkit simulate`` driven in-process; user errors exit 2 with one line on stderr."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

from squealkit.cli.main import cli
from squealkit.io import load_dataset


def _run(args):
    try:
        runner = CliRunner(mix_stderr=False)
    except TypeError:  # click >= 8.2 keeps stderr apart by default
        runner = CliRunner()
    return runner.invoke(cli, ["simulate", *args])


def test_json_summary_fig4_case(tmp_path):
    out, png = tmp_path / "run.nc", tmp_path / "fig4.png"
    r = _run(["--mu", "0.4", "--sro", "sine", "--sro-amplitude", "8e-5", "--sro-wavelength", "1e-3",
              "--speed", "0.02", "--duration", "0.06", "--fs", "20000", "--json", "--out", str(out),
              "--plot", str(png)])
    assert r.exit_code == 0, r.output + r.stderr
    s = json.loads(r.stdout)
    assert s["status"] == "completed"
    assert set(s["peak"]) == {"x1", "y1", "y2"}
    assert {st["stage"] for st in s["stages"]} == {"rising", "falling"}
    ds = load_dataset(out)
    assert ds.sizes["time"] == 1201 and ds.attrs["mu"] == 0.4
    assert png.stat().st_size > 1000


def test_rosenbrock_method(tmp_path):
    # issue 12: the stiff integrator from the CLI, with the nonlinear contact
    r = _run(["--mu", "0.4", "--sro", "sine", "--contact", "nonlinear", "--duration", "0.005", "--fs", "20000",
              "--method", "rosenbrock", "--json"])
    assert r.exit_code == 0, r.output + r.stderr
    s = json.loads(r.stdout)
    assert s["status"] == "completed" and s["method"] == "rosenbrock" and s["steps"] > 0


def test_text_output_smooth_with_preset_and_set(tmp_path):
    r = _run(["--preset", "lv2013", "--set", "c1=100", "--sro", "none", "--perturbation", "1e-9",
              "--duration", "0.005", "--plot", str(tmp_path / "fig3.png")])
    assert r.exit_code == 0, r.output + r.stderr
    assert r.stdout.startswith("status: completed")


def test_file_and_random_profiles(tmp_path):
    x = np.linspace(0, 1e-3, 201)
    f = tmp_path / "p.txt"
    np.savetxt(f, np.column_stack([x, 1e-5 * np.sin(2 * np.pi * x / 1e-3)]))
    r = _run(["--sro", "file", "--sro-file", str(f), "--duration", "0.01", "--json"])
    assert r.exit_code == 0, r.output + r.stderr
    r = _run(["--sro", "random", "--sro-amplitude", "1e-6", "--seed", "3", "--duration", "0.005", "--json",
              "--contact", "nonlinear"])
    assert r.exit_code == 0, r.output + r.stderr
    assert "tanh" in json.loads(r.stdout)["contact"]


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["--duration", "-1"], "duration"),
        (["--sro", "wobbly"], "wobbly"),
        (["--sro", "file", "--sro-file", "/nonexistent/p.csv"], "does not exist"),
        (["--sro", "file"], "--sro-file"),
        (["--fs", "0"], "fs"),
        (["--out", "x.txt"], "--out"),
        (["--sro-wavelength", "-1"], "wavelength"),
    ],
)
def test_bad_input_exit_2_one_line(args, needle):
    r = _run([*args, "--duration", "0.001"] if "--duration" not in args else args)
    assert r.exit_code == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0], r.stderr


def test_output_rate_below_the_fastest_mode_is_one_warning_line(tmp_path):
    # issue #15: --fs 1000 sampled the 2.4 kHz squeal aliased without a word
    r = _run(["--duration", "0.002", "--fs", "1000", "--json"])
    assert r.exit_code == 0, r.stderr
    lines = [x for x in r.stderr.splitlines() if "sampled, not filtered" in x]
    assert len(lines) == 1 and lines[0].startswith("squealkit: warning: fs=1000 Hz")


def test_streamed_out_gives_the_in_memory_summary(tmp_path):
    # --out streams the run into the file; the summary read back from it is the in-memory one
    a = _run(["--duration", "0.01", "--json", "--out", str(tmp_path / "r.nc")])
    b = _run(["--duration", "0.01", "--json"])
    assert a.exit_code == 0 and b.exit_code == 0, a.stderr + b.stderr
    assert json.loads(a.stdout) == json.loads(b.stdout)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.nc"]


def test_synth_squeal_above_half_the_sample_rate_is_one_line(tmp_path):
    from squealkit.cli.main import cli

    r = CliRunner().invoke(cli, ["synth", "--out", str(tmp_path / "r.nc"), "--fs", "1000", "--duration", "0.1"])
    assert r.exit_code == 2 and "fs/2 = 500 Hz" in r.stderr and len(r.stderr.strip().splitlines()) == 1
    assert list(tmp_path.iterdir()) == []

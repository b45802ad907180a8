"""The one step runner every staged report goes through (``squealkit.report.runner.run_report``).

The paper's report and the FE report each had their own copy of the loop (progress, figures/ and
data/, sections, staging); both now hand their steps to ``run_report``. These tests check the loop
once with steps that take no time, and check that both reports are interrupted and terminated in the
same way: the output folder holds a complete report or is as it was, and no staging file is left.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import pytest
import xarray as xr
from click.testing import CliRunner

from squealkit.io import MANIFEST, save_dataset
from squealkit.report.document import FigureRef, Section
from squealkit.report.runner import REPORT_FILES, ReportStep, run_report

SQUEALKIT = [sys.executable, "-c", "from squealkit.cli.main import main; main()"]


def _figure_step(figures, data):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from squealkit.io import save_figure
    from squealkit.report.steps_stability import FIGURE_FORMATS

    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])
    for fmt in FIGURE_FORMATS.get():  # the formats the run asks for (PNG alone for a preview)
        save_figure(fig, figures / f"line.{fmt}")
    plt.close(fig)
    save_dataset(xr.Dataset({"x": ("i", [1.0, 2.0, 3.0])}), data / "numbers.nc")
    return Section("one", "One", ("first",), figures=(FigureRef("line", "a line"),), data=("numbers.nc",),
                   numbers={"x": 1.0})


def _two_sections(figures, data):
    return [Section("two", "Two", ("second",)), Section("three", "Three", ("third",), numbers={"y": 2.0})]


STEPS = [ReportStep("figure", _figure_step), ReportStep("pair", _two_sections)]


@pytest.mark.parametrize(("quick", "suffixes"), [(True, [".png"]), (False, [".png", ".svg"])])
def test_steps_run_in_order_into_one_complete_folder(tmp_path, quick, suffixes):
    calls = []
    result = run_report(tmp_path / "out", STEPS, title="T", subtitle="S", quick=quick,
                        progress=lambda *a: calls.append(a),
                        closing=lambda sections: Section("end", f"After {len(sections)}", ()))
    # before each step, and once at the end (the closing section is not a step)
    assert calls == [(0, 2, "figure"), (1, 2, "pair"), (2, 2, "report")]
    assert [s.key for s in result.sections] == ["one", "two", "three", "end"]
    assert result.sections[-1].title == "After 3"  # the closing section sees every step's sections
    assert result.numbers() == {"one": {"x": 1.0}, "two": {}, "three": {"y": 2.0}, "end": {}}
    out = tmp_path / "out"
    assert sorted(p.name for p in out.iterdir()) == sorted([MANIFEST, *REPORT_FILES])
    assert sorted(p.name for p in (out / "figures").iterdir()) == sorted(f"line{s}" for s in suffixes)
    listed = json.loads((out / MANIFEST).read_text())["files"]
    assert sorted(listed) == sorted(["report.html", "data/numbers.nc", *(f"figures/line{s}" for s in suffixes)])
    html = result.report.read_text()
    assert "<h1>T</h1>" in html and "After 3" in html and "data/numbers.nc" in html
    assert oct(result.report.stat().st_mode & 0o777) == oct(0o666 & ~_umask())  # as a plain write would be
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]  # no staging left


def _umask() -> int:
    old = os.umask(0)
    os.umask(old)
    return old


@pytest.mark.parametrize("fail_at", ["step", "closing", "progress"])
def test_a_failed_or_interrupted_run_leaves_the_folder_as_it_was(tmp_path, fail_at):
    out = tmp_path / "out"
    out.mkdir()
    (out / "report.html").write_text("previous good report")
    (out / MANIFEST).write_text('{"files": ["report.html"]}')  # squealkit wrote it

    def bad_step(figures, data):
        (figures / "half.png").write_bytes(b"half")
        raise RuntimeError("step failed")

    def bad_closing(sections):
        raise KeyboardInterrupt

    def bad_progress(done, total, name):
        if name == "report":
            raise KeyboardInterrupt

    steps = [*STEPS, ReportStep("bad", bad_step)] if fail_at == "step" else STEPS
    with pytest.raises((RuntimeError, KeyboardInterrupt)):
        run_report(out, steps, title="T", quick=True, closing=bad_closing if fail_at == "closing" else None,
                   progress=bad_progress if fail_at == "progress" else None)
    assert sorted(p.name for p in out.iterdir()) == [MANIFEST, "report.html"]
    assert (out / "report.html").read_text() == "previous good report"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_a_foreign_folder_is_refused_before_any_step(tmp_path):
    from squealkit import InputError

    (tmp_path / "mine.txt").write_text("the user's")
    ran = []
    with pytest.raises(InputError):
        run_report(tmp_path, [ReportStep("s", lambda f, d: ran.append(1))], title="T")
    assert ran == [] and sorted(p.name for p in tmp_path.iterdir()) == ["mine.txt"]


@pytest.mark.parametrize(("quick", "kinds"), [(True, "PNG"), (False, "PNG and SVG")])
def test_cli_names_the_kinds_of_file_it_wrote(tmp_path, monkeypatch, quick, kinds):
    # `squealkit reproduce --quick` said "(PNG and SVG)" though a preview draws PNG only
    import squealkit.report
    from squealkit.cli.main import cli

    def fake_reproduce(out_dir, *, quick, progress, force, **kw):
        return run_report(out_dir, STEPS, title="T", quick=quick, progress=progress, force=force)

    monkeypatch.setattr(squealkit.report, "reproduce", fake_reproduce)
    r = CliRunner().invoke(cli, ["reproduce", "--out-dir", str(tmp_path / "rep"), *(["--quick"] if quick else [])])
    assert r.exit_code == 0, (r.output, r.exception)
    assert f"figures: {tmp_path / 'rep' / 'figures'} ({kinds}); data: {tmp_path / 'rep' / 'data'} (netCDF)" in r.output


@pytest.fixture(scope="module")
def small_brake(tmp_path_factory):
    """The built-in FE brake at its smallest (8 elements around), written as a model file with a [report] table."""
    from squealkit.fe.demo import build_fe_demo, write_fe_demo

    toml = write_fe_demo(build_fe_demo(n_theta=8, n_r=2), tmp_path_factory.mktemp("brake") / "brake")
    report = toml.parent / "report.toml"
    report.write_text(toml.read_text() + '\n[report]\nrpm = 1000\nmu = 0.6\neigen_band = ["9 kHz", "20 kHz"]\n'
                      'method = "pod"\nmu_sweep = [0.0, 0.8, 3]\nrpm_sweep = [500, 1000, 2]\nmax_views = 1\n'
                      "n_frames = 4\n")
    return report


def test_the_fe_report_is_interrupted_as_the_papers_is(tmp_path, small_brake):
    # tests/test_report.py::test_interrupted_run_leaves_nothing_half_written does this for the paper's report
    from squealkit.models import load_model
    from squealkit.report.fe_modes import fe_report

    out = tmp_path / "report"
    out.mkdir()
    (out / "report.html").write_text("previous good report")
    (out / MANIFEST).write_text('{"files": ["report.html"]}')
    seen = []

    def interrupt(done, total, name):
        seen.append((done, total, name))
        if done == 1:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        fe_report(out, load_model(small_brake), config=small_brake, quick=True, progress=interrupt)
    assert seen == [(0, 3, "FE model"), (1, 3, "unstable modes")]
    assert (out / "report.html").read_text() == "previous good report"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report"]


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["paper", "fe"])
def test_sigterm_during_a_report_leaves_no_partial_file(tmp_path, small_brake, kind):
    args = (["reproduce", "--quick"] if kind == "paper" else ["report", "--config", str(small_brake), "--quick"])
    p = subprocess.Popen([*SQUEALKIT, *args, "--out-dir", "rep", "--json"], stdout=subprocess.DEVNULL,
                         stderr=subprocess.PIPE, text=True, cwd=tmp_path)
    deadline = time.monotonic() + 300  # a loaded machine starts slowly
    while not any(n.startswith(".rep.") for n in os.listdir(tmp_path)):  # the staging folder: a step runs
        if p.poll() is not None:
            pytest.fail(f"finished before the signal: {p.stderr.read()}")
        if time.monotonic() > deadline:
            p.kill()
            pytest.fail("the staging folder never appeared")
        time.sleep(0.05)
    p.send_signal(signal.SIGTERM)
    err = p.communicate(timeout=120)[1]
    assert p.returncode == 143, err
    assert "Traceback" not in err
    assert os.listdir(tmp_path) == []

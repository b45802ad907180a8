"""Campaigns: a SYNTHETIC J2521-like test matrix recovered by ``squealkit campaign``.

Truth comes from :func:`squealkit.campaign.synthetic_campaign` (squeal lines by rules on the
conditions, every fifth application with a 1.6 kHz tone below the component band, decelerating
stops with a tacho). Done when (issue 14): occurrence within 1 percentage point of truth per
band, no events outside the setup's band, the run-out link right with a tacho at varying speed.
"""

import json

import duckdb
import numpy as np
import pytest
from click.testing import CliRunner

from squealkit.campaign import read_matrix, run_campaign, synthetic_campaign, third_octave_bands
from squealkit.cli.main import cli


def run(args):
    return CliRunner().invoke(cli, args)


KW = dict(mic="mic", displacement="displacement", radius=0.05, tacho="tacho")


@pytest.fixture(scope="module")
def camp(tmp_path_factory):
    d = tmp_path_factory.mktemp("camp")
    truth = synthetic_campaign(d, n_applications=40, duration=1.5, seed=3, suffix=".mf4")
    # a 41st application whose recording was cut short: it fails, the 40 others are the campaign
    b = (d / "recordings" / "A0001.mf4").read_bytes()
    (d / "recordings" / "cut.mf4").write_bytes(b[: len(b) // 3])
    with open(d / "matrix.csv", "a") as fh:
        fh.write("A0041,recordings/cut.mf4,S8,drag,10.0,100.0,50.0\n")
    res = run(["campaign", str(d / "matrix.csv"), "--out-dir", str(d / "out"), "--mic", "mic", "--displacement",
               "displacement", "--radius", "0.05", "--tacho", "tacho", "--json"])
    assert res.exit_code == 1, res.output  # 1: some application failed (issue #15)
    (d / "stderr.txt").write_text(res.stderr)
    return d, truth, json.loads(res.stdout)


def test_occurrence_per_band_within_one_point_of_truth(camp):
    _, truth, summary = camp
    assert set(summary) >= {"applications", "applications_with_squeal", "occurrence_percent", "by_band", "criteria"}
    assert summary["applications"] == 40 and "J2521 component" in summary["criteria"]
    assert summary["occurrence_percent"] == pytest.approx(truth["occurrence_percent"], abs=1.0)
    line_band = {float(f): next(b for b in summary["by_band"] if b["band_hz"][0] <= float(f) < b["band_hz"][1])
                 for f in truth["line_occurrence_percent"]}
    for f, occ in truth["line_occurrence_percent"].items():
        assert line_band[float(f)]["occurrence_percent"] == pytest.approx(occ, abs=1.0)
    others = [b for b in summary["by_band"] if b not in line_band.values()]
    assert all(b["occurrence_percent"] == 0.0 for b in others)
    assert summary["by_band"][0]["band_hz"] == pytest.approx([1778.3, 2238.7], abs=0.1)


def test_no_event_outside_the_setup_band_and_runout_link(camp):
    d, truth, _ = camp
    con = duckdb.connect(str(d / "out" / "campaign.duckdb"), read_only=True)
    lo, hi = con.execute("SELECT min(frequency_hz), max(frequency_hz) FROM events").fetchone()
    assert lo >= 2000.0 and hi <= 16000.0  # the 1.6 kHz tone of every fifth application never counts
    rows = con.execute("SELECT application, mode, runout_phase_deg, growth_slope_correlation FROM applications "
                       "WHERE squeal").fetchall()
    assert {r[1] for r in rows} == {"drag", "stop"}
    for app, _, phase, corr in rows:  # the squeal's place on the disc against the run-out, stops included
        err = (phase - truth["by_application"][app]["runout_phase_deg"] + 180) % 360 - 180
        assert abs(err) < 10.0 and corr > 0.5
    # the query, on the view that joins events and conditions
    q = con.execute("SELECT count(*) FROM squeal WHERE peak_dba > 75 AND frequency_hz BETWEEN 6000 AND 8000 "
                    "AND temperature_c < 120").fetchone()[0]
    assert q == sum(6300.0 in a["lines_hz"] for a in truth["by_application"].values())


def test_report_and_figures(camp):
    d, _, _ = camp
    html = (d / "out" / "report.html").read_text()
    assert html.count("data:image/png;base64") == 5 and "SYNTHETIC" in html
    assert len(list((d / "out" / "figures").glob("*.png"))) == 5


def test_a_failed_application_is_in_every_output(camp):
    # issue #15: the cut recording is named in summary.json, the database, the report and on stderr
    d, _, summary = camp
    cut = str(d / "recordings" / "cut.mf4")
    assert [(f["application"], f["file"]) for f in summary["failed"]] == [("A0041", cut)]
    error = summary["failed"][0]["error"]
    assert error.startswith(f"Recording {cut!r}: ") and "truncated" in error
    con = duckdb.connect(str(d / "out" / "campaign.duckdb"), read_only=True)
    assert con.execute("SELECT application, error IS NOT NULL FROM applications WHERE status = 'failed'").fetchall() \
        == [("A0041", True)]
    assert con.execute("SELECT count(*) FROM applications WHERE status = 'ok'").fetchone()[0] == 40
    con.close()
    html = (d / "out" / "report.html").read_text()
    assert "Failed applications" in html and "cut.mf4" in html and "1 of 41 applications could not be analysed" in html
    tail = (d / "stderr.txt").read_text().strip().splitlines()[-2:]
    assert "1 of 41 applications failed" in tail[0] and tail[1].startswith(f"A0041 ({cut}): Recording")


def test_killed_run_resumes_and_rerun_updates(tmp_path):
    truth = synthetic_campaign(tmp_path, n_applications=8, duration=1.0, seed=5)

    class Killed(Exception):
        pass

    def kill_after_three(done, total):
        if done == 3:
            raise Killed

    with pytest.raises(Killed):
        run_campaign(tmp_path / "matrix.csv", tmp_path / "out", progress=kill_after_three, report=False, **KW)
    con = duckdb.connect(str(tmp_path / "out" / "campaign.duckdb"), read_only=True)
    # killed while the third finished: the first two were committed as they finished
    assert con.execute("SELECT count(*) FROM applications").fetchone()[0] == 2
    con.close()
    s = run_campaign(tmp_path / "matrix.csv", tmp_path / "out", report=False, **KW)
    assert s["analysed_now"] == 6 and s["applications"] == 8
    assert s["occurrence_percent"] == pytest.approx(truth["occurrence_percent"])
    # a changed recording is analysed again; the others are kept
    f = read_matrix(tmp_path / "matrix.csv")[2].file
    f.write_bytes(f.read_bytes())
    import os

    os.utime(f, ns=(f.stat().st_atime_ns, f.stat().st_mtime_ns + 10**9))
    s = run_campaign(tmp_path / "matrix.csv", tmp_path / "out", report=False, **KW)
    assert s["analysed_now"] == 1 and s["applications"] == 8
    # other criteria: everything again
    s = run_campaign(tmp_path / "matrix.csv", tmp_path / "out", report=False, setup="corner", **KW)
    assert s["analysed_now"] == 8 and "corner" in s["criteria"]


def test_missing_recording_is_a_failed_application_not_a_crash(tmp_path):
    synthetic_campaign(tmp_path, n_applications=3, duration=0.5, seed=1)
    (tmp_path / "recordings" / "A0002.nc").unlink()
    s = run_campaign(tmp_path / "matrix.csv", tmp_path / "out", report=False, **KW)
    assert s["applications"] == 2 and [f["application"] for f in s["failed"]] == ["A0002"]


def test_no_application_analysed_has_no_occurrence(tmp_path):
    # nothing analysed: an occurrence of 0 % would read as "no squeal"; it is unknown (null)
    synthetic_campaign(tmp_path, n_applications=2, duration=0.5, seed=1)
    for f in (tmp_path / "recordings").glob("*.nc"):
        f.unlink()
    res = run(["campaign", str(tmp_path / "matrix.csv"), "--out-dir", str(tmp_path / "out"), "--mic", "mic",
               "--displacement", "displacement", "--radius", "0.05", "--rpm", "900"])
    assert res.exit_code == 1 and "no application could be analysed (2 failed)" in res.output
    s = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert s["applications"] == 0 and s["occurrence_percent"] is None
    assert all(b["occurrence_percent"] is None for b in s["by_band"])
    assert (tmp_path / "out" / "report.html").is_file()


@pytest.mark.parametrize(("text", "match"), [
    ("file\na.nc\n", "application"),
    ("application,file\nA,a.nc\nA,b.nc\n", "twice"),
    ("application,file,mode\nA,a.nc,coast\n", "drag"),
    ("application,file,temperature_c\nA,a.nc,hot\n", "number"),
])
def test_bad_matrix_exit_2(tmp_path, text, match):
    (tmp_path / "m.csv").write_text(text)
    res = run(["campaign", str(tmp_path / "m.csv"), "--out-dir", str(tmp_path / "o"), "--mic", "mic",
               "--displacement", "displacement", "--radius", "0.05", "--rpm", "900"])
    assert res.exit_code == 2 and match in res.output


def test_third_octave_bands_are_iec_base_ten():
    b = third_octave_bands((1250.0, 16000.0))
    assert len(b) == 12 and b[0][0] == pytest.approx(1258.9, abs=0.1) and b[-1][0] == pytest.approx(15848.9, abs=0.1)
    assert np.allclose([hi / lo for _, lo, hi in b], 10**0.1)


def test_campaign_on_a_local_dask_cluster(tmp_path):
    truth = synthetic_campaign(tmp_path, n_applications=4, duration=0.5, seed=2)
    res = run(["campaign", str(tmp_path / "matrix.csv"), "--out-dir", str(tmp_path / "out"), "--mic", "mic",
               "--displacement", "displacement", "--radius", "0.05", "--tacho", "tacho", "--scheduler", "local",
               "--json", "--no-report"])
    assert res.exit_code == 0, res.output
    assert json.loads(res.output)["occurrence_percent"] == pytest.approx(truth["occurrence_percent"])


@pytest.mark.skipif(__import__("shutil").which("chromium") is None, reason="Debian's chromium is not installed")
def test_campaign_report_loads_in_headless_chromium(camp):
    from test_report import _chromium_body

    body = _chromium_body(camp[0] / "out" / "report.html")
    assert 'data-figures="5"' in body and 'data-figures-loaded="5"' in body


def test_conditions_taken_from_channels(tmp_path):
    truth = synthetic_campaign(tmp_path, n_applications=4, duration=0.5, seed=4, condition_channels=True,
                               suffix=".tdms")
    assert np.isnan(read_matrix(tmp_path / "matrix.csv")[0].temperature_c)  # not in the matrix
    res = run(["campaign", str(tmp_path / "matrix.csv"), "--out-dir", str(tmp_path / "out"), "--mic", "mic",
               "--displacement", "displacement", "--radius", "0.05", "--tacho", "tacho", "--no-report",
               "--pressure-channel", "pressure", "--temperature-channel", "temperature", "--json"])
    assert res.exit_code == 0, res.output
    con = duckdb.connect(str(tmp_path / "out" / "campaign.duckdb"), read_only=True)
    for app, p, t in con.execute("SELECT application, pressure_bar, temperature_c FROM applications").fetchall():
        assert p == pytest.approx(truth["by_application"][app]["pressure_bar"], abs=0.01)
        assert t == pytest.approx(truth["by_application"][app]["temperature_c"], abs=0.05)


def test_unreadable_files_are_reported_and_the_rest_analysed(tmp_path, monkeypatch):
    """Issue #15: a campaign went on only past missing files; any file that cannot be analysed (here a
    truncated one and one whose analysis raises an unexpected error) is now a failed application,
    listed in the database, summary.json and on stderr (the report: test_a_failed_application_...);
    exit code 1."""
    import squealkit.measurement as measurement

    truth = synthetic_campaign(tmp_path, n_applications=3, duration=0.5, seed=1)
    rec = tmp_path / "recordings"
    b = (rec / "A0002.nc").read_bytes()
    (rec / "A0002.nc").write_bytes(b[: len(b) // 2])
    real = measurement.analyze_recording

    def flaky(path, **kw):  # a fault of no known kind must not stop the campaign either
        if str(path).endswith("A0003.nc"):
            raise RuntimeError("something unforeseen")
        return real(path, **kw)

    monkeypatch.setattr(measurement, "analyze_recording", flaky)
    args = ["campaign", str(tmp_path / "matrix.csv"), "--out-dir", str(tmp_path / "out"), "--mic", "mic",
            "--displacement", "displacement", "--radius", "0.05", "--tacho", "tacho", "--no-report"]
    res = run(args)
    assert res.exit_code == 1 and isinstance(res.exception, SystemExit | None), res.output
    bad = ["A0002", "A0003"]
    tail = res.stderr.strip().splitlines()[-3:]
    assert "2 of 3 applications failed" in tail[0] and [ln.split()[0] for ln in tail[1:]] == bad, res.stderr
    assert "A0002.nc" in tail[1] and "truncated" in tail[1] and "RuntimeError: something unforeseen" in tail[2]
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert [f["application"] for f in summary["failed"]] == bad and summary["applications"] == 1
    assert summary["failed"][0]["file"] == str(rec / "A0002.nc") and "Recording" in summary["failed"][0]["error"]
    ok = [a for a in truth["by_application"] if a not in bad]
    assert summary["applications_with_squeal"] == sum(bool(truth["by_application"][a]["lines_hz"]) for a in ok)
    con = duckdb.connect(str(tmp_path / "out" / "campaign.duckdb"), read_only=True)
    rows = con.execute("SELECT application, status FROM applications ORDER BY application").fetchall()
    con.close()
    assert rows == [(a, "failed" if a in bad else "ok") for a in sorted(truth["by_application"])]
    # a re-run retries the failed applications only (the others are unchanged): here they fail again
    res = run([*args, "--json"])
    assert res.exit_code == 1 and json.loads(res.stdout)["analysed_now"] == 2
    # taken out of the matrix, they no longer count nor fail (their rows stay in the database)
    m = tmp_path / "matrix.csv"
    m.write_text("".join(ln for ln in m.read_text().splitlines(keepends=True) if not ln.startswith(tuple(bad))))
    res = run([*args, "--json"])
    s = json.loads(res.stdout)
    assert res.exit_code == 0 and s["failed"] == [] and s["applications"] == 1 and s["analysed_now"] == 0

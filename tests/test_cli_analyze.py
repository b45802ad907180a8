"""``squealkit analyze`` and ``squealkit synth`` driven in-process with click's CliRunner."""

import json

import numpy as np
import pytest
from click.testing import CliRunner

from squealkit.cli.main import cli

ARGS = ["--mic", "mic", "--displacement", "displacement", "--rpm", "900", "--radius", "0.05"]


def invoke(args):
    r = CliRunner()
    return r.invoke(cli, args, prog_name="squealkit")


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("rec")
    for name, mode in (("rising", "rising"), ("quiet", "none")):
        res = invoke(["synth", "--out", str(d / f"{name}.nc"), "--seed", "1", "--duration", "1", "--squeal-on", mode])
        assert res.exit_code == 0, res.output
    return d


def test_synth_reports_truth(tmp_path):
    res = invoke(["synth", "--out", str(tmp_path / "r.nc"), "--duration", "0.5", "--json"])
    assert res.exit_code == 0
    out = json.loads(res.output)
    assert out["synthetic"] is True and out["truth"]["frequency_hz"] == 2388.0


def test_analyze_json_one_file(files):
    res = invoke(["analyze", str(files / "rising.nc"), *ARGS, "--json"])
    assert res.exit_code == 0, res.output
    out = json.loads(res.output)
    assert out["synthetic"] is True
    assert abs(out["squeal_frequency_hz"] - 2388.0) < 2.0
    assert out["rising_fraction"] > 0.8
    assert len(out["events"]) == 1  # Fast (125 ms): the bursts of each revolution are one noise
    assert out["criteria"]["setup"] == "component" and out["criteria"]["band_hz"] == [2000.0, 16000.0]
    assert set(out["events"][0]) >= {"start_s", "end_s", "frequency_hz", "peak_dba"}


def test_analyze_json_silence_has_nulls(files):
    res = invoke(["analyze", str(files / "quiet.nc"), *ARGS, "--json"])
    out = json.loads(res.output)
    assert out["squeal_frequency_hz"] is None and out["rising_fraction"] is None and out["events"] == []


def test_analyze_text_says_synthetic(files):
    res = invoke(["analyze", str(files / "rising.nc"), *ARGS])
    assert res.exit_code == 0 and "[SYNTHETIC]" in res.output and "rising_fraction" in res.output


def test_campaign_summary_csv(files, tmp_path):
    out = tmp_path / "campaign.csv"
    res = invoke(["analyze", str(files / "rising.nc"), str(files / "quiet.nc"), *ARGS, "--summary", str(out)])
    assert res.exit_code == 0, res.output
    assert "50.0% of 2 recordings" in res.output
    text = out.read_text()
    assert "occurrence_percent=50" in text
    rows = [ln for ln in text.splitlines() if not ln.startswith("#")]
    assert rows[0].startswith("recording,") and len(rows) == 3


def test_a_bad_recording_does_not_stop_the_others(files, tmp_path):
    bad = tmp_path / "broken.nc"
    bad.write_bytes(b"not a netCDF file")
    res = invoke(["analyze", str(files / "rising.nc"), str(bad), str(files / "quiet.nc"), *ARGS, "--json"])
    assert res.exit_code == 1
    out = json.loads(res.stdout)
    assert len(out["recordings"]) == 2 and out["occurrence_percent"] == 50.0
    assert [f["recording"] for f in out["failed"]] == [str(bad)] and "broken.nc" in out["failed"][0]["error"]
    assert "1 of 3 recordings could not be analysed" in res.stderr
    res = invoke(["analyze", str(bad), str(bad), *ARGS])  # none: exit 2 with one line
    assert res.exit_code == 2 and "None of the 2 recordings could be analysed" in res.output


def test_plots_written(files, tmp_path):
    res = invoke(["analyze", str(files / "rising.nc"), *ARGS, "--plot", str(tmp_path / "figs")])
    assert res.exit_code == 0, res.output
    names = sorted(p.name for p in (tmp_path / "figs").iterdir())
    assert "rising_polar.png" in names and "rising_spectrogram.png" in names and len(names) == 8
    assert "rising_event_phase.png" in names  # the run-out phase of each event (issue #14)


def test_csv_without_time_column_with_fs(tmp_path):
    rng = np.random.default_rng(0)
    f = tmp_path / "rec.csv"
    rows = rng.standard_normal((2000, 2)) * [0.01, 1e-6]
    f.write_text("p,q\n" + "\n".join(f"{a:.6g},{b:.6g}" for a, b in rows) + "\n")
    res = invoke(["analyze", str(f), "--mic", "0", "--displacement", "q", "--rpm", "900", "--radius", "0.05",
                  "--fs", "40000", "--json"])
    assert res.exit_code == 0, res.output
    assert json.loads(res.output)["events"] == []


def test_tdms_through_cli(tmp_path):
    from nptdms import ChannelObject, TdmsWriter

    from squealkit.measurement import synthetic_recording

    rec = synthetic_recording(duration=0.5, seed=1)
    f = tmp_path / "rec.tdms"
    props = {"wf_increment": 1 / 40000.0}
    with TdmsWriter(f) as w:
        w.write_segment([ChannelObject("rig", "Mic", rec["mic"].values, properties=props),
                         ChannelObject("rig", "Probe", rec["displacement"].values, properties=props)])
    res = invoke(["analyze", str(f), "--mic", "Mic", "--displacement", "rig/Probe", "--rpm", "900",
                  "--radius", "0.05", "--json"])
    assert res.exit_code == 0, res.output
    assert abs(json.loads(res.output)["squeal_frequency_hz"] - 2388.0) < 3.0


@pytest.mark.parametrize(("extra", "match"), [
    (["--rpm", "0"], "rpm"),
    (["--radius", "-2"], "radius"),
    (["--mic", "nope"], "'nope' is not in"),
    (["--band", "2000"], "--band"),
    (["--band", "5000:3000"], "lower < upper"),
    (["--band", "2000:30000"], "fs/2"),
    (["--setup", "axle"], "axle"),
    (["--tacho", "nope"], "'nope' is not in"),
    (["--polarity", "2"], "polarity"),
    (["--summary", "x.txt"], "--summary"),
])
def test_bad_options_exit_2_with_one_line(files, extra, match):
    res = invoke(["analyze", str(files / "rising.nc"), *ARGS, *extra])
    assert res.exit_code == 2
    lines = [ln for ln in res.output.strip().splitlines() if ln]
    assert len(lines) == 1 and match in lines[0] and "Traceback" not in res.output


@pytest.mark.parametrize(("name", "content", "match"), [
    ("missing.csv", None, "does not exist"),
    ("empty.csv", "", "empty"),
    ("nan.csv", "time,mic,displacement\n" + "".join(f"{i / 40000},{'nan' if i == 700 else 0.1},0\n"
                                                      for i in range(2000)), "non-finite"),
    ("junk.wav", "garbage", "could not be read"),
    ("one.csv", "time\n0\n1\n", "no data channel"),
])
def test_bad_files_exit_2(tmp_path, name, content, match):
    f = tmp_path / name
    if content is not None:
        f.write_text(content)
    res = invoke(["analyze", str(f), *ARGS])
    assert res.exit_code == 2
    assert match in res.output and len(res.output.strip().splitlines()) == 1


def test_wav_with_scale_and_unit_and_out(tmp_path):
    from scipy.io import wavfile

    from squealkit.io import load_dataset
    from squealkit.measurement import synthetic_recording

    rec = synthetic_recording(duration=0.5, seed=1)
    f = tmp_path / "rec.wav"
    # float WAV: full scale 1.0 = 20 Pa on ch0 and 100 um on ch1
    data = np.column_stack([rec["mic"].values / 20.0, rec["displacement"].values / 1e-4]).astype(np.float32)
    wavfile.write(f, 40000, data)
    out = tmp_path / "res.nc"
    res = invoke(["analyze", str(f), "--mic", "ch0", "--displacement", "1", "--rpm", "900", "--radius", "0.05",
                  "--scale", "ch0=20", "--scale", "ch1=1e-4", "--unit", "ch0=Pa", "--out", str(out), "--json"])
    assert res.exit_code == 0, res.output
    assert abs(json.loads(res.output)["squeal_frequency_hz"] - 2388.0) < 3.0
    assert load_dataset(out)["event_start"].size == len(json.loads(res.output)["events"])


def test_decelerating_stop_with_tacho_and_probe_settings(tmp_path):
    path = tmp_path / "stop.nc"
    res = invoke(["synth", "--out", str(path), "--duration", "2", "--rpm-end", "300", "--probe-offset-deg", "10",
                  "--polarity", "-1"])
    assert res.exit_code == 0, res.output
    args = ["analyze", str(path), "--mic", "mic", "--displacement", "displacement", "--radius", "0.05",
            "--tacho", "tacho", "--probe-offset-deg", "10", "--polarity", "-1", "--json"]
    out = json.loads(invoke(args).output)
    assert out["runout"]["n_revolutions"] == 20 and out["growth_slope_correlation"] > 0.5
    assert out["rising_fraction"] > 0.85
    res = invoke(["analyze", str(path), "--mic", "mic", "--displacement", "displacement", "--radius", "0.05"])
    assert res.exit_code == 2 and "--rpm" in res.output


@pytest.mark.parametrize("suffix", [".wav", ".tdms", ".mf4", ".uff"])
def test_synth_writes_every_daq_format_and_analyze_reads_it(tmp_path, suffix):
    path = tmp_path / f"r{suffix}"
    assert invoke(["synth", "--out", str(path), "--duration", "1"]).exit_code == 0
    mic, disp = ("0", "1") if suffix == ".wav" else ("mic", "displacement")
    res = invoke(["analyze", str(path), "--mic", mic, "--displacement", disp, "--rpm", "900", "--radius", "0.05",
                  "--json"])
    assert res.exit_code == 0, res.output
    assert abs(json.loads(res.output)["squeal_frequency_hz"] - 2388.0) < 0.1


def test_setup_corner_and_user_band_named_in_text(files):
    res = invoke(["analyze", str(files / "rising.nc"), *ARGS, "--setup", "corner"])
    assert res.exit_code == 0 and "SAE J2521 corner" in res.output and "1250-16000 Hz" in res.output
    res = invoke(["analyze", str(files / "rising.nc"), *ARGS, "--band", "1000:5000", "--json"])
    crit = json.loads(res.output)["criteria"]
    assert crit["setup"] == "user" and crit["band_hz"] == [1000.0, 5000.0] and "user band" in crit["name"]


def test_white_noise_is_not_squeal_from_the_cli(tmp_path):
    # issue #15: white noise at 10 Pa RMS was "squeal 3164.6 Hz, 2305 events"; now tonality is required
    # (tone-to-noise ratio >= 8 dB, ECMA-418-1), and --min-tnr-db sets it (-100: any peak, the old reading)
    import xarray as xr

    rng = np.random.default_rng(0)
    n = 24000
    rec = xr.Dataset({"mic": ("time", 10 * rng.standard_normal(n), {"units": "Pa"}),
                      "displacement": ("time", 1e-6 * rng.standard_normal(n), {"units": "m"})}, attrs={"fs": 48000.0})
    f = tmp_path / "noise.nc"
    rec.to_netcdf(f, engine="h5netcdf")
    out = json.loads(invoke(["analyze", str(f), *ARGS, "--json"]).output)
    assert out["squeal"] is False and out["peak_dba"] > 100 and out["settings"]["min_tnr_db"] == 8.0
    old = json.loads(invoke(["analyze", str(f), *ARGS, "--json", "--min-tnr-db", "-100"]).output)
    assert old["squeal"] is True and old["n_events"] > 50
    bad = invoke(["analyze", str(f), *ARGS, "--min-tnr-db", "nan"])
    assert bad.exit_code == 2 and "min_tnr_db" in bad.output and "Traceback" not in bad.output

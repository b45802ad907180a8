"""Each reader on files the tests write, and bad files rejected with a clear message."""

import numpy as np
import pytest
import xarray as xr
from scipy.io import wavfile

from squealkit import InputError
from squealkit.measurement import open_recording, read_recording, recording_dataset

FS = 40000.0
N = 4000


@pytest.fixture
def signals():
    rng = np.random.default_rng(3)
    return rng.standard_normal(N) * 0.5, rng.standard_normal(N) * 1e-6


def _write_csv(path, header, rows):
    path.write_text(header + "\n" + "\n".join(",".join(f"{v:.10g}" for v in r) for r in rows) + "\n")


def test_csv_with_time_column(tmp_path, signals):
    p, q = signals
    f = tmp_path / "rec.csv"
    _write_csv(f, "time [s],mic [Pa],probe [m]", np.column_stack([np.arange(N) / FS, p, q]))
    ds = read_recording(f)
    assert ds.attrs["fs"] == pytest.approx(FS)
    assert ds["mic"].attrs["units"] == "Pa" and ds["probe"].attrs["units"] == "m"
    assert np.allclose(ds["mic"], p, rtol=1e-9) and np.allclose(ds["probe"], q, rtol=1e-9)


def test_csv_without_time_needs_fs(tmp_path, signals):
    p, q = signals
    f = tmp_path / "rec.csv"
    _write_csv(f, "mic,probe", np.column_stack([p, q]))
    with pytest.raises(InputError, match="fs"):
        open_recording(f)
    src = open_recording(f, fs=FS)
    assert src.n_samples == N and src.resolve(1) == "probe"
    ds = read_recording(f, channels=["1"], fs=FS)
    assert list(ds.data_vars) == ["probe"]


def test_csv_blocks_cover_the_file(tmp_path, signals):
    p, q = signals
    f = tmp_path / "rec.csv"
    _write_csv(f, "mic,probe", np.column_stack([p, q]))
    blocks = list(open_recording(f, fs=FS).iter_blocks(["mic"], block=1000))
    assert [s for s, _ in blocks] == [0, 1000, 2000, 3000]
    assert np.allclose(np.concatenate([b["mic"] for _, b in blocks]), p)


def test_wav_int16_with_scale(tmp_path, signals):
    p, q = signals
    f = tmp_path / "rec.wav"
    raw = np.column_stack([p / 4, q / 8e-6])
    wavfile.write(f, int(FS), np.round(raw * 32767).astype(np.int16))
    ds = read_recording(f, scale={"ch0": 4.0, "1": 8e-6}, units={"ch0": "Pa", "ch1": "m"})
    assert ds.attrs["fs"] == FS
    assert ds["ch0"].attrs["units"] == "Pa"
    # int PCM is read as a fraction of full scale (32768 for int16)
    assert np.allclose(ds["ch0"], p, rtol=1e-4, atol=2 * 4.0 / 32767)
    assert np.allclose(ds["ch1"], q, rtol=1e-4, atol=2 * 8e-6 / 32767)


def test_netcdf_written_by_xarray(tmp_path, signals):
    p, q = signals
    f = tmp_path / "rec.nc"
    recording_dataset({"mic": p, "disp": q}, FS, {"mic": "Pa", "disp": "m"}).to_netcdf(f, engine="h5netcdf")
    ds = read_recording(f, channels=["disp", "mic"])
    assert ds["disp"].attrs["units"] == "m"
    assert np.array_equal(ds["mic"].values, p)


def test_netcdf_channels_are_xarrays_data_variables(tmp_path, signals):
    # the reader lists variables without xarray: coordinates (the time index and one named in a
    # "coordinates" attribute) are not channels, and fs comes from the time coordinate
    p, q = signals
    f = tmp_path / "rec.nc"
    ds = recording_dataset({"mic": p, "disp": q}, FS, {"mic": "Pa", "disp": "m"})
    ds = ds.assign_coords(temperature=("time", np.full(N, 20.0)))
    ds.attrs = {}
    ds.to_netcdf(f, engine="h5netcdf")
    src = open_recording(f)
    with xr.open_dataset(f, engine="h5netcdf") as back:
        assert src.channels == tuple(back.data_vars) == ("mic", "disp")
    assert src.fs == pytest.approx(FS) and src.n_samples == N and src.units == {"mic": "Pa", "disp": "m"}


def test_tdms_written_by_nptdms(tmp_path, signals):
    from nptdms import ChannelObject, TdmsWriter

    p, q = signals
    f = tmp_path / "rec.tdms"
    props = {"wf_increment": 1 / FS}
    with TdmsWriter(f) as w:
        w.write_segment([ChannelObject("rig", "Mic", p, properties={**props, "unit_string": "Pa"}),
                         ChannelObject("rig", "Probe", q, properties={**props, "unit_string": "m"})])
    src = open_recording(f)
    assert src.fs == pytest.approx(FS)
    assert src.channels == ("rig/Mic", "rig/Probe")
    assert src.resolve("Probe") == "rig/Probe"
    ds = read_recording(f)
    assert ds["rig/Mic"].attrs["units"] == "Pa"
    assert np.array_equal(ds["rig/Probe"].values, q)


@pytest.mark.parametrize(
    ("name", "content", "match"),
    [
        ("empty.csv", "", "empty"),
        ("header_only.csv", "time,mic\n", "fewer than 2"),
        ("time_only.csv", "time\n0\n0.1\n0.2\n", "no data channel"),
        ("nan.csv", "time,mic\n0,1\n0.1,nan\n0.2,3\n", "non-finite"),
        ("text.csv", "time,mic\n0,1\n0.1,abc\n0.2,3\n", "non-numeric"),
        ("junk.tdms", "this is not tdms", "not a TDMS file"),
        ("junk.wav", "RIFF nonsense", "could not be read"),
        ("rec.xyz", "1,2", "unknown format"),
    ],
)
def test_bad_files_raise_input_error(tmp_path, name, content, match):
    f = tmp_path / name
    f.write_text(content)
    with pytest.raises(InputError, match=match):
        read_recording(f)


def test_missing_file_and_unknown_channel(tmp_path, signals):
    with pytest.raises(InputError, match="does not exist"):
        open_recording(tmp_path / "nope.csv")
    f = tmp_path / "rec.csv"
    _write_csv(f, "mic,probe", np.column_stack(signals))
    with pytest.raises(InputError, match="'accel' is not in"):
        open_recording(f, fs=FS).resolve("accel")
    with pytest.raises(InputError, match="fs"):
        open_recording(f, fs=-1)


# -- DAQ formats written by squealkit synth: each reads back sample for sample, labelled SYNTHETIC ------------
@pytest.mark.parametrize("suffix", [".wav", ".tdms", ".mf4", ".uff", ".csv"])
def test_every_synth_format_reads_back(tmp_path, suffix):
    from squealkit.measurement import synthetic_recording
    from squealkit.measurement.writers import write_recording

    rec = synthetic_recording(duration=0.5, seed=1, rpm_end=600.0)
    path = write_recording(rec, tmp_path / f"r{suffix}")
    src = open_recording(path)
    assert src.fs == pytest.approx(40000.0, rel=1e-9) and src.n_samples == 20000
    names = [src.resolve(c) for c in ("mic", "displacement", "tacho")] if suffix != ".wav" else list(src.channels)
    blocks = list(src.iter_blocks(names, block=3001))  # blocks not aligned with the file's own
    assert [b[0] for b in blocks] == list(range(0, 20000, 3001))
    for n, m in zip(names, ("mic", "displacement", "tacho"), strict=True):
        got = np.concatenate([b[1][n] for b in blocks])
        # float32 WAV; 8 significant digits in CSV; UFF 58 ASCII E13.5-like fields
        rel = {".wav": 1e-6, ".csv": 1e-7, ".uff": 1e-10}.get(suffix, 0.0)
        assert np.max(np.abs(got - rec[m].values)) <= rel * np.max(np.abs(rec[m].values))
    if suffix in (".tdms", ".mf4", ".uff"):
        assert src.synthetic and src.units[names[0]] == "Pa"


def test_mdf4_recording_analyses_like_the_dataset(tmp_path):
    from squealkit.measurement import analyze_recording, synthetic_recording
    from squealkit.measurement.writers import write_recording

    rec = synthetic_recording(duration=2.0, seed=1, rpm_end=300.0)
    path = write_recording(rec, tmp_path / "stop.mf4")
    kw = dict(mic="mic", displacement="displacement", radius=0.05, tacho="tacho")
    a, b = analyze_recording(rec, **kw), analyze_recording(path, **kw)
    assert a.rising_fraction == pytest.approx(b.rising_fraction, abs=1e-9)
    assert a.peak_dba == pytest.approx(b.peak_dba, abs=1e-9) and b.attrs["synthetic"]

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
    from squealkit.measurement.formats.writers import write_recording

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
    from squealkit.measurement.formats.writers import write_recording

    rec = synthetic_recording(duration=2.0, seed=1, rpm_end=300.0)
    path = write_recording(rec, tmp_path / "stop.mf4")
    kw = dict(mic="mic", displacement="displacement", radius=0.05, tacho="tacho")
    a, b = analyze_recording(rec, **kw), analyze_recording(path, **kw)
    assert a.rising_fraction == pytest.approx(b.rising_fraction, abs=1e-9)
    assert a.peak_dba == pytest.approx(b.peak_dba, abs=1e-9) and b.attrs["synthetic"]


# -- every reader x every fault: one line naming the file (and the channel / where), never a traceback ---------
# (issue #15, "Inputs that are wrong but accepted"). Each bad file is a good small file written by
# squealkit's own writers, then damaged the way the issue found them damaged.
FAULT_N, FAULT_FS = 1200, 1000.0


def _good(tmp_path, suffix, t=None, **extra):
    """A small good recording (mic, probe) in ``suffix``; ``t`` replaces the time axis where the format has one."""
    from squealkit.measurement.formats.writers import write_recording

    rng = np.random.default_rng(0)
    rec = recording_dataset({"mic": rng.standard_normal(FAULT_N), "probe": rng.standard_normal(FAULT_N)},
                            FAULT_FS, {"mic": "Pa", "probe": "m"})
    if t is not None:
        rec = rec.assign_coords(time=("time", t))
        if suffix == ".nc":
            rec.attrs = {}
    for name, values in extra.items():
        rec[name] = ("time", values)
    return write_recording(rec, tmp_path / f"rec{suffix}")


def _time_fault(kind):
    t = np.arange(FAULT_N) / FAULT_FS
    if kind == "back":  # a block runs backwards (the second half of the file, as a DAQ buffer replayed)
        t[700:] -= 0.3
    elif kind == "jump":  # a 5 s jump, beyond the first blocks
        t[900:] += 5.0
    elif kind == "repeat":  # a frozen clock: zero sample interval
        t[:] = 0.0
    return t


def _patch_bytes(path, old, new):
    b = path.read_bytes()
    assert old in b
    path.write_bytes(b.replace(old, new))
    return path


def _text_tdms(tmp_path):
    from nptdms import ChannelObject, TdmsWriter

    f = tmp_path / "rec.tdms"
    with TdmsWriter(f) as w:
        w.write_segment([ChannelObject("rig", "mic", np.zeros(FAULT_N), properties={"wf_increment": 1 / FAULT_FS}),
                         ChannelObject("rig", "note", np.array(["x"] * FAULT_N))])
    return f


def _text_mdf4(tmp_path):
    from asammdf import MDF, Signal

    t = np.arange(FAULT_N) / FAULT_FS
    f = tmp_path / "rec.mf4"
    with MDF(version="4.10") as m:
        m.append([Signal(np.zeros(FAULT_N), t, name="mic"),
                  Signal(np.array([b"x"] * FAULT_N), t, name="note", encoding="utf-8")])
        m.save(f, overwrite=True)
    return f


def _rate(tmp_path, suffix, value):
    """A file whose own sample rate (or interval) is ``value`` (0, negative, NaN)."""
    import struct

    f = _good(tmp_path, suffix)
    if suffix == ".wav":  # the header's sample rate field (bytes 24-27) and byte rate (28-31)
        b = bytearray(f.read_bytes())
        b[24:28] = struct.pack("<I", int(value))
        f.write_bytes(bytes(b))
    elif suffix == ".tdms":
        from nptdms import ChannelObject, TdmsWriter

        with TdmsWriter(f) as w:
            w.write_segment([ChannelObject("rig", "mic", np.zeros(FAULT_N), properties={"wf_increment": value})])
    elif suffix == ".uff":  # abscissa_inc, the 5th field of each record's 7th line
        f.write_text(f.read_text().replace("1.00000e-03", f"{value:.5e}"))
    elif suffix == ".nc":
        ds = recording_dataset({"mic": np.zeros(FAULT_N)}, FAULT_FS).drop_vars("time")
        ds.attrs["fs"] = value
        ds.to_netcdf(f, engine="h5netcdf")
    return f


def _corrupt_chunk(tmp_path):
    """A netCDF whose 3rd compressed chunk of 'probe' is overwritten with zeros."""
    import h5py

    f = tmp_path / "rec.nc"
    ds = recording_dataset({"mic": np.zeros(FAULT_N), "probe": np.sin(np.arange(FAULT_N))}, FAULT_FS)
    ds.to_netcdf(f, engine="h5netcdf", encoding={"probe": {"zlib": True, "chunksizes": (200,)}})
    with h5py.File(f, "r") as h:
        info = h["probe"].id.get_chunk_info(2)
    b = bytearray(f.read_bytes())
    b[info.byte_offset + 4:info.byte_offset + info.size] = bytes(info.size - 4)
    f.write_bytes(bytes(b))
    return f


def _truncated(tmp_path, suffix):
    f = _good(tmp_path, suffix)
    b = f.read_bytes()
    b = b[: int(len(b) * 0.6)]
    if suffix == ".csv":  # cut inside a row (a cut inside its last number, with all fields, cannot be told)
        b = b[: b.rfind(b"\n") + 1] + b"0.7"
    f.write_bytes(b)
    return f


FAULTS = [
    # (id, make(tmp_path) -> path, what the one line must say, channel it must name or None)
    *[(f"empty{s}", lambda tp, s=s: (tp / f"e{s}").write_bytes(b"") or tp / f"e{s}", "empty", None)
      for s in (".csv", ".wav", ".nc", ".tdms", ".mf4", ".uff")],
    *[(f"truncated{s}", lambda tp, s=s: _truncated(tp, s), "truncated", None)
      for s in (".csv", ".wav", ".nc", ".tdms", ".mf4", ".uff")],
    ("text.csv", lambda tp: _patch_bytes(_good(tp, ".csv"), b"\n0.7,", b"\n0.7,abc") and tp / "rec.csv",
     "non-numeric value", "mic"),
    ("text.nc", lambda tp: _good(tp, ".nc", note=np.array(["x"] * FAULT_N)), "not numeric", "note"),
    ("text.tdms", _text_tdms, "holds text", "rig/note"),
    ("text.mf4", _text_mdf4, "holds text", "note"),
    ("rate0.wav", lambda tp: _rate(tp, ".wav", 0), "0 Hz, not a finite number > 0", None),
    ("rate0.nc", lambda tp: _rate(tp, ".nc", 0.0), "0.0 Hz, not a finite number > 0", None),
    ("rate-nan.nc", lambda tp: _rate(tp, ".nc", np.nan), "nan Hz", None),
    ("interval0.tdms", lambda tp: _rate(tp, ".tdms", 0.0), "0.0 s, not a finite number > 0", None),
    ("interval-neg.tdms", lambda tp: _rate(tp, ".tdms", -1e-3), "-0.001 s", None),
    ("interval-inf.tdms", lambda tp: _rate(tp, ".tdms", np.inf), "inf s", None),
    ("interval0.uff", lambda tp: _rate(tp, ".uff", 0.0), "0.0 s, not a finite number > 0", None),
    *[(f"time-{k}{s}", lambda tp, s=s, k=k: _good(tp, s, t=_time_fault(k)), say, None)
      for s in (".csv", ".nc", ".mf4")
      for k, say in (("back", "goes back from 0.699 s to 0.4 s at "), ("jump", "jumps from 0.899 s to 5.9 s at "),
                     ("repeat", "repeats 0 s at "))],
    ("corrupt-chunk.nc", _corrupt_chunk, "could not be read at samples", "probe"),
]


@pytest.mark.parametrize(("make", "says", "channel"), [f[1:] for f in FAULTS], ids=[f[0] for f in FAULTS])
def test_every_reader_fault_is_one_line_naming_file_and_channel(tmp_path, make, says, channel):
    f = make(tmp_path)
    with pytest.raises(InputError) as err:
        src = open_recording(f)  # faults of the header are found here, those of the samples while streaming
        for _ in src.iter_blocks(src.channels if channel is None or channel not in src.channels else [channel],
                                 block=500):
            pass
        if channel is not None:
            src.resolve(channel)
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith(f"Recording {str(f)!r}") and says in msg, msg
    if channel is not None:
        assert f"channel {channel!r}" in msg, msg
    if "time-" in msg or "jumps" in says or "goes back" in says:
        where = "line" if f.suffix == ".csv" else "sample"
        assert f" at {where} " in msg, msg


@pytest.mark.parametrize(("rows", "says"), [
    # the CSV line (header = line 1) and what is wrong with it; rows are "time,mic"
    ({702: "0.7,1,2"}, "line 702 has 3 fields where the header has 2: extra fields"),
    ({402: "0.4"}, "line 402 has 1 field where the header has 2: missing fields"),
    ({302: ""}, "line 302 is empty"),
    ({1002: "abc,0"}, "time column 'time' has a non-numeric value"),
    ({1101: "1.2,0"}, "time column 'time' jumps from 1.098 s to 1.2 s at line 1101"),
])
def test_csv_rows_are_all_checked_not_only_the_first(tmp_path, rows, says):
    lines = ["time,mic"] + [f"{i / FAULT_FS:.6g},0" for i in range(FAULT_N)]
    for k, v in rows.items():
        lines[k - 1] = v
    f = tmp_path / "r.csv"
    f.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match=says):
        read_recording(f)


def test_csv_trailing_blank_lines_and_rounded_times_are_fine(tmp_path):
    # 8 significant digits (squealkit's own CSV writer) at t ~ 1000 s resolve 1e-4 s, four sample intervals
    # at 40 kHz: steps of 0 or 1e-4 s are the rounding of a uniform time base, not a fault
    t = 1000.0 + np.arange(FAULT_N) / 40000.0
    f = tmp_path / "r.csv"
    f.write_text("time,mic\n" + "".join(f"{x:.8g},1\n" for x in t) + "\n\n")
    src = open_recording(f, fs=40000.0)
    assert src.n_samples == FAULT_N
    t = np.arange(FAULT_N) / 40000.0
    f.write_text("time,mic\n" + "".join(f"{x:.8g},1\n" for x in t) + "\n")
    ds = read_recording(f)
    assert ds.sizes["time"] == FAULT_N and ds.attrs["fs"] == pytest.approx(40000.0)


# -- the streaming time-axis check as a property (hypothesis): no false alarm, every fault found where it is ----
from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402
from hypothesis.extra import numpy as hnp  # noqa: E402

from squealkit.measurement.formats._common import _TimeAxis  # noqa: E402


def _first_fault(t, dt, block):
    axis = _TimeAxis("r.csv", "time column 'time'", dt)
    try:
        for s in range(0, t.size, block):
            axis.check(s, t[s:s + block])
    except InputError as e:
        return int(str(e).split(" at sample ")[1].split()[0].rstrip(":;."))
    return None


@settings(max_examples=60, deadline=None)
@given(fs=st.floats(100.0, 1e5), t0=st.floats(0.0, 1e3), n=st.integers(3, 400), block=st.integers(1, 500),
       fault=st.sampled_from(["none", "back", "jump", "repeat"]), where=st.floats(0.0, 1.0))
def test_time_axis_check_finds_each_fault_at_its_sample_whatever_the_blocks(fs, t0, n, block, fault, where):
    # a uniform time base printed with 8 significant digits (as squealkit's CSV writer does) is never a
    # fault, whatever its start and rate; a step back, a repeat or a jump of 2+ intervals is found at the
    # very sample where it happens, whether or not it falls on a block boundary
    t = t0 + np.arange(n) / fs
    t = np.array([float(f"{x:.8g}") for x in t])
    k = 1 + int(where * (n - 2))
    if fault == "back":
        t[k:] -= 1.5 / fs + 1e-6 * t0
    elif fault == "jump":
        t[k:] += 2.0 / fs + 1e-6 * t0
    elif fault == "repeat" and 1.0 / fs > 1e-6 * t0:  # a repeat is a fault only where the digits resolve dt
        t[k] = t[k - 1]
    else:
        fault = "none"
    found = _first_fault(t, 1.0 / fs, block)
    assert found == (None if fault == "none" else k)


@settings(max_examples=300, deadline=None)
@given(n=st.integers(1, 300), at=st.floats(0.0, 1.0, exclude_max=True), fault=st.integers(0, 6),
       bad=st.sampled_from([np.nan, np.inf, -np.inf]), gap=st.sampled_from([1.0, 3.0]))
def test_branch_free_time_check_agrees_with_the_scan_that_locates_a_fault(n, at, fault, bad, gap):
    # _time_steps_ok (vectorised, no early exit) must pass exactly the blocks _first_bad_time passes;
    # the block and its fault drawn by hypothesis (a failure shrinks to the shortest block)
    from squealkit.measurement.formats._common import _first_bad_time, _time_steps_ok

    dt = 1 / 48000.0
    t = 3.0 + np.arange(n) * dt
    k = int(at * n)
    if fault == 1:
        t[k] = bad
    elif fault == 2:
        t[k:] -= 1.5 * dt
    elif fault == 3:
        t[k:] += 2.0 * dt
    elif fault == 4 and k > 0:
        t[k] = t[k - 1]
    elif fault == 5:
        t[k] += 0.49 * dt  # within tolerance either side
    has_last = fault == 6
    last = 3.0 - dt * gap
    assert bool(_time_steps_ok(t, last, has_last, dt)) == (_first_bad_time(t, last, has_last, dt) == -1)


def test_time_axis_is_checked_on_the_first_complete_pass_only(tmp_path, signals, monkeypatch):
    # a second pass (the analysis after the tacho pass) neither reads nor checks the time coordinate,
    # but only once a pass has gone through the whole axis
    from squealkit.measurement.formats import netcdf

    p, q = signals
    f = tmp_path / "rec.nc"
    recording_dataset({"mic": p, "disp": q}, FS, {"mic": "Pa", "disp": "m"}).to_netcdf(f, engine="h5netcdf")
    src = open_recording(f)
    reads = []
    blocks = netcdf.blocks
    monkeypatch.setattr(netcdf, "blocks", lambda src, names, block, with_time: reads.append(with_time) or
                        blocks(src, names, block, with_time))
    next(src.iter_blocks(["mic"], block=1000))  # stopped early: the axis is not yet known good
    for _ in src.iter_blocks(["mic"], block=1000):
        pass
    first = [blk["disp"] for _, blk in src.iter_blocks(["disp"], block=1000)]
    assert reads == [True, True, False]
    assert np.array_equal(np.concatenate(first), q)


def test_netcdf_time_coordinate_in_milliseconds_is_scaled_then_checked(tmp_path, signals):
    p, _ = signals
    t_ms = np.arange(N) * (1e3 / FS)
    t_ms[3000:] += 2e3 / FS  # a gap of two intervals at sample 3000
    f = tmp_path / "rec.nc"
    ds = xr.Dataset({"mic": ("time", p)}, coords={"time": ("time", t_ms, {"units": "milliseconds"})})
    ds.to_netcdf(f, engine="h5netcdf")
    src = open_recording(f)
    assert src.fs == pytest.approx(FS)
    with pytest.raises(InputError, match=r"jumps .* at sample 3000"):
        for _ in src.iter_blocks(["mic"], block=1000):
            pass


@settings(max_examples=200, deadline=None)
@given(v=hnp.arrays(np.float64, st.integers(0, 500), elements=st.floats(allow_nan=True, allow_infinity=True)))
def test_all_finite_kernel_matches_numpy(v):
    # any float64 values (hypothesis draws NaN, +-inf, subnormals and the extremes; a failure shrinks)
    from squealkit.measurement.formats._common import _all_finite

    with np.errstate(over="ignore"):  # (beyond float32's range: inf, one more case)
        v32 = v.astype(np.float32)
    for arr in (v, v[::3], v32):
        assert bool(_all_finite(arr)) == bool(np.isfinite(arr).all())


def test_contiguous_datasets_are_mapped_as_h5py_reads_them(tmp_path):
    # blocks of a contiguous dataset are mapped from the file: the same numbers as h5py reads (any byte
    # order and type), writable without touching the file; chunked or unwritten datasets are not mapped
    import h5py

    from squealkit.measurement.formats._common import _mapped_block, _stored_as_is

    f = tmp_path / "d.h5"
    rng = np.random.default_rng(5)
    with h5py.File(f, "w") as h:
        h["le"] = rng.standard_normal(5000)
        h.create_dataset("be", data=rng.standard_normal(5000), dtype=">f8")
        h["i16"] = rng.integers(-30000, 30000, 5000).astype(np.int16)
        h.create_dataset("chunked", data=np.arange(5000.0), chunks=(1000,))
        h.create_dataset("unwritten", shape=(5000,), dtype="f8")
    before = f.read_bytes()
    with h5py.File(f, "r") as h:
        assert _stored_as_is(f, h["chunked"]) is None and _stored_as_is(f, h["unwritten"]) is None
        for name in ("le", "be", "i16"):
            d = h[name]
            off = _stored_as_is(f, d)
            assert off is not None
            for start, stop in ((0, 5000), (1234, 4321), (4999, 5000)):
                blk = _mapped_block(f, d.dtype, off, start, stop)
                assert blk.dtype == d.dtype and np.array_equal(blk, d[start:stop])
            blk[0] += 1
    assert f.read_bytes() == before


def test_netcdf_head_is_what_h5netcdf_reads(tmp_path):
    # the time coordinate's first values are read from its HDF5 dataset, as h5netcdf reads them; a
    # dataset shorter than its (unlimited) dimension is padded by h5netcdf, so it is read through it
    import h5netcdf
    import h5py

    from squealkit.measurement.formats._common import _head

    f = tmp_path / "pad.nc"
    with h5netcdf.File(f, "w") as nc:
        nc.dimensions = {"time": None}
        nc.create_variable("time", ("time",), float)
        nc.create_variable("mic", ("time",), np.float32)
        nc.resize_dimension("time", 100)
        nc.variables["time"][:] = np.arange(100) / 1000.0
        nc.variables["mic"][:] = np.arange(100, dtype=np.float32)
    with h5py.File(f, "a") as h5:
        h5["mic"].resize((40,))
    with h5py.File(f, "r") as h5, h5netcdf.File(h5, "r") as nc:
        for name in ("time", "mic"):
            v = nc.variables[name]
            got, ref = _head(h5, v, name, 100), v[:64]
            assert got.dtype == ref.dtype and np.array_equal(got, ref), name
        assert np.count_nonzero(_head(h5, nc.variables["mic"], "mic", 100)[40:]) == 0  # the padding

"""One sample-rate estimate for every reader with a time axis (issue #27: "A CSV's sample rate is taken
from rounded time steps"): least squares over the whole time axis, its jitter in the recording's attrs.

The truth is the generator's: a 2900 Hz tone sampled at exactly 48 kHz for 1 s, its times written
with 7 decimals (steps of 2.08e-5 or 2.09e-5 s; their median, 2.08e-5 s, reads as 48076.9 Hz and
puts the tone at 2904.6 Hz). A sample interval of 208 1/3 units of 1e-7 s leaves rounding errors of 0,
+1/3 and -1/3 units in turn: RMS 1e-7 sqrt(2/27) s = 2.72e-8 s about the (unbiased) line.
"""

import itertools
import math

import numpy as np
import pytest
import xarray as xr

FS, F_TONE, N, DECIMALS = 48000.0, 2900.0, 48000, 7
JITTER = 10.0 ** -DECIMALS * math.sqrt(2 / 27)   # see above


def _rounded_times(decimals=DECIMALS, scale=1.0):
    """The generator's times in units of ``scale`` seconds, as a DAQ prints them (the decimal string read
    back), so that every format holds the very same numbers."""
    t = np.arange(N) / FS / scale
    return np.array([float(f"{v:.{decimals}f}") for v in t])


def _tone():
    return np.sin(2 * np.pi * F_TONE * np.arange(N) / FS)


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """The same recording (mic in Pa, rounded time axis) as CSV, MDF4 (asammdf) and netCDF (xarray/h5netcdf)."""
    from asammdf import MDF, Signal

    d = tmp_path_factory.mktemp("rounded")
    t, p = _rounded_times(), _tone()
    csv = d / "r.csv"
    csv.write_text("time [s],mic [Pa]\n" + "".join(f"{a:.7f},{b:.9g}\n" for a, b in zip(t, p, strict=True)))
    mf4 = d / "r.mf4"
    with MDF(version="4.10") as mdf:
        mdf.append([Signal(p, t, name="mic", unit="Pa")])
        mdf.save(mf4, overwrite=True)
    nc = d / "r.nc"   # no fs attribute: the time coordinate is all there is
    xr.Dataset({"mic": ("time", p, {"units": "Pa"})}, coords={"time": ("time", t, {"units": "s"})}
               ).to_netcdf(nc, engine="h5netcdf")
    nc_ms = d / "r_ms.nc"   # the same in milliseconds with 4 decimals (1e-7 s)
    xr.Dataset({"mic": ("time", p, {"units": "Pa"})},
               coords={"time": ("time", _rounded_times(4, 1e-3), {"units": "milliseconds"})}
               ).to_netcdf(nc_ms, engine="h5netcdf")
    return {"csv": csv, "mf4": mf4, "nc": nc, "nc_ms": nc_ms}


@pytest.mark.parametrize("kind", ["csv", "mf4", "nc", "nc_ms"])
def test_sample_rate_is_the_least_squares_slope_of_the_whole_time_axis(files, kind):
    from squealkit.measurement import open_recording, read_recording

    src = open_recording(files[kind])
    # the time base is exactly 48 kHz; rounding leaves the slope unbiased over 48000 samples (its
    # standard error is 1e-10 relative); a fit over the first block of 64 samples would be off by 1e-5
    assert src.fs == pytest.approx(FS, rel=1e-6)   # was 48076.9 Hz for MDF4 and netCDF
    ds = read_recording(files[kind])
    assert ds.attrs["fs"] == pytest.approx(FS, rel=1e-6)
    assert ds.attrs["time_jitter_rms"] == pytest.approx(JITTER, rel=0.01)
    assert "least-squares" in ds.attrs["fs_method"]
    spec = np.abs(np.fft.rfft(ds["mic"].values))
    freq = np.fft.rfftfreq(N, 1.0 / ds.attrs["fs"])
    assert freq[np.argmax(spec)] == pytest.approx(F_TONE, abs=0.5)   # was 2904.6 Hz from the median step


def test_every_reader_uses_the_one_estimate(files):
    # the same numbers in every format give the same rate, also for an in-memory Dataset (analyze_recording)
    from squealkit.measurement import open_recording
    from squealkit.measurement.analysis.framing import _DatasetSource

    rates = {k: open_recording(f).fs for k, f in files.items() if k != "nc_ms"}
    mem = xr.Dataset({"mic": ("time", _tone())}, coords={"time": _rounded_times()})
    rates["dataset"] = _DatasetSource(mem, None).fs
    assert max(rates.values()) - min(rates.values()) <= 1e-9 * FS, rates


def test_time_fit_is_exact_for_long_offset_axes_in_any_blocks():
    # 2e6 samples starting at t = 1000 s, rounded to 1e-7 s, fed in blocks of uneven sizes (a tiny first
    # one): the slope and the residuals' RMS as numpy's one-shot least squares on the centred axis finds them
    from squealkit.measurement.formats._common import _TimeFit

    n, fs = 2_000_000, 48000.0
    t = np.round(1000.0 + np.arange(n) / fs, 7)
    k = np.arange(n, dtype=np.float64)
    kc, tc = k - k.mean(), t - t.mean()
    slope = float(np.dot(kc, tc) / np.dot(kc, kc))
    rms = float(np.sqrt(np.sum((tc - slope * kc) ** 2) / (n - 2)))
    cuts = [0, 3, 5000, 5001, 777_777, 1_500_000, n]
    fit = _TimeFit()
    for a, b in itertools.pairwise(cuts):
        fit.add(t[a:b])
    dt, jitter = fit.result()
    assert dt == pytest.approx(slope, rel=1e-12)
    assert jitter == pytest.approx(rms, rel=1e-3)
    assert jitter == pytest.approx(JITTER, rel=0.01)


def test_a_jittery_mdf4_time_axis_warns(tmp_path):
    from asammdf import MDF, Signal

    from squealkit.measurement import open_recording

    rng = np.random.default_rng(1)
    t = np.arange(2000) / 1000.0 + rng.uniform(-2e-4, 2e-4, 2000)   # +-0.2 sample intervals of jitter
    f = tmp_path / "jitter.mf4"
    with MDF(version="4.10") as mdf:
        mdf.append([Signal(np.ones(2000), t, name="mic", unit="Pa")])
        mdf.save(f, overwrite=True)
    with pytest.warns(UserWarning, match="jitter"):
        src = open_recording(f)
    assert src.fs == pytest.approx(1000.0, rel=1e-3)


def test_a_netcdf_fs_attribute_still_sets_the_rate(tmp_path):
    # a file that states its rate keeps it (like TDMS's wf_increment and UFF's abscissa spacing); the
    # rounded coordinate agrees with it and is only checked
    from squealkit.measurement import open_recording

    f = tmp_path / "fs.nc"
    xr.Dataset({"mic": ("time", _tone())}, coords={"time": _rounded_times()}, attrs={"fs": FS}
               ).to_netcdf(f, engine="h5netcdf")
    assert open_recording(f).fs == FS

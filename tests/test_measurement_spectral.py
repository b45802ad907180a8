"""A-weighting, peak refinement and spectrogram of squealkit.measurement.signal.spectral."""

import numpy as np
import pytest

from squealkit.measurement import a_weighting_db, phase_advance_freq, refine_peak, spectrogram
from squealkit.measurement.signal.spectral import frame_power

# IEC 61672-1:2013 Table 3, A-weighting rounded to 0.1 dB. The table is computed at the exact
# base-10 frequencies 10**(n/10) Hz whose nominal names are 31.5, 2000, 4000, 8000, 16000 Hz.
IEC_TABLE = [(10**1.5, -39.4), (100.0, -19.1), (1000.0, 0.0), (10**3.3, 1.2), (10**3.6, 1.0), (10**3.9, -1.1),
             (10000.0, -2.5), (10**4.2, -6.6)]


@pytest.mark.parametrize(("freq", "expected"), IEC_TABLE)
def test_a_weighting_matches_iec_61672_table(freq, expected):
    assert a_weighting_db(freq) == pytest.approx(expected, abs=0.06)


def test_a_weighting_is_zero_at_1khz_to_rounding():
    assert abs(float(a_weighting_db(1000.0))) < 1e-3


@pytest.mark.parametrize("freq", [2388.0, 2391.3, 2402.7, 2437.9])
def test_refine_peak_beats_bin_spacing(freq):
    fs, n = 40000.0, 512  # bins of 78 Hz
    t = np.arange(n) / fs
    spec, power = frame_power(np.sin(2 * np.pi * freq * t + 0.7), n, n)
    k = int(np.argmax(power[0]))
    est = float(refine_peak(np.abs(spec[0]), k)) * fs / n
    assert abs(est - freq) < 0.5  # < 1 % of a bin


@pytest.mark.parametrize("growth_rate", [-1500.0, 0.0, 1500.0])
@pytest.mark.parametrize("freq", [2350.0, 2388.0, 2400.0, 2420.0, 3000.0])
def test_phase_advance_recovers_growing_and_decaying_tones(freq, growth_rate):
    # x = exp(growth_rate t) sin(2 pi freq t): for any real envelope the lag-hop product of the tone
    # has phase 2 pi freq hop / fs exactly; what remains comes from keeping 5 bins of the main
    # lobe and from the negative-frequency image (measured < 0.004 Hz for one frame pair)
    fs, n, hop = 40000.0, 512, 256
    t = np.arange(n + hop) / fs
    spec, power = frame_power(np.exp(growth_rate * t) * np.sin(2 * np.pi * freq * t + 0.7), n, hop)
    k = int(np.argmax(power[1]))
    coarse = float(refine_peak(np.abs(spec[1]), k)) * fs / n
    cross = (spec[1, k - 2:k + 3] * np.conj(spec[0, k - 2:k + 3])).sum()
    assert abs(float(phase_advance_freq(cross, coarse, fs, hop)) - freq) < 0.01
    if growth_rate:
        assert abs(coarse - freq) > 4.0  # the two-bin ratio assumes a steady tone's main lobe


def test_frame_power_sums_to_mean_square():
    # Parseval: a sine of amplitude 2 Pa has a mean square of 2 Pa^2.
    fs, n = 40000.0, 1024
    t = np.arange(4 * n) / fs
    _, p = frame_power(2.0 * np.sin(2 * np.pi * 2388.0 * t), n, n // 2)
    assert np.allclose(p.sum(axis=1), 2.0, rtol=2e-3)


def test_spectrogram_is_labelled():
    fs = 40000.0
    sg = spectrogram(np.sin(2 * np.pi * 2388.0 * np.arange(8000) / fs), fs, nperseg=1024)
    assert sg.dims == ("time", "freq")
    assert sg["freq"].attrs["units"] == "Hz"
    assert abs(float(sg["freq"][int(np.argmax(sg.mean("time").values))]) - 2388.0) < fs / 1024

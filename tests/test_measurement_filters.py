"""Zero-phase Butterworth filters against SciPy's reference designs."""

import numpy as np
import pytest
from scipy import signal

from squealkit import InputError
from squealkit.measurement import bandpass, butter_sos, highpass, lowpass, lowpass_decimated, synthetic_source

FS = 40000.0


@pytest.fixture
def x():
    return np.random.default_rng(0).standard_normal(20000)


def test_lowpass_equals_scipy_reference(x):
    ref = signal.sosfiltfilt(signal.butter(4, 1000.0, "lowpass", fs=FS, output="sos"), x)
    assert np.allclose(lowpass(x, 1000.0, FS), ref, atol=1e-12)


def test_highpass_equals_scipy_reference(x):
    ref = signal.sosfiltfilt(signal.butter(4, 500.0, "highpass", fs=FS, output="sos"), x)
    assert np.allclose(highpass(x, 500.0, FS), ref, atol=1e-12)


def test_bandpass_equals_scipy_reference(x):
    # paper Fig. 13: 1000-2500 Hz
    ref = signal.sosfiltfilt(signal.butter(4, (1000.0, 2500.0), "bandpass", fs=FS, output="sos"), x)
    assert np.allclose(bandpass(x, 1000.0, 2500.0, FS), ref, atol=1e-12)


def test_zero_phase_keeps_a_passband_tone_in_place():
    t = np.arange(8000) / FS
    tone = np.sin(2 * np.pi * 100.0 * t)
    y = lowpass(tone + np.sin(2 * np.pi * 5000.0 * t), 1000.0, FS)
    assert np.max(np.abs(y[1000:-1000] - tone[1000:-1000])) < 1e-3


@pytest.mark.parametrize(("kind", "freq"), [("lowpass", 25000.0), ("bandpass", (2000.0, 1000.0)),
                                            ("lowpass", -5.0), ("notch", 100.0)])
def test_bad_designs_are_rejected(kind, freq):
    with pytest.raises(InputError):
        butter_sos(kind, freq, FS)


def test_lowpass_decimated_agrees_with_the_full_rate_lowpass():
    # the analysis filters the run-out at fs / 8 (5 kHz): on a synthetic displacement (run-out
    # orders 1-40 at 900 rpm = 15-600 Hz, the 2388 Hz squeal vibration, noise) it must give the
    # full-rate zero-phase 1000 Hz low-pass to 0.2 % of the peak-to-peak (0.02 % off the ends)
    src = synthetic_source(duration=1.0, seed=4)
    q = src.block(0, src.n_samples)["displacement"]
    ref = lowpass(q, 1000.0, FS)[::8]
    got = lowpass_decimated(q, 1000.0, FS, 8)
    assert got.shape == ref.shape
    err = np.abs(got - ref) / np.ptp(ref)
    assert err.max() < 2e-3 and err[100:-100].max() < 2e-4


@pytest.mark.parametrize(("freq", "gain"), [(100.0, 1.0), (1000.0, 0.5), (4776.0, 0.0), (9000.0, 0.0)])
def test_lowpass_decimated_keeps_the_corner_and_rejects_aliases(freq, gain):
    # zero-phase Butterworth: gain 1/2 (-6 dB) at the corner after both passes; 4776 Hz (the squeal's
    # second harmonic) and 9 kHz would fold to 224 Hz and 1 kHz at 5 kHz without the anti-alias FIR
    t = np.arange(40000) / FS
    y = lowpass_decimated(np.cos(2 * np.pi * freq * t), 1000.0, FS, 8)
    ref = gain * np.cos(2 * np.pi * freq * t[::8])
    assert np.max(np.abs(y - ref)[500:-500]) < 1e-3


def test_lowpass_decimated_rejects_a_too_low_rate():
    with pytest.raises(InputError, match="dec"):
        lowpass_decimated(np.zeros(1000), 1000.0, FS, 16)

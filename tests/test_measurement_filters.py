"""Zero-phase Butterworth filters against SciPy's reference designs."""

import numpy as np
import pytest
from scipy import signal

from squealkit import InputError
from squealkit.measurement import bandpass, butter_sos, highpass, lowpass

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

"""Known answers at the edges (issue 30): J2521 band edges, stability windows, eigenvalues at
doublets and rigid-body modes, contact event times, event onsets, absent harmonics."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from squealkit.measurement import analyze_recording
from squealkit.measurement.criteria import P_REF, a_weighting_db, squeal_criteria, time_weighted_level

FS = 48000.0


def _tone_recording(tones, duration=0.6, fs=FS):
    """Steady tones ``[(freq, level_dba), ...]``: each tone's RMS is its level less A(f) (IEC 61672-1
    Annex E closed form), so a band-limited A-weighted meter reads exactly ``level_dba`` for it."""
    t = np.arange(int(duration * fs)) / fs
    mic = sum(np.sqrt(2) * P_REF * 10 ** ((dba - float(a_weighting_db(f))) / 20) * np.sin(2 * np.pi * f * t + 0.3)
              for f, dba in tones)
    disp = 1e-6 * np.sin(2 * np.pi * 15.0 * t)
    return xr.Dataset({"mic": ("time", mic), "displacement": ("time", disp)}, attrs={"fs": fs})


def _analyze(rec, **kw):
    return analyze_recording(rec, mic="mic", displacement="displacement", rpm=900.0, radius=0.05, **kw)


# -- 1. SAE J2521 band edges ------------------------------------------------------------------------------

@pytest.mark.parametrize(("setup", "freq"), [("component", 2000.0), ("component", 2010.0), ("component", 2060.0),
                                             ("component", 15900.0), ("component", 15990.0), ("corner", 1260.0),
                                             ("corner", 1340.0)])
@pytest.mark.parametrize("min_tnr_db", [8.0, None])
def test_tone_inside_the_band_edges_is_squeal_at_its_full_level(setup, freq, min_tnr_db):
    # SAE J2521: a tone in the band (component 2-16 kHz, corner 1.25-16 kHz) counts at its full level;
    # 80 dB(A) by construction (A-weighting closed form), above the 70 dB(A) threshold
    res = _analyze(_tone_recording([(freq, 80.0)]), setup=setup, min_tnr_db=min_tnr_db)
    assert len(res.events) == 1
    assert abs(res.events[0].frequency_hz - freq) < 0.5
    assert abs(res.events[0].peak_dba - 80.0) < 0.2 and abs(res.peak_dba - 80.0) < 0.2


@pytest.mark.parametrize(("setup", "freq"), [("component", 1990.0), ("component", 16010.0), ("corner", 1240.0)])
def test_tone_just_outside_the_band_does_not_count(setup, freq):
    # 95 dB(A) 10 Hz outside the band: the band filter stops it (EDGE_HZ = 5 Hz roll-off outside the
    # edges), also at the recording's ends, so the in-band level stays far below 70 dB(A)
    res = _analyze(_tone_recording([(freq, 95.0)]), setup=setup)
    assert res.peak_dba < 50.0 and res.events == ()


def test_in_band_tone_keeps_its_level_beside_a_loud_tone_outside():
    # 80 dB(A) at 3 kHz with 95 dB(A) at 1990 Hz: the out-of-band tone takes no share of the in-band level
    res = _analyze(_tone_recording([(3000.0, 80.0), (1990.0, 95.0)]))
    assert [round(e.frequency_hz) for e in res.events] == [3000]
    assert abs(res.events[0].peak_dba - 80.0) < 0.2


@pytest.mark.parametrize("freq", [2000.0, 2005.0, 16000.0])
def test_level_meter_reads_full_level_at_the_edges(freq):
    # the band's edges are in the band: the Fast level of a steady 80 dB(A) tone reads 80 dB(A)
    t = np.arange(int(FS)) / FS
    x = np.sqrt(2) * P_REF * 10 ** ((80.0 - float(a_weighting_db(freq))) / 20) * np.sin(2 * np.pi * freq * t)
    lev = time_weighted_level(x, FS, squeal_criteria("component"))
    assert abs(lev[int(0.9 * FS)] - 80.0) < 0.05

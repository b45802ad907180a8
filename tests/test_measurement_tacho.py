"""Tacho, order tracking, synchronous averaging and the rig geometry (probe offset, polarity, delay).

Known truth: the synthetic rig's disc position ``SyntheticSource.turns(t)`` (constant speed or a
linear deceleration), its surface ``SyntheticSource.surface(turns)`` and the squeal's rising
fraction computed from the noise-free envelope at the pin. Issue 14's defects reproduced on main:
a probe 2 degrees off the pin and a reversed probe moved ``rising_fraction`` (no settings existed).
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from squealkit import InputError
from squealkit.measurement import analyze_recording, synthetic_recording, synthetic_source
from squealkit.measurement.formats.readers import recording_dataset
from squealkit.measurement.signal.tacho import (
    angular_resample,
    pulse_times,
    read_tacho,
    synchronous_average,
    tacho_angle,
)

FS = 40000.0
KW = dict(mic="mic", displacement="displacement", radius=0.05)


@pytest.fixture(scope="module")
def stop():
    """A decelerating stop, 900 -> 300 rpm in 2 s, with a once-per-revolution tacho."""
    src = synthetic_source(duration=2.0, seed=1, rpm_end=300.0)
    return src, src.block(0, src.n_samples)


@pytest.mark.parametrize("ppr", [1, 60])
def test_angle_and_speed_from_pulses(ppr):
    src = synthetic_source(duration=2.0, seed=1, rpm_end=300.0, tacho_ppr=ppr)
    data = src.block(0, src.n_samples)
    ang = tacho_angle(data["tacho"], FS, pulses_per_rev=ppr)
    t = np.linspace(ang.marks_s[0], ang.marks_s[-1], 50)
    # angle 0 is the first rising edge: the recording starts inside a pulse, so that is mark 1
    assert src.turns(ang.marks_s[0]) == pytest.approx(1 / ppr, abs=1e-3)
    # edges found to a sample (25 us): at 900 rpm that is 4e-4 rev
    assert np.max(np.abs(ang.turns(t) + 1 / ppr - src.turns(t))) < 1e-3
    true_rpm = 900.0 + (300.0 - 900.0) * t / 2.0
    assert np.max(np.abs(ang.rpm(t) / true_rpm - 1)) < 5e-3


def test_angle_from_an_angle_channel():
    src = synthetic_source(duration=1.0, seed=1, rpm_end=450.0)
    t = np.arange(src.n_samples) / FS
    deg = (src.turns(t) * 360.0 + 30.0) % 360.0  # a wrapping encoder angle, 30 deg at t = 0
    ang = tacho_angle(deg, FS, kind="angle")
    tt = np.linspace(0.05, 0.95, 20)
    assert np.max(np.abs(ang.turns(tt) - src.turns(tt))) < 1e-6
    assert ang.rpm(0.5) == pytest.approx(900 + (450 - 900) * 0.5, rel=1e-4)


def test_pulse_times_interpolate_between_samples():
    x = np.array([0.0, 0.0, 1.0, 3.0, 5.0, 5.0, 0.0, 2.0, 4.0])
    assert np.allclose(pulse_times(x, 100.0), [(2 + 1.5 / 2) / 100.0, (6 + 2.5 / 2) / 100.0])


def test_blockwise_tacho_equals_whole(stop):
    src, data = stop
    rec = recording_dataset(data, FS, src.units, {})
    from squealkit.measurement.analysis.framing import _DatasetSource

    whole = tacho_angle(data["tacho"], FS)
    blocks = read_tacho(_DatasetSource(rec, FS), "tacho", block=7777)  # edges straddle block ends
    assert np.allclose(blocks.marks_s, whole.marks_s) and np.array_equal(blocks.marks_turns, whole.marks_turns)


def test_synchronous_average_recovers_the_runout_of_a_stop(stop):
    src, data = stop
    ang = tacho_angle(data["tacho"], FS)
    phase, mean, per_rev, revs = synchronous_average(data["displacement"], FS, ang, samples_per_rev=512)
    q, _ = src.surface(phase)
    assert revs[0] == 0 and per_rev.shape == (revs.size, 512) and revs.size == 19  # 20 turns, whole ones
    # what is not locked to the disc (squeal on the probe, noise) averages out
    assert np.sqrt(np.mean((mean - q) ** 2)) < 0.01 * np.ptp(q)
    assert np.allclose(np.ptp(per_rev, axis=1), np.ptp(q), rtol=0.05)


def test_order_tracking_puts_an_order_at_its_order(stop):
    src, data = stop
    ang = tacho_angle(data["tacho"], FS)
    t = np.arange(src.n_samples) / FS
    x = np.sin(2 * np.pi * 12 * src.turns(t))  # order 12: 180 Hz falling to 60 Hz
    grid, xa = angular_resample(x, FS, ang, samples_per_rev=64)
    assert np.allclose(np.diff(grid), 1 / 64)
    n = (xa.size // 64) * 64
    spec = np.abs(np.fft.rfft(xa[:n]))
    orders = np.fft.rfftfreq(n, 1 / 64)
    assert orders[np.argmax(spec)] == pytest.approx(12.0, abs=0.06)


def test_analysis_of_a_decelerating_stop_with_a_tacho():
    rec = synthetic_recording(duration=2.0, seed=1, rpm_end=300.0)
    res = analyze_recording(rec, tacho="tacho", **KW)
    src = synthetic_source(duration=2.0, seed=1, rpm_end=300.0)
    q, _ = src.surface(np.linspace(0, 1, 4096, endpoint=False))
    assert res.revolutions.sizes["revolution"] == 20  # 20 turns in 2 s, from a mark to a mark
    inner = res.revolutions["sro_p2p"].values[1:-1]
    assert np.allclose(inner, np.ptp(q), rtol=0.05)
    assert res.growth_slope_correlation > 0.5
    assert res.rising_fraction == pytest.approx(rec.attrs["truth_rising_fraction"], abs=0.05)
    assert res.squeal_frequency_hz == pytest.approx(2388.0, abs=0.05)
    assert res.settings.rpm == pytest.approx(600.0, rel=0.01)  # mean speed from the tacho


@pytest.mark.parametrize(("geometry", "setting"), [
    (dict(probe_offset_deg=2.0), dict(probe_offset_deg=2.0)),
    (dict(probe_offset_deg=-20.0), dict(probe_offset_deg=-20.0)),
    (dict(polarity=-1), dict(polarity=-1)),
    (dict(acoustic_delay=0.003), dict(acoustic_delay=0.003)),
])
def test_rig_geometry_settings_restore_the_runout_link(geometry, setting):
    ref = analyze_recording(synthetic_recording(duration=2.0, seed=1), rpm=900.0, **KW)
    rec = synthetic_recording(duration=2.0, seed=1, **geometry)
    naive = analyze_recording(rec, rpm=900.0, **KW)
    fixed = analyze_recording(rec, rpm=900.0, **KW, **setting)
    assert fixed.rising_fraction == pytest.approx(ref.rising_fraction, abs=0.005)
    assert fixed.growth_slope_correlation == pytest.approx(ref.growth_slope_correlation, abs=0.02)
    assert abs(naive.rising_fraction - ref.rising_fraction) > 0.02  # without the setting it is wrong
    # and the same with the tacho, at varying speed
    rec = synthetic_recording(duration=2.0, seed=1, rpm_end=450.0, **geometry)
    ref_t = analyze_recording(synthetic_recording(duration=2.0, seed=1, rpm_end=450.0), tacho="tacho", **KW)
    fixed_t = analyze_recording(rec, tacho="tacho", **KW, **setting)
    assert fixed_t.rising_fraction == pytest.approx(ref_t.rising_fraction, abs=0.01)


def test_correlation_is_the_robust_statistic_for_symmetric_growth():
    # growth and decay equally fast: rising_fraction says little (energy near 0.5 either side),
    # the growth/slope correlation still shows the link
    rec = synthetic_recording(duration=2.0, seed=6, growth_rate=2000.0, decay_rate=2000.0)
    res = analyze_recording(rec, rpm=900.0, **KW)
    assert res.growth_slope_correlation > 0.5
    d = res.to_dict()
    assert list(d).index("growth_slope_correlation") < list(d).index("rising_fraction")


def test_tacho_errors_are_clear(stop):
    src, data = stop
    with pytest.raises(InputError, match="rpm"):
        analyze_recording(synthetic_recording(duration=0.2, seed=1), **KW)
    flat = recording_dataset({**data, "tacho": np.zeros(src.n_samples)}, FS, src.units, {})
    with pytest.raises(InputError, match="constant"):
        analyze_recording(flat, tacho="tacho", **KW)
    with pytest.raises(InputError, match="polarity"):
        analyze_recording(synthetic_recording(duration=0.2, seed=1), rpm=900.0, polarity=0, **KW)
    with pytest.raises(InputError, match="pulses_per_rev"):
        tacho_angle(data["tacho"], FS, pulses_per_rev=0)


def test_figures_follow_the_squeal_found():
    # issue 14: the Figs. 10-13 views were fixed (0.1-0.3 s, 1000-2500 Hz); they follow the squeal now
    from squealkit.measurement import squeal_views

    rec = synthetic_recording(duration=2.0, seed=1, rpm_end=300.0, freq=6100.0)
    res = analyze_recording(rec, tacho="tacho", **KW)
    v = squeal_views(res, 2.0)
    onset = float(rec.attrs["truth_event_starts_s"][0])
    t0, t1 = v["zoom"]
    assert t0 <= onset < t1
    speed = 900.0 + (300.0 - 900.0) * onset / 2.0  # rpm at the onset
    assert t1 - t0 == pytest.approx(3 * 60.0 / speed, rel=0.02)  # three revolutions at the actual speed
    assert v["band"][0] < 6100.0 < v["band"][1] and v["freq_max"] > 6100.0
    quiet = analyze_recording(synthetic_recording(duration=0.5, seed=1, squeal_on="none"), rpm=900.0, **KW)
    assert squeal_views(quiet, 0.5)["band"] == (1000.0, 2500.0)


def test_each_event_has_its_own_runout_phase():
    # two squeal lines on the same disc (same seed: the same run-out), one growing on rising run-out,
    # one on falling: each event's phase recovers its own line's truth (VDA 303: separate components)
    a = synthetic_recording(duration=2.0, seed=1, freq=3000.0, squeal_on="rising", rpm_end=450.0)
    b = synthetic_recording(duration=2.0, seed=1, freq=7000.0, squeal_on="falling", rpm_end=450.0, noise_pa=0.0,
                            harmonics=(0.05,))
    res = analyze_recording(a.assign(mic=a["mic"] + b["mic"]), tacho="tacho", **KW)
    by_f = {round(e.frequency_hz, -3): e for e in res.events}
    for f, rec in ((3000.0, a), (7000.0, b)):
        err = (by_f[f].runout_phase_deg - rec.attrs["truth_runout_phase_deg"] + 180) % 360 - 180
        assert abs(err) < 10.0
    assert abs(by_f[3000.0].runout_phase_deg - by_f[7000.0].runout_phase_deg) > 90


#: A tacho block: samples at the levels (exactly on the 2.5 threshold too), or any value around them.
_TACHO_SAMPLES = st.one_of(st.sampled_from([0.0, 2.5, 5.0]), st.floats(-3.0, 8.0))


@settings(max_examples=150, deadline=None)
@given(x=hnp.arrays(np.float64, st.integers(1, 300), elements=_TACHO_SAMPLES), start=st.integers(1, 10**6),
       before=st.one_of(st.none(), st.sampled_from([0.0, 2.5, 5.0])))
def test_rising_edges_kernel_matches_pulse_times_of_the_joined_block(x, start, before):
    # read_tacho finds the edges of a block and the sample before it in one compiled pass; the times
    # must be those pulse_times gives for the two joined, to the last bit (blocks drawn by hypothesis:
    # a failure shrinks to the shortest one)
    from squealkit.measurement.signal.tacho import _rising_edges

    level = 2.5
    k, frac = _rising_edges(x, 0.0 if before is None else before, before is not None, level)
    t0 = start / FS if before is None else (start - 1) / FS
    joined = x if before is None else np.concatenate([[before], x])
    ref = pulse_times(joined, FS, level=level, t0=t0) if joined.size >= 2 else np.empty(0)
    assert np.array_equal(t0 + (k + frac) / FS, ref)


@pytest.mark.parametrize("block", [7777, 1 << 12, 10**6])
def test_tacho_blocks_are_the_sources_blocks(stop, block):
    # read_tacho reads several blocks at a time, then takes them one by one: the same blocks (starts
    # and samples) as the source yields them one by one, so the edges and the level are the same
    from squealkit.measurement.analysis.framing import _DatasetSource
    from squealkit.measurement.signal.tacho import _tacho_blocks

    src, data = stop
    source = _DatasetSource(recording_dataset(data, FS, src.units, {}), FS)
    got = list(_tacho_blocks(source, "tacho", block))
    ref = list(source.iter_blocks(["tacho"], block=block))
    assert [s for s, _ in got] == [s for s, _ in ref]
    assert all(np.array_equal(x, blk["tacho"]) for (_, x), (_, blk) in zip(got, ref, strict=True))

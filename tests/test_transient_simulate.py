"""The transient solver's interface: outputs, initial states, profiles, contact laws, batches, errors."""

from __future__ import annotations

import importlib
import math
import os
import warnings

import numpy as np
import pytest
import xarray as xr

from squealkit._validation import InputError
from squealkit.io import load_dataset, save_blocks, save_dataset
from squealkit.models import get_preset
from squealkit.transient import (
    AliasingWarning,
    Contact,
    DiscRunOut,
    RandomRoughness,
    SampledProfile,
    SineRunOut,
    Smooth,
    TensileContactWarning,
    simulate,
    simulate_batch,
    simulate_blocks,
    transient_summary,
)

LV = get_preset("lv2013")
FIG4 = SineRunOut(0.08e-3, 1e-3)  # paper section 4: q0 = 0.08 mm, lambda = 1 mm


def test_dataset_variables_units_and_sampling():
    ds = simulate(LV, mu=0.4, profile=FIG4, duration=0.005, fs=40_000)
    assert ds.sizes["time"] == 201
    assert np.allclose(np.diff(ds.time.values), 1 / 40_000)
    for d in ("x1", "y1", "y2"):
        assert ds[d].attrs["units"] == "m"
        assert ds[f"{d}_dot"].attrs["units"] == "m/s"
        assert ds[f"{d}_ddot"].attrs["units"] == "m/s^2"
    for v, u in [("normal_force", "N"), ("friction_force", "N"), ("q", "m"), ("tan_theta", "1"),
                 ("mu_e", "1"), ("growth_rate", "1/s")]:
        assert ds[v].attrs["units"] == u
    assert ds.attrs["status"] == "completed"
    # Paper eq. 11: tan(theta) = 2 pi q0 / lambda cos(2 pi v t / lambda); eq. 6: mu_e = mu + tan(theta).
    t = ds.time.values
    assert np.allclose(ds.tan_theta, 2 * math.pi * 0.08 * np.cos(2 * math.pi * 0.02 * t / 1e-3))
    assert np.allclose(ds.mu_e, 0.4 + ds.tan_theta)
    # Eq. 3: F_f = mu N.
    assert ds.friction_force[0] == pytest.approx(0.4 * ds.normal_force[0])
    assert np.all(np.isfinite(ds.to_array().values))


def test_growth_rate_matches_stability_engine():
    from squealkit.stability.eigen import eigenvalues

    ds = simulate(LV, mu=0.4, profile=FIG4, duration=0.003, fs=10_000)
    lam = eigenvalues(LV, 0.4, tan_theta=ds.tan_theta.values, damped=True)
    assert np.allclose(ds.growth_rate, lam.real.max(-1))
    # Rising SRO (tan theta > 0) destabilises (paper section 4, Fig. 4).
    assert ds.growth_rate[0] > 0


def test_default_start_is_static_equilibrium():
    ds = simulate(LV, mu=0.4, duration=0.002, fs=10_000)
    x_eq = LV.static_equilibrium(0.4)
    x = np.stack([ds[d].values for d in LV.dof_names], axis=-1)
    assert np.allclose(x, x_eq, rtol=1e-9, atol=1e-15)


def test_perturbation_is_seeded():
    kw = dict(mu=0.4, duration=0.002, fs=10_000, perturbation=1e-9)
    a = simulate(LV, rng=np.random.default_rng(3), **kw)
    b = simulate(LV, rng=np.random.default_rng(3), **kw)
    c = simulate(LV, rng=np.random.default_rng(4), **kw)
    assert np.array_equal(a.x1.values, b.x1.values)
    assert not np.array_equal(a.x1.values, c.x1.values)
    with pytest.raises(InputError, match="rng"):
        simulate(LV, perturbation=1e-9, **{k: v for k, v in kw.items() if k != "perturbation"})


def test_divergence_stops_with_status_not_nan():
    model = LV.undamped()  # mu = 0.8: sigma ~ 430 1/s
    ds = simulate(model, mu=0.8, duration=0.2, fs=10_000, perturbation=1e-9, rng=np.random.default_rng(0),
                  limit=1e-5)
    assert ds.attrs["status"] == "diverged"
    assert ds.attrs["t_stop"] < 0.2
    assert ds.sizes["time"] < 2001
    assert np.all(np.isfinite(ds.to_array().values))


def test_nonlinear_contact_bounds_unstable_run_on_limit_cycle():
    # mu = 0.8 is unstable (sigma ~ 34 1/s damped); the linear law grows without bound, the
    # nonlinear one (loss of contact, velocity-sign friction) settles.
    kw = dict(mu=0.8, duration=0.3, fs=20_000, perturbation=1e-9, rng=np.random.default_rng(0))
    lin = simulate(LV, **kw)
    kw["rng"] = np.random.default_rng(0)
    nl = simulate(LV, contact="nonlinear", **kw)
    assert nl.attrs["status"] == "completed"
    assert nl.normal_force.min() >= 0.0
    peaks = [np.abs(nl.x1_ddot.values[i : i + 500]).max() for i in range(4000, 6000, 500)]
    assert max(peaks) / min(peaks) < 1.1  # near-steady amplitude over the last 0.1 s
    assert np.abs(lin.x1_ddot).max() > 3 * np.abs(nl.x1_ddot).max()


def test_nonlinear_contact_equals_linear_for_small_motion():
    a = simulate(LV, mu=0.4, profile=FIG4, duration=0.01, fs=20_000)
    b = simulate(LV, mu=0.4, profile=FIG4, duration=0.01, fs=20_000, contact=Contact(separation=True))
    assert np.allclose(a.x1, b.x1, rtol=1e-12, atol=1e-18)


def test_stribeck_option_runs():
    c = Contact.nonlinear(mu_static=0.5, v_stribeck=0.01)
    ds = simulate(LV, mu=0.4, duration=0.005, fs=20_000, contact=c)
    assert ds.attrs["status"] == "completed"
    assert "Stribeck" in ds.attrs["contact"]
    # At rest the disc slides at v = 0.02 m/s: mu(v) = 0.4 + 0.1 exp(-2), times tanh(v / v_reg).
    expected = (0.4 + 0.1 * math.exp(-2.0)) * math.tanh(20.0)
    assert ds.mu_e.values[0] == pytest.approx(expected, rel=1e-9)


def test_sampled_profile_file_matches_sine(tmp_path):
    x = np.linspace(0, 2e-3, 4001)
    q, _ = FIG4.evaluate(x)
    f = tmp_path / "profile.csv"
    np.savetxt(f, np.column_stack([x, q]), delimiter=",", header="position_m,q_m")
    prof = SampledProfile.from_file(f)
    xs = np.linspace(0.1e-3, 1.9e-3, 77)
    assert np.allclose(prof.evaluate(xs)[1], FIG4.evaluate(xs)[1], atol=1e-5)
    a = simulate(LV, mu=0.4, profile=FIG4, duration=0.02, fs=20_000)
    b = simulate(LV, mu=0.4, profile=prof, duration=0.02, fs=20_000)
    assert np.allclose(a.x1, b.x1, rtol=0, atol=1e-5 * np.abs(a.x1).max())
    with pytest.raises(InputError, match="sampled only"):
        simulate(LV, mu=0.4, profile=prof, duration=0.2)
    with pytest.raises(InputError, match="does not exist"):
        SampledProfile.from_file(tmp_path / "missing.csv")


def test_random_roughness_reproducible_and_band_limited():
    kw = dict(rms=1e-6, wavelength_min=0.1e-3, wavelength_max=1e-3)
    a = RandomRoughness.draw(rng=np.random.default_rng(7), **kw)
    b = RandomRoughness.draw(rng=np.random.default_rng(7), **kw)
    assert np.array_equal(a.phase, b.phase)
    lam = 2 * np.pi / a.wavenumber
    assert lam.min() >= 0.1e-3 and lam.max() <= 1e-3
    q, _ = a.evaluate(np.linspace(0, 1.0, 400_001))
    assert q.std() == pytest.approx(1e-6, rel=0.1)


def test_disc_runout_repeats_every_revolution():
    disc = DiscRunOut.build(radius=0.1, macro={1: 20e-6, 2: 5e-6}, micro_rms=0.5e-6,
                            micro_orders=(40, 120), rng=np.random.default_rng(1))
    x = np.linspace(0, 0.3, 50)
    q1, t1 = disc.evaluate(x)
    q2, t2 = disc.evaluate(x + 2 * np.pi * 0.1)
    assert np.allclose(q1, q2, atol=1e-15) and np.allclose(t1, t2, atol=1e-12)
    v = disc.sliding_speed(900.0)  # paper section 5: 900 rpm
    ds = simulate(LV, mu=0.4, profile=disc, speed=v, duration=0.002, fs=40_000)
    assert ds.attrs["status"] == "completed"


def test_batch_matches_single_runs():
    mus = [0.3, 0.5]
    batch = simulate_batch(LV, mu=mus, profiles=[FIG4, Smooth()], duration=0.004, fs=20_000)
    assert list(batch.status.values) == ["completed", "completed"]
    for i, (mu, prof) in enumerate(zip(mus, [FIG4, Smooth()], strict=True)):
        # Dormand-Prince steps each run on its own: the same numbers alone as in the batch
        single = simulate(LV, mu=mu, profile=prof, duration=0.004, fs=20_000)
        assert np.allclose(batch.x1.isel(run=i), single.x1, rtol=1e-12, atol=0)
    rk4 = simulate_batch(LV, mu=mus, profiles=[FIG4, Smooth()], duration=0.004, fs=20_000, method="rk4")
    for i, (mu, prof) in enumerate(zip(mus, [FIG4, Smooth()], strict=True)):
        # RK4 takes the batch's smallest step: the same numbers with that step
        single = simulate(LV, mu=mu, profile=prof, duration=0.004, fs=20_000, dt=rk4.attrs["dt"], method="rk4")
        assert np.allclose(rk4.x1.isel(run=i), single.x1, rtol=1e-12, atol=0)


def test_netcdf_round_trip(tmp_path):
    ds = simulate(LV, mu=0.4, profile=FIG4, duration=0.002, fs=20_000)
    back = load_dataset(save_dataset(ds, tmp_path / "run.nc"))
    assert back.identical(ds) or back.equals(ds)
    assert back.attrs["status"] == "completed"


def test_summary_growth_and_decay_per_stage():
    ds = simulate(LV, mu=0.4, profile=FIG4, duration=0.1, fs=20_000)
    s = transient_summary(ds)
    rising = [st for st in s["stages"] if st["stage"] == "rising" and st["t_start"] > 0.03]
    falling = [st for st in s["stages"] if st["stage"] == "falling"]
    # Paper section 4: responses grow while the SRO rises and decay while it falls.
    assert rising and all(st["rate_per_s"] > 0 for st in rising)
    assert falling and all(st["rate_per_s"] < 0 for st in falling)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        (dict(duration=-1.0), "duration"),
        (dict(duration=0.01, fs=0.0), "fs"),
        (dict(duration=0.01, speed=-1.0), "speed"),
        (dict(duration=0.01, profile="sine"), "SurfaceProfile"),
        (dict(duration=0.01, contact="sticky"), "contact"),
        (dict(duration=0.01, x0=[0.0, 0.0]), "x0"),
    ],
)
def test_bad_input_rejected(kwargs, match):
    with pytest.raises(InputError, match=match):
        simulate(LV, mu=0.4, **kwargs)


def test_bad_profiles_rejected():
    with pytest.raises(InputError, match="wavelength"):
        SineRunOut(1e-5, -1.0)
    with pytest.raises(InputError, match="increasing"):
        SampledProfile([0, 2, 1, 3], [0, 0, 0, 0])
    with pytest.raises(InputError, match="rng"):
        RandomRoughness.draw(rms=1e-6, wavelength_min=1e-4, wavelength_max=1e-3, rng=None)


def test_flat_disc_envelope_grows_at_sigma():
    # On a flat disc the coefficients are constant: the vibration must grow at exactly the
    # damped eigenvalue's real part (paper eq. 8); mu = 0.6 gives sigma ~ 16.8 1/s.
    ds = simulate(LV, mu=0.6, duration=0.15, fs=20_000, perturbation=1e-9, rng=np.random.default_rng(1))
    (stage,) = transient_summary(ds)["stages"]
    assert stage["stage"] == "flat"
    assert stage["rate_per_s"] == pytest.approx(float(ds.growth_rate[0]), rel=0.05)


# -- streaming (issue #15: long runs must not be held in memory) -------------------------------------

# the driver of the compiled integrators, whose chunk sizes these tests cut small
_SIM = importlib.import_module("squealkit.transient._driver")


@pytest.mark.parametrize(("method", "contact"), [("dopri5", "nonlinear"), ("rk4", "linear")])
def test_streamed_run_equals_the_one_shot_run_bit_for_bit(tmp_path, monkeypatch, method, contact):
    # several integrator chunks (97 samples) cut into blocks of 64 that straddle them: the state carries
    # over, and the written file is the one-shot run's, to the last bit (events and attributes included)
    monkeypatch.setattr(_SIM, "_CHUNK_SAMPLES", 97)
    monkeypatch.setattr(_SIM, "_CHUNK_STEPS", 4 * 97)
    kw = dict(mu=0.6, profile=FIG4, duration=0.01, method=method, contact=contact)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TensileContactWarning)
        one = simulate(LV, **kw)
        blocks = simulate_blocks(LV, block_samples=64, **kw)
        save_blocks(blocks, tmp_path / "s.nc")
    assert [b for b in os.listdir(tmp_path)] == ["s.nc"]
    save_dataset(one, tmp_path / "one.nc")
    streamed, whole = load_dataset(tmp_path / "s.nc"), load_dataset(tmp_path / "one.nc")
    # sigma(t) comes from eigenvalue solves over each block's distinct slopes; near the lock-in they
    # agree to 4e-13 relative (measured), not to the bit. Everything the integrator wrote is bit-exact.
    np.testing.assert_allclose(streamed.growth_rate, whole.growth_rate, rtol=0, atol=1e-12 * 50)
    xr.testing.assert_identical(streamed.drop_vars("growth_rate"), whole.drop_vars("growth_rate"))
    if method == "dopri5":
        assert one.attrs["events"] > 0 and "event_time" in one  # the events came through the last block


def test_integrator_chunks_carry_the_state(monkeypatch):
    # RK4 has a fixed step: cutting it in chunks changes nothing. Dormand-Prince ends a step at each
    # chunk's end, so its steps differ; the result stays within the error control's tolerance.
    kw = dict(mu=0.4, profile=FIG4, duration=0.01)
    whole = {m: simulate(LV, method=m, **kw) for m in ("rk4", "dopri5")}
    monkeypatch.setattr(_SIM, "_CHUNK_SAMPLES", 50)
    monkeypatch.setattr(_SIM, "_CHUNK_STEPS", 200)
    cut = {m: simulate(LV, method=m, **kw) for m in ("rk4", "dopri5")}
    np.testing.assert_array_equal(cut["rk4"].x1_ddot, whole["rk4"].x1_ddot)
    scale = float(abs(whole["dopri5"].x1_ddot).max())
    assert float(abs(cut["dopri5"].x1_ddot - whole["dopri5"].x1_ddot).max()) < 1e-6 * scale  # measured 3e-9


def test_streaming_memory_does_not_grow_with_the_duration(monkeypatch):
    # every array the streamed run allocates for its outputs holds one integrator chunk (here 100
    # samples), and every block at most block_samples, whatever the duration (4000 samples here);
    # the peak RSS of a CLI run is measured in the report of issue #15 (flat from 10 s to 1000 s)
    monkeypatch.setattr(_SIM, "_CHUNK_SAMPLES", 100)
    shapes = []
    buffers = _SIM._buffers
    monkeypatch.setattr(_SIM, "_buffers", lambda R, m, n: shapes.append(m) or buffers(R, m, n))
    sizes = [b.sizes["time"] for b in simulate_blocks(LV, mu=0.4, profile=FIG4, duration=0.1, block_samples=150)]
    assert sum(sizes) == 4001 and max(sizes) <= 150
    assert len(shapes) > 30 and max(shapes) <= 101


def test_in_memory_run_that_will_not_fit_is_refused_and_streaming_is_not(monkeypatch):
    from squealkit import _validation

    monkeypatch.setattr(_validation, "available_memory", lambda: 1 << 20)  # 1 MiB
    with pytest.raises(InputError, match=r"needs about .* simulate_blocks"):
        simulate(LV, mu=0.4, duration=0.1)
    n = sum(b.sizes["time"] for b in simulate_blocks(LV, mu=0.4, duration=0.1, block_samples=1000))
    assert n == 4001


def test_output_rate_below_the_fastest_mode_warns():
    # the paper's model has its highest mode at 10.5 kHz (the pin's tensile mode, 8653 Hz on its own):
    # fs = 1 kHz samples the 2.4 kHz squeal aliased (peak |a| 45 instead of 421 m/s^2)
    with pytest.warns(AliasingWarning, match="sampled, not filtered"):
        simulate(LV, mu=0.4, duration=0.002, fs=1000)
    with warnings.catch_warnings():
        warnings.simplefilter("error", AliasingWarning)
        simulate(LV, mu=0.4, duration=0.002, fs=25_000)

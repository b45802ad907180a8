"""A user's own files and values: the model's damping used, one model per file, units that mean what they say.

Issue 27 ("Silent defaults and one model per file", "Units"). References: the damped and undamped
onsets are the stability engine's own (tests/test_stability.py checks it against LAPACK); the rig's
stiffnesses are ``k = m (2 pi f)^2`` (paper §3); units are converted by pint.
"""

from __future__ import annotations

import json
import math
import warnings

import numpy as np
import pytest

from squealkit import InputError

#: The paper's model with one strong damper beside k1 only: stable undamped at mu = 0.3 (the undamped
#: onset is mu = 0.4448, paper §3), unstable with its damping from mu = 0.0378 on (unequal modal damping
#: destabilises mode coupling).
DAMPED_RIG = 'preset = "lv2013"\n[parameters]\nc1 = 2000.0\nc2 = 0.0\nc3 = 0.0\n'


@pytest.fixture()
def damped_rig(tmp_path):
    p = tmp_path / "damped.toml"
    p.write_text(DAMPED_RIG)
    return p


# -- 1. the model's damping is used unless --undamped ---------------------------------------------------


def test_stability_uses_the_models_damping_by_default(run, damped_rig):
    r = run("stability", "--config", str(damped_rig), "--mu", "0.3", "--theta", "0", "--json")
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout)
    assert out["damped"] is True and out["unstable_fraction"] == 1.0
    r = run("stability", "--config", str(damped_rig), "--mu", "0.3", "--theta", "0", "--undamped", "--json")
    assert r.exit_code == 0, r.output
    assert json.loads(r.stdout)["unstable_fraction"] == 0.0
    # leaving the model's damping out is said in one line
    assert "damping" in r.stderr and "left out" in r.stderr and len(r.stderr.strip().splitlines()) == 1


def test_critical_rig_and_montecarlo_use_the_models_damping(run, damped_rig, tmp_path):
    r = run("critical", "--config", str(damped_rig), "--mu-max", "0.8", "--json")
    assert r.exit_code == 0, r.output
    assert json.loads(r.stdout)["mu_critical"] == pytest.approx(0.0378, abs=1e-3)
    r = run("critical", "--config", str(damped_rig), "--damped", "--mu-max", "0.8", "--json")  # old flag: a no-op
    assert r.exit_code == 0 and json.loads(r.stdout)["mu_critical"] == pytest.approx(0.0378, abs=1e-3)
    r = run("critical", "--config", str(damped_rig), "--undamped", "--json")
    assert json.loads(r.stdout)["mu_critical"] == pytest.approx(0.4448, abs=1e-3)   # paper §3
    unc = tmp_path / "unc.toml"
    unc.write_text(DAMPED_RIG + '[uncertain]\nk3 = {dist = "normal", mean = 9.452e8, std = 1e6}\n')
    r = run("montecarlo", "--config", str(unc), "--samples", "16", "--mu", "0.3", "--no-sensitivity", "--json")
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout)
    assert out["damped"] is True and out["probability_unstable"] == [1.0]


def test_api_warns_when_a_damped_model_is_analysed_undamped():
    from squealkit.models import get_preset
    from squealkit.stability import critical_friction, stability_map

    model = get_preset("lv2013")
    with pytest.warns(UserWarning, match="damping .* left out"):
        critical_friction(model)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        critical_friction(model, damped=False)          # asked for: no warning
        stability_map(model.undamped(), [0.3], [0.0])   # nothing left out: no warning


# -- 2. one file, one model ----------------------------------------------------------------------------

RIG_WITH_PARAMETERS = """
[rig]
pin_diameter = 0.028
pin_length = 0.045
disc_freq = 2346.0
pin_axial_freq = 8653.0
pin_bending_freq = 2500.0
preload = "contact_force"
P = 20.0
[parameters]
alpha_deg = 3.0
c1 = 0.0
c2 = 0.0
c3 = 0.0
"""


def test_rig_and_critical_give_one_model_from_one_file(run, tmp_path):
    cfg = tmp_path / "rig.toml"
    cfg.write_text(RIG_WITH_PARAMETERS)
    r = run("rig", "--config", str(cfg), "--json")
    assert r.exit_code == 0, r.output
    rig_out = json.loads(r.stdout)
    r = run("critical", "--config", str(cfg), "--json")
    assert r.exit_code == 0, r.output
    assert rig_out["mu_crit"] == pytest.approx(json.loads(r.stdout)["mu_critical"], rel=1e-9)
    # the static contact force is the requested 20 N at the file's alpha (3 deg), not at the default 2 deg
    assert rig_out["static_contact_force"] == pytest.approx(20.0, rel=1e-9)


def test_parameters_of_the_rig_reach_the_rig_and_the_model(tmp_path):
    from squealkit.models import load_model, load_rig

    cfg = tmp_path / "rig.toml"
    cfg.write_text("[rig]\ndisc_freq = 2346.0\n[parameters]\nP = 56.8\nalpha_deg = 3.0\n")
    model, rig = load_model(cfg), load_rig(cfg)
    assert model.P == rig.P == 56.8
    assert model.alpha == rig.alpha == pytest.approx(math.radians(3.0))
    # --set overrides go the same way
    from squealkit.models import build_model

    cfg.write_text(RIG_WITH_PARAMETERS)
    m = build_model(config=cfg, overrides={"alpha_deg": 5.0})
    assert float(m.static_contact_force(0.0)) == pytest.approx(20.0, rel=1e-9)


# -- 3. [uncertain] takes what a rig engineer measures --------------------------------------------------

RIG_UNCERTAIN = """
[rig]
pin_bending_freq = 2561.0
pin_axial_freq = 8653.0
[parameters]
c1 = 0.0
c2 = 0.0
c3 = 0.0
[uncertain]
disc_freq = {dist = "uniform", lower = 2300.0, upper = 2400.0}
pin_diameter = {dist = "normal", mean = 0.030, std = 0.0003}
"""


def test_uncertain_rig_quantities_are_sampled_through_the_rig(run, tmp_path):
    from squealkit.models import load_model, load_rig_model
    from squealkit.stability import critical_friction
    from squealkit.uncertainty import load_uncertain, squeal_propensity

    cfg = tmp_path / "rig.toml"
    cfg.write_text(RIG_UNCERTAIN)
    rig = load_rig_model(cfg)
    unc = load_uncertain(cfg, rig)
    assert load_uncertain(cfg) == unc   # the file's own rig by default
    ds = squeal_propensity(load_model(cfg), unc, np.linspace(0.1, 0.8, 141), samples=8, sensitivity=False,
                           damped=False, rig=rig)
    assert list(ds.parameter_unit.values) == ["Hz", "m"]
    # each sample is the model derived from its own rig (k3 = m2 (2 pi f)^2, kc = E A / L): its onset is
    # the one critical_friction finds for that rig, to the grid's resolution (0.005)
    f, d = ds.parameter_value.values[0]
    ref = critical_friction(rig.rig.__class__.paper(disc_freq=f, pin_diameter=d, c1=0.0, c2=0.0, c3=0.0).to_model(),
                            damped=False)
    assert float(ds.mu_critical[0]) == pytest.approx(ref.mu_critical, abs=5e-3)
    assert np.ptp(ds.mu_critical.values) > 0.01    # the disc frequency moves the onset
    r = run("montecarlo", "--config", str(cfg), "--samples", "8", "--mu", "0.3:0.6:7", "--no-sensitivity",
            "--json")
    assert r.exit_code == 0, r.output
    # without a [rig] table the message says what is missing
    cfg.write_text('preset = "lv2013"\n[uncertain]\ndisc_freq = {dist = "normal", mean = 2346.0, std = 10.0}\n')
    r = run("montecarlo", "--config", str(cfg), "--samples", "8")
    assert r.exit_code == 2 and "rig quantity" in r.stderr and "[rig] table" in r.stderr


# -- 6. a CSV's sample rate from its whole time column ---------------------------------------------------


@pytest.fixture(scope="module")
def rounded_time_csv(tmp_path_factory):
    """1 s at 48 kHz, a 2900 Hz tone (1 Pa), times written with 7 decimals (steps of 2.08e-5 or 2.09e-5 s)."""
    fs, n = 48000.0, 48000
    t = np.arange(n) / fs
    f = tmp_path_factory.mktemp("fs") / "rounded.csv"
    f.write_text("time [s],mic [Pa]\n" + "".join(f"{a:.7f},{b:.9g}\n" for a, b in
                                                 zip(t, np.sin(2 * np.pi * 2900.0 * t), strict=True)))
    return f


def test_csv_sample_rate_is_the_least_squares_slope_of_its_time_column(rounded_time_csv):
    from squealkit.measurement import open_recording, read_recording

    src = open_recording(rounded_time_csv)
    # the time base is exactly 48 kHz; rounding to 1e-7 s leaves it unbiased over 48000 samples
    assert src.fs == pytest.approx(48000.0, rel=1e-6)
    ds = read_recording(rounded_time_csv)
    assert ds.attrs["fs"] == pytest.approx(48000.0, rel=1e-6)
    # the jitter is the rounding: uniform over +-0.5e-7 s, RMS 1e-7 / sqrt(12) = 2.9e-8 s
    assert ds.attrs["time_jitter_rms"] == pytest.approx(1e-7 / math.sqrt(12), rel=0.1)
    # an in-memory recording with the same rounded time coordinate and no fs attribute: the same
    from squealkit.measurement.analysis.framing import _DatasetSource

    mem = ds.drop_attrs().assign_coords(time=np.round(ds["time"].values, 7))
    assert _DatasetSource(mem, None).fs == pytest.approx(48000.0, rel=1e-6)
    spec = np.abs(np.fft.rfft(ds["mic"].values))
    freq = np.fft.rfftfreq(ds.sizes["time"], 1.0 / ds.attrs["fs"])
    assert freq[np.argmax(spec)] == pytest.approx(2900.0, abs=0.5)   # was 2904.6 Hz from the median step


def test_csv_with_a_jittery_time_column_warns(tmp_path):
    from squealkit.measurement import open_recording

    rng = np.random.default_rng(1)
    t = np.arange(2000) / 1000.0 + rng.uniform(-2e-4, 2e-4, 2000)   # +-0.2 sample intervals of jitter
    f = tmp_path / "jitter.csv"
    f.write_text("time,mic\n" + "".join(f"{a:.9f},1\n" for a in t))
    with pytest.warns(UserWarning, match="jitter"):
        src = open_recording(f)
    assert src.fs == pytest.approx(1000.0, rel=1e-3)


# -- 4. channel units applied where a channel is read ----------------------------------------------------


@pytest.fixture(scope="module")
def recording_in_um(tmp_path_factory):
    """The synthetic rig recording (squeal at 2388 Hz) as CSV twice: the probe in m, and in um."""
    from squealkit.measurement import synthetic_recording

    rec = synthetic_recording(duration=0.5, seed=1)
    t, p, q = rec["time"].values, rec["mic"].values, rec["displacement"].values
    d = tmp_path_factory.mktemp("units")
    si, um = d / "si.csv", d / "um.csv"
    rows = list(zip(t, p, q, strict=True))
    si.write_text("time [s],mic [Pa],probe [m]\n" + "".join(f"{a:.9g},{b:.9g},{c:.9g}\n" for a, b, c in rows))
    um.write_text("time [s],mic [Pa],probe [um]\n" + "".join(f"{a:.9g},{b:.9g},{c * 1e6:.9g}\n" for a, b, c in rows))
    return si, um


def test_channel_units_from_the_header_and_unit_option_are_applied(recording_in_um, tmp_path):
    from squealkit.measurement import open_recording, read_recording

    si, um = recording_in_um
    a, b = read_recording(si), read_recording(um)
    assert b["probe"].attrs["units"] == "m" and b["probe"].attrs["file_units"] == "um"
    np.testing.assert_allclose(b["probe"].values, a["probe"].values, rtol=1e-8, atol=1e-15)
    # --unit (units=) says it for a file whose header does not
    bare = tmp_path / "bare.csv"
    bare.write_text(um.read_text().replace("probe [um]", "probe"))
    src = open_recording(bare, units={"probe": "um"})
    assert src.units["probe"] == "m" and src.scales["probe"] == 1e-6
    # an in-memory recording with a probe in mm is analysed in metres too
    from squealkit.measurement.analysis.framing import _DatasetSource

    ds = a.copy()
    ds["probe"] = ds["probe"] * 1e3
    ds["probe"].attrs["units"] = "mm"
    blk = next(_DatasetSource(ds, None).iter_blocks(["probe"]))[1]["probe"]
    np.testing.assert_allclose(blk, a["probe"].values[: blk.size], rtol=1e-12)


def test_analyze_reports_the_runout_of_a_probe_in_um_in_metres(run, recording_in_um):
    out = {}
    for f in recording_in_um:
        r = run("analyze", str(f), "--mic", "mic", "--displacement", "probe", "--rpm", "900", "--radius", "0.05",
                "--json")
        assert r.exit_code == 0, r.output
        out[f.stem] = json.loads(r.stdout)["runout"]
    # the same run-out whichever unit the file is written in (was 1e6 times larger: "40.8 m p-p")
    assert out["um"]["sro_p2p_m"] == pytest.approx(out["si"]["sro_p2p_m"], rel=1e-6)
    assert out["um"]["max_tan_theta"] == pytest.approx(out["si"]["max_tan_theta"], rel=1e-6)
    assert out["si"]["sro_p2p_m"] < 1e-3


# -- 5. values with units, and unit slips refused ---------------------------------------------------------


def test_model_files_take_values_with_units(tmp_path):
    from squealkit.models import PinOnDiscRig, load_model

    cfg = tmp_path / "rig.toml"
    cfg.write_text('[rig]\npin_diameter = "30 mm"\npin_length = "45 mm"\ndisc_freq = "2.346 kHz"\n'
                   'pin_youngs_modulus = "2.95 GPa"\npin_density = "1.04 g/cm^3"\npin_bending_freq = "2561 Hz"\n'
                   'pin_axial_freq = "8.653 kHz"\n[parameters]\nalpha_deg = 2.0\nc1 = "220 N s/m"\n')
    # the same model as the paper's rig in SI (Table 1 frequencies), to rounding
    ref = PinOnDiscRig.paper().to_model()
    m = load_model(cfg)
    for k, v in ref.parameters().items():
        assert getattr(m, k) == (pytest.approx(v, rel=1e-12) if isinstance(v, float) else v), k


@pytest.mark.parametrize(("table", "says"), [
    ("disc_freq = 3.15", "did you mean 3.15 kHz? write '3.15 kHz'"),
    ("pin_diameter = 15", "did you mean 15 mm? write '15 mm'"),
    ("pin_youngs_modulus = 2.95", "did you mean 2.95 GPa?"),
    ('pin_diameter = "15 Hz"', "is not in a unit of 'm'"),
])
def test_unit_slips_in_a_rig_table_are_refused_naming_the_slip(run, tmp_path, table, says):
    cfg = tmp_path / "rig.toml"
    cfg.write_text(f"[rig]\n{table}\n")
    r = run("rig", "--config", str(cfg))
    assert r.exit_code == 2 and says in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.output


def test_set_takes_a_unit_and_parameters_convert_to_their_declared_unit():
    from squealkit.models import build_model, parse_assignments

    m = build_model(overrides=parse_assignments(["m1=33 g", "c1=0.22 kN s/m", "alpha_deg=3"]))
    assert (m.m1, m.c1, m.alpha) == (0.033, 220.0, pytest.approx(math.radians(3.0)))
    with pytest.raises(InputError, match="not in a unit of 'kg'"):
        build_model(overrides={"m1": "33 Hz"})


def test_cli_lengths_take_units_and_refuse_unit_slips(run, recording_in_um):
    si = recording_in_um[0]
    r = run("analyze", str(si), "--mic", "mic", "--displacement", "probe", "--rpm", "900", "--radius", "60")
    assert r.exit_code == 2 and "did you mean 60 mm? write '60 mm'" in r.stderr, r.output
    r = run("simulate", "--mu", "0.3", "--sro-amplitude", "80", "--duration", "0.001")
    assert r.exit_code == 2 and "did you mean 80 um? write '80 um'" in r.stderr, r.output
    r = run("simulate", "--mu", "0.3", "--sro-amplitude", "80 um", "--duration", "0.002", "--json")
    assert r.exit_code == 0, r.output
    from squealkit.models import PinOnDiscRig

    # a declared length given as text with its unit, as the CLI's options and model files take it
    assert PinOnDiscRig(pin_diameter="60 mm").pin_diameter == 0.06
    assert PinOnDiscRig(pin_diameter="30000 µm").pin_diameter == pytest.approx(0.03, rel=1e-15)


def test_tolerance_wavelength_takes_its_unit_and_names_a_slip(run):
    # issue #27 (units): "--wavelength 1 mm" must mean 1e-3 m, as --sro-wavelength does in simulate and
    # floquet; a bare 50 (mm typed as m) is named as the likely slip instead of a 50 m wavelength
    import json

    mm = run("tolerance", "--mu", "0.3", "--wavelength", "1 mm", "--undamped", "--json")
    si = run("tolerance", "--mu", "0.3", "--wavelength", "0.001", "--undamped", "--json")
    assert mm.exit_code == 0 and si.exit_code == 0, (mm.output, si.output)
    assert json.loads(mm.stdout) == json.loads(si.stdout)
    slip = run("tolerance", "--mu", "0.3", "--wavelength", "50", "--undamped")
    assert slip.exit_code == 2 and "mm" in slip.stderr and len(slip.stderr.strip().splitlines()) == 1

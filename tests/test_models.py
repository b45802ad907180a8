"""Models: the paper's matrices, parameters from the rig, presets and model files."""

import math
from pathlib import Path

import numpy as np
import pytest

from squealkit import InputError
from squealkit.models import (
    Hoffmann2002,
    MatrixModel,
    PinOnDisc3DOF,
    PinOnDiscRig,
    build_model,
    cantilever_bending_frequency,
    contact_stiffness,
    get_preset,
    load_model,
    load_rig,
    modal_stiffness,
    rod_axial_frequency,
    rod_mass,
)
from squealkit.stability import eigenvalues

# Paper §3 (printed values) and Table 1 (FEA frequencies).
PAPER = {"m1": 0.033, "m2": 4.35, "k1": 8.545e6, "k2": 9.755e7, "k3": 9.452e8, "kc": 4.632e7}
F_PIN_BENDING, F_PIN_TENSILE, F_DISC = 2561.0, 8653.0, 2346.0


def test_modal_stiffness_reproduces_paper_section_3():
    # k = m (2 pi f)^2 with the paper's masses and Table 1 frequencies (paper §3).
    assert modal_stiffness(0.033, F_PIN_BENDING) == pytest.approx(PAPER["k1"], rel=5e-4)
    assert modal_stiffness(0.033, F_PIN_TENSILE) == pytest.approx(PAPER["k2"], rel=5e-4)
    assert modal_stiffness(4.35, F_DISC) == pytest.approx(PAPER["k3"], rel=5e-4)


def test_contact_stiffness_and_pin_mass_from_geometry():
    # kc = E A / L = 2.95e9 * pi * 0.015^2 / 0.045 = 4.634e7 N/m; paper prints 4.632e7 (0.04 % apart).
    assert contact_stiffness(0.030, 0.045, 2.95e9) == pytest.approx(4.634e7, rel=2e-4)
    assert contact_stiffness(0.030, 0.045, 2.95e9) == pytest.approx(PAPER["kc"], rel=1e-3)
    # m1 = rho pi d^2/4 L = 0.0331 kg; the paper weighed 0.033 kg (0.25 % apart).
    assert rod_mass(0.030, 0.045, 1040.0) == pytest.approx(0.03308, rel=1e-3)


def test_beam_theories_against_table_1():
    # Table 1 gives FEA 2561 Hz (bending) and 8653 Hz (tensile) for the stubby PA6 pin (L/d = 1.5).
    eb = cantilever_bending_frequency(0.03, 0.045, 2.95e9, 1040.0, theory="euler_bernoulli")
    ti = cantilever_bending_frequency(0.03, 0.045, 2.95e9, 1040.0, poisson=0.35, theory="timoshenko")
    ax = rod_axial_frequency(0.045, 2.95e9, 1040.0)
    # Euler-Bernoulli closed form: 1.8751^2 sqrt(EI / (rho A L^4)) / 2 pi = 3491 Hz, 36 % above FEA.
    assert eb == pytest.approx(3491.0, abs=1.0)
    assert eb / F_PIN_BENDING - 1 == pytest.approx(0.363, abs=0.005)
    # Timoshenko (shear + rotary inertia) lands 11.5 % above FEA: much closer, still stiff.
    assert ti / F_PIN_BENDING - 1 == pytest.approx(0.115, abs=0.01)
    assert F_PIN_BENDING < ti < eb
    # Quarter-wave rod sqrt(E/rho)/(4L) = 9357 Hz, 8.1 % above FEA.
    assert ax == pytest.approx(9357.0, abs=1.0)


def test_timoshenko_tends_to_euler_bernoulli_for_slender_beams():
    for slenderness in (20.0, 100.0):
        eb = cantilever_bending_frequency(0.01, 0.01 * slenderness, 2e11, 7800.0, theory="euler_bernoulli")
        ti = cantilever_bending_frequency(0.01, 0.01 * slenderness, 2e11, 7800.0, theory="timoshenko")
        assert ti < eb
        assert ti == pytest.approx(eb, rel=3.0 / slenderness**2 * 10)


def test_rig_model_lands_near_paper_preset():
    rig_model = PinOnDiscRig.paper().to_model()
    preset = get_preset("lv2013")
    for name, value in PAPER.items():
        assert getattr(rig_model, name) == pytest.approx(value, rel=3e-3), name
    assert rig_model.alpha == preset.alpha and rig_model.sliding == preset.sliding


def test_rig_with_beam_theory_when_frequencies_not_given():
    rig = PinOnDiscRig(pin_bending_freq=None, pin_axial_freq=None, pin_bending_theory="euler_bernoulli")
    m = rig.to_model()
    assert m.k1 == pytest.approx(modal_stiffness(rig.pin_mass(), 3490.61), rel=1e-4)


def test_stiffness_matrix_is_eq_4_as_printed():
    m = PinOnDisc3DOF(sliding=1)
    mu, th = 0.3, math.radians(5.0)
    t = math.tan(th)
    s, c = math.sin(m.alpha), math.cos(m.alpha)
    k1, k2, k3, kc = m.k1, m.k2, m.k3, m.kc
    e, g = mu + t, 1 - mu * t
    K_paper = np.array([
        [k1 + k2 * s * s, k2 * c * s - kc * e, kc * e],
        [k2 * c * s, k2 * c * c + kc * g, -kc * g],
        [0.0, -kc * g, k3 + kc * g],
    ])
    np.testing.assert_allclose(m.stiffness_matrix(mu, t), K_paper, rtol=1e-14)
    q = 1e-5
    F_paper = np.array([-kc * q * e, kc * q * g - m.P, -kc * q * g])
    np.testing.assert_allclose(m.load_vector(mu, t, q), F_paper, rtol=1e-14)


def test_reversed_sliding_equals_mirrored_pin_incline():
    # sliding = -1 gives the eigenvalues of eq. (4) with alpha -> -alpha (the mirror image).
    mu = np.linspace(0, 0.8, 9)
    a = eigenvalues(PinOnDisc3DOF(sliding=-1), mu, tan_theta=0.05)
    b = eigenvalues(PinOnDisc3DOF(sliding=1, alpha=-math.radians(2.0)), mu, tan_theta=0.05)
    np.testing.assert_allclose(a, b, rtol=1e-10)


def test_stiffness_matrix_is_vectorised():
    m = get_preset("lv2013")
    K = m.stiffness_matrix(np.zeros((4, 5)), np.zeros((4, 5)))
    assert K.shape == (4, 5, 3, 3)
    np.testing.assert_allclose(K[2, 3], m.stiffness_matrix(0.0, 0.0))


def test_matrix_model_matches_hoffmann():
    h = Hoffmann2002()
    K0, Kn, Kf = h.stiffness_parts()
    mm = MatrixModel(M=h.mass_matrix(), K0=K0, Kn=Kn, Kf=Kf)
    mu = np.linspace(0, 0.5, 11)
    np.testing.assert_allclose(eigenvalues(mm, mu), eigenvalues(h, mu), rtol=1e-12)


def test_undamped_zeroes_damping_only():
    m = get_preset("lv2013")
    u = m.undamped()
    assert np.all(u.damping_matrix() == 0)
    np.testing.assert_array_equal(u.stiffness_matrix(0.4, 0.1), m.stiffness_matrix(0.4, 0.1))


@pytest.mark.parametrize(
    "changes, message",
    [
        ({"m1": -1.0}, "m1=-1.0 must be > 0"),
        ({"k3": 0.0}, "k3=0.0 must be > 0"),
        ({"c1": -5.0}, "c1=-5.0 must be >= 0"),
        ({"kc": float("nan")}, "kc=nan must be finite"),
        ({"alpha_deg": 90.0}, "between -90 and 90 deg"),
        ({"sliding": 0}, r"must be \+1 or -1"),
        ({"nope": 1.0}, "Unknown parameter 'nope'"),
        ({"m2": "heavy"}, "is not a number"),
    ],
)
def test_invalid_parameters_are_named(changes, message):
    with pytest.raises(InputError, match=message):
        get_preset("lv2013").replace(**changes)


def test_matrix_model_rejects_non_spd_mass():
    with pytest.raises(InputError, match="positive definite"):
        MatrixModel(M=[[1.0, 0.0], [0.0, -1.0]], K0=np.eye(2))
    with pytest.raises(InputError, match="symmetric"):
        MatrixModel(M=[[1.0, 0.5], [0.0, 1.0]], K0=np.eye(2))
    with pytest.raises(InputError, match="square"):
        MatrixModel(M=[[1.0, 0.0]], K0=np.eye(2))


def test_model_file_preset_overrides_and_rig(tmp_path):
    f = tmp_path / "rig.toml"
    f.write_text('preset = "lv2013"\n[parameters]\nalpha_deg = 3.0\nc1 = 0.0\n')
    m = load_model(f)
    assert m.alpha == pytest.approx(math.radians(3.0)) and m.c1 == 0.0 and m.k1 == PAPER["k1"]
    g = tmp_path / "myrig.toml"
    g.write_text("[rig]\npin_diameter = 0.025\npin_length = 0.05\ndisc_freq = 2400.0\n")
    r = load_model(g)
    assert r.kc == pytest.approx(contact_stiffness(0.025, 0.05, 2.95e9))
    h = tmp_path / "matrix.toml"
    h.write_text('model = "matrix"\n[matrices]\nM = [[1.0, 0.0], [0.0, 1.0]]\nK0 = [[2.0e6, 1.0e5], [1.0e5, 1.0e6]]\n'
                 'Kf = [[0.0, -8.0e5], [0.0, 0.0]]\nnames = ["u", "v"]\n')
    mm = load_model(h)
    assert mm.dof_names == ("u", "v")


@pytest.mark.parametrize(
    "text, message",
    [
        ("[parameters\n", "not valid TOML"),
        ('model = "banana"\n', "Unknown model 'banana'"),
        ("[parameters]\nm1 = -3.0\n", "m1=-3.0 must be > 0"),
        ("[rig]\npin_diamter = 0.03\n", "Unknown \\[rig\\] key 'pin_diamter'"),
        ("typo = 1\n", "Unknown top-level key 'typo'"),
        ('model = "matrix"\n', "needs a \\[matrices\\] table"),
    ],
)
def test_bad_model_files(tmp_path, text, message):
    f = tmp_path / "bad.toml"
    f.write_text(text)
    with pytest.raises(InputError, match=message):
        load_model(f)


def test_missing_model_file():
    with pytest.raises(InputError, match="does not exist"):
        build_model(config="/definitely/not/here.toml")


# -- rigs derived right (issue 12) --------------------------------------------------------------
# Reference values: Timoshenko bending of the paper's pin (d 30 mm, L 45 mm, PA6) 2855.9 Hz and the
# quarter-wave rod 9356.7 Hz (NOTES: Euler-Bernoulli 3491 Hz, rod 9357 Hz); the mu_crit of
# examples/myrig.toml with beam theory applied, 1.127, and of the all-theory rig, 1.57.


def test_rig_table_without_pin_frequencies_uses_beam_theory(tmp_path):
    f = tmp_path / "rig.toml"
    f.write_text("[rig]\npin_diameter = 0.030\npin_length = 0.045\n")
    m = load_model(f)
    rig = PinOnDiscRig()
    assert m.k1 == pytest.approx(modal_stiffness(rig.pin_mass(), 2855.9), rel=1e-4)
    assert m.k2 == pytest.approx(modal_stiffness(rig.pin_mass(), 9356.7), rel=1e-4)
    src = rig.frequency_sources()
    assert src["pin_bending"]["source"].startswith("Timoshenko")
    assert src["pin_axial"]["source"].startswith("quarter-wave")
    assert src["disc"]["source"] == "given"
    assert PinOnDiscRig.paper().frequency_sources()["pin_bending"] == {"frequency_hz": 2561.0, "source": "given"}


@pytest.mark.parametrize(("value", "freq", "source"), [
    ('"timoshenko"', 2855.9, "Timoshenko"), ('"euler_bernoulli"', 3490.6, "Euler-Bernoulli"),
    ("2600.0", 2600.0, "given"),
])
def test_rig_table_names_the_bending_theory(tmp_path, value, freq, source):
    f = tmp_path / "rig.toml"
    f.write_text(f"[rig]\npin_bending_freq = {value}\npin_axial_freq = \"rod\"\n")
    rig = load_rig(f)
    assert rig.bending_freq() == pytest.approx(freq, abs=0.1)
    assert rig.frequency_sources()["pin_bending"]["source"].startswith(source)
    assert "Hz (" in rig.describe()


def test_rig_rejects_an_unknown_theory(tmp_path):
    f = tmp_path / "rig.toml"
    f.write_text('[rig]\npin_bending_freq = "rayleigh"\n')
    with pytest.raises(ValueError, match="pin_bending_freq='rayleigh' must be a frequency"):
        load_model(f)


def test_example_rig_needs_unrealistic_friction_and_says_so():
    from squealkit.stability import UnrealisticFrictionWarning, critical_friction

    mine = load_model(Path(__file__).parents[1] / "examples" / "myrig.toml")
    with pytest.warns(UnrealisticFrictionWarning, match="mu_crit = 1.127"):
        assert critical_friction(mine).mu_critical == pytest.approx(1.1270, abs=1e-4)
    with pytest.warns(UnrealisticFrictionWarning, match="mu_crit = 1.57"):
        critical_friction(PinOnDiscRig().to_model().undamped())


def test_rig_modal_mass_and_preload_options():
    paper = PinOnDiscRig.paper()
    assert paper.to_model().m1 == pytest.approx(paper.pin_mass())  # the paper's choice: the whole pin
    tip = PinOnDiscRig.paper(pin_mass_factor=0.25).to_model()
    assert tip.m1 == pytest.approx(0.25 * paper.pin_mass())
    assert tip.k1 == pytest.approx(tip.m1 * (2 * math.pi * 2561.0) ** 2)  # frequencies kept
    # the paper's P = 10 N on the pin gives ~3 N of contact force (NOTES); preload="contact_force" gives 10 N
    assert float(paper.to_model().static_contact_force(0.0)) == pytest.approx(3.15, abs=0.01)
    force = PinOnDiscRig.paper(preload="contact_force").to_model().static_contact_force(0.0)
    assert float(force) == pytest.approx(10.0)
    with pytest.raises(ValueError, match="preload"):
        PinOnDiscRig(preload="bolted")

"""Speed-dependent (Stribeck) friction in the stability analysis, against closed forms and the transient solver."""

import json
import math

import numpy as np
import pytest
from click.testing import CliRunner
from scipy.signal import find_peaks

from squealkit import InputError
from squealkit.cli.main import cli
from squealkit.models import Hoffmann2002, MatrixModel, get_preset
from squealkit.models.friction import Stribeck, point_contact
from squealkit.solvers import ode as transient_kernels
from squealkit.stability import critical_friction, eigenvalues, runout_tolerance, stability_map
from squealkit.stability.eigen import stability_verdict
from squealkit.transient import Contact, simulate


def mass_on_belt(*, m=0.5, kx=2.0e5, ky=3.0e5, kc=1.0e6, c=4.0, P=5.0):
    """A mass pressed on a moving belt: x along the belt, y normal to it; springs kx, ky to
    ground, contact spring kc, preload P, friction along x (f = [-1, 0], b = [0, 1])."""
    return MatrixModel(
        M=m * np.eye(2), C=c * np.eye(2), K0=np.diag([kx, ky]),
        Kn=kc * np.array([[0.0, 0.0], [0.0, 1.0]]), Kf=kc * np.array([[0.0, -1.0], [0.0, 0.0]]),
        F0=[0.0, -P], fn=[0.0, kc], ff=[-kc, 0.0], names=("x", "y"),
    )


# -- closed forms ------------------------------------------------------------------------


@pytest.mark.parametrize("speed", [2e-3, 5e-3, 1e-2, 3e-2])  # sigma = +150.7, +80.9, +27.2, -3.4 1/s
def test_mass_on_belt_matches_the_classic_negative_damping_closed_form(speed):
    # The mass on a belt (Popp & Stelter 1990; Ibrahim, Appl. Mech. Rev. 47 (1994)):
    # m x'' + c x' + kx x = N mu(V - x')  ->  m x'' + (c + N mu'(V)) x' + kx x = N mu(V),
    # so sigma = -(c + N0 mu'(V)) / (2 m) and omega_d = sqrt(kx / m - sigma^2). Here the
    # normal force is the contact spring's static force N0 = kc P / (ky + kc) (y in
    # equilibrium: (ky + kc) y = -P), and K is triangular, so the x mode is exactly that.
    m, kx, ky, kc, c, P = 0.5, 2.0e5, 3.0e5, 1.0e6, 4.0, 5.0
    model = mass_on_belt(m=m, kx=kx, ky=ky, kc=kc, c=c, P=P)
    law = Stribeck(mu_static=0.6, v_stribeck=5e-3)
    mu = 0.3
    N0 = kc * P / (ky + kc)
    slope = -(law.mu_static - mu) / law.v_stribeck * math.exp(-speed / law.v_stribeck)
    sigma = -(c + N0 * slope) / (2 * m)
    omega_d = math.sqrt(kx / m - sigma**2)
    assert float(model.static_contact_force(law.mu(mu, speed))) == pytest.approx(N0, rel=1e-14)
    lam = eigenvalues(model, mu, damped=True, friction=law, speed=speed)
    x_mode = lam[np.argmin(np.abs(lam.imag - omega_d))]
    assert x_mode.real == pytest.approx(sigma, rel=1e-10)
    assert x_mode.imag == pytest.approx(omega_d, rel=1e-12)
    # the y mode does not feel the friction's slope: sigma = -c / (2 m)
    y_mode = lam[np.argmin(np.abs(lam.imag - math.sqrt((ky + kc) / m - (c / (2 * m)) ** 2)))]
    assert y_mode.real == pytest.approx(-c / (2 * m), rel=1e-10)


def test_slope_and_coefficient_of_the_law():
    # d/dv [mu + (mu_s - mu) exp(-v / v_s)] = -(mu_s - mu) / v_s exp(-v / v_s), checked by
    # a central difference; the law is the transient Contact's (contact.py).
    law = Stribeck(0.55, 4e-3)
    v = np.array([1e-3, 4e-3, 2e-2])
    h = 1e-9
    fd = (law.mu(0.3, v + h) - law.mu(0.3, v - h)) / (2 * h)
    np.testing.assert_allclose(law.slope(0.3, v), fd, rtol=1e-6)
    assert Contact(mu_static=0.55, v_stribeck=4e-3).friction_law == law
    np.testing.assert_allclose(law.mu(0.3, 0.0), 0.55)  # static value at rest


@pytest.mark.parametrize("kinematics", ["paper", "consistent"])
def test_linearised_friction_is_the_derivative_of_the_transient_force(kinematics):
    # The transient kernel's force (solvers/ode.py, _rhs) differentiated numerically
    # at the static equilibrium of steady sliding: d acc / d x' = -M^-1 (C + dmu/dv N0 D) and
    # d acc / d x = -M^-1 K(mu(V), tan_theta), with tan_theta != 0 to test the slope terms
    # (with consistent kinematics also the kernel's gap b_t.x against slope_parts).
    model = get_preset("lv2013").replace(kinematics=kinematics)
    law, mu, V, t = Stribeck(0.6, 1e-3), 0.3, 1.5e-3, 0.07
    pc = point_contact(model)
    Minv = np.linalg.inv(model.mass_matrix())
    K0, Kn, Kf = model.stiffness_parts()
    Knx, Kfx = model.slope_parts()
    F0, fn, ff = model.load_parts()
    s = float(model.sliding_direction)
    opts = Contact(mu_static=law.mu_static, v_stribeck=law.v_stribeck).options()
    x_s = model.static_equilibrium(law.mu(mu, V), t, 0.0)

    # the kernel's bundled arrays: [C, K0, Kn, Kf, Knx, Kfx] and [bM, fM, F0, fn, ff, b, fhat], premultiplied by M^-1
    mats = np.stack([Minv @ a for a in (model.damping_matrix(), K0, Kn, Kf, Knx, Kfx)])
    vecs = np.stack([Minv @ pc.b, Minv @ pc.f, Minv @ F0, Minv @ fn, Minv @ ff, pc.b, pc.fhat])

    def acc(x, xd):
        out = np.empty(3)
        transient_kernels._rhs(x, 0, xd, 0, 0.0, t, mu, V, float(model.slope_coupled), pc.kc, s, mats, vecs, opts,
                               out)
        return out

    np.testing.assert_allclose(acc(x_s, np.zeros(3)), 0.0, atol=1e-9)  # an equilibrium
    dv, dx = 1e-8, 1e-12
    J_v = np.column_stack([(acc(x_s, dv * e) - acc(x_s, -dv * e)) / (2 * dv) for e in np.eye(3)])
    J_x = np.column_stack([(acc(x_s + dx * e, np.zeros(3)) - acc(x_s - dx * e, np.zeros(3))) / (2 * dx)
                           for e in np.eye(3)])
    C_lin = model.damping_matrix() + model.friction_damping(law, mu, t, speed=V)
    np.testing.assert_allclose(J_v, -Minv @ C_lin, rtol=1e-6, atol=1e-6 * np.abs(Minv @ C_lin).max())
    K_lin = model.stiffness_matrix(law.mu(mu, V), t)
    np.testing.assert_allclose(J_x, -Minv @ K_lin, rtol=1e-5, atol=1e-5 * np.abs(Minv @ K_lin).max())


def test_friction_direction_matrix_of_the_paper_model():
    # eq. (4): friction along x1 (f = [-1, 0, 0]), contact approach y1 - y2 (b = [0, 1, -1]);
    # D = (f - s tan_theta b) fhat^T, s = -1 for the preset.
    model = get_preset("lv2013")
    np.testing.assert_array_equal(model.friction_damping_matrix(0.0), np.diag([1.0, 0.0, 0.0]))
    D = model.friction_damping_matrix(0.1)
    np.testing.assert_allclose(D[:, 0], [1.0, -0.1, 0.1])
    np.testing.assert_array_equal(D[:, 1:], 0.0)
    x = model.static_equilibrium(0.4, 0.0)
    assert float(model.static_contact_force(0.4)) == pytest.approx(-model.kc * (x[1] - x[2]), rel=1e-14)


# -- against the transient solver ---------------------------------------------------------

CASES = {
    # the paper's damped rig at a creep speed: negative damping beats c1 = 220 N s/m
    "lv2013 damped, 1.5 mm/s": (get_preset("lv2013"), 0.2, Stribeck(0.6, 1e-3), 1.5e-3, 0.009, (0.003, 0.009)),
    # undamped rig at the paper's speed (0.02 m/s)
    "lv2013 undamped, 20 mm/s": (get_preset("lv2013").replace(c1=0.0, c2=0.0, c3=0.0), 0.2, Stribeck(0.5, 1e-2),
                                 0.02, 0.06, (0.02, 0.06)),
}


@pytest.mark.parametrize("case", list(CASES))
def test_growth_rate_matches_the_transient_simulation(case):
    model, mu, law, V, duration, (t_a, t_b) = CASES[case]
    lam = eigenvalues(model, mu, damped=True, friction=law, speed=V)
    sigma = float(lam.real.max())
    assert sigma > 50.0
    # with the same friction held constant at mu(V) (no slope) the point is not growing:
    # the instability is the falling friction's, not mode coupling
    assert eigenvalues(model, law.mu(mu, V), damped=True).real.max() < 0.05 * sigma
    # The transient solver with the same Stribeck law (permanent contact, friction mu(w) N),
    # from a tiny random start: the log of the peaks of |x1 - x1_eq| grows at sigma once the
    # other modes have decayed. Amplitudes stay far below v_stribeck (a linear response).
    ds = simulate(model, mu=mu, speed=V, duration=duration, fs=100_000, perturbation=1e-14,
                  contact=Contact(mu_static=law.mu_static, v_stribeck=law.v_stribeck), rng=np.random.default_rng(3))
    assert ds.attrs["status"] == "completed"
    assert float(np.abs(ds.x1_dot).max()) < 0.1 * law.v_stribeck
    x = ds.x1.values - model.static_equilibrium(law.mu(mu, V))[0]
    t = ds.time.values
    peaks, _ = find_peaks(np.abs(x))
    peaks = peaks[(t[peaks] >= t_a) & (t[peaks] <= t_b)]
    rate = np.polyfit(t[peaks], np.log(np.abs(x[peaks])), 1)[0]
    assert rate == pytest.approx(sigma, rel=0.02)
    # the transient's own frozen-time growth rate is the same linearisation
    np.testing.assert_allclose(ds.growth_rate.values, sigma, rtol=1e-12)


# -- limits and special cases --------------------------------------------------------------


def test_zero_slope_reduces_to_constant_friction_exactly():
    # At V = 1000 v_stribeck, exp(-V / v_stribeck) underflows to 0: mu(V) = mu and the slope
    # is 0, so the linearisation is the constant-friction model, bit for bit.
    model = get_preset("lv2013")
    law = Stribeck(0.6, 1e-3)
    mu = np.linspace(0.0, 0.8, 33)
    theta = np.radians(np.linspace(-8.0, 8.0, 9))
    ref = stability_map(model, mu, theta, damped=True)
    fast = stability_map(model, mu, theta, damped=True, friction=law, speed=1.0)
    np.testing.assert_array_equal(fast.growth_rate.values, ref.growth_rate.values)
    np.testing.assert_array_equal(fast.omega.values, ref.omega.values)
    np.testing.assert_array_equal(fast.mu_sliding.values, mu)
    assert fast.attrs["speed"] == 1.0 and fast.attrs["mu_static"] == 0.6
    # At V = 40 v_stribeck the slope is ~1e-18 relative: every point has its own (tiny)
    # friction damping and is solved on its own, and still agrees to rounding.
    lam = eigenvalues(model, mu[:, None], tan_theta=np.tan(theta)[None, :], damped=True, friction=law, speed=0.04)
    lam0 = eigenvalues(model, mu[:, None], tan_theta=np.tan(theta)[None, :], damped=True)
    np.testing.assert_allclose(lam, lam0, rtol=1e-11, atol=1e-11 * np.abs(lam0).max())


def test_without_static_contact_force_the_law_only_shifts_mu():
    # Hoffmann's model has no preload (F0 = 0): N0 = 0, so the slope adds no damping and
    # the result is the constant-friction one at mu(V).
    model = Hoffmann2002(c=5.0)
    law, V = Stribeck(0.5, 2e-3), 1e-3
    mu = np.linspace(0.0, 0.4, 41)
    assert np.all(model.friction_damping(law, mu, speed=V) == 0.0)
    np.testing.assert_array_equal(eigenvalues(model, mu, damped=True, friction=law, speed=V),
                                  eigenvalues(model, law.mu(mu, V), damped=True))


def test_falling_friction_lowers_the_critical_friction():
    # lv2013, damped, at the paper's speed: a falling law adds negative damping on x1, so the
    # brake loses stability at a lower kinetic mu than with constant friction (0.3977).
    model = get_preset("lv2013")
    law, V = Stribeck(0.6, 1e-2), 0.02
    base = critical_friction(model, damped=True)
    c = critical_friction(model, damped=True, friction=law, speed=V)
    assert c.status == "onset" and c.mu_critical < base.mu_critical - 0.02
    assert c.mu_e_critical == pytest.approx(float(law.mu(c.mu_critical, V)))
    below, above = c.mu_critical * (1 - 1e-6), c.mu_critical * (1 + 1e-6)
    v = stability_verdict(model, [below, above], damped=True, friction=law, speed=V).tolist()
    assert v == ["stable", "flutter"]
    tol = runout_tolerance(model, 0.9 * c.mu_critical, damped=True, friction=law, speed=V)
    assert tol.stable_on_flat_disc and tol.tan_theta_max > 0


def test_streamed_map_with_friction_equals_the_in_memory_map(tmp_path):
    model = get_preset("lv2013")
    kw = dict(damped=True, friction=Stribeck(0.6, 1e-3), speed=1.5e-3)
    mu, theta = np.linspace(0.0, 0.6, 7), np.radians(np.linspace(-4.0, 4.0, 5))
    ref = stability_map(model, mu, theta, **kw)
    zs = stability_map(model, mu, theta, store=tmp_path / "m.zarr", tile_points=10, **kw)
    np.testing.assert_array_equal(zs.growth_rate.values, ref.growth_rate.values)
    np.testing.assert_array_equal(zs.mu_e.values, ref.mu_e.values)


def test_bad_friction_input_is_rejected_with_a_clear_message():
    model = get_preset("lv2013")
    law = Stribeck(0.6, 1e-3)
    with pytest.raises(InputError, match="needs the sliding speed"):
        eigenvalues(model, 0.2, friction=law)
    with pytest.raises(InputError, match=r"speed=0\.02 only matters with a speed-dependent friction law"):
        eigenvalues(model, 0.2, speed=0.02)
    with pytest.raises(InputError, match=r"speed=-0.1 must be > 0"):
        stability_map(model, [0.2], friction=law, speed=-0.1)
    with pytest.raises(InputError, match="must be a Stribeck law"):
        eigenvalues(model, 0.2, friction=0.5, speed=0.02)
    with pytest.raises(InputError, match=r"v_stribeck=0.0 must be > 0"):
        Stribeck(0.6, 0.0)
    # a matrix model whose contact is not one point (here: no load vectors fn, ff)
    no_point = MatrixModel(M=np.eye(2), K0=np.diag([1e6, 2e6]), Kn=[[0, 0], [0, 1e5]], Kf=[[0, -1e5], [0, 0]])
    with pytest.raises(InputError, match=r"one point contact .* this 'matrix' model has none"):
        eigenvalues(no_point, 0.2, friction=law, speed=0.02)
    with pytest.raises(InputError, match="one point contact"):
        no_point.friction_damping_matrix()


# -- command line ---------------------------------------------------------------------------


def test_cli_stability_and_simulate_agree_with_the_api(run):
    args = ["--stribeck", "0.6,0.001", "--speed", "0.0015"]
    r = run("stability", "--damped", "--mu", "0.2", "--theta", "0", "--json", *args)
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout)
    sigma = float(eigenvalues(get_preset("lv2013"), 0.2, damped=True, friction=Stribeck(0.6, 1e-3),
                              speed=1.5e-3).real.max())
    assert out["max_growth_rate"] == pytest.approx(sigma, rel=1e-12)
    assert out["stribeck"] == {"mu_static": 0.6, "v_stribeck": 0.001} and out["speed"] == 0.0015
    r = run("simulate", "--mu", "0.2", "--sro", "none", "--duration", "0.002", "--json", *args)
    assert r.exit_code == 0, r.output
    sim = json.loads(r.stdout)
    assert "Stribeck" in sim["contact"] and sim["growth_rate_max"] == pytest.approx(sigma, rel=1e-12)


def test_cli_critical_with_stribeck(run):
    r = run("critical", "--damped", "--stribeck", "0.6,0.01", "--speed", "0.02", "--json")
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout)
    ref = critical_friction(get_preset("lv2013"), damped=True, friction=Stribeck(0.6, 0.01), speed=0.02)
    assert out["status"] == "onset" and out["mu_critical"] == pytest.approx(ref.mu_critical, abs=1e-12)
    assert out["stribeck"]["mu_static"] == 0.6 and out["speed"] == 0.02


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["stability", "--speed", "0.1"], "--speed only matters with --stribeck"),
        (["critical", "--stribeck", "0.6"], "--stribeck '0.6' must be MU_STATIC,V_STRIBECK"),
        (["critical", "--stribeck", "a,b"], "must be two numbers MU_STATIC,V_STRIBECK"),
        (["stability", "--stribeck", "0.6,-1"], "Parameter v_stribeck=-1.0 must be > 0"),
        (["stability", "--stribeck", "0.6,0.01", "--speed", "0"], "Parameter speed=0.0 must be > 0"),
    ],
)
def test_cli_bad_friction_options_are_one_line_exit_2(args, message):
    r = CliRunner().invoke(cli, args)
    assert r.exit_code == 2
    assert message in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1

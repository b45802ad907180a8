"""Harmonic balance, continuation, Floquet stability and the Lyapunov coefficient (squealkit.nonlinear).

References: Van der Pol's cycle from a long scipy ``solve_ivp`` run (an independent integrator);
the first Lyapunov coefficient of ``x'' + x = beta x' + g(x, x')`` in closed form from
Guckenheimer & Holmes, *Nonlinear Oscillations* (1983), eq. (3.4.11), with ``l1 = 2 a / omega``
(Kuznetsov's normalisation); the square-root law of the Hopf normal form.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from squealkit import InputError
from squealkit.nonlinear import SecondOrderSystem, harmonic_balance
from squealkit.nonlinear.hopf import hopf_point


def oscillator(c1=0.0, c2=0.0, c3=0.0, d=1.0, e=0.0) -> SecondOrderSystem:
    """``x'' + x = beta v + c1 x^2 + c2 x v + c3 v^2 - d x^2 v + e x^4 v`` (parameter beta)."""

    def force(x, v, beta):
        f = beta * v + c1 * x**2 + c2 * x * v + c3 * v**2 - d * x**2 * v + e * x**4 * v
        dfdx = 2 * c1 * x + c2 * v - 2 * d * x * v + 4 * e * x**3 * v
        dfdv = beta + c2 * x + 2 * c3 * v - d * x**2 + e * x**4
        return f, dfdx[..., None], dfdv[..., None], v

    return SecondOrderSystem(np.eye(1), np.zeros((1, 1)), np.eye(1), np.zeros(1), force, ("x",), "beta")


def vdp_reference(eps: float) -> tuple[float, float]:
    """Amplitude and angular frequency of Van der Pol's cycle from a long solve_ivp run."""
    sol = solve_ivp(lambda t, y: [y[1], eps * (1 - y[0] ** 2) * y[1] - y[0]], (0, 300), [0.1, 0.0],
                    rtol=1e-11, atol=1e-12, dense_output=True)
    t = np.linspace(200, 300, 200_001)
    x = sol.sol(t)[0]
    i = np.flatnonzero((x[:-1] < 0) & (x[1:] >= 0))
    tc = t[i] - x[i] * (t[i + 1] - t[i]) / (x[i + 1] - x[i])
    return 0.5 * (x.max() - x.min()), 2 * math.pi / np.mean(np.diff(tc))


@pytest.mark.parametrize("eps", [0.2, 1.0])
def test_harmonic_balance_van_der_pol_matches_solve_ivp(eps):
    # x'' - eps (1 - x^2) x' + x = 0 is oscillator(d=1) at beta = eps with force eps (1 - x^2) v:
    def force(x, v, e):
        return e * (1 - x**2) * v, (-2 * e * x * v)[..., None], (e * (1 - x**2))[..., None], (1 - x**2) * v

    sys = SecondOrderSystem(np.eye(1), np.zeros((1, 1)), np.eye(1), np.zeros(1), force, ("x",), "eps")
    guess = np.zeros((3, 1))
    guess[1] = 2.0
    lc = harmonic_balance(sys, eps, omega=1.0, guess=guess, harmonics=15)
    amp, omega = vdp_reference(eps)
    assert abs(lc.amplitude[0] / amp - 1) < 1e-3  # the brief asks 1 %; measured ~1e-6
    assert abs(lc.omega / omega - 1) < 1e-4  # the brief asks 0.1 %; measured ~1e-9
    assert lc.harmonics_change < 1e-3


@pytest.mark.parametrize(
    ("coeffs", "l1_exact"),
    [
        ({"d": 1.0}, -0.25),  # Van der Pol: a = -1/8 (G&H 3.4.11), l1 = 2a
        ({"d": -1.0}, 0.25),  # the subcritical mirror
        ({"c1": 0.3, "c2": 0.5, "c3": 0.2, "d": 1.0}, 0.5 * 0.5 / 4 - 0.25),  # l1 = c2 (c1 + c3)/4 - d/4
        ({"c1": 1.0, "c2": 2.0, "c3": 0.5, "d": 1.0}, 2.0 * 1.5 / 4 - 0.25),  # quadratic terms win: subcritical
    ],
)
def test_lyapunov_coefficient_closed_form(coeffs, l1_exact):
    # For x'' + x = beta x' + g(x, x'): G&H eq. (3.4.11) with f = 0 and g_GH(x, y) = -g(x, -y)
    # gives a = [g_xxy + g_yyy]/16 - g_xy (g_xx + g_yy)/16 = c2 (c1 + c3)/8 - d/8 at beta = 0.
    h = hopf_point(oscillator(**coeffs), 0.01)
    assert abs(h.p) < 1e-10 and abs(h.omega - 1) < 1e-10
    assert h.lyapunov_coefficient == pytest.approx(l1_exact, rel=1e-5, abs=1e-8)
    assert h.kind == ("supercritical" if l1_exact < 0 else "subcritical")
    assert h.growth_slope == pytest.approx(0.5, rel=1e-6)  # Re(lambda) = beta / 2


def test_square_root_law_near_hopf():
    # Supercritical Hopf with quadratic terms: HB amplitude -> sqrt(-sigma' dbeta / (omega l1)) (normal form)
    sys = oscillator(c1=0.3, c2=0.5, c3=0.2, d=1.0)
    h = hopf_point(sys, 0.01)
    for beta in (1e-3, 4e-3):
        pred = h.amplitude(beta)[0]
        guess = np.zeros((3, 1))
        guess[1] = pred
        lc = harmonic_balance(sys, beta, omega=1.0, guess=guess, harmonics=8)
        # the next term of the normal form is O(beta): relative error ~ beta
        assert abs(lc.amplitude[0] / pred - 1) < 3 * beta


def test_branch_of_the_paper_model_starts_at_the_damped_critical_friction():
    from squealkit.models import get_preset
    from squealkit.nonlinear import limit_cycle_branch
    from squealkit.stability import critical_friction

    model = get_preset("lv2013")
    ds = limit_cycle_branch(model, (0.3, 0.6), harmonics=6, n_points=8, n_floquet=256, check_harmonics=False)
    crit = critical_friction(model, 0.0, damped=True)
    # critical_friction stops where its verdict turns (growth 7e-5 1/s there); the secant on
    # Re(lambda) = 0 lands 2e-6 (relative) lower
    assert ds.attrs["hopf_mu"] == pytest.approx(crit.mu_critical, rel=1e-5)
    assert ds.attrs["hopf_frequency_hz"] == pytest.approx(crit.frequency_hz, rel=1e-6)
    # the contact law is piecewise linear about steady sliding: no cubic term, l1 = 0, and the
    # onset type comes from the branch (it leaves towards higher friction, stable: soft onset)
    assert ds.attrs["lyapunov_coefficient"] == 0.0
    assert (ds.attrs["hopf_kind"], ds.attrs["hopf_kind_from"]) == ("supercritical", "branch")
    above = ds.mu.values > crit.mu_critical + 0.05
    assert above.any() and ds.stable.values[above].all()
    assert (ds.contact_loss_fraction.values[above] > 0).all()  # bounded by loss of contact
    assert np.all(np.diff(ds.amplitude.sel(dof="x1").values) > 0)
    assert ds.mu.max() >= 0.6 - 1e-12 or ds.attrs["stop_reason"] != "left_range"


@pytest.fixture(scope="module")
def paper_branch():
    from squealkit.models import get_preset
    from squealkit.nonlinear import limit_cycle_branch

    model = get_preset("lv2013")
    return model, limit_cycle_branch(model, (0.3, 0.75), harmonics=10, n_points=12, n_floquet=256,
                                     check_harmonics=False)


@pytest.mark.parametrize("mu", [0.5, 0.7])
def test_limit_cycle_matches_a_long_transient_of_the_same_model(paper_branch, mu):
    # The transient solver (compiled RK4, Contact.nonlinear) started off the cycle (80 % of its
    # deflection) settles on it: measured agreement 7e-5 (x1) to 2e-4 (y1) in amplitude and 4e-7 in
    # frequency at mu = 0.624 (fs 400 kHz, 0.5 s); asserted 1e-3 and 1e-5 here (fs 200 kHz, 0.4 s).
    from squealkit.nonlinear import contact_system
    from squealkit.nonlinear.harmonic_balance import _Basis
    from squealkit.transient import Contact, simulate

    model, ds = paper_branch
    sys = contact_system(model)
    i = int(np.argmin(np.abs(ds.mu.values - mu)))
    lc = harmonic_balance(sys, mu, omega=float(ds.omega_rad_s[i]), guess=ds.coefficients[i].values,
                          harmonics=10, check_harmonics=False)
    b = _Basis.make(lc.harmonics, 4)
    x_eq = sys.static_equilibrium(mu)
    x0 = x_eq + 0.8 * ((b.E @ lc.coefficients)[0] - x_eq)
    v0 = 0.8 * lc.omega * (b.dE @ lc.coefficients)[0]
    fs = 200_000.0
    tr = simulate(model, mu=mu, duration=0.4, fs=fs, contact=Contact.nonlinear(), x0=x0, v0=v0)
    last = int(0.02 * fs)
    for j, name in enumerate(sys.dof_names):
        seg = tr[name].values[-last:]
        assert 0.5 * (seg.max() - seg.min()) == pytest.approx(lc.amplitude[j], rel=1e-3), name
    x = tr["x1"].values[-int(0.05 * fs):]
    x = x - x.mean()
    k = np.flatnonzero((x[:-1] < 0) & (x[1:] >= 0))
    tc = (k - x[k] / (x[k + 1] - x[k])) / fs
    assert 1 / np.mean(np.diff(tc)) == pytest.approx(lc.frequency_hz, rel=1e-5)


def test_cli_limitcycle_json_plot_and_dataset(run, tmp_path):
    import json

    from squealkit.io import load_dataset

    out, png = tmp_path / "branch.nc", tmp_path / "branch.png"
    r = run("limitcycle", "--mu", "0.35:0.6:6", "--harmonics", "6", "--json", "--out", str(out), "--plot", str(png))
    assert r.exit_code == 0, r.output
    d = json.loads(r.output)
    assert set(d) >= {"mu", "frequency_hz", "amplitude", "stable", "hopf", "folds"}
    assert set(d["amplitude"]) == {"x1", "y1", "y2"}
    assert len(d["amplitude"]["x1"]) == len(d["mu"]) == len(d["stable"]) == len(d["frequency_hz"])
    assert set(d["hopf"]) >= {"mu", "frequency_hz", "lyapunov_coefficient", "kind"}
    assert d["hopf"]["kind"] in ("supercritical", "subcritical")
    assert png.stat().st_size > 10_000
    ds = load_dataset(out)
    assert ds["amplitude"].attrs["units"] == "m" and ds.attrs["hopf_mu"] == pytest.approx(d["hopf"]["mu"])
    from squealkit.plotting.limitcycle import limitcycle_signal_plot

    ax = limitcycle_signal_plot(ds, -1).axes[0]
    x1 = ax.lines[0].get_ydata() * 1e-6  # one period about the mean: half its range is the amplitude
    assert 0.5 * np.ptp(x1) == pytest.approx(d["amplitude"]["x1"][-1], rel=1e-2)


def test_cli_limitcycle_rejects_bad_input(run):
    r = run("limitcycle", "--mu", "0.5")
    assert r.exit_code == 2 and "START:STOP:N" in r.output
    r = run("limitcycle", "--mu", "0.1:0.3:5")  # the onset (0.3977) is outside the range
    assert r.exit_code == 2 and "outside the friction range" in r.output
    r = run("limitcycle", "--mu", "0.3:0.6:5", "--set", "P=0")  # no load: nothing to squeal about
    assert r.exit_code == 2 and "not pressed" in r.output


def test_subcritical_branch_fold_stability_and_hysteresis():
    # x'' + x = eps (beta + x^2 - x^4) x' (Bautin-type): l1 = eps/4 > 0 (G&H 3.4.11), and averaging
    # (Krylov-Bogoliubov: A^4 - 2 A^2 - 8 beta = 0) puts a fold at beta = -1/8, A = 1, with the inner
    # branch unstable and the outer one stable: hysteresis over beta in [-1/8, 0]. Errors O(eps).
    from squealkit.nonlinear import continue_branch
    from squealkit.nonlinear.continuation import branch_dataset

    eps = 0.05

    def force(x, v, beta):
        h = eps * (beta + x**2 - x**4)
        return h * v, (eps * (2 * x - 4 * x**3) * v)[..., None], h[..., None], eps * v

    sys = SecondOrderSystem(np.eye(1), np.zeros((1, 1)), np.eye(1), np.zeros(1), force, ("x",), "beta")
    hopf = hopf_point(sys, 0.01)
    assert hopf.lyapunov_coefficient == pytest.approx(eps / 4, rel=1e-5) and hopf.kind == "subcritical"
    ds = branch_dataset(sys, continue_branch(sys, hopf, (-0.3, 0.1), harmonics=7, step=0.01, n_floquet=512),
                        harmonics=7, check_harmonics=False)
    assert ds.sizes["fold"] == 1
    assert ds.fold_mu.values[0] == pytest.approx(-0.125, abs=0.125 * 2 * eps)
    amp = ds.amplitude.sel(dof="x").values
    inner, outer = amp < 0.95, amp > 1.05
    assert not ds.stable.values[inner].any() and ds.stable.values[outer].all()
    lo, hi = ds.attrs["hysteresis_mu"]
    assert lo == pytest.approx(-0.125, abs=0.125 * 2 * eps) and abs(hi) < 1e-9
    assert ds.attrs["hopf_kind"] == "subcritical"


def test_branch_over_the_run_out_slope_starts_where_mu_is_critical():
    # continuation in tan(theta) at mu = 0.35 (below the smooth disc's 0.3977): the onset slope is
    # where critical_friction(theta) is 0.35 (eq. 6: the slope acts like friction)
    from squealkit.models import get_preset
    from squealkit.nonlinear import limit_cycle_branch_slope
    from squealkit.stability import critical_friction

    model = get_preset("lv2013")
    ds = limit_cycle_branch_slope(model, (-0.15, 0.15), mu=0.35, harmonics=6, n_points=8, n_floquet=256,
                                  check_harmonics=False)
    t_c = ds.attrs["hopf_mu"]
    assert critical_friction(model, math.atan(t_c), damped=True).mu_critical == pytest.approx(0.35, rel=1e-5)
    assert ds.tan_theta.values.max() == pytest.approx(0.15) and ds.stable.values.all()
    assert (ds.contact_loss_fraction.values[ds.tan_theta.values > t_c + 0.02] > 0).all()


def test_stribeck_friction_gives_a_hard_onset_with_hysteresis_that_transients_confirm():
    # Falling (Stribeck) friction adds a smooth cubic term at steady sliding: l1 > 0, the branch
    # leaves the Hopf point towards lower friction (unstable), folds where contact loss sets in and
    # comes back stable. Between the fold and the Hopf point the quiet state and the squeal coexist:
    # a transient from rest decays, one started on the cycle stays there (measured: 1e-4 agreement).
    from squealkit.models import get_preset
    from squealkit.nonlinear import contact_system, limit_cycle_branch
    from squealkit.nonlinear.harmonic_balance import _Basis
    from squealkit.transient import Contact, simulate

    model, contact = get_preset("lv2013"), Contact.nonlinear(mu_static=0.6, v_stribeck=0.01)
    ds = limit_cycle_branch(model, (0.1, 0.8), contact=contact, harmonics=10, n_points=21, n_floquet=512,
                            check_harmonics=False)
    assert ds.attrs["lyapunov_coefficient"] > 0 and ds.attrs["hopf_kind"] == "subcritical"
    assert ds.sizes["fold"] == 1
    lo, hi = ds.attrs["hysteresis_mu"]
    assert lo == pytest.approx(ds.fold_mu.values[0]) and hi == pytest.approx(ds.attrs["hopf_mu"])
    sys = contact_system(model, contact)
    # normal form: the unstable small cycles (contact not yet lost) follow the square-root law
    hopf = hopf_point(sys, ds.attrs["hopf_mu"])
    small = (ds.contact_loss_fraction.values == 0) & (ds.mu.values < hi - 5e-4)
    assert small.sum() >= 2 and not ds.stable.values[small].any()
    pred = hopf.amplitude(ds.mu.values[small])
    assert np.allclose(ds.amplitude.values[small], pred, rtol=0.05)  # measured 0.3 % to 1.6 % (farther)
    mu = 0.5 * (lo + hi)
    i = int(np.flatnonzero(ds.stable.values & (ds.mu.values < hi))[0])
    lc = harmonic_balance(sys, mu, omega=float(ds.omega_rad_s[i]), guess=ds.coefficients[i].values, harmonics=10,
                          check_harmonics=False)
    b = _Basis.make(10, 4)
    fs = 100_000.0
    on = simulate(model, mu=mu, duration=0.4, fs=fs, contact=contact, x0=(b.E @ lc.coefficients)[0],
                  v0=lc.omega * (b.dE @ lc.coefficients)[0])
    seg = on.x1.values[-2000:]
    assert 0.5 * (seg.max() - seg.min()) == pytest.approx(lc.amplitude[0], rel=2e-3)
    quiet = simulate(model, mu=mu, duration=0.4, fs=fs, contact=contact, perturbation=1e-8,
                     rng=np.random.default_rng(0))
    x = quiet.x1.values
    assert np.ptp(x[-2000:]) < np.ptp(x[2000:4000])  # decays: the quiet state is stable here


def test_a_transient_from_rest_grows_onto_the_limit_cycle(paper_branch):
    # From the static equilibrium with a 1e-9 m perturbation at mu = 0.75 (growth 31 1/s): 0.8 s to
    # grow and settle at 4 kHz output, then 0.02 s at 200 kHz to measure. Measured: within 2.8e-4 (y1).
    from squealkit.nonlinear import contact_system
    from squealkit.transient import Contact, simulate

    model, ds = paper_branch
    mu = 0.75
    sys = contact_system(model)
    i = int(np.argmin(np.abs(ds.mu.values - mu)))
    lc = harmonic_balance(sys, mu, omega=float(ds.omega_rad_s[i]), guess=ds.coefficients[i].values,
                          harmonics=10, check_harmonics=False)
    grow = simulate(model, mu=mu, duration=0.8, fs=4000.0, contact=Contact.nonlinear(), perturbation=1e-9,
                    rng=np.random.default_rng(1))
    end = grow.isel(time=-1)
    fine = simulate(model, mu=mu, duration=0.02, fs=200_000.0, contact=Contact.nonlinear(),
                    x0=[float(end[n]) for n in sys.dof_names], v0=[float(end[f"{n}_dot"]) for n in sys.dof_names])
    for j, name in enumerate(sys.dof_names):
        x = fine[name].values
        assert 0.5 * (x.max() - x.min()) == pytest.approx(lc.amplitude[j], rel=2e-3), name


class _Consistent:
    """A pin-on-disc model that reports consistent contact kinematics (the option of newer models)."""

    def __new__(cls):
        from squealkit.models import get_preset

        base = type(get_preset("lv2013"))
        sub = type("ConsistentPinOnDisc", (base,), {"kinematics_option": property(lambda self: "consistent")})
        return sub()


@pytest.mark.parametrize("param", ["mu", "tan_theta"])
@pytest.mark.parametrize("kinematics", ["paper", "consistent"])
@pytest.mark.parametrize("stribeck", [None, 0.6])
def test_contact_force_derivatives_match_finite_differences(param, kinematics, stribeck):
    # The analytic derivatives the Newton solver, Floquet and l1 use, against central differences
    # of the force itself, at states with contact closed and sliding in both directions.
    from squealkit.models import get_preset
    from squealkit.nonlinear import contact_system
    from squealkit.transient import Contact

    model = get_preset("lv2013") if kinematics == "paper" else _Consistent()
    contact = Contact.nonlinear(mu_static=stribeck, v_stribeck=0.01, v_reg=5e-3)
    sys = contact_system(model, contact, tan_theta=0.1, mu=0.5, param=param)
    rng = np.random.default_rng(3)
    x0 = sys.static_equilibrium(0.45 if param == "mu" else 0.05)
    X = x0 + 0.3 * sys.length_scale * rng.standard_normal((6, 3))
    V = 0.02 * rng.standard_normal((6, 3))
    p = 0.45 if param == "mu" else 0.05
    f, dfdx, dfdv, dfdp = sys.force(X, V, p)
    closed = np.linalg.norm(f, axis=1) > 0  # contact closed: away from the kink of N_c >= 0
    assert closed.sum() >= 3
    hx, hv = 1e-6 * sys.length_scale, 1e-7
    for j in range(3):
        ex, ev = np.eye(3)[j] * hx, np.eye(3)[j] * hv
        fd_x = (sys.force(X + ex, V, p)[0] - sys.force(X - ex, V, p)[0]) / (2 * hx)
        fd_v = (sys.force(X, V + ev, p)[0] - sys.force(X, V - ev, p)[0]) / (2 * hv)
        assert np.allclose(dfdx[closed, :, j], fd_x[closed], rtol=1e-5, atol=1e-7 * np.abs(dfdx).max())
        assert np.allclose(dfdv[closed, :, j], fd_v[closed], rtol=1e-4, atol=1e-6 * np.abs(dfdv).max())
    fd_p = (sys.force(X, V, p + 1e-7)[0] - sys.force(X, V, p - 1e-7)[0]) / 2e-7
    assert np.allclose(dfdp, fd_p, rtol=1e-5, atol=1e-7 * np.abs(dfdp).max())


def test_consistent_kinematics_hopf_point_matches_critical_friction():
    # After the models gain the 'kinematics' option: the Hopf point of the nonlinear system with
    # consistent kinematics at a slope is the damped critical friction of that model.
    from squealkit.models import PinOnDisc3DOF
    from squealkit.nonlinear import contact_system
    from squealkit.stability import critical_friction

    try:
        model = PinOnDisc3DOF(kinematics="consistent")
    except TypeError:
        pytest.skip("this squealkit's models have no 'kinematics' option yet")
    theta = math.radians(-3.0)  # with consistent kinematics +3 deg stabilises, -3 deg destabilises
    crit = critical_friction(model, theta, damped=True)
    assert crit.status == "onset"
    hopf = hopf_point(contact_system(model, tan_theta=math.tan(theta)), crit.mu_critical)
    assert hopf.p == pytest.approx(crit.mu_critical, rel=1e-5)
    assert hopf.frequency_hz == pytest.approx(crit.frequency_hz, rel=1e-6)


def _vdp_system() -> SecondOrderSystem:
    def force(x, v, e):
        return e * (1 - x**2) * v, (-2 * e * x * v)[..., None], (e * (1 - x**2))[..., None], (1 - x**2) * v

    return SecondOrderSystem(np.eye(1), np.zeros((1, 1)), np.eye(1), np.zeros(1), force, ("x",), "eps")


def test_aft_jacobian_matches_finite_differences_of_the_residual():
    # The FFT-assembled Jacobian of the AFT residual against central differences of the residual
    # itself, at a random state of the paper's model with contact closed over the whole period (the
    # contact law is smooth there): relative agreement ~1e-8 measured.
    from squealkit.models import get_preset
    from squealkit.nonlinear import contact_system
    from squealkit.nonlinear.harmonic_balance import _Basis, hb_residual, n_time_samples

    sys = contact_system(get_preset("lv2013"))
    H = 4
    b = _Basis.make(H, n_time_samples(H))
    rng = np.random.default_rng(5)
    Z = np.zeros((2 * H + 1, 3))
    Z[0] = sys.static_equilibrium(0.5)
    Z[1:] = 0.05 * sys.length_scale * rng.standard_normal((2 * H, 3))
    omega = 2 * math.pi * 2380.0
    _, JZ, Rw, _ = hb_residual(sys, b, Z, omega, 0.5)
    h = 1e-4 * sys.length_scale
    fd = np.empty_like(JZ)
    for c in range(Z.size):
        dZ = np.zeros(Z.size)
        dZ[c] = h
        dZ = dZ.reshape(Z.shape)
        fd[:, c] = ((hb_residual(sys, b, Z + dZ, omega, 0.5, jacobian=False)
                     - hb_residual(sys, b, Z - dZ, omega, 0.5, jacobian=False)) / (2 * h)).ravel()
    assert np.allclose(JZ, fd, rtol=1e-6, atol=1e-7 * np.abs(JZ).max())
    dw = 1e-6 * omega
    fd_w = (hb_residual(sys, b, Z, omega + dw, 0.5, jacobian=False)
            - hb_residual(sys, b, Z, omega - dw, 0.5, jacobian=False)) / (2 * dw)
    assert np.allclose(Rw, fd_w, rtol=1e-6, atol=1e-7 * np.abs(Rw).max())


@settings(max_examples=8, deadline=None)
@given(eps=st.floats(0.05, 1.5), sort=st.sampled_from(["symmetry", "imaginary"]))
def test_hill_exponents_of_van_der_pol_follow_liouville(eps, sort):
    # Liouville: the sum of the Floquet exponents is the period mean of the divergence of the
    # vector field, eps (1 - x^2); the trivial one is 0, so the other is that mean exactly.
    from squealkit.nonlinear import floquet_multipliers, hill_exponents
    from squealkit.nonlinear.harmonic_balance import _Basis

    sys = _vdp_system()
    guess = np.zeros((3, 1))
    guess[1] = 2.0
    lc = harmonic_balance(sys, eps, omega=1.0, guess=guess, harmonics=14, check_harmonics=False)
    x = (_Basis.make(14, 512).E @ lc.coefficients)[:, 0]
    mean_div = eps * np.mean(1 - x**2)
    lam = hill_exponents(sys, lc, sort=sort)
    assert abs(lam[-1]) < 1e-9 * eps  # the trivial exponent (phase shift)
    assert lam[0].real == pytest.approx(mean_div, rel=1e-4)  # measured 1e-13 to eps = 1, 7e-6 at 1.5 (H = 14)
    assert abs(lam[0].imag) < 1e-9
    rho = floquet_multipliers(sys, lc)  # the monodromy matrix agrees (RK4: measured ~1e-6)
    assert np.log(abs(rho[0])) * lc.omega / (2 * math.pi) == pytest.approx(mean_div, rel=1e-4)


def test_hill_and_monodromy_agree_on_the_paper_model(paper_branch):
    # Both methods on three cycles of the paper's branch (contact lost over part of the period):
    # the same verdict, the largest exponents within the cycles' own error. The HB cycle with H = 10
    # is not exact where the contact kinks: its trivial exponents sit 0.1-5 1/s off 0, and the two
    # methods' largest exponents differ by up to 3.6 1/s of about -20 (measured).
    from squealkit.nonlinear import contact_system, floquet_multipliers, hill_exponents

    model, ds = paper_branch
    sys = contact_system(model)
    far = np.flatnonzero(ds.mu.values > ds.attrs["hopf_mu"] + 0.05)  # off the neutral vertical start
    for i in far[[0, far.size // 2, -1]]:
        lc = harmonic_balance(sys, float(ds.mu[i]), omega=float(ds.omega_rad_s[i]), guess=ds.coefficients[i].values,
                              harmonics=10, check_harmonics=False)
        T = 2 * math.pi / lc.omega
        lam = hill_exponents(sys, lc)
        lam_i = hill_exponents(sys, lc, sort="imaginary")
        mono = np.log(floquet_multipliers(sys, lc).astype(complex)) / T
        assert lam[0].real < 0 and mono[0].real < 0  # stable, as the branch says
        assert bool(ds.stable[i])
        assert lam[0].real == pytest.approx(mono[0].real, rel=0.25)
        assert lam_i[0].real == pytest.approx(lam[0].real, rel=1e-6)
        assert np.all(np.abs(lam_i.imag) <= lc.omega / 2 + 1e-6)  # the symmetric ones need not be


def test_hill_stability_on_a_hard_onset_branch():
    # The subcritical oscillator's branch (see the test above) with Hill's method: inner cycles
    # unstable, outer stable, as the monodromy matrix says (Krylov-Bogoliubov averaging).
    from squealkit.nonlinear import continue_branch

    eps = 0.05

    def force(x, v, beta):
        h = eps * (beta + x**2 - x**4)
        return h * v, (eps * (2 * x - 4 * x**3) * v)[..., None], h[..., None], eps * v

    sys = SecondOrderSystem(np.eye(1), np.zeros((1, 1)), np.eye(1), np.zeros(1), force, ("x",), "beta")
    hopf = hopf_point(sys, 0.01)
    br = continue_branch(sys, hopf, (-0.3, 0.1), harmonics=5, step=0.02, stability="hill")
    amp = np.array([c.amplitude[0] for c in br.cycles])
    assert not br.stable[amp < 0.95].any() and br.stable[amp > 1.05].all()
    with pytest.raises(ValueError, match="stability"):
        continue_branch(sys, hopf, (-0.3, 0.1), stability="lyapunov")


def test_sound_level_from_a_radiation_factor_and_a_transfer(paper_branch, tmp_path):
    # p_rms = R v_rms with v_rms the RMS of the DOF's velocity over one period (sampled from the
    # stored Fourier series here: Parseval's identity is the known answer); a flat transfer table
    # equal to R gives the same level; dB SPL re 20 uPa.
    from squealkit.nonlinear import read_transfer_csv, sound_level
    from squealkit.nonlinear.harmonic_balance import _Basis

    _, ds = paper_branch
    out = sound_level(ds, radiation_factor=400.0, dof="y2")
    i = -1
    c = ds.coefficients.isel(point=i).sel(dof="y2").values
    b = _Basis.make((c.size - 1) // 2, 1024)
    v = float(ds.omega_rad_s[i]) * (b.dE @ c)
    p_rms = 400.0 * np.sqrt(np.mean(v**2))
    assert float(out.level_db[i]) == pytest.approx(20 * np.log10(p_rms / 20e-6), abs=1e-9)
    assert out.level_db.attrs["units"] == "dB" and out.attrs["level_dof"] == "y2"
    csv = tmp_path / "transfer.csv"
    csv.write_text("frequency_hz,pa_per_m_s\n100,400\n50000,400\n")
    flat = sound_level(ds, transfer=read_transfer_csv(csv), dof="y2")
    assert np.allclose(flat.level_db.values[1:], out.level_db.values[1:], atol=1e-9)
    csv.write_text("3000,400\n5000,400\n")
    with pytest.raises(ValueError, match="outside the transfer's range"):
        sound_level(ds, transfer=read_transfer_csv(csv))
    with pytest.raises(ValueError, match="exactly one"):
        sound_level(ds)


def test_cli_limitcycle_over_theta_with_a_level(run, tmp_path):
    import json

    r = run("limitcycle", "--mu", "0.35", "--theta", "-4:6:6", "--harmonics", "4", "--radiation-factor", "400",
            "--json")
    assert r.exit_code == 0, r.output
    d = json.loads(r.output)
    assert d["parameter"] == "theta" and d["mu"] == 0.35
    assert len(d["theta_deg"]) == len(d["level_db"]) == len(d["stable"])
    # the onset incline is where the damped critical friction equals 0.35 (eq. 6: the slope acts
    # like friction); the branch test above checks it against critical_friction
    assert 0 < d["hopf"]["theta_deg"] < 6 and d["theta_deg"][-1] == pytest.approx(6.0)
    assert d["level_from"].startswith("radiation factor 400")
    assert all(np.diff(d["level_db"][1:]) > -1e-9)  # louder as the incline grows past the onset
    r = run("limitcycle", "--mu", "0.3:0.6:4", "--theta", "-4:6:6")
    assert r.exit_code == 2 and "one friction value" in r.output
    r = run("limitcycle", "--mu", "0.3:0.6:4", "--radiation-factor", "1", "--transfer", str(tmp_path / "t.csv"))
    assert r.exit_code == 2 and "not both" in r.output
    bad = tmp_path / "bad.csv"
    bad.write_text("f,t\n1000,abc\n")
    r = run("limitcycle", "--mu", "0.3:0.6:4", "--transfer", str(bad))
    assert r.exit_code == 2 and "line 2" in r.output and "Traceback" not in r.output
    r = run("limitcycle", "--mu", "0.3:0.6:4", "--radiation-factor", "1", "--level-dof", "z9")
    assert r.exit_code == 2 and "--level-dof" in r.output


def test_report_section_how_loud_is_written_from_its_numbers(tmp_path):
    # The report's "How loud" section (quick): the onset is the damped critical friction, the limit
    # cycle at the steepest Fig. 4 slope matches the flat disc's at the same mu + tan(theta) (eq. 6
    # carried over to the cycles; measured 1.3 %), and every number quoted in the prose is the computed one.
    from squealkit.models import get_preset
    from squealkit.report.steps_nonlinear import nonlinear_step
    from squealkit.stability import critical_friction

    (tmp_path / "f").mkdir()
    (tmp_path / "d").mkdir()
    model = get_preset("lv2013")
    sec = nonlinear_step(model, tmp_path / "f", tmp_path / "d", quick=True)
    num = sec.numbers
    assert num["hopf_mu"] == pytest.approx(critical_friction(model, 0.0, damped=True).mu_critical, rel=1e-5)
    assert num["amplitude_steepest_slope"] == pytest.approx(num["amplitude_flat_same_mu_e"], rel=0.05)
    text = " ".join(sec.paragraphs)
    assert f"mu = {num['hopf_mu']:.4f}" in text and f"{num['amplitude_mu05'] * 1e6:.3f} um" in text
    assert f"{100 * num['fig4_envelope_ratio']:.2g} %" in text
    assert (tmp_path / "f" / "how_loud.png").stat().st_size > 10_000
    assert {p.name for p in (tmp_path / "d").iterdir()} == set(sec.data)


def test_adaptive_harmonics_double_until_the_amplitude_settles():
    # issue 13: "an adaptive number of harmonics (convergence of the amplitude stated)"
    import xarray as xr

    from squealkit.nonlinear.continuation import MAX_HARMONICS, _enough_harmonics

    tried = []
    changes = {2: 0.3, 4: 0.04, 8: 0.004}  # amplitude change at 2H for each H; 0.2 for any other

    def solve(H):
        tried.append(H)
        return xr.Dataset(attrs={"harmonics": H, "harmonics_change": changes.get(H, 0.2)})

    ds = _enough_harmonics(solve, 2, 0.01, True)
    assert tried == [2, 4, 8] and ds.attrs["harmonics"] == 8 and ds.attrs["harmonics_converged"] == 1
    tried.clear()
    with pytest.warns(RuntimeWarning, match="more than harmonics_tol = 0.001, at the most harmonics"):
        ds = _enough_harmonics(solve, 10, 1e-3, True)
    assert tried[-1] <= MAX_HARMONICS < 2 * tried[-1] and ds.attrs["harmonics_converged"] == 0
    assert _enough_harmonics(solve, 3, None, True).attrs["harmonics"] == 3  # fixed H: one solve
    with pytest.raises(InputError, match="check_harmonics"):
        _enough_harmonics(solve, 3, 0.01, False)


def test_adaptive_branch_of_the_paper_model_converges_in_the_harmonics(run):
    # the paper's cycles lose contact (kinks): H = 2 is far off, the adaptive branch raises H until
    # the amplitudes change by at most 1 % at 2H, and says so in its JSON
    r = run("limitcycle", "--mu", "0.39:0.6:5", "--harmonics", "2", "--harmonics-tol", "0.01", "--json")
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout)
    assert out["harmonics"] > 2 and out["harmonics_change"] <= 0.01
    assert out["harmonics_tol"] == 0.01 and out["harmonics_converged"] is True

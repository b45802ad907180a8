"""The stiff integrator (``method="rosenbrock"``: Rodas4 with the analytic Jacobian), issue 12.

References: SciPy's Radau (rtol 1e-9) on the independent first-order form of the nonlinear
contact in test_transient_error_control (the issue's stiff case: v_reg = 1e-5 m/s, disc at
rest), and the exact solution of a linear problem by the matrix exponential (order of
convergence with the error control switched off).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import expm

from _reference import nonlinear_rhs
from squealkit.models import get_preset
from squealkit.transient import Contact, simulate

LV = get_preset("lv2013")


def test_stiff_friction_matches_radau_in_far_fewer_steps():
    contact = Contact.nonlinear(v_reg=1e-5)
    x0 = LV.static_equilibrium(0.0) + np.array([1e-7, -5e-8, 2e-8])
    kw = dict(mu=0.4, speed=0.0, contact=contact, duration=0.005, fs=40_000, x0=x0)
    ds = simulate(LV, method="rosenbrock", **kw)
    assert ds.attrs["status"] == "completed" and ds.attrs["method"] == "rosenbrock"
    assert "Rodas4" in ds.attrs["integrator"]
    ref = solve_ivp(nonlinear_rhs(LV, 0.4, 1e-5), (0, 0.005), np.concatenate([x0, np.zeros(3)]), method="Radau",
                    rtol=1e-9, atol=1e-15, t_eval=ds.time.values)
    assert ref.success
    # the tolerances of the Dormand-Prince test (measured here: 4e-10 and <= 1.4e-8)
    assert ds.x1.values[-1] == pytest.approx(ref.y[0, -1], rel=1e-6)
    for i, name in enumerate(LV.dof_names):
        scale = np.abs(ref.y[3 + i]).max()
        assert np.abs(ds[f"{name}_dot"].values - ref.y[3 + i]).max() < 1e-4 * scale, name
    # Dormand-Prince is held at the friction law's stability bound: 15623 steps; Rodas4 6675
    # at the same rtol = 1e-8, 1.5-2 k at rtol = 1e-6 (still within the tolerances above)
    dp = simulate(LV, **kw)
    assert ds.attrs["steps"] < dp.attrs["steps"] / 2, (ds.attrs["steps"], dp.attrs["steps"])
    loose = simulate(LV, method="rosenbrock", rtol=1e-6, **kw)
    assert loose.attrs["steps"] < dp.attrs["steps"] / 5, (loose.attrs["steps"], dp.attrs["steps"])
    assert loose.x1.values[-1] == pytest.approx(ref.y[0, -1], rel=1e-6)
    for i, name in enumerate(LV.dof_names):
        scale = np.abs(ref.y[3 + i]).max()
        assert np.abs(loose[f"{name}_dot"].values - ref.y[3 + i]).max() < 1e-4 * scale, name


def _linear_exact(model, mu, z0, times):
    """z' = A z + c of the linear contact on a flat disc, solved by the matrix exponential."""
    n = model.n_dof
    Minv = np.linalg.inv(model.mass_matrix())
    A = np.zeros((2 * n + 1, 2 * n + 1))
    A[:n, n:2 * n] = np.eye(n)
    A[n:2 * n, :n] = -Minv @ model.stiffness_matrix(mu, 0.0)
    A[n:2 * n, n:2 * n] = -Minv @ model.damping_matrix()
    A[n:2 * n, -1] = Minv @ model.load_vector(mu, 0.0, 0.0)
    za = np.append(z0, 1.0)
    return np.stack([expm(A * t) @ za for t in times])[:, :2 * n]


def test_order_four_on_a_linear_problem():
    # error control off (huge tolerances): every step is the largest allowed, dt; the error at
    # the end falls as dt^4 (Rodas4), that of the dense output between steps at least as dt^3
    mu = 0.2
    x0 = LV.static_equilibrium(mu) + np.array([2e-7, -1e-7, 5e-8])
    z0 = np.concatenate([x0, np.zeros(3)])
    duration, fs = 2e-3, 10_000
    exact = None
    end, dense = [], []
    dts = (8e-6, 4e-6, 2e-6, 1e-6)
    for dt in dts:
        ds = simulate(LV, mu=mu, duration=duration, fs=fs, x0=x0, method="rosenbrock", dt=dt, rtol=0.5, atol=1.0)
        assert ds.attrs["rejected_steps"] == 0
        assert ds.attrs["steps"] == pytest.approx(duration / dt, abs=2 + duration * fs / 16384)
        if exact is None:
            exact = _linear_exact(LV, mu, z0, ds.time.values)
        x = np.stack([ds[d].values for d in LV.dof_names], axis=-1)
        scale = np.abs(exact[:, :3] - x0).max()
        end.append(np.abs(x[-1] - exact[-1, :3]).max() / scale)
        dense.append(np.abs(x - exact[:, :3]).max() / scale)
    p_end = np.log2(np.array(end[:-1]) / np.array(end[1:]))
    p_dense = np.log2(np.array(dense[:-1]) / np.array(dense[1:]))
    assert np.all(p_end > 3.6) and np.all(p_end < 4.6), (end, p_end)
    assert np.all(p_dense > 2.7), (dense, p_dense)


def test_rosenbrock_locates_contact_events():
    # the contact-loss case of test_transient_error_control (undamped, frictionless, the pin
    # lifted 0.3 um): all 196 openings and closures in 10 ms against DOP853 (rtol 1e-13) with an
    # event function (measured: within 4.7e-9 s; Dormand-Prince at the same rtol 1e-6 s)
    model = LV.undamped()
    x0 = model.static_equilibrium(0.0) + np.array([0.0, 3e-7, 0.0])
    ros = simulate(model, mu=0.0, duration=0.01, fs=40_000, x0=x0, contact=Contact(separation=True),
                   method="rosenbrock")
    assert ros.attrs["status"] == "completed"

    def gap(t, z):
        return z[1] - z[2]

    ref = solve_ivp(nonlinear_rhs(model, 0.0, 1.0), (0, 0.01), np.concatenate([x0, np.zeros(3)]),
                    method="DOP853", rtol=1e-13, atol=1e-20, events=gap)
    t_ref = ref.t_events[0]
    kinds = ros.event_kind.values
    assert ros.attrs["events"] == t_ref.size > 100
    assert kinds[0] == 2 and np.all(kinds[1:] != kinds[:-1])  # closes, opens, closes, ...
    np.testing.assert_allclose(ros.event_time.values, t_ref, rtol=0, atol=2e-8)


@pytest.mark.parametrize("kin", [0.0, 1.0])
@pytest.mark.parametrize("contact", [Contact.linear(), Contact.nonlinear(v_reg=1e-4, mu_static=0.6, v_stribeck=1e-3)])
def test_analytic_jacobian_matches_finite_differences(contact, kin):
    from squealkit.solvers import ode as K
    from squealkit.transient.contact import contact_geometry

    m = LV
    Mi = np.linalg.inv(m.mass_matrix())
    C = Mi @ m.damping_matrix()
    K0, Kn, Kf = (Mi @ a for a in m.stiffness_parts())
    Knx, Kfx = (Mi @ a for a in m.slope_parts())
    F0, fn, ff = (Mi @ a for a in m.load_parts())
    _ok, kc, b, f = contact_geometry(m)
    fhat, bM, fM, s = f / np.linalg.norm(f), Mi @ b, Mi @ f, float(m.sliding_direction)
    opts = contact.options()
    rng = np.random.default_rng(1)
    x = m.static_equilibrium(0.4) + 1e-7 * rng.standard_normal(3)
    xd = 1e-4 * rng.standard_normal(3)
    q, t, mu, v = 1e-6, 0.05, 0.4, 2e-4

    # the kernel's bundled arrays: [C, K0, Kn, Kf, Knx, Kfx] and [bM, fM, F0, fn, ff, b, fhat]
    mats, vecs = np.stack([C, K0, Kn, Kf, Knx, Kfx]), np.stack([bM, fM, F0, fn, ff, b, fhat])

    def acc(x, xd):
        a = np.empty(3)
        K._rhs(x, 0, xd, 0, q, t, mu, v, kin, kc, s, mats, vecs, opts, a)
        return a

    Jx, Jv = np.empty((3, 3)), np.empty((3, 3))
    K._jacobian(x, xd, q, t, mu, v, kin, kc, s, mats, vecs, opts, Jx, Jv)
    fdx = np.column_stack([(acc(x + e, xd) - acc(x - e, xd)) / 2e-12 for e in np.eye(3) * 1e-12])
    fdv = np.column_stack([(acc(x, xd + e) - acc(x, xd - e)) / 2e-9 for e in np.eye(3) * 1e-9])
    assert np.abs(Jx - fdx).max() < 1e-7 * np.abs(Jx).max()   # measured <= 2.4e-11
    assert np.abs(Jv - fdv).max() < 1e-6 * np.abs(Jv).max()   # measured <= 1.1e-8 (rounding)


def test_limit_cycle_with_stick_slip_and_contact_loss():
    # the limit cycle of test_transient_error_control (mu = 0.8, v_reg = 1 mm/s) by Rodas4: the
    # same events, alternating, and the same amplitude as Dormand-Prince (measured: 1064 events
    # each, peak x1 within 2e-7 relative)
    kw = dict(mu=0.8, duration=0.3, fs=20_000, contact=Contact.nonlinear(), perturbation=1e-9)
    ros = simulate(LV, method="rosenbrock", rng=np.random.default_rng(0), **kw)
    dp = simulate(LV, rng=np.random.default_rng(0), **kw)
    assert ros.attrs["status"] == "completed"
    kinds = ros.event_kind.values
    assert set(kinds.tolist()) == {1, 2, 3, 4}
    for pair in ((1, 2), (3, 4)):
        sub = kinds[np.isin(kinds, pair)]
        assert np.all(sub[1:] != sub[:-1])
    assert abs(ros.attrs["events"] - dp.attrs["events"]) <= 4
    assert float(np.abs(ros.x1).max()) == pytest.approx(float(np.abs(dp.x1).max()), rel=1e-4)

"""Accuracy of the transient solver against independent solutions.

References: the matrix exponential (scipy.linalg.expm) of the frozen-coefficient linear system,
a high-accuracy solve_ivp(DOP853, rtol=1e-10) of the paper's Fig. 4 case (Lv, Zhang & Yu 2013,
section 4: mu = 0.4, c = 220 N s/m, q0 = 0.08 mm, lambda = 1 mm, v = 0.02 m/s, 0.15 s), the
theoretical order 4 of classical RK4, and conservation of energy of the undamped conservative
system (mu = 0, flat disc: K symmetric).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import expm
from scipy.signal import butter, sosfiltfilt

from squealkit.models import Hoffmann2002, get_preset
from squealkit.transient import SineRunOut, simulate
from squealkit.transient.reference import first_order_rhs


def _frozen_exact(model, mu, z0, t):
    """z(t) = z_eq + expm(A t) (z0 - z_eq) for the flat disc (constant K, F)."""
    n = model.n_dof
    Minv = np.linalg.inv(model.mass_matrix())
    A = np.zeros((2 * n, 2 * n))
    A[:n, n:] = np.eye(n)
    A[n:, :n] = -Minv @ model.stiffness_matrix(mu, 0.0)
    A[n:, n:] = -Minv @ model.damping_matrix()
    z_eq = np.concatenate([model.static_equilibrium(mu), np.zeros(n)])
    return np.stack([z_eq + expm(A * ti) @ (z0 - z_eq) for ti in t])


@pytest.mark.parametrize("mu", [0.0, 0.4, 0.8])
def test_frozen_coefficients_match_expm(mu):
    model = get_preset("lv2013")
    x0 = model.static_equilibrium(mu) + np.array([1e-7, -2e-7, 5e-8])
    ds = simulate(model, mu=mu, duration=0.004, fs=20_000, x0=x0)
    z0 = np.concatenate([x0, np.zeros(3)])
    exact = _frozen_exact(model, mu, z0, ds.time.values)
    x = np.stack([ds[n].values for n in model.dof_names], axis=-1)
    dev = exact[:, :3] - exact[:1, :3]
    err = np.abs(x - exact[:, :3]).max(axis=0) / np.abs(dev).max(axis=0)
    assert np.all(err < 1e-4), err


def test_measured_convergence_order_is_four():
    # Classical RK4: global error ~ dt^4. Measured against expm on the flat-disc system.
    model = get_preset("lv2013")
    mu = 0.4
    x0 = model.static_equilibrium(mu) + np.array([1e-7, -2e-7, 5e-8])
    fs, T = 1000.0, 0.004
    exact = _frozen_exact(model, mu, np.concatenate([x0, np.zeros(3)]), [T])[0, :3]
    dts, errs = [], []
    for stride in (60, 120, 240):
        dt = 1.0 / (fs * stride)
        ds = simulate(model, mu=mu, duration=T, fs=fs, x0=x0, dt=dt, method="rk4")
        x = np.array([ds[n].values[-1] for n in model.dof_names])
        dts.append(ds.attrs["dt"])
        errs.append(np.linalg.norm(x - exact))
    order = np.polyfit(np.log(dts), np.log(errs), 1)[0]
    assert 3.7 < order < 4.3, (order, errs)


@pytest.fixture(scope="module")
def fig4_pair():
    model, mu, speed = get_preset("lv2013"), 0.4, 0.02
    profile = SineRunOut(0.08e-3, 1e-3)  # paper section 4, Fig. 4
    ds = simulate(model, mu=mu, profile=profile, speed=speed, duration=0.15, fs=40_000)
    q0, t0 = profile.evaluate(0.0)
    z0 = np.concatenate([model.static_equilibrium(mu, t0, q0), np.zeros(3)])
    rhs = first_order_rhs(model, mu=mu, profile=profile, speed=speed)
    ref = solve_ivp(rhs, (0, 0.15), z0, method="DOP853", rtol=1e-10, atol=1e-16, t_eval=ds.time.values)
    assert ref.success
    return model, ds, ref


def test_fig4_matches_dop853(fig4_pair):
    model, ds, ref = fig4_pair
    sos = butter(4, 1000.0, btype="highpass", fs=40_000, output="sos")
    for i, name in enumerate(model.dof_names):
        ours = sosfiltfilt(sos, ds[name].values)
        theirs = sosfiltfilt(sos, ref.y[i])
        rel = np.sqrt(np.mean((ours - theirs) ** 2)) / np.sqrt(np.mean(theirs**2))
        assert rel < 1e-3, (name, rel)


def test_fig4_velocities_and_accelerations_consistent(fig4_pair):
    model, ds, ref = fig4_pair
    rhs = first_order_rhs(model, mu=0.4, profile=SineRunOut(0.08e-3, 1e-3), speed=0.02)
    k = 3000
    zdot = rhs(float(ds.time[k]), ref.y[:, k])
    for i, name in enumerate(model.dof_names):
        assert ds[f"{name}_dot"].values[k] == pytest.approx(ref.y[3 + i, k], rel=1e-3, abs=1e-6)
        assert ds[f"{name}_ddot"].values[k] == pytest.approx(zdot[3 + i], rel=1e-3, abs=1e-2)


@pytest.mark.parametrize("model", [get_preset("lv2013").undamped(), Hoffmann2002()])
@pytest.mark.parametrize(("dt", "tol"), [(None, 1e-3), (2.5e-7, 1e-7)])
def test_energy_conserved_undamped_conservative(model, dt, tol):
    # mu = 0 on a flat disc: K symmetric, no damping, constant load => the energy about the
    # static equilibrium is constant. RK4 loses energy slowly, ~ (omega dt)^6 per step
    # (dt = 0.25/omega_max by default: < 1e-3 over 0.02 s; dt = 2.5e-7 s: < 1e-7).
    n = model.n_dof
    x0 = model.static_equilibrium(0.0) + 1e-7 * np.arange(1, n + 1)
    ds = simulate(model, mu=0.0, duration=0.02, fs=20_000, x0=x0, dt=dt, method="rk4")
    M, K, F = model.mass_matrix(), model.stiffness_matrix(0.0, 0.0), model.load_vector(0.0, 0.0, 0.0)
    x = np.stack([ds[d].values for d in model.dof_names], axis=-1)
    v = np.stack([ds[f"{d}_dot"].values for d in model.dof_names], axis=-1)
    x_eq = model.static_equilibrium(0.0)
    E = 0.5 * np.einsum("ti,ij,tj->t", v, M, v) + 0.5 * np.einsum("ti,ij,tj->t", x - x_eq, K, x - x_eq)
    assert np.allclose(K, K.T)
    assert np.abs(E - E[0]).max() / E[0] < tol
    assert E.max() <= E[0] * (1 + 1e-12)  # never gains energy
    assert np.allclose(F, K @ x_eq)


def test_dormand_prince_order_is_five():
    # Tolerances so loose that every step is accepted: the step is then the given largest step
    # (after a short start-up), and the error against expm falls as dt^5 (Dormand & Prince 1980).
    model = get_preset("lv2013")
    mu = 0.4
    x0 = model.static_equilibrium(mu) + np.array([1e-7, -2e-7, 5e-8])
    T = 0.004
    exact = _frozen_exact(model, mu, np.concatenate([x0, np.zeros(3)]), [T])[0, :3]
    dts, errs = [2e-5, 1e-5, 5e-6], []
    for dt in dts:
        ds = simulate(model, mu=mu, duration=T, fs=1000, x0=x0, dt=dt, rtol=0.5, atol=1.0)
        assert ds.attrs["rejected_steps"] == 0
        errs.append(np.linalg.norm(np.array([ds[n].values[-1] for n in model.dof_names]) - exact))
    order = np.polyfit(np.log(dts), np.log(errs), 1)[0]
    assert 4.4 < order < 5.4, (order, errs)   # measured 4.73

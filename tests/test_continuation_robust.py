"""Limit-cycle continuation past the non-smooth points of a contact that opens (squealkit.nonlinear).

A damped pin-on-disc rig (a user's, below) has a vertical onset: the contact law is piecewise
linear about steady sliding, so cycles of every small amplitude sit at the Hopf point until the
contact starts to open, where the branch turns towards larger slope or friction. Each AFT sample
where the contact opens puts a kink in the harmonic-balance residual, and the branch turns at each.
With the report's full settings the slope branch stopped there ("corrector_failed" at
tan(theta) = 0.0233, just past the Hopf point at 0.0230) while the quick settings, with coarser
steps, followed the same branch to the end of the range.

References:
- eq. (6) of Lv et al. (2013): the slope acts like friction, mu_e = mu + tan(theta); the cycle at
  the steepest slope matches the flat disc's at mu + tan(theta) (measured within 0.6 % by the
  quick run; asserted within 2 %).
- the periodic orbit of the same frozen-slope equations found in the time domain by shooting:
  classical RK4 over one period (400 steps) and Newton on the period map, which knows nothing of
  Fourier series, AFT samples or continuation. ``squealkit.transient.simulate`` cannot hold a slope
  frozen: it takes tan(theta) from dq/dt of its interpolated surface, so a surface at q = 0 is flat
  to it, and a real incline keeps raising the normal load through the grounded structure.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from squealkit.models import model_from_dict
from squealkit.nonlinear import contact_system, harmonic_balance, limit_cycle_branch, limit_cycle_branch_slope
from squealkit.nonlinear.continuation import CONTACT_SAMPLES
from squealkit.nonlinear.harmonic_balance import HBProblem, _Basis

# rigs whose pin bends far above the disc's frequency need mu > 1 to squeal: the warning says so, the branch
# is followed all the same
pytestmark = pytest.mark.filterwarnings("ignore::squealkit.stability.critical.UnrealisticFrictionWarning")

#: The user's damped rig (dampers c1, c2, c3 [N s/m]).
RIG = {"rig": {"pin_diameter": "25 mm", "pin_length": "50 mm", "pin_youngs_modulus": "2.95 GPa", "pin_density": 1040.0,
               "disc_mass": 4.1, "disc_freq": "2.9 kHz", "pin_bending_freq": "3.3 kHz", "pin_axial_freq": "rod"},
       "parameters": {"alpha_deg": 2.5, "c1": 8.0, "c2": 8.0, "c3": 5.0}}
#: The report's full (not quick) settings of its slope branch (report/steps_nonlinear.py).
N_POINTS, HARMONICS = 26, 10


def rig(c: float = 8.0, pin_bending_khz: float = 3.3):
    """The user's rig with dampers ``c, c, 0.6 c`` [N s/m] and another pin bending frequency."""
    data = {"rig": {**RIG["rig"], "pin_bending_freq": f"{pin_bending_khz} kHz"},
            "parameters": {"alpha_deg": 2.5, "c1": c, "c2": c, "c3": 0.6 * c}}
    return model_from_dict(data)


@pytest.fixture(scope="module")
def slope_branch():
    from squealkit.report.settings import ReportSettings

    model = model_from_dict(RIG)
    s = ReportSettings.for_model(model)
    t_max = 2 * math.pi * s.sro_amplitude / s.sro_wavelength  # the steepest slope of the Fig. 4 run-out (eq. 11)
    ds = limit_cycle_branch_slope(model, (-t_max, t_max), mu=s.mu_transient, harmonics=HARMONICS,
                                  n_points=N_POINTS, speed=s.speed)
    return model, s, t_max, ds


def test_slope_branch_of_the_damped_rig_reaches_the_end_of_the_range(slope_branch):
    _, _, t_max, ds = slope_branch
    assert ds.attrs["hopf_mu"] == pytest.approx(0.0230, abs=1e-4)  # the onset slope (as the report measured)
    assert ds.attrs["stop_reason"] == "left_range", ds.attrs.get("stop_detail")
    assert float(ds.tan_theta[-1]) == pytest.approx(t_max, rel=1e-12)
    assert "reached the end of the range" in ds.attrs["stop_detail"]
    # squealing beyond the onset: stable cycles bounded by loss of contact, growing with the slope
    beyond = ds.tan_theta.values > ds.attrs["hopf_mu"] + 0.005
    assert ds.stable.values[beyond].all()
    assert (ds.contact_loss_fraction.values[beyond] > 0.05).all()


def test_slope_branch_end_matches_the_flat_disc_at_mu_plus_tan_theta(slope_branch):
    # eq. (6): mu_e = mu + tan(theta). The flat disc's branch at mu_e, solved there from its nearest point.
    model, s, t_max, ds = slope_branch
    mu_e = s.mu_transient + t_max
    flat = limit_cycle_branch(model, (s.mu_transient, mu_e + 0.02), harmonics=HARMONICS, n_points=N_POINTS,
                              speed=s.speed, n_floquet=256, check_harmonics=False)
    assert flat.attrs["stop_reason"] == "left_range"
    i = int(np.argmin(np.abs(flat.mu.values - mu_e)))
    lc = harmonic_balance(contact_system(model, speed=s.speed), mu_e, omega=float(flat.omega_rad_s[i]),
                          guess=flat.coefficients[i].values, harmonics=HARMONICS, check_harmonics=False,
                          n_time=CONTACT_SAMPLES)  # as many AFT samples as the branches
    a_slope = float(ds.amplitude.sel(dof="x1")[-1])
    assert a_slope == pytest.approx(lc.amplitude[0], rel=0.02)  # measured 0.66 % (0.3451 um against 0.3428 um)
    assert float(ds.frequency_hz[-1]) == pytest.approx(lc.frequency_hz, rel=1e-3)


def _shoot(system, p: float, y: np.ndarray, T: float, steps: int = 400):
    """The periodic orbit through ``y`` (x1' = 0 there) of the frozen-parameter equations, by shooting.

    Classical RK4 over one period carries the state and its 2n finite-difference neighbours; Newton on
    ``Phi(y, T) - y = 0`` with the phase condition ``x1'(0) = 0``. Returns x1 over the period [m],
    the period [s] and the monodromy matrix (from the finite differences).
    """
    n = system.n_dof
    Minv = np.linalg.inv(system.M)
    om = 2 * math.pi / T
    scale = np.r_[np.full(n, system.length_scale), np.full(n, system.length_scale * om)]
    eps = 1e-6 * scale

    def rhs(Y):
        x, v = Y[:, :n], Y[:, n:]
        return np.hstack([v, (system.F0 + system.force(x, v, p)[0] - x @ system.K.T - v @ system.C.T) @ Minv.T])

    for _ in range(8):
        Y = np.vstack([y, y + np.diag(eps)])
        h = T / steps
        x1 = np.empty(steps + 1)
        x1[0] = Y[0, 0]
        for k in range(steps):
            k1 = rhs(Y)
            k2 = rhs(Y + 0.5 * h * k1)
            k3 = rhs(Y + 0.5 * h * k2)
            k4 = rhs(Y + h * k3)
            Y = Y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
            x1[k + 1] = Y[0, 0]
        r = np.r_[(Y[0] - y) / scale, y[n] / scale[n]]
        if np.linalg.norm(r) < 1e-10:
            break
        monodromy = ((Y[1:] - Y[0]) / eps[:, None]).T
        A = np.zeros((2 * n + 1, 2 * n + 1))
        A[:2 * n, :2 * n] = (monodromy - np.eye(2 * n)) * scale[None, :] / scale[:, None]
        A[:2 * n, 2 * n] = rhs(Y[:1])[0] / scale * T
        A[2 * n, n] = 1.0
        d = np.linalg.solve(A, -r)
        y, T = y + d[:2 * n] * scale, T * (1 + d[2 * n])
    else:
        raise AssertionError(f"shooting did not converge (residual {np.linalg.norm(r):.3g})")
    return x1, T, ((Y[1:] - Y[0]) / eps[:, None]).T


def test_slope_branch_end_is_the_periodic_orbit_of_a_time_integration(slope_branch):
    model, s, t_max, ds = slope_branch
    system = contact_system(model, mu=s.mu_transient, speed=s.speed, param="tan_theta")
    c, om = ds.coefficients.values[-1], float(ds.omega_rad_s[-1])
    b = _Basis.make(HARMONICS, 1024)
    X, V = b.E @ c, om * (b.dE @ c)
    j = int(np.argmax(X[:, 0]))  # start where x1 is largest (x1' = 0): the phase condition
    x1, T, monodromy = _shoot(system, t_max, np.r_[X[j], V[j]], 2 * math.pi / om)
    assert float(ds.amplitude.sel(dof="x1")[-1]) == pytest.approx(0.5 * np.ptp(x1), rel=2e-3)  # measured 1.3e-4
    assert float(ds.frequency_hz[-1]) == pytest.approx(1 / T, rel=1e-5)  # measured 8e-7
    # the steady state a transient settles on: every multiplier but the trivial one inside the unit circle
    mult = np.sort(np.abs(np.linalg.eigvals(monodromy)))
    assert mult[-1] == pytest.approx(1.0, abs=2e-3) and mult[-2] < 1.0 and bool(ds.stable.values[-1])


@pytest.mark.parametrize("branch", ["mu", "tan_theta"])
def test_lightly_damped_rig_is_followed_to_the_end_of_both_ranges(branch):
    # dampers 2, 2, 1.2 N s/m and the pin bending at 3.8 kHz: before the fix the corrector gave up at
    # mu = 1.0223 (range to 1.0854) and at tan(theta) = 0.0668 (range to 0.0691)
    from squealkit.stability import critical_friction

    model = rig(2.0, 3.8)
    mu_c = critical_friction(model, 0.0, damped=True, mu_max=2.0).mu_critical
    if branch == "mu":
        ds = limit_cycle_branch(model, (0.9 * mu_c, mu_c + 0.1), harmonics=HARMONICS, n_points=N_POINTS,
                                n_floquet=256, check_harmonics=False)
        end = mu_c + 0.1
    else:
        ds = limit_cycle_branch_slope(model, (-0.069, 0.069), mu=mu_c - 0.04, harmonics=HARMONICS,
                                      n_points=N_POINTS, n_floquet=256, check_harmonics=False)
        end = 0.069
    assert ds.attrs["stop_reason"] == "left_range", ds.attrs["stop_detail"]
    assert float(ds[branch][-1]) == pytest.approx(end, rel=1e-12)
    assert np.all(np.diff(ds.amplitude.sel(dof="x1").values) > -1e-3 * ds.amplitude.sel(dof="x1").values[:-1])


def _residual(system, ds, i: int) -> float:
    """The scaled harmonic-balance residual of point ``i`` of a branch, recomputed from its coefficients."""
    from squealkit.nonlinear.harmonic_balance import n_time_samples

    H = int(ds.attrs["harmonics"])
    c = ds.coefficients.values[i]
    prob = HBProblem(system, H, float(ds.omega_rad_s[i]), int(np.argmax(np.abs(c[1]))),
                     n_time=max(n_time_samples(H), CONTACT_SAMPLES))
    Z = c.copy()
    r, _ = prob.residual(prob.pack(Z, float(ds.omega_rad_s[i]), float(ds[system.param][i])))
    return float(np.linalg.norm(r[:-1]))  # the harmonic balance, without the phase row


@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(c=st.floats(1.5, 25.0), pin_bending_khz=st.floats(3.05, 4.0))
def test_a_branch_ends_at_its_range_or_says_where_and_why_it_stopped(c, pin_bending_khz):
    # never a silent wrong amplitude: either the branch reaches the end of its range, or it names the
    # reason and the place, and every point it returns (the last one too) solves harmonic balance
    from squealkit.stability import critical_friction

    model = rig(c, pin_bending_khz)
    crit = critical_friction(model, 0.0, damped=True, mu_max=2.0)
    assert crit.status == "onset"  # these rigs squeal on a flat disc within mu < 2
    hi = crit.mu_critical + 0.1
    ds = limit_cycle_branch(model, (0.9 * crit.mu_critical, hi), harmonics=HARMONICS, n_points=11,
                            n_floquet=256, check_harmonics=False)
    reason, detail = ds.attrs["stop_reason"], ds.attrs["stop_detail"]
    assert reason in ("left_range", "corrector_failed", "max_points", "max_amplitude")
    mu_last = float(ds.mu[-1])
    if reason == "left_range":
        assert mu_last == pytest.approx(hi, rel=1e-12) or mu_last == pytest.approx(0.9 * crit.mu_critical, rel=1e-12)
    else:
        assert f"mu = {mu_last:.6g}" in detail, detail
    system = contact_system(model)
    for i in (1, ds.sizes["point"] // 2, ds.sizes["point"] - 1):
        assert _residual(system, ds, i) < 1e-7, (i, detail)


@pytest.mark.parametrize(("c", "pin_bending_khz", "n_folds"), [(2.0, 3.3, 0), (8.0, 3.05, 2)])
def test_folds_are_turns_of_the_branch_not_kinks_of_the_residual(c, pin_bending_khz, n_folds):
    # The same branch followed with coarse and fine steps has the same folds: (8, 3.05) an S-shaped branch
    # (it turns back at mu = 0.126, forward again at 0.078); (2, 3.3) none, where the one-sided tangents
    # at the AFT samples that open next to the onset used to report two (mu = 0.2287 and 0.2348, coarse
    # steps only).
    from squealkit.stability import critical_friction

    model = rig(c, pin_bending_khz)
    mu_c = critical_friction(model, 0.0, damped=True, mu_max=2.0).mu_critical
    folds = [limit_cycle_branch(model, (0.9 * mu_c, mu_c + 0.1), harmonics=HARMONICS, n_points=n, n_floquet=256,
                                check_harmonics=False).fold_mu.values for n in (11, N_POINTS)]
    assert len(folds[0]) == len(folds[1]) == n_folds
    np.testing.assert_allclose(folds[0], folds[1], atol=2e-3)

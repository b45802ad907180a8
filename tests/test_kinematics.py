"""Contact kinematics: the paper's (eq. 2 as printed) against the consistent one (gap with tan(theta) x1).

References: the paper's forces (Lv, Zhang & Yu 2013, eqs. 1-3) rebuilt here by hand, with the
gap ``y1 - y2 - q - s tan(theta) x1`` of a contact point moving along the inclined surface
(issue 12); a frictionless elastic contact is conservative, so its stiffness is symmetric and
an undamped frictionless run keeps its energy; thresholds checked by LAPACK (scipy.linalg.eigvals)
on the hand-built matrices, not by squealkit's solver.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg

from squealkit.models import PinOnDisc3DOF, get_preset
from squealkit.models.config import model_from_dict
from squealkit.stability import critical_friction, stability_verdict
from squealkit.transient import SineRunOut, simulate


def _hand_stiffness(m: PinOnDisc3DOF, mu: float, t: float, consistent: bool) -> np.ndarray:
    """K from the paper's forces (eqs. 1-3), N = -kc delta / cos(theta), friction mu N.

    Contact force on (x1, y1, y2), sliding s: -kc delta u, u = [-s(mu + t), 1 - mu t, -(1 - mu t)];
    delta = y1 - y2 - q (paper) or y1 - y2 - q - s t x1 (consistent).
    """
    s, a = m.sliding, m.alpha
    K0 = np.array([[m.k1 + m.k2 * math.sin(a) ** 2, m.k2 * math.sin(a) * math.cos(a), 0.0],
                   [m.k2 * math.sin(a) * math.cos(a), m.k2 * math.cos(a) ** 2, 0.0],
                   [0.0, 0.0, m.k3]])
    u = np.array([-s * (mu + t), 1 - mu * t, -(1 - mu * t)])
    b = np.array([-s * t if consistent else 0.0, 1.0, -1.0])
    return K0 + m.kc * np.outer(u, b)


def _lapack_unstable(m: PinOnDisc3DOF, mu: float, t: float, consistent: bool) -> bool:
    w = scipy.linalg.eigvals(_hand_stiffness(m, mu, t, consistent), m.mass_matrix())  # lambda^2 = -w
    lam = np.sqrt(-w.astype(complex))
    return bool(np.max(np.abs(lam.real)) > 1e-6 * np.max(np.abs(lam)))


def _lapack_mu_crit(m, t, consistent, mu_max=2.0) -> float:
    """First onset on a 0.001 scan, then bisection (LAPACK only)."""
    grid = np.linspace(0.0, mu_max, 2001)
    flags = [_lapack_unstable(m, x, t, consistent) for x in grid]
    if not any(flags):
        return math.inf
    i = int(np.argmax(flags))
    lo, hi = grid[i - 1], grid[i]
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if _lapack_unstable(m, mid, t, consistent) else (mid, hi)
    return hi


@pytest.mark.parametrize("sliding", [1, -1])
@pytest.mark.parametrize("t", [-0.5, -0.14, 0.1, 0.5])
def test_matrices_match_the_hand_derivation(sliding, t):
    for kin in ("paper", "consistent"):
        m = PinOnDisc3DOF(sliding=sliding, kinematics=kin)
        for mu in (0.0, 0.4):
            np.testing.assert_allclose(m.stiffness_matrix(mu, t), _hand_stiffness(m, mu, t, kin == "consistent"),
                                       rtol=1e-14, atol=1e-6)


@pytest.mark.parametrize("t", [-0.5, -0.14, 0.14, 0.5])
def test_frictionless_consistent_stiffness_is_symmetric(t):
    K = PinOnDisc3DOF(kinematics="consistent").stiffness_matrix(0.0, t)
    np.testing.assert_allclose(K, K.T, rtol=0, atol=1e-9 * np.abs(K).max())
    Kp = PinOnDisc3DOF().stiffness_matrix(0.0, t)  # the paper's is not: kc t off the diagonal
    assert np.abs(Kp - Kp.T).max() == pytest.approx(abs(t) * PinOnDisc3DOF().kc)


@pytest.mark.parametrize("mu", [0.1, 0.4, 0.8])
@pytest.mark.parametrize("t", [-0.5, 0.0, 0.3])
def test_skew_part_scales_with_mu_one_plus_tan_squared(mu, t):
    m = PinOnDisc3DOF(kinematics="consistent")
    K = m.stiffness_matrix(mu, t)
    skew = np.linalg.norm(0.5 * (K - K.T))
    assert skew == pytest.approx(mu * m.kc * (1.0 + t * t), rel=1e-12)


def test_sliding_reverse_is_the_mirror_image():
    # x1 -> -x1 mirrors the rig: sliding -1 at alpha equals sliding +1 at -alpha, same mu and slope
    T = np.diag([-1.0, 1.0, 1.0])
    a = PinOnDisc3DOF(sliding=-1, kinematics="consistent")
    b = PinOnDisc3DOF(sliding=1, alpha=-a.alpha, kinematics="consistent")
    for mu, t in ((0.3, 0.2), (0.6, -0.4)):
        np.testing.assert_allclose(a.stiffness_matrix(mu, t), T @ b.stiffness_matrix(mu, t) @ T, rtol=1e-14)


def test_frictionless_consistent_contact_never_flutters():
    # issue 12: tan(theta) = 0.5, mu = 0: the paper's matrices flutter, no elastic contact can
    paper = get_preset("lv2013")
    consistent = paper.replace(kinematics="consistent")
    t = 0.5
    assert stability_verdict(paper, 0.0, tan_theta=t).item() == "flutter"
    assert stability_verdict(consistent, 0.0, tan_theta=t).item() == "stable"
    assert critical_friction(paper, math.atan(t)).status == "unstable_at_start"
    assert critical_friction(consistent, math.atan(t)).status != "unstable_at_start"
    slopes = np.linspace(-0.8, 0.8, 33)
    assert np.all(stability_verdict(consistent, 0.0, tan_theta=slopes) == "stable")


@pytest.mark.parametrize(("theta_deg", "kin", "expected"), [
    (8.0, "paper", 0.30492),       # issue 12: 0.305 in the paper's model
    (8.0, "consistent", math.inf),  # stable up to mu = 2
    (-8.0, "paper", 0.58474),      # = mu_crit(0) - tan(-8 deg): mu_e = mu + tan(theta) holds
    (-8.0, "consistent", 0.26600),  # the slope that stabilises in the paper destabilises here
    (0.0, "consistent", 0.44485),   # on a flat disc the two agree
])
def test_critical_friction_against_lapack(theta_deg, kin, expected):
    model = get_preset("lv2013").replace(kinematics=kin)
    t = math.tan(math.radians(theta_deg))
    ref = _lapack_mu_crit(model, t, kin == "consistent")
    c = critical_friction(model, math.radians(theta_deg))
    if math.isinf(expected):
        assert math.isinf(ref) and c.status == "stable_in_range"
        return
    assert ref == pytest.approx(expected, abs=1e-5)
    assert c.status == "onset"
    assert c.mu_critical == pytest.approx(ref, abs=1e-7)


def test_kinematics_option_in_model_files_and_json():
    m = model_from_dict({"preset": "lv2013", "parameters": {"kinematics": "consistent"}})
    assert m.kinematics == "consistent" and m.slope_coupled
    assert not get_preset("lv2013").slope_coupled
    d = m.to_dict()
    assert model_from_dict({"model": d["kind"], "parameters": d["parameters"]}) == m
    with pytest.raises(ValueError, match="kinematics='sideways' must be one of 'paper', 'consistent'"):
        get_preset("lv2013").replace(kinematics="sideways")


def test_cli_set_kinematics(run):
    import json

    out = {}
    for kin in ("paper", "consistent"):
        r = run("critical", "--theta", "8", "--set", f"kinematics={kin}", "--json")
        assert r.exit_code == 0, r.output
        out[kin] = json.loads(r.output)
    r = run("critical", "--set", "kinematics=diagonal", "--json")
    assert r.exit_code == 2 and "must be one of 'paper', 'consistent'" in r.output


def _energy(model, mu, t, q, ds):
    """E = T + V with V = x^T K x / 2 - F.x (K symmetric: the frictionless consistent contact)."""
    M, K, F = model.mass_matrix(), model.stiffness_matrix(mu, t), model.load_vector(mu, t, q)
    x = np.stack([ds[n].values for n in model.dof_names], axis=-1)
    v = np.stack([ds[f"{n}_dot"].values for n in model.dof_names], axis=-1)
    return 0.5 * np.einsum("ti,ij,tj->t", v, M, v) + 0.5 * np.einsum("ti,ij,tj->t", x, K, x) - x @ F


def test_frictionless_undamped_consistent_transient_conserves_energy():
    # Disc at rest (speed 0) on the steepest point of a sine run-out, tan(theta) = 0.5: q and
    # the slope are frozen. Consistent kinematics make it a conservative system: the energy of
    # the vibration is kept to the RK4 step's own dissipation (~(omega dt)^6 / 144 per step,
    # ~1e-5 over the run at dt = 1 us). The paper's matrices flutter here: the same run grows.
    profile = SineRunOut(0.5e-3 / (2 * math.pi), 1e-3)   # max slope 2 pi q0 / lambda = 0.5
    q, t = (float(a[0]) for a in profile.evaluate(np.array([0.0])))
    assert t == pytest.approx(0.5)
    growth = {}
    for kin in ("paper", "consistent"):
        model = get_preset("lv2013").replace(kinematics=kin).undamped()
        ds = simulate(model, mu=0.0, profile=profile, speed=0.0, duration=0.02, fs=20_000,
                      perturbation=1e-7, rng=np.random.default_rng(1), dt=1e-6)
        x_eq = model.static_equilibrium(0.0, t, q)
        x = np.stack([ds[n].values for n in model.dof_names], axis=-1) - x_eq
        growth[kin] = np.abs(x[-200:]).max() / np.abs(x[:200]).max()
        if kin == "consistent":
            E = _energy(model, 0.0, t, q, ds)
            E_eq = float(0.5 * x_eq @ model.stiffness_matrix(0.0, t) @ x_eq - x_eq @ model.load_vector(0.0, t, q))
            drift = np.abs(E - E[0]).max() / (E[0] - E_eq)   # relative to the vibration's energy
            assert drift < 1e-4, drift
    assert growth["consistent"] < 2.0 and growth["paper"] > 3.0, growth


@pytest.mark.parametrize("damped", [False, True])
def test_consistent_map_matches_lapack_point_by_point(damped):
    # the compiled kernel takes the slope terms per point (warm-started along each row);
    # reference: LAPACK on every point's state matrix
    from squealkit.stability import stability_map

    model = get_preset("lv2013").replace(kinematics="consistent")
    mu = np.linspace(0.0, 0.8, 41)
    theta = np.radians(np.linspace(-8.0, 8.0, 41))
    ds = stability_map(model, mu, theta, damped=damped)
    MU, T = np.meshgrid(mu, np.tan(theta), indexing="ij")
    M, K = model.mass_matrix(), model.stiffness_matrix(MU, T)
    C = model.damping_matrix() if damped else np.zeros_like(M)
    A = np.zeros((*MU.shape, 6, 6))
    A[..., :3, 3:] = np.eye(3)
    A[..., 3:, :3] = -np.linalg.solve(M, K)
    A[..., 3:, 3:] = -np.linalg.solve(M, C)
    w = np.linalg.eigvals(A)
    scale = np.abs(w).max(axis=-1)
    smax = w.real.max(axis=-1)
    clear = np.abs(smax) > 1e-6 * scale  # LAPACK's verdict is clear there
    np.testing.assert_array_equal(ds.any_unstable.values[clear], (smax > 0)[clear])
    np.testing.assert_allclose(ds.max_growth_rate.values, smax, rtol=0, atol=1e-12 * scale.max())

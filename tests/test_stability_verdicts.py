"""Verdicts and unstable windows that no model can fool (issue #10).

References: LAPACK (``numpy.linalg.eigvals``) on the 2n x 2n state matrix where its verdict
is clear (max Re above 1e-6 of max |lambda|, or below 1e-11 of it), and mpmath's
eigenvalues of the same matrix in 40-digit arithmetic where it is not; closed forms for
the constructed models below.
"""

from __future__ import annotations

import json
import math

import mpmath
import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from squealkit.cli.main import cli
from squealkit.models import MatrixModel, get_preset
from squealkit.stability import critical_friction, eigenvalues, runout_tolerance, stability_verdict

CLEAR_UNSTABLE = 1e-6
CLEAR_STABLE = 1e-11


def state_matrix(M, C, K):
    n = M.shape[0]
    Mi = np.linalg.inv(M)
    return np.block([[np.zeros((n, n)), np.eye(n)], [-Mi @ K, -Mi @ C]])


def reference_verdict(M, C, K) -> str:
    """'stable' / 'unstable' from LAPACK, or from 40-digit mpmath where LAPACK is unclear."""
    w = np.linalg.eigvals(state_matrix(M, C, K))
    rel = w.real.max() / np.abs(w).max()
    if rel > CLEAR_UNSTABLE:
        return "unstable"
    if rel < CLEAR_STABLE:
        return "stable"
    with mpmath.workdps(40):
        n = M.shape[0]
        A = mpmath.matrix(2 * n, 2 * n)
        Mi = mpmath.inverse(mpmath.matrix(M.tolist()))
        Km, Cm = mpmath.matrix(K.tolist()), mpmath.matrix(C.tolist())
        B1, B2 = -Mi * Km, -Mi * Cm
        for i in range(n):
            A[i, n + i] = 1
            for j in range(n):
                A[n + i, j] = B1[i, j]
                A[n + i, n + j] = B2[i, j]
        ev = mpmath.eig(A, left=False, right=False)
        rel = max(mpmath.re(x) for x in ev) / max(abs(x) for x in ev)
    if rel > 1e-9:
        return "unstable"
    if rel < 1e-20:
        return "stable"
    return "unclear"


def matrices(m: MatrixModel, mu: float, damped: bool):
    K0, Kn, Kf = m.stiffness_parts()
    return m.M, (m.C if damped else np.zeros_like(m.M)), K0 + Kn + m.sliding * mu * Kf


# --- issue case 1: divergence (a real positive root) is never dropped --------------------

def test_preset_divergence_is_reported():
    # LAPACK on the state matrix of the paper's rig, damped, mu = 1.885, theta = 45 deg:
    # a real root of +933.8 1/s (issue #10, case 1)
    m = get_preset("lv2013")
    assert stability_verdict(m, 1.885, tan_theta=1.0, damped=True).tolist() == "divergence"
    lam = eigenvalues(m, 1.885, tan_theta=1.0, damped=True)
    assert lam.real.max() == pytest.approx(933.8, abs=0.1)
    res = CliRunner().invoke(cli, ["stability", "--mu", "1.885:1.885:1", "--theta=45:45:1", "--damped", "--json"])
    assert res.exit_code == 0, res.output
    out = json.loads(res.output)
    assert out["unstable_fraction"] == 1.0
    assert out["max_growth_rate"] == pytest.approx(933.8, abs=0.1)


# --- issue case 2: disc doublets ---------------------------------------------------------

# a doublet split by 1e-10 (both halves carried alike by friction), and a third mode
K_D, D, C_SKEW, K3 = 1e6, 0.8e6, 0.1e6, 1.1735e6
K0_DOUBLET = np.diag([K_D, K_D * (1 + 1e-10), K3])
# one-way friction coupling inside the doublet: triangular, eigenvalues = diagonal, stable
ONE_WAY = MatrixModel(M=np.eye(3), K0=K0_DOUBLET, Kf=[[D, 0.3 * D, 0], [0, D, 0], [0, 0, 0]])
# skew coupling of one half to the third mode: lock-in where (K3 - K_D - mu D)^2 = 4 mu^2 c^2,
# i.e. on [(K3 - K_D) / (D + 2c), (K3 - K_D) / (D - 2c)] = [0.1735, 0.289167]
SKEW = MatrixModel(M=np.eye(3), K0=K0_DOUBLET, Kf=[[D, 0, 0], [0, D, C_SKEW], [0, -C_SKEW, 0]])


def test_one_way_coupled_doublet_is_stable_for_every_mu():
    c = critical_friction(ONE_WAY)
    assert c.status == "stable_in_range" and c.unstable_intervals == ()
    assert set(stability_verdict(ONE_WAY, np.linspace(0, 2, 41)).tolist()) == {"stable"}


def test_skew_coupled_doublet_onset_is_the_closed_form():
    lo, hi = (K3 - K_D) / (D + 2 * C_SKEW), (K3 - K_D) / (D - 2 * C_SKEW)
    c = critical_friction(SKEW)
    assert c.status == "onset"
    assert c.mu_critical == pytest.approx(lo, abs=1e-8)
    assert len(c.unstable_intervals) == 1
    assert c.unstable_intervals[0] == pytest.approx((lo, hi), abs=1e-8)


# --- issue case 3: every unstable window ---------------------------------------------------

# three modes: a narrow lock-in of modes 1-2 (width 4e-4) below a wide one of modes 2-3.
# Reference windows from LAPACK on a 1e-5 grid over [0, 2]: [0.30299, 0.30339] and
# [0.78382, 1.04624] (see test below for the check at the edges).
S = 1e6
TWO_WINDOWS = MatrixModel(
    M=np.eye(3), K0=np.diag([1.0, 1.3023, 2.3023]) * S,
    Kf=np.array([[1.0, 3.31e-4, 0], [-3.31e-4, 0, 0.08], [0, -0.08, -1.1158]]) * S,
)


def test_narrow_first_window_and_restabilisation_are_found():
    c = critical_friction(TWO_WINDOWS)
    assert c.status == "onset"
    assert len(c.unstable_intervals) == 2
    (a, b), (c2, d2) = c.unstable_intervals
    assert c.mu_critical == a
    assert (a, b, c2, d2) == pytest.approx((0.30299, 0.30339, 0.78382, 1.04624), abs=1e-5)
    # each end is a boundary: LAPACK unstable just inside, stable just outside
    for lo, hi in c.unstable_intervals:
        for x, inside in ((lo - 1e-7, False), (lo + 1e-7, True), (hi - 1e-7, True), (hi + 1e-7, False)):
            assert (reference_verdict(*matrices(TWO_WINDOWS, x, False)) == "unstable") == inside


def _toml(a) -> str:
    return "[" + ", ".join("[" + ", ".join(repr(float(x)) for x in r) + "]" for r in a) + "]"


def test_critical_json_lists_every_window(tmp_path):
    cfg = tmp_path / "two_windows.toml"
    cfg.write_text(f'model = "matrix"\n[matrices]\nM = {_toml(TWO_WINDOWS.M)}\nK0 = {_toml(TWO_WINDOWS.K0)}\n'
                   f'Kf = {_toml(TWO_WINDOWS.Kf)}\n')
    res = CliRunner().invoke(cli, ["critical", "--config", str(cfg), "--json"])
    assert res.exit_code == 0, res.output
    out = json.loads(res.output)
    assert out["status"] == "onset"
    assert np.array(out["unstable_intervals"]) == pytest.approx(
        np.array([[0.30299, 0.30339], [0.78382, 1.04624]]), abs=1e-5)


def test_window_open_at_the_range_end_ends_there():
    # the paper's rig: unstable from 0.4448 on (test_stability), open at mu_max
    c = critical_friction(get_preset("lv2013"), mu_max=1.0)
    assert len(c.unstable_intervals) == 1 and c.unstable_intervals[0][1] == 1.0


def test_runout_tolerance_sees_a_narrow_slope_window():
    # at mu = 0.2 the narrow window of TWO_WINDOWS is reached by a slope: mu_e = mu + tan
    # theta with Kn = 0 (only mu_e enters), so the first unstable slope is 0.30299 - 0.2
    tol = runout_tolerance(TWO_WINDOWS, 0.2)
    assert tol.limiting_side == "rising"
    assert tol.tan_theta_max == pytest.approx(0.30299 - 0.2, abs=1e-5)


# --- property: every verdict right, on random models of every kind ------------------------

def _spd(rng, n, scale):
    A = rng.standard_normal((n, n))
    return scale * (A @ A.T / n + 0.2 * np.eye(n))


@st.composite
def models(draw):
    n = draw(st.integers(2, 6))
    kind = draw(st.sampled_from(["general", "overdamped", "gyroscopic", "rigid_body", "doublet", "divergence"]))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    M = np.diag(rng.uniform(0.5, 2.0, n))
    K0 = _spd(rng, n, 1e6)
    Kf = 3e5 * rng.standard_normal((n, n))
    C = np.zeros((n, n))
    if kind == "general":
        C = _spd(rng, n, 30.0) * rng.uniform(0, 1)
    elif kind == "overdamped":
        C = _spd(rng, n, 1e5)  # far above critical damping 2 sqrt(k m) ~ 2e3
    elif kind == "gyroscopic":
        G = 500.0 * rng.standard_normal((n, n))
        C = G - G.T + (_spd(rng, n, 10.0) if rng.uniform() < 0.5 else 0.0)
    elif kind == "rigid_body":
        w, V = np.linalg.eigh(K0)
        w[0] = 0.0  # a free (rigid-body) mode, lambda = 0
        K0 = V @ np.diag(w) @ V.T
        Kf[:, :] = 0.0
        Kf[1:, 1:] = 3e5 * rng.standard_normal((n - 1, n - 1))
        K0[0, :] = K0[:, 0] = 0.0
        K0[0, 0] = 0.0
    elif kind == "doublet":
        w = rng.uniform(0.5e6, 2e6, n)
        w[1] = w[0] * (1 + draw(st.sampled_from([0.0, 1e-12, 1e-10, 1e-8])))
        K0 = np.diag(w)
        Kf = np.zeros((n, n))
        i, j = rng.choice(n, 2, replace=False)
        Kf[i, j] = 3e5 * rng.standard_normal()
        if rng.uniform() < 0.5:
            Kf[j, i] = -Kf[i, j] * rng.uniform(0, 1.5)
        Kf[np.diag_indices(n)] = 1e5 * rng.standard_normal(n)
    elif kind == "divergence":
        Kf = -_spd(rng, n, 1e6) + 1e5 * rng.standard_normal((n, n))
    return MatrixModel(M=M, K0=K0, C=C, Kf=Kf), kind


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(models(), st.lists(st.floats(0.0, 1.5), min_size=1, max_size=6))
def test_verdict_agrees_with_lapack_and_mpmath(case, mus):
    model, kind = case
    ours = stability_verdict(model, np.array(mus), damped=True)
    for mu, v in zip(mus, ours.tolist(), strict=True):
        ref = reference_verdict(*matrices(model, mu, True))
        if ref == "unclear":
            continue
        if ref == "unstable":
            assert v in ("flutter", "divergence"), (kind, mu, v)
        else:
            assert v == "stable", (kind, mu, v)


@settings(max_examples=30, deadline=None)
@given(models())
def test_divergence_is_a_real_growing_root(case):
    model, _kind = case
    mus = np.linspace(0.0, 1.5, 7)
    ours = stability_verdict(model, mus, damped=True)
    for mu, v in zip(mus, ours.tolist(), strict=True):
        if v != "divergence":
            continue
        w = np.linalg.eigvals(state_matrix(*matrices(model, mu, True)))
        grow = w[w.real > CLEAR_UNSTABLE * np.abs(w).max()]
        if grow.size:  # LAPACK clear: a growing root is real (to rounding)
            assert np.min(np.abs(grow.imag)) < 1e-6 * np.abs(w).max(), (mu, grow)


def test_rigid_body_mode_is_not_unstable():
    # a free DOF: lambda = 0 twice (rigid-body translation), the rest stable
    m = MatrixModel(M=np.eye(2), K0=[[0.0, 0.0], [0.0, 1e6]])
    assert stability_verdict(m, [0.0, 0.5], damped=True).tolist() == ["stable", "stable"]
    assert math.isnan(critical_friction(m).mu_critical)

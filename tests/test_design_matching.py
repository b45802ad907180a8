"""Robust margins' Monte Carlo: each sample's modes matched to the nominal ones by shape and eigenvalue.

A near-degenerate pair (a brake disc's doublet, two modes of almost one frequency) whose scatter moves the two
frequencies apart in opposite directions crosses in a share of the samples; matched by the nearest eigenvalue,
the crossed samples swap the two modes and give each the other's growth rate, silently. References: closed forms
of uncoupled oscillators (each mode's eigenvector is a unit vector whatever the scatter, so its identity and
growth rate are known exactly), and the full-model backward error of every sample's eigenpairs.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from squealkit.design import robust_margins
from squealkit.fe.model import FEModel

K0 = (2 * math.pi * 100.0) ** 2  # 100 Hz with a unit mass
SPLIT = 0.01  # the pair's stiffnesses differ by 1 % (frequencies by 0.5 %)
E = 0.2 * K0  # the scattered part moves the two stiffnesses by -+ E (s - 1)
C_A, C_B = -0.2, 0.2  # damping of the two oscillators: growth rates +0.1 and -0.1 1/s


def _crossing_pair() -> FEModel:
    """Two uncoupled oscillators: x_A'' - 0.2 x_A' + (K0 + E (s - 1)) x_A = 0 and
    x_B'' + 0.2 x_B' + (K0 (1 + SPLIT) - E (s - 1)) x_B = 0, with ``s`` the scale of KR (nominal 1).

    Mode A grows (sigma = +0.1 1/s) and mode B decays (-0.1 1/s) whatever ``s``: P_A = 1, P_B = 0
    exactly. Their frequencies cross where ``2 E (s - 1) = SPLIT K0``, s = 1.025: half a standard
    deviation at a 5 % scatter, so about 31 % of the samples cross.
    """
    return FEModel.from_matrices(M=np.eye(2), K1=np.diag([K0 - E, K0 * (1 + SPLIT) + E]), KR=np.diag([E, -E]),
                                 D1=np.diag([C_A, C_B]))


def test_a_crossing_pair_keeps_each_modes_own_growth_rate():
    ds = robust_margins(_crossing_pair(), rpm=0.0, scatter={"KR": 0.05}, samples=400, seed=2,
                        method="montecarlo")
    s = ds.parameter_value.values[:, 0]
    crossed = 2 * E * (s - 1) > SPLIT * K0
    assert 0.2 < crossed.mean() < 0.45  # the test means something: many samples cross
    mc = ds.sel(estimator="montecarlo")
    # closed form: sigma_A = -C_A / 2, sigma_B = -C_B / 2 in every sample (uncoupled, damping not scattered)
    np.testing.assert_allclose(mc.sampled_growth_rate.values[:, 0], -C_A / 2, rtol=1e-9)
    np.testing.assert_allclose(mc.sampled_growth_rate.values[:, 1], -C_B / 2, rtol=1e-9)
    assert mc.probability_unstable.values.tolist() == [1.0, 0.0]
    assert mc.propensity.item() == 1.0


def _veering_pair(split: float) -> FEModel:
    """Two 100 Hz oscillators, stiffnesses K0 and K0 (1 + split), coupled by ``E (s - 1)`` off the diagonal
    (the scattered KR minus its nominal in K1): the scatter rotates the pair's shapes. Equal damping 0.2 N s/m
    (proportional: the shapes are those of K, real). Nominal shapes: the unit vectors."""
    X = E * np.array([[0.0, 1.0], [1.0, 0.0]])
    return FEModel.from_matrices(M=np.eye(2), K1=np.diag([K0, K0 * (1 + split)]) - X, KR=X, D1=0.2 * np.eye(2))


def test_a_doublet_mixed_by_the_scatter_is_indeterminate_not_picked():
    split = 1e-3
    with pytest.warns(UserWarning, match="ambiguous"):
        ds = robust_margins(_veering_pair(split), rpm=0.0, scatter={"KR": 0.05}, samples=300, seed=4,
                            method="montecarlo")
    # independent reference: the shapes of each sample's K (numpy.linalg.eigh, ascending: the lower mode
    # continues the nominal lower one, e_1) and their MAC with e_1; near-equal MACs (|2 MAC - 1| small) cannot
    # tell the two modes apart, clear ones can
    mac_ref = np.empty(ds.sizes["sample"])
    for i, s in enumerate(ds.parameter_value.values[:, 0]):
        K = np.diag([K0, K0 * (1 + split)]) + E * (s - 1) * np.array([[0.0, 1.0], [1.0, 0.0]])
        mac_ref[i] = np.linalg.eigh(K)[1][0, 0] ** 2
    clear, mixed = np.abs(2 * mac_ref - 1) > 0.15, np.abs(2 * mac_ref - 1) < 0.05
    assert clear.sum() > 20 and mixed.sum() > 20  # both kinds occur
    flag = ds.match_indeterminate.values
    assert not flag[clear].any() and flag[mixed].all()
    mc = ds.sel(estimator="montecarlo")
    growth = mc.sampled_growth_rate.values
    assert np.isnan(growth[flag]).all()
    np.testing.assert_allclose(growth[~flag], -0.1, rtol=1e-9)  # proportional damping: sigma = -c / 2
    # both candidates of every ambiguous match are stable: the per-mode probability is still known, exactly 0;
    # the mean and standard deviation are not (NaN), and the system's propensity does not need the match
    assert mc.probability_unstable.values.tolist() == [0.0, 0.0]
    assert np.isnan(mc.growth_rate_mean.values).all()
    assert mc.propensity.item() == 0.0


def test_every_sample_is_checked_in_the_full_model():
    # a 3-DOF chain reduced on a 2-vector basis that is not invariant: each sample's reduced pairs have a
    # real backward error; reference: the full matrices' pencil_backward_errors of (lambda, V y), with (lambda, y)
    # from scipy.linalg.eig of the reduced pencil of that sample
    import scipy.linalg as sla

    from squealkit.solvers.band import pencil_backward_errors

    k = K0 * np.array([[2.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.5]])
    kr = 0.05 * K0 * np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    model = FEModel.from_matrices(M=np.eye(3), K1=k, KR=kr, D1=0.5 * np.eye(3))
    V = np.linalg.qr(np.array([[1.0, 0.3], [0.9, -0.5], [0.4, 1.0]]))[0]
    ds = robust_margins(model, rpm=0.0, scatter={"KR": 0.1, "K1": 0.02}, samples=40, seed=1, basis=V,
                        band=(0.0, 1e4), method="montecarlo", eta_max=1.0)
    assert ds.attrs["residual_checked"] == 41  # the nominal and every sample
    got = ds.sample_residual.values
    ref = np.empty(got.size)
    for i, (s_kr, s_k1) in enumerate(ds.parameter_value.values):
        Mr, Cr, Kr = V.T @ V, 0.5 * V.T @ V, V.T @ (s_k1 * k + s_kr * kr) @ V
        A = np.block([[np.zeros((2, 2)), np.eye(2)], [-Kr, -Cr]])
        B = np.block([[np.eye(2), np.zeros((2, 2))], [np.zeros((2, 2)), Mr]])
        lam, Z = sla.eig(A, B)
        keep = lam.imag >= 0
        ref[i] = pencil_backward_errors(np.eye(3), 0.5 * np.eye(3), s_k1 * k + s_kr * kr, lam[keep],
                                        V @ Z[:2, keep]).max()
    assert ref.min() > 1e-3  # the basis does not hold the model: a real check
    np.testing.assert_allclose(got, ref, rtol=1e-8)
    assert ds.attrs["max_residual"] == pytest.approx(max(ref.max(), ds.attrs["max_residual"]))
    assert ds.attrs["max_residual"] >= ref.max()

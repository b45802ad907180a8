"""Reduction of FE brake models: modal and POD bases, reduced eigenvalues and their residuals."""

import math

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from hypothesis import given, settings
from hypothesis import strategies as st

from squealkit import InputError
from squealkit.solvers.band import backward_errors, band_eigs
from squealkit.solvers.reduction import (
    as_fe_model,
    modal_basis,
    pod_basis,
    reduce,
    reduced_eigs,
    reduced_sweep,
)

pytest.importorskip("skfem")

BAND = (10e3, 14e3)  # a narrow band keeps the full reference solves fast on the small mesh


@pytest.fixture(scope="module")
def brake():
    from squealkit.fe.demo import build_fe_demo

    return build_fe_demo(n_theta=16, n_r=2)


@pytest.fixture(scope="module")
def pod(brake):
    V = pod_basis(brake, [50.0], [0.3, 0.6], band=BAND, extra=modal_basis(brake, freq_max=20e3))
    return reduce(brake, V)


def full(brake, omega, mu, band=BAND):
    sol = band_eigs(as_fe_model(brake), omega, mu, band=band)
    return sol.eigenvalues, sol.vectors


def nearest_rel_error(lam, ref):
    return np.array([np.min(np.abs(ref - x)) / abs(x) for x in lam])


@pytest.mark.slow
def test_band_solver_agrees_with_scipy_shift_invert(brake):
    # independent reference: scipy's own shift-invert on the companion pencil (A - s B)
    omega, mu = 50.0, 0.45
    lam, X = full(brake, omega, mu)
    n = brake["M"].shape[0]
    eye = sp.identity(n, format="csr")
    C = brake["D1"] + omega / brake["disc_speed_ref"] * brake["DG"]
    K = brake["K1"] + mu / brake["mu_ref"] * brake["KR"] + (omega / brake["disc_speed_ref"]) ** 2 * brake["KGeo"]
    A = sp.bmat([[None, eye], [-K, -C]], format="csc").astype(complex)
    B = sp.bmat([[eye, None], [None, brake["M"]]], format="csc").astype(complex)
    ref = spla.eigs(A, k=4, M=B, sigma=2j * math.pi * 12e3, return_eigenvectors=False)
    assert np.max(nearest_rel_error(ref, lam)) < 1e-10
    assert np.max(backward_errors(as_fe_model(brake), omega, mu, lam, X)) < 1e-12


def test_modal_basis_is_mass_normalised_up_to_the_cut_off(brake):
    V, freq = modal_basis(brake, freq_max=15e3, return_freq=True)
    assert np.all(freq <= 15e3) and np.all(np.diff(freq) >= 0)
    np.testing.assert_allclose(V.T @ (brake["M"] @ V), np.eye(V.shape[1]), atol=1e-9)
    # k = m (2 pi f)^2 per mode: V^T K1 V = diag((2 pi f)^2)
    np.testing.assert_allclose(np.diag(V.T @ (brake["K1"] @ V)), (2 * math.pi * freq) ** 2, rtol=1e-9)
    ref = spla.eigsh(brake["K1"], k=len(freq) + 1, M=brake["M"], sigma=0.0, return_eigenvectors=False)
    ref = np.sort(np.sqrt(ref)) / (2 * math.pi)
    np.testing.assert_allclose(freq, ref[: len(freq)], rtol=1e-10)
    assert ref[len(freq)] > 15e3


@settings(max_examples=25, deadline=None)
@given(n=st.integers(5, 60), seed=st.integers(0, 2**32 - 1), frac=st.floats(0.0, 1.0))
def test_sturm_count_matches_lapack(n, seed, frac):
    # reference: the generalized symmetric eigenvalues of LAPACK (eigh) below the cut-off
    from squealkit.solvers.lu import fill_reducing_order
    from squealkit.solvers.reduction import count_below

    rng = np.random.default_rng(seed)
    A = sp.random(n, n, density=0.2, random_state=rng) + sp.identity(n)
    K = (A @ A.T).tocsc()  # symmetric positive definite, sparse
    M = sp.diags(rng.uniform(0.5, 2.0, n)).tocsc()
    w = sla.eigh(K.toarray(), M.toarray(), eigvals_only=True)
    w2 = float(np.quantile(w, frac)) * (1 + 1e-6) + 1e-9  # between eigenvalues, not on one
    count = count_below(K, M, w2, fill_reducing_order(K, M))
    assert count == int(np.sum(w < w2))


def test_modal_basis_counts_its_modes_before_solving(brake):
    # the cut-off's Sturm count sizes the single eigsh call: the built-in brake's count agrees
    # with the dense modes below 15 kHz
    from squealkit.solvers.lu import fill_reducing_order
    from squealkit.solvers.reduction import count_below

    w = sla.eigh(brake["K1"].toarray(), brake["M"].toarray(), eigvals_only=True)
    for f in (3e3, 15e3, 40e3):
        w2 = (2 * math.pi * f) ** 2
        assert count_below(brake["K1"], brake["M"], w2, fill_reducing_order(brake["K1"])) == np.sum(w < w2)


@pytest.mark.slow
def test_pod_reduction_agrees_with_full_solve_where_trusted(brake, pod):
    # between the samples (mu = 0.3, 0.6) and away from their speed
    for omega, mu in ((50.0, 0.45), (20.0, 0.52)):
        red = reduced_eigs(pod, omega, mu, band=BAND)
        lam, _ = full(brake, omega, mu)
        assert len(red["eigenvalue"]) == len(lam)
        err = nearest_rel_error(red["eigenvalue"], lam)
        assert red["trusted"].all()
        assert np.max(err[red["trusted"]]) < 1e-6
        # the unstable (mode-coupling) pair is found by the reduced model too
        assert np.any(red["growth_rate"] > 0) == np.any(lam.real > 0)


@pytest.mark.slow
def test_left_corrections_make_the_reduced_eigenvalues_more_accurate(brake):
    # friction (KR) makes left and right eigenvectors differ; a basis of right eigenvectors
    # only gives eigenvalue errors first order in the left vectors' error. Measured: 4.7e-7
    # without, 5.5e-8 with the static corrections K1^-1 KR^T V0 (same POD tolerance).
    V0 = modal_basis(brake, freq_max=20e3)
    worst = {}
    for left in (False, True):
        red = reduce(brake, pod_basis(brake, [50.0], [0.3, 0.6], band=BAND, extra=V0, left=left, tol=1e-10))
        errs = []
        for omega, mu in ((50.0, 0.45), (20.0, 0.52), (100.0, 0.35)):
            lam, _ = full(brake, omega, mu)
            errs.append(nearest_rel_error(reduced_eigs(red, omega, mu, band=BAND)["eigenvalue"], lam).max())
        worst[left] = max(errs)
    assert worst[True] < 1e-7 and worst[True] < 0.3 * worst[False]


def test_left_corrections_need_a_restrained_model(brake):
    # a DOF without stiffness (an unrestrained node): K1 exactly singular
    n = brake["K1"].shape[0]
    keep = sp.diags(np.r_[0.0, np.ones(n - 1)])
    loose = dict(brake, K1=(keep @ brake["K1"] @ keep).tocsr())
    no_snapshots = lambda *args: (None, np.zeros((n, 0)))  # noqa: E731 - only the corrections are tried
    with pytest.raises(InputError, match="K1 is singular"):
        pod_basis(loose, [50.0], [0.3], band=BAND, extra=np.eye(n, 3), eig_solver=no_snapshots)


def test_residual_flags_a_too_small_basis(brake):
    # 12 real modes (up to ~4 kHz) cannot represent modes at 10-14 kHz: every reduced
    # eigenvalue there is wrong, and the residual says so
    small = reduce(brake, modal_basis(brake, n_modes=12))
    red = reduced_eigs(small, 50.0, 0.45, band=(1e3, 16e3))
    lam, _ = full(brake, 50.0, 0.45, band=(1e3, 16e3))
    err = nearest_rel_error(red["eigenvalue"], lam)
    assert (~red["trusted"]).any()
    assert np.all(~red["trusted"][err > 1e-6])
    # and the worse the eigenvalue, the larger its residual: 1e-3 off means ~1e-5 (Frobenius norms)
    assert np.all(red["residual"][err > 1e-3] > 1e-6)


def test_reduced_residual_is_the_full_model_backward_error(brake, pod):
    # the same definition as the sparse and dense solvers (Frobenius norms of the assembled
    # C(omega, mu) and K(omega, mu)), evaluated on the lifted vector V y in the full model
    for omega, mu in ((50.0, 0.45), (5.0, 0.0), (200.0, 1.3)):
        red = reduced_eigs(pod, omega, mu, band=BAND, vectors=True)
        ref = backward_errors(as_fe_model(brake), omega, mu, red["eigenvalue"], red["vector"])
        np.testing.assert_allclose(red["residual"], ref, rtol=1e-6)


def test_reduced_sweep_dataset(pod):
    ds = reduced_sweep(pod, [20.0, 50.0], [0.0, 0.3, 0.6], band=BAND)
    assert ds.growth_rate.dims == ("rpm", "mu", "mode")  # the disc speed is rpm / disc_speed, never omega
    assert ds.sizes["rpm"] == 2 and ds.sizes["mu"] == 3
    np.testing.assert_allclose(ds.rpm, np.array([20.0, 50.0]) * 60 / (2 * math.pi))
    assert not ds.any_unstable.sel(mu=0.0).any()
    assert ds.any_unstable.sel(mu=0.6).all()
    assert ds.growth_rate.attrs["units"] == "1/s"


def test_bad_input_is_rejected(brake):
    with pytest.raises(InputError, match="freq_max"):
        modal_basis(brake)
    with pytest.raises(InputError, match="band"):
        reduced_eigs(reduce(brake, modal_basis(brake, n_modes=4)), 1.0, 0.3, band=(5e3, 1e3))
    with pytest.raises(InputError, match="K1"):
        modal_basis({"M": brake["M"]}, n_modes=3)


def test_reduced_sweep_tracks_modes_by_mac(pod):
    # tracking only relabels: each point keeps its eigenvalues; a tracked mode moves
    # smoothly along mu (the friction matrix enters linearly), here by < 2 % per 0.1 of mu
    mus = np.linspace(0.0, 0.6, 7)
    tracked = reduced_sweep(pod, [20.0, 50.0], mus, band=BAND)
    plain = reduced_sweep(pod, [20.0, 50.0], mus, band=BAND, track=False)
    assert tracked.attrs["tracked"] == 1 and plain.attrs["tracked"] == 0
    for i in range(2):
        for j in range(mus.size):
            a = tracked.frequency_hz.values[i, j]
            b = plain.frequency_hz.values[i, j]
            np.testing.assert_allclose(np.sort(a[~np.isnan(a)]), np.sort(b[~np.isnan(b)]), rtol=1e-12)
    lam = tracked.growth_rate.values + 2j * math.pi * tracked.frequency_hz.values
    step = np.abs(np.diff(lam, axis=1)) / np.abs(lam[:, :-1])
    assert np.nanmax(step) < 0.02
    # by frequency, the labels jump where two modes cross or coalesce; tracking never does worse
    lam_p = plain.growth_rate.values + 2j * math.pi * plain.frequency_hz.values
    assert np.nanmax(step) <= np.nanmax(np.abs(np.diff(lam_p, axis=1)) / np.abs(lam_p[:, :-1]))

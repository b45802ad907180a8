"""Robust margins (issue #26 item 4): propensity under parameter scatter by Monte Carlo and by perturbation.

References: eigenvalue derivatives against central differences of LAPACK eigenvalues (random small
models drawn by hypothesis, the built-in FE brake); a 2-DOF model whose growth rate is linear in its
scattered parameter (closed-form mean, standard deviation and probability); the existing exact
first-order sensitivities of the small models (``stability.eigenvalue_sensitivity``).
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from scipy import stats

from squealkit import InputError
from squealkit.design import PerturbationWarning, robust_margins
from squealkit.design._pencil import _linear_matrices, _state_eigvals
from squealkit.design._scatter import _uncertain
from squealkit.design.perturbation import _second_order_derivatives
from squealkit.design.robust import _fe_setup
from squealkit.fe.model import FEModel, rpm_to_disc_speed

RPM, MU = 500.0, 0.13  # the built-in brake's 11.7 kHz pair is just stable here (growth rate -3.7 1/s)
BAND = (11.2e3, 12.2e3)
SCATTER = {"KR": 0.02, "D1": 0.2}


def _nearest(lam: np.ndarray, ref: np.ndarray) -> np.ndarray:
    return lam[np.argmin(np.abs(lam[None, :] - ref[:, None]), axis=1)]


def _fd(func, p0: np.ndarray, ref: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
    """Central differences of the eigenvalues nearest ``ref``: first (m, d) and second (m, d, d) derivatives."""
    d = p0.size
    E = np.eye(d) * h

    def lam(p):
        return _nearest(func(p), ref)

    l0 = lam(p0)
    first = np.empty((ref.size, d), dtype=complex)
    second = np.empty((ref.size, d, d), dtype=complex)
    for i in range(d):
        up, dn = lam(p0 + E[i]), lam(p0 - E[i])
        first[:, i] = (up - dn) / (2 * h)
        second[:, i, i] = (up - 2 * l0 + dn) / h**2
        for j in range(i):
            pp, pm = lam(p0 + E[i] + E[j]), lam(p0 + E[i] - E[j])
            mp, mm = lam(p0 - E[i] + E[j]), lam(p0 - E[i] - E[j])
            second[:, i, j] = second[:, j, i] = (pp - pm - mp + mm) / (4 * h * h)
    return first, second


# ----------------------------------------------------------------------------- random small models


@settings(max_examples=30, deadline=None)
@given(n=st.integers(2, 5), d=st.integers(1, 3), seed=st.integers(0, 2**32 - 1))
def test_second_order_derivatives_match_central_differences_on_random_models(n, d, seed):
    # A(p) = A0 + p_i A_i + p_i p_j A_ij / 2 for each of M, C, K: non-symmetric C and K, M s.p.d.;
    # reference: central differences of LAPACK's eigenvalues (geev), step 1e-3 (error ~1e-6)
    rng = np.random.default_rng(seed)
    B = rng.normal(size=(n, n))
    mats = np.stack([B @ B.T + n * np.eye(n), rng.normal(size=(n, n)), rng.normal(size=(n, n)) + 3 * n * np.eye(n)])
    first = 0.3 * rng.normal(size=(d, 3, n, n))
    first[:, 0] = 0.5 * (first[:, 0] + np.transpose(first[:, 0], (0, 2, 1)))  # M stays symmetric
    second = 0.3 * rng.normal(size=(d, d, 3, n, n))
    second = 0.5 * (second + np.transpose(second, (1, 0, 2, 3, 4)))
    second[:, :, 0] = 0.5 * (second[:, :, 0] + np.swapaxes(second[:, :, 0], -1, -2))

    def at(p):
        A = mats + np.einsum("i,ikab->kab", p, first) + 0.5 * np.einsum("i,j,ijkab->kab", p, p, second)
        return _state_eigvals(A[None], 1.0)[0]

    lam = at(np.zeros(d))
    gaps = np.abs(lam[:, None] - lam[None, :]) + np.diag(np.full(lam.size, np.inf))
    assume(gaps.min() > 0.05 * np.abs(lam).max())  # simple, well separated eigenvalues
    der = _second_order_derivatives(mats, first, second, eigenvalues=lam)
    np.testing.assert_allclose(der["eigenvalues"], lam, rtol=1e-10, atol=1e-10)
    fd1, fd2 = _fd(at, np.zeros(d), lam, 1e-3)
    scale1 = np.abs(fd1).max() + 1.0
    scale2 = np.abs(fd2).max() + 1.0
    np.testing.assert_allclose(der["first"], fd1, atol=1e-5 * scale1)
    np.testing.assert_allclose(der["second"], fd2, atol=1e-3 * scale2)


def test_small_model_sensitivity_matches_the_exact_first_order_sensitivity():
    # the existing closed-form first-order sensitivity (psi^H Q' phi / psi^H (2 lam M + C) phi)
    from squealkit.models import get_preset
    from squealkit.stability import eigenvalue_sensitivity

    model = get_preset("lv2013")  # the paper's pin-on-disc rig, damped: 3 modes
    ds = robust_margins(model, mu=0.3, scatter={"k3": 0.01, "kc": 0.05, "c1": 0.1}, damped=True,
                        method="perturbation")
    for name in ("k3", "kc", "c1"):
        ref = eigenvalue_sensitivity(model, 0.3, 0.0, name, damped=True)
        ref = ref.where(ref.frequency_hz > 0, drop=True)
        got = ds.growth_rate_sensitivity.sel(parameter=name).values
        order = np.argsort(ref.frequency_hz.values)
        np.testing.assert_allclose(ds.frequency_hz.values, ref.frequency_hz.values[order], rtol=1e-10)
        assert np.abs(got).max() > 0
        np.testing.assert_allclose(got, ref.dgrowth_rate_dp.values[order], rtol=1e-6)


def test_small_model_propensity_agrees_with_monte_carlo():
    # the paper's rig (Lv et al. 2013) just below its onset: the 2384 Hz mode grows in a share of samples
    from squealkit.models import get_preset

    ds = robust_margins(get_preset("lv2013"), mu=0.35, scatter={"kc": 0.1, "c1": 0.1, "c2": 0.1},
                        samples=2000, damped=True, seed=1)
    pert, mc = ds.sel(estimator="perturbation"), ds.sel(estimator="montecarlo")
    assert np.all(pert.perturbation_status.values == 0)
    assert 0.05 < pert.propensity.item() < 0.5
    assert mc.propensity_ci_lower.item() <= pert.propensity.item() <= mc.propensity_ci_upper.item()
    assert list(ds.parameter_unit.values) == ["N/m", "N s/m", "N s/m"]


# ----------------------------------------------------------------------------- closed form, 2 DOF


def _two_dof(c1: float = 2.0, c0: float = 1.9) -> FEModel:
    """Two uncoupled oscillators; D1 = diag(c1, c2) scattered, D4 = diag(-c0, 0) a negative damping.

    Mode 1: lambda = -(s c1 - c0)/2 +- i sqrt(k1 - (s c1 - c0)^2/4): its growth rate is LINEAR in the
    scale s of D1, so the second-order estimate is exact in mean and variance, and for a normal s
    the probability P(sigma > 0) = P(s < c0/c1) = Phi((c0/c1 - 1)/cov) exactly.
    """
    k1, k2 = (2 * math.pi * 100.0) ** 2, (2 * math.pi * 150.0) ** 2
    return FEModel.from_matrices(M=np.eye(2), K1=np.diag([k1, k2]), D1=np.diag([c1, 3.0]),
                                 D4=np.diag([-c0, 0.0]))


def test_the_result_saves_and_loads_back_unchanged(tmp_path):
    import xarray as xr

    ds = robust_margins(_two_dof(), rpm=0.0, scatter={"D1": 0.1}, samples=50)
    ds.to_netcdf(tmp_path / "margins.nc")
    xr.testing.assert_identical(xr.load_dataset(tmp_path / "margins.nc"), ds)
    empty = robust_margins(_two_dof(), rpm=0.0, scatter={"D1": 0.1}, samples=50, band=(1e3, 2e3))
    assert empty.sizes["mode"] == 0 and empty.propensity.values.tolist() == [0.0, 0.0]


def test_linear_growth_rate_gives_the_closed_form_statistics():
    cov, c1, c0 = 0.1, 2.0, 1.9
    ds = robust_margins(_two_dof(c1, c0), rpm=0.0, scatter={"D1": cov}, samples=4000, seed=3, confidence=0.999)
    assert ds.attrs["basis"] == "identity" and ds.attrs["trusted"] == 1
    mode = int(np.argmin(ds.frequency_hz.values))  # the 100 Hz oscillator
    mean, std = -(c1 - c0) / 2, c1 * cov / 2
    p = stats.norm.cdf((c0 / c1 - 1) / cov)
    # a growth rate within 1e-9 max|lambda| of zero is neutral (the stability maps' rule); |lambda|^2 = k
    # for M = 1, so P(sigma > 1e-9 sqrt(k2)) exactly
    p_tol = stats.norm.sf((1e-9 * 2 * math.pi * 150.0 - mean) / std)
    pert = ds.sel(estimator="perturbation")
    assert pert.growth_rate_mean.values[mode] == pytest.approx(mean, rel=1e-9)
    assert pert.growth_rate_std.values[mode] == pytest.approx(std, rel=1e-9)
    assert pert.probability_unstable.values[mode] == pytest.approx(p_tol, rel=1e-9)
    assert pert.propensity.item() == pytest.approx(p_tol, rel=1e-9)  # the other mode never grows
    assert p_tol == pytest.approx(p, rel=1e-4)
    assert pert.perturbation_status.values.tolist() == [0, 0]
    mc = ds.sel(estimator="montecarlo")
    assert mc.propensity_ci_lower.item() <= p <= mc.propensity_ci_upper.item()
    n = ds.attrs["samples"]
    assert abs(mc.growth_rate_mean.values[mode] - mean) < 4 * std / math.sqrt(n)
    assert mc.growth_rate_std.values[mode] == pytest.approx(std, rel=0.06)
    # a uniform scale of the same cov: mean and std as exact (the probability is then not normal)
    uni = robust_margins(_two_dof(c1, c0), rpm=0.0, scatter={"D1": {"dist": "uniform", "cov": cov}},
                         method="perturbation")
    assert uni.growth_rate_std.values[0, mode] == pytest.approx(std, rel=1e-9)


def test_same_result_in_batches_and_small_work_never_uses_the_cluster():
    model = _two_dof()
    whole = robust_margins(model, rpm=0.0, scatter={"D1": 0.1}, samples=300, seed=5, method="montecarlo")
    parts = robust_margins(model, rpm=0.0, scatter={"D1": 0.1}, samples=300, seed=5, method="montecarlo",
                           batch_size=64)
    np.testing.assert_array_equal(whole.max_growth_rate.values, parts.max_growth_rate.values)

    class NoCluster:
        def map(self, *args, **kwargs):
            raise AssertionError("a single batch was sent to the cluster")

    one = robust_margins(model, rpm=0.0, scatter={"D1": 0.1}, samples=300, seed=5, method="montecarlo",
                         client=NoCluster())
    np.testing.assert_array_equal(whole.max_growth_rate.values, one.max_growth_rate.values)


def test_dask_client_gives_the_same_numbers(monkeypatch):
    distributed = pytest.importorskip("distributed")
    import squealkit.design.montecarlo as montecarlo

    monkeypatch.setattr(montecarlo, "_CLUSTER_MIN_SECONDS", 0.0)  # send even this small work to the cluster
    model = _two_dof()
    kw = {"rpm": 0.0, "scatter": {"D1": 0.1}, "samples": 200, "seed": 7, "method": "montecarlo", "batch_size": 50}
    local = robust_margins(model, **kw)
    with distributed.Client(processes=False, n_workers=1, threads_per_worker=1, dashboard_address=None) as client:
        remote = robust_margins(model, client=client, **kw)
    np.testing.assert_array_equal(local.sampled_growth_rate.values, remote.sampled_growth_rate.values)
    assert local.propensity.item() == remote.propensity.item()


# ----------------------------------------------------------------------------- validity


def test_near_a_coalescence_the_estimate_says_indeterminate():
    # Hoffmann's undamped model just above its flutter onset (mu = 0.2165, Hoffmann et al. 2002):
    # the unstable pair is near its exceptional point, where eigenvalue derivatives blow up
    from squealkit.models import Hoffmann2002

    # Monte Carlo cannot tell the pair's two roots apart in the samples near the coalescence either (one
    # shape, near-equal eigenvalues): it says so for those samples, and its system propensity still answers
    with pytest.warns(PerturbationWarning, match="coalescence"), pytest.warns(UserWarning, match="ambiguous"):
        ds = robust_margins(Hoffmann2002(), mu=0.23, scatter={"k3": 0.05}, samples=200, damped=False)
    pert = ds.sel(estimator="perturbation")
    assert np.isnan(pert.propensity.item()) and np.all(pert.perturbation_status.values == 2)
    assert ds.sel(estimator="montecarlo").propensity.item() > 0.5  # Monte Carlo still answers
    assert 0 < ds.match_indeterminate.values.any(axis=1).mean() < 0.5


def test_a_close_stable_pair_is_bounded_stable_not_indeterminate():
    # two equal oscillators (100 Hz) split by a weak spring (1e-3 k) and damped by 100 N s/m; the
    # scattered damping diag(1, -1) couples their modes: beyond the expansion (coupling ratio 0.85),
    # but the pair cannot reach sigma = 0 (-50 1/s, shifts of a few 1/s), so it counts as stable
    k = (2 * math.pi * 100.0) ** 2
    model = FEModel.from_matrices(M=np.eye(2), K1=[[k, 1e-3 * k], [1e-3 * k, k]], D1=100.0 * np.eye(2),
                                  D4=np.diag([1.0, -1.0]))
    # (the two equal oscillators' shapes are mixed half and half in a few samples: Monte Carlo says so)
    with warnings.catch_warnings(), pytest.warns(UserWarning, match="ambiguous"):
        warnings.simplefilter("error", PerturbationWarning)
        ds = robust_margins(model, rpm=0.0, scatter={"D4": 0.3}, samples=200)
    assert np.all(ds.coupling_ratio.values > 0.5)
    assert ds.perturbation_status.values.tolist() == [1, 1]
    assert ds.propensity.values.tolist() == [0.0, 0.0]


def test_bad_inputs_are_named():
    from squealkit.models import Hoffmann2002

    model = _two_dof()
    with pytest.raises(InputError, match=r"Unknown scatter name 'K9'.*M, D1, D4, K1"):
        robust_margins(model, rpm=0.0, scatter={"K9": 0.1})
    with pytest.raises(InputError, match=r"cov=-0\.1 must be > 0"):
        robust_margins(model, rpm=0.0, scatter={"D1": -0.1})
    with pytest.raises(InputError, match="needs a disc speed: give rpm="):
        robust_margins(model, scatter={"D1": 0.1})
    with pytest.raises(InputError, match="method="):
        robust_margins(model, rpm=0.0, scatter={"D1": 0.1}, method="taylor")
    with pytest.raises(InputError, match="sampled scale factors are <= 0"):
        robust_margins(model, rpm=0.0, scatter={"D1": 0.6}, samples=500)
    with pytest.raises(InputError, match="no disc speed"):
        robust_margins(Hoffmann2002(), rpm=100.0, mu=0.1, scatter={"k3": 0.05}, damped=True)
    with pytest.raises(InputError, match="Unknown uncertain parameter 'KR'"):
        robust_margins(Hoffmann2002(), mu=0.1, scatter={"KR": 0.05}, damped=True)


# ----------------------------------------------------------------------------- the built-in FE brake


@pytest.fixture(scope="module")
def brake():
    pytest.importorskip("skfem")
    from squealkit.fe.demo import build_fe_demo
    from squealkit.solvers.reduction import as_fe_model

    model = as_fe_model(build_fe_demo(n_theta=16, n_r=2))
    unc = _uncertain({"KR": {"dist": "normal", "mean": 1.0, "std": 0.02},
                      "D1": {"dist": "normal", "mean": 1.0, "std": 0.2}})
    setup = _fe_setup(model, float(rpm_to_disc_speed(RPM)), MU, unc, BAND, "pod")
    return model, setup


def test_fe_derivatives_match_central_differences(brake):
    # reference: central differences (step 1e-3) of the reduced model's LAPACK eigenvalues, with the
    # mass scaled too (the pencil's B part) and KR, D1
    from threadpoolctl import threadpool_limits

    with threadpool_limits(1, user_api="blas"):  # small dense solves: threads on busy cores only wait
        _check_fe_derivatives(*brake)


def _check_fe_derivatives(model, setup):
    red = setup["reduced"]
    f = setup["factors"]
    r = red.n_reduced
    names = ("KR", "D1", "M")
    slot = {"M": 0, "D1": 1, "KR": 2}
    parts = np.zeros((3, 3, r, r))
    for i, name in enumerate(names):
        parts[i, slot[name]] = f[name] * red.mats[name]
    fixed = setup["payload"][0] + setup["payload"][1].sum(axis=0) - parts.sum(axis=0)

    def at(p):
        return _state_eigvals(_linear_matrices((fixed, parts), p[None]), 1.0)[0]

    p0 = np.ones(3)
    lam = at(p0)
    f_hz = lam.imag / (2 * math.pi)
    want = lam[(f_hz >= BAND[0]) & (f_hz <= BAND[1])]
    mats = _linear_matrices((fixed, parts), p0[None])[0]
    der = _second_order_derivatives(mats, parts, None, eigenvalues=want)
    assert want.size >= 2 and setup["reduced"].n_reduced < model.n_dof / 5
    fd1, fd2 = _fd(at, p0, der["eigenvalues"], 1e-3)
    for k in range(want.size):  # per mode: relative to that mode's largest derivative
        np.testing.assert_allclose(der["first"][k], fd1[k], rtol=0, atol=1e-5 * np.abs(fd1[k]).max())
        np.testing.assert_allclose(der["second"][k], fd2[k], rtol=0, atol=1e-3 * np.abs(fd2[k]).max())


@pytest.mark.slow
def test_fe_montecarlo_and_perturbation_agree_where_the_estimate_holds(brake):
    model, setup = brake
    V = setup["reduced"].V
    ds = robust_margins(model, rpm=RPM, mu=MU, band=BAND, scatter=SCATTER, samples=300, seed=11, basis=V,
                        confidence=0.99)
    assert ds.attrs["kind"] == "robust_margins" and ds.attrs["trusted"] == 1
    assert ds.attrs["max_residual"] <= ds.attrs["eta_max"] and ds.attrs["residual_checked"] > 1
    pert, mc = ds.sel(estimator="perturbation"), ds.sel(estimator="montecarlo")
    assert np.all(pert.perturbation_status.values == 0)
    p = pert.propensity.item()
    assert 0.1 < p < 0.9  # a real test: neither always nor never squealing
    assert mc.propensity_ci_lower.item() <= p <= mc.propensity_ci_upper.item()
    n = ds.attrs["samples"]
    # per mode: the means within 4 standard errors, the standard deviations within 15 %
    se = mc.growth_rate_std.values / math.sqrt(n)
    assert np.all(np.abs(mc.growth_rate_mean.values - pert.growth_rate_mean.values) < 4 * se)
    np.testing.assert_allclose(mc.growth_rate_std.values, pert.growth_rate_std.values, rtol=0.15)
    assert np.all(ds.cost_seconds.values > 0)
    assert pert.propensity_ci_lower.item() <= p <= pert.propensity_ci_upper.item()


def test_the_figure_draws_what_the_result_holds():
    pytest.importorskip("matplotlib")
    from squealkit.models import Hoffmann2002
    from squealkit.plotting.design_robust import robust_margins_plot

    ds = robust_margins(_two_dof(), rpm=0.0, scatter={"D1": 0.1}, samples=100)
    ax = robust_margins_plot(ds).axes[0]
    bars = [c for c in ax.containers if hasattr(c, "lines")]  # one errorbar per estimator
    assert len(bars) == 2
    np.testing.assert_allclose(bars[1].lines[0].get_ydata(), ds.growth_rate_mean.sel(estimator="perturbation"))
    with pytest.warns(PerturbationWarning), pytest.warns(UserWarning, match="ambiguous"):
        near = robust_margins(Hoffmann2002(), mu=0.23, scatter={"k3": 0.05}, samples=50, damped=False)
    labels = robust_margins_plot(near).axes[0].get_legend_handles_labels()[1]
    assert any("near a coalescence" in label for label in labels)
    assert any("match indeterminate" in label for label in labels)

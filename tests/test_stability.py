"""Stability engine against published numbers, closed forms and LAPACK."""

import math

import numpy as np
import pytest
import xarray as xr

from squealkit import InputError
from squealkit.io import load_dataset, save_dataset
from squealkit.models import Hoffmann2002, MatrixModel, get_preset
from squealkit.stability import (
    critical_friction,
    critical_friction_curve,
    critical_friction_sensitivity,
    eigenvalue_sensitivity,
    eigenvalues,
    runout_tolerance,
    stability_map,
    stability_summary,
)


def lapack_eigvals(model, mu, t, damped):
    """Reference: numpy.linalg.eigvals of the 2n x 2n state matrix."""
    M = model.mass_matrix()
    C = model.damping_matrix() if damped else np.zeros_like(M)
    K = model.stiffness_matrix(mu, t)
    n = M.shape[0]
    A = np.zeros((*K.shape[:-2], 2 * n, 2 * n))
    A[..., :n, n:] = np.eye(n)
    A[..., n:, :n] = -np.linalg.solve(M, K)
    A[..., n:, n:] = -np.linalg.solve(M, C)
    return np.linalg.eigvals(A)


def max_rel_mismatch(ours, ref):
    """Largest distance from each reference eigenvalue (with Im >= 0) to ours, over max |lambda|."""
    worst = 0.0
    for a, r in zip(ours.reshape(-1, ours.shape[-1]), ref.reshape(-1, ref.shape[-1]), strict=True):
        r = r[r.imag >= -1e-9 * np.abs(r).max()]
        d = np.abs(r[:, None] - a[None, :]).min(axis=1).max() / np.abs(r).max()
        worst = max(worst, d)
    return worst


@pytest.fixture(scope="module")
def fig2():
    # The paper's Fig. 2 grid: mu 0..0.8, theta -8..8 deg, undamped (eq. 7).
    return stability_map(get_preset("lv2013"), np.linspace(0, 0.8, 81), np.radians(np.linspace(-8, 8, 81)))


def test_fig2_lock_in_band_matches_paper(fig2):
    # Paper §3: "The coupled frequency is about 14997-15317 rad/sec (2387-2438 Hz)".
    s = stability_summary(fig2)
    lo, hi = s["unstable_omega_rad_s"]
    assert lo == pytest.approx(14997.0, abs=1.0)
    assert hi == pytest.approx(15317.0, rel=5e-4)
    assert 0.3 < s["unstable_fraction"] < 0.6
    assert s["lock_in_fraction"] == s["unstable_fraction"]  # undamped: every instability is a lock-in


def test_fig2_real_parts_split_into_two_branches(fig2):
    # Paper §3: one branch goes positive, the other negative, as mu and theta grow.
    g = fig2.growth_rate.values
    assert g[..., 0].max() > 400 and g[..., 0].min() > -1e-6
    assert g[..., 1].min() < -400 and g[..., 1].max() < 1e-6
    locked = fig2.lock_in.values
    np.testing.assert_allclose(g[..., 0][locked], -g[..., 1][locked], rtol=1e-6)
    np.testing.assert_allclose(fig2.omega.values[..., 0][locked], fig2.omega.values[..., 1][locked], rtol=1e-6)


def test_undamped_without_friction_is_purely_imaginary():
    for model in (get_preset("lv2013"), Hoffmann2002()):
        lam = eigenvalues(model, 0.0, tan_theta=0.0)
        assert np.all(np.abs(lam.real) < 1e-12 * np.abs(lam))
        # and equals sqrt of the symmetric generalised eigenproblem K x = w^2 M x
        K = model.stiffness_matrix(0.0, 0.0)
        w2 = np.linalg.eigvals(np.linalg.solve(model.mass_matrix(), K)).real
        np.testing.assert_allclose(np.sort(lam.imag), np.sort(np.sqrt(w2)), rtol=1e-12)


@pytest.mark.parametrize("damped", [False, True])
def test_kernel_agrees_with_lapack_on_grid(damped):
    # Issue 2: eigenvalues agree with LAPACK to 1e-7 relative.
    model = get_preset("lv2013")
    mu = np.linspace(0, 0.8, 61)[:, None]
    t = np.tan(np.radians(np.linspace(-8, 8, 41)))[None, :]
    ours = eigenvalues(model, mu, tan_theta=t, damped=damped)
    ref = lapack_eigvals(model, *np.broadcast_arrays(mu, t), damped)
    assert max_rel_mismatch(ours, ref) < 1e-7


def test_kernel_agrees_with_lapack_for_other_sizes():
    rng = np.random.default_rng(7)
    for n in (1, 2, 4, 5):  # 5 DOF goes through the LAPACK path
        A = rng.normal(size=(n, n))
        K0 = A @ A.T * 1e6 + n * 1e6 * np.eye(n)
        Kf = rng.normal(size=(n, n)) * 2e5
        C = np.diag(rng.uniform(1, 50, n))
        m = MatrixModel(M=np.diag(rng.uniform(0.5, 2, n)), K0=K0, Kf=Kf, C=C)
        mu = np.linspace(0, 1, 50)
        for damped in (False, True):
            ref = lapack_eigvals(m, mu, np.zeros_like(mu), damped)
            assert max_rel_mismatch(eigenvalues(m, mu, damped=damped), ref) < 1e-7


@pytest.mark.parametrize(
    "params",
    [{}, {"k1": 2e6, "k2": 0.5e6, "alpha1": math.radians(40)}, {"m": 0.2, "k3": 3e6}, {"sliding": -1,
     "alpha1": math.radians(150), "alpha2": math.radians(30)}],
)
def test_hoffmann_closed_form_threshold(params):
    # Hoffmann et al. (2002): flutter where (a - d)^2 + 4 b (b - mu k3) turns negative.
    m = Hoffmann2002(**params)
    closed = m.mu_critical_closed_form()
    assert critical_friction(m, mu_max=5.0).mu_critical == pytest.approx(closed, abs=1e-6)


def test_mu_e_critical_nearly_constant_over_theta():
    # Paper eqs. 5-6: the SRO incline acts like friction, mu_e = mu + tan(theta).
    ds = critical_friction_curve(get_preset("lv2013"), np.radians(np.linspace(-8, 8, 17)))
    mu_e = ds.mu_e_critical.values
    assert np.all(ds.status.values == 0)
    assert np.ptp(mu_e) / mu_e.mean() < 5e-3
    assert np.all(np.diff(ds.mu_critical.values) < 0)  # a rising slope needs less friction
    # onset at the coupled frequency of Fig. 2
    assert np.all((ds.omega_rad_s.values > 14990) & (ds.omega_rad_s.values < 15330))


def test_critical_friction_is_on_the_boundary():
    m = get_preset("lv2013")
    c = critical_friction(m, math.radians(3.0))
    lam_below = eigenvalues(m, c.mu_critical - 1e-6, tan_theta=math.tan(math.radians(3.0)))
    lam_above = eigenvalues(m, c.mu_critical + 1e-6, tan_theta=math.tan(math.radians(3.0)))
    assert lam_below.real.max() < 1e-9 * np.abs(lam_below).max()
    assert lam_above.real.max() > 1e-9 * np.abs(lam_above).max()


def test_unstable_without_friction_gives_negative_mu_crit():
    c = critical_friction(get_preset("lv2013"), math.atan(0.6))
    assert c.status == "unstable_at_start"  # one vocabulary (ONSET_STATUS): unstable at mu = 0
    assert c.mu_critical < 0 and c.mu_e_critical == pytest.approx(0.445, abs=0.01)


def test_runout_tolerance_closes_the_loop():
    m = get_preset("lv2013")
    mu, lam = 0.3, 1e-3
    tol = runout_tolerance(m, mu, wavelength=lam)
    assert tol.limiting_side == "rising"
    # stable just below the slope limit, unstable just above (root-finding to 1e-6)
    assert eigenvalues(m, mu, tan_theta=tol.tan_theta_max * (1 - 1e-6)).real.max() < 1e-3
    assert eigenvalues(m, mu, tan_theta=tol.tan_theta_max * (1 + 1e-6)).real.max() > 1e-3
    # eq. 11: tan(theta) = 2 pi q0 / lambda
    assert tol.q0_max == pytest.approx(tol.tan_theta_max * lam / (2 * math.pi))
    assert mu + tol.tan_theta_max == pytest.approx(critical_friction(m).mu_e_critical, abs=2e-3)
    flat = runout_tolerance(m, 0.5)
    assert not flat.stable_on_flat_disc and flat.tan_theta_max == 0.0


def test_sensitivity_predicts_a_finite_change():
    m = get_preset("lv2013")
    rows = {r["parameter"]: r for r in critical_friction_sensitivity(m)}
    base = critical_friction(m).mu_critical
    changed = critical_friction(m.replace(k1=m.k1 * 1.01)).mu_critical
    predicted = base * (1 + 0.01 * rows["k1"]["elasticity"])
    assert changed == pytest.approx(predicted, rel=2e-3)
    assert rows["P"]["dmu_dp"] == 0.0  # the static load does not enter K


def elasticities(rows):
    return {r["parameter"]: r["elasticity"] for r in rows}


@pytest.mark.parametrize("damped", [False, True])
def test_exact_sensitivity_agrees_with_finite_differences(damped):
    # The exact derivatives (one onset search; coalescence formula undamped, Hopf damped)
    # against central differences of two more onset searches per parameter (rel. step 1e-4).
    # FD differentiates the search's boundary sigma = 1e-9 |lambda|, the exact method sigma = 0:
    # they differ by ~1e-6 of mu_crit, hence the absolute floor on small elasticities.
    # (A subset of the parameters keeps the FD side to ten onset searches; all of them agree.)
    m = get_preset("lv2013")
    names = ["k1", "k3", "kc", "alpha", "c1" if damped else "m2"]
    exact = critical_friction_sensitivity(m, damped=damped, parameters=names)
    fd = elasticities(critical_friction_sensitivity(m, damped=damped, parameters=names, method="fd"))
    assert [r["parameter"] for r in exact] == sorted(fd, key=lambda k: -abs(fd[k]))
    for r in exact:
        assert r["elasticity"] == pytest.approx(fd[r["parameter"]], rel=1e-4, abs=1e-5), r


def hoffmann_closed_form_gradient(h):
    """d mu_crit / d p of Hoffmann's threshold s ((a - d)^2 + 4 b^2) / (4 b k3) (Hoffmann et al.
    2002), differentiated by hand: a = sum k_i cos^2, b = sum k_i cos sin, d = sum k_i sin^2 + k3."""
    s1, c1, s2, c2 = math.sin(h.alpha1), math.cos(h.alpha1), math.sin(h.alpha2), math.cos(h.alpha2)
    a = h.k1 * c1**2 + h.k2 * c2**2
    b = h.k1 * c1 * s1 + h.k2 * c2 * s2
    d = h.k1 * s1**2 + h.k2 * s2**2 + h.k3
    g = (a - d) ** 2 + 4 * b * b
    partials = {  # (da, db, dd, dk3) per parameter
        "k1": (c1**2, c1 * s1, s1**2, 0.0),
        "k2": (c2**2, c2 * s2, s2**2, 0.0),
        "k3": (0.0, 0.0, 1.0, 1.0),
        "alpha1": (-2 * h.k1 * c1 * s1, h.k1 * (c1**2 - s1**2), 2 * h.k1 * c1 * s1, 0.0),
        "alpha2": (-2 * h.k2 * c2 * s2, h.k2 * (c2**2 - s2**2), 2 * h.k2 * c2 * s2, 0.0),
        "m": (0.0, 0.0, 0.0, 0.0),
    }
    out = {}
    for name, (da, db, dd, dk3) in partials.items():
        dg = 2 * (a - d) * (da - dd) + 8 * b * db
        out[name] = h.sliding * (dg / (4 * b * h.k3) - g * (db * h.k3 + b * dk3) / (4 * b * b * h.k3**2))
    return out


@pytest.mark.parametrize(
    "params",
    [{}, {"k1": 2e6, "k2": 0.5e6, "alpha1": math.radians(40)},
     {"sliding": -1, "alpha1": math.radians(150), "alpha2": math.radians(30)}],
)
def test_sensitivity_matches_hoffmanns_closed_form(params):
    h = Hoffmann2002(**params)
    ref = hoffmann_closed_form_gradient(h)
    scale = max(abs(v) * abs(getattr(h, k)) for k, v in ref.items())
    # FD (two onset searches per parameter, slow) on the default supports only
    for method, rtol in (("exact", 1e-8), ("fd", 1e-5))[:1 if params else 2]:
        rows = {r["parameter"]: r["dmu_dp"] for r in critical_friction_sensitivity(h, method=method)}
        assert set(rows) == set(ref)
        for name, d in rows.items():  # per unit of p, compared at the scale of the largest p dmu/dp
            assert abs(d - ref[name]) * abs(getattr(h, name)) < rtol * scale, (method, name, d, ref[name])


def test_coalescence_formula_is_the_limit_of_the_smooth_discriminant():
    # Undamped onset is a double root; F = (lambda_1 - lambda_2)^2 is smooth through it, so
    # -F_p / F_mu on the stable side, F_p = 2 (l1 - l2)(dl1/dp - dl2/dp) from the public
    # eigenvalue derivatives, tends to d mu_crit / d p at O(delta): Richardson over delta.
    m = get_preset("lv2013")
    crit = critical_friction(m)
    exact = {r["parameter"]: r["dmu_dp"] for r in critical_friction_sensitivity(m, parameters=["k1", "alpha"])}

    def ratio(p, delta):
        sp = eigenvalue_sensitivity(m, crit.mu_critical - delta, 0.0, p)
        smu = eigenvalue_sensitivity(m, crit.mu_critical - delta, 0.0, "mu")
        lam = sp.growth_rate.values + 1j * sp.omega.values
        i, j = np.argsort(np.abs(lam - 1j * crit.omega_rad_s))[:2]
        dp = sp.dgrowth_rate_dp.values + 1j * sp.domega_dp.values
        dm = smu.dgrowth_rate_dp.values + 1j * smu.domega_dp.values
        return -((lam[i] - lam[j]) * (dp[i] - dp[j]) / ((lam[i] - lam[j]) * (dm[i] - dm[j]))).real

    for p in ("k1", "alpha"):
        coarse, fine = ratio(p, 2.5e-3), ratio(p, 1.25e-3)
        assert abs(coarse / exact[p] - 1) > 1e-3  # the plain quotient is still off ...
        assert 2 * fine - coarse == pytest.approx(exact[p], rel=5e-6)  # ... its extrapolation is not


def test_sensitivity_method_is_checked():
    with pytest.raises(InputError, match="method='newton'"):
        critical_friction_sensitivity(Hoffmann2002(), method="newton")


@pytest.mark.parametrize("suffix", [".nc", ".zarr"])
def test_dataset_round_trip(tmp_path, fig2, suffix):
    path = save_dataset(fig2, tmp_path / f"map{suffix}")
    back = load_dataset(path)
    xr.testing.assert_identical(back, fig2)


def test_dataset_labels_and_units(fig2):
    assert fig2.growth_rate.attrs["units"] == "1/s"
    assert fig2.omega.attrs["units"] == "rad/s"
    assert fig2.frequency_hz.attrs["units"] == "Hz"
    assert fig2.theta.attrs["units"] == "rad"
    np.testing.assert_allclose(fig2.mu_e.values, fig2.mu.values[:, None] + fig2.tan_theta.values[None, :])


def test_tracking_follows_crossing_modes():
    # Two uncoupled DOFs whose frequencies cross as mu grows: tracking keeps each branch.
    m = MatrixModel(M=np.eye(2), K0=np.diag([1.0e6, 0.5e6]), Kf=np.diag([0.0, 1.0e6]))
    mu = np.linspace(0, 1, 101)
    ds = stability_map(m, mu, 0.0)
    w = ds.omega.isel(theta=0).values
    # at the exact crossing (mu = 0.5, a double root) accuracy is sqrt(eps)-level, as for LAPACK
    np.testing.assert_allclose(w[:, 0], np.sqrt(0.5e6 + 1e6 * mu), rtol=1e-7)
    np.testing.assert_allclose(w[:, 1], np.full_like(mu, 1e3), rtol=1e-7)
    untracked = stability_map(m, mu, 0.0, track=False).omega.isel(theta=0).values
    assert np.all(np.diff(untracked, axis=1) >= 0)  # frequency order swaps at the crossing


def test_warm_start_through_a_double_root_finds_every_root():
    # Two uncoupled DOFs crossing at mu = 0.5 (omega = 1000 rad/s twice). Warm-started from
    # the double root, two approximations once converged onto 1000 and missed the other root
    # (1% frequency error, a false instability); the Vieta check now sends such points to a
    # cold start. Reference: the closed-form frequencies sqrt(k/m) of the two DOFs.
    m = MatrixModel(M=np.eye(2), K0=np.diag([1.0e6, 0.5e6]), Kf=np.diag([0.0, 1.0e6]))
    for n in (101, 1001, 10007):
        mu = np.linspace(0, 1, n)
        lam = eigenvalues(m, mu[None, :], tan_theta=0.0)[0]  # one row: each point warm-started from the last
        ref = np.sort(np.stack([np.sqrt(0.5e6 + 1e6 * mu), np.full_like(mu, 1e3)], axis=1), axis=1)
        # sqrt(eps)-level at the exact double root, as for any polynomial root finder
        np.testing.assert_allclose(np.sort(lam.imag, axis=1), ref, rtol=1e-8)
        off = mu != 0.5
        assert np.all(np.abs(lam.real[off]) <= 1e-9 * np.abs(lam[off]))  # no false instability


def test_stability_inputs_rejected():
    m = get_preset("lv2013")
    with pytest.raises(InputError, match="theta"):
        stability_map(m, [0.1], [math.pi / 2])
    with pytest.raises(InputError, match="non-finite"):
        eigenvalues(m, [0.1, np.nan])

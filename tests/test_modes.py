"""Mode shapes, friction work and eigenvalue derivatives (issue #10), against their definitions.

References: the quadratic eigenproblem itself (residuals of right and left eigenvectors),
the energy balance sigma = (W_f - W_d) / (2 pi omega phi^H M phi) that follows from the
imaginary part of phi^H (lambda^2 M + lambda C + K) phi = 0, and finite differences of
eigenvalues computed independently by numpy.linalg.eigvals.
"""

import json
import math

import numpy as np
import pytest
import xarray as xr
from hypothesis import given, settings
from hypothesis import strategies as st

from squealkit import InputError
from squealkit.io import load_dataset
from squealkit.models import Hoffmann2002, MatrixModel, get_preset
from squealkit.stability import (
    UNSTABLE_RTOL,
    critical_friction,
    eigenvalue_sensitivity,
    eigenvalues,
    mode_shapes,
    modes,
    modes_summary,
    onset_modes,
)

LV = get_preset("lv2013")


def random_model(rng: np.random.Generator, n: int, *, damped: bool) -> MatrixModel:
    """A random n-DOF friction model: SPD mass and structural stiffness, symmetric contact
    part, a friction part without symmetry, a symmetric positive semi-definite damping."""
    A = rng.normal(size=(n, n))
    M = A @ A.T / n + np.diag(rng.uniform(0.2, 2.0, n))
    B = rng.normal(size=(n, n))
    K0 = (B @ B.T / n + np.eye(n)) * 10 ** rng.uniform(4, 7)
    Kn = np.diag(rng.uniform(0, 1, n)) * K0[0, 0] * 0.3
    Kf = rng.normal(size=(n, n)) * K0[0, 0] * 0.3
    D = rng.normal(size=(n, n))
    C = (D @ D.T / n) * math.sqrt(K0[0, 0]) * 0.05 if damped else None
    return MatrixModel(M=M, K0=K0, Kn=Kn, Kf=Kf, C=C, sliding=int(rng.choice([-1, 1])))


def qep_parts(model, mu, theta, damped):
    M = model.mass_matrix()
    C = model.damping_matrix() if damped else np.zeros_like(M)
    return M, C, model.stiffness_matrix(mu, math.tan(theta))


def relative_residuals(ds, model, damped):
    """||Q(lambda) phi|| / ((||M|| |lambda|^2 + ||C|| |lambda| + ||K||) ||phi||), and for psi^H Q."""
    M, C, K = qep_parts(model, ds.attrs["mu"], ds.attrs["theta"], damped)
    lam = ds.growth_rate.values + 1j * ds.omega.values
    phi, psi = mode_shapes(ds), mode_shapes(ds, left=True)
    right, left = [], []
    for k, lk in enumerate(lam):
        Q = lk * lk * M + lk * C + K
        scale = np.linalg.norm(M, 2) * abs(lk) ** 2 + np.linalg.norm(C, 2) * abs(lk) + np.linalg.norm(K, 2)
        right.append(np.linalg.norm(Q @ phi[k]) / (scale * np.linalg.norm(phi[k])))
        left.append(np.linalg.norm(psi[k].conj() @ Q) / (scale * np.linalg.norm(psi[k])))
    return np.array(right), np.array(left)


def check_energy_balance(ds):
    """Sign of the net work per cycle == sign of the growth rate, via the exact balance."""
    osc = ~ds.real_root.values
    sigma = ds.growth_rate.values[osc]
    omega = ds.omega.values[osc]
    net = ds.net_work.values[osc]
    # sigma = (W_f - W_d) / (2 pi omega m): the imaginary part of phi^H Q(lambda) phi = 0
    predicted = net / (2 * np.pi * omega * ds.modal_mass.values[osc])
    lam_max = np.abs(ds.growth_rate.values + 1j * ds.omega.values).max()
    np.testing.assert_allclose(predicted, sigma, rtol=0, atol=1e-12 * lam_max)
    # hence the signs agree wherever sigma is above rounding (the engine's own threshold)
    clear = np.abs(sigma) > UNSTABLE_RTOL * lam_max
    np.testing.assert_array_equal(np.sign(net[clear]), np.sign(sigma[clear]))
    np.testing.assert_allclose(ds.net_work.values[osc], (ds.friction_work - ds.damping_work).values[osc])
    assert np.all(ds.damping_work.values[osc] >= -1e-12 * np.abs(ds.friction_work.values[osc]).max(initial=1.0))
    assert np.all(np.isnan(ds.friction_work.values[~osc]))  # a real root has no cycle


# -- eigenvectors -----------------------------------------------------------------------------


@pytest.mark.parametrize("damped", [False, True])
@pytest.mark.parametrize("mu", [0.0, 0.1, 0.6])
def test_preset_eigenvectors_solve_the_quadratic_problem(mu, damped):
    ds = modes(LV, mu, math.radians(2.0), damped=damped)
    right, left = relative_residuals(ds, LV, damped)
    assert right.max() < 1e-10 and left.max() < 1e-10
    # one mode per pair: the same eigenvalues as the stability engine (LAPACK-level agreement)
    ref = eigenvalues(LV, mu, tan_theta=math.tan(math.radians(2.0)), damped=damped)
    lam = ds.growth_rate.values + 1j * ds.omega.values
    np.testing.assert_allclose(np.sort(lam.imag), np.sort(ref.imag), rtol=1e-10)
    assert np.abs(lam[:, None] - ref[None, :]).min(axis=1).max() < 1e-9 * np.abs(ref).max()


def test_shape_normalisation_and_participation():
    ds = modes(LV, 0.6, damped=True)
    phi = mode_shapes(ds)
    amp = np.abs(phi)
    k = amp.argmax(axis=1)
    np.testing.assert_array_equal(phi[np.arange(phi.shape[0]), k], 1.0 + 0.0j)  # largest entry exactly 1
    assert np.all(amp <= 1.0)
    np.testing.assert_allclose(ds.participation.sum("dof"), 1.0, rtol=1e-12)
    # diagonal M: |phi_i|^2 m_ii / sum_j |phi_j|^2 m_jj
    m = np.diag(LV.mass_matrix())
    e = amp**2 * m
    np.testing.assert_allclose(ds.participation.values, e / e.sum(axis=1, keepdims=True), rtol=1e-12)
    assert list(ds.dof.values) == ["x1", "y1", "y2"]
    assert ds.growth_rate.attrs["units"] == "1/s" and ds.friction_work.attrs["units"] == "J"


@settings(max_examples=30, deadline=None)
@given(n=st.integers(2, 6), seed=st.integers(0, 2**32 - 1), damped=st.booleans(),
       mu=st.floats(0.0, 1.5), theta_deg=st.floats(-10.0, 10.0))
def test_random_models_residuals_and_energy_balance(n, seed, damped, mu, theta_deg):
    rng = np.random.default_rng(seed)
    model = random_model(rng, n, damped=damped)
    ds = modes(model, mu, math.radians(theta_deg), damped=damped)
    right, left = relative_residuals(ds, model, damped)
    assert right.max() < 1e-10 and left.max() < 1e-10
    # every root is accounted for: pairs count once, real roots each (2n roots in all)
    n_real = int(ds.real_root.sum())
    assert 2 * (ds.sizes["mode"] - n_real) + n_real == 2 * n
    check_energy_balance(ds)


def test_real_roots_are_all_kept():
    # One DOF, overdamped (c^2 > 4 m k): two real roots -c/2m +- sqrt(c^2/4m^2 - k/m); with
    # a negative net stiffness (friction) one of them is positive: divergence. Both are modes.
    m = MatrixModel(M=[[1.0]], K0=[[100.0]], Kf=[[-400.0]], C=[[50.0]])
    ds = modes(m, 0.5, damped=True)  # k = 100 - 200 = -100
    roots = np.sort(np.roots([1.0, 50.0, -100.0]))
    np.testing.assert_allclose(np.sort(ds.growth_rate.values), roots, rtol=1e-12)
    assert ds.real_root.all() and ds.attrs["verdict"] == "divergence"
    assert ds.unstable.values.tolist() == (ds.growth_rate.values > 0).tolist() == [True, False]
    # no cycle, no work per cycle: NaN in the dataset, null in JSON
    assert [m["friction_work"] for m in modes_summary(ds)["modes"]] == [None, None]


# -- friction work --------------------------------------------------------------------------


@pytest.mark.parametrize("damped", [False, True])
def test_friction_work_sign_on_the_paper_preset(damped):
    # Paper §3: undamped, the flat-disc model is unstable at mu = 0.6 (above mu_crit = 0.4448)
    # and stable at mu = 0.1; damped, the onset is lower (0.3977), so the same holds.
    unstable = modes(LV, 0.6, damped=damped)
    stable = modes(LV, 0.1, damped=damped)
    check_energy_balance(unstable)
    check_energy_balance(stable)
    k = int(unstable.growth_rate.argmax("mode"))
    assert unstable.unstable[k] and unstable.net_work[k] > 0 and unstable.friction_work[k] > 0
    assert int(unstable.unstable.sum()) == 1
    assert not stable.unstable.any()
    assert np.all(stable.net_work.values <= 1e-9 * np.abs(stable.friction_work.values).max(initial=1.0))
    if not damped:
        # undamped: the energy balance is friction work alone; a stable undamped mode takes none
        np.testing.assert_array_equal(unstable.damping_work.values, 0.0)
        lam_max = float(np.abs(stable.omega).max())
        assert np.all(np.abs(stable.growth_rate.values) < 1e-12 * lam_max)


# -- eigenvalue derivatives -------------------------------------------------------------------


def fd_eigenvalues(model, mu, theta, parameter, damped, h):
    """Fourth-order central difference of the eigenvalues (numpy.linalg.eigvals on the state
    matrix) with respect to ``parameter``, each root matched to the nearest at the base point."""
    def lam_at(**change):
        p = dict(mu=mu, theta=theta)
        m = model
        if parameter in ("mu", "theta"):
            p[parameter] += change["d"]
        elif parameter == "tan_theta":
            p["theta"] = math.atan(math.tan(theta) + change["d"])
        else:
            m = model.replace(**{parameter: float(getattr(model, parameter)) + change["d"]})
        M, C, K = qep_parts(m, p["mu"], p["theta"], damped)
        n = M.shape[0]
        A = np.block([[np.zeros((n, n)), np.eye(n)], [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
        return np.linalg.eigvals(A)

    base = lam_at(d=0.0)

    def matched(d):
        lam = lam_at(d=d)
        return lam[np.abs(lam[None, :] - base[:, None]).argmin(axis=1)]

    d = (-matched(2 * h) + 8 * matched(h) - 8 * matched(-h) + matched(-2 * h)) / (12 * h)
    return base, d


@pytest.mark.parametrize(
    "model, mu, theta_deg, damped, parameter, h",
    [
        (LV, 0.2, 1.0, False, "mu", 1e-3),
        (LV, 0.2, 1.0, True, "mu", 1e-3),
        (LV, 0.6, -2.0, True, "tan_theta", 1e-3),
        (LV, 0.3, 3.0, False, "theta", 1e-3),
        (LV, 0.3, 0.0, True, "k1", 8.545e6 * 1e-3),
        (LV, 0.6, 0.0, False, "alpha", 1e-4),
        (LV, 0.3, 0.0, True, "c3", 0.5),
        (LV, 0.3, 0.0, True, "m1", 0.033 * 1e-3),
        (Hoffmann2002(c=3.0), 0.1, 0.0, True, "alpha1", 1e-4),
    ],
)
def test_eigenvalue_derivatives_match_finite_differences(model, mu, theta_deg, damped, parameter, h):
    # simple roots only (away from the lock-in): derivatives exist and FD converge at O(h^4)
    theta = math.radians(theta_deg)
    s = eigenvalue_sensitivity(model, mu, theta, parameter, damped=damped)
    base, d_fd = fd_eigenvalues(model, mu, theta, parameter, damped, h)
    lam = s.growth_rate.values + 1j * s.omega.values
    d = s.dgrowth_rate_dp.values + 1j * s.domega_dp.values
    idx = np.abs(base[None, :] - lam[:, None]).argmin(axis=1)
    np.testing.assert_allclose(base[idx], lam, rtol=1e-10)
    err = np.abs(d - d_fd[idx]) / np.abs(d)
    assert err.max() < 1e-6, (err, d)
    assert s.attrs["parameter"] == parameter


@settings(max_examples=30, deadline=None)
@given(n=st.integers(2, 6), seed=st.integers(0, 2**32 - 1), damped=st.booleans())
def test_eigenvalue_derivatives_random_models(n, seed, damped):
    rng = np.random.default_rng(seed)
    model = random_model(rng, n, damped=damped)
    mu = float(rng.uniform(0.0, 1.0))
    s = eigenvalue_sensitivity(model, mu, 0.0, "mu", damped=damped)
    lam = s.growth_rate.values + 1j * s.omega.values
    gaps = np.abs(lam[:, None] - lam[None, :])
    np.fill_diagonal(gaps, np.inf)
    gaps = np.minimum(gaps.min(axis=1), 2 * np.abs(lam.imag) + np.where(lam.imag == 0, np.inf, 0))
    if gaps.min() < 1e-2 * np.abs(lam).max():
        return  # near a double root the derivative is ill-conditioned and FD is not a reference
    base, d_fd = fd_eigenvalues(model, mu, 0.0, "mu", damped, 1e-4)
    d = s.dgrowth_rate_dp.values + 1j * s.domega_dp.values
    idx = np.abs(base[None, :] - lam[:, None]).argmin(axis=1)
    assert (np.abs(d - d_fd[idx]) / np.abs(d)).max() < 1e-6


def test_sensitivity_rejects_bad_parameters():
    with pytest.raises(InputError, match="Unknown parameter 'q'"):
        eigenvalue_sensitivity(LV, 0.3, 0.0, "q")
    with pytest.raises(InputError, match="no derivative"):
        eigenvalue_sensitivity(LV, 0.3, 0.0, "sliding")
    with pytest.raises(InputError, match="theta"):
        modes(LV, 0.3, math.pi / 2)
    with pytest.raises(InputError, match="finite"):
        modes(LV, math.nan)


# -- onset ------------------------------------------------------------------------------------


@pytest.mark.parametrize("damped", [False, True])
def test_onset_mode_is_the_one_that_grows_above_mu_crit(damped):
    crit = critical_friction(LV, damped=damped)
    ds = onset_modes(LV, damped=damped)
    # damped: one root crosses; undamped: both roots of the merging pair are marked (issue 27: the round-off
    # sign of their sigma, +-2.7e-9, decided which one the figure called "stable")
    assert ds.attrs["mu"] == crit.mu_critical and int(ds.loses_stability.sum()) == (1 if damped else 2)
    assert ds.attrs["onset_kind"] == ("crossing" if damped else "coalescence")
    k = int(ds.loses_stability.argmax("mode"))
    # at onset its frequency is critical_friction's onset frequency (paper §3: ~2436 Hz undamped),
    # which is taken just above mu_crit; at a coalescence the frequency moves as sqrt(mu - mu_crit)
    assert float(ds.frequency_hz[k]) == pytest.approx(crit.frequency_hz, rel=1e-5)
    assert not ds.unstable.any()  # mu_crit is the stable end of the bracket
    above = modes(LV, crit.mu_critical + 1e-3, damped=damped)
    j = int(above.growth_rate.argmax("mode"))
    # the growing mode above onset continues the marked shape (|cosine| ~ 1)
    a, b = mode_shapes(ds)[k], mode_shapes(above)[j]
    assert abs(np.vdot(a, b)) / (np.linalg.norm(a) * np.linalg.norm(b)) > 0.99


def test_onset_without_onset_is_an_input_error():
    with pytest.raises(InputError, match="No friction onset"):
        onset_modes(LV, math.atan(0.6))  # unstable without friction (test_stability)


# -- results as values ------------------------------------------------------------------------


def test_dataset_round_trip_and_summary(tmp_path):
    from squealkit.io import save_dataset

    ds = onset_modes(LV)
    back = load_dataset(save_dataset(ds, tmp_path / "modes.nc"))
    xr.testing.assert_identical(back, ds)
    out = modes_summary(ds)
    json.dumps(out, allow_nan=False)  # plain JSON
    assert out["mu_critical"] == out["mu"] and out["dof_names"] == ["x1", "y1", "y2"]
    row = out["modes"][0]
    assert {"eigenvalue", "frequency_hz", "growth_rate", "damping_ratio", "shape", "dof_names",
            "friction_work", "loses_stability"} <= set(row)
    assert len(row["shape"]) == 3 and all(len(z) == 2 for z in row["shape"])


# -- CLI --------------------------------------------------------------------------------------


def test_cli_modes_json(run):
    r = run("modes", "--mu", "0.6", "--theta", "0", "--undamped", "--json")  # the paper's §3 sweep
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout)
    assert {"mu", "theta_deg", "damped", "model", "modes"} <= set(out)
    assert out["mu"] == 0.6 and out["theta_deg"] == 0.0 and out["damped"] is False
    assert out["model"]["kind"] == "pin_on_disc"
    for m in out["modes"]:
        assert {"eigenvalue", "frequency_hz", "growth_rate", "damping_ratio", "shape", "dof_names",
                "friction_work"} <= set(m)
        amp = np.hypot(*np.array(m["shape"]).T)
        assert amp.max() == 1.0 and m["dof_names"] == ["x1", "y1", "y2"]
        assert m["frequency_hz"] == pytest.approx(m["eigenvalue"][1] / (2 * np.pi))
    # paper §3: at mu = 0.6 the lock-in mode flutters (one growing mode near 2420 Hz)
    grow = [m for m in out["modes"] if m["unstable"]]
    assert len(grow) == 1 and grow[0]["friction_work"] > 0 and 2380 < grow[0]["frequency_hz"] < 2440


def test_cli_modes_at_onset_text(run):
    r = run("modes", "--at-onset", "--damped")
    assert r.exit_code == 0, r.output
    crit = critical_friction(LV, damped=True)
    assert f"{crit.mu_critical:.6f}" in r.stdout and "loses stability" in r.stdout
    assert "f [Hz]" in r.stdout


def test_cli_modes_writes_netcdf_and_png(run, tmp_path):
    nc, png = tmp_path / "m.nc", tmp_path / "m.png"
    r = run("modes", "--mu", "0.6", "--damped", "--out", str(nc), "--plot", str(png))
    assert r.exit_code == 0, r.output
    with xr.open_dataset(nc, engine="h5netcdf") as ds:  # readable by plain xarray
        assert ds.sizes["dof"] == 3 and "shape_real" in ds and "shape_imag" in ds
        assert ds.attrs["mu"] == 0.6
    assert png.read_bytes()[:4] == b"\x89PNG"
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # written atomically


@pytest.mark.parametrize(
    "args, message",
    [
        (["modes"], "give --mu or --at-onset"),
        (["modes", "--mu", "0.3", "--at-onset"], "either --mu or --at-onset"),
        (["modes", "--mu", "abc"], "is not a valid float"),
        (["modes", "--mu", "nan"], "must be finite"),
        (["modes", "--mu", "0.3", "--theta", "95"], "between -90 and 90"),
        (["modes", "--mu", "0.3", "--out", "x.csv"], "must end in .nc"),
        (["modes", "--mu", "0.3", "--plot", "x.txt"], "must end in .png"),
        (["modes", "--at-onset", "--theta", "31"], "No friction onset"),
        (["modes", "--mu", "0.3", "--set", "m1=-1"], "m1=-1.0 must be > 0"),
    ],
)
def test_cli_modes_bad_input_is_one_line_exit_2(run, args, message):
    r = run(*args)
    assert r.exit_code == 2, r.output
    assert message in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and "Traceback" not in r.output

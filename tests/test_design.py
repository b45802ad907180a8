"""Design parameters, eigenvalue derivatives, countermeasures and the DOE sweep (issue #26).

References: central differences of eigenvalues refined by Newton's method on the bordered system
``[P(lambda) x; c^H x - 1] = 0`` (no left eigenvector, no derivative formula involved); the exact
sensitivities of :func:`squealkit.stability.eigenvalue_sensitivity` for small models; full solves
(:func:`squealkit.stability.fe_modes`) for the confirmed changes and the reduced DOE.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from squealkit import InputError
from squealkit.design import (
    countermeasures,
    design_parameters,
    doe_sweep,
    eigen_derivatives,
    eigenvalue_derivatives,
    left_eigenvectors,
)
from squealkit.fe import FEModel, rpm_to_disc_speed

# the built-in brake, coarse (738 DOFs): at 500 rpm and mu = 0.6 one mode of 4-5 kHz is unstable
# (4414 Hz, sigma = 3.3 1/s), found by a band solve
RPM, MU, BAND = 500.0, 0.6, (4000.0, 4800.0)
DEMO_DESIGN = {
    "pad": "K1",
    "friction": "KR",
    "damping": "D1",
    "spin": "DG",
    "centrifugal": "KGeo",
    "mass": "M",
    "inboard": {"part": "K1", "nodes": [8, 9, 10, 11, 12, 13], "components": [3]},
    "disc_mass": {"mass": 0.0, "nodes": [8]},
}


@pytest.fixture(scope="module", autouse=True)
def _one_blas_thread():
    """The reference solves below run outside squealkit's entry points: one BLAS thread for them too."""
    from threadpoolctl import threadpool_limits

    with threadpool_limits(1, user_api="blas"):
        yield


@pytest.fixture(scope="module")
def demo():
    from squealkit.fe.demo import build_fe_demo

    d = build_fe_demo(n_theta=8, n_r=2)
    return FEModel.from_matrices(**{k: d[k] for k in ("M", "D1", "DG", "K1", "KR", "KGeo")}, dof_names=d["dof_names"],
                                 disc_speed_ref=d["disc_speed_ref"], mu_ref=d["mu_ref"])


@pytest.fixture(scope="module")
def demo_derivatives(demo):
    return eigen_derivatives(demo, DEMO_DESIGN, RPM, MU, method="sparse", band=BAND)


@pytest.fixture(scope="module")
def nlevp():
    from squealkit.data import nlevp_path
    from squealkit.fe import load_fe_model

    return load_fe_model(nlevp_path())


def _pencil(model, rpm, mu):
    w = float(rpm_to_disc_speed(rpm))
    return model.mass_matrix(), model.damping_matrix(w, mu), model.stiffness_matrix(w, mu)


def _newton(M, C, K, lam, x, iterations=5):
    """The eigenpair of ``P(lambda) = lambda^2 M + lambda C + K`` near ``(lam, x)`` by Newton's method on
    ``[P(lambda) x; c^H x - 1] = 0`` (Ruhe's form: ``u = P^-1 P'(lambda) x``, ``lambda -= c^H x / c^H u``)."""
    c = x / np.vdot(x, x)
    x = x / np.vdot(c, x)
    for _ in range(iterations):
        P = sp.csc_matrix(lam * lam * M + lam * C + K, dtype=complex)
        u = spla.splu(P).solve((2 * lam) * (M @ x) + C @ x)
        lam = lam - np.vdot(c, x) / np.vdot(c, u)
        x = u / np.vdot(c, u)
    return lam


def _central(model, param, rpm, mu, lam, x, h):
    """Richardson-extrapolated central difference of the eigenvalue near ``lam`` (error O(h^4))."""
    def d(step):
        up = _newton(*_pencil(param.apply(model, param.nominal + step), rpm, mu), lam, x)
        dn = _newton(*_pencil(param.apply(model, param.nominal - step), rpm, mu), lam, x)
        return (up - dn) / (2 * step)

    return (4 * d(h / 2) - d(h)) / 3


def _check_fd(model, ds, rpm, mu, design, mode_vectors):
    """Each derivative against the central difference whose step moves the eigenvalue by 1e-4 |lambda|
    (rounding of the refined eigenvalues: about 1e-12 relative; truncation after Richardson: h^4)."""
    params = design_parameters(design, model)
    lam = ds.growth_rate.values + 2j * math.pi * ds.frequency_hz.values
    for k in range(lam.size):
        for j, p in enumerate(params):
            exact = complex(ds.dgrowth_rate_dp.values[k, j] + 2j * math.pi * ds.dfrequency_hz_dp.values[k, j])
            fd = _central(model, p, rpm, mu, lam[k], mode_vectors[:, k],
                          min(1e-4 * abs(lam[k]) / abs(exact), (0.01 if p.kind == "mass" else 0.5) * p.step))
            assert abs(exact - fd) <= 1e-5 * abs(exact), (p.name, exact, fd)


def test_unit_mass_oscillator_derivative():
    """``x'' + k x = 0``: ``lambda = j sqrt(k)``, ``d lambda / d k = j / (2 sqrt(k))`` (closed form), with
    the left eigenvector found by inverse iteration."""
    one = np.eye(1)
    y = left_eigenvectors(one, 0 * one, 4 * one, [2j])
    d = eigenvalue_derivatives(one, 0 * one, [2j], one, y, 0 * one, 0 * one, one)
    assert d[0] == pytest.approx(0.25j, abs=1e-15)


def test_derivatives_match_central_differences_on_the_built_in_brake(demo, demo_derivatives):
    """Every parameter kind (part scales of K, C and M, a node-set scale, a point mass): d lambda / d p
    agrees with central differences of Newton-refined eigenvalues to 1e-5 relative."""
    ds = demo_derivatives
    assert ds.sizes["mode"] == 1 and ds.frequency_hz.values[0] == pytest.approx(4414.06, abs=0.01)
    assert ds.attrs["kind"] == "eigen_derivatives" and ds.attrs["method"] == "sparse"
    from squealkit.stability import fe_modes

    modes = fe_modes(demo, RPM, MU, method="sparse", band=BAND, unstable_only=True)
    X = modes.shape_real.values + 1j * modes.shape_imag.values
    _check_fd(demo, ds, RPM, MU, DEMO_DESIGN, X)
    # the signs an engineer expects: more damping or less friction stabilise the mode
    d = ds.dgrowth_rate_dp.sel(parameter=["damping", "friction"]).values[0]
    assert d[0] < 0 < d[1]


def test_derivatives_match_central_differences_on_nlevp_disk_brake100(nlevp):
    """NLEVP disk_brake100 at disc speed 2 pi rad/s (60 rpm): one unstable mode; every matrix part, a DOF
    block and a point mass where the mode moves most."""
    from squealkit.stability import fe_modes

    modes = fe_modes(nlevp, 60.0, 1.0, unstable_only=True)
    X = modes.shape_real.values + 1j * modes.shape_imag.values
    design = {"K1": "K1", "KR": "KR", "D1": "D1", "DR": "DR", "DG": "DG", "M": "M",
              "block": {"part": "K1", "dofs": list(range(20))},
              "point": {"mass": 0.0, "dofs": [int(np.argmax(np.abs(X[:, 0])))]}}
    ds = eigen_derivatives(nlevp, design, 60.0, 1.0)
    assert ds.sizes["mode"] == 1 and ds.growth_rate.values[0] == pytest.approx(1.06524e-3, rel=1e-4)
    _check_fd(nlevp, ds, 60.0, 1.0, design, X)


def test_reduced_derivatives_are_those_of_the_reduced_model(demo, demo_derivatives):
    """On a POD basis the derivatives are those of the reduced eigenvalue on that fixed basis (central
    differences of :func:`squealkit.solvers.reduction.reduced_solve`), and near the full model's."""
    from squealkit.solvers.reduction import reduce, reduced_solve
    from squealkit.stability.fe_sweep import FESolver

    w = float(rpm_to_disc_speed(RPM))
    V = FESolver(demo, "pod", BAND, samples=(np.array([w]), np.array([MU]))).reduced.V  # fe_modes' POD basis
    design = {"friction": "KR", "inboard": DEMO_DESIGN["inboard"]}
    ds = eigen_derivatives(demo, design, RPM, MU, band=BAND, basis=V)
    assert ds.attrs["method"] == "basis" and ds.attrs["basis_size"] == V.shape[1]
    assert ds.sizes["mode"] == 1 and ds.residual.values[0] < 1e-8
    d = ds.dgrowth_rate_dp.values[0] + 2j * math.pi * ds.dfrequency_hz_dp.values[0]
    full = demo_derivatives.sel(parameter=["friction", "inboard"])
    full = full.dgrowth_rate_dp.values[0] + 2j * math.pi * full.dfrequency_hz_dp.values[0]
    # the basis holds the mode: the reduced derivatives are near the full ones (3 % on this narrow band's basis)
    np.testing.assert_allclose(d, full, rtol=0.05)
    lam0, h = ds.growth_rate.values[0] + 2j * math.pi * ds.frequency_hz.values[0], 1e-4
    for j, p in enumerate(design_parameters(design, demo)):
        ev = []
        for s in (1, -1):
            lam, _, _ = reduced_solve(reduce(p.apply(demo, 1.0 + s * h), V), w, MU, *BAND)
            ev.append(lam[np.argmin(np.abs(lam - lam0))])
        fd = (ev[0] - ev[1]) / (2 * h)
        assert abs(d[j] - fd) <= 1e-5 * abs(d[j])


@pytest.fixture(scope="module")
def demo_countermeasures(demo):
    return countermeasures(demo, {"friction": "KR", "damping": "D1"}, RPM, MU, method="sparse", band=BAND)


def test_predicted_stabilising_change_is_confirmed_by_a_solve(demo, demo_countermeasures):
    """Done-when of issue #26: on the built-in brake the first-order stabilising change of the friction
    scale is confirmed by solves within 5 %, and an independent full solve at the confirmed value finds
    the mode on the stability boundary."""
    from squealkit.stability import fe_modes

    ds = demo_countermeasures
    assert ds.attrs["kind"] == "countermeasures" and ds.sizes["mode"] == 1
    assert list(ds.status.values[0]) == ["confirmed", "confirmed"]
    assert float(ds.prediction_error.sel(parameter="friction")[0]) < 0.05
    assert float(ds.predicted_change.sel(parameter="friction")[0]) < 0  # less friction
    assert float(ds.confirmed_change.sel(parameter="damping")[0]) > 0  # more damping
    assert list(ds["rank"].values[0]) == [1, 2]  # per 10 % step, friction acts more than damping
    params = design_parameters({"friction": "KR"}, demo)
    value = float(ds.confirmed_value.sel(parameter="friction")[0])
    f0 = float(ds.frequency_hz[0])
    for shift, stable in ((-1e-3, True), (1e-3, False)):  # just beyond the root the mode is stable, before not
        check = fe_modes(params[0].apply(demo, value + shift), RPM, MU, method="sparse", band=BAND)
        near = np.abs(check.frequency_hz.values - f0) < 0.02 * f0
        assert (check.growth_rate.values[near].max() < 0) == stable


def test_mode_coupling_is_removed_at_the_closed_form_friction():
    """Two DOFs ``K = diag(1, 1.2) + mu p [[0, 1], [-1, 0]]``, ``C = c I``: the stiffness eigenvalues are
    ``kappa = 1.1 +- sqrt(0.01 - (mu p)^2)``; the pair is on the stability boundary where
    ``lambda = j omega``, i.e. ``Im kappa = c sqrt(1.1)`` (closed form): ``p = sqrt(0.01 + 1.1 c^2) / mu``.
    The growth rate goes as a square root there (Newton crawls; the bracket confirms it)."""
    c, mu = 1e-3, 0.2
    m = FEModel.from_matrices(M=np.eye(2), K1=np.diag([1.0, 1.2]), KR=[[0.0, 1.0], [-1.0, 0.0]], D1=c * np.eye(2))
    ds = countermeasures(m, {"friction": "KR"}, rpm=60.0, mu=mu)
    assert str(ds.status.values[0, 0]) == "confirmed"
    assert float(ds.confirmed_value[0, 0]) == pytest.approx(math.sqrt(0.01 + 1.1 * c * c) / mu, abs=1e-4)
    assert float(ds.confirmed_growth_rate[0, 0]) <= 0.0


def test_report_sentences_are_made_from_the_numbers(demo_countermeasures):
    from squealkit.report.design import design_section, design_sentences

    ds = demo_countermeasures
    text = design_sentences(ds)
    change = float(ds.confirmed_change.sel(parameter="friction")[0])
    assert text[0].startswith("1 mode is unstable at 500 rpm and mu = 0.6")
    assert f"is removed at the smallest cost by changing friction by {change:+.3g}" in text[1]
    assert "also removed by changing damping by +" in text[1]
    assert design_section(ds).tables[0].rows[0][1] == "friction"


def test_doe_on_the_reduced_model_matches_full_solves(demo):
    """A 2 x 3 DOE on the reduced model: every pair trusted by its full-model backward error, and the
    largest growth rate equal to a full solve's at the corners."""
    from squealkit.stability import fe_modes

    values = {"friction": [0.7, 1.0], "damping": [1.0, 1.5, 2.0]}
    ds = doe_sweep(demo, {"friction": "KR", "damping": "D1"}, values, RPM, MU, band=BAND)
    assert ds.sizes["point"] == 6 and ds.attrs["kind"] == "doe_sweep" and bool(ds.all_trusted.all())
    assert ds.change_size.values[np.argmin(np.abs(ds.value.values - [1.0, 1.0]).sum(axis=1))] == 0.0
    params = design_parameters({"friction": "KR", "damping": "D1"}, demo)
    for i in (0, 5):
        changed = demo
        for p, v in zip(params, ds.value.values[i], strict=True):
            changed = p.apply(changed, v)
        full = fe_modes(changed, RPM, MU, method="sparse", band=BAND)
        assert float(ds.max_growth_rate[i]) == pytest.approx(float(full.growth_rate.max()), rel=1e-6, abs=1e-6)
    assert ds.pareto.any() and ds.squeal.plots == ("pareto",)
    fig = ds.squeal.plot()  # squealkit.plotting.design.pareto_plot
    assert fig.axes[0].get_xlabel() == "size of the change [declared steps]"


# -- declarations -----------------------------------------------------------------------------


def test_declared_derivative_matrices():
    """Known answers: a part's derivative carries its factor at the operating point (KR: mu / mu_ref;
    DG: v / v_ref; KGeo: (v / v_ref)^2); a node-set scale keeps the set's block; a point mass is E."""
    KR = np.array([[0.0, 1.0], [-1.0, 0.0]])
    m = FEModel.from_matrices(M=np.eye(2), K1=np.diag([4.0, 9.0]), KR=KR, DG=np.array([[0, 1.0], [-1.0, 0]]),
                              KGeo=np.eye(2), mu_ref=0.5, disc_speed_ref=2.0)
    p = {q.name: q for q in design_parameters({"f": "KR", "g": "DG", "c": "KGeo", "k": "K", "one": {
        "part": "K1", "dofs": [1]}, "m": {"mass": 0.0, "dofs": [0]}}, m)}
    kw = {"disc_speed": 4.0, "mu": 0.25}
    np.testing.assert_allclose(p["f"].matrix_derivatives(m, **kw)[2].toarray(), 0.5 * KR)
    np.testing.assert_allclose(p["g"].matrix_derivatives(m, **kw)[1].toarray(), 2.0 * m.DG.toarray())
    np.testing.assert_allclose(p["c"].matrix_derivatives(m, **kw)[2].toarray(), 4.0 * np.eye(2))
    np.testing.assert_allclose(p["k"].matrix_derivatives(m, **kw)[2].toarray(), m.stiffness_matrix(4.0, 0.25).toarray())
    np.testing.assert_allclose(p["one"].matrix_derivatives(m, **kw)[2].toarray(), [[0, 0], [0, 9.0]])
    np.testing.assert_allclose(p["m"].matrix_derivatives(m, **kw)[0].toarray(), [[1.0, 0], [0, 0]])
    np.testing.assert_allclose(p["one"].apply(m, 2.0).K1.toarray(), np.diag([4.0, 18.0]))
    np.testing.assert_allclose(p["m"].apply(m, 0.5).M.toarray(), np.diag([1.5, 1.0]))


@pytest.mark.parametrize(("table", "match"), [
    ({}, "empty"),
    ({"pad": "K7"}, "part = 'K7'"),
    ({"pad": "DR"}, "has no DR"),
    ({"pad": {"part": "K1", "nodse": [1]}}, "unknown key 'nodse'"),
    ({"pad": {"part": "K1", "dofs": [5]}}, "dofs must be indices in 0..1"),
    ({"pad": {"part": "K1", "nodes": [1]}}, "no DOF map"),
    ({"tip": {"mass": -1.0, "dofs": [0]}}, "mass = -1.0"),
    ({"tip": {"mass": 1.0}}, "needs nodes"),
    ({"bad name": "K1"}, "identifier"),
    ({"pad": {"part": "K1", "step": 0}}, "step = 0"),
])
def test_bad_declarations_are_refused_in_one_line(table, match):
    m = FEModel.from_matrices(M=np.eye(2), K1=np.diag([4.0, 9.0]))
    with pytest.raises(InputError, match=match) as e:
        design_parameters(table, m)
    assert "\n" not in str(e.value)


def test_small_model_parameters_and_operating_point():
    from squealkit.models import get_preset

    model = get_preset("lv2013")
    with pytest.raises(InputError, match="scalar model parameter"):
        design_parameters({"x": "K1"}, model)
    with pytest.raises(InputError, match="rpm applies to FE models only"):
        eigen_derivatives(model, {"k": "k1"}, rpm=100.0, mu=0.6)
    with pytest.raises(InputError, match="needs a disc speed"):
        eigen_derivatives(FEModel.from_matrices(M=np.eye(1), K1=np.eye(1)), {"k": "K1"}, mu=0.6)


# -- property tests: random small models against the exact sensitivities ------------------------


def _separated(lam, tol=1e-3):
    d = np.where(np.eye(lam.size, dtype=bool), np.inf, np.abs(lam[:, None] - lam[None, :]))
    return bool(np.all(d.min(axis=1) > tol * np.abs(lam).max()))


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(n=st.integers(2, 4), data=st.data(), mu=st.floats(0.05, 1.0))
def test_friction_scale_of_random_matrix_models_matches_the_exact_sensitivity(n, data, mu):
    """A random damped matrix model ``K = K0 + s mu Kf`` in FE form (``K1 = K0``, ``KR = Kf``, mu_ref = 1):
    the scale of KR is mu times d/d mu, so d lambda / d p = mu * eigenvalue_sensitivity(.., "mu")."""
    from squealkit.models import MatrixModel
    from squealkit.stability import eigenvalue_sensitivity

    entries = st.floats(-1.0, 1.0, allow_nan=False)
    A = data.draw(hnp.arrays(float, (n, n), elements=entries))
    B = data.draw(hnp.arrays(float, (n, n), elements=entries))
    Kf = data.draw(hnp.arrays(float, (n, n), elements=entries))
    masses = data.draw(hnp.arrays(float, (n,), elements=st.floats(0.5, 2.0)))
    K0 = A @ A.T + np.diag(2.0 * np.arange(1, n + 1))  # distinct undamped frequencies
    C = 0.01 * (B @ B.T + np.eye(n))
    small = MatrixModel(M=np.diag(masses), K0=K0, C=C, Kf=Kf)
    exact = eigenvalue_sensitivity(small, mu, 0.0, "mu", damped=True)
    lam_ref = exact.growth_rate.values + 1j * exact.omega.values
    assume(_separated(lam_ref))
    fe = FEModel.from_matrices(M=np.diag(masses), K1=K0, D1=C, KR=Kf, mu_ref=1.0)
    ds = eigen_derivatives(fe, {"friction": "KR"}, rpm=60.0, mu=mu, method="dense", unstable_only=False)
    lam = ds.growth_rate.values + 2j * math.pi * ds.frequency_hz.values
    d = ds.dgrowth_rate_dp.values[:, 0] + 2j * math.pi * ds.dfrequency_hz_dp.values[:, 0]
    ref = exact.dgrowth_rate_dp.values + 1j * exact.domega_dp.values
    for k in range(lam_ref.size):
        i = int(np.argmin(np.abs(lam - lam_ref[k])))
        assert abs(lam[i] - lam_ref[k]) <= 1e-8 * abs(lam_ref).max()
        assert d[i] == pytest.approx(mu * ref[k], rel=1e-6, abs=1e-9 * np.abs(lam_ref).max())


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(k1=st.floats(0.5, 2.0), kc=st.floats(0.5, 2.0), mu=st.floats(0.2, 0.9),
       name=st.sampled_from(["k1", "k2", "k3", "kc", "m1", "c1"]))
def test_model_parameters_of_random_pin_on_disc_models_match_the_exact_sensitivity(k1, kc, mu, name):
    """The pin-on-disc model with scaled stiffnesses: a design parameter naming a model parameter has the
    derivative :func:`~squealkit.stability.eigenvalue_sensitivity` computes, for every mode."""
    from squealkit.models import get_preset
    from squealkit.stability import eigenvalue_sensitivity

    base = get_preset("lv2013")
    model = base.replace(k1=base.k1 * k1, kc=base.kc * kc)
    exact = eigenvalue_sensitivity(model, mu, 0.0, name, damped=True)
    lam_ref = exact.growth_rate.values + 1j * exact.omega.values
    assume(_separated(lam_ref))
    ds = eigen_derivatives(model, {"p": name}, mu=mu, unstable_only=False)
    lam = ds.growth_rate.values + 2j * math.pi * ds.frequency_hz.values
    d = ds.dgrowth_rate_dp.values[:, 0] + 2j * math.pi * ds.dfrequency_hz_dp.values[:, 0]
    ref = exact.dgrowth_rate_dp.values + 1j * exact.domega_dp.values
    np.testing.assert_allclose(lam, lam_ref, rtol=1e-10)
    np.testing.assert_allclose(d, ref, rtol=1e-6, atol=1e-9 * np.abs(ref).max() + 1e-12 * np.abs(lam_ref).max())

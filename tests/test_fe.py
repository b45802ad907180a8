"""FE brake models: the model, its readers, the dense and sparse solvers, sweeps and the CLI.

References: NLEVP's disk_brake100 (Betcke et al., BSD-3; Graebner et al., ZAMM 96(12) 2016),
solved by LAPACK's generalised eigensolver (scipy.linalg.eigvals on the companion pencil) as
an independent dense reference; the closed-form flutter threshold of a 2-DOF model; and
MatrixModel, the toolkit's existing engine, on the same 2-DOF system.
"""

import json
import math

import numpy as np
import pytest
import scipy.io
import scipy.linalg as sla
import scipy.sparse as sp

from squealkit import InputError
from squealkit.data import nlevp_path
from squealkit.models import FEModel, MatrixModel, load_fe_model, load_model
from squealkit.solvers.band import band_eigs, dense_eigs
from squealkit.stability import (
    ONSET_STATUS,
    eigenvalues,
    fe_critical_friction,
    fe_modes,
    fe_stability_map,
    stability_map,
)

# -- the NLEVP problem and its dense reference -------------------------------------------------


@pytest.fixture(scope="module")
def brake():
    return load_fe_model(nlevp_path())


def reference_eigs(model, omega, mu):
    """All 2n eigenvalues of the companion pencil (A, B), LAPACK's QZ: no M^-1, no Cholesky."""
    n = model.n_dof
    M = model.M.toarray()
    C = model.damping_matrix(omega, mu).toarray()
    K = model.stiffness_matrix(omega, mu).toarray()
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-K, -C]])
    B = sla.block_diag(np.eye(n), M)
    return sla.eigvals(A, B)


def nlevp_matrices(omega):
    """NLEVP's own assembly (disk_brake100.m): D = D1 + DR/omega + omega DG, K = K1 + KR."""
    d = scipy.io.loadmat(nlevp_path())
    return d["M"], d["D1"] + d["DR"] / omega + omega * d["DG"], d["K1"] + d["KR"]


def test_fe_model_reproduces_nlevp_assembly(brake):
    # disc_speed_ref = mu_ref = 1 and mu = 1: exactly NLEVP's formulation (README, "Finite element brake models")
    for omega in (2 * np.pi, 8 * np.pi):
        M, D, K = nlevp_matrices(omega)
        np.testing.assert_array_equal(brake.mass_matrix().toarray(), M)
        np.testing.assert_allclose(brake.damping_matrix(omega, 1.0).toarray(), D, rtol=1e-15, atol=0)
        np.testing.assert_allclose(brake.stiffness_matrix(omega, 1.0).toarray(), K, rtol=1e-15, atol=0)


def _upper(lam):
    lam = lam[np.isfinite(lam) & (lam.imag > 0)]
    return lam[np.lexsort((lam.real, lam.imag))]


def test_dense_solve_agrees_with_reference_to_1e8(brake):
    # Done-when of issue 11: disk_brake100 at omega = 2 pi against a dense reference, 1e-8 relative
    omega = 2 * np.pi
    ref = reference_eigs(brake, omega, 1.0)
    sol = dense_eigs(brake, omega, 1.0)
    assert sol.eigenvalues.size == brake.n_dof
    got = _upper(sol.eigenvalues)
    want = _upper(ref)
    assert got.size == want.size
    assert np.max(np.abs(got - want) / np.abs(want)) < 1e-8
    # the real roots: the larger half of the reference's real roots
    real_ref = np.sort(ref[np.abs(ref.imag) == 0].real)[::-1][: brake.n_dof - got.size]
    real_got = np.sort(sol.eigenvalues[sol.eigenvalues.imag == 0].real)[::-1]
    np.testing.assert_allclose(real_got, real_ref, rtol=1e-8)
    assert sol.residuals.max() < 1e-12


def test_band_solve_agrees_with_reference_to_1e8(brake):
    # shift-invert with one sparse LU per shift: every reference eigenvalue in the band within the
    # covered strip is found, nothing else, each to 1e-8 relative
    omega, band = 2 * np.pi, (0.1, 0.3)
    sol = band_eigs(brake, omega, 1.0, band=band, k=30, sigma_reach=0.5)
    ref = _upper(reference_eigs(brake, omega, 1.0))
    f = ref.imag / (2 * np.pi)
    in_band = ref[(f >= band[0]) & (f <= band[1])]
    must = in_band[np.abs(in_band.real) <= sol.covered_growth]
    assert sol.covered_growth >= 0.5 and must.size >= 15
    for r in must:
        assert np.min(np.abs(sol.eigenvalues - r)) / abs(r) < 1e-8
    for x in sol.eigenvalues:
        assert np.min(np.abs(in_band - x)) / abs(x) < 1e-8
    assert np.all(sol.residuals < 1e-12)
    # no duplicates across shifts
    assert np.unique(np.round(sol.eigenvalues, 10)).size == sol.eigenvalues.size


def test_band_solve_keeps_exact_doublets():
    # a symmetric "disc": pairs of equal frequencies (doublets) must both be found, once each
    n = 40
    w = np.repeat(2 * np.pi * np.linspace(1000, 9000, n // 2), 2)
    m = FEModel.from_matrices(M=sp.eye(n), K1=sp.diags(w**2), D1=sp.diags(2e-3 * w))
    sol = band_eigs(m, 10.0, 0.0, band=(990, 16000), k=6)
    np.testing.assert_allclose(np.sort(sol.eigenvalues.imag), np.sort(w * np.sqrt(1 - 1e-6)), rtol=1e-9)


@pytest.mark.parametrize("workers", [1, 2])
def test_band_solve_default_k_fits_small_models(workers):
    # the default eigenvalues per shift (24 for one walk, 32 for two) are capped by the model's
    # size: a 15-DOF model has 30 eigenvalues, every one of them in the band
    n = 15
    w = 2 * np.pi * np.linspace(500.0, 1500.0, n)
    m = FEModel.from_matrices(M=sp.eye(n), K1=sp.diags(w**2))
    sol = band_eigs(m, 1.0, 0.3, band=(400.0, 1600.0), workers=workers)
    np.testing.assert_allclose(np.sort(sol.eigenvalues.imag), w, rtol=1e-10)


# -- closed forms: a 2-DOF model in both engines ------------------------------------------------


def two_dof():
    """Hoffmann-like: K = [[k1, mu kc], [-mu kc, k2]] flutters where (k1 - k2)^2 = 4 (mu kc)^2."""
    k1, k2, kc = 1.2e6, 1.0e6, 4.0e5
    fe = FEModel.from_matrices(M=np.eye(2), K1=np.diag([k1, k2]), KR=[[0.0, kc], [-kc, 0.0]])
    mm = MatrixModel(M=np.eye(2), K0=np.diag([k1, k2]), Kf=[[0.0, kc], [-kc, 0.0]])
    return fe, mm, abs(k1 - k2) / (2 * kc)


def test_two_dof_fe_and_matrix_model_agree():
    fe, mm, _ = two_dof()
    for mu in (0.0, 0.1, 0.4):
        a = np.sort_complex(dense_eigs(fe, 1.0, mu).eigenvalues)
        b = np.sort_complex(eigenvalues(mm, mu))
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-9)


def test_two_dof_critical_friction_closed_form():
    fe, _, mu_c = two_dof()
    ds = fe_critical_friction(fe, [100.0, 1000.0], mu_max=1.0)
    np.testing.assert_allclose(ds.mu_critical.values, mu_c, atol=2e-6)
    assert list(ds.status.values) == [ONSET_STATUS.index("onset")] * 2
    # the run-out slope acts as friction: mu_e = mu + tan(theta)
    t = math.radians(3.0)
    ds = fe_critical_friction(fe, [100.0], mu_max=1.0, theta=t, mu_operating=0.1)
    assert ds.mu_critical.values[0] == pytest.approx(mu_c - math.tan(t), abs=2e-6)
    assert ds.tan_theta_max.values[0] == pytest.approx(mu_c - 0.1, abs=2e-6)


def test_speed_terms_follow_their_formulas():
    n = 3
    rng = np.random.default_rng(1)
    G = rng.normal(size=(n, n))
    parts = {"M": np.eye(n), "K1": np.diag([1.0, 2.0, 3.0]), "KR": rng.normal(size=(n, n)),
             "DR": rng.normal(size=(n, n)), "DG": G - G.T, "D4": np.eye(n), "KGeo": np.diag([1.0, 0.0, 1.0]),
             "D1": 0.1 * np.eye(n)}
    m = FEModel.from_matrices(**parts, disc_speed_ref=2.0, mu_ref=0.5, f_ref=4.0)
    w, mu, t = 3.0, 0.3, 0.1
    C = parts["D1"] + (mu + t) / 0.5 * (2.0 / w) * parts["DR"] + w / 2.0 * parts["DG"] + parts["D4"] / 4.0
    K = parts["K1"] + (mu + t) / 0.5 * parts["KR"] + (w / 2.0) ** 2 * parts["KGeo"]
    np.testing.assert_allclose(m.damping_matrix(w, mu, t).toarray(), C, rtol=1e-14)
    np.testing.assert_allclose(m.stiffness_matrix(w, mu, t).toarray(), K, rtol=1e-14)
    V = np.linalg.qr(rng.normal(size=(n, 2)))[0]
    red = m.project(V)
    np.testing.assert_allclose(red.stiffness_matrix(w, mu).toarray(), V.T @ m.stiffness_matrix(w, mu) @ V,
                               rtol=1e-12)


def test_undamped_symmetric_model_is_on_the_imaginary_axis():
    fe = FEModel.from_matrices(M=np.diag([1.0, 2.0]), K1=[[3.0, -1.0], [-1.0, 2.0]])
    lam = dense_eigs(fe, 1.0, 0.0).eigenvalues
    assert np.all(np.abs(lam.real) < 1e-12 * np.abs(lam))


# -- sweeps ---------------------------------------------------------------------------------------


def test_sweep_matches_pointwise_solves_and_stability_map(brake):
    rpm, mu = [60.0, 240.0], [0.0, 1.0]
    ds = stability_map(brake, mu, rpm=rpm)
    assert dict(ds.sizes) == {"rpm": 2, "mu": 2, "mode": brake.n_dof}
    for i, r in enumerate(rpm):
        for j, m in enumerate(mu):
            lam = np.sort_complex(dense_eigs(brake, 2 * np.pi * r / 60, m, vectors=False).eigenvalues)
            got = np.sort_complex(ds.growth_rate.values[i, j] + 1j * ds.omega.values[i, j])
            np.testing.assert_allclose(got, lam, rtol=1e-9, atol=1e-12)
    # NLEVP at mu = mu_ref: one eigenvalue with positive real part, |lambda| ~ 1e-3 (dense reference)
    assert bool(ds.any_unstable.values[0, 1]) and not bool(ds.any_unstable.values[0, 0])
    ref = reference_eigs(brake, 2 * np.pi, 1.0)
    assert int(np.sum(ref.real > 1e-9 * np.abs(ref).max())) == 2  # a conjugate pair
    assert set(ds.attrs) >= {"model", "method", "band_hz"} and ds.attrs["method"] == "dense"


def test_tracking_follows_modes_through_a_crossing():
    # two uncoupled modes whose frequencies cross as friction (in KR) grows: tracked by MAC
    fe = FEModel.from_matrices(M=np.eye(2), K1=np.diag([1.0, 2.0]), KR=np.diag([2.0, 0.0]),
                               D1=0.01 * np.eye(2))
    ds = fe_stability_map(fe, [60.0], np.linspace(0.0, 1.0, 11))
    w = ds.omega.values[0]
    np.testing.assert_allclose(w[:, 0] ** 2 + 0.005**2, 1 + 2 * np.linspace(0, 1, 11), rtol=1e-9)  # mode 0: x1


@pytest.mark.slow
def test_sparse_sweep_with_an_empty_band(run, brake_toml):
    # disk_brake100's scaled frequencies are all below 1 Hz: nothing in the default 1-16 kHz band
    r = run("stability", "--config", str(brake_toml), "--rpm", "60", "--method", "sparse", "--json")
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout)
    assert out["unstable_fraction"] == 0.0 and out["unstable_frequency_hz"] is None
    assert out["band_hz"] == [1000.0, 16000.0]


def test_sparse_sweep_tracks_band_modes():
    # a 40-DOF modal model with two friction-coupled modes at 2.0 and 2.1 kHz: the sparse sweep
    # equals the dense sweep restricted to the band, mode by mode
    n = 40
    w = 2 * np.pi * np.linspace(500, 9000, n)
    w[10], w[11] = 2 * np.pi * 2000, 2 * np.pi * 2100
    KR = sp.lil_matrix((n, n))
    KR[10, 11], KR[11, 10] = 0.2 * w[10] ** 2, -0.2 * w[10] ** 2
    fe = FEModel.from_matrices(M=sp.eye(n), K1=sp.diags(w**2), KR=KR.tocsr(), D1=sp.diags(1e-4 * w))
    band = (1500.0, 4000.0)
    sp_ds = fe_stability_map(fe, [100.0, 200.0], np.linspace(0.0, 1.0, 6), method="sparse", band=band)
    de_ds = fe_stability_map(fe, [100.0, 200.0], np.linspace(0.0, 1.0, 6), method="dense", band=band)
    np.testing.assert_array_equal(sp_ds.any_unstable.values, de_ds.any_unstable.values)
    assert sp_ds.any_unstable.values[:, -1].all() and not sp_ds.any_unstable.values[:, 0].any()
    np.testing.assert_allclose(np.sort(sp_ds.frequency_hz.values, axis=-1), np.sort(de_ds.frequency_hz.values, axis=-1),
                               rtol=1e-10)
    np.testing.assert_allclose(sp_ds.max_growth_rate.values, de_ds.max_growth_rate.values, rtol=1e-8, atol=1e-9)


def test_sweep_bad_input():
    fe, _, _ = two_dof()
    with pytest.raises(InputError, match="method"):
        fe_stability_map(fe, [60.0], [0.1], method="magic")
    with pytest.raises(InputError, match="rpm"):
        stability_map(fe, [0.1])
    with pytest.raises(InputError, match="FE models only"):
        stability_map(MatrixModel(M=np.eye(2), K0=np.eye(2)), [0.1], rpm=[60.0])
    import importlib.util

    if importlib.util.find_spec("squealkit.stability.reduction") is None:  # delivered on its own branch
        with pytest.raises(InputError, match=r"squealkit\.stability\.reduction"):
            fe_stability_map(fe, [60.0], [0.1], method="modal")


def test_modes_unit_shapes_and_residuals(brake):
    ds = fe_modes(brake, 60.0, 1.0)
    amp = np.hypot(ds.shape_real.values, ds.shape_imag.values)
    np.testing.assert_allclose(amp.max(axis=0), 1.0)
    assert ds.attrs["verdict"] == "flutter" and int(ds.unstable.sum()) == 1
    assert float(ds.residual.max()) < 1e-12


# -- validation and readers ----------------------------------------------------------------------


@pytest.mark.parametrize(
    ("mats", "message"),
    [
        ({"M": np.eye(2), "K1": np.eye(3)}, "Matrix K1 must be 2x2 like M"),
        ({"M": [[1.0, 0.5], [0.0, 1.0]], "K1": np.eye(2)}, "Matrix M must be symmetric"),
        ({"M": [[1.0, 2.0], [2.0, 1.0]], "K1": np.eye(2)}, "Matrix M must be positive semidefinite"),
        ({"M": np.eye(2), "K1": [[1.0, np.nan], [0.0, 1.0]]}, "Matrix K1 contains a non-finite"),
        ({"M": np.eye(2), "K1": np.ones((2, 3))}, "Matrix K1 must be square"),
        ({"M": np.eye(2)}, "needs matrix K1"),
        ({"M": np.eye(2), "K1": np.eye(2), "KX": np.eye(2)}, "Unknown FE matrix 'KX'"),
    ],
)
def test_bad_matrices_one_line_errors(mats, message):
    with pytest.raises(InputError, match=message) as e:
        FEModel.from_matrices(**mats)
    assert "\n" not in str(e.value)


def test_bad_reference_values():
    with pytest.raises(InputError, match="mu_ref"):
        FEModel.from_matrices(M=np.eye(1), K1=np.eye(1), mu_ref=0.0)
    m = FEModel.from_matrices(M=np.eye(1), K1=np.eye(1), DR=np.eye(1))
    with pytest.raises(InputError, match="disc_speed"):
        m.damping_matrix(0.0, 0.3)


@pytest.fixture()
def small():
    rng = np.random.default_rng(7)
    n = 6
    A = rng.normal(size=(n, n))
    return {"M": sp.csr_matrix(A @ A.T + n * np.eye(n)), "K1": sp.random(n, n, 0.5, random_state=1, format="csr")
            + sp.eye(n), "KR": sp.csr_matrix(rng.normal(size=(n, n))), "DG": sp.csr_matrix(A - A.T)}


def _same(model, mats):
    for k, v in mats.items():
        np.testing.assert_array_equal(getattr(model, k).toarray(), v.toarray())


def test_read_mat_v5(tmp_path, small):
    scipy.io.savemat(tmp_path / "b.mat", {"MAA": small["M"], **{k: v for k, v in small.items() if k != "M"}})
    m = load_fe_model(tmp_path / "b.mat", names={"M": "MAA"}, mu_ref=0.5)
    _same(m, small)
    assert m.mu_ref == 0.5


def _write_v73(path, mats):
    """A MATLAB v7.3 file as MATLAB writes it: HDF5, dense arrays transposed, sparse as data/ir/jc."""
    import h5py

    with h5py.File(path, "w") as f:
        for k, v in mats.items():
            if k == "M":  # dense, column-major
                f.create_dataset(k, data=v.toarray().T)
                f[k].attrs["MATLAB_class"] = np.bytes_("double")
            else:
                c = sp.csc_matrix(v)
                g = f.create_group(k)
                g.attrs["MATLAB_class"] = np.bytes_("double")
                g.attrs["MATLAB_sparse"] = np.uint64(c.shape[0])
                g.create_dataset("data", data=c.data)
                g.create_dataset("ir", data=c.indices.astype(np.uint64))
                g.create_dataset("jc", data=c.indptr.astype(np.uint64))


def test_read_mat_v73(tmp_path, small):
    _write_v73(tmp_path / "b.mat", small)
    _same(load_fe_model(tmp_path / "b.mat"), small)


def test_read_matrix_market_files_and_toml(tmp_path, small):
    for k, v in small.items():
        scipy.io.mmwrite(tmp_path / f"{k}.mtx", v)
    (tmp_path / "sub").mkdir()
    toml = tmp_path / "sub" / "brake.toml"
    files = ", ".join(f'{k} = "../{k}.mtx"' for k in small)
    toml.write_text(f'model = "fe"\n[fe]\nfiles = {{{files}}}\ndisc_speed_ref = 2.0\nf_ref = 1600\n')
    m = load_model(toml)
    _same(m, small)
    assert (m.disc_speed_ref, m.mu_ref, m.f_ref) == (2.0, 1.0, 1600.0)


def test_read_op4_round_trip(tmp_path, small):
    pytest.importorskip("pyNastran")
    from pyNastran.op2.result_objects.matrix import Matrix
    from pyNastran.op4.op4 import write_op4

    # Nastran names; the dense M as a square form-6 (symmetric) matrix, the others sparse (ASCII OP4)
    mats = {"MAA": Matrix("MAA", 6, small["M"].toarray()), "KAA": Matrix("KAA", 1, sp.coo_matrix(small["K1"])),
            "KR": Matrix("KR", 1, sp.coo_matrix(small["KR"])), "DG": Matrix("DG", 1, sp.coo_matrix(small["DG"]))}
    write_op4(str(tmp_path / "b.op4"), mats, is_binary=False, precision="double")
    m = load_fe_model(tmp_path / "b.op4", names={"M": "MAA", "K1": "KAA"})
    for k in small:
        np.testing.assert_allclose(getattr(m, k).toarray(), small[k].toarray(), rtol=1e-15)


@pytest.mark.parametrize(
    ("toml", "message"),
    [
        ('model = "fe"\n', "needs an \\[fe\\] table"),
        ('model = "fe"\n[fe]\nfile = "nope.mat"\n', "does not exist"),
        ('model = "fe"\n[fe]\nfile = "x.mat"\nfiles = {M = "M.mtx"}\n', "either file"),
        ('model = "fe"\n[fe]\nfile = "x.mat"\nomega = 1\n', "Unknown \\[fe\\] key 'omega'"),
        ('model = "fe"\npreset = "lv2013"\n[fe]\nfile = "x.mat"\n', "remove 'preset'"),
        ('model = "fe"\n[fe]\nfile = "b.txt"\n', "unknown format"),
    ],
)
def test_bad_fe_toml(tmp_path, toml, message):
    (tmp_path / "b.txt").write_text("1")
    p = tmp_path / "brake.toml"
    p.write_text(toml)
    with pytest.raises(InputError, match=message) as e:
        load_model(p)
    assert "\n" not in str(e.value)


def test_missing_named_matrix(tmp_path, small):
    scipy.io.savemat(tmp_path / "b.mat", {k: v for k, v in small.items()})
    with pytest.raises(InputError, match="no matrix 'KAA' \\(for K1\\)"):
        load_fe_model(tmp_path / "b.mat", names={"K1": "KAA"})


# -- the CLI end to end on disk_brake100 -----------------------------------------------------------


@pytest.fixture()
def brake_toml(tmp_path):
    import shutil

    shutil.copy(nlevp_path(), tmp_path / "disk_brake100.mat")
    p = tmp_path / "brake.toml"
    p.write_text('model = "fe"\n[fe]\nfile = "disk_brake100.mat"\n')
    return p


def test_cli_stability_fe(run, brake_toml, tmp_path):
    png, mp, nc = tmp_path / "g.png", tmp_path / "m.png", tmp_path / "m.nc"
    r = run("stability", "--config", str(brake_toml), "--rpm", "60:240:3", "--mu", "0:1:3", "--json",
            "--plot", str(png), "--plot-map", str(mp), "--out", str(nc))
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout)
    assert out["grid_points"] == 9 and out["method"] == "dense" and out["n_dof"] == 100
    for key in ("unstable_fraction", "max_growth_rate", "unstable_frequency_hz", "lock_in_fraction"):
        assert key in out
    assert out["unstable_fraction"] == pytest.approx(6 / 9)  # mu = 0 stable, 0.5 and 1 unstable
    assert png.read_bytes()[:4] == b"\x89PNG" and mp.read_bytes()[:4] == b"\x89PNG"
    from squealkit.io import load_dataset

    assert dict(load_dataset(nc).sizes) == {"rpm": 3, "mu": 3, "mode": 100}


def test_cli_critical_modes_tolerance_fe(run, brake_toml):
    r = run("critical", "--config", str(brake_toml), "--rpm", "60:240:2", "--json")
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout)
    assert out["status"] == ["onset", "onset"] and 0.0 < out["mu_critical"][0] < 0.5
    r = run("modes", "--config", str(brake_toml), "--rpm", "60", "--eigen-band", "0.3:0.4", "--json")
    assert r.exit_code == 0, r.output
    modes = json.loads(r.stdout)["modes"]
    assert modes and all(0.3 <= m["frequency_hz"] <= 0.4 and m["residual"] < 1e-12 for m in modes)
    r = run("tolerance", "--config", str(brake_toml), "--rpm", "60", "--mu", "0.05", "--json")
    assert r.exit_code == 0, r.output
    t = json.loads(r.stdout)
    assert t["tan_theta_max"][0] == pytest.approx(t["mu_critical"][0] - 0.05)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (("stability", "--rpm", "60:240:3"), "--rpm applies to FE models only"),
        (("stability", "--CONFIG"), None),
        (("critical", "--config", "{toml}"), "needs disc speeds"),
        (("stability", "--config", "{toml}", "--rpm", "-60:60:3"), "must be > 0 rpm"),
        (("stability", "--config", "{toml}", "--rpm", "60", "--eigen-band", "16000"),
         "--eigen-band '16000' must be LO:HI"),
        (("stability", "--config", "{toml}", "--rpm", "60", "--theta", "-8:8:3"), "one angle"),
        (("modes", "--config", "{toml}", "--rpm", "60:120:2"), "one disc speed"),
        (("report", "--config", "{toml}", "--recording", "x.wav"), "--recording applies to the paper's model"),
        (("simulate", "--config", "{toml}"), "work with stability, critical, modes, tolerance, report, design only"),
    ],
)
def test_cli_fe_bad_input(run, brake_toml, args, message):
    r = run(*[a.format(toml=brake_toml) for a in args])
    assert r.exit_code == 2
    assert "Traceback" not in r.output
    if message is not None:
        assert message in r.stderr and len(r.stderr.strip().splitlines()) == 1


def test_unstable_mode_shapes_to_vtk(tmp_path):
    meshio = pytest.importorskip("meshio")
    pts = np.array([[0.0, 0, 0], [1.0, 0, 0]])
    mesh = meshio.Mesh(pts, [("line", np.array([[0, 1]]))])
    # 6 DOFs = 2 points x (ux, uy, uz); x-motion of point 0 and y-motion of point 1 coupled by friction
    K1 = np.diag([1.2, 5.0, 5.0, 5.0, 1.0, 5.0])
    KR = np.zeros((6, 6))
    KR[0, 4], KR[4, 0] = 1.0, -1.0
    fe = FEModel.from_matrices(M=np.eye(6), K1=K1, KR=KR, mesh=mesh)
    ds = fe_modes(fe, 60.0, 0.5, unstable_only=True)
    assert ds.sizes["mode"] == 1
    from squealkit.stability.fe_sweep import modes_to_vtk

    modes_to_vtk(ds, fe, tmp_path / "m.vtu")
    back = meshio.read(tmp_path / "m.vtu")
    shape = back.point_data["mode0_re"] + 1j * back.point_data["mode0_im"]
    assert shape.shape == (2, 3)
    np.testing.assert_allclose(np.abs(shape).max(), 1.0)
    assert np.abs(shape[0, 0]) > 0.5 and np.abs(shape[1, 1]) > 0.5 and np.abs(shape[0, 1]) < 1e-12


@pytest.fixture()
def reduction_calls(monkeypatch):
    """The arguments squealkit.solvers.reduction's basis builders are called with."""
    from squealkit.solvers import reduction

    calls = {}
    modal, pod = reduction.modal_basis, reduction.pod_basis

    def modal_basis(model, **kw):
        calls["modal"] = (kw.get("freq_max"), kw.get("n_modes"))
        return modal(model, **kw)

    def pod_basis(model, omegas, mus, **kw):
        calls["pod"] = (np.asarray(omegas), np.asarray(mus), kw.get("band"))
        return pod(model, omegas, mus, **kw)

    monkeypatch.setattr(reduction, "modal_basis", modal_basis)
    monkeypatch.setattr(reduction, "pod_basis", pod_basis)
    return calls


def test_reduced_methods_plumbing(reduction_calls):
    n = 8
    rng = np.random.default_rng(3)
    K1 = np.diag(np.linspace(1.0, 3.0, n) * 1e6)
    KR = 2e5 * rng.normal(size=(n, n))
    fe = FEModel.from_matrices(M=np.eye(n), K1=K1, KR=KR, D1=1e-2 * np.eye(n))
    rpm, mu = [60.0, 120.0], [0.2, 0.5]
    band = (1.0, 1e4)  # every mode of this model (159-276 Hz); reduced methods default to 1-16 kHz
    dense = fe_stability_map(fe, rpm, mu)
    full = fe_stability_map(fe, rpm, mu, method="modal", band=band)  # the complete modal basis: exact
    np.testing.assert_allclose(np.sort(full.growth_rate.values, -1), np.sort(dense.growth_rate.values, -1),
                               rtol=1e-8, atol=1e-6)
    assert full.attrs["basis_size"] == n and bool(full.trusted.all())
    cut = fe_stability_map(fe, rpm, mu, method="modal", n_modes=4, band=band)  # truncated: residuals flag it
    assert cut.attrs["basis_size"] == 4 and not bool(cut.trusted.all())
    assert reduction_calls["modal"] == (None, 4)
    pod = fe_stability_map(fe, rpm, mu, theta=math.radians(2.0), method="pod", n_modes=n, band=band)
    np.testing.assert_allclose(reduction_calls["pod"][0], [2 * math.pi * 120.0 / 60])  # the middle speed
    np.testing.assert_allclose(reduction_calls["pod"][1], np.array(mu) + math.tan(math.radians(2.0)))
    assert pod.attrs["basis_size"] == n and float(np.nanmax(pod.residual.values)) < 1e-10
    # the critical-friction search samples the middle speed only (not every speed of the grid),
    # at three frictions over its range; its onsets are the dense solve's
    crit = fe_critical_friction(fe, [60.0, 120.0, 240.0], mu_max=1.0, method="pod", band=band)
    np.testing.assert_allclose(reduction_calls["pod"][0], [2 * math.pi * 120.0 / 60])
    np.testing.assert_allclose(reduction_calls["pod"][1], [0.0, 0.5, 1.0])
    np.testing.assert_allclose(crit.mu_critical, fe_critical_friction(fe, [60.0, 120.0, 240.0], mu_max=1.0).mu_critical,
                               rtol=1e-6)


def test_sweep_on_dask_is_identical_to_local(brake):
    distributed = pytest.importorskip("distributed")
    # a sparse band sweep in which modes enter the band inside rows (new indices) and a dense one
    n = 40
    w = 2 * np.pi * np.linspace(500, 9000, n)
    KR = sp.lil_matrix((n, n))
    KR[10, 11], KR[11, 10] = 0.3 * w[10] ** 2, -0.3 * w[10] ** 2
    KR[12, 12] = -0.5 * w[12] ** 2  # mode 12 falls into the band as friction grows
    fe = FEModel.from_matrices(M=sp.eye(n), K1=sp.diags(w**2), KR=KR.tocsr(), D1=sp.diags(1e-4 * w))
    cases = [(fe, {"method": "sparse", "band": (1500.0, 3000.0)}), (brake, {})]
    with distributed.Client(processes=False, n_workers=2, threads_per_worker=1, dashboard_address=None) as client:
        for model, kw in cases:
            rpm, mu = [60.0, 120.0, 180.0], np.linspace(0.0, 1.0, 5)
            local = fe_stability_map(model, rpm, mu, **kw)
            remote = fe_stability_map(model, rpm, mu, client=client, **kw)
            xr_equal = local.identical(remote)
            assert xr_equal, (local, remote)
    assert local.sizes["mode"] == brake.n_dof

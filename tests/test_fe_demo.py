"""The built-in FE disc brake: disc doublets, convergence, matrix structure, squeal, export."""

import math
import tomllib

import numpy as np
import pytest
import scipy.io
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from squealkit import InputError
from squealkit.fe.demo import FEDemoGeometry, build_fe_demo, fe_demo_dofs, write_fe_demo

pytest.importorskip("skfem")


def lowest_freqs(model, k):
    """Lowest k natural frequencies [Hz] of (M, K1) by shift-invert Lanczos."""
    w = spla.eigsh(model["K1"], k=k, M=model["M"], sigma=0.0, which="LM", return_eigenvectors=False)
    return np.sort(np.sqrt(w)) / (2 * math.pi)


@pytest.fixture(scope="module")
def brake():
    return build_fe_demo(n_theta=16, n_r=2)


def test_disc_alone_has_exact_doublets():
    # 16 equal sectors: a mode with n nodal diameters, 0 < n < 8, is a degenerate pair
    # (cyclic symmetry), so the pairs agree to rounding; 0-nodal-diameter modes are single.
    disc = build_fe_demo(n_theta=16, n_r=2, pads=False)
    f = lowest_freqs(disc, 16)
    rel = np.diff(f) / f[1:]
    pairs = np.flatnonzero(rel < 1e-6)
    assert len(pairs) >= 6
    assert np.all(rel[pairs] < 1e-8)
    # pairs are disjoint: no triple
    assert np.all(np.diff(pairs) > 1)
    # the lowest mode (0 nodal diameters, umbrella) is single
    assert rel[0] > 1e-3


def test_disc_frequencies_converge_with_refinement():
    # The changes shrink with each refinement (the polygonal edge of a coarse mesh makes the
    # discretisation error non-monotone, so no Rayleigh-Ritz bound is claimed), and the
    # order of magnitude agrees with thin-plate theory: the umbrella (0 nodal diameter) mode
    # of a 15 mm cast-iron annulus clamped at 80 mm, free at 140 mm, is near 2.6 kHz
    # (Kirchhoff: lambda^2 = omega a^2 sqrt(rho h / D) = 17.2 at b/a = 0.57).
    coarse, mid, fine = (
        lowest_freqs(build_fe_demo(n_theta=nt, n_r=nt // 8, pads=False), 8) for nt in (16, 24, 32)
    )
    change_1, change_2 = np.max(np.abs(coarse - mid) / mid), np.max(np.abs(mid - fine) / fine)
    assert change_2 < 0.6 * change_1
    assert change_2 < 0.02
    assert 2400 < fine[0] < 2800


def test_matrix_structure(brake):
    M, K1, KR, DG, KGeo = (brake[k] for k in ("M", "K1", "KR", "DG", "KGeo"))
    n = M.shape[0]
    assert brake["n_dofs"] == n == len(brake["dof_names"])
    for A in (M, K1, KGeo, brake["D1"]):
        assert abs(A - A.T).max() == 0
    assert abs(DG + DG.T).max() == 0 and abs(DG).max() > 0
    # M, K1 positive definite: Cholesky of the dense matrices
    np.linalg.cholesky(M.toarray())
    np.linalg.cholesky(K1.toarray())
    # friction: non-symmetric, rows in the sliding plane (x, y), columns normal (z)
    comp = brake["dof_component"]
    KRc = KR.tocoo()
    assert abs(KR - KR.T).max() > 0.5 * abs(KR).max()
    assert set(comp[KRc.row]) == {0, 1} and set(comp[KRc.col]) == {2}
    # action = reaction: the friction forces of any motion sum to zero in x and in y
    for c in (0, 1):
        assert np.abs(np.asarray(KR[comp == c].sum(axis=0))).max() < 1e-9 * abs(KR).max()
    # a common normal motion of disc and pads (rigid heave) changes no normal force
    heave = (comp == 2).astype(float)
    assert np.abs(KR @ heave).max() < 1e-9 * abs(KR).max()
    assert brake["disc_speed_ref"] > 0 and brake["mu_ref"] == 0.4 and brake["f_ref"] == 1.0


def test_geometric_stiffness_is_signed():
    # KGeo = centrifugal stiffening (positive) + convective softening (negative); on the
    # disc's lowest (umbrella) mode the stiffening wins (a spinning disc stiffens).
    disc = build_fe_demo(n_theta=16, n_r=2, pads=False)
    _, V = spla.eigsh(disc["K1"], k=1, M=disc["M"], sigma=0.0, which="LM")
    assert (V[:, 0] @ (disc["KGeo"] @ V[:, 0])) > 0


@pytest.mark.slow
def test_friction_makes_mode_coupling_squeal_in_band(brake):
    # the band solver itself is checked against scipy's shift-invert in test_reduction.py
    from squealkit.solvers.band import band_eigs
    from squealkit.solvers.reduction import as_fe_model

    # on this coarse mesh (1566 unknowns) the pair near 11.4 kHz locks in below mu = 0.3
    omega = 2 * math.pi * 600 / 60  # 600 rpm
    band = (10e3, 12.5e3)
    model = as_fe_model(brake)
    stable = band_eigs(model, omega, 0.0, band=band).eigenvalues
    assert stable.size >= 3 and np.all(stable.real < 0)
    lam = band_eigs(model, omega, 0.3, band=band).eigenvalues
    unstable = lam[lam.real > 0]
    assert unstable.size >= 1
    assert np.all((unstable.imag / (2 * math.pi) > 11e3) & (unstable.imag / (2 * math.pi) < 12e3))


def test_dof_count_spans_1e3_to_1e5():
    assert 1e3 < fe_demo_dofs(16, 2) < 3e3
    assert fe_demo_dofs(176, 15) > 9e4


def test_bad_input_is_rejected():
    with pytest.raises(InputError, match="n_theta=15"):
        build_fe_demo(n_theta=15)
    with pytest.raises(InputError, match="pad_r_inner"):
        build_fe_demo(n_theta=16, geometry=FEDemoGeometry(pad_r_inner=0.2))


def test_write_fe_demo_round_trip(brake, tmp_path):
    toml_path = write_fe_demo(brake, tmp_path / "brake")
    cfg = tomllib.loads(toml_path.read_text())
    assert cfg["model"] == "fe"
    assert cfg["fe"]["mu_ref"] == brake["mu_ref"] and cfg["fe"]["disc_speed_ref"] == brake["disc_speed_ref"]
    assert set(cfg["fe"]["files"]) == {"M", "D1", "DG", "K1", "KR", "KGeo"}
    for name, file in cfg["fe"]["files"].items():
        A = scipy.io.mmread(toml_path.parent / file)
        assert abs(sp.csr_matrix(A) - brake[name]).max() <= 1e-15 * abs(brake[name]).max()
    assert (toml_path.parent / "mesh.vtu").is_file()


def test_cli_fe_demo_writes_a_model_folder(run, tmp_path):
    import json

    r = run("fe-demo", "--size", "16", "--out-dir", str(tmp_path / "brake"), "--json")
    assert r.exit_code == 0, r.output
    info = json.loads(r.output)
    assert info["n_dofs"] > 1000 and "brake.toml" in info["files"] and "KR.mtx" in info["files"]
    r = run("fe-demo", "--size", "15", "--out-dir", str(tmp_path / "b2"))
    assert r.exit_code == 2


@pytest.mark.slow
def test_reduced_maps_of_the_built_in_brake_agree_with_the_band_solve_or_say_they_cannot(brake):
    # the POD basis (built for the squeal band) gives the band solve's numbers; a modal basis
    # too small for the coupled modes fails the residual check, and those points are
    # indeterminate, never a made-up flutter from eigenpairs that are not the brake's
    from squealkit.fe.demo import FE_MATRIX_NAMES
    from squealkit.models import FEModel
    from squealkit.stability import stability_map

    model = FEModel.from_matrices(**{k: brake[k] for k in FE_MATRIX_NAMES if brake[k] is not None},
                                  disc_speed_ref=brake["disc_speed_ref"], mu_ref=brake["mu_ref"], f_ref=brake["f_ref"])
    mu = np.array([0.0, 0.3])
    full = stability_map(model, mu, rpm=[600.0], method="sparse")
    pod = stability_map(model, mu, rpm=[600.0], method="pod")
    np.testing.assert_allclose(pod.max_growth_rate, full.max_growth_rate, rtol=1e-6)
    np.testing.assert_array_equal(pod.verdict, full.verdict)
    modal = stability_map(model, mu, rpm=[600.0], method="modal", n_modes=12)
    untrusted = ~modal.trusted.fillna(True).astype(bool)
    assert untrusted.any()
    assert not modal.any_unstable.values[untrusted.any("mode").values].any()

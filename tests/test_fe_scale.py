"""Scale of the FE path (issue #25, items 4-5): the PARDISO LU backend, the subspace projection,
the memory estimate and the shared basis of Dask sweeps. Small models only."""

from __future__ import annotations

import importlib.util
import math

import numpy as np
import pytest
import scipy.sparse as sp

from squealkit._validation import InputError
from squealkit.fe import FEModel
from squealkit.solvers import lu

HAS_PARDISO = importlib.util.find_spec("pypardiso") is not None
needs_pardiso = pytest.mark.skipif(not HAS_PARDISO, reason="pypardiso (squealkit[fast]) is not installed")

DISC_SPEED = 2 * math.pi * 600 / 60  # 600 rpm
MU = 0.45


@pytest.fixture(scope="module")
def brake():
    """The built-in brake at its coarsest (n_theta=16, n_r=2: 1 422 DOFs), a few seconds to build."""
    pytest.importorskip("skfem")
    from squealkit.fe.demo import build_fe_demo

    d = build_fe_demo(n_theta=16, n_r=2)
    names = ("M", "D1", "DG", "DR", "D4", "K1", "KR", "KGeo")
    return FEModel.from_matrices(**{k: d[k] for k in names if d[k] is not None},
                                 disc_speed_ref=d["disc_speed_ref"], mu_ref=d["mu_ref"], f_ref=d["f_ref"])


# -- the PARDISO backend ------------------------------------------------------------------------------


@needs_pardiso
@pytest.mark.parametrize("kind", ["real", "complex", "real symmetric", "complex symmetric"])
def test_pardiso_solves_as_superlu_does(kind):
    # reference: SuperLU in the METIS order, the default backend (an independent factorisation)
    rng = np.random.default_rng(3)
    n = 200
    A = sp.random(n, n, density=0.03, random_state=4, format="csr") + 4 * sp.eye(n)
    if "complex" in kind:
        A = A + 1j * sp.random(n, n, density=0.02, random_state=5)
    if "symmetric" in kind:
        A = A + A.T
    A = sp.csr_matrix(A)
    f = lu.factorize(A, lu="pardiso")
    assert f.mtype == {"real": 11, "complex": 13, "real symmetric": -2, "complex symmetric": 6}[kind]
    ref = lu.factorize(A, lu="superlu")
    B = rng.standard_normal((n, 3)) + (1j * rng.standard_normal((n, 3)) if "complex" in kind else 0)
    np.testing.assert_allclose(f.solve(B), ref.solve(B), rtol=0, atol=1e-12 * np.abs(ref.solve(B)).max())
    np.testing.assert_allclose(f.solve(B[:, 0]), ref.solve(B[:, 0]), rtol=0, atol=1e-12 * np.abs(ref.solve(B)).max())
    if kind == "real":  # a real factor solves a complex right-hand side by parts
        Z = B + 1j * B[:, ::-1]
        np.testing.assert_allclose(f.solve(Z), ref.solve(B) + 1j * ref.solve(B[:, ::-1]), atol=1e-12 * np.abs(Z).max())


@needs_pardiso
def test_pardiso_singular_matrix_is_a_runtime_error():
    for P in ([[1.0, 2.0], [2.0, 4.0]], [[1.0, 2.0], [3.0, 6.0]]):
        with pytest.raises(RuntimeError, match="singular"):
            lu.factorize(sp.csr_matrix(np.array(P)), lu="pardiso")


@needs_pardiso
def test_band_solve_with_pardiso_gives_superlu_eigenvalues(brake):
    from squealkit.solvers.band import band_eigs

    kw = dict(band=(1000.0, 6000.0), workers=1)
    ref = band_eigs(brake, DISC_SPEED, MU, lu="superlu", **kw)
    got = band_eigs(brake, DISC_SPEED, MU, lu="pardiso", **kw)
    assert ref.eigenvalues.size == got.eigenvalues.size > 5
    np.testing.assert_allclose(got.eigenvalues, ref.eigenvalues, rtol=1e-10, atol=0)
    assert got.residuals.max() < 1e-10


@needs_pardiso
def test_modal_basis_with_pardiso_gives_superlu_frequencies(brake):
    from squealkit.solvers.reduction import modal_basis

    _, f_ref = modal_basis(brake, freq_max=8000.0, return_freq=True, lu="superlu")
    _, f_got = modal_basis(brake, freq_max=8000.0, return_freq=True, lu="pardiso")
    assert f_ref.size > 5
    np.testing.assert_allclose(f_got, f_ref, rtol=1e-10)


def test_auto_rule_and_forcing_by_environment(monkeypatch):
    # auto: SuperLU for complex and for small matrices whatever is installed
    small = sp.csr_matrix(sp.eye(10) * 2.0)
    assert isinstance(lu.factorize(small, lu="auto"), lu.PermutedLU)
    assert isinstance(lu.factorize(small * (1 + 1j), lu="auto"), lu.PermutedLU)
    nb = lu.PARDISO_MIN_DOF
    big = sp.diags(np.full(nb, 2.0)) + sp.eye(nb, k=1) + sp.eye(nb, k=-1)
    expect = lu.PardisoLU if HAS_PARDISO else lu.PermutedLU
    assert isinstance(lu.factorize(big.tocsr(), lu="auto"), expect)
    monkeypatch.setenv("SQUEALKIT_LU", "dense")
    assert lu.lu_backend() == "dense"
    assert isinstance(lu.factorize(small), lu.DenseLU)
    with lu.use_lu_backend("superlu"):
        assert lu.lu_backend() == "superlu"
    assert lu.lu_backend() == "dense"  # the environment's again
    monkeypatch.setenv("SQUEALKIT_LU", "mumps")
    with pytest.raises(InputError, match=r"SQUEALKIT_LU='mumps' is not an LU backend; known: superlu"):
        lu.factorize(small)

"""The built-in LU backends share one solve: vectors and blocks, real and complex, in any pairing of the
factor's and the right-hand side's type, with the same shapes and types out (issue #28: solvers apart,
one plumbing). The reference is LAPACK's dense solve (numpy.linalg.solve) of the same system."""

import importlib.util

import numpy as np
import pytest
import scipy.sparse as sp

from squealkit.solvers import lu

BACKENDS = ["superlu", "dense"] + (["pardiso"] if importlib.util.find_spec("pypardiso") else [])


def _matrix(kind, n=40, seed=2):
    """A sparse, structurally symmetric, well-conditioned matrix: real symmetric, real unsymmetric or complex."""
    rng = np.random.default_rng(seed)
    A = sp.random(n, n, density=0.1, random_state=np.random.RandomState(seed))
    A = A + A.T + sp.diags(n + rng.random(n))
    if kind == "unsymmetric":
        A = A + sp.triu(A, 1) * 0.3
    if kind == "complex":
        A = A + 1j * sp.diags(rng.random(n))
    return sp.csr_matrix(A)


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("kind", ["symmetric", "unsymmetric", "complex"])
@pytest.mark.parametrize("rhs", ["real", "complex", "float32"])
@pytest.mark.parametrize("shape", [(), (3,)])
def test_every_backend_solves_every_right_hand_side(backend, kind, rhs, shape):
    A = _matrix(kind)
    n = A.shape[0]
    rng = np.random.default_rng(7)
    b = rng.standard_normal((n, *shape))
    if rhs == "complex":
        b = b + 1j * rng.standard_normal((n, *shape))   # was a TypeError from SuperLU with a real factor
    elif rhs == "float32":
        b = b.astype(np.float32)
    f = lu.factorize(A, lu=backend)
    x = f.solve(b)
    ref = np.linalg.solve(A.toarray(), b.astype(np.result_type(b, A.dtype, np.float64)))
    assert x.shape == b.shape
    assert x.dtype == np.result_type(A.dtype, b.dtype, np.float64)
    assert np.max(np.abs(x - ref)) <= 1e-12 * np.max(np.abs(ref))


@pytest.mark.parametrize("backend", BACKENDS)
def test_every_backend_refuses_a_right_hand_side_of_another_size(backend):
    # the shared solve checks the rows (SuperLU indexed with the permutation, PARDISO reshaped: each failed
    # its own way, or not at all for a (39, 40) block)
    f = lu.factorize(_matrix("symmetric"), lu=backend)
    assert f.n == 40 and f.dtype == np.float64
    for b in (np.ones(39), np.ones((39, 40)), np.ones((40, 2, 2))):
        with pytest.raises(ValueError, match=r"right-hand side of shape \(39|right-hand side of shape \(40, 2, 2"):
            f.solve(b)

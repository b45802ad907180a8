"""Industrial FE matrix formats with node/DOF labels, their DOF map and meshes: known-answer round trips.

References: every format route must give the eigenvalues of the Matrix Market route of the same
matrices (the labelled route only renumbers the DOFs, a permutation similarity, so the spectra
agree to rounding: 1e-10 relative). The files are written by the independent writers of
``_fe_format_writers.py`` from each format's documentation. The hand-made model's spectrum comes
from LAPACK (``scipy.linalg.eigvals`` of the companion form); the demo brake's eigenvalues near
5 kHz from ARPACK shift-invert on each route.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.io
import scipy.linalg as sl
import scipy.sparse as sp
import scipy.sparse.linalg as spla

import _fe_format_writers as wr
from squealkit._validation import InputError
from squealkit.fe.dofmap import DofMap
from squealkit.models.config import load_model
from squealkit.models.fe_readers import load_fe_model

OMEGA, MU = 10.0, 0.4
SYM = ("M", "D1", "K1", "KGeo")
NAMES = ("M", "D1", "DG", "K1", "KR", "KGeo")


# ----------------------------------------------------------------------------- models


def _round9(A):
    """Entries rounded to 10 significant digits: what a 16-character large field holds exactly."""
    A = sp.coo_matrix(A)
    return sp.coo_matrix((np.array([float(f"{x:.9E}") for x in A.data]), (A.row, A.col)), shape=A.shape).tocsr()


@pytest.fixture(scope="module")
def hand():
    """A 13-DOF model of four nodes (labels 101, 7, 55, 3000, not in order) and an internal node -1.

    DG lives on nodes 101 and 7 only, KR on 55 and 3000 only, KGeo on 3000 only, the internal
    DOF in M and K1 only: label sets differ from file to file.
    """
    rng = np.random.default_rng(25)
    node = np.array([101] * 3 + [7] * 3 + [55] * 3 + [3000] * 3 + [-1])
    dof = np.array([1, 2, 3] * 4 + [1])
    n = node.size
    R = rng.standard_normal((n, n))
    M = np.diag(rng.uniform(1.0, 2.0, n)) + 0.05 * (R + R.T) * (np.abs(R + R.T) > 1.5)
    B = rng.standard_normal((n, n))
    K1 = 1e6 * (B @ B.T + n * np.eye(n))
    DG = np.zeros((n, n))
    S = rng.standard_normal((6, 6))
    DG[:6, :6] = 30.0 * (S - S.T)
    KR = np.zeros((n, n))
    KR[6:12, 6:12] = 2e5 * rng.standard_normal((6, 6))
    KGeo = np.zeros((n, n))
    KGeo[9:12, 9:12] = np.diag([5e3, 5e3, 1e3])
    mats = {"M": M, "D1": 0.5 * M + 1e-5 * K1, "DG": DG, "K1": K1, "KR": KR, "KGeo": KGeo}
    mats = {k: _round9(v) for k, v in mats.items()}
    for k in SYM:  # exactly symmetric after rounding
        mats[k] = _round9(sp.triu(mats[k]) + sp.triu(mats[k], 1).T)
    return {"mats": mats, "node": node, "dof": dof}


@pytest.fixture(scope="module")
def demo():
    from squealkit.models.fe_demo import build_fe_demo

    return build_fe_demo(n_theta=8, n_r=2)  # 738 DOFs


@pytest.fixture(scope="module")
def demo_mm(demo, tmp_path_factory):
    """The demo brake by the Matrix Market route (``fe-demo``'s files and TOML): the reference."""
    from squealkit.models.fe_demo import write_fe_demo

    toml = write_fe_demo(demo, tmp_path_factory.mktemp("mm") / "brake")
    return load_model(toml), toml.parent


def _demo_labels(demo):
    """Node labels permuted (so the DOF map's order is not the Matrix Market order): (node, dof) per DOF."""
    perm = np.random.default_rng(3).permutation(len(demo["node_points"])) + 1
    return perm[demo["dof_node"]], demo["dof_component"] + 1, perm


def _write_mm(folder: Path, mats) -> dict:
    folder.mkdir(exist_ok=True)
    for k, A in mats.items():
        scipy.io.mmwrite(folder / f"{k}.mtx", sp.coo_matrix(A), precision=17)
    return {k: str(folder / f"{k}.mtx") for k in mats}


def _write_format(fmt: str, folder: Path, mats, node, dof) -> dict:
    """Files of the matrices in one format; returns load_fe_model's keyword arguments."""
    folder.mkdir(exist_ok=True)
    rng = np.random.default_rng(7)
    if fmt == "abaqus":  # one file per matrix, lines in a random order
        return {"files": {k: str(wr.abaqus_matrix_input(folder / f"brake_{k}.mtx", A, node, dof, symmetric=k in SYM,
                                                        order=rng.permutation)) for k, A in mats.items()}}
    if fmt == "abaqus-coordinate":
        return {"files": {k: str(wr.abaqus_coordinate(folder / f"{k}.mtx", A, symmetric=k in SYM))
                          for k, A in mats.items()}}
    if fmt in ("dmig", "dmig-punch"):
        style, bulk, suffix = ("free", True, ".bdf") if fmt == "dmig" else ("large", False, ".pch")
        path = wr.dmig(folder / f"brake{suffix}", {k.upper(): (A, k in SYM) for k, A in mats.items()}, node, dof,
                       style=style, bulk=bulk)
        return {"file": str(path)}
    if fmt == "hb":
        return {"files": {k: str(wr.harwell_boeing(folder / f"{k}.matrix", A, symmetric=k in SYM, node=node,
                                                    dof=dof)) for k, A in mats.items()}}
    raise AssertionError(fmt)


def _companion_eigs(model) -> np.ndarray:
    """All eigenvalues of lambda^2 M + lambda C + K at (OMEGA, MU): LAPACK on the companion form."""
    M = model.mass_matrix().toarray()
    C = model.damping_matrix(OMEGA, MU).toarray()
    K = model.stiffness_matrix(OMEGA, MU).toarray()
    n = M.shape[0]
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    return sl.eigvals(A)


def _eigs_near(model, sigma: complex, k: int = 4) -> np.ndarray:
    """The k eigenvalues nearest sigma, each refined by a shift-invert at itself (then it converges to rounding).

    ARPACK on ``(A - s B)^-1 B`` of the first-order form ``A = [[0, I], [-K, -C]]``, ``B = diag(I, M)``,
    applied through one n x n factorisation: ``u = -Q(s)^-1 (M b + (C + s M) a)``, ``v = a + s u``
    with ``Q(s) = s^2 M + s C + K``.
    """
    M, C, K = model.mass_matrix(), model.damping_matrix(OMEGA, MU), model.stiffness_matrix(OMEGA, MU)
    n = M.shape[0]
    v0 = np.ones(2 * n, dtype=complex)

    def near(shift: complex, count: int) -> np.ndarray:
        lu = spla.splu((shift * shift * M + shift * C + K).tocsc().astype(complex))
        CsM = (C + shift * M).tocsr()

        def apply(z):
            a, b = z[:n], z[n:]
            u = -lu.solve(M @ b + CsM @ a)
            return np.concatenate([u, a + shift * u])

        op = spla.LinearOperator((2 * n, 2 * n), matvec=apply, dtype=complex)
        return shift + 1.0 / spla.eigs(op, k=count, which="LM", v0=v0, return_eigenvectors=False)

    return np.array([near(lam * (1 + 1e-7), 1)[0] for lam in near(sigma, k)])


def _assert_same_spectrum(got: np.ndarray, ref: np.ndarray, rtol: float = 1e-10) -> None:
    assert got.size == ref.size
    for lam in ref:
        assert np.min(np.abs(got - lam)) <= rtol * abs(lam), (lam, got[np.argmin(np.abs(got - lam))])


# ----------------------------------------------------------------------------- the DOF map


def test_dof_map_orders_labels_and_names_them():
    dm = DofMap.from_labels([3000, 7, 7, -2, 55, 7], [1, 3, 1, 1, 2, 3])
    assert list(zip(dm.node.tolist(), dm.dof.tolist(), strict=True)) == [(7, 1), (7, 3), (55, 2), (3000, 1), (-2, 1)]
    assert dm.index([-2, 55], [1, 2]).tolist() == [4, 2]
    assert dm.names[:2] == ("n7.u1", "n7.u3")
    with pytest.raises(InputError, match="node 8 DOF 1 is not in"):
        dm.index([8], [1])
    with pytest.raises(InputError, match="appears twice"):
        DofMap([1, 1], [2, 2])


# ----------------------------------------------------------------------------- known answers


@pytest.mark.parametrize("fmt", ["abaqus", "abaqus-coordinate", "dmig", "dmig-punch", "hb"])
def test_hand_model_in_each_format_has_the_matrix_market_spectrum(hand, tmp_path, fmt):
    mats, node, dof = hand["mats"], hand["node"], hand["dof"]
    ref_model = load_fe_model(files=_write_mm(tmp_path / "mm", mats), omega_ref=OMEGA, mu_ref=MU)
    model = load_fe_model(**_write_format(fmt, tmp_path / fmt, mats, node, dof), omega_ref=OMEGA, mu_ref=MU)
    assert model.n_dof == 13 and model.dof_map is not None
    if fmt != "abaqus-coordinate":  # labelled: the map holds the file's labels, positive ones first
        assert model.dof_map.node.tolist() == [7] * 3 + [55] * 3 + [101] * 3 + [3000] * 3 + [-1]
        assert model.dof_names[0] == "n7.u1" and model.dof_names[-1] == "n-1.u1"
        # the same matrix up to the renumbering: entry (101 u2, 7 u1) of K1
        i, j = model.dof_map.index([101, 7], [2, 1])
        assert model.K1[i, j] == mats["K1"][1, 3]
    _assert_same_spectrum(_companion_eigs(model), _companion_eigs(ref_model))


@pytest.mark.parametrize("fmt", ["abaqus", "dmig", "hb"])
def test_demo_brake_in_each_format_has_the_matrix_market_spectrum(demo, demo_mm, tmp_path, fmt):
    ref_model = demo_mm[0]
    node, dof, _ = _demo_labels(demo)
    mats = {k: demo[k] for k in NAMES}
    model = load_fe_model(**_write_format(fmt, tmp_path / fmt, mats, node, dof), omega_ref=demo["omega_ref"],
                          mu_ref=demo["mu_ref"])
    assert model.n_dof == ref_model.n_dof == 738
    # the same matrices, renumbered: the DOF map puts each (node, DOF) where the labels say
    P = model.dof_map.index(node, dof)
    assert not np.array_equal(P, np.arange(model.n_dof))
    for k in NAMES:
        assert abs(getattr(model, k)[P][:, P] - getattr(ref_model, k)).max() == 0.0
    sigma = 2j * np.pi * 5000.0
    _assert_same_spectrum(_eigs_near(model, sigma), _eigs_near(ref_model, sigma))

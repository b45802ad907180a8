"""Industrial FE matrix formats with node/DOF labels, their DOF map and meshes: known-answer round trips.

References: every format route must give the eigenvalues of the Matrix Market route of the same
matrices (the labelled route only renumbers the DOFs, a permutation similarity, so the spectra
agree to rounding: 1e-10 relative). The files are written by the independent writers of
``_fe_format_writers.py`` from each format's documentation. The hand-made model's spectrum comes
from LAPACK (``scipy.linalg.eigvals`` of the companion form); the demo brake's eigenvalues near
5 kHz from ARPACK shift-invert on each route.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import scipy.io
import scipy.linalg as sl
import scipy.sparse as sp
import scipy.sparse.linalg as spla

import _fe_format_writers as wr
from squealkit import InputError
from squealkit.fe.demo import demo_dof_map, demo_mesh
from squealkit.fe.dofmap import DofMap
from squealkit.fe.mesh import FEMesh, read_mesh, write_abaqus_inp
from squealkit.fe.readers import load_fe_model
from squealkit.models.config import load_model

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
    from squealkit.fe.demo import build_fe_demo

    return build_fe_demo(n_theta=8, n_r=2)  # 738 DOFs


@pytest.fixture(scope="module")
def demo_mm(demo, tmp_path_factory):
    """The demo brake by the Matrix Market route (``fe-demo``'s files and TOML): the reference."""
    from squealkit.fe.demo import write_fe_demo

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
    ref_model = load_fe_model(files=_write_mm(tmp_path / "mm", mats), disc_speed_ref=OMEGA, mu_ref=MU)
    model = load_fe_model(**_write_format(fmt, tmp_path / fmt, mats, node, dof), disc_speed_ref=OMEGA, mu_ref=MU)
    assert model.n_dof == 13 and model.dof_map is not None
    if fmt != "abaqus-coordinate":  # labelled: the map holds the file's labels, positive ones first
        assert model.dof_map.node.tolist() == [7] * 3 + [55] * 3 + [101] * 3 + [3000] * 3 + [-1]
        assert model.dof_names[0] == "n7.u1" and model.dof_names[-1] == "n-1.u1"
        # the same matrix up to the renumbering: entry (101 u2, 7 u1) of K1
        i, j = model.dof_map.index([101, 7], [2, 1])
        assert model.K1[i, j] == mats["K1"][1, 3]
    _assert_same_spectrum(_companion_eigs(model), _companion_eigs(ref_model))


@pytest.mark.slow
@pytest.mark.parametrize("fmt", ["abaqus", "dmig", "hb"])
def test_demo_brake_in_each_format_has_the_matrix_market_spectrum(demo, demo_mm, tmp_path, fmt):
    ref_model = demo_mm[0]
    node, dof, _ = _demo_labels(demo)
    mats = {k: demo[k] for k in NAMES}
    model = load_fe_model(**_write_format(fmt, tmp_path / fmt, mats, node, dof), disc_speed_ref=demo["disc_speed_ref"],
                          mu_ref=demo["mu_ref"])
    assert model.n_dof == ref_model.n_dof == 738
    # the same matrices, renumbered: the DOF map puts each (node, DOF) where the labels say
    P = model.dof_map.index(node, dof)
    assert not np.array_equal(P, np.arange(model.n_dof))
    for k in NAMES:
        assert abs(getattr(model, k)[P][:, P] - getattr(ref_model, k)).max() == 0.0
    sigma = 2j * np.pi * 5000.0
    _assert_same_spectrum(_eigs_near(model, sigma), _eigs_near(ref_model, sigma))


def test_ansys_full_file_reads_with_its_labels():
    # reference: ansys-mapdl-reader's own recipe (examples.solve_km): load_km(sort=True), mirror the
    # stored upper triangle; its lowest frequencies near 7 kHz must be ours, with DOFs labelled
    # (node, UX/UY/UZ) and the 63 constrained DOFs (no entries) left out
    fullmod = pytest.importorskip("ansys.mapdl.reader")
    from ansys.mapdl.reader import examples

    model = load_fe_model(files={"M": examples.fullfile, "K1": examples.fullfile}, names={"M": "M", "K1": "K"})
    _dof_ref, k, m = fullmod.read_binary(examples.fullfile).load_km(sort=True)
    k, m = k + sp.triu(k, 1).T, m + sp.triu(m, 1).T
    assert model.n_dof == 900 and set(model.dof_map.dof.tolist()) == {1, 2, 3}
    keep = np.asarray(abs(k).sum(axis=1)).ravel() > 0
    sigma = (2 * np.pi * 7000.0) ** 2
    ref = spla.eigsh(k[keep][:, keep].tocsc(), k=4, M=m[keep][:, keep].tocsc(), sigma=sigma,
                     return_eigenvectors=False)
    got = spla.eigsh(model.K1.tocsc(), k=4, M=model.M.tocsc(), sigma=sigma, return_eigenvectors=False)
    np.testing.assert_allclose(np.sort(got), np.sort(ref), rtol=1e-10)
    assert model.dof_names[0].startswith("n") and model.dof_names[0].endswith(".u1")


# ----------------------------------------------------------------------------- meshes


def test_abaqus_inp_mesh_with_labels_blocks_and_continuations(tmp_path):
    inp = tmp_path / "brake.inp"
    inp.write_text("""*HEADING
** two node blocks, labels not in order, a 20-node brick over two lines
*NODE, NSET=A
 20, 1.0, 0.0, 0.0
 10, 0.0, 0.0, 0.0
*NODE
 30, 0.0, 1.0, 0.0
 40, 0.0, 0.0, 1.0
*ELEMENT, TYPE=C3D4, ELSET=PAD
 1, 10, 20, 30, 40
*ELEMENT, TYPE=T3D2
 7, 10,
 40
*MATERIAL, NAME=STEEL
*DENSITY
 7850.,
""")
    mesh = read_mesh(inp)
    assert mesh.node_labels.tolist() == [20, 10, 30, 40]
    np.testing.assert_array_equal(mesh.points[1], [0.0, 0.0, 0.0])
    kinds = dict(mesh.cells)
    assert kinds["tetra"].tolist() == [[1, 0, 2, 3]] and kinds["line"].tolist() == [[1, 3]]
    dm = DofMap.from_labels([10, 10, 40, 40, -3], [1, 3, 2, 6, 1])
    dof, point, comp = mesh.dof_points(dm)  # rotations and the internal node have no place
    assert dof.tolist() == [0, 1, 2] and point.tolist() == [1, 1, 3] and comp.tolist() == [0, 2, 1]


def test_nastran_bdf_mesh_small_large_and_free_field(tmp_path):
    bdf = tmp_path / "brake.bdf"
    small = "".join(f"{x:>8}" for x in ("", 1, "", "0.", "0.", "0."))[8:]
    large = "".join(f"{x:>16}" for x in (3, "", "0.", "1."))
    bdf.write_text("SOL 103\nCEND\nBEGIN BULK\n$ small field\n"
                   f"GRID    {small}\n"
                   f"GRID    {small.replace('       1', '       2', 1).replace('0.', '1.', 1)}\n"
                   f"GRID*   {large}\n*       {'0.':>16}\n"
                   "GRID,4,,0.,0.,1.\n"
                   "CTETRA,9,1,1,2,3,4\n"
                   f"CBAR    {12:>8}{2:>8}{1:>8}{4:>8}{'0.':>8}{'0.':>8}{'1.':>8}\n"
                   "ENDDATA\n")
    mesh = read_mesh(bdf)
    assert mesh.node_labels.tolist() == [1, 2, 3, 4]
    np.testing.assert_array_equal(mesh.points[2], [0.0, 1.0, 0.0])
    kinds = dict(mesh.cells)
    assert kinds["tetra"].tolist() == [[0, 1, 2, 3]] and kinds["line"].tolist() == [[0, 3]]


def test_ansys_cdb_mesh():
    pytest.importorskip("ansys.mapdl.reader")
    from ansys.mapdl.reader import examples

    mesh = read_mesh(examples.hexarchivefile)
    assert mesh.n_points == len(set(mesh.node_labels.tolist())) > 0
    assert any(k.startswith("hexahedron") for k, _ in mesh.cells)


def test_demo_mesh_written_as_inp_carries_the_dof_map(demo, tmp_path):
    mesh = demo_mesh(demo)
    dm = demo_dof_map(demo)
    back = read_mesh(write_abaqus_inp(mesh, tmp_path / "demo.inp"))
    np.testing.assert_array_equal(back.points, mesh.points)
    dof, point, _comp = back.dof_points(dm)
    assert dof.size == dm.n_dof  # every demo DOF is a displacement of a node of its mesh
    np.testing.assert_array_equal(point, demo["dof_node"])



def test_fe_demo_writes_its_mesh_as_an_inp_deck(demo, demo_mm):
    # write_fe_demo (fe-demo) writes brake.inp beside the matrices: the reference is demo_mesh,
    # every scalar node a point labelled k + 1, read back through the .inp reader
    _, folder = demo_mm
    back = read_mesh(folder / "brake.inp")
    mesh = demo_mesh(demo)
    np.testing.assert_array_equal(back.node_labels, np.arange(1, len(demo["node_points"]) + 1))
    np.testing.assert_array_equal(back.points, mesh.points)
    assert [(k, c.tolist()) for k, c in back.cells] == [(k, c.tolist()) for k, c in mesh.cells]


# ----------------------------------------------------------------------------- the CLI on Abaqus matrices + .inp


@pytest.fixture(scope="module")
def abaqus_brake(demo, tmp_path_factory):
    """The demo brake as Abaqus would export it: *MATRIX OUTPUT files, its .inp deck and a TOML naming them."""
    folder = tmp_path_factory.mktemp("abaqus")
    node, dof, perm = _demo_labels(demo)
    files = _write_format("abaqus", folder, {k: demo[k] for k in NAMES}, node, dof)["files"]
    mesh = demo_mesh(demo)
    write_abaqus_inp(FEMesh(mesh.points, perm, mesh.cells), folder / "brake.inp")
    table = ", ".join(f'{k} = "{Path(v).name}"' for k, v in files.items())
    toml = folder / "brake.toml"
    toml.write_text(f'model = "fe"\n\n[fe]\nfiles = {{ {table} }}\ndisc_speed_ref = {demo["disc_speed_ref"]!r}\n'
                    f'mu_ref = {demo["mu_ref"]!r}\nmesh = "brake.inp"\n')
    return toml


def test_modes_and_stability_on_abaqus_matrices_with_an_inp(run, abaqus_brake, demo_mm, tmp_path):
    meshio = pytest.importorskip("meshio")
    vtu = tmp_path / "modes.vtu"
    args = ("--rpm", "1000", "--mu", "0.5", "--method", "sparse", "--band", "9000:13000")
    r = run("modes", "--config", str(abaqus_brake), *args, "--vtk", str(vtu), "--json")
    assert r.exit_code == 0, (r.output, r.exception)
    got = json.loads(r.stdout)
    ref = json.loads(run("modes", "--config", str(demo_mm[1] / "brake.toml"), *args, "--json").stdout)
    # the same modes as the Matrix Market route (to the sparse solver's own accuracy)
    np.testing.assert_allclose(sorted(m["frequency_hz"] for m in got["modes"]),
                               sorted(m["frequency_hz"] for m in ref["modes"]), rtol=1e-8)
    unstable = [m for m in got["modes"] if m["unstable"]]
    assert unstable, got["modes"]
    shapes = meshio.read(vtu)
    keys = [k for k in shapes.point_data if k.endswith("_re")]
    assert len(keys) == len(unstable)
    # the clamped nodes (on the inner radius) carry no DOF: at rest; the others move
    v = np.linalg.norm(shapes.point_data[keys[0]], axis=1)
    labels = shapes.point_data["node_label"]
    inner = np.hypot(shapes.points[:, 0], shapes.points[:, 1]) <= np.hypot(*shapes.points[:, :2].T).min() + 1e-12
    assert np.all(v[inner] == 0.0) and v.max() > 0.0 and labels.size == shapes.points.shape[0]
    r = run("stability", "--config", str(abaqus_brake), "--rpm", "1000", "--method", "sparse", "--band",
            "9000:13000", "--json")
    assert r.exit_code == 0, (r.output, r.exception)
    # the report of the same files (issue #25: modes, stability and report on Abaqus matrices + an .inp):
    # every unstable mode of the case drawn on the .inp's mesh
    toml = abaqus_brake.parent / "brake_report.toml"
    toml.write_text(abaqus_brake.read_text() + '\n[report]\nrpm = 1000\nmu = 0.5\neigen_band = [9000, 13000]\n'
                    'method = "sparse"\nmax_views = 1\nn_frames = 4\n')
    r = run("report", "--config", str(toml), "--out-dir", str(tmp_path / "rep"), "--quick", "--json")
    assert r.exit_code == 0, (r.output, r.exception)
    assert int(json.loads(r.stdout)["numbers"]["fe_modes"]["unstable"]) == len(unstable)
    html = (tmp_path / "rep" / "report.html").read_text()
    assert html.count("Mesh3d") >= 1 or html.count('"type":"mesh3d"') >= 1


# ----------------------------------------------------------------------------- malformed files: one line, exit 2

MALFORMED = {
    "abaqus.mtx": ("1,1, 1,1, 2.0\n1,1, 2,x, 3.0\n1,2, 1,2, 1.0\n", r"abaqus\.mtx line 2: not an Abaqus MATRIX INPUT"),
    "coord.mtx": ("1 1 2.0\n2 2 3.0\n2 1\n", r"coord\.mtx line 3: not an Abaqus COORDINATE"),
    "dmig.pch": ("DMIG,K1,0,6,2,0,,,2\nDMIG,K1,1,1,,1,1,abc\n", r"dmig\.pch line 2 \(A\): 'abc' is not a real"),
    "cdmig.bdf": ("DMIG,K1,0,6,4,0,,,2\nDMIG,K1,1,1,,1,1,2.0,0.0\n", r"cdmig\.bdf line 1: DMIG K1 is complex"),
    "hb.matrix": (None, r"hb\.matrix \(values\): 2 values where the header declares 3"),
    "bad.full": (None, r"bad\.full: not a readable ANSYS \.full file"),
}


def _malformed(tmp_path: Path, name: str) -> Path:
    text, _ = MALFORMED[name]
    path = tmp_path / name
    if name == "hb.matrix":
        wr.harwell_boeing(path, sp.csr_matrix(np.array([[2.0, 0.0], [1.0, 3.0]])), symmetric=True)
        lines = path.read_text().splitlines()
        path.write_text("\n".join([*lines[:-1], lines[-1][:50]]) + "\n")  # the last value cut off
    elif name == "bad.full":
        import struct

        path.write_bytes(struct.pack("<3i", 100, 0, 4) + b"\x07" * 64)  # the header of a .full, then junk
    else:
        path.write_text(text)
    return path


@pytest.mark.parametrize("name", sorted(MALFORMED))
def test_a_malformed_file_is_one_line_and_exit_2(run, tmp_path, name):
    if name == "bad.full":
        pytest.importorskip("ansys.mapdl.reader")
    path = _malformed(tmp_path, name)
    with pytest.raises(InputError, match=MALFORMED[name][1]) as info:
        load_fe_model(files={"M": str(path), "K1": str(path)})
    assert "\n" not in str(info.value)
    toml = tmp_path / "m.toml"
    toml.write_text(f'model = "fe"\n[fe]\nfiles = {{ M = "{name}", K1 = "{name}" }}\n')
    r = run("modes", "--config", str(toml), "--rpm", "100", "--mu", "0.3")
    assert r.exit_code == 2, (r.output, r.exception)
    assert len(r.stderr.strip().splitlines()) == 1 and name in r.stderr


def test_labelled_and_unlabelled_files_are_not_mixed(hand, tmp_path):
    mats = hand["mats"]
    mm = _write_mm(tmp_path / "mm", {"M": mats["M"]})
    abq = _write_format("abaqus", tmp_path / "abq", {"K1": mats["K1"]}, hand["node"], hand["dof"])["files"]
    with pytest.raises(InputError, match="K1 have node/DOF labels but M do not"):
        load_fe_model(files={"M": mm["M"], "K1": abq["K1"]})


def test_a_mesh_without_the_models_nodes_is_refused(hand, tmp_path):
    files = _write_format("abaqus", tmp_path, {k: hand["mats"][k] for k in ("M", "K1")}, hand["node"],
                          hand["dof"])["files"]
    (tmp_path / "other.inp").write_text("*NODE\n1, 0., 0., 0.\n2, 1., 0., 0.\n")
    with pytest.raises(InputError, match=r"other\.inp: none of the model's 13 DOFs"):
        load_fe_model(files=files, mesh=tmp_path / "other.inp")

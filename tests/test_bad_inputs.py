"""Malformed input is refused with one line naming it (issues #29, #31: the adversarial round's readers).

Each case is one of /work/shared/reference/adversarial-2026-12-02.md, rebuilt small in tmp_path.
The reference for every case is the documented contract: an InputError (a ValueError) from the
API, exit code 2 and one stderr line from the CLI, and the user's file left as it was.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import scipy.io
import scipy.sparse as sp

from squealkit import InputError
from squealkit.fe import FEModel, load_fe_model


def _one_line(excinfo, *words):
    msg = str(excinfo.value)
    assert "\n" not in msg, msg
    for w in words:
        assert w in msg, msg


# -- A. FE matrix readers ---------------------------------------------------------------------------

def _v73(path, KR_attrs=None, jc=True, ir=(0, 1), n_rows=6, data=(1.0, 2.0)):
    """A MATLAB v7.3 file (HDF5) with dense M, K1 (stored transposed) and a sparse KR group."""
    import h5py

    with h5py.File(path, "w") as f:
        f["M"] = np.eye(6)
        f["K1"] = 4.0 * np.eye(6)
        g = f.create_group("KR")
        g.attrs["MATLAB_sparse"] = n_rows if KR_attrs is None else KR_attrs
        g["data"] = np.asarray(data, dtype=np.float64)
        g["ir"] = np.asarray(ir, dtype=np.uint64)
        if jc:
            g["jc"] = np.asarray([0, 1, 2, 2, 2, 2, 2], dtype=np.uint64)
    return path


def _mtx(path, shape, entries):
    rows = "".join(f"{i + 1} {j + 1} {v!r}\n" for i, j, v in entries)
    path.write_text(f"%%MatrixMarket matrix coordinate real general\n{shape[0]} {shape[1]} {len(entries)}\n{rows}")
    return path


_OP4_NAN = """\
       3       3       6       2M       1P,3E23.16
       1       1       1
 1.0000000000000000E+00
       2       2       1
 1.0000000000000000E+00
       3       3       1
 1.0000000000000000E+00
       4       1       1
 1.0000000000000000E+00
       3       3       6       2K1      1P,3E23.16
       1       1       1
 4.0000000000000000E+00
       2       2       1
 4.0000000000000000E+00
       3       3       1
 4.0000000000000000E+00
       4       1       1
 1.0000000000000000E+00
       3       3       1       2KR      1P,3E23.16
       1       2       1
 1.0000000000000000E+00
       2       1       1
                    NAN
       4       1       1
 1.0000000000000000E+00
"""


def _fe_case(name, tmp_path):
    """(load arguments, words the message must hold) for one malformed FE input."""
    if name == "mat-zeros":  # scipy: MatReadError "Mat file appears to be corrupt (first 20 bytes == 0)"
        (tmp_path / "z.mat").write_bytes(bytes(200))
        return {"file": tmp_path / "z.mat"}, ("z.mat", "not a readable MATLAB file")
    if name == "v73-nojc":
        return {"file": _v73(tmp_path / "a.mat", jc=False)}, ("a.mat", "KR", "jc")
    if name == "v73-bigrows":  # MATLAB_sparse = 1e12 rows: 7.28 TiB if a CSR index were built
        return {"file": _v73(tmp_path / "a.mat", n_rows=10**12)}, ("a.mat", "KR", "1000000000000")
    if name == "v73-strattr":
        return {"file": _v73(tmp_path / "a.mat", KR_attrs=np.bytes_(b"abc"))}, ("a.mat", "KR", "MATLAB_sparse")
    if name == "v73-badir":  # row indices 99, 100 in a 6-row matrix (KR was silently empty)
        return {"file": _v73(tmp_path / "a.mat", ir=(99, 100))}, ("a.mat", "KR", "row ind")
    if name == "mat-cplx-sparse":
        scipy.io.savemat(tmp_path / "c.mat", {"M": sp.eye(3, format="csc"), "K1": sp.eye(3, format="csc"),
                                              "KR": sp.csc_matrix(np.eye(3) * (1 + 0.5j))})
        return {"file": tmp_path / "c.mat"}, ("c.mat", "KR", "complex")
    if name == "mat-cplx-M-sparse":
        scipy.io.savemat(tmp_path / "c.mat", {"M": sp.csc_matrix(np.eye(3) * (1 + 0.5j)),
                                              "K1": sp.eye(3, format="csc")})
        return {"file": tmp_path / "c.mat"}, ("c.mat", "Matrix M", "complex")
    if name == "op4-nan":  # pyNastran's ASCII reader drops the NAN entry (KR nnz 2 -> 1)
        pytest.importorskip("pyNastran")
        (tmp_path / "n.op4").write_text(_OP4_NAN)
        return {"file": tmp_path / "n.op4"}, ("n.op4", "non-finite")
    if name == "tiny-M":  # M = 1e-300 I: onset reported at 4.8e-17 Hz (true ~1e152 Hz)
        files = {"M": _mtx(tmp_path / "M.mtx", (2, 2), [(0, 0, 1e-300), (1, 1, 1e-300)]),
                 "K1": _mtx(tmp_path / "K1.mtx", (2, 2), [(0, 0, 1.0), (1, 1, 2.0)])}
        return {"files": files}, ("Matrix M",)
    if name == "huge-decl":  # 1e8 x 1e8 with one entry each: 7.2 GB then MemoryError
        files = {"M": _mtx(tmp_path / "M.mtx", (10**8, 10**8), [(0, 0, 1.0)]),
                 "K1": _mtx(tmp_path / "K1.mtx", (10**8, 10**8), [(0, 0, 1.0)])}
        return {"files": files}, ("100000000", "DOF")
    if name == "mtx-dense-decl":  # a 1e5 x 1e5 dense array declared in a few bytes: 74.5 GiB, MemoryError
        (tmp_path / "K1.mtx").write_text("%%MatrixMarket matrix array real general\n100000 100000\n1.0\n")
        return {"files": {"M": tmp_path / "K1.mtx", "K1": tmp_path / "K1.mtx"}}, ("K1.mtx", "10000000000")
    raise AssertionError(name)


@pytest.mark.parametrize("case", ["mtx-dense-decl", "mat-zeros", "v73-nojc", "v73-bigrows", "v73-strattr", "v73-badir",
                                  "mat-cplx-sparse", "mat-cplx-M-sparse", "op4-nan", "tiny-M", "huge-decl"])
def test_malformed_fe_files_refused_in_one_line(tmp_path, case):
    kwargs, words = _fe_case(case, tmp_path)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # numpy's ComplexWarning alone is not a refusal
        with pytest.raises(InputError) as e:
            load_fe_model(**kwargs)
    _one_line(e, *words)


@pytest.mark.parametrize("case", ["mat-zeros", "v73-bigrows", "mat-cplx-sparse", "huge-decl"])
def test_malformed_fe_files_cli_exit_2(run, tmp_path, case):
    kwargs, words = _fe_case(case, tmp_path)
    if "file" in kwargs:
        fe = f'file = "{kwargs["file"].name}"'
    else:
        fe = "files = {" + ", ".join(f'{k} = "{v.name}"' for k, v in kwargs["files"].items()) + "}"
    (tmp_path / "fe.toml").write_text(f'model = "fe"\n[fe]\n{fe}\n')
    _cli_refuses(run("critical", "--config", str(tmp_path / "fe.toml"), "--rpm", "100"), "fe.toml", *words)


@pytest.mark.parametrize(
    ("mats", "words"),
    [
        ({"M": np.eye(2), "K1": np.eye(2) * (1 + 1j)}, ("Matrix K1", "complex")),
        ({"M": sp.eye(2, format="csr") * (1 + 0.5j), "K1": np.eye(2)}, ("Matrix M", "complex")),
        ({"M": np.eye(2), "K1": np.eye(2), "KR": sp.csr_matrix(np.eye(2) * 1j)}, ("Matrix KR", "complex")),
        ({"M": 1e-300 * np.eye(2), "K1": np.eye(2)}, ("Matrix M",)),
        ({"M": sp.coo_matrix(([1.0], ([0], [0])), shape=(10**8, 10**8)),
          "K1": sp.coo_matrix(([1.0], ([0], [0])), shape=(10**8, 10**8))}, ("100000000", "DOF")),
    ],
    ids=["complex-dense", "complex-sparse-M", "complex-sparse-KR", "tiny-M", "huge-decl"],
)
def test_from_matrices_same_checks_as_readers(mats, words):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(InputError) as e:
            FEModel.from_matrices(**mats)
    _one_line(e, *words)


def test_plausible_fe_models_still_accepted():
    # a massless DOF held by stiffness only, and a model in scaled units (NLEVP: f ~ 0.16 Hz)
    m = FEModel.from_matrices(M=np.diag([1.0, 0.0]), K1=np.diag([1.0, 1.0]))
    assert m.n_dof == 2
    from squealkit.data import nlevp_path

    assert load_fe_model(nlevp_path("disk_brake100.mat")).n_dof == 100


# -- B. TOML of the wrong type -----------------------------------------------------------------------

def _cli_refuses(r, *words):
    """Exit 2, one stderr line holding ``words``, no traceback (the CLI's contract for user errors)."""
    assert r.exit_code == 2, (r.exit_code, r.output, r.exception)
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr
    for w in words:
        assert w in lines[0], lines[0]
    assert "Traceback" not in r.output


@pytest.mark.parametrize(
    ("toml", "words"),
    [
        ('model = ["fe"]\n', ("model", "array", "string")),
        ('preset = ["lv2013"]\n', ("preset", "array", "string")),
        ("rig = 5\n", ("rig", "integer", "table")),
        ('model = "fe"\n[fe]\nfile = 5\n', ("[fe] file", "integer", "string")),
        ('model = "fe"\n[fe]\nfiles = {M = 5, K1 = "K1.mtx"}\n', ("[fe] files.M", "integer", "string")),
        ('model = "fe"\n[fe]\nfile = "a.mat"\ndisc_speed_ref = "fast"\n', ("[fe] disc_speed_ref", "string", "number")),
        ('model = "fe"\n[fe]\nfile = "a.mat"\nnames = {M = ["MAA"]}\n', ("[fe] names.M", "array", "string")),
        ("description = 3.5\n", ("description", "float", "string")),
        ("parameters = [1, 2]\n", ("parameters", "array", "table")),
    ],
    ids=["model-list", "preset-list", "rig-int", "fe-file-int", "fe-files-int", "fe-ref-str", "fe-names-list",
         "description-float", "parameters-list"],
)
def test_toml_of_the_wrong_type_one_line(run, tmp_path, toml, words):
    (tmp_path / "m.toml").write_text(toml)
    _cli_refuses(run("critical", "--config", str(tmp_path / "m.toml")), "m.toml", *words)


@pytest.mark.parametrize(
    ("call", "words"),
    [
        (lambda: __import__("squealkit.models.config", fromlist=["x"]).model_from_dict({"model": ["fe"]}),
         ("model", "array", "string")),
        (lambda: __import__("squealkit.models.config", fromlist=["x"]).model_from_dict(["fe"]),
         ("doc", "list")),
        (lambda: __import__("squealkit.models.config", fromlist=["x"]).parse_assignments([5]),
         ("5", "NAME=VALUE")),
        (lambda: __import__("squealkit.models.config", fromlist=["x"]).parse_assignments("m1=0.05"),
         ("items", "str")),
    ],
    ids=["model_from_dict-list", "model_from_dict-not-mapping", "parse_assignments-int", "parse_assignments-str"],
)
def test_config_api_wrong_types(call, words):
    with pytest.raises((InputError, TypeError)) as e:
        call()
    _one_line(e, *words)


# -- F. the demo's brake.toml names its mesh and DOF names ---------------------------------------------

@pytest.mark.slow
def test_fe_demo_mesh_reaches_modes_vtk(run, tmp_path):
    meshio = pytest.importorskip("meshio")
    out = tmp_path / "b"
    r = run("fe-demo", "--size", "8", "--out-dir", str(out))  # the smallest demo (738 DOFs)
    assert r.exit_code == 0, r.output
    from squealkit.models.config import load_model

    model = load_model(out / "brake.toml")
    names = (out / "dof_names.txt").read_text().split()
    assert model.dof_names == tuple(names) and model.mesh is not None
    vtu = tmp_path / "m.vtu"
    r = run("modes", "--config", str(out / "brake.toml"), "--rpm", "1000", "--mu", "0.5", "--vtk", str(vtu))
    assert r.exit_code == 0, (r.output, r.exception)
    got = meshio.read(vtu)
    shapes = [k for k in got.point_data if k.endswith("_re")]
    assert shapes, got.point_data.keys()
    # reference: each DOF named node{k}.{x,y,z} on a mesh vertex k lands on that point and component;
    # the clamped vertices (r = r_inner) carry no DOF, so their displacement is exactly zero
    v = got.point_data[shapes[0]]
    assert v.shape == (len(got.points), 3)
    on_vertex = [(int(n[4:].split(".")[0]), "xyz".index(n[-1])) for n in names
                 if int(n[4:].split(".")[0]) < len(got.points)]
    free_pts = {k for k, _ in on_vertex}
    clamped = [p for p in range(len(got.points)) if p not in free_pts]
    assert clamped and np.all(v[clamped] == 0.0)
    assert np.abs(v[sorted(free_pts)]).max() > 0.0


# -- C. campaign matrix CSV ------------------------------------------------------------------------------

@pytest.mark.parametrize(
    ("content", "words"),
    [
        (b"\x89HDF\r\n\x1a\n\x00\x00\x00\x00\x00\x08\x08\x00\x04\x00\x10\x00" * 50, ("m.csv", "not a text")),
        (b"application,file,section\nA1,rec.nc,\xe9t\xe9\n", ("m.csv", "UTF-8", "line 2")),
        (b"application,file\nA1,\n", ("m.csv", "line 2", "no file")),
        (b"application,file,temperature_c\nA1,rec.nc,inf\n", ("m.csv", "line 2", "temperature_c")),
        (b"application,file,rpm\nA1,rec.nc,-900\n", ("m.csv", "line 2", "rpm", "> 0")),
        (b"application,file,pressure_bar\nA1,rec.nc,nan\n", ("m.csv", "line 2", "pressure_bar")),
        (b"application,file,speed_kmh\nA1,rec.nc,-5\n", ("m.csv", "line 2", "speed_kmh")),
    ],
    ids=["binary", "latin1", "empty-file-cell", "temperature-inf", "rpm-negative", "pressure-nan", "speed-negative"],
)
def test_bad_matrix_csv_refused_before_any_analysis(run, tmp_path, content, words):
    from squealkit.campaign.matrix import read_matrix

    m = tmp_path / "m.csv"
    m.write_bytes(content)
    with pytest.raises(InputError) as e:
        read_matrix(m)
    _one_line(e, *words)
    out = tmp_path / "o"
    r = run("campaign", str(m), "--out-dir", str(out), "--mic", "mic", "--displacement", "displacement",
            "--radius", "0.05", "--rpm", "900", "--no-report")
    _cli_refuses(r, "m.csv")
    assert not out.exists()  # nothing written


# -- D. DuckDB campaign store ----------------------------------------------------------------------------

@pytest.fixture(scope="module")
def good_store(tmp_path_factory):
    """A valid store of about 1 MB (3 000 applications of 20 events), written by CampaignStore itself."""
    pytest.importorskip("duckdb")
    from squealkit.campaign.store import CampaignStore

    p = tmp_path_factory.mktemp("store") / "good.duckdb"
    with CampaignStore(p) as s:
        s.put_many([({"application": f"A{i}", "file": "x" * 50, "peak_dba": float(i)},
                     [{"application": f"A{i}", "event": j, "frequency_hz": 1.0 * j} for j in range(20)])
                    for i in range(3000)])
    return p


def _make_store(kind, path, good):
    import shutil

    import duckdb

    if kind == "random":
        path.write_bytes(np.random.default_rng(1).bytes(300_000))
    elif kind == "zero":
        path.write_bytes(b"")
    elif kind == "truncated":
        shutil.copy(good, path)
        with open(path, "r+b") as f:
            f.truncate(path.stat().st_size // 2)
    elif kind == "flipped":
        shutil.copy(good, path)
        with open(path, "r+b") as f:
            f.seek(12288)
            f.write(b"\xff" * 4096)
    elif kind == "folder":
        path.mkdir()
    elif kind == "sqlite":
        import sqlite3

        c = sqlite3.connect(path)
        c.execute("create table t(x)")
        c.commit()
        c.close()
    elif kind == "text":
        path.write_text("application,file\n")
    elif kind == "other-columns":
        c = duckdb.connect(str(path))
        c.execute("create table applications(id int, name varchar)")
        c.close()
    elif kind == "view-events":
        c = duckdb.connect(str(path))
        c.execute("create view events as select 1 as x")
        c.close()
    elif kind == "user-table":
        c = duckdb.connect(str(path))
        c.execute("create table budget(x int)")
        c.execute("insert into budget values (42)")
        c.close()
    else:
        raise AssertionError(kind)


_STORE_CASES = {
    "random": "not a DuckDB", "zero": "empty", "truncated": "damaged", "flipped": "damaged",
    "folder": "folder", "sqlite": "SQLite", "text": "not a DuckDB", "other-columns": "applications",
    "view-events": "events", "user-table": "budget",
}


def _snapshot(path):
    return sorted(p.name for p in path.iterdir()) if path.is_dir() else path.read_bytes()


@pytest.mark.parametrize("kind", list(_STORE_CASES))
def test_bad_store_refused_and_left_unchanged(tmp_path, good_store, kind):
    from squealkit.campaign.store import CampaignStore

    p = tmp_path / "campaign.duckdb"
    _make_store(kind, p, good_store)
    before = _snapshot(p)
    with pytest.raises(InputError) as e:
        CampaignStore(p)
    _one_line(e, "campaign.duckdb", _STORE_CASES[kind])
    assert _snapshot(p) == before
    assert sorted(x.name for x in tmp_path.iterdir()) == ["campaign.duckdb"]  # no WAL or other file left


def test_bad_store_cli_exit_2(run, tmp_path, good_store):
    # one CLI case (the rest share the API's path): a SQLite file must not make DuckDB fetch an extension.
    # A campaign.duckdb squealkit's manifest does not list is the user's: the CLI refuses the folder
    # before DuckDB sees the file (the SQLite check itself: test_bad_store_refused_and_left_unchanged)
    pytest.importorskip("duckdb")
    out = tmp_path / "o"
    out.mkdir()
    _make_store("sqlite", out / "campaign.duckdb", good_store)
    before = _snapshot(out / "campaign.duckdb")
    m = tmp_path / "m.csv"
    (tmp_path / "r.nc").write_bytes(b"")
    m.write_text("application,file\nA1,r.nc\n")
    r = run("campaign", str(m), "--out-dir", str(out), "--mic", "mic", "--displacement", "displacement",
            "--radius", "0.05", "--rpm", "900", "--no-report")
    _cli_refuses(r, "campaign.duckdb", "did not write")
    assert _snapshot(out / "campaign.duckdb") == before


def test_store_locked_by_another_process(tmp_path, good_store):
    import shutil
    import subprocess
    import sys

    from squealkit.campaign.store import CampaignStore

    p = tmp_path / "campaign.duckdb"
    shutil.copy(good_store, p)
    holder = subprocess.Popen([sys.executable, "-c", "import duckdb, sys, time; c = duckdb.connect(sys.argv[1]); "
                               "print('held', flush=True); time.sleep(60)", str(p)], stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "held"
        with pytest.raises(InputError) as e:
            CampaignStore(p)
        _one_line(e, "campaign.duckdb", "in use")
    finally:
        holder.kill()
        holder.wait()


def test_read_only_store(tmp_path, good_store):
    import os
    import shutil
    import subprocess
    import sys

    p = tmp_path / "campaign.duckdb"
    shutil.copy(good_store, p)
    code = ("import sys\nfrom squealkit.campaign.store import CampaignStore\n"
            "from squealkit import InputError\n"
            "try:\n    CampaignStore(sys.argv[1])\nexcept InputError as e:\n    print(e)\n    sys.exit(3)\n")
    if os.geteuid() == 0:  # root writes read-only files: drop the capability that lets it
        if not shutil.which("setpriv"):
            pytest.skip("needs setpriv to drop root's dac_override")
        prefix = ["setpriv", "--bounding-set=-dac_override,-dac_read_search", "--"]
    else:
        prefix = []
    p.chmod(0o444)
    tmp_path.chmod(0o555)
    try:
        r = subprocess.run([*prefix, sys.executable, "-c", code, str(p)], capture_output=True, text=True,
                           env={**os.environ}, timeout=120)
    finally:
        tmp_path.chmod(0o755)
    assert r.returncode == 3, (r.returncode, r.stdout, r.stderr)
    assert "campaign.duckdb" in r.stdout and "\n" not in r.stdout.strip()


# -- E. public API given the wrong type ------------------------------------------------------------------

def _public_functions_taking_a_model():
    import importlib
    import inspect

    out = {}
    for m in ("squealkit.stability", "squealkit.transient", "squealkit.nonlinear", "squealkit.uncertainty",
              "squealkit.solvers.band", "squealkit.stability.fe_sweep"):
        mod = importlib.import_module(m)
        for name in mod.__all__:
            f = getattr(mod, name)
            if inspect.isfunction(f) and next(iter(inspect.signature(f).parameters), None) == "model":
                out[f"{f.__module__}.{name}"] = f
    return out


_REQUIRED = {"theta": 0.0, "mu": 0.3, "parameter": "k1", "rpm": 100.0, "duration": 0.01, "tan_theta": 0.0,
             "uncertain": {}, "samples": 8, "omega": 1.0, "disc_speed": 1.0, "lam": [1j], "X": [[1.0]]}
_TAKING_A_MODEL = _public_functions_taking_a_model()


@pytest.mark.parametrize("name", sorted(_TAKING_A_MODEL))
def test_every_public_function_taking_a_model_checks_its_type(name):
    import inspect

    from squealkit import InputTypeError

    f = _TAKING_A_MODEL[name]
    params = list(inspect.signature(f).parameters.values())[1:]
    kwargs = {p.name: _REQUIRED[p.name] for p in params
              if p.default is p.empty and p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)}
    with pytest.raises(InputTypeError) as e:  # both an InputError and a TypeError
        f("lv2013", **kwargs)
    _one_line(e, "model must be", "str", "'lv2013'")
    assert isinstance(e.value, TypeError) and isinstance(e.value, InputError)


def _lc_model():
    from squealkit.models.config import get_preset

    return get_preset("lv2013")


def _e_case(name, tmp_path):
    import xarray as xr

    from squealkit.io import load_dataset, save_blocks
    from squealkit.nonlinear import limit_cycle_branch
    from squealkit.solvers.band import band_eigs
    from squealkit.transient import transient_summary

    if name == "band-k-0":
        from squealkit.data import nlevp_path

        m = load_fe_model(nlevp_path("disk_brake100.mat"))
        return lambda: band_eigs(m, 6.28, 1.0, band=(0.1, 0.5), k=0), ("k=0", ">= 1")
    if name == "band-friction-model":
        return lambda: band_eigs(_lc_model(), 6.28, 1.0), ("model must be an FEModel", "PinOnDisc3DOF")
    if name == "summary-dict":
        return lambda: transient_summary({"a": 1}), ("ds must be an xarray.Dataset", "dict")
    if name == "summary-other-dataset":
        return (lambda: transient_summary(xr.Dataset({"a": ("x", [1.0])})), ("ds", "simulate"))
    if name == "lc-harmonics-0":
        return lambda: limit_cycle_branch(_lc_model(), (0.3, 0.8), harmonics=0), ("harmonics=0", ">= 1")
    if name == "lc-harmonics-float":
        return lambda: limit_cycle_branch(_lc_model(), (0.3, 0.8), harmonics=2.5), ("harmonics=2.5", "integer")
    if name == "load-garbage":
        (tmp_path / "g.nc").write_bytes(np.random.default_rng(2).bytes(5000))
        return lambda: load_dataset(tmp_path / "g.nc"), ("g.nc",)
    if name == "load-empty-zarr":
        (tmp_path / "e.zarr").mkdir()
        return lambda: load_dataset(tmp_path / "e.zarr"), ("e.zarr",)
    if name == "save-blocks-mismatch":
        b1 = xr.Dataset({"a": ("time", [1.0, 2.0])})
        b2 = xr.Dataset({"b": ("time", [1.0])})
        return lambda: save_blocks([b1, b2], tmp_path / "x.nc"), ("block 1", "'b'", "'a'")
    raise AssertionError(name)


@pytest.mark.parametrize("case", ["band-k-0", "band-friction-model", "summary-dict", "summary-other-dataset",
                                  "lc-harmonics-0", "lc-harmonics-float", "load-garbage", "load-empty-zarr",
                                  "save-blocks-mismatch"])
def test_public_api_wrong_argument_one_line(tmp_path, case):
    call, words = _e_case(case, tmp_path)
    with pytest.raises((InputError, TypeError)) as e:
        call()
    _one_line(e, *words)
    assert not (tmp_path / "x.nc").exists()

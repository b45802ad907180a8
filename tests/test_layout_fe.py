"""The FE side's layout (issue #28): no import circle, options that cannot apply are refused, a pluggable LU.

- Import circles: found statically, from the ``ast`` of every module of ``src/squealkit`` (imports at
  module level and inside functions), so a circle hidden in a function-level import is found
  before it bites at run time. The finder is checked on a planted circle first.
- ``stability_map`` on an FE model used to ignore ``damped``, ``track``, ``lock_in_rtol`` and
  ``tile_points`` without a word (``track=False, damped=False`` gave ``tracked=1, damped=1``).
- The LU of every shift-invert solve is a backend of :mod:`squealkit.solvers.lu`; the reference for
  a second backend is the first: LAPACK's dense LU and SuperLU's sparse one give the same
  eigenvalues to 1e-10 (both backward stable; every eigenpair's backward error is checked).

Imports of the new packages are inside the tests that need them, so that the option tests run
(and fail) on the code before the change too.
"""

from __future__ import annotations

import ast
import importlib
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp

from squealkit import InputError
from squealkit.models import FEModel, get_preset
from squealkit.stability import stability_map

SRC = Path(__file__).resolve().parents[1] / "src" / "squealkit"


# -- import circles ------------------------------------------------------------------------------


def _modules(root: Path) -> dict[str, tuple[Path, bool]]:
    """Dotted name -> (file, is a package) of every module under ``root`` (a package folder)."""
    out = {}
    for p in sorted(root.rglob("*.py")):
        parts = list(p.relative_to(root.parent).with_suffix("").parts)
        is_pkg = parts[-1] == "__init__"
        out[".".join(parts[:-1] if is_pkg else parts)] = (p, is_pkg)
    return out


def _import_graph(root: Path, *, packages: bool = False) -> dict[str, set[str]]:
    """Module -> the modules of the same tree it imports, anywhere in its code (function level too).

    ``from pkg import name`` is an import of ``pkg.name`` where that is a module, else of ``pkg``.
    With ``packages``, importing ``a.b.c`` also counts as importing the packages ``a.b`` and ``a``
    (Python runs their ``__init__`` first).
    """
    mods = _modules(root)
    graph: dict[str, set[str]] = {m: set() for m in mods}
    for name, (path, is_pkg) in mods.items():
        pkg = name if is_pkg else name.rpartition(".")[0]
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = pkg.split(".")[: len(pkg.split(".")) - node.level + 1] if node.level else []
                mod = ".".join(base + ([node.module] if node.module else []))
                targets = [f"{mod}.{a.name}" if f"{mod}.{a.name}" in mods else mod for a in node.names]
            else:
                continue
            for t in targets:
                while t and t not in mods:  # an attribute of a module, or another distribution
                    t = t.rpartition(".")[0]
                if t and t != name:
                    graph[name].add(t)
                    while packages and (t := t.rpartition(".")[0]):
                        if t in mods and t != name and not name.startswith(t + "."):
                            graph[name].add(t)
    return graph


def _circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while (w := stack.pop()) != v:
                comp.append(w)
            comp.append(v)
            if len(comp) > 1:
                out.append(sorted(comp))

    limit = sys.getrecursionlimit()
    sys.setrecursionlimit(max(limit, 10 * len(graph)))
    try:
        for v in sorted(graph):
            if v not in index:
                visit(v)
    finally:
        sys.setrecursionlimit(limit)
    return sorted(out)


def test_the_circle_finder_finds_a_circle_hidden_in_a_function(tmp_path):
    pkg = tmp_path / "pkg"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "sub" / "__init__.py").write_text("from .b import g\n")
    (pkg / "a.py").write_text("from .sub import b\n")
    (pkg / "sub" / "b.py").write_text("def g():\n    from .. import a\n    return a\n")
    (pkg / "c.py").write_text("import pkg.a\nfrom pkg.sub.b import g\n")  # imports, no circle
    assert _circles(_import_graph(pkg)) == [["pkg.a", "pkg.sub.b"]]
    (pkg / "sub" / "b.py").write_text("def g():\n    return 1\n")
    assert _circles(_import_graph(pkg)) == []
    # through a package: pkg.a and pkg.c import pkg.sub.b, whose package's __init__ imports pkg.c
    (pkg / "sub" / "__init__.py").write_text("from .. import c\n")
    assert _circles(_import_graph(pkg)) == []
    assert _circles(_import_graph(pkg, packages=True)) == [["pkg.a", "pkg.c", "pkg.sub"]]
    # an import for type names only (under TYPE_CHECKING) counts too: the annotation names the other module,
    # a dependency of the design if not of the run (none is needed: results are duck-typed where drawn)
    (pkg / "sub" / "__init__.py").write_text("")
    (pkg / "sub" / "b.py").write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from .. import a\n")
    assert _circles(_import_graph(pkg)) == [["pkg.a", "pkg.sub.b"]]


def test_no_import_circle_among_squealkit_modules():
    # was: stability.eigen <-> stability.fe_sweep, and _validation (validate_model imported
    # models._base and models.fe inside the function) <-> models._base, models.fe, models.friction
    assert _circles(_import_graph(SRC)) == []


def test_no_import_circle_through_packages():
    # a module's import runs its packages' __init__ first, so a package that imports (even in a function)
    # a module that imports the package back is a circle. Were: the report's runner <-> the warm-up child
    # (which read the report's operating points: now squealkit._operating_point, below both), and
    # measurement <-> plotting.measurement (plotting computed the signals of the deprecated recording call
    # forms through measurement: plotting now only draws what it is given)
    assert _circles(_import_graph(SRC, packages=True)) == []


def test_fe_and_solver_modules_are_short():
    # issue #28: no module over ~800 lines unless it is one algorithm
    # no exception left: the compiled integrators are a package of one algorithm a module (solvers/ode/: force,
    # events, dp5, rosenbrock, rk4, periodic), the small-model kernels two (solvers/small/: the roots with their
    # error radii, and what the roots say), each under the limit
    for folder in ("fe", "solvers", "io"):
        for p in (SRC / folder).rglob("*.py"):
            assert len(p.read_text(encoding="utf-8").splitlines()) <= 800, p
    for name in ("maps.py", "_schema.py", "fe_sweep.py", "eigen.py"):
        assert len((SRC / "stability" / name).read_text(encoding="utf-8").splitlines()) <= 800, name


def test_solvers_know_no_analysis():
    # engines below the analyses: nothing in solvers/ imports stability/, plotting/, report/ or cli/
    graph = _import_graph(SRC)
    for mod, deps in graph.items():
        if mod.startswith("squealkit.solvers"):
            up = [d for d in deps if d.startswith(("squealkit.stability", "squealkit.plotting", "squealkit.report",
                                                   "squealkit.cli"))]
            assert not up, (mod, up)


# -- options that do not apply to the model's kind -------------------------------------------------


@pytest.fixture(scope="module")
def fe2():
    # Hoffmann-like 2 DOF: K = [[k1, mu kc], [-mu kc, k2]], flutter beyond mu = |k1 - k2| / (2 kc) = 0.25
    k1, k2, kc = 1.2e6, 1.0e6, 4.0e5
    return FEModel.from_matrices(M=np.eye(2), K1=np.diag([k1, k2]), KR=[[0.0, kc], [-kc, 0.0]],
                                 D1=1e-3 * np.eye(2))


def test_fe_map_refuses_damped_false(fe2):
    # before: ignored, and the result said damped=1
    with pytest.raises(InputError, match=r"damped=False.*fe model"):
        stability_map(fe2, [0.1, 0.4], rpm=[60.0], damped=False)
    assert stability_map(fe2, [0.1], rpm=[60.0], damped=True).attrs["damped"] == 1


def test_fe_map_honours_track_and_lock_in_rtol(fe2):
    # before: track=False gave tracked=1, lock_in_rtol was dropped (the default 1e-3 in the result)
    ds = stability_map(fe2, [0.1, 0.4], rpm=[60.0], track=False, lock_in_rtol=0.05)
    assert ds.attrs["tracked"] == 0
    assert ds["lock_in"].attrs["rtol"] == 0.05
    assert stability_map(fe2, [0.1, 0.4], rpm=[60.0]).attrs["tracked"] == 1


@pytest.mark.parametrize(("option", "value"), [("tile_points", 1000), ("friction", "stribeck"), ("speed", 1.0),
                                               ("store", "m.zarr")])
def test_fe_map_refuses_small_model_options(fe2, option, value, tmp_path):
    if option == "friction":
        from squealkit.models.friction import Stribeck

        value = Stribeck(mu_static=0.5, v_stribeck=0.1)
    if option == "store":
        value = tmp_path / value
    with pytest.raises(InputError) as e:
        stability_map(fe2, [0.1], rpm=[60.0], **{option: value})
    msg = str(e.value)
    assert option in msg and "fe model" in msg and "\n" not in msg


@pytest.mark.parametrize(("option", "value"), [("rpm", [600.0]), ("method", "auto"), ("method", "dense"),
                                               ("band", (1000.0, 2000.0)), ("n_modes", 4)])
def test_small_map_refuses_fe_options(option, value):
    # method="auto" given is refused too: the default is a sentinel, "not given" is told apart
    with pytest.raises(InputError) as e:
        stability_map(get_preset("lv2013"), [0.3], damped=False, **{option: value})
    msg = str(e.value)
    assert f"Option {option} " in msg and "pin_on_disc model" in msg and "FE models only" in msg


def test_small_map_names_every_fe_option_given():
    with pytest.raises(InputError, match=r"Options rpm, band do not apply to a pin_on_disc model"):
        stability_map(get_preset("lv2013"), [0.3], damped=False, rpm=[600.0], band=(1.0, 2.0))


def test_small_map_refuses_tile_points_without_store():
    with pytest.raises(InputError, match=r"tile_points=10 applies to streamed maps only"):
        stability_map(get_preset("lv2013"), [0.3], damped=False, tile_points=10)


def test_fe_map_through_stability_map_equals_fe_stability_map(fe2):
    from squealkit.stability import fe_stability_map

    a = stability_map(fe2, [0.1, 0.4], rpm=[60.0, 120.0])
    b = fe_stability_map(fe2, [60.0, 120.0], [0.1, 0.4])
    assert np.array_equal(a.growth_rate.values, b.growth_rate.values, equal_nan=True)


# -- the pluggable LU ----------------------------------------------------------------------------------


def _random_fe(n: int = 40, seed: int = 3) -> FEModel:
    """A sparse damped, gyroscopic, non-symmetric model with modes over 100-3000 Hz (as test_fe_properties)."""
    rng = np.random.default_rng(seed)
    w = 2 * np.pi * np.sort(rng.uniform(100.0, 3000.0, n))
    KR = sp.random(n, n, density=0.1, random_state=seed, format="csr") * 1e5
    G = sp.random(n, n, density=0.1, random_state=seed + 1, format="csr")
    return FEModel.from_matrices(M=sp.eye(n), K1=sp.diags(w**2), KR=KR, D1=sp.diags(1e-3 * w), DG=G - G.T)


def test_dense_lu_backend_gives_the_superlu_eigenvalues():
    from squealkit.solvers.band import band_eigs

    model = _random_fe()
    band = (300.0, 2800.0)
    ref = band_eigs(model, 10.0, 0.4, band=band, k=8, workers=1)  # SuperLU, the default
    got = band_eigs(model, 10.0, 0.4, band=band, k=8, workers=1, lu="dense")
    assert ref.eigenvalues.size == got.eigenvalues.size > 10
    np.testing.assert_allclose(got.eigenvalues, ref.eigenvalues, rtol=1e-10, atol=0)
    assert np.all(got.residuals < 1e-12)


def test_a_registered_backend_is_used_per_call_and_globally():
    from squealkit.solvers import lu
    from squealkit.solvers.band import band_eigs

    calls = []

    def counting(P, perm):
        calls.append(P.shape)
        return lu.DenseLU(P)

    lu.register_lu_backend("counting", counting)
    try:
        model = _random_fe(n=20)
        ref = band_eigs(model, 10.0, 0.4, band=(300.0, 2800.0), k=6, workers=1)
        assert calls == []
        one = band_eigs(model, 10.0, 0.4, band=(300.0, 2800.0), k=6, workers=1, lu=counting)  # a callable
        n_shifts = len(calls)
        assert n_shifts >= 1 and all(s == (20, 20) for s in calls)
        with lu.use_lu_backend("counting"):
            assert lu.lu_backend() == "counting"
            two = band_eigs(model, 10.0, 0.4, band=(300.0, 2800.0), k=6, workers=1)
        assert lu.lu_backend() != "counting" and len(calls) == 2 * n_shifts
        for sol in (one, two):
            np.testing.assert_allclose(sol.eigenvalues, ref.eigenvalues, rtol=1e-10, atol=0)
    finally:
        del lu.LU_BACKENDS["counting"]


def test_unknown_or_unavailable_lu_backend_is_named():
    from squealkit.solvers import lu
    from squealkit.solvers.band import band_eigs

    model = _random_fe(n=20)
    with pytest.raises(InputError, match=r"Unknown LU backend lu='pardisoo'; known: superlu, dense"):
        band_eigs(model, 10.0, 0.4, band=(300.0, 2800.0), lu="pardisoo")
    before = lu.lu_backend()
    lu.register_lu_backend("missing", lambda P, perm: None, requires=("pypardiso_not_installed_here",),
                           install="pip install pypardiso")
    try:
        with pytest.raises(InputError, match=r"LU backend 'missing' is not available: it needs "
                                             r"pypardiso_not_installed_here \(not installed, or it does not import\): "
                                             r"pip install pypardiso"):
            lu.set_lu_backend("missing")
        assert lu.lu_backend() == before
    finally:
        del lu.LU_BACKENDS["missing"]


def test_singular_matrix_is_a_runtime_error_for_every_backend():
    from squealkit.solvers.lu import factorize

    P = sp.csr_matrix(np.array([[1.0, 2.0], [2.0, 4.0]]))
    for backend in ("superlu", "dense"):
        with pytest.raises(RuntimeError):
            factorize(P, lu=backend)


# -- the disc speed's name -------------------------------------------------------------------------------


def test_disc_speed_is_the_name_and_omega_still_works_with_a_warning(fe2):
    from squealkit.fe import rpm_to_disc_speed, rpm_to_omega

    m = FEModel.from_matrices(M=np.eye(2), K1=np.eye(2), DG=[[0.0, 1.0], [-1.0, 0.0]], disc_speed_ref=2.0)
    C = m.damping_matrix(disc_speed=4.0, mu=0.3).toarray()
    assert C[0, 1] == 2.0  # (disc_speed / disc_speed_ref) DG
    with pytest.warns(DeprecationWarning, match="use disc_speed="):
        assert np.array_equal(m.damping_matrix(omega=4.0, mu=0.3).toarray(), C)
    with pytest.warns(DeprecationWarning, match="use disc_speed_ref="):
        old = FEModel.from_matrices(M=np.eye(2), K1=np.eye(2), DG=[[0.0, 1.0], [-1.0, 0.0]], omega_ref=2.0)
    assert old.disc_speed_ref == 2.0
    with pytest.warns(DeprecationWarning, match="use disc_speed_ref"):
        assert old.omega_ref == 2.0
    with pytest.warns(DeprecationWarning, match="use disc_speed_ref="):
        assert FEModel(M=np.eye(1), K1=np.eye(1), omega_ref=3.0).disc_speed_ref == 3.0
    with pytest.warns(DeprecationWarning, match="use rpm_to_disc_speed"):
        assert rpm_to_omega(60.0) == rpm_to_disc_speed(60.0) == 2 * np.pi
    assert "omega_ref" not in m.to_dict() and m.to_dict()["disc_speed_ref"] == 2.0


def test_toml_omega_ref_still_read_with_a_warning(tmp_path):
    import scipy.io

    from squealkit.models import load_model

    scipy.io.mmwrite(tmp_path / "M.mtx", sp.eye(2, format="coo"))
    scipy.io.mmwrite(tmp_path / "K1.mtx", sp.diags([4.0, 9.0]).tocoo())
    head = 'model = "fe"\n[fe]\nfiles = {M = "M.mtx", K1 = "K1.mtx"}\n'
    (tmp_path / "new.toml").write_text(head + "disc_speed_ref = 5.0\n")
    assert load_model(tmp_path / "new.toml").disc_speed_ref == 5.0
    (tmp_path / "old.toml").write_text(head + "omega_ref = 5.0\n")
    with pytest.warns(DeprecationWarning, match="omega_ref is deprecated; use disc_speed_ref"):
        assert load_model(tmp_path / "old.toml").disc_speed_ref == 5.0
    (tmp_path / "both.toml").write_text(head + "omega_ref = 5.0\ndisc_speed_ref = 5.0\n")
    with pytest.raises(InputError, match="both omega_ref"):
        load_model(tmp_path / "both.toml")


# -- old paths and the readers' table ---------------------------------------------------------------------


@pytest.mark.parametrize(("old", "new", "name"), [
    ("squealkit.models.fe", "squealkit.fe.model", "FEModel"),
    ("squealkit.models.fe_readers", "squealkit.fe.readers", "load_fe_model"),
    ("squealkit.models.fe_demo", "squealkit.fe.demo", "build_fe_demo"),
    ("squealkit.stability.sparse", "squealkit.solvers.band", "band_eigs"),
    ("squealkit.stability.reduction", "squealkit.solvers.reduction", "pod_basis"),
])
def test_old_paths_are_shims_that_warn(old, new, name):
    sys.modules.pop(old, None)
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        mod = importlib.import_module(old)
    assert any(issubclass(x.category, DeprecationWarning) and new in str(x.message) for x in w)
    assert getattr(mod, name) is getattr(importlib.import_module(new), name)
    from squealkit.models import FEModel as public

    assert public is importlib.import_module("squealkit.fe").FEModel


def test_a_registered_reader_is_used_by_its_suffix(tmp_path):
    from squealkit.fe import READERS, load_fe_model, read_matrices, register_reader

    path = tmp_path / "brake.diag"
    path.write_text("4 9\n")

    def read_diag(p):
        return {"K1": sp.diags([float(x) for x in Path(p).read_text().split()]), "M": sp.eye(2)}

    register_reader(".DIAG", read_diag)
    try:
        assert set(read_matrices(path)) == {"K1", "M"}
        assert load_fe_model(path).K1.diagonal().tolist() == [4.0, 9.0]
    finally:
        del READERS[".diag"]
    with pytest.raises(InputError, match=r"unknown format '\.diag'; known: \.mat, \.mtx, \.op4"):
        read_matrices(path)

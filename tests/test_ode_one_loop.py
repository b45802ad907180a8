"""DP5 and Rodas4 share one driver loop and every ODE kernel takes a handful of named bundles (issue #28, item 3).

Reference: ``tests/golden/ode_loop/ode_loop.npz``, written by ``tests/golden/make_golden_ode_loop.py`` from commit
f778029, before the two adaptive kernels (53 and 55 positional arguments, each with its own copy of the
loop) became one loop around each method's step. Each case is recomputed here and compared with
``np.array_equal`` (NaN equal to NaN): the same bits, not a tolerance. The structural tests read the
sources (``ast``) and the compiled functions' signatures; nothing is compiled for them.
"""

from __future__ import annotations

import ast
import importlib
import importlib.util
import inspect
import pkgutil
from pathlib import Path

import numba
import numpy as np
import pytest

from squealkit.solvers import ode

GOLDEN = Path(__file__).parent / "golden"
ODE_DIR = Path(inspect.getfile(ode)).parent
BUNDLES = ("state", "model", "forcing", "span", "tableau", "control", "out", "log")


def _maker():
    spec = importlib.util.spec_from_file_location("make_golden_ode_loop", GOLDEN / "make_golden_ode_loop.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def recorded() -> np.lib.npyio.NpzFile:
    return np.load(GOLDEN / "ode_loop" / "ode_loop.npz")


@pytest.fixture(scope="module")
def computed() -> dict[str, np.ndarray]:
    return _maker().flat(_maker().cases())


def _case_names() -> list[str]:
    return sorted({k.split("/")[0] for k in np.load(GOLDEN / "ode_loop" / "ode_loop.npz").files})


def test_the_cases_cover_both_methods_and_their_events(recorded):
    names = _case_names()
    for method in ("dopri5", "rosenbrock"):
        assert {f"{method}_contact_opening", f"{method}_stick_slip", f"{method}_chunks"} <= set(names)
        # contact opens (1) and closes (2); the sign law's stick (3) and slip (4) events
        assert {1, 2} <= set(recorded[f"{method}_contact_opening/var:event_kind"].tolist())
        assert {3, 4} <= set(recorded[f"{method}_stick_slip/var:event_kind"].tolist())
    assert "rosenbrock_stiff_friction" in names and any(n.startswith("rk4") for n in names)


@pytest.mark.parametrize("case", _case_names())
def test_case_is_bit_identical_to_the_two_loops(computed, recorded, case):
    want = {k: recorded[k] for k in recorded.files if k.startswith(case + "/")}
    got = {k: np.asarray(v) for k, v in computed.items() if k.startswith(case + "/")}
    assert sorted(got) == sorted(want)
    for key, b in want.items():
        a = got[key]
        assert a.shape == b.shape, key
        assert np.array_equal(a, b, equal_nan=b.dtype.kind in "fc"), (
            f"{key}: max |difference| {np.nanmax(np.abs(a - b)) if a.size else 0:.3e}")


# -- the structure ---------------------------------------------------------------------------------


def _compiled_functions():
    """Every numba-compiled function defined in solvers/ode/ (the kernels and their helpers), by name."""
    found = {}
    for info in pkgutil.iter_modules([str(ODE_DIR)]):
        mod = importlib.import_module(f"{ode.__name__}.{info.name}")
        for name, obj in vars(mod).items():
            if isinstance(obj, numba.core.registry.CPUDispatcher):
                found[f"{info.name}.{name}"] = obj
    return found


def test_no_compiled_ode_function_takes_more_than_15_parameters():
    # before: integrate_adaptive 53, integrate_rosenbrock 55, integrate_chunk 37, _jacobian 23, _locate 22
    funcs = _compiled_functions()
    assert len(funcs) > 20 and "dp5.integrate_adaptive" in funcs
    wide = {name: len(inspect.signature(f.py_func).parameters) for name, f in funcs.items()}
    assert {name: k for name, k in wide.items() if k > 15} == {}


def test_the_kernels_take_named_bundles():
    for kernel in (ode.integrate_adaptive, ode.integrate_rosenbrock):
        assert tuple(inspect.signature(kernel.py_func).parameters) == BUNDLES
    assert tuple(inspect.signature(ode.integrate_chunk.py_func).parameters) == (
        "state", "model", "forcing", "steps", "limit", "out", "log")


def _tree(name: str) -> ast.Module:
    return ast.parse((ODE_DIR / name).read_text(encoding="utf-8"))


def _called(node: ast.AST) -> list[str]:
    return [n.func.id for n in ast.walk(node) if isinstance(n, ast.Call) and isinstance(n.func, ast.Name)]


def test_dp5_and_rodas4_share_one_loop():
    # the methods' modules hold their steps only: no loop over time, no output, no event; each builds its
    # run by the one loop of adaptive.py
    loop_parts = {"_store", "_locate", "_log_event", "_interp", "_f_call"}
    for name in ("dp5.py", "rosenbrock.py"):
        tree = _tree(name)
        assert not any(isinstance(n, ast.While) for n in ast.walk(tree)), name
        assert not loop_parts & set(_called(tree)), name
        assert _called(tree).count("_adaptive_for") == 1, name
    loop = _tree("adaptive.py")
    assert sum(isinstance(n, ast.While) for n in ast.walk(loop)) == 2  # the steps, the samples of a step
    assert loop_parts <= set(_called(loop))

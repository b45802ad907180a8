"""A first run compiles each transient kernel once, and as little of it as it must (issue #27's cold start).

numba's IR-level inlining (``inline="always"``) copies a helper's whole body into every call site before
type inference and the parallel-loop passes: each copy of the right-hand side (the contact force of
eq. 4) cost seconds of compile time on a first run. Measured with ``benchmarks/bench_compile.py``
(CPU seconds, empty cache): the Dormand-Prince kernel 28.8-33.6 s with the right-hand side inlined at four
sites, about 17 s with it inlined at one, the same run time. The structural tests below read the
source (``ast``; nothing is compiled), so a new inlined call site is caught before a first run pays
for it. The last test checks that the report's transient runs call the integrator with the types the
warm-up child compiles (``squealkit._warmup``): otherwise the report compiles it a second time.
"""

from __future__ import annotations

import ast
import inspect
from pathlib import Path

import numba
import numpy as np
import pytest

from squealkit.models import get_preset
from squealkit.solvers import ode
from squealkit.transient import Contact, SineRunOut, simulate

_SOURCE = Path(inspect.getfile(ode))
#: every function of the integrators, by name: the modules of the package ``solvers/ode/`` (or the one module)
FUNCS = {node.name: node
         for path in (sorted(_SOURCE.parent.glob("*.py")) if _SOURCE.name == "__init__.py" else [_SOURCE])
         for node in ast.parse(path.read_text(encoding="utf-8")).body if isinstance(node, ast.FunctionDef)}


def _calls(func: str, callee: str) -> int:
    return sum(1 for node in ast.walk(FUNCS[func])
               if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == callee)


def _inlined(func: str) -> bool:
    for deco in FUNCS[func].decorator_list:
        if isinstance(deco, ast.Call):
            for kw in deco.keywords:
                if kw.arg == "inline" and isinstance(kw.value, ast.Constant) and kw.value.value == "always":
                    return True
    return False


@pytest.mark.parametrize(("step", "sites"), [("_dp5_step", 1), ("_rodas4_step", 2)])
def test_each_integrator_inlines_its_right_hand_side_once_per_loop(step, sites):
    # DP5: its stages and FSAL stage in one loop; Rodas4: f, f(t + dt), f(t - dt) in one loop, its
    # stages in another (before the loops were one: 4 and 6 sites). The step is the method's part of
    # the shared loop (adaptive.py), compiled once and called (not inlined: it is compiled without
    # reference counts), where the first sample of a chunk and the dense output call the compiled-once _f_call
    assert _inlined("_f") and _inlined("_rhs")
    assert not _inlined(step)
    assert _calls(step, "_f") == sites
    assert _calls("_adaptive_for", "_f") == 0
    assert _calls("_adaptive_for", "_f_call") == 2
    assert not _inlined("_f_call")


@pytest.mark.parametrize("helper", ["_store", "_dense", "_dense_ros", "_log_event", "_locate", "_f_call", "_bundle"])
def test_helpers_of_the_output_and_the_events_are_compiled_once(helper):
    # called per output sample or per event, not per stage: a call costs nothing measurable there
    assert not _inlined(helper)


def _kernel_types(monkeypatch, run) -> tuple:
    """The numba types of the arguments ``run()`` passes to the Dormand-Prince kernel (which is not run)."""
    seen = []

    class Stop(Exception):
        pass

    def spy(*args):
        seen.append(tuple(numba.typeof(a) for a in args))
        raise Stop

    monkeypatch.setattr(ode, "integrate_adaptive", spy)
    with pytest.raises(Stop):
        run()
    return seen[0]


def test_the_report_calls_the_integrator_the_warm_up_child_compiled(monkeypatch):
    # reference: the warm-up child's call (_warmup's transient group) and the report's transient runs
    # (report/steps_transient.py: smooth disc with a perturbation, sine run-out; steps_nonlinear.py: the
    # contact law that may open), all at the paper's settings
    import sys

    from squealkit import _warmup

    # the child sets its stand-in for the eigenvalues in the transient modules that call them: put them back after
    for name, module in list(sys.modules.items()):
        if name.startswith("squealkit.transient") and hasattr(module, "eigenvalues"):
            monkeypatch.setattr(module, "eigenvalues", module.eigenvalues)
    child = _kernel_types(monkeypatch, _warmup._transient)
    model = get_preset("lv2013")
    runs = {
        "smooth": lambda: simulate(model, mu=0.4, speed=0.02, duration=1e-3, perturbation=1e-9,
                                   rng=np.random.default_rng(2013)),
        "run-out": lambda: simulate(model, mu=0.4, profile=SineRunOut(0.08e-3, 1e-3), speed=0.02, duration=1e-3),
        "contact loss": lambda: simulate(model, mu=0.4, profile=SineRunOut(0.08e-3, 1e-3), speed=0.02,
                                         duration=1e-3, contact=Contact.nonlinear()),
    }
    for name, run in runs.items():
        assert _kernel_types(monkeypatch, run) == child, name

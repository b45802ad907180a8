"""Issue #28: no module over ~800 lines unless it is one algorithm; the split modules keep every old import.

The limit and the old paths are the reference: issue #28's "done when" list, and the names
``squealkit.transient.simulate`` held before it was split (read from its ``__all__`` and its
module-level constants at the commit before the split).
"""

from __future__ import annotations

import importlib
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "squealkit"


@pytest.mark.parametrize("folder", ["transient", "solvers/small"])
def test_no_module_over_800_lines(folder):
    long = {p.relative_to(SRC).as_posix(): n for p in sorted((SRC / folder).rglob("*.py"))
            if (n := len(p.read_text(encoding="utf-8").splitlines())) > 800}
    assert long == {}


#: what ``from squealkit.transient.simulate import ...`` gave before the split: its ``__all__`` and constants
_SIMULATE_NAMES = ("AliasingWarning", "TensileContactWarning", "response_envelope", "simulate", "simulate_batch",
                   "simulate_blocks", "step_bound", "transient_summary", "METHODS", "STEP_FACTOR",
                   "STABILITY_FACTOR", "DOPRI_OMEGA_FACTOR", "BLOCK_SAMPLES", "SUMMARY_STAGE_SAMPLES")


def test_the_old_simulate_module_path_still_has_its_names():
    import squealkit.transient as package

    module = importlib.import_module("squealkit.transient.simulate")
    for name in _SIMULATE_NAMES:
        assert hasattr(module, name), name
    for name in package.__all__:  # the package's names are the module's where both have them
        if hasattr(module, name):
            assert getattr(package, name) is getattr(module, name), name
    from squealkit.transient import simulate

    assert callable(simulate) and simulate is module.simulate  # the package's attribute is the function
    assert module.METHODS == ("dopri5", "rosenbrock", "rk4") and module.STEP_FACTOR == 0.25


#: what ``from squealkit.solvers.small import ...`` gave the analyses and the warm-up before it became a package,
#: split (issue #28) between the engine (the roots and their error radii: solvers/small) and the analysis' reading
#: of them (verdicts, one root per mode, unstable flags, lock-in: stability/_verdicts.py, was solvers/small/modes.py)
_ENGINE_NAMES = ("charpoly_table", "inclusion_radii", "permutations_table", "quadratic_eigvals",
                 "quadratic_eigvals_stack", "_radii_range")
_ANALYSIS_NAMES = ("DIVERGENCE", "FLUTTER", "INDETERMINATE", "STABLE", "UNDECIDED", "ZERO_ROOT_REACH", "VERDICTS",
                   "classify_points", "derived_quantities", "select_modes", "_REAL_RTOL", "_locked_in")


def test_the_small_kernels_are_split_between_engine_and_analysis():
    small = importlib.import_module("squealkit.solvers.small")
    verdicts = importlib.import_module("squealkit.stability._verdicts")
    old = importlib.import_module("squealkit.stability._kernels")  # the private path of the one old module
    for name in _ENGINE_NAMES:
        assert hasattr(small, name) and getattr(old, name) is getattr(small, name), name
    for name in _ANALYSIS_NAMES:
        assert not hasattr(small, name), name  # the engine speaks no analysis vocabulary
        assert hasattr(verdicts, name), name
        if name != "VERDICTS":
            assert getattr(old, name) is getattr(verdicts, name), name
    assert not (SRC / "solvers" / "small" / "modes.py").exists()
    from squealkit.stability import VERDICTS

    assert VERDICTS is verdicts.VERDICTS and VERDICTS[verdicts.FLUTTER] == "flutter"

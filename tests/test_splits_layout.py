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


#: what ``from squealkit.solvers.small import ...`` gave the analyses and the warm-up before it became a package
_SMALL_NAMES = ("DIVERGENCE", "FLUTTER", "INDETERMINATE", "STABLE", "UNDECIDED", "ZERO_ROOT_REACH", "charpoly_table",
                "classify_points", "derived_quantities", "inclusion_radii", "permutations_table", "quadratic_eigvals",
                "quadratic_eigvals_stack", "select_modes", "_radii_range", "_REAL_RTOL", "_locked_in")


def test_the_small_kernels_keep_their_import_path():
    small = importlib.import_module("squealkit.solvers.small")
    for name in _SMALL_NAMES:
        assert hasattr(small, name), name
    from squealkit.solvers.small import modes, roots

    assert small.classify_points is modes.classify_points and small.quadratic_eigvals is roots.quadratic_eigvals

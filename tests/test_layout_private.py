"""The tests use squealkit's public API, not its private names (issue #28, "the tests stop importing private names").

A test that imports ``squealkit.x._y`` (or ``from squealkit._x import y``, or reaches ``module._y`` of a squealkit
module it imported) breaks whenever the inside of a module is rearranged, and hides that a user cannot do what
the test does. Every ``.py`` file under ``tests/`` is read (its ``ast``; nothing of it is run) for:

- ``from squealkit... import name`` and ``import squealkit...`` with a private part (``_x``, not ``__x__``);
- ``alias._y`` where ``alias`` is a squealkit module or object the file imported;
- code in strings run by a child process (``"from squealkit._x import y"``) and a dotted name given whole as a
  call's first argument (``monkeypatch.setattr("squealkit.x._y", ...)``, ``importlib.import_module(...)``).

The few exceptions are in :data:`ALLOWED`, each with its reason: tests of an internal step against an independent
reference that no public call isolates (a compiled kernel against NumPy, a reader's byte-level helper), the
CLI's option registry that the naming test is about, and files other work owns. The finder is checked on
planted code first.
"""

from __future__ import annotations

import ast
import importlib
import inspect
import pkgutil
import re
import warnings
from pathlib import Path

TESTS = Path(__file__).resolve().parent

#: Test file (relative to tests/) -> private squealkit names it may use: an entry covers the name and what is
#: inside it (``"squealkit._warmup"`` covers ``squealkit._warmup.start``). Keep it short; each needs its reason.
ALLOWED: dict[str, tuple[str, ...]] = {
    # pytest's hook keeps the report's warm-up child out of the suite: test infrastructure, not a user's call
    "conftest.py": ("squealkit._warmup",),
    # owned by the warm-up and transient work of issue #28 (not edited here); the lead settles them at merge
    "test_warmup.py": ("squealkit._warmup", "squealkit.stability._schema", "squealkit.stability._solve",
                       "squealkit.stability._verdicts", "squealkit.transient._step", "squealkit.transient._result"),
    # which compiled kernels the warm-up child compiles (their dispatchers' signatures) and which stay in
    # numba's on-disk cache from one process to the next: the kernels themselves are the subject
    "test_warmup_stability.py": ("squealkit._warmup", "squealkit.stability.tracking._track_column",
                                 "squealkit.stability.tracking._track_rows", "squealkit.stability.tracking._carry",
                                 "squealkit.stability._verdicts", "squealkit.solvers.small._radii_range"),
    # the small-model kernels split between the engine (roots) and the analysis (verdicts): the paths are the subject
    "test_splits_layout.py": ("squealkit.stability._verdicts", "squealkit.stability._kernels"),
    # the one operating point the report and its warm-up child share (issue #28: was an import circle)
    "test_layout_circles.py": ("squealkit._operating_point",),
    # the compiled loops a cached kernel carries inside it: only their dispatchers tell they were not compiled
    "test_kernel_cache.py": ("squealkit.solvers.ode._sampled_monodromy", "squealkit.solvers.ode.dp5._dp5_run",
                             "squealkit.solvers.ode.rk4._rk4_run"),
    "test_transient_rosenbrock.py": ("squealkit.solvers.ode._rhs", "squealkit.solvers.ode._jacobian"),
    # the integrator's chunk sizes cut small, so that a short run crosses several compiled calls (a streamed run
    # equals the one-shot run bit for bit; memory bounded by a chunk): no public call sets them
    "test_transient_simulate.py": ("squealkit._validation", "squealkit.transient._driver"),
    # the naming test checks the CLI's one option registry itself (the CLI has no Python API)
    "test_naming.py": ("squealkit.cli._options",),
    # the exact moment of a second signal during the clean-up can only be placed by calling the CLI's handler
    "test_output_safety.py": ("squealkit.cli.main._on_signal",),
    # a machine with little memory, simulated where squealkit asks the OS; the budget rule on its own
    "test_faults.py": ("squealkit._validation.available_memory",),
    # the perturbation estimate's internal steps (state-space eigenvalues, exact first and second derivatives
    # of the reduced pencil) against central differences of LAPACK eigenvalues; the result only holds moments
    # the rule that drops parallel band walks when memory is short, checked at the cap where one fits and two do not
    "test_fe_scale.py": ("squealkit.solvers.band._walks_that_fit",),
    "test_design_robust.py": ("squealkit.design.robust._fe_setup", "squealkit.design._pencil._linear_matrices",
                              "squealkit.design.perturbation._second_order_derivatives",
                              "squealkit.design._pencil._state_eigvals", "squealkit.design._scatter._uncertain"),
    "test_refusals.py": ("squealkit._validation.check_budget", "squealkit._validation.MAX_POINTS",
                         "squealkit.nonlinear.continuation._sample"),
    # the CLI's range grammar under hypothesis (thousands of examples; through the CLI each costs a command)
    "test_properties.py": ("squealkit._validation.parse_range",),
    # internal steps against independent references (NumPy, lfilter, mpmath, closed forms)
    "test_measurement_analysis.py": ("squealkit.measurement.analysis.kernels._",
                                     "squealkit.measurement.analysis.components._rows"),
    "test_measurement_criteria.py": ("squealkit.measurement.squeal.events._",),
    "test_measurement_readers.py": ("squealkit.measurement.formats._common",),
    "test_measurement_tacho.py": ("squealkit.measurement.analysis.framing._DatasetSource",
                                  "squealkit.measurement.signal.tacho._"),
    "test_user_inputs.py": ("squealkit.measurement.analysis.framing._DatasetSource",),
    # the one sample-rate estimate: the streaming fit against a one-shot least squares, block sizes no file
    # of a test's size reaches; an in-memory recording's rate, which only the analysis takes
    # how the report reads a limit-cycle branch that folds (along its arclength), against interpolation by hand:
    # a folding branch is built by hand, no public call reaches these readers without a whole report;
    # and the one check whether an optional package is there and imports (squealkit._optional.available)
    "test_leftovers_fold_slope.py": ("squealkit._optional.available", "squealkit.report.steps_nonlinear._at",
                                     "squealkit.report.steps_nonlinear._cycles_at",
                                     "squealkit.report.steps_nonlinear._fold_text",
                                     "squealkit.report.steps_nonlinear._segments"),
    "test_leftovers_fs.py": ("squealkit.measurement.formats._common",
                             "squealkit.measurement.analysis.framing._DatasetSource"),
    "test_nonlinear.py": ("squealkit.nonlinear.harmonic_balance._Basis",
                          "squealkit.nonlinear.continuation._enough_harmonics"),
    "test_vocabulary.py": ("squealkit.nonlinear.continuation._old_or_new",),
    "test_smaller_27.py": ("squealkit.stability._solve", "squealkit._threads.honour_thread_limit"),
    # the thread bound's BLAS controller when a BLAS library loads after the first bounded call: every public
    # entry point's import loads scipy.linalg first, so only the decorator itself can make that call first
    "test_done_when_28.py": ("squealkit._threads.honour_thread_limit",),
    "test_stability_ensemble.py": ("squealkit.stability._windows",),
    "test_stribeck.py": ("squealkit.solvers.ode._rhs",),
    "test_threads.py": ("squealkit.stability.eigen._solve_block",
                        # a BLAS loaded after the first bounded call: needs the decorator before scipy.linalg
                        "squealkit._threads"),
    "test_report.py": ("squealkit.report.steps_stability._tolerance_text",),
    "test_report_own_rig.py": ("squealkit.report.steps_transient._fig4_text",
                               "squealkit.report.steps_nonlinear._settle_text"),
    # the warm-up child's call of the integrator against the report's: the child is the subject
    "test_coldstart_kernels.py": ("squealkit._warmup",),
    # the harmonic-balance residual recomputed from a branch's stored coefficients on a finer time grid (the
    # independent check that every cycle returned solves harmonic balance): the AFT basis is the subject
    "test_continuation_robust.py": ("squealkit.nonlinear.harmonic_balance._Basis",),
    # the adaptive integrators' golden cases cross chunks in a short run: the driver's chunk sizes made small
    "golden/make_golden_ode_loop.py": ("squealkit.transient._driver",),
    # the optional-package table and require(): the static check that every optional import goes through it
    "test_optional_dependencies.py": ("squealkit._optional",),
}


def _private(part: str) -> bool:
    return part.startswith("_") and not (part.startswith("__") and part.endswith("__"))


def _first_private(dotted: str) -> str | None:
    """``dotted`` cut after its first private part, or None if it has none."""
    parts = dotted.split(".")
    for i, part in enumerate(parts):
        if _private(part):
            return ".".join(parts[:i + 1])
    return None


_DOTTED = re.compile(r"squealkit(\.\w+)+")


def private_names(source: str) -> list[tuple[int, str]]:
    """(line, dotted name) of each private squealkit name the Python ``source`` uses, in order.

    A name is cut after its first private part (``squealkit._validation``, ``squealkit.io._state``), or is
    the whole imported name (``squealkit._validation.InputError``) for an import from a private module.
    """
    tree = ast.parse(source)
    found: list[tuple[int, str]] = []
    bound: dict[str, str] = {}  # local name -> the squealkit name it stands for
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.level == 0 and (node.module or "").split(".")[0] == "squealkit":
            for alias in node.names:
                full = f"{node.module}.{alias.name}"
                if _first_private(full):
                    found.append((node.lineno, full))
                bound[alias.asname or alias.name] = full
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.split(".")[0] != "squealkit":
                    continue
                if _first_private(alias.name):
                    found.append((node.lineno, alias.name))
                if alias.asname:
                    bound[alias.asname] = alias.name
                else:
                    bound["squealkit"] = "squealkit"
        elif isinstance(node, ast.Call) and node.args and isinstance(node.args[0], ast.Constant) \
                and isinstance(node.args[0].value, str) and _DOTTED.fullmatch(node.args[0].value):
            # monkeypatch.setattr("squealkit.x._y", ...), importlib.import_module("squealkit._x"), mock.patch(...)
            if _first_private(node.args[0].value):
                found.append((node.lineno, node.args[0].value))
        elif isinstance(node, ast.Constant) and isinstance(node.value, str) and "squealkit" in node.value:
            text = node.value.strip()
            if "import" in text and not _DOTTED.fullmatch(text):  # code run by a child process
                try:
                    inner = private_names(text)
                except SyntaxError:
                    inner = []
                found += [(node.lineno, name) for _, name in inner]
    for node in ast.walk(tree):
        if not isinstance(node, ast.Attribute):
            continue
        chain, base = [], node
        while isinstance(base, ast.Attribute):
            chain.append(base.attr)
            base = base.value
        if isinstance(base, ast.Name) and base.id in bound and not _first_private(bound[base.id]):
            cut = _first_private(".".join([bound[base.id], *reversed(chain)]))
            if cut is not None:
                found.append((node.lineno, cut))
    return sorted(set(found))


def _allowed(name: str, entries: tuple[str, ...]) -> bool:
    return any(name == e or name.startswith(e if e.endswith("_") else e + ".") for e in entries)


def _public_path(name: str) -> str | None:
    """Where the object a private ``name`` stands for is public, if anywhere: the ``__all__`` of a public
    package above it, or of a public top-level module or package of squealkit."""
    import squealkit

    head, _, attr = name.rpartition(".")
    parts = name.split(".")
    ancestors = [".".join(parts[:i]) for i in range(1, len(parts)) if not any(map(_private, parts[1:i]))]
    top = [f"squealkit.{m.name}" for m in pkgutil.iter_modules(squealkit.__path__) if not _private(m.name)]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # a moved module's shim: not a place to point to
        try:
            obj = getattr(importlib.import_module(head), attr)
        except (ImportError, AttributeError, ValueError):
            return None
        if inspect.ismodule(obj):
            return None
        for modname in dict.fromkeys([*reversed(ancestors), *top]):
            if modname == "squealkit.cli":
                continue
            try:
                mod = importlib.import_module(modname)
            except ImportError:  # an optional dependency missing
                continue
            for public in getattr(mod, "__all__", ()):
                if getattr(mod, public, None) is obj:
                    return f"{modname}.{public}"
    return None


def _test_files() -> list[Path]:
    """Every Python file under tests/ but this one (whose ALLOWED and planted code name private names as data)."""
    here = Path(__file__).resolve()
    return sorted(p for p in TESTS.rglob("*.py") if "__pycache__" not in p.parts and p.resolve() != here)


# -- the finder, on planted code -----------------------------------------------------------------


def test_the_finder_finds_every_form_of_private_use_and_nothing_public():
    planted = '''
import squealkit
import squealkit.io as sio
import squealkit._threads
from squealkit import InputError, io, _validation
from squealkit._units import parse_quantity
from squealkit.io import _state, atomic_path
from squealkit.stability import stability_map
import numpy._core  # not squealkit

io._interrupted.clear()
sio.note_interrupt()
squealkit.__version__
squealkit._accessor.result_kind
stability_map._cache
atomic_path.__wrapped__
code = "import sys\\nfrom squealkit._validation import InputError\\n"
monkeypatch.setattr("squealkit.measurement.formats._common._head", None)
text = "see squealkit._validation for the validators"
modules = ["squealkit._warmup", "squealkit.io"]
'''
    got = private_names(planted)
    assert got == sorted([
        (4, "squealkit._threads"), (5, "squealkit._validation"), (6, "squealkit._units.parse_quantity"),
        (7, "squealkit.io._state"), (11, "squealkit.io._interrupted"), (14, "squealkit._accessor"),
        (15, "squealkit.stability.stability_map._cache"), (17, "squealkit._validation.InputError"),
        (18, "squealkit.measurement.formats._common._head"),
    ])


def test_allowed_entries_cover_a_name_and_what_is_inside_it_only():
    assert _allowed("squealkit._warmup.start", ("squealkit._warmup",))
    assert not _allowed("squealkit._warmup_extra", ("squealkit._warmup",))
    assert _allowed("squealkit.measurement.analysis.kernels._bin_powers", ("squealkit.measurement.analysis.kernels._",))
    assert not _allowed("squealkit._validation.InputError", ("squealkit._validation.parse_range",))


def test_the_public_path_of_a_private_import_is_named():
    assert _public_path("squealkit._validation.InputError") == "squealkit.InputError"
    assert _public_path("squealkit.io._datasets.save_dataset") == "squealkit.io.save_dataset"


# -- the tests themselves --------------------------------------------------------------------------


def test_no_test_imports_a_private_squealkit_name():
    problems = []
    for path in _test_files():
        rel = path.relative_to(TESTS).as_posix()
        entries = ALLOWED.get(rel, ())
        for line, name in private_names(path.read_text(encoding="utf-8")):
            if _allowed(name, entries):
                continue
            public = _public_path(name)
            fix = (f"import it as {public}" if public else
                   "test it through the public API, make it public (documented on a docs/api page), or, for an "
                   f"internal step only a test can reach, add {_first_private(name)!r} to ALLOWED[{rel!r}] in "
                   "tests/test_layout_private.py with the reason")
            problems.append(f"tests/{rel}:{line} uses the private name {name}: {fix}")
    assert not problems, "\n".join(problems)


def test_every_allowed_name_is_still_used():
    stale = []
    for rel, entries in sorted(ALLOWED.items()):
        path = TESTS / rel
        used = [name for _, name in private_names(path.read_text(encoding="utf-8"))] if path.is_file() else []
        stale += [f"ALLOWED[{rel!r}] lists {e!r}, which tests/{rel} no longer uses: remove it"
                  for e in entries if not any(_allowed(n, (e,)) for n in used)]
    assert not stale, "\n".join(stale)

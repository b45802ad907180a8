"""Issue 28, "Done when", checked mechanically: each test below walks the whole public API, the
whole CLI, every documentation page, every example or every module, so a name, option, result,
page or module added later is held to the same rule. Each rule failed on main for the gap named.

- Names: ``omega`` never names the disc speed, on public methods too (``solvers.reduction`` took
  ``omegas``/``omega`` [rad/s] of the disc); ``tan_theta`` keyword-only in every public module
  (``fe.energy.friction_parts`` took it fourth).
- CLI flags: one ``--on/--off`` pair and one default per flag across commands (``--damped`` was
  checked as a flag only: a command with ``--damped`` off by default, or ``--no-damped``, passed).
- Results: every public function returning a Dataset is registered here and its result follows
  the shared schema (``kind`` one of ``RESULT_KINDS``, ``*_hz`` frequencies, ``theta`` in rad...);
  correlate's results had no registered kind and ``band_lo``/``band_hi`` in Hz.
- Docs: every package name and every result producer is on a task page (docs/api/*.md), every
  callable there documents its parameters, every function the README and the guide teach (also by
  a dotted path in prose) is public and has its page: read from the autosummary tables without
  building the site (tests/test_docs.py builds it, slow). The gallery runs every example.
- The developer guide names every package and only module paths that exist (design/ was "planned").
- No module over 800 lines (nonlinear/continuation.py had 878); every numba kernel is cached on
  disk (compiled once per run); property tests draw through hypothesis, not seeded loops.
"""

from __future__ import annotations

import functools
import importlib
import importlib.util
import inspect
import re
from pathlib import Path

import click
import pytest

from test_api_docs import public_methods, public_objects
from test_naming import naming_problems

ROOT = Path(__file__).resolve().parents[1]


# -- names: inputs of methods too; omega never the disc speed ----------------------------------------


def test_public_inputs_never_call_the_disc_speed_omega():
    """The conventions (docs/api.md): ``omega`` is an eigen (circular) frequency [rad/s]; the disc
    speed is ``disc_speed`` [rad/s] or ``rpm``. Functions and methods alike."""
    objs = {**public_objects(), **public_methods()}
    problems = [msg for name, obj in sorted(objs.items()) for msg in naming_problems(name, obj)]
    assert not problems, "\n".join(problems)


def test_the_omega_rule_catches_a_disc_speed_named_omega():
    def f(omega, mu):
        """Sketch.

        Parameters
        ----------
        omega : float
            Disc speed [rad/s].
        mu : float
            Friction coefficient.
        """

    def g(omega):
        """Sketch.

        Parameters
        ----------
        omega : float
            Initial guess of the angular frequency [rad/s].
        """

    assert naming_problems("f", f) == ["f(omega=): the disc speed is disc_speed [rad/s] (or rpm), never omega"]
    assert naming_problems("g", g) == []  # an eigen/angular frequency keeps its name


def test_reduction_takes_the_disc_speed_by_its_name_and_the_old_one_warns():
    import numpy as np
    import scipy.sparse as sp

    from squealkit.fe import FEModel
    from squealkit.solvers import pod_basis, reduce, reduced_eigs, reduced_sweep

    # two doublets coupled by friction (KR), lightly damped: a 4-DOF model, LAPACK throughout
    w = 2 * np.pi * np.array([1000.0, 1000.0, 1200.0, 1200.0])
    KR = sp.lil_matrix((4, 4))
    KR[0, 2], KR[2, 0] = 3e7, -3e7
    m = FEModel.from_matrices(M=sp.eye(4), K1=sp.diags(w**2), KR=KR.tocsr(), D1=sp.diags(1e-4 * w))
    band = (500.0, 2000.0)
    V = pod_basis(m, disc_speeds=[10.0], mus=[0.0, 0.5], band=band)
    with pytest.warns(DeprecationWarning, match=r"pod_basis\(omegas=\.\.\.\) is deprecated; use disc_speeds="):
        np.testing.assert_array_equal(pod_basis(m, omegas=[10.0], mus=[0.0, 0.5], band=band), V)
    red = reduce(m, V)
    new = reduced_eigs(red, disc_speed=10.0, mu=0.4, band=band)
    with pytest.warns(DeprecationWarning, match="disc_speed="):
        old = reduced_eigs(red, omega=10.0, mu=0.4, band=band)
    np.testing.assert_array_equal(old["eigenvalue"], new["eigenvalue"])
    ds = reduced_sweep(red, disc_speeds=[10.0, 20.0], mus=[0.0, 0.5], band=band)
    with pytest.warns(DeprecationWarning, match="disc_speeds="):
        assert reduced_sweep(red, omegas=[10.0, 20.0], mus=[0.0, 0.5], band=band).identical(ds)
    np.testing.assert_array_equal(ds.disc_speed.values, [10.0, 20.0])


# -- CLI flags: one on/off pair and one default per flag --------------------------------------------


def _commands():
    from squealkit.cli.main import cli

    ctx = click.Context(cli)
    return [(name, cli.get_command(ctx, name)) for name in cli.list_commands(ctx)]


def flag_problems(commands) -> list[str]:
    """A flag option (``--damped``) spelled with different off-switches (``--undamped``,
    ``--no-damped``) or with different defaults in different commands."""
    seen: dict[str, tuple[str, tuple[str, ...], object]] = {}
    problems = []
    for cmd_name, cmd in commands:
        for p in cmd.params:
            if not isinstance(p, click.Option) or p.hidden or not p.is_flag:
                continue
            key = p.opts[0]
            now = (cmd_name, tuple(p.secondary_opts), p.default)
            first = seen.setdefault(key, now)
            if now[1:] != first[1:]:
                problems.append(f"{cmd_name} {key}: off-switch {now[1]} default {now[2]!r}; "
                                f"{first[0]} has {first[1]} default {first[2]!r}")
    return problems


def test_cli_flags_have_one_off_switch_and_one_default_everywhere():
    commands = _commands()
    assert not flag_problems(commands), "\n".join(flag_problems(commands))
    # the case: --damped (on) with --undamped to turn it off, in every command with damping
    damped = {n for n, c in commands for p in c.params if "--damped" in getattr(p, "opts", ())}
    assert {"stability", "critical", "modes", "floquet", "montecarlo", "tolerance"} <= damped


def test_the_flag_check_catches_a_breach():
    @click.command()
    @click.option("--damped/--undamped", default=True)
    def a(**kw):
        pass

    @click.command()
    @click.option("--damped", is_flag=True, default=False)  # off by default, no off-switch
    def b(**kw):
        pass

    assert flag_problems([("a", a), ("b", b)]) == ["b --damped: off-switch () default False; a has "
                                                   "('--undamped',) default True"]


# -- results: every public function returning a Dataset follows the one schema ------------------------


def every_public_module():
    """Every module a user may import: no part of its path private, not the CLI (documented from its
    commands), not a moved module's shim; the modules inside packages too (``squealkit.transient.floquet``)."""
    import pkgutil

    import squealkit

    yield squealkit
    for info in pkgutil.walk_packages(squealkit.__path__, "squealkit."):
        parts = info.name.split(".")[1:]
        if any(p.startswith("_") for p in parts) or parts[0] == "cli":
            continue
        origin = importlib.util.find_spec(info.name).origin
        if Path(origin).read_text(encoding="utf-8").startswith('"""Moved to '):
            continue  # a moved module's shim (importing it warns by design)
        yield importlib.import_module(info.name)


@functools.cache
def dataset_producers() -> set[str]:
    """Names of the public functions (in any public module's ``__all__``) whose numpydoc Returns is
    a Dataset or DataArray."""
    docscrape = pytest.importorskip("numpydoc.docscrape")
    out = set()
    for mod in every_public_module():
        for name in getattr(mod, "__all__", ()):
            obj = getattr(mod, name)
            if not inspect.isfunction(obj):
                continue
            doc = docscrape.NumpyDocString(inspect.getdoc(obj) or "")
            returns = " ".join(p.type or p.name for p in doc["Returns"])
            if "Dataset" in returns or "DataArray" in returns:
                out.add(name)
    return out


#: Dataset-returning public functions that return no result of their own, and why.
NOT_RESULTS = {
    "load_dataset": "returns the result it loads (saved with its kind: tests/test_io.py)",
    "upgrade_result": "gives an older file the current names and kind (tests/test_vocabulary.py)",
    "lazy_template": "scale: the lazy frame of another function's result (simulate_batch's)",
    "stream_to_zarr": "scale: streams another function's result (simulate_batch's) into zarr",
    "read_recording": "a recording: measured channels, the analyses' input",
    "recording_dataset": "a recording: measured channels, the analyses' input",
    "synthetic_recording": "a SYNTHETIC recording: the analyses' input",
    "campaign_conditions": "a campaign's test conditions read from its store: correlate's input",
    "operating_points": "test conditions mapped to model inputs: predict_modes' input",
    "spectrogram": "a signal-processing primitive (a DataArray over time and freq, as scipy.signal's)",
    "response_envelope": "a DataArray of one signal's envelope (transient_summary's step)",
}

#: Results checked where a fixture already computes them (a campaign, an FE brake with its mesh:
#: seconds each): the file and test that check them with the same schema_problems.
CHECKED_ELSEWHERE = {
    **{name: ("test_correlate.py", "test_correlation_results_follow_the_result_schema")
       for name in ("correlate", "match_modes", "predict_modes", "measured_components")},
    "mode_surface": ("test_fe_seeing.py", "test_energy_and_surface_results_follow_the_schema_and_draw_themselves"),
}


@pytest.fixture(scope="module")
def small_fe():
    """Three doublets, the first two coupled by friction (KR): a flutter onset near mu = 0.3."""
    import numpy as np
    import scipy.sparse as sp

    from squealkit.fe import FEModel

    w = 2 * np.pi * np.array([1000, 1000, 1200, 1200, 5000, 5000.0])
    KR = sp.lil_matrix((6, 6))
    KR[0, 2], KR[2, 0] = 3e7, -3e7
    return FEModel.from_matrices(M=sp.eye(6), K1=sp.diags(w**2), KR=KR.tocsr(), D1=sp.diags(1e-4 * w))


@pytest.fixture(scope="module")
def recording():
    from squealkit.measurement import analyze_recording, synthetic_recording

    rec = synthetic_recording(duration=0.5, seed=1)
    return rec, analyze_recording(rec, mic="mic", displacement="displacement", rpm=900.0, radius=0.05)


def _lv():
    from squealkit.models import get_preset

    return get_preset("lv2013")


def _result_cases(small_fe, recording):
    """Producer name -> a call on small inputs (each well under a second once compiled)."""
    import numpy as np

    from squealkit import design, fe, nonlinear, solvers, stability, transient, uncertainty
    from squealkit.measurement.analysis import views
    from squealkit.transient.floquet import floquet_map

    lv, rec, res = _lv(), *recording
    fe_modes = stability.fe_modes(small_fe, 100.0, 0.5)

    def reduced():
        V = solvers.pod_basis(small_fe, [10.0], [0.0, 0.5], band=(500.0, 6000.0))
        return solvers.reduced_sweep(solvers.reduce(small_fe, V), [10.0, 20.0], [0.0, 0.5], band=(500.0, 6000.0))

    def branch():
        return nonlinear.limit_cycle_branch(lv, (0.3, 0.5), harmonics=3, n_points=4, check_harmonics=False)

    def branch_slope():
        # the paper's rig squeals from tan(theta) = mu_c - mu: at mu = 0.3 below the flat-disc onset
        mu_c = stability.critical_friction(lv, 0.0, damped=False).mu_critical
        return nonlinear.limit_cycle_branch_slope(lv, (0.0, 0.2), mu=mu_c - 0.05, harmonics=3, n_points=4,
                                                  check_harmonics=False)

    P = {"friction": "KR", "pad": "K1"}
    return {
        "stability_map": lambda: stability.stability_map(lv, [0.2, 0.6], np.radians([0.0, 2.0]), damped=False),
        "modes": lambda: stability.modes(lv, 0.5, 0.0, damped=False),
        "onset_modes": lambda: stability.onset_modes(lv, damped=False),
        "eigenvalue_sensitivity": lambda: stability.eigenvalue_sensitivity(lv, 0.5, 0.0, "k3", damped=False),
        "critical_friction_curve": lambda: stability.critical_friction_curve(lv, np.radians([0.0, 2.0]),
                                                                             damped=False),
        "fe_stability_map": lambda: stability.fe_stability_map(small_fe, [100.0, 200.0], [0.0, 0.5]),
        "fe_modes": lambda: fe_modes,
        "fe_critical_friction": lambda: stability.fe_critical_friction(small_fe, [100.0], mu_max=1.0),
        "reduced_sweep": reduced,
        "mode_energy": lambda: fe.mode_energy(small_fe, fe_modes),
        "eigen_derivatives": lambda: design.eigen_derivatives(small_fe, P, 100.0, 0.5),
        "countermeasures": lambda: design.countermeasures(small_fe, P, 100.0, 0.5),
        "doe_sweep": lambda: design.doe_sweep(small_fe, P, {"friction": [0.9, 1.1]}, 100.0, 0.5,
                                              band=(500.0, 6000.0)),
        "robust_margins": lambda: design.robust_margins(lv, mu=0.1, scatter={"k3": 0.05}, samples=8,
                                                        method="montecarlo", damped=False),
        "simulate": lambda: transient.simulate(lv, mu=0.4, profile=transient.SineRunOut(0.08e-3, 1e-3),
                                               duration=0.002),
        "simulate_batch": lambda: transient.simulate_batch(lv, mu=[0.3, 0.4], duration=0.002),
        "floquet_map": lambda: floquet_map(lv, mu=[0.2], amplitude=[1e-5], wavelength=1e-3, speed=0.02),
        "limit_cycle_branch": branch,
        "limit_cycle_branch_slope": branch_slope,
        "sound_level": lambda: nonlinear.sound_level(branch(), radiation_factor=400.0, dof="y2"),
        "squeal_propensity": lambda: uncertainty.squeal_propensity(
            lv, {"k1": {"dist": "normal", "mean": 1.0e5, "std": 1.0e3}}, [0.0, 2.0], samples=4, damped=False,
            sensitivity=False),
        "measurement_signals": lambda: views.measurement_signals(rec, res),
        "figure_signals": lambda: views.figure_signals(rec, rpm=900.0),
    }


def test_every_dataset_producer_is_registered():
    """A new public function returning a Dataset is checked below, or says why it returns no result."""
    registered = set(RESULT_CASES) | set(NOT_RESULTS) | set(CHECKED_ELSEWHERE)
    assert dataset_producers() - registered == set(), "register it in RESULT_CASES (or NOT_RESULTS, with why)"
    assert registered - dataset_producers() == set(), "no longer a public Dataset producer"
    for file, test in CHECKED_ELSEWHERE.values():
        text = (ROOT / "tests" / file).read_text(encoding="utf-8")
        body = text.partition(f"def {test}(")[2].partition("\ndef ")[0]
        assert "schema_problems(" in body, (file, test)


RESULT_CASES = ("stability_map", "modes", "onset_modes", "eigenvalue_sensitivity", "critical_friction_curve",
                "fe_stability_map", "fe_modes", "fe_critical_friction", "reduced_sweep", "mode_energy",
                "eigen_derivatives", "countermeasures", "doe_sweep", "robust_margins", "simulate", "simulate_batch",
                "floquet_map", "limit_cycle_branch", "limit_cycle_branch_slope", "sound_level",
                "squeal_propensity", "measurement_signals", "figure_signals")


@pytest.fixture(scope="module")
def result_cases(small_fe, recording):
    return _result_cases(small_fe, recording)


@pytest.mark.parametrize("producer", RESULT_CASES)
def test_every_result_follows_the_schema_and_says_its_kind(result_cases, producer):
    from squealkit.io import RESULT_KINDS, result_kind
    from test_vocabulary import schema_problems

    ds = result_cases[producer]()
    assert schema_problems(ds) == [], producer
    assert ds.attrs["kind"] in RESULT_KINDS and result_kind(ds) == ds.attrs["kind"]


# -- docs: every public name on a task page; what the README and the guide teach is public and there --


@functools.cache
def task_page_entries() -> dict[int, str]:
    """id(object) -> its public path, for every name the task pages (docs/api/*.md) list in an
    autosummary table (each gets its own page under docs/api/generated)."""
    out: dict[int, str] = {}
    for page in sorted((ROOT / "docs" / "api").glob("*.md")):
        module, listing = None, False
        for raw in page.read_text(encoding="utf-8").splitlines():
            line = raw.strip()
            if m := re.match(r"\.\. currentmodule:: ([\w.]+)$", line):
                module, listing = m.group(1), False
            elif line.startswith(".. autosummary::"):
                listing = True
            elif listing and raw.startswith("   ") and line and not line.startswith(":"):
                path = f"{module}.{line}" if module else line
                mod, _, name = path.rpartition(".")
                out[id(getattr(importlib.import_module(mod), name))] = path
            elif listing and line and not raw.startswith("   "):
                listing = False
    return out


def test_every_package_name_is_on_a_task_page():
    """The fast twin of tests/test_docs.py's check on the built site: every name in the ``__all__``
    of squealkit and of its public packages (and top-level and plotting modules) is listed on a task
    page, and every public function returning a result too, wherever its module is."""
    from test_api_docs import _public_modules

    listed = task_page_entries()
    missing = [f"{m.__name__}.{n}" for m in _public_modules() for n in getattr(m, "__all__", ())
               if not n.startswith("__") and id(getattr(m, n)) not in listed]
    missing += [f"{m.__name__}.{n}" for m in every_public_module() for n in getattr(m, "__all__", ())
                if n in dataset_producers() and id(getattr(m, n)) not in listed]
    assert not missing, f"on no task page (docs/api/*.md): {', '.join(sorted(set(missing)))}"
    assert len(listed) > 300


@functools.cache
def _public_paths() -> dict[int, str]:
    out: dict[int, str] = {}
    for mod in every_public_module():
        for name in getattr(mod, "__all__", ()):
            out.setdefault(id(getattr(mod, name)), f"{mod.__name__}.{name}")
    return out


def _public_path(obj) -> str | None:
    """A public path of ``obj``: ``module.name`` with ``name`` in the ``__all__`` of a public module."""
    return _public_paths().get(id(obj))


def taught_references(text: str) -> set[str]:
    """What a Markdown page teaches to call: ``name(`` and ``squealkit.a.b.name(`` in its prose
    (in backticks) and the calls and ``from squealkit... import`` lines of its Python blocks."""
    code = "\n".join(re.findall(r"```python\n(.*?)```", text, flags=re.S))
    prose = re.sub(r"```.*?```", "", text, flags=re.S)
    refs = set(re.findall(r"`((?:squealkit\.)?[\w.]*?\w+)\(", prose))
    refs |= set(re.findall(r"`(squealkit\.[\w.]+)`", prose))
    refs |= set(re.findall(r"(?<![\w.])([A-Za-z_]\w+)\(", code))
    for module, wrapped, names in re.findall(r"^from (squealkit[\w.]*) import (?:\(([^)]*)\)|([\w, ]+))", code,
                                             flags=re.M):
        refs |= {f"{module}.{n.strip()}" for n in (wrapped or names).split(",") if n.strip()}
    return refs


@functools.cache
def _squealkit_objects() -> dict[str, list[object]]:
    """Bare name -> the functions and classes of that name defined anywhere in squealkit."""
    import pkgutil

    import squealkit

    out: dict[str, list[object]] = {}
    for info in pkgutil.walk_packages(squealkit.__path__, "squealkit."):
        origin = importlib.util.find_spec(info.name).origin
        if info.name.startswith("squealkit.cli") or Path(origin).read_text(encoding="utf-8").startswith('"""Moved to '):
            continue
        for n, o in vars(importlib.import_module(info.name)).items():
            if (inspect.isfunction(o) or inspect.isclass(o)) and getattr(o, "__module__", "").startswith("squealkit"):
                if not any(o is x for x in out.setdefault(n, [])):
                    out[n].append(o)
    return out


def _resolve(path: str):
    """The object a dotted path names (attribute by attribute, importing modules as needed), or None."""
    first, *rest = path.split(".")
    obj, sofar = importlib.import_module(first), first
    for part in rest:
        sofar = f"{sofar}.{part}"
        if hasattr(obj, part):
            obj = getattr(obj, part)
            continue
        try:
            obj = importlib.import_module(sofar)
        except ImportError:
            return None
    return obj


def taught_problems(pages: dict[str, str]) -> list[str]:
    """Squealkit functions and classes the pages (name -> Markdown) teach that are taught by a
    private path, are in no public ``__all__`` or are on no task page."""
    listed = task_page_entries()
    by_name = _squealkit_objects()
    problems = []
    for page, text in pages.items():
        for ref in sorted(taught_references(text)):
            where = f"{page}: {ref}"
            if ref.startswith("squealkit."):
                obj = _resolve(ref)
                if obj is None or inspect.ismodule(obj) or not callable(obj):
                    continue
                if any(p.startswith("_") for p in ref.split(".")[1:]):
                    problems.append(f"{where} is a private path (public: {_public_path(obj)})")
                    continue
            elif ref in by_name and not ref.startswith("_"):
                if any(id(o) in listed for o in by_name[ref]):
                    continue
                obj = by_name[ref][0]
            else:
                continue  # not squealkit's (Python's, NumPy's) or a method
            if _public_path(obj) is None:
                problems.append(f"{where} is in no public __all__")
            elif id(obj) not in listed:
                problems.append(f"{where} is on no task page (docs/api/*.md)")
    return problems


def test_every_function_the_readme_and_guide_teach_is_public_and_on_a_task_page():
    pages = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")), *sorted((ROOT / "docs" / "guide").glob("*.md"))]
    problems = taught_problems({str(p.relative_to(ROOT)): p.read_text(encoding="utf-8") for p in pages})
    assert not problems, "\n".join(problems)


def test_the_taught_check_catches_a_private_or_unlisted_function(monkeypatch):
    import sys

    from squealkit.transient.reference import first_order_rhs

    # every public name has its page now: a task page that forgot first_order_rhs's is planted
    listed = {k: v for k, v in task_page_entries().items() if k != id(first_order_rhs)}
    monkeypatch.setattr(sys.modules[__name__], "task_page_entries", lambda: listed)
    text = ("Read old files with `squealkit._accessor.upgrade_result`; "
            "`squealkit.transient.reference.first_order_rhs(f)` and `recognise(path)` too.\n\n"
            "```python\nfrom squealkit.stability import stability_map\nds = stability_map(m, mu, theta)\n```\n")
    assert {"squealkit._accessor.upgrade_result", "squealkit.transient.reference.first_order_rhs", "recognise",
            "stability_map", "squealkit.stability.stability_map"} <= taught_references(text)
    assert taught_problems({"page": text}) == [
        "page: recognise is in no public __all__",  # the labelled readers' sniffer: not public
        "page: squealkit._accessor.upgrade_result is a private path (public: squealkit.io.upgrade_result)",
        "page: squealkit.transient.reference.first_order_rhs is on no task page (docs/api/*.md)"]


def test_every_function_on_a_task_page_documents_its_parameters():
    """tests/test_api_docs.py checks the names of the packages' ``__all__``; the task pages also list
    names of public modules (``squealkit.fe.demo.write_fe_demo``): their pages need the same sections."""
    from test_api_docs import docstring_problems

    problems = []
    for path in task_page_entries().values():
        module, _, name = path.rpartition(".")
        obj = getattr(importlib.import_module(module), name)
        if callable(obj) and not (inspect.isclass(obj) and issubclass(obj, BaseException)):
            problems += [f"{path}: {p}" for p in docstring_problems(obj)]
    assert not problems, "\n".join(problems)


# -- the gallery runs every example ---------------------------------------------------------------


def test_the_gallery_runs_every_example():
    """conf.py's sphinx-gallery settings pick up every examples/NN_*.py (tests/test_examples.py runs
    each and checks its printed output and figures; tests/test_docs.py checks them on the built pages)."""
    import runpy

    conf = runpy.run_path(str(ROOT / "docs" / "conf.py"))["sphinx_gallery_conf"]
    assert (ROOT / "docs" / conf["examples_dirs"]).resolve() == ROOT / "examples"
    scripts = sorted((ROOT / "examples").glob("*.py"))
    assert [s.name for s in scripts if not re.search(conf["filename_pattern"], str(s))] == []
    assert "05_campaign.py" in {s.name for s in scripts}
    for script in scripts:  # each writes its figures where the gallery's scraper looks: argv[1]
        assert "out = Path(sys.argv[1]" in script.read_text(encoding="utf-8"), script.name


# -- the developer guide describes the tree as it is ------------------------------------------------


PKG = ROOT / "src" / "squealkit"


def _layout_rows() -> list[tuple[list[str], list[str]]]:
    """docs/dev/layout.md's table of packages: (names in the first column, names in the second)."""
    rows = []
    for line in (ROOT / "docs" / "dev" / "layout.md").read_text(encoding="utf-8").splitlines():
        cells = line.split("|")
        if len(cells) >= 4 and "`" in cells[1]:
            rows.append((re.findall(r"`([^`]+)`", cells[1]), re.findall(r"`([^`]+)`", cells[2])))
    return rows


def layout_problems(rows, root: Path = PKG) -> list[str]:
    """Packages and top-level modules of ``root`` missing from the table, and module paths the table
    names that do not exist under the row's packages."""
    problems = []
    named = {n.rstrip("/") for first, _ in rows for n in first}
    for p in sorted(root.iterdir()):
        name = p.stem if p.suffix == ".py" else p.name
        if ((p.is_dir() and (p / "__init__.py").is_file()) or (p.suffix == ".py" and p.stem != "__init__")) \
                and name not in named:
            problems.append(f"{name}: a {'package' if p.is_dir() else 'module'} the table does not name")
    for first, second in rows:
        bases = [root / n.rstrip("/") for n in first if (root / n.rstrip("/")).is_dir()] + [root]
        for ref in second:
            if not re.fullmatch(r"[\w*]+(/[\w*]+)*(\.py|/)", ref):
                continue  # a name, not a module path
            pattern = ref.rstrip("/")
            if not any(any(b.rglob(pattern)) or (b / pattern).exists() for b in bases):
                problems.append(f"{'/'.join(first)}: {ref} does not exist")
    return problems


def test_the_developer_layout_names_every_package_and_only_modules_that_exist():
    problems = layout_problems(_layout_rows())
    assert not problems, "\n".join(problems)


def test_the_layout_check_catches_a_stale_table(tmp_path):
    for path in ("a/__init__.py", "a/kept.py", "b/__init__.py", "c.py"):
        (tmp_path / path).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / path).write_text("")
    rows = [(["a/"], ["kept.py", "gone.py", "sub/"]), (["c"], [])]
    assert layout_problems(rows, tmp_path) == ["b: a package the table does not name", "a/: gone.py does not exist",
                                               "a/: sub/ does not exist"]


def test_every_path_the_developer_guide_names_exists():
    """Backticked paths in docs/dev/*.md and the tree in docs/guide/layout.md: repository paths
    (``tests/test_docs.py``, ``examples/NN_*.py`` as a glob), paths inside the package
    (``solvers/lu.py``) and dotted module names (``squealkit.fe.readers``)."""
    missing = []
    pages = sorted((ROOT / "docs" / "dev").glob("*.md"))
    refs = {(p.name, r) for p in pages for r in re.findall(r"`([^`\s]+)`", p.read_text(encoding="utf-8"))}
    guide = (ROOT / "docs" / "guide" / "layout.md").read_text(encoding="utf-8")
    refs |= {("guide/layout.md", r) for r in re.findall(r"^(src/squealkit/[\w/.]+)", guide, flags=re.M)}
    # folders the docs build writes (.gitignore: "generated by the docs build"): absent from a fresh checkout
    generated = {line.strip().rstrip("/") for line in (ROOT / ".gitignore").read_text(encoding="utf-8").splitlines()
                 if line.strip().startswith("docs/")}
    for page, ref in sorted(refs):
        if ref.rstrip("/") in generated:
            continue
        ref = re.sub(r"NN|<\w+>", "*", ref)
        if re.fullmatch(r"squealkit(\.\w+)+", ref):
            if _resolve(ref) is None:
                missing.append(f"{page}: {ref}")
        elif re.fullmatch(r"[\w*.-]+(/[\w*.-]+)*/?", ref) and ("/" in ref or ref.endswith(".py")):
            top = ref.split("/")[0]
            if top in ("src", "tests", "docs", "benchmarks", "examples"):
                found = any(ROOT.glob(ref.rstrip("/")))
            else:  # a path inside the package (at any depth: the table's rows name paths below their
                # package) or a file of the tests, docs, benchmarks or examples named alone
                found = any(any((ROOT / d).rglob(ref.rstrip("/"))) for d in ("src", "tests", "docs", "benchmarks",
                                                                              "examples"))
            if not found:
                missing.append(f"{page}: {ref}")
    assert not missing, "\n".join(missing)
    # the packages the guide's tree shows are the package's
    shown = set(re.findall(r"^src/squealkit/(\w+)/", guide, flags=re.M))
    packages = {p.name for p in PKG.iterdir() if (p / "__init__.py").is_file()}
    assert packages - shown == set(), "docs/guide/layout.md does not show these packages"


# -- property tests draw through hypothesis (shrinkable), not through a seeded loop --------------------


def seeded_random_loops(source: str) -> list[str]:
    """Test functions that loop ``for _ in range(N)`` (N >= 10) drawing from a random generator:
    a property checked on inputs hypothesis cannot shrink (docs/dev/tests.md)."""
    import ast

    found = []
    for fn in ast.walk(ast.parse(source)):
        if not isinstance(fn, ast.FunctionDef) or not fn.name.startswith("test_"):
            continue
        for node in ast.walk(fn):
            if not (isinstance(node, ast.For) and isinstance(node.iter, ast.Call)
                    and getattr(node.iter.func, "id", "") == "range" and len(node.iter.args) == 1
                    and isinstance(node.iter.args[0], ast.Constant) and node.iter.args[0].value >= 10):
                continue
            calls = [c for c in ast.walk(node) if isinstance(c, ast.Call)]
            if any((isinstance(c.func, ast.Attribute) and "rng" in ast.unparse(c.func.value))
                   or "random" in ast.unparse(c.func) for c in calls):
                found.append(f"{fn.name} (line {node.lineno})")
    return found


def test_property_tests_draw_their_inputs_with_hypothesis():
    found = {p.name: f for p in sorted((ROOT / "tests").glob("test_*.py"))
             if (f := seeded_random_loops(p.read_text(encoding="utf-8")))}
    assert not found, f"seeded random loops (draw the inputs with hypothesis instead): {found}"


def test_the_loop_check_catches_a_seeded_loop():
    src = ("def test_a():\n    rng = np.random.default_rng(1)\n    for trial in range(50):\n"
           "        x = rng.standard_normal(3)\n        assert f(x)\n"
           "def test_b():\n    for _ in range(40):\n        lo, hi = bisect(lo, hi)\n")
    assert seeded_random_loops(src) == ["test_a (line 3)"]


def test_no_public_function_anywhere_takes_tan_theta_by_position():
    """tests/test_vocabulary.py checks the packages' names; the public modules' ``__all__`` too
    (``squealkit.fe.energy.friction_parts(model, disc_speed, mu, tan_theta)`` took it fourth)."""
    from test_vocabulary import SWEEPS_OVER_SLOPE

    offenders = []
    for mod in every_public_module():
        for name in getattr(mod, "__all__", ()):
            obj = getattr(mod, name)
            if not inspect.isfunction(obj) or f"{obj.__module__}.{obj.__name__}" in SWEEPS_OVER_SLOPE:
                continue
            p = inspect.signature(obj).parameters.get("tan_theta")
            if p is not None and p.kind is not p.KEYWORD_ONLY:
                offenders.append(f"{mod.__name__}.{name}")
    assert not offenders, offenders


def test_friction_parts_by_position_warns_for_one_release():
    import numpy as np
    import pytest

    from squealkit.fe import FEModel
    from squealkit.fe.energy import friction_parts

    m = FEModel.from_matrices(M=np.eye(2), K1=np.eye(2), KR=[[0.0, 1.0], [-1.0, 0.0]])
    new = friction_parts(m, 10.0, 0.3, tan_theta=0.1)
    np.testing.assert_allclose(new[0].toarray(), 0.4 * np.array([[0.0, 1.0], [-1.0, 0.0]]), rtol=1e-15)
    with pytest.warns(DeprecationWarning, match=r"friction_parts\(\.\.\., tan_theta\) by position is deprecated"):
        old = friction_parts(m, 10.0, 0.3, 0.1)
    assert (old[0] != new[0]).nnz == 0


# -- no module over ~800 lines unless it is one algorithm ---------------------------------------------

#: Modules allowed over the limit, each with the one algorithm it holds (none: keep it so).
ONE_ALGORITHM: dict[str, str] = {}


def test_no_module_anywhere_over_800_lines():
    """tests/test_splits_layout.py and tests/test_layout_fe.py check some folders; this the whole package
    (nonlinear/continuation.py had grown to 878 lines: the continuation algorithm and the squealkit-model
    branches on it)."""
    long = {p.relative_to(PKG).as_posix(): n for p in sorted(PKG.rglob("*.py"))
            if (n := len(p.read_text(encoding="utf-8").splitlines())) > 800}
    assert set(long) <= set(ONE_ALGORITHM), long


# -- kernels compiled once per test run ---------------------------------------------------------------


def uncached_kernels(source: str) -> list[str]:
    """Functions compiled by numba (``@njit``/``@jit``/``@vectorize``/``@guvectorize``) without
    ``cache=True``: compiled again by every process (the suite's workers, the CLI's children)."""
    import ast

    found = []
    for fn in ast.walk(ast.parse(source)):
        if not isinstance(fn, ast.FunctionDef):
            continue
        for dec in fn.decorator_list:
            call = dec if isinstance(dec, ast.Call) else None
            name = ast.unparse(call.func if call else dec).rpartition(".")[2]
            if name not in ("njit", "jit", "vectorize", "guvectorize"):
                continue
            cached = call is not None and any(k.arg == "cache" and getattr(k.value, "value", False) is True
                                              for k in call.keywords)
            if not cached:
                found.append(fn.name)
    return found


def test_every_compiled_kernel_is_cached_on_disk():
    """numba's on-disk cache (``cache=True``) is what makes a kernel compile once per test run (and
    once per checkout: tests/test_kernel_cache.py shows a second process loading it)."""
    found = {p.relative_to(PKG).as_posix(): f for p in sorted(PKG.rglob("*.py"))
             if (f := uncached_kernels(p.read_text(encoding="utf-8")))}
    assert found == CALLEES_OF_CACHED_KERNELS, found


#: Functions compiled only as callees of cached kernels: their code is compiled into the caller's and
#: kept in the caller's cache entry (a second process loads the caller and never compiles them). The
#: adaptive loop's ``run`` is a closure over each method's step (a compiled function as a closure variable
#: is a "dynamic global" numba's cache cannot key on its own); RK4's per-run loop is called by
#: ``integrate_chunk`` only.
CALLEES_OF_CACHED_KERNELS = {"solvers/ode/adaptive.py": ["run"], "solvers/ode/rk4.py": ["_rk4_run"]}



def test_the_cache_check_catches_an_uncached_kernel():
    src = ("@njit(cache=True)\ndef a(x):\n    return x\n@numba.njit\ndef b(x):\n    return x\n"
           "@njit(parallel=True)\ndef c(x):\n    return x\n")
    assert uncached_kernels(src) == ["b", "c"]


# -- the thread limit holds for a BLAS library loaded after the first limited call -----------------------

_LATE_BLAS = """
import json, sys
import numpy as np
assert "scipy.linalg" not in sys.modules
from squealkit._threads import honour_thread_limit
honour_thread_limit(lambda: np.ones(2) @ np.ones(2))()   # the first limited call: numpy's BLAS only
import scipy.linalg                                      # scipy's own OpenBLAS loads now
from threadpoolctl import threadpool_info, threadpool_limits
seen = []
with threadpool_limits(2, user_api="blas"):
    honour_thread_limit(lambda: seen.extend(i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"))()
print(json.dumps(seen))
"""


def test_the_thread_limit_holds_for_a_blas_loaded_after_the_first_limited_call():
    # found by the whole suite: the BLAS controller was made once, at the first bounded call, so a
    # BLAS library loaded later was never bounded: pypardiso's MKL (tests/test_leftovers_lu.py before
    # tests/test_smaller_27.py in one worker: its LAPACK calls on 2 threads under SQUEALKIT_THREADS=1).
    # Here the late library is scipy's OpenBLAS (no optional package needed), loaded after a call on numpy's.
    import json
    import os
    import subprocess
    import sys

    env = {**os.environ, "SQUEALKIT_THREADS": "1"}
    out = subprocess.run([sys.executable, "-c", _LATE_BLAS], capture_output=True, text=True, env=env, check=True)
    seen = json.loads(out.stdout.strip().splitlines()[-1])
    assert len(seen) >= 2 and set(seen) == {1}, seen  # numpy's and scipy's libraries, each on 1 thread



# -- every name in a public module's __all__ has its page ------------------------------------------------


def test_no_new_public_module_name_without_a_page():
    """Every name in the ``__all__`` of every public module (not only of the packages:
    test_every_package_name_is_on_a_task_page) is listed on a task page, so it gets its own page.
    A helper the readers' dispatch or a report step uses is kept out of ``__all__`` instead (the
    file-format sniffers, the memory estimators, the report's steps and context): importable by
    its path, not public."""
    listed = task_page_entries()
    unlisted = sorted(f"{m.__name__}.{n}" for m in every_public_module() for n in getattr(m, "__all__", ())
                      if not n.startswith("__") and id(getattr(m, n)) not in listed)
    assert unlisted == [], f"document it on a task page (docs/api/*.md) or keep it out of __all__: {unlisted}"

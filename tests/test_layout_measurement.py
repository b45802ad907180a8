"""measurement/ laid out by concept (issue 28): the analysis is unchanged bit for bit, the figures
draw what the analysis returns and compute nothing, the old module paths keep working.

The golden values in tests/golden_measurement/ were written by its make_golden.py on the code
before the refactor (commit "tests: golden measurement outputs"): they are the reference.
"""

from __future__ import annotations

import dataclasses
import json
import sys
from pathlib import Path

import numpy as np
import pytest

GOLDEN = Path(__file__).parent / "golden_measurement"
sys.path.insert(0, str(GOLDEN))

from _cases import analysis_arrays, cases, digest, figure_arrays  # noqa: E402


@pytest.fixture(scope="module")
def golden_cases():
    return cases()


def test_analysis_bit_identical_to_golden(golden_cases):
    # reference: analysis.npz, written by make_golden.py before measurement/ was split
    ref = np.load(GOLDEN / "analysis.npz")
    got = {}
    for name, (_rec, res, _kw) in golden_cases.items():
        got.update({f"{name}/{k}": v for k, v in analysis_arrays(res).items()})
    assert sorted(got) == sorted(ref.files)
    for k in ref.files:
        np.testing.assert_array_equal(got[k], ref[k], err_msg=k, strict=True)


def test_figures_draw_bit_identical_data(golden_cases):
    # reference: figures.json, digests of every line, mesh and scatter of the report's figures
    # as the plotting module drew them before it stopped computing (make_golden.py)
    ref = json.loads((GOLDEN / "figures.json").read_text())
    got = {}
    for name, (rec, res, kw) in golden_cases.items():
        got.update({f"{name}/{k}": digest(v) for k, v in figure_arrays(rec, res, kw).items()})
    assert sorted(got) == sorted(ref)
    assert [k for k in ref if got[k] != ref[k]] == []


# -- the analysis returns what its figures draw; plotting only draws -------------------------------

def test_keep_signals_returns_what_the_figures_draw(golden_cases, tmp_path):
    # reference: measurement_signals on the recording in memory; the analysis' own numbers unchanged
    from squealkit.measurement import analyze_recording, measurement_signals
    from squealkit.measurement.formats import write_recording

    rec, res, kw = golden_cases["const"]
    with_sig = analyze_recording(rec, **kw, keep_signals=True)
    assert res.signals is None
    ref = measurement_signals(rec, res)
    assert with_sig.signals.identical(ref)
    a, b = analysis_arrays(res), analysis_arrays(with_sig)
    assert all(np.array_equal(a[k], b[k], equal_nan=True) for k in a)
    # from a file, block by block: the same arrays (the file holds float64 samples as the Dataset does)
    f = write_recording(rec, tmp_path / "rec.nc")
    from_file = analyze_recording(f, **kw, keep_signals=True).signals
    for name in ("mic", "runout_macro", "displacement_band", "mic_level"):
        np.testing.assert_array_equal(from_file[name].values, ref[name].values, err_msg=name)
    assert {ref[v].attrs["units"] for v in ref.data_vars} >= {"m", "Pa", "dB re 20 uPa", "dB re 1 pm"}
    assert ref.attrs["kind"] == "measurement_signals"


def test_figures_compute_nothing(golden_cases, monkeypatch):
    # every filter, spectrum and run-out split made to fail: the figures of a result still draw
    import squealkit.measurement.analysis.views as views
    from squealkit.measurement import measurement_signals
    from squealkit.plotting.measurement import measurement_figures

    rec, res, _ = golden_cases["const"]
    sig = measurement_signals(rec, res)

    def boom(*a, **k):
        raise AssertionError("a figure recomputed the analysis")

    for name in ("bandpass", "spectrogram", "split_runout"):
        monkeypatch.setattr(views, name, boom)
    figs = measurement_figures(res, sig)
    assert sorted(figs) == ["band", "level", "polar", "runout", "spectrogram", "time", "zoom"]


def _imports(tree):
    """(enclosing function or None, absolute module, names) of every import in a plotting module's AST."""
    import ast

    out = []

    def walk(node, func):
        for child in ast.iter_child_nodes(node):
            f = child.name if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef) else func
            if isinstance(child, ast.ImportFrom):
                mod = child.module or ""
                if child.level:  # relative to squealkit.plotting
                    base = "squealkit.plotting".split(".")[: 3 - child.level]
                    mod = ".".join([*base, mod] if mod else base)
                out.append((func, mod, tuple(a.name for a in child.names)))
            elif isinstance(child, ast.Import):
                out.append((func, None, tuple(a.name for a in child.names)))
            walk(child, f)

    walk(tree, None)
    return out


def test_plotting_imports_nothing_from_measurement():
    # plotting/ draws what measurement/ returns: it imports nothing of measurement/, at module level or in a
    # function (the result's plot() imports plotting; an import back was a circle, issue #28). It was allowed
    # the deprecated recording call forms' bridge to figure_signals, now refused (see below).
    import ast

    import squealkit.plotting as plotting

    found = set()
    for path in Path(plotting.__file__).parent.glob("*.py"):
        for func, mod, names in _imports(ast.parse(path.read_text())):
            if mod is not None and "measurement" in mod.split(".")[1:]:
                found |= {(path.name, func, n) for n in names}
            if path.name == "measurement.py":  # no signal processing library either
                assert not any(n.startswith("scipy") for n in (mod or "", *names)), (func, mod, names)
    assert found == set()


@pytest.mark.parametrize("func", ["runout_plot", "band_vs_pressure_plot", "spectrogram_plot"])
def test_a_recording_is_refused_with_the_call_that_replaces_it(golden_cases, func):
    # the recording call form computed the signals inside plotting: refused, naming figure_signals
    from squealkit import InputError
    from squealkit.plotting import measurement as mp

    rec = golden_cases["const"][0]
    with pytest.raises(InputError, match=rf"{func}\(\) draws the signals .*figure_signals\(recording"):
        getattr(mp, func)(rec)
    with pytest.raises(TypeError, match="rpm"):  # the old form's keywords are gone, not ignored
        getattr(mp, func)(rec, rpm=900.0)


def test_measurement_figures_without_signals_says_what_to_do(golden_cases):
    from squealkit import InputError
    from squealkit.plotting.measurement import measurement_figures

    with pytest.raises(InputError, match="keep_signals=True"):
        measurement_figures(golden_cases["const"][1])
    rec, res, _ = golden_cases["const"]
    with pytest.raises(InputError, match=r"measurement_figures\(result, measurement_signals\(recording, result\)\)"):
        measurement_figures(rec, res)


# -- layout: one concept per module, old paths still work ------------------------------------------

MOVED = {"filters": "signal.filters", "spectral": "signal.spectral", "tacho": "signal.tacho",
         "criteria": "squeal.criteria", "events": "squeal.events", "runout": "squeal.runout",
         "readers": "formats.readers", "writers": "formats.writers"}


@pytest.mark.parametrize("old", sorted(MOVED))
def test_old_module_paths_are_deprecated_shims(old):
    import importlib

    new = importlib.import_module(f"squealkit.measurement.{MOVED[old]}")
    sys.modules.pop(f"squealkit.measurement.{old}", None)
    with pytest.warns(DeprecationWarning, match=f"squealkit.measurement.{MOVED[old]}"):
        shim = importlib.import_module(f"squealkit.measurement.{old}")
    assert shim.__all__ == new.__all__
    assert all(getattr(shim, n) is getattr(new, n) for n in new.__all__)


def test_public_measurement_names_unchanged():
    # the names squealkit.measurement offered before the split (its __all__ then), plus the new ones
    import squealkit.measurement as m

    before = {"SETUPS", "AnalysisSettings", "DiscAngle", "MeasurementResult", "RecordingSource", "SquealCriteria",
              "SquealEvent", "SyntheticSource", "a_weighting_db", "analyze_recording", "angular_resample",
              "bandpass", "butter_sos", "highpass", "incline", "lowpass", "lowpass_decimated", "open_recording",
              "phase_advance_freq", "read_recording", "recording_dataset", "refine_peak", "revolution_frequency",
              "ridge", "spectrogram", "split_runout", "squeal_criteria", "surface_speed", "synchronous_average",
              "synthetic_recording", "synthetic_source", "tacho_angle", "time_weighted_level"}
    assert before <= set(m.__all__)
    assert all(hasattr(m, n) for n in m.__all__)


def test_no_measurement_module_over_800_lines():
    # issue 28's bound: a module a reader can hold in mind (the old analysis.py had 1490, readers.py 1271)
    import squealkit.measurement as m

    root = Path(m.__file__).parent
    sizes = {str(p.relative_to(root)): len(p.read_text().splitlines()) for p in root.rglob("*.py")}
    assert {k: v for k, v in sizes.items() if v > 800} == {}


# -- one campaign path -----------------------------------------------------------------------------

@pytest.fixture(scope="module")
def small_campaign(tmp_path_factory):
    from squealkit.campaign import read_matrix, synthetic_campaign

    d = tmp_path_factory.mktemp("camp")
    synthetic_campaign(d, n_applications=3, duration=0.5, seed=5, suffix=".nc")
    return d, read_matrix(d / "matrix.csv")


def test_analyze_campaign_rows_are_run_campaigns_rows(small_campaign, tmp_path):
    # reference: run_campaign's store (the campaign engine) on the same recordings; the old API is
    # now a thin wrapper over the engine's analysis task, so every number agrees exactly
    from squealkit.campaign import CampaignStore, analyze_campaign, run_campaign

    d, apps = small_campaign
    kw = dict(mic="mic", displacement="displacement", radius=0.05)
    run_campaign(d / "matrix.csv", tmp_path / "out", report=False, **kw)
    with CampaignStore(tmp_path / "out" / "campaign.duckdb") as store:
        engine = {r["file"]: r for r in store.query("SELECT * FROM applications").to_dict("records")}
    summ = analyze_campaign([a.file for a in apps], rpm=None, **kw)
    assert len(summ.rows) == len(apps)
    for a, row in zip(apps, summ.rows, strict=True):
        ref = engine[str(a.file)]
        for k in ("squeal", "n_events", "peak_dba", "squeal_frequency_hz", "duration_s"):
            assert row[k] == ref[k] or (row[k] is None and ref[k] != ref[k]), k


def test_analyze_campaign_needs_no_rpm_and_names_a_bad_file(small_campaign, tmp_path):
    from squealkit import InputError
    from squealkit.campaign import analyze_campaign

    _d, apps = small_campaign
    summ = analyze_campaign([apps[0].file], mic="mic", displacement="displacement", radius=0.05)
    assert summ.rows[0]["rising_fraction"] is None  # no disc speed: squeal alone (SAE J2521 occurrence)
    bad = tmp_path / "bad.nc"
    bad.write_text("not a netCDF file")
    with pytest.raises(InputError, match=r"bad\.nc"):
        analyze_campaign([bad], mic="mic", displacement="displacement", radius=0.05, rpm=900.0)


def test_old_campaign_module_is_a_deprecated_shim():
    import importlib

    import squealkit.campaign as campaign

    sys.modules.pop("squealkit.measurement.campaign", None)
    with pytest.warns(DeprecationWarning, match="squealkit.campaign"):
        old = importlib.import_module("squealkit.measurement.campaign")
    assert old.analyze_campaign is campaign.analyze_campaign
    assert old.summarize_campaign is campaign.summarize_campaign


def test_result_plot_draws_its_signals(golden_cases):
    # reference: the plotting function called on the same signals (plot() only delegates)
    from _cases import _artist_arrays

    from squealkit import InputError
    from squealkit.measurement import measurement_signals
    from squealkit.plotting.measurement import runout_plot

    rec, res, _ = golden_cases["const"]
    with pytest.raises(InputError, match="keep_signals=True"):
        res.plot(kind="runout")
    with pytest.raises(InputError, match="kind='nope'"):
        res.plot(kind="nope")
    sig = measurement_signals(rec, res)
    full = dataclasses.replace(res, signals=sig)
    a = _artist_arrays(full.plot(kind="runout", t_range=(0.1, 0.2)))
    b = _artist_arrays(runout_plot(sig, t_range=(0.1, 0.2)))
    assert [k for k in a if digest(a[k]) != digest(b[k])] == []
    # an old call's keyword with the signals is refused, not ignored
    with pytest.raises(TypeError, match="rpm"):
        runout_plot(sig, rpm=600.0)

"""Results draw themselves by delegating to their ``*_plot`` function (python-control's
``result.plot()``): ``ds.squeal.plot()`` for Dataset results, ``MeasurementResult.plot()``.

Each ``.plot()`` must give the figure the plotting function gives when called directly: the same
axes, titles, labels and the same artists with the same data. The results are small (a few grid
points, 2 ms of simulation) and computed once per module.
"""

from __future__ import annotations

import subprocess
import sys
import warnings

import numpy as np
import pytest

pytest.importorskip("matplotlib")

from squealkit import InputError
from squealkit.models import get_preset


def _artists(fig) -> list:
    """What a reader sees, per axes: title, labels, and each child artist's type and data."""
    out = []
    for ax in fig.axes:
        children = []
        for a in ax.get_children():
            kind = type(a).__name__
            if hasattr(a, "get_xydata"):
                xy = np.asarray(a.get_xydata(), dtype=float)
                children.append((kind, xy.shape, round(float(np.nansum(xy)), 9)))
            elif hasattr(a, "get_array") and a.get_array() is not None:
                arr = np.ma.filled(np.asarray(a.get_array(), dtype=float), np.nan)
                children.append((kind, arr.shape, round(float(np.nansum(arr)), 6)))
            elif hasattr(a, "get_text"):
                children.append((kind, a.get_text()))
            else:
                children.append((kind,))
        out.append((ax.get_title(), ax.get_xlabel(), ax.get_ylabel(), sorted(children, key=repr)))
    return out


@pytest.fixture(scope="module")
def model():
    return get_preset("lv2013")


@pytest.fixture(scope="module")
def results(model):
    """One small result of each kind that has a figure."""
    from squealkit.data import nlevp_path
    from squealkit.models import load_fe_model
    from squealkit.nonlinear import limit_cycle_branch
    from squealkit.stability import fe_stability_map, modes, stability_map
    from squealkit.transient import SineRunOut, simulate
    from squealkit.transient.floquet import floquet_map
    from squealkit.uncertainty import squeal_propensity

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return {
            "stability_map": stability_map(model, np.linspace(0.0, 0.8, 5), np.radians([-2.0, 0.0, 2.0])),
            "modes": modes(model, 0.4),
            "simulation": simulate(model, mu=0.4, profile=SineRunOut(0.08e-3, 1e-3), duration=0.002),
            "floquet_map": floquet_map(model, mu=[0.2, 0.3], amplitude=[1e-5], wavelength=1e-3, speed=0.02),
            "fe_stability_map": fe_stability_map(load_fe_model(nlevp_path()), rpm=[60.0], mu=[0.5]),
            "limit_cycle_branch": limit_cycle_branch(model, (0.3, 0.6), n_points=3, n_floquet=64, harmonics=3,
                                                     check_harmonics=False),
            "propensity": squeal_propensity(
                model, {"m1": {"dist": "normal", "mean": 0.033, "std": 0.001},
                        "k1": {"dist": "normal", "mean": 8.5e6, "std": 1e5}},
                np.linspace(0.2, 0.6, 3), samples=8),
        }


#: result -> the plotting function its ``ds.squeal.plot()`` must call by default
DEFAULTS = {
    "stability_map": ("stability", "stability_map_plot"),
    "modes": ("modes", "modes_plot"),
    "simulation": ("transient", "fig4_plot"),  # a run-out profile: the paper's Fig. 4
    "floquet_map": ("transient", "floquet_plot"),
    "fe_stability_map": ("fe", "fe_map_plot"),
    "limit_cycle_branch": ("limitcycle", "limitcycle_plot"),
    "propensity": ("uncertainty", "uncertainty_plot"),
}


@pytest.mark.parametrize("kind", sorted(DEFAULTS))
def test_dataset_plot_is_the_plotting_function(results, kind):
    import importlib

    from matplotlib.figure import Figure

    ds = results[kind]
    assert ds.squeal.result == kind
    module, func = DEFAULTS[kind]
    direct = getattr(importlib.import_module(f"squealkit.plotting.{module}"), func)(ds)
    via = ds.squeal.plot()
    assert isinstance(via, Figure) and via is not direct
    assert _artists(via) == _artists(direct) and _artists(via)[0][3]  # the same, and not empty


def test_every_listed_plot_draws_its_result(results):
    """The alternatives (``kind=``) draw too; one per result kind keeps this quick."""
    from squealkit.plotting.stability import fig2_plot

    ds = results["stability_map"]
    assert ds.squeal.plots == ("stability_map", "fig2", "root_locus")
    assert _artists(ds.squeal.plot(kind="fig2")) == _artists(fig2_plot(ds))
    sim = results["simulation"]
    assert _artists(sim.squeal.plot(kind="envelope")) == _artists(
        __import__("squealkit.plotting.transient", fromlist=["envelope_plot"]).envelope_plot(sim))
    for kind, ds in results.items():
        for name in ds.squeal.plots[1:]:
            if (kind, name) not in {("stability_map", "fig2"), ("simulation", "envelope")}:
                assert ds.squeal.plot(kind=name).axes, (kind, name)


def test_plot_draws_into_given_axes(results):
    from matplotlib.figure import Figure

    fig = Figure()
    ax = fig.subplots()
    assert results["stability_map"].squeal.plot(ax) is fig
    assert ax.get_title()  # drawn there
    with pytest.raises(TypeError, match="fig="):
        results["modes"].squeal.plot(ax)  # a whole-figure plot takes fig=, not ax


def test_smooth_disc_plots_fig3(model):
    from squealkit.plotting.transient import fig3_plot
    from squealkit.transient import simulate

    ds = simulate(model, mu=0.4, duration=0.002)
    assert ds.attrs["profile_kind"] == "none"  # Smooth()
    assert _artists(ds.squeal.plot()) == _artists(fig3_plot(ds))


def test_a_saved_result_plots_after_loading(results, tmp_path):
    from squealkit.io import load_dataset, save_dataset

    path = tmp_path / "map.nc"
    save_dataset(results["stability_map"], path)
    loaded = load_dataset(path)
    assert loaded.squeal.result == "stability_map"
    assert _artists(loaded.squeal.plot()) == _artists(results["stability_map"].squeal.plot())


def test_not_a_result_or_wrong_kind_is_one_clear_error(results):
    import xarray as xr

    with pytest.raises(InputError, match="not a squealkit result"):
        xr.Dataset({"a": ("x", [1.0, 2.0])}).squeal.plot()
    with pytest.raises(InputError, match=r"kind='fig3'.*stability_map"):
        results["stability_map"].squeal.plot(kind="fig3")


@pytest.fixture(scope="module")
def measurement():
    from squealkit.measurement import analyze_recording, synthetic_recording

    rec = synthetic_recording(duration=0.5, seed=1)
    return analyze_recording(rec, mic="mic", displacement="displacement", rpm=900, radius=0.05)


def test_measurement_result_plot_is_the_plotting_function(measurement):
    from matplotlib.figure import Figure

    from squealkit.plotting.measurement import level_plot, polar_plot

    assert _artists(measurement.plot()) == _artists(level_plot(measurement))
    assert _artists(measurement.plot(kind="polar")) == _artists(polar_plot(measurement))
    fig = Figure()
    ax = fig.add_subplot(projection="polar")
    assert measurement.plot(ax, kind="polar") is fig and ax.get_title()
    with pytest.raises(InputError, match="kind='spectrum'"):
        measurement.plot(kind="spectrum")


def test_the_accessor_does_not_import_matplotlib():
    """The engines import the accessor (to register it), so it must not import plotting itself:
    matplotlib comes only with ``.plot()``. (The engines' own imports are those of main.)"""
    code = ("import sys, squealkit.io; import xarray as xr; assert hasattr(xr.Dataset, 'squeal'); "
            "print(sorted(m for m in sys.modules if m.startswith(('matplotlib', 'squealkit.plotting'))))")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr[-2000:]
    assert r.stdout.strip() == "[]"


def test_fe_growth_plot_titles_say_which_friction(results):
    from squealkit.plotting.fe import fe_growth_plot

    # one friction: named as such, not a colour range "0.5 to 0.5"
    titles = [ax.get_title() for ax in fe_growth_plot(results["fe_stability_map"]).axes]
    assert titles == ["60 rpm  (mu 0.5)"]

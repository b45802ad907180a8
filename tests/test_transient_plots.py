"""Figures of transient runs render without pyplot state, and the progress callback reports."""

from __future__ import annotations

import numpy as np
import pytest

from squealkit.models import get_preset
from squealkit.transient import SineRunOut, simulate

pytest.importorskip("matplotlib")


@pytest.fixture(scope="module")
def runs():
    model = get_preset("lv2013")
    fig4 = simulate(model, mu=0.4, profile=SineRunOut(0.08e-3, 1e-3), duration=0.02, fs=20_000)
    smooth = simulate(model, mu=0.4, duration=0.02, fs=20_000, perturbation=1e-9, rng=np.random.default_rng(0))
    return fig4, smooth


def test_figures(runs, tmp_path):
    import matplotlib.pyplot as plt

    from squealkit.io import save_figure
    from squealkit.plotting.transient import envelope_plot, fig3_plot, fig4_plot

    fig4, smooth = runs
    before = plt.get_fignums()
    for name, fig in [("fig3", fig3_plot(smooth)), ("fig4", fig4_plot(fig4, smooth=smooth)),
                      ("env", envelope_plot(fig4))]:
        assert len(fig.axes) >= 1
        out = save_figure(fig, tmp_path / f"{name}.png")
        assert out.stat().st_size > 1000
    assert plt.get_fignums() == before  # no pyplot figures leaked


def test_fig3_into_given_axes(runs):
    from matplotlib.figure import Figure

    from squealkit.plotting.transient import fig3_plot

    fig = Figure()
    axes = fig.subplots(2, 1)
    assert fig3_plot(runs[1], ax=list(axes)) is fig


def test_progress_callback_reaches_total():
    calls = []
    simulate(get_preset("lv2013"), mu=0.4, duration=0.01, fs=20_000, progress=lambda d, t: calls.append((d, t)))
    assert calls and calls[-1][0] == calls[-1][1]
    assert [c[0] for c in calls] == sorted(c[0] for c in calls)

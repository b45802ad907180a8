"""``ds.squeal.plot()``: draw a squealkit result Dataset with its ``*_plot`` function.

Importing this module registers the ``squeal`` accessor on :class:`xarray.Dataset`; the engine
packages import it, so every result they return has it. It imports only xarray: the plotting
module (and so matplotlib) is imported when :meth:`SquealAccessor.plot` is called, never before,
so computation stays free of plotting (python-control's ``result.plot()`` does the same).

The kind of result is read from what the Dataset holds (its variables and dimensions), which a
result keeps when it is saved and loaded back (:func:`squealkit.io.save_dataset`), so a file from
disk plots the same. (The attribute ``kind`` is taken: a limit-cycle branch's says whether its
onset is ``supercritical`` or ``subcritical``.)
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import xarray as xr

from ._validation import InputError

__all__ = ["PLOTS", "SquealAccessor", "result_kind"]

#: Plot name -> (module in squealkit.plotting, function, whether it draws into an ``ax`` or a ``fig``).
PLOTS: dict[str, tuple[str, str, str]] = {
    "stability_map": ("stability", "stability_map_plot", "ax"),
    "fig2": ("stability", "fig2_plot", "fig"),
    "root_locus": ("stability", "root_locus_plot", "ax"),
    "kinematics": ("stability", "kinematics_plot", "ax"),
    "fe_map": ("fe", "fe_map_plot", "ax"),
    "fe_growth": ("fe", "fe_growth_plot", "fig"),
    "modes": ("modes", "modes_plot", "fig"),
    "fig3": ("transient", "fig3_plot", "ax"),
    "fig4": ("transient", "fig4_plot", "ax"),
    "envelope": ("transient", "envelope_plot", "ax"),
    "floquet": ("transient", "floquet_plot", "ax"),
    "limitcycle": ("limitcycle", "limitcycle_plot", "fig"),
    "limitcycle_signal": ("limitcycle", "limitcycle_signal_plot", "fig"),
    "uncertainty": ("uncertainty", "uncertainty_plot", "fig"),
    "propensity": ("uncertainty", "propensity_plot", "ax"),
    "sensitivity": ("uncertainty", "sensitivity_plot", "ax"),
}


def _is_simulation(ds: xr.Dataset) -> bool:
    return "time" in ds.dims and "run" not in ds.dims and {"tan_theta", "growth_rate", "q"} <= set(ds.data_vars)


#: Result kind -> (how to recognise it, the plots that draw it; the first is the default).
_RESULTS: dict[str, tuple[Callable[[xr.Dataset], bool], tuple[str, ...]]] = {
    # squealkit.transient.floquet.floquet_map
    "floquet_map": (lambda ds: "floquet_exponent" in ds.data_vars, ("floquet",)),
    # squealkit.stability.fe_stability_map (stability_map of an FEModel)
    "fe_stability_map": (lambda ds: "max_growth_rate" in ds.data_vars and {"rpm", "mu", "mode"} <= set(ds.dims),
                         ("fe_map", "fe_growth")),
    # squealkit.stability.stability_map
    "stability_map": (lambda ds: "max_growth_rate" in ds.data_vars and {"mu", "theta", "mode"} <= set(ds.dims),
                      ("stability_map", "fig2", "root_locus")),
    # critical_friction_curve results stacked along "kinematics"
    "kinematics": (lambda ds: "mu_critical" in ds.data_vars and "kinematics" in ds.dims, ("kinematics",)),
    # squealkit.stability.modes, onset_modes, fe_modes
    "modes": (lambda ds: {"mode", "dof"} <= set(ds.dims) and {"shape_real", "shape_imag"} <= set(ds.data_vars),
              ("modes",)),
    # squealkit.transient.simulate (one run)
    "simulation": (_is_simulation, ("fig4", "fig3", "envelope")),
    # squealkit.nonlinear.limit_cycle_branch (and _slope)
    "limit_cycle_branch": (
        lambda ds: "point" in ds.dims and {"amplitude", "stable", "coefficients"} <= set(ds.data_vars),
        ("limitcycle", "limitcycle_signal"),
    ),
    # squealkit.uncertainty.squeal_propensity
    "propensity": (lambda ds: "probability_unstable" in ds.data_vars, ("uncertainty", "propensity", "sensitivity")),
}


def result_kind(ds: xr.Dataset) -> str | None:
    """Which squealkit result ``ds`` is (a key of the table above), or None.

    Parameters
    ----------
    ds : xarray.Dataset
        A Dataset, e.g. returned by :func:`squealkit.stability.stability_map` or loaded from a file.

    Returns
    -------
    str or None
        ``"stability_map"``, ``"fe_stability_map"``, ``"kinematics"``, ``"modes"``,
        ``"simulation"``, ``"floquet_map"``, ``"limit_cycle_branch"`` or ``"propensity"``;
        None for anything else.
    """
    return next((kind for kind, (test, _) in _RESULTS.items() if test(ds)), None)


@xr.register_dataset_accessor("squeal")
class SquealAccessor:
    """``ds.squeal``: the figures of a squealkit result Dataset.

    ``ds.squeal.plot()`` calls the ``*_plot`` function of :mod:`squealkit.plotting` that draws
    this kind of result, exactly as calling it directly would; ``ds.squeal.plots`` lists the
    others that draw it (choose one with ``kind=``).

    Parameters
    ----------
    ds : xarray.Dataset
        The result (xarray passes it when ``ds.squeal`` is first used).

    Examples
    --------
    >>> import numpy as np
    >>> from squealkit.models import get_preset
    >>> from squealkit.stability import stability_map
    >>> ds = stability_map(get_preset("lv2013"), np.linspace(0, 0.8, 5), np.radians([-2.0, 0.0, 2.0]))
    >>> ds.squeal.result, ds.squeal.plots
    ('stability_map', ('stability_map', 'fig2', 'root_locus'))
    >>> fig = ds.squeal.plot()   # squealkit.plotting.stability.stability_map_plot(ds)
    """

    def __init__(self, ds: xr.Dataset) -> None:
        self._ds = ds

    @property
    def result(self) -> str | None:
        """Which squealkit result this is (see :func:`result_kind`), or None."""
        return result_kind(self._ds)

    @property
    def plots(self) -> tuple[str, ...]:
        """Names of the plots that draw this result, the default first (empty if none)."""
        kind = self.result
        return () if kind is None else _RESULTS[kind][1]

    def _default_plot(self) -> str:
        plots = self.plots
        if not plots:
            have = ", ".join(sorted(map(str, self._ds.data_vars))[:12]) or "none"
            raise InputError(f"This Dataset is not a squealkit result with a figure (variables: {have}); "
                             f"plottable results come from {', '.join(_RESULTS)}.")
        if self.result == "simulation" and self._ds.attrs.get("profile_kind") == "none":  # Smooth()
            return "fig3"  # the paper's Fig. 3 is the smooth disc; Fig. 4 adds the run-out
        return plots[0]

    def plot(self, ax: Any = None, *, kind: str | None = None, **kwargs: Any) -> Any:
        """Draw the result with its plotting function (imported now, not before).

        Parameters
        ----------
        ax : matplotlib Axes, optional
            Where to draw, for the plots that draw into axes (``stability_map``,
            ``root_locus``, ``kinematics``, ``fe_map``, ``fig3``, ``fig4``, ``envelope``,
            ``floquet``, ``propensity``, ``sensitivity``); the figure-level plots take ``fig=``
            among ``kwargs`` instead.
        kind : str, optional
            One of :attr:`plots` (default: the first; ``fig3`` for a run on a smooth disc).
        **kwargs
            Passed on to the plotting function (e.g. ``critical=`` of
            :func:`~squealkit.plotting.stability.stability_map_plot`).

        Returns
        -------
        matplotlib.figure.Figure
            What the plotting function returns.

        Raises
        ------
        InputError
            If the Dataset is not a plottable squealkit result, or ``kind`` does not draw it.
        TypeError
            If ``ax`` is given to a plot that draws a whole figure.
        """
        name = self._default_plot() if kind is None else kind
        if name not in self.plots:
            self._default_plot()  # not a result at all: say so
            raise InputError(f"Parameter kind={kind!r} does not draw a {self.result} result; "
                             f"choose one of {', '.join(map(repr, self.plots))}.")
        module, func, target = PLOTS[name]
        if ax is not None:
            if target != "ax":
                raise TypeError(f"The {name!r} plot draws a whole figure: pass fig=..., not ax.")
            kwargs["ax"] = ax
        import importlib

        plot = getattr(importlib.import_module(f"squealkit.plotting.{module}"), func)
        return plot(self._ds, **kwargs)

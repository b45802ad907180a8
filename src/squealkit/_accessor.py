"""``ds.squeal.plot()``: draw a squealkit result Dataset with its ``*_plot`` function.

Importing this module registers the ``squeal`` accessor on :class:`xarray.Dataset`; the engine
packages import it, so every result they return has it. It imports only xarray: the plotting
module (and so matplotlib) is imported when :meth:`SquealAccessor.plot` is called, never before,
so computation stays free of plotting (python-control's ``result.plot()`` does the same).

The kind of result is its attribute ``kind`` (one of :data:`RESULT_KINDS`, set by every engine and
kept when the result is saved and loaded back with :func:`squealkit.io.save_dataset`), never a guess
from its variable names. A file saved by an older squealkit has no ``kind`` (and older names:
``frequency`` for ``frequency_hz``, ``omega_disc`` for ``disc_speed``); for those alone the kind is
recognised from what the Dataset holds and :func:`upgrade_result` gives the current names.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import xarray as xr

from ._validation import InputError

__all__ = ["PLOTS", "RESULT_KINDS", "SquealAccessor", "result_kind", "upgrade_result"]

#: Plot name -> (module in squealkit.plotting, function, whether it draws into an ``ax`` or a ``fig``).
PLOTS: dict[str, tuple[str, str, str]] = {
    "stability_map": ("stability", "stability_map_plot", "ax"),
    "fig2": ("stability", "fig2_plot", "fig"),
    "root_locus": ("stability", "root_locus_plot", "ax"),
    "kinematics": ("stability", "kinematics_plot", "ax"),
    "fe_map": ("fe", "fe_map_plot", "ax"),
    "fe_growth": ("fe", "fe_growth_plot", "fig"),
    "modes": ("modes", "modes_plot", "fig"),
    "mode_tracking": ("fe_modes", "mode_tracking_plot", "fig"),
    "friction_work": ("fe_modes", "friction_work_plot", "fig"),
    "fig3": ("transient", "fig3_plot", "ax"),
    "fig4": ("transient", "fig4_plot", "ax"),
    "envelope": ("transient", "envelope_plot", "ax"),
    "floquet": ("transient", "floquet_plot", "ax"),
    "limitcycle": ("limitcycle", "limitcycle_plot", "fig"),
    "limitcycle_signal": ("limitcycle", "limitcycle_signal_plot", "fig"),
    "uncertainty": ("uncertainty", "uncertainty_plot", "fig"),
    "propensity": ("uncertainty", "propensity_plot", "ax"),
    "sensitivity": ("uncertainty", "sensitivity_plot", "ax"),
    "pareto": ("design", "pareto_plot", "ax"),
    "countermeasures": ("design", "countermeasures_plot", "ax"),
    "robust_margins": ("design_robust", "robust_margins_plot", "ax"),
}


def _is_simulation(ds: xr.Dataset) -> bool:
    return "time" in ds.dims and "run" not in ds.dims and {"tan_theta", "growth_rate", "q"} <= set(ds.data_vars)


#: Result kind -> (how to recognise it in a file saved before results carried ``kind``, the plots
#: that draw it; the first is the default).
_RESULTS: dict[str, tuple[Callable[[xr.Dataset], bool], tuple[str, ...]]] = {
    # squealkit.transient.floquet.floquet_map
    "floquet_map": (lambda ds: "floquet_exponent" in ds.data_vars, ("floquet",)),
    # squealkit.stability.fe_stability_map (stability_map of an FEModel)
    "fe_stability_map": (lambda ds: "max_growth_rate" in ds.data_vars and {"rpm", "mu", "mode"} <= set(ds.dims),
                         ("fe_map", "fe_growth", "mode_tracking")),
    # squealkit.stability.stability_map
    "stability_map": (lambda ds: "max_growth_rate" in ds.data_vars and {"mu", "theta", "mode"} <= set(ds.dims),
                      ("stability_map", "fig2", "root_locus")),
    # critical_friction_curve results stacked along "kinematics"
    "kinematics": (lambda ds: "mu_critical" in ds.data_vars and "kinematics" in ds.dims, ("kinematics",)),
    # squealkit.stability.modes, onset_modes (and fe_modes, saved before results carried their kind)
    "modes": (lambda ds: {"mode", "dof"} <= set(ds.dims) and {"shape_real", "shape_imag"} <= set(ds.data_vars),
              ("modes",)),
    # squealkit.stability.fe_modes
    "fe_modes": (lambda ds: False, ("modes",)),
    # squealkit.fe.mode_energy: friction work per contact point (ds.squeal.plot(mode=k))
    "fe_mode_energy": (lambda ds: False, ("friction_work",)),
    # squealkit.transient.simulate (one run)
    "simulation": (_is_simulation, ("fig4", "fig3", "envelope")),
    # squealkit.nonlinear.limit_cycle_branch (and _slope)
    "limit_cycle_branch": (
        lambda ds: "point" in ds.dims and {"amplitude", "stable", "coefficients"} <= set(ds.data_vars),
        ("limitcycle", "limitcycle_signal"),
    ),
    # squealkit.uncertainty.squeal_propensity
    "propensity": (lambda ds: "probability_unstable" in ds.data_vars, ("uncertainty", "propensity", "sensitivity")),
    # squealkit.design.doe_sweep
    "doe_sweep": (lambda ds: {"change_size", "pareto"} <= set(ds.data_vars), ("pareto",)),
    # squealkit.design.countermeasures
    "countermeasures": (lambda ds: {"effect", "predicted_change"} <= set(ds.data_vars), ("countermeasures",)),
    # squealkit.design.robust_margins (always saved with its kind)
    "robust_margins": (lambda ds: False, ("robust_margins",)),
}


#: Results without a figure of their own (``kind`` attribute -> the function that returns them).
_UNPLOTTED: dict[str, str] = {
    "critical_friction": "squealkit.stability.critical_friction_curve (and CriticalFriction.to_dataset)",
    "fe_critical_friction": "squealkit.stability.fe_critical_friction",
    "fe_mode_surface": "squealkit.fe.mode_surface (a 3D view: squealkit.plotting.fe_modes.mode_view)",
    "eigenvalue_sensitivity": "squealkit.stability.eigenvalue_sensitivity",
    "eigen_derivatives": "squealkit.design.eigen_derivatives",
    "reduced_sweep": "squealkit.solvers.reduced_sweep",
    "simulation_batch": "squealkit.transient.simulate_batch",
    "measurement_signals": "squealkit.measurement.analysis.views.measurement_signals and figure_signals "
                           "(what the figures of squealkit.plotting.measurement draw)",
    "correlation": "squealkit.correlate.correlate (its figures: squealkit.plotting.correlate)",
    "predicted_modes": "squealkit.correlate.predict_modes",
    "measured_components": "squealkit.correlate.measured_components",
    "mode_match": "squealkit.correlate.match_modes",
}

#: Every value of a result's ``kind`` attribute.
RESULT_KINDS: tuple[str, ...] = (*_RESULTS, *_UNPLOTTED)

#: Variables renamed since results carried ``kind``: old name -> current name.
RENAMED_VARIABLES: dict[str, str] = {"frequency": "frequency_hz", "omega_disc": "disc_speed"}


def upgrade_result(ds: xr.Dataset) -> xr.Dataset:
    """``ds`` with the current names and a ``kind`` attribute, for a file saved by an older squealkit.

    A current result is returned unchanged (the same object). An older one gets its renamed
    variables (:data:`RENAMED_VARIABLES`) under their new names and ``kind`` recognised from what it
    holds; a limit-cycle branch's onset kind moves from ``kind`` to ``hopf_kind``.

    Parameters
    ----------
    ds : xarray.Dataset
        A squealkit result, e.g. loaded from a file.

    Returns
    -------
    xarray.Dataset
    """
    if ds.attrs.get("kind") in RESULT_KINDS and not (RENAMED_VARIABLES.keys() & set(ds.variables)):
        return ds
    renames = {old: new for old, new in RENAMED_VARIABLES.items() if old in ds.variables and new not in ds.variables}
    out = ds.rename(renames) if renames else ds.copy()
    if out.attrs.get("kind") not in RESULT_KINDS:
        if "kind" in out.attrs and "hopf_kind" not in out.attrs:  # a limit-cycle branch: its onset's kind
            out.attrs["hopf_kind"] = out.attrs.pop("kind")
            out.attrs["hopf_kind_from"] = out.attrs.pop("kind_from", "")
        kind = next((k for k, (test, _) in _RESULTS.items() if test(out)), None)
        if kind is not None:
            out.attrs["kind"] = kind
    return out


def result_kind(ds: xr.Dataset) -> str | None:
    """Which squealkit result ``ds`` is (its ``kind`` attribute, one of :data:`RESULT_KINDS`), or None.

    A Dataset without a known ``kind`` (a file saved by an older squealkit) is recognised from
    what it holds (see :func:`upgrade_result`).

    Parameters
    ----------
    ds : xarray.Dataset
        A Dataset, e.g. returned by :func:`squealkit.stability.stability_map` or loaded from a file.

    Returns
    -------
    str or None
        ``"stability_map"``, ``"fe_stability_map"``, ``"kinematics"``, ``"modes"``,
        ``"simulation"``, ``"floquet_map"``, ``"limit_cycle_branch"``, ``"propensity"`` or
        one without a figure (``"fe_modes"``, ``"critical_friction"``, ...); None for anything else.
    """
    kind = ds.attrs.get("kind")
    if kind in RESULT_KINDS:
        return kind
    return upgrade_result(ds).attrs.get("kind")


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
        return () if kind is None or kind in _UNPLOTTED else _RESULTS[kind][1]

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
        return plot(upgrade_result(self._ds), **kwargs)

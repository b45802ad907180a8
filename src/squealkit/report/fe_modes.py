"""The report of an FE brake model: its unstable modes, seen on the brake.

``squealkit report --config brake.toml`` on a model with ``model = "fe"`` writes one
self-contained ``report.html`` (figures as PNG data, 3D views with plotly.js inlined once: it
opens offline), ``figures/`` and ``data/``:

1. the model: its matrices, size and bodies (the separate parts of its mesh);
2. every unstable mode of each load case (disc speed x friction): frequency, growth rate,
   damping ratio, the body carrying most of its kinetic energy, the friction work per cycle;
3. each unstable mode animated over its phase on the mesh (a 3D view to turn), and the friction
   work per contact point on the pads: which part of the pad feeds the mode; every unstable
   mode also goes to ``data/fe_modes_case<N>.vtu`` for ParaView (``mode<k>_re``/``_im``,
   ``mode<k>_friction_work``; with meshio);
4. the modes tracked by MAC over friction and over disc speed.

The load cases come from the model file's ``[report]`` table::

    [report]
    rpm = [500, 1000]          # disc speeds of the load cases [rpm]
    mu = [0.4, 0.6]            # friction coefficients (every rpm x mu pair is a load case)
    eigen_band = [1000, 16000] # Hz: the band the eigenvalue solvers search
    method = "pod"             # auto, dense, sparse, modal, pod, subspace
    mu_sweep = [0.0, 0.8, 9]   # START, STOP, N of the tracking over friction
    rpm_sweep = [200, 2000, 7] # START, STOP, N of the tracking over disc speed
    max_views = 8              # unstable modes drawn per load case (the most unstable first)
    n_frames = 16              # frames per cycle of the animations

A value may carry its unit as text (``eigen_band = ["1 kHz", "16 kHz"]``); the table is parsed
as the small-model report's is (:func:`squealkit.report.settings.report_table_values`).
Without it: the reference speed and friction of the matrices (``disc_speed_ref``, ``mu_ref``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from .._optional import available
from ..io import check_output, save_dataset
from .document import FigureRef, Section, Table
from .settings import check_report_keys, report_key, report_table_values, settings_from_file

__all__ = ["FEReportSettings", "fe_report"]

#: Coordinates per 3D view [bytes] (before base64): frames are dropped (down to 6 a cycle) to stay near it.
_VIEW_BYTES = 1_500_000


def _methods() -> tuple[str, ...]:
    from ..stability.fe_sweep import METHODS

    return METHODS


@dataclass(frozen=True)
class FEReportSettings:
    """The load cases and sweeps of an FE report.

    Attributes
    ----------
    rpm, mu : tuple of float
        Disc speeds [rpm] and friction coefficients; every pair is a load case.
    eigen_band : (float, float) or None
        Frequency band [Hz] the eigenvalue solvers search (None: the solver's default).
    method : str
        Solver: ``auto``, ``dense``, ``sparse``, ``modal``, ``pod`` or ``subspace``.
    mu_sweep, rpm_sweep : (float, float, int)
        START, STOP, N of the tracking over friction (at the first speed) and over disc speed
        (at the first friction).
    max_views : int
        Unstable modes drawn per load case, the most unstable first.
    n_frames : int
        Frames per cycle of the animations.
    """

    rpm: tuple[float, ...] = report_key(unit="rpm", kind="values", doc="disc speeds of the load cases")
    mu: tuple[float, ...] = report_key(unit="1", kind="values", doc="friction coefficients of the load cases")
    eigen_band: tuple[float, float] | None = report_key(None, unit="Hz", kind="band",
                                                        doc="band the eigenvalue solvers search")
    method: str = report_key("auto", unit="", kind="choice", choices=_methods, doc="eigenvalue solver")
    mu_sweep: tuple[float, float, int] = report_key((0.0, 1.0, 9), unit="1", kind="sweep",
                                                    doc="tracking over friction")
    rpm_sweep: tuple[float, float, int] = report_key((100.0, 2000.0, 5), unit="rpm", kind="sweep",
                                                     doc="tracking over disc speed")
    max_views: int = report_key(8, unit="", kind="count", doc="unstable modes drawn per load case")
    n_frames: int = report_key(16, unit="", kind="count", doc="frames per cycle of the animations")
    #: Whose ``[report]`` table this is, in messages.
    table_of: ClassVar[str] = "an FE model's report"

    def __post_init__(self) -> None:
        check_report_keys(self)

    @classmethod
    def for_model(cls, model: Any, *, quick: bool = False) -> FEReportSettings:
        """The matrices' own reference point as the load case; sweeps around it."""
        rpm0 = 60.0 * model.disc_speed_ref / (2.0 * math.pi)
        n = 5 if quick else 9
        return cls(rpm=(rpm0,), mu=(model.mu_ref,), mu_sweep=(0.0, 1.5 * model.mu_ref, n),
                   rpm_sweep=(0.5 * rpm0, 2.0 * rpm0, 3 if quick else 5), n_frames=12 if quick else 16)

    @classmethod
    def from_table(cls, table: Mapping[str, Any], base: FEReportSettings) -> FEReportSettings:
        """``base`` with the values of a ``[report]`` table; one line naming a bad key or value.

        Parsed as the small-model report's table is (:func:`~squealkit.report.settings.report_table_values`):
        a value may carry its unit as text (``eigen_band = ["9 kHz", "20 kHz"]``).
        """
        return replace(base, **report_table_values(cls, table, what=cls.table_of))

    @property
    def load_cases(self) -> list[tuple[float, float]]:
        """Every ``(rpm, mu)`` pair."""
        return [(r, m) for r in self.rpm for m in self.mu]


def load_fe_report_settings(path: str | Path | None, model: Any, *, quick: bool = False) -> FEReportSettings:
    """The FE report's settings: a model file's ``[report]`` table over :meth:`FEReportSettings.for_model`."""
    return settings_from_file(path, FEReportSettings, lambda: FEReportSettings.for_model(model, quick=quick))


# ----------------------------------------------------------------------------- steps


def _save_fig(fig, figures: Path, stem: str) -> None:
    from .steps_stability import _save_fig as save

    save(fig, figures, stem)


def model_step(model: Any, settings: FEReportSettings) -> Section:
    """The model: matrices, size, reference values and the bodies of its mesh."""
    from ..fe.surface import bodies

    paragraphs = [
        f"An FE brake model of {model.n_dof} DOFs with the matrices {', '.join(model.present)}"
        + (f", read from {model.source}" if model.source else "")
        + f"; KR and DR are given at mu_ref = {model.mu_ref:g}, DG and KGeo at the disc speed "
        f"{model.disc_speed_ref:g} rad/s ({60 * model.disc_speed_ref / (2 * math.pi):.4g} rpm).",
        f"Load cases: every pair of disc speed {', '.join(f'{r:g}' for r in settings.rpm)} rpm and friction "
        f"{', '.join(f'{m:g}' for m in settings.mu)}; solver {settings.method}"
        + (f" in {settings.eigen_band[0]:g}-{settings.eigen_band[1]:g} Hz" if settings.eigen_band else "") + ".",
    ]
    tables: tuple[Table, ...] = ()
    if model.mesh is not None:
        b = bodies(model)
        centre = np.round(1e3 * b.centroid, 2)
        centre[centre == 0.0] = 0.0  # no -0
        rows = tuple((name, int((b.of_dof == k).sum()), *np.round(1e3 * b.extent[k], 2).tolist(),
                      *centre[k].tolist()) for k, name in enumerate(b.names))
        tables = (Table("Bodies of the mesh (its separate parts, the largest first)",
                        ("body", "DOFs", "size x [mm]", "size y [mm]", "size z [mm]", "centre x [mm]",
                         "centre y [mm]", "centre z [mm]"), rows),)
        paragraphs.append("The mode table names the body that carries the largest share of a mode's kinetic "
                          "energy (bodies are the connected parts of the mesh: disc, pads, caliper...).")
    else:
        paragraphs.append("The model has no mesh ([fe] mesh = \"brake.inp\"): its modes are listed, not drawn; "
                          "the mode table names the DOF that moves most.")
    return Section("fe_model", "The FE model", tuple(paragraphs), tables=tables,
                   numbers={"n_dof": float(model.n_dof)})


def modes_step(model: Any, settings: FEReportSettings, figures: Path, data: Path) -> list[Section]:
    """Every unstable mode of each load case: the table, then a section per drawn mode (3D view, friction work)."""
    from ..fe.energy import mode_energy
    from ..fe.surface import mode_surface
    from ..plotting.fe_modes import friction_work_plot, mode_view
    from ..stability import fe_modes

    rows, files, off_mesh, mode_sections = [], [], [], []
    numbers: dict[str, float] = {}
    meshed = model.mesh is not None
    plotly_js: bool | str = True  # inlined once, in the first view: the report opens offline
    n_unstable = 0
    for case, (rpm, mu) in enumerate(settings.load_cases, start=1):
        ds = fe_modes(model, rpm, mu, method=settings.method, band=settings.eigen_band)
        energy = mode_energy(model, ds)
        save_dataset(ds, data / f"fe_modes_case{case}.nc")
        save_dataset(energy.drop_vars(["friction_work_dof"]), data / f"fe_energy_case{case}.nc")
        files += [f"fe_modes_case{case}.nc", f"fe_energy_case{case}.nc"]
        unstable = ds.mode.values[ds.unstable.values]
        unstable = unstable[np.argsort(-ds.growth_rate.sel(mode=unstable).values)]
        n_unstable += unstable.size
        numbers[f"case{case}_unstable"] = float(unstable.size)
        if unstable.size:
            numbers[f"case{case}_max_growth_rate"] = float(ds.growth_rate.sel(mode=unstable[0]))
        for k in unstable:
            e = energy.sel(mode=k)
            comp = str(e.dominant_body.values) if meshed else str(e.dominant_dof.values)
            lead = comp.split(" + ")[0]
            share = float(e.kinetic_share.sel(body=lead)) if meshed else float(e.dominant_dof_share)
            rows.append((case, float(rpm), float(mu), int(k), float(e.frequency_hz), float(e.growth_rate),
                         float(e.damping_ratio), comp, round(100 * share, 1), float(e.friction_work),
                         float(ds.residual.sel(mode=k))))
        if not (meshed and unstable.size):
            continue
        drawn = unstable[: settings.max_views]
        surface = mode_surface(model, ds.sel(mode=drawn), energy.sel(mode=drawn))
        save_dataset(surface, data / f"fe_surface_case{case}.nc")
        files.append(f"fe_surface_case{case}.nc")
        if _has_meshio():  # every unstable mode for ParaView: real and imaginary parts, friction work per node
            from ..stability.fe_sweep import modes_to_vtk

            modes_to_vtk(ds.sel(mode=unstable), model, data / f"fe_modes_case{case}.vtu", energy=energy)
            files.append(f"fe_modes_case{case}.vtu")
        drawn_work = energy.friction_work_drawn.sel(mode=drawn).values
        total_work = energy.friction_work.sel(mode=drawn).values
        off_mesh += list(1.0 - drawn_work / total_work)
        # a sane page: about _VIEW_BYTES of coordinates per view (float32 x, y, z per point and frame)
        frames = int(np.clip(_VIEW_BYTES // (12 * surface.sizes["surface_point"]), 6, settings.n_frames))
        for k in drawn:
            e = energy.sel(mode=k)
            fig = mode_view(surface, int(k), energy=energy, n_frames=min(frames, settings.n_frames))
            view = fig.to_html(full_html=False, include_plotlyjs=plotly_js, auto_play=False,
                               config={"displaylogo": False, "responsive": True})
            plotly_js = False
            figs: tuple[FigureRef, ...] = ()
            if "friction_work_contact" in energy:
                stem = f"fe_friction_work_case{case}_mode{int(k)}"
                _save_fig(friction_work_plot(energy, int(k)), figures, stem)
                figs = (FigureRef(stem, f"Load case {case} ({rpm:g} rpm, mu {mu:g}), mode {int(k)}: friction work "
                                        "per cycle on each pad's contact surface (red: energy fed into the mode)."),)
            text = (f"{float(e.frequency_hz):.6g} Hz, growth rate {float(e.growth_rate):+.4g} 1/s (damping ratio "
                    f"{float(e.damping_ratio):.3g}) at {rpm:g} rpm and mu {mu:g}; carried by "
                    f"{e.dominant_body.values!s}; friction feeds in {float(e.friction_work):.3g} J per cycle "
                    "at 1 m largest amplitude. Press play or drag the slider through the phase; drag the view to "
                    "turn it; the friction work per contact point is in the legend (click to show).")
            mode_sections.append(Section(f"fe_case{case}_mode{int(k)}",
                                         f"Case {case}, mode {int(k)}: {float(e.frequency_hz):.5g} Hz",
                                         (text,), figures=figs, views=(view,),
                                         numbers={"frequency_hz": float(e.frequency_hz),
                                                  "growth_rate": float(e.growth_rate),
                                                  "friction_work": float(e.friction_work)}))
    paragraphs = [
        f"{n_unstable} unstable mode{'s' if n_unstable != 1 else ''} over {len(settings.load_cases)} load "
        f"case{'s' if len(settings.load_cases) != 1 else ''}. Friction work W is the energy the friction forces "
        "feed into a mode per cycle, -pi Im(conj(phi_i)(K_f phi)_i) - pi omega Re(conj(phi_i)(D_f phi)_i) per "
        "DOF, for the shape scaled to 1 m largest amplitude (it scales with the amplitude squared); friction "
        "work minus what the damping removes equals pi sigma (2 omega m + Im phi^H C phi), the energy gain of "
        "the growth rate, for every mode.",
    ]
    if meshed and n_unstable:
        paragraphs.append(f"Each unstable mode (up to {settings.max_views} per load case, the most unstable first) "
                          "has a section below: its shape on the mesh's surface animated over its phase (a 3D view: "
                          "drag to turn, scroll to zoom) and a map of its friction work on the pads.")
    if off_mesh and max(off_mesh) > 1e-6:
        paragraphs.append(f"Up to {100 * max(off_mesh):.0f} % of a mode's friction work acts on nodes that are not "
                          "points of the mesh (e.g. the mid-side nodes of quadratic elements when the mesh holds "
                          "their vertices only): the maps show the rest. Name the input deck with every node "
                          "([fe] mesh = \"brake.inp\") to see all of it.")
    header = ("case", "rpm", "mu", "mode", "f [Hz]", "sigma [1/s]", "zeta", "dominant component",
              "kinetic share (%)", "W_friction [J]", "residual")
    table = Table("Unstable modes per load case (most unstable first)", header, tuple(rows))
    summary = Section("fe_modes", "Unstable modes", tuple(paragraphs), tables=(table,), data=tuple(files),
                      numbers={**numbers, "unstable": float(n_unstable)})
    return [summary, *mode_sections]


def _has_meshio() -> bool:
    return available("meshio")  # optional: the VTK files need it


def tracking_step(model: Any, settings: FEReportSettings, figures: Path, data: Path) -> Section:
    """The modes tracked by MAC over friction (first speed) and over disc speed (first friction)."""
    from ..plotting.fe_modes import mode_tracking_plot
    from ..stability import fe_stability_map

    rpm0, mu0 = settings.rpm[0], settings.mu[0]
    kw = {"method": settings.method, "band": settings.eigen_band}
    mus = np.linspace(*settings.mu_sweep[:2], settings.mu_sweep[2])
    rpms = np.linspace(*settings.rpm_sweep[:2], settings.rpm_sweep[2])
    over_mu = fe_stability_map(model, [rpm0], mus, **kw)
    over_rpm = fe_stability_map(model, rpms, [mu0], **kw)
    save_dataset(over_mu, data / "fe_tracking_mu.nc")
    save_dataset(over_rpm, data / "fe_tracking_rpm.nc")
    _save_fig(mode_tracking_plot(over_mu, over="mu", at=0), figures, "fe_tracking_mu")
    _save_fig(mode_tracking_plot(over_rpm, over="rpm", at=0), figures, "fe_tracking_rpm")
    grown_mu = int(over_mu.unstable.any(("rpm", "mu")).sum())
    grown_rpm = int(over_rpm.unstable.any(("rpm", "mu")).sum())
    paragraphs = (
        f"Each mode is followed from point to point by its shape (MAC on the right eigenvectors) and its "
        f"eigenvalue. Over friction mu = {mus[0]:g}..{mus[-1]:g} at {rpm0:g} rpm, {grown_mu} mode"
        f"{'s' if grown_mu != 1 else ''} become unstable; over {rpms[0]:g}..{rpms[-1]:g} rpm at mu = {mu0:g}, "
        f"{grown_rpm}. Coloured: the branches that become unstable; dots: where they are.",
    )
    figs = (FigureRef("fe_tracking_mu", f"Frequency and growth rate of the tracked modes over friction at "
                                        f"{rpm0:g} rpm."),
            FigureRef("fe_tracking_rpm", f"Frequency and growth rate of the tracked modes over disc speed at "
                                         f"mu = {mu0:g}."))
    return Section("fe_tracking", "Modes tracked over friction and disc speed", paragraphs, figures=figs,
                   data=("fe_tracking_mu.nc", "fe_tracking_rpm.nc"),
                   numbers={"unstable_over_mu": float(grown_mu), "unstable_over_rpm": float(grown_rpm)})


def fe_report(
    out_dir: str | Path,
    model: Any,
    *,
    settings: FEReportSettings | None = None,
    config: str | Path | None = None,
    quick: bool = False,
    force: bool = False,
    progress: Callable[[int, int, str], None] | None = None,
) -> Any:
    """Write the report of an FE brake model (module docstring): ``report.html``, ``figures/``, ``data/``.

    Parameters
    ----------
    out_dir : path-like
        Output folder, replaced as a whole when the run succeeds (as :func:`~squealkit.report.reproduce`).
    model : FEModel
        The model.
    settings : FEReportSettings, optional
        Load cases and sweeps; default: the ``[report]`` table of ``config`` over the model's
        reference point.
    config : path-like, optional
        The model file (named in the report; its ``[report]`` table).
    quick : bool
        Fewer sweep points and frames, PNG only.
    force : bool
        Write into a folder holding other files, leaving them alone.
    progress : callable, optional
        ``progress(done, total, step_name)``.

    Returns
    -------
    squealkit.report.ReproduceResult
    """
    from .runner import REPORT_FILES, ReportStep, run_report

    out = Path(out_dir)
    check_output(out, directory=True, force=force, names=REPORT_FILES)  # before the work, not after
    settings = settings or load_fe_report_settings(config, model, quick=quick)
    steps = [
        ReportStep("FE model", lambda fig, dat: model_step(model, settings)),
        ReportStep("unstable modes", lambda fig, dat: modes_step(model, settings, fig, dat)),
        ReportStep("tracking", lambda fig, dat: tracking_step(model, settings, fig, dat)),
    ]
    subtitle = f"FE model, {model.n_dof} DOFs" + (f", from {Path(config).name}" if config is not None else "")
    return run_report(out, steps, title="squealkit report: unstable modes of an FE brake", subtitle=subtitle,
                      quick=quick, force=force, progress=progress)

"""The HTML campaign report: summary tables and the industry's figures (one self-contained file)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ..report.document import FigureRef, Section, Table

__all__ = ["write_campaign_report"]


def write_campaign_report(store, summary: dict[str, Any], out: Path, *, threshold_dba: float = 70.0) -> Path:
    """Write ``out/report.html`` (figures embedded) and ``out/figures/*.png``.

    Parameters
    ----------
    store : CampaignStore
        The campaign's store (its applications and squeal events).
    summary : dict
        :func:`squealkit.campaign.run_campaign`'s summary of the same campaign.
    out : Path
        The (staging) output folder; ``figures/`` is made in it.
    threshold_dba : float, default 70.0
        Squeal threshold [dB(A)] the figures draw (the criteria's, as run_campaign passes it).

    Returns
    -------
    Path
        The report.
    """
    import matplotlib.pyplot as plt

    from ..io import atomic_path, save_figure
    from ..plotting import campaign as cp
    from ..report.html import render_html

    apps = store.query("SELECT * FROM applications WHERE error IS NULL AND {in_matrix} ORDER BY application")
    events = store.query("SELECT * FROM squeal WHERE {in_matrix} ORDER BY application, event")
    synthetic = bool(len(apps) and apps["synthetic"].all())
    figures = out / "figures"
    figures.mkdir(exist_ok=True)
    figs = {
        "occurrence_by_band": (cp.occurrence_by_band_plot(summary, synthetic=synthetic),
                               "Occurrence (SAE J2521: share of applications with squeal) per 1/3-octave band."),
        "noise_matrix_temperature": (cp.noise_matrix_plot(events, by="temperature_c", label="brake temperature [C]",
                                                          threshold_dba=threshold_dba, synthetic=synthetic),
                                     "Noise matrix: squeal frequency against brake temperature, colour: peak level."),
        "noise_matrix_pressure": (cp.noise_matrix_plot(events, by="pressure_bar", label="brake pressure [bar]",
                                                       threshold_dba=threshold_dba, synthetic=synthetic),
                                  "Noise matrix: squeal frequency against brake pressure, colour: peak level."),
        "level_vs_application": (cp.level_vs_application_plot(apps, threshold_dba=threshold_dba, synthetic=synthetic),
                                 "Peak level (Fast, A-weighted, criteria band) of every application."),
        "runout_phase": (cp.runout_phase_plot(apps[apps["squeal"]], synthetic=synthetic),
                         "Run-out phase of the squeal: its disc angle relative to the run-out crest."),
    }
    refs = []
    for stem, (fig, caption) in figs.items():
        save_figure(fig, figures / f"{stem}.png")
        plt.close(fig)
        refs.append(FigureRef(stem, caption))
    paragraphs = [f"Criteria: {summary['criteria']}."]
    if synthetic:
        paragraphs.insert(0, "SYNTHETIC DATA: every recording of this campaign was made by squealkit with known "
                             "truth; it is not a measurement.")
    failed = summary["failed"]
    if failed:
        n_all = summary["applications"] + len(failed)
        paragraphs.append(f"{len(failed)} of {n_all} applications could not be analysed and are left out of every "
                          "figure and table above the last one; the table 'Failed applications' gives the reason "
                          "of each (a re-run retries them).")
    no_link = summary.get("runout_unavailable", [])
    if no_link:
        reasons = sorted({r["reason"] for r in no_link})
        paragraphs.append(f"The run-out link (median correlation and rising fraction) is unavailable for "
                          f"{len(no_link)} of {summary['applications']} applications, whose squeal was analysed "
                          f"all the same: {'; '.join(reasons)}.")
    link = summary["runout_link"]
    table = Table("Campaign", ("quantity", "value"), (
        ("applications", summary["applications"]),
        ("applications with squeal", summary["applications_with_squeal"]),
        ("occurrence [%]", summary["occurrence_percent"]),
        ("highest peak [dB(A)]", summary["max_peak_dba"]),
        ("median growth/slope correlation (squealing applications)", link["median_growth_slope_correlation"]),
        ("median rising_fraction (squealing applications)", link["median_rising_fraction"]),
        ("applications without run-out link", len(no_link)),
        ("failed applications", len(summary["failed"])),
    ))
    bands = Table("Occurrence by 1/3-octave band", ("band [Hz]", "applications with squeal", "occurrence [%]"),
                  tuple((f"{b['band_hz'][0]:.0f}-{b['band_hz'][1]:.0f}", b["applications_with_squeal"],
                         b["occurrence_percent"]) for b in summary["by_band"]))
    temps = Table("Occurrence by brake temperature", ("temperature [C]", "applications", "occurrence [%]"),
                  tuple((f"{r['range'][0]:g} to {r['range'][1]:g}", r["applications"], r["occurrence_percent"])
                        for r in summary["by_temperature_c"]))
    tables = (table, bands, temps)
    if failed:
        tables += (Table("Failed applications", ("application", "file", "error"),
                         tuple((f["application"], f["file"], f["error"]) for f in failed)),)
    section = Section("campaign", "Brake noise campaign", tuple(paragraphs), (), tables, tuple(refs))
    html = render_html([section], figures, title="squealkit brake noise campaign",
                       subtitle=f"{summary['applications']} applications"
                       + (f" ({len(failed)} more failed)" if failed else "") + "; database: campaign.duckdb (SQL view "
                                "'squeal': events with their conditions)")
    with atomic_path(out / "report.html") as tmp:
        tmp.write_text(html, encoding="utf-8")
    return out / "report.html"

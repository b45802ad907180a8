"""``squealkit analyze``: squeal events, frequency and run-out relation of rig recordings."""

from __future__ import annotations

from pathlib import Path

import click

from .._validation import InputError
from ._options import (
    check_output_suffix,
    emit_json,
    progress_callback,
    recording_kwargs_from_options,
    recording_options,
    scheduler_option,
    writable,
    writable_folder,
)

#: Show a progress bar for recordings longer than this [s].
_PROGRESS_ABOVE_S = 60.0


#: The figure formats --plot takes.
_FIGURE_SUFFIXES = (".png", ".svg", ".pdf")


def _figure_stem(ctx: click.Context, param: click.Parameter, value: Path | None) -> Path | None:
    """--plot FILE.png (like every other --plot), or a folder as before (deprecated, noted on stderr)."""
    if value is None or ctx.resilient_parsing:
        return value
    if value.suffix.lower() in _FIGURE_SUFFIXES and not value.is_dir():
        return writable(ctx, param, value)
    if value.suffix and not value.is_dir():
        raise InputError(f"--plot {str(value)!r} must end in {' or '.join(_FIGURE_SUFFIXES)} "
                         "(the figures are written beside it as NAME_time.png, NAME_spectrogram.png, ...).")
    from ._options import PENDING_NOTES

    PENDING_NOTES.append(f"squealkit: --plot FOLDER is deprecated: give a file name such as --plot "
                         f"{value / 'figs.png'} (writes figs_time.png, ...); the folder {str(value)!r} is used "
                         "as before.")
    return writable_folder(ctx, param, value)


@click.command()
@click.argument("files", nargs=-1, required=True, type=click.Path(path_type=Path))
@recording_options(required=True)
@click.option("--json", "as_json", is_flag=True, help="Print the result (or the campaign) as JSON.")
@click.option("--plot", "plot_dir", type=click.Path(path_type=Path), default=None, callback=_figure_stem,
              help="Write the figures (paper Figs. 6-13 equivalents, polar plot): --plot figs.png writes "
              "figs_time.png, figs_spectrogram.png, ... (.png, .svg or .pdf); with several FILEs "
              "figs_<recording>_time.png, ... (A folder still works, deprecated.)")
@click.option("--out", "out_path", type=click.Path(dir_okay=False, path_type=Path), default=None,
              callback=writable,
              help="Write the labelled result of one file as netCDF (.nc).")
@click.option("--summary", "summary_path", type=click.Path(dir_okay=False, path_type=Path), default=None,
              callback=writable,
              help="Write the campaign summary (one row per recording) as CSV.")
@scheduler_option
def analyze(files: tuple[Path, ...], mic: str, displacement: str, rpm: float | None, radius: float,
            tacho: str | None, tacho_kind: str, pulses_per_rev: int, probe_offset_deg: float, acoustic_delay: float,
            polarity: str, setup: str | None,
            band: str | None, threshold_dba: float, time_weighting: str, min_duration: float, min_tnr_db: float,
            fs: float | None,
            scales: tuple[str, ...], units: tuple[str, ...], as_json: bool, plot_dir: Path | None,
            out_path: Path | None, summary_path: Path | None, scheduler: str | None) -> int:
    """Find squeal in rig recordings and relate it to the disc run-out (paper §5).

    Each FILE is .csv, .wav, .nc/.h5 or .tdms with a microphone and a displacement
    channel. Squeal follows SAE J2521 (--setup component, the default for a rig that is
    not a full corner: 2-16 kHz; corner: 1.25-16 kHz): the A-weighted, Fast time-weighted
    level in the band reaches the threshold; each tonal component is an event (VDA 303).
    The criteria are named in every output. growth/slope correlation (the squeal's growth
    rate against the run-out slope) is the primary run-out statistic; rising_fraction is
    the share of squeal energy on rising run-out.

    \b
    Example:
      squealkit synth --out rec.nc --seed 1
      squealkit analyze rec.nc --mic mic --displacement displacement --rpm 900 --radius 0.05
      squealkit analyze a.tdms b.tdms --mic Mic --displacement Probe --rpm 900 --radius 0.05 \\
          --summary campaign.csv
      squealkit analyze runs/*.nc --mic mic --displacement displacement --rpm 900 \\
          --radius 0.05 --summary campaign.csv --scheduler tcp://10.0.0.5:8786

    \b
    With --scheduler each recording is analysed by a worker of the Dask cluster
    (the files must be readable there under the same paths) and only the campaign
    summary comes back: the output is the campaign, for one file or many.

    \b
    With several FILEs, one that cannot be read or analysed does not stop the
    others: it is left out of the summary and listed on stderr at the end, and the
    exit code is 1 (2 when none could be analysed).
    """
    from ..campaign.recordings import summarize_campaign
    from ..io import save_dataset, write_text
    from ..measurement import open_recording

    crit_kw, scale_map, unit_map = recording_kwargs_from_options(
        rpm=rpm, tacho=tacho, tacho_kind=tacho_kind, pulses_per_rev=pulses_per_rev, probe_offset_deg=probe_offset_deg,
        acoustic_delay=acoustic_delay, polarity=polarity, setup=setup, band=band, threshold_dba=threshold_dba,
        time_weighting=time_weighting, min_duration=min_duration, min_tnr_db=min_tnr_db, scales=scales, units=units)
    check_output_suffix(out_path, (".nc",), "--out")
    check_output_suffix(summary_path, (".csv",), "--summary")
    if out_path is not None and len(files) > 1:
        raise InputError("--out takes one FILE; use --summary for several.")
    folder = plot_dir is not None and plot_dir.suffix.lower() not in _FIGURE_SUFFIXES
    if folder and not plot_dir.is_dir():
        plot_dir.mkdir(parents=True, exist_ok=True)
    kwargs = dict(mic=mic, displacement=displacement, rpm=rpm, radius=radius, **crit_kw)
    if scheduler is not None:
        sources = [open_recording(f, fs=fs, scale=scale_map or None, units=unit_map or None) for f in files]
        for src in sources:  # bad channel names fail here, in one line, not on a worker
            src.resolve(mic), src.resolve(displacement)
        if plot_dir is not None or out_path is not None:
            raise InputError("--plot and --out work on this machine only; leave them out with --scheduler.")
        _campaign_on_cluster(files, scheduler, as_json, summary_path, fs=fs, scale=scale_map or None,
                             units=unit_map or None, **kwargs)
        return 0
    done, failed = [], []
    for f in files:
        try:
            src = open_recording(f, fs=fs, scale=scale_map or None, units=unit_map or None)
            res = _analyse(src, f, kwargs)
        except InputError as e:
            if len(files) == 1:
                raise
            failed.append((f, str(e)))  # one bad recording does not stop the others
            continue
        done.append((f, res))
        if plot_dir is not None:
            if folder:
                stem, suffix = plot_dir / f.stem, ".png"
            else:
                name = plot_dir.stem if len(files) == 1 else f"{plot_dir.stem}_{f.stem}"
                stem, suffix = plot_dir.with_name(name), plot_dir.suffix.lower()
            _write_plots(src, res, mic, displacement, stem, suffix)
    if not done:
        raise InputError(f"None of the {len(files)} recordings could be analysed; the first: {failed[0][1]}")
    results = [r for _, r in done]
    if out_path is not None:
        save_dataset(results[0].to_dataset(), out_path)
    campaign = summarize_campaign(results, [str(f) for f, _ in done]) if len(files) > 1 or summary_path else None
    if summary_path is not None and campaign is not None:
        write_text(summary_path, campaign.to_csv())
    if as_json:
        out = results[0].to_dict() if campaign is None else campaign.to_dict()
        if failed:
            out["failed"] = [{"recording": str(f), "error": e} for f, e in failed]
        emit_json(out)
    else:
        for f, r in done:
            _print_text(f, r)
        if campaign is not None:
            _print_campaign(campaign)
    return _report_failures(failed, len(files))


def _analyse(src, f: Path, kwargs: dict):
    """One recording's analysis, with a progress bar on stderr for a long one."""
    from ..measurement import analyze_recording

    if src.duration <= _PROGRESS_ABOVE_S:
        return analyze_recording(src, **kwargs)
    from rich.progress import Progress

    with Progress(transient=True, console=_stderr_console()) as bar:
        task = bar.add_task(f"analysing {f.name}", total=src.n_samples)

        def report(done: int, total: int) -> None:
            bar.update(task, completed=done)

        return analyze_recording(src, progress=report, **kwargs)


def _report_failures(failed: list[tuple[Path, str]], n: int) -> int:
    """List the recordings that could not be analysed on stderr, last; the exit code: 1 if any, else 0."""
    if not failed:
        return 0
    click.echo(f"squealkit analyze: {len(failed)} of {n} recordings could not be analysed (left out of the "
               "summary):", err=True)
    for f, e in failed:
        click.echo(f"{f}: {e}", err=True)
    return 1


def _print_campaign(campaign) -> None:
    click.echo(f"criteria: {campaign.criteria}")
    click.echo(f"campaign: {campaign.occurrence_percent:.1f}% of {len(campaign.rows)} recordings squeal, "
               f"{campaign.n_events} events; frequencies: "
               + (", ".join(f"{g['frequency_hz']:.0f} Hz ({g['n_events']})" for g in campaign.frequencies)
                  or "none"))


def _campaign_on_cluster(files, scheduler: str, as_json: bool, summary_path: Path | None, **kwargs) -> None:
    from ..campaign.recordings import analyze_campaign
    from ..io import write_text
    from ..scale import cluster_client

    with cluster_client(scheduler) as client, \
            progress_callback("recordings", enabled=not as_json and len(files) > 1) as cb:
        # as the local path: analyze needs a disc speed (the campaign command is the one without)
        campaign = analyze_campaign(list(files), client=client, progress=cb, require_runout=True, **kwargs)
    if summary_path is not None:
        write_text(summary_path, campaign.to_csv())
    if as_json:
        emit_json(campaign.to_dict())
        return
    for r in campaign.rows:
        tag = " [SYNTHETIC]" if r["synthetic"] else ""
        what = (f"squeal {r['squeal_frequency_hz']:.1f} Hz, peak {r['peak_dba']:.1f} dB(A), {r['n_events']} events, "
                f"rising_fraction {r['rising_fraction']:.3f}" if r["squeal"] else "no squeal")
        click.echo(f"{r['recording']}{tag}: {r['duration_s']:.3f} s, {what}")
    _print_campaign(campaign)
    if summary_path is not None:
        click.echo(f"wrote summary: {summary_path}")


def _stderr_console():
    from rich.console import Console

    return Console(stderr=True)


def _print_text(f: Path, r) -> None:
    tag = " [SYNTHETIC]" if r.attrs.get("synthetic") else ""
    click.echo(f"{f}{tag}: {r.duration_s:.3f} s at {r.fs:g} Hz")
    click.echo(f"  criteria: {r.settings.criteria.describe()}")
    if not r.squeal:
        click.echo(f"  no squeal (peak {r.peak_dba:.1f} dB(A))")
    else:
        corr = "n/a" if r.growth_slope_correlation is None else f"{r.growth_slope_correlation:.2f}"
        click.echo(f"  squeal {r.squeal_frequency_hz:.1f} Hz, peak {r.peak_dba:.1f} dB(A), {len(r.events)} events")
        click.echo(f"  growth/slope correlation {corr} (squeal growth rate against the run-out slope), "
                   f"rising_fraction {r.rising_fraction:.3f} (share of squeal energy on rising run-out)")
        if r.runout_phase_deg is not None:
            click.echo(f"  run-out phase {r.runout_phase_deg:+.0f} deg (where the squeal sounds on the disc, from the "
                       "run-out crest; negative: on the rising run-out)")
        for e in r.events[:10]:
            click.echo(f"    {e.start_s:8.4f}-{e.end_s:8.4f} s  {e.frequency_hz:8.1f} Hz  {e.peak_dba:6.1f} dB(A)")
        if len(r.events) > 10:
            click.echo(f"    ... {len(r.events) - 10} more (see --json)")
    ro = r.to_dict()["runout"]
    if ro["sro_p2p_m"] is not None:
        click.echo(f"  run-out per revolution (median p-p): {ro['sro_p2p_m'] * 1e6:.2f} um "
                   f"(macro {ro['macro_p2p_m'] * 1e6:.2f}, micro {ro['micro_p2p_m'] * 1e6:.2f}); "
                   f"max tan(theta) {ro['max_tan_theta']:.2e}")


def _write_plots(src, res, mic: str, displacement: str, stem: Path, suffix: str = ".png",
                 max_seconds: float = 10.0) -> None:
    """Figures from the first ``max_seconds`` of the recording plus the whole-recording results."""
    import numpy as np

    from ..io import save_figure
    from ..measurement import measurement_signals, recording_dataset
    from ..plotting import measurement as mp

    names = [src.resolve(mic), src.resolve(displacement)]
    n_max = int(min(src.n_samples, max_seconds * src.fs))
    parts: dict[str, list] = {n: [] for n in names}
    got = 0
    for _, block in src.iter_blocks(names):
        for n in names:
            parts[n].append(block[n][: n_max - got])
        got += len(block[names[0]])
        if got >= n_max:
            break
    rec = recording_dataset({n: np.concatenate(v) for n, v in parts.items()}, src.fs,
                            {n: src.units.get(n, "") for n in names},
                            {"synthetic": int(bool(res.attrs.get("synthetic")))})
    figs = mp.measurement_figures(res, measurement_signals(rec, res, mic=names[0], displacement=names[1]))
    figs["event_phase"] = mp.event_phase_plot(res)  # every event's place on the disc
    for key, fig in figs.items():
        save_figure(fig, stem.parent / f"{stem.name}_{key}{suffix}")

"""Analyse every application of a test matrix into the campaign store, then summarise and report."""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from .._validation import InputError
from ..measurement.squeal.criteria import squeal_criteria
from .matrix import read_matrix
from .store import CampaignStore
from .summary import band_of, campaign_summary, third_octave_bands

__all__ = ["run_campaign"]


#: Results stored per transaction (at most a second's worth).
_BATCH = 64


def _failure(e: BaseException) -> str:
    """One line for a failed application: the message of a bad file or option as it is, anything else
    with its exception type (a fault of no known kind, still only this application's)."""
    text = " ".join(str(e).split())
    if not isinstance(e, InputError | OSError):
        text = f"{type(e).__name__}: {text}"
    return text[:500]


def _analyze_application(item: dict[str, Any]) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """One task: analyse one application's recording; keep its row and its events (small).

    Whatever goes wrong with one application (an unreadable or damaged file, a channel that
    is missing or text, an unforeseen error) makes it a failed application with its reason;
    the campaign goes on with the others.

    ``item``: ``app`` (the application's row: ``application``, ``file``, ...), ``analysis`` (the
    arguments of :func:`~squealkit.measurement.analyze_recording`), ``bands`` (third-octave bands
    of the events), optionally ``condition_channels`` and ``open`` (arguments of
    :func:`~squealkit.measurement.open_recording`: ``fs``, ``scale``, ``units``). The one analysis
    task of both :func:`run_campaign` and :func:`~squealkit.campaign.analyze_campaign`.
    """
    from ..measurement import analyze_recording, open_recording

    app, kw, bands = item["app"], item["analysis"], item["bands"]
    row = {**app, "error": None}
    try:
        for col, channel in item.get("condition_channels", {}).items():
            if not math.isfinite(row[col]):  # the matrix does not say: the channel's mean over the application
                row[col] = _channel_mean(app["file"], channel, col)
        open_kw = {k: v for k, v in item.get("open", {}).items() if v is not None}
        res = analyze_recording(open_recording(app["file"], **open_kw) if open_kw else app["file"], **kw)
    except Exception as e:  # one application's fault, whatever it is, is recorded, not raised
        row["error"] = _failure(e)
        return row, []
    d = res.to_dict()
    row.update(duration_s=res.duration_s, synthetic=bool(d["synthetic"]), squeal=res.squeal, peak_dba=res.peak_dba,
               squeal_frequency_hz=res.squeal_frequency_hz, n_events=len(res.events),
               growth_slope_correlation=res.growth_slope_correlation, rising_fraction=res.rising_fraction,
               runout_phase_deg=res.runout_phase_deg, mean_rpm=res.settings.rpm,
               runout_unavailable=res.runout_unavailable, criteria=res.settings.criteria.describe())
    events = []
    for i, e in enumerate(res.events):
        b = band_of(e.frequency_hz, bands)
        events.append({"application": app["application"], "event": i, "start_s": e.start_s, "end_s": e.end_s,
                       "duration_s": e.duration_s, "frequency_hz": e.frequency_hz, "peak_dba": e.peak_dba,
                       "band_center_hz": b[0] if b else math.nan, "band_lo_hz": b[1] if b else math.nan,
                       "band_hi_hz": b[2] if b else math.nan, "runout_phase_deg": e.runout_phase_deg})
    return row, events


#: The unit each condition is stored in (the matrix's columns).
_CONDITION_UNITS = {"pressure_bar": "bar", "temperature_c": "degC"}


def _channel_mean(path: str, channel: str, condition: str) -> float:
    """Mean of a condition channel over the application, in the condition's unit (``bar``, ``degC``).

    A channel the reader converted to SI (its file said ``bar``: read in Pa) is converted back
    to the condition's unit; any other channel is taken in the unit the file gives.
    """
    from ..measurement import open_recording

    src = open_recording(path)
    name = src.resolve(channel)
    total = 0.0
    for _, blk in src.iter_blocks([name]):
        total += float(blk[name].sum())
    mean = total / src.n_samples
    if name in src._extra.get("file_units", {}):
        from .._units import _pint_unit, registry

        have, want = src.units.get(name, ""), _CONDITION_UNITS[condition]
        try:
            mean = float(registry().Quantity(mean, _pint_unit(have)).to(_pint_unit(want)).magnitude)
        except Exception as e:  # pint's dimensionality and parsing errors
            raise InputError(f"Channel {channel!r} of {path}: its unit {have!r} is not one of {condition} "
                             f"({want}).") from e
    return mean


def _check_options(crit: Any, radius: float, rpm: float | None, options: dict[str, Any]) -> None:
    """The analysis options every application shares, checked once as :func:`analyze_recording`
    checks them (what depends on a recording, its sample rate, is checked per application)."""
    from ..measurement.analysis import AnalysisSettings

    try:
        settings = AnalysisSettings(rpm=rpm, radius=radius, criteria=crit, **options)  # type: ignore[arg-type]
    except TypeError as e:
        raise InputError(f"Unknown analysis option: {e}") from e
    settings.validated()


def run_campaign(
    matrix: str | Path,
    out: str | Path,
    *,
    mic: str | int,
    displacement: str | int,
    radius: float,
    tacho: str | int | None = None,
    rpm: float | None = None,
    setup: str | None = None,
    band: tuple[float, float] | None = None,
    threshold_dba: float = 70.0,
    time_weighting: str = "fast",
    min_duration: float = 0.01,
    client: Any = None,
    progress: Callable[[int, int], None] | None = None,
    report: bool = True,
    pressure_channel: str | None = None,
    temperature_channel: str | None = None,
    **options: Any,
) -> dict[str, Any]:
    """Analyse a campaign: every application of ``matrix`` into ``out/campaign.duckdb``.

    Applications already in the store with the same criteria and an unchanged file (size and
    modification time) are skipped, so re-running updates an output without losing earlier
    results and a killed run resumes where it stopped (each application is committed as it
    finishes). Writes ``out/summary.json`` and, with ``report``, ``out/report.html`` with its
    figures in ``out/figures``.

    An application whose recording cannot be analysed (missing, unreadable, damaged, a bad
    channel) does not stop the campaign: it is stored with ``status = 'failed'`` and its
    one-line ``error``, left out of every statistic, and listed in the summary's ``failed``
    (``application``, ``file``, ``error``) and in the report. Failed applications are
    retried on every re-run (the file may have been fixed); the ones analysed are not.

    Squeal occurrence needs no disc speed: an application without one (no ``rpm``, ``tacho``
    nor matrix ``rpm``, or a tacho that cannot give one, such as 2 marks in a short low-speed
    drag) is analysed for squeal, and its run-out link is stored as unavailable with the
    reason (column ``runout_unavailable``; the summary's ``runout_unavailable`` lists them).

    Parameters
    ----------
    matrix : path
        Test matrix CSV (:func:`squealkit.campaign.read_matrix`).
    out : path
        Output folder (created). A folder holding files squealkit did not write is refused;
        the database stays in it across runs, the summary, report and figures of a run
        appear together when it ends (:func:`squealkit.io.output_folder`).
    mic, displacement, radius, tacho, rpm
        As for :func:`squealkit.measurement.analyze_recording`; a matrix column ``rpm``
        gives each application's speed where there is no tacho. Optional: without a speed the
        run-out link is left out (see above).
    setup, band, threshold_dba, time_weighting, min_duration
        The squeal criteria (:func:`squealkit.measurement.squeal_criteria`; ``band`` in [Hz]).
    client : distributed.Client, optional
        Analyse the applications on a Dask cluster (the files must be readable there).
    progress : callable, optional
        ``progress(done, total)`` in applications still to analyse.
    report : bool, default True
        Also write ``out/report.html`` and its figures.
    pressure_channel, temperature_channel : str, optional
        Channels [bar], [C] whose mean over an application gives its condition where the
        matrix leaves ``pressure_bar`` or ``temperature_c`` empty.
    **options
        Further analysis options (``probe_offset_deg``, ``pulses_per_rev``, ``nperseg``, ...).

    Returns
    -------
    dict
        The summary written to ``summary.json``; ``failed`` lists the applications that
        could not be analysed (empty when all were).
    """
    from ..io import output_folder

    crit = squeal_criteria(setup, band=band, threshold_dba=threshold_dba, time_weighting=time_weighting,
                           min_duration=min_duration)
    _check_options(crit, radius, rpm, options)  # bad options: refused before anything is read or written
    apps = read_matrix(matrix)
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    bands = third_octave_bands(crit.band)
    # J2521 occurrence needs no disc speed: without one (no rpm, or a tacho that gives none) an
    # application is analysed for squeal and its run-out link stored as unavailable, with the reason
    kw_base = dict(mic=mic, displacement=displacement, radius=radius, setup=crit.setup if crit.setup != "user"
                   else None, band=crit.band, threshold_dba=crit.threshold_dba, time_weighting=crit.time_weighting,
                   min_duration=crit.min_duration, require_runout=False, **options)
    # the folder is squealkit's or new (refused if it holds other files); the database stays in it across runs
    # (a killed run resumes), the summary, report and figures of this run are staged and appear together
    with output_folder(out, keep=_STORE_FILES) as stage, CampaignStore(out / "campaign.duckdb") as store:
        done = store.done(crit.describe())
        items = []
        for a in apps:
            st = a.file.stat() if a.file.is_file() else None
            sig = (st.st_size, st.st_mtime_ns) if st else (None, None)
            missing = (f"Recording {str(a.file)!r} is a folder, not a file." if a.file.is_dir()
                       else f"Recording {str(a.file)!r} does not exist.")
            if st is not None and done.get(a.application) == sig:
                continue
            row = {"application": a.application, "file": str(a.file), "section": a.section, "mode": a.mode,
                   "pressure_bar": a.pressure_bar, "temperature_c": a.temperature_c, "speed_kmh": a.speed_kmh,
                   "mu": a.mu, "criteria": crit.describe(), "file_size": sig[0], "file_mtime_ns": sig[1]}
            kw = dict(kw_base)
            if tacho is not None:
                kw["tacho"] = tacho
            elif math.isfinite(a.rpm):
                kw["rpm"] = a.rpm
            elif rpm is not None:
                kw["rpm"] = rpm
            if st is None:
                store.put({**row, "error": missing}, [])
                continue
            cond = {c: ch for c, ch in (("pressure_bar", pressure_channel), ("temperature_c", temperature_channel))
                    if ch is not None}
            items.append({"app": row, "analysis": kw, "bands": bands, "condition_channels": cond})
        from ..scale import map_tasks

        batch: list[tuple[dict[str, Any], list[dict[str, Any]]]] = []
        flushed = time.monotonic()
        try:
            for _, result in map_tasks(_analyze_application, items, client=client, progress=progress,
                                       name="squealkit-application"):
                batch.append(result)
                # stored in batches (a transaction per application would cost the client 5-10 ms
                # each, CPU the workers need); a killed run loses at most the last second's results
                if len(batch) >= _BATCH or time.monotonic() - flushed > 1.0:
                    full, batch, flushed = batch, [], time.monotonic()
                    store.put_many(full)  # (a failing batch is not tried again below)
        finally:  # also on Ctrl-C: what was analysed is kept
            store.put_many(batch)
        store.limit_to([a.application for a in apps])  # the summary and report: this matrix's applications
        summary = campaign_summary(store, crit.band, crit.describe())
        summary["analysed_now"] = len(items)
        (stage / "summary.json").write_text(json.dumps(_clean(summary), indent=2, allow_nan=False))
        if report:
            from .report import write_campaign_report

            write_campaign_report(store, summary, stage, threshold_dba=crit.threshold_dba)
    return summary


#: The campaign's database and its write-ahead log, kept in the output folder across runs.
_STORE_FILES = ("campaign.duckdb", "campaign.duckdb.wal")


def _clean(obj: Any) -> Any:
    """JSON-ready: NaN and infinities become None, NumPy scalars plain numbers."""
    if isinstance(obj, dict):
        return {k: _clean(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_clean(v) for v in obj]
    if hasattr(obj, "item") and not isinstance(obj, str):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj

"""A campaign of recordings without a test matrix: analysed by the campaign engine, summarised in memory.

Occurrence is the percentage of recordings (brake applications) with at least one squeal
event (SAE J2521); frequencies of all events are grouped within a tolerance so a campaign shows
which squeal frequencies occur and how often (VDA 303). :func:`analyze_campaign` analyses each
recording with the same task as :func:`~squealkit.campaign.run_campaign` (one analysis path);
:func:`summarize_campaign` summarises analyses already made.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .._validation import InputError
from ..measurement.analysis import MeasurementResult
from ..measurement.squeal.criteria import squeal_criteria
from .run import _analyze_application
from .summary import third_octave_bands

__all__ = ["CampaignSummary", "analyze_campaign", "summarize_campaign"]

_COLUMNS = ("recording", "synthetic", "duration_s", "squeal", "n_events", "squeal_frequency_hz", "peak_dba",
            "rising_fraction")


@dataclass(frozen=True)
class CampaignSummary:
    """Per-recording rows and campaign totals.

    Attributes
    ----------
    rows : tuple of dict
        One per recording, keys as in the CSV columns.
    occurrence_percent : float
        Share of recordings (brake applications) with squeal [%]: a tonal component reached
        the threshold (so the application's peak level did too), SAE J2521's occurrence.
    n_events : int
        Squeal events over all recordings.
    frequencies : tuple of dict
        ``frequency_hz`` (event-count-weighted mean), ``n_events``, ``n_recordings``,
        ``max_peak_dba`` per frequency group.
    criteria : str
        The criteria every recording was analysed with (see ``SquealCriteria.describe``).
    """

    rows: tuple[dict[str, Any], ...]
    occurrence_percent: float
    n_events: int
    frequencies: tuple[dict[str, Any], ...]
    criteria: str = ""

    def to_dict(self) -> dict[str, Any]:
        """Plain dict for JSON."""
        return {"criteria": self.criteria, "n_recordings": len(self.rows),
                "occurrence_percent": self.occurrence_percent,
                "n_events": self.n_events, "frequencies": list(self.frequencies), "recordings": list(self.rows)}

    def to_csv(self) -> str:
        """CSV text: ``#`` comment lines with the totals, then one row per recording."""
        buf = io.StringIO()
        buf.write(f"# squealkit campaign summary ({self.criteria}): n_recordings={len(self.rows)}, "
                  f"occurrence_percent={self.occurrence_percent:.6g}, n_events={self.n_events}\n")
        for g in self.frequencies:
            buf.write(f"# frequency_hz={g['frequency_hz']:.6g}, n_events={g['n_events']}, "
                      f"n_recordings={g['n_recordings']}, max_peak_dba={g['max_peak_dba']:.4g}\n")
        w = csv.DictWriter(buf, fieldnames=_COLUMNS, lineterminator="\n")
        w.writeheader()
        for r in self.rows:
            w.writerow({k: ("" if r[k] is None else r[k]) for k in _COLUMNS})
        return buf.getvalue()


def summarize_campaign(results: Sequence[MeasurementResult], names: Sequence[str] | None = None, *,
                       freq_tol: float = 100.0) -> CampaignSummary:
    """Summarise the analyses of several recordings.

    Parameters
    ----------
    results : sequence of MeasurementResult
    names : sequence of str, optional
        Recording names (default: each result's source).
    freq_tol : float
        Events whose frequencies lie within this distance [Hz] of a group's mean join it.

    Returns
    -------
    CampaignSummary
    """
    if not results:
        raise InputError("A campaign summary needs at least one recording.")
    names = list(names) if names is not None else [str(r.attrs.get("source")) for r in results]
    if len(names) != len(results):
        raise InputError(f"Got {len(names)} names for {len(results)} recordings.")
    return _summarize([_row(name, r) for name, r in zip(names, results, strict=True)], freq_tol)


def _row(name: str, r: MeasurementResult) -> dict[str, Any]:
    """What the campaign keeps of one analysis: the CSV row and the events' frequency and level."""
    return {"recording": name, "synthetic": int(bool(r.attrs.get("synthetic", False))),
            "duration_s": r.duration_s, "squeal": int(r.squeal), "n_events": len(r.events),
            "squeal_frequency_hz": r.squeal_frequency_hz, "peak_dba": r.peak_dba,
            "rising_fraction": r.rising_fraction,
            "_events": [(e.frequency_hz, e.peak_dba) for e in r.events], "_criteria": r.settings.criteria.describe()}


def _summarize(rows: Sequence[dict[str, Any]], freq_tol: float) -> CampaignSummary:
    groups: list[dict[str, Any]] = []
    for row in rows:
        for f_hz, peak in row["_events"]:
            g = next((g for g in groups if abs(g["frequency_hz"] - f_hz) <= freq_tol), None)
            if g is None:
                g = {"frequency_hz": f_hz, "n_events": 0, "recordings": set(), "max_peak_dba": -np.inf}
                groups.append(g)
            g["frequency_hz"] = (g["frequency_hz"] * g["n_events"] + f_hz) / (g["n_events"] + 1)
            g["n_events"] += 1
            g["recordings"].add(row["recording"])
            g["max_peak_dba"] = max(g["max_peak_dba"], peak)
    freqs = tuple({"frequency_hz": g["frequency_hz"], "n_events": g["n_events"],
                   "n_recordings": len(g["recordings"]), "max_peak_dba": g["max_peak_dba"]}
                  for g in sorted(groups, key=lambda g: -g["n_events"]))
    occ = 100.0 * sum(r["squeal"] for r in rows) / len(rows)
    crit = sorted({r["_criteria"] for r in rows})
    if len(crit) > 1:
        raise InputError(f"The recordings were analysed with different criteria: {crit}.")
    clean = tuple({k: v for k, v in r.items() if not k.startswith("_")} for r in rows)
    return CampaignSummary(clean, occ, sum(r["n_events"] for r in rows), freqs, crit[0])


def _engine_row(name: str, row: dict[str, Any], events: list[dict[str, Any]]) -> dict[str, Any]:
    """The summary row of one recording from the campaign engine's application row and events."""
    if row["error"] is not None:
        raise InputError(f"Recording {name!r}: {row['error']}")
    return {"recording": name, "synthetic": int(bool(row["synthetic"])), "duration_s": row["duration_s"],
            "squeal": int(row["squeal"]), "n_events": row["n_events"],
            "squeal_frequency_hz": row["squeal_frequency_hz"], "peak_dba": row["peak_dba"],
            "rising_fraction": row["rising_fraction"],
            "_events": [(e["frequency_hz"], e["peak_dba"]) for e in events], "_criteria": row["criteria"]}


def analyze_campaign(
    files: Sequence[str | Path],
    *,
    mic: str | int,
    displacement: str | int,
    radius: float,
    rpm: float | None = None,
    fs: float | None = None,
    scale: Mapping[str, float] | None = None,
    units: Mapping[str, str] | None = None,
    freq_tol: float = 100.0,
    client: Any = None,
    progress: Callable[[int, int], None] | None = None,
    **options: Any,
) -> CampaignSummary:
    """Analyse many recordings and summarise them as one campaign, here or on a Dask cluster.

    Each recording is read and analysed by one task of the campaign engine (the task of
    :func:`~squealkit.campaign.run_campaign`; on a worker when ``client`` is given, where the
    files must be readable under the same paths), which returns only its summary row and
    events, so a campaign of hundreds of long recordings never gathers their analyses in one
    process. The rows keep the order of ``files``. A recording that cannot be analysed stops
    the campaign with its reason (:func:`~squealkit.campaign.run_campaign` records it and goes on).

    The disc speed is optional, as in :func:`~squealkit.campaign.run_campaign`: without ``rpm``
    (nor a ``tacho`` option) the recordings are analysed for squeal alone (SAE J2521 occurrence
    needs no speed) and their ``rising_fraction`` is empty.

    Parameters
    ----------
    files : sequence of path
        Recordings (formats of :func:`~squealkit.measurement.open_recording`).
    mic, displacement, radius, rpm, **options
        As for :func:`~squealkit.measurement.analyze_recording` (``tacho``, ``setup``, ``band``,
        ``threshold_dba``, ``min_duration``, ...); ``rpm`` optional (see above).
    fs, scale, units
        As for :func:`~squealkit.measurement.open_recording`.
    freq_tol : float
        Frequency grouping tolerance [Hz] of the summary.
    client : distributed.Client, optional
    progress : callable, optional
        ``progress(done, total)`` in recordings.

    Returns
    -------
    CampaignSummary
    """
    from ..scale import map_tasks

    if not files:
        raise InputError("A campaign needs at least one recording.")
    crit_kw = {k: options[k] for k in ("setup", "band", "threshold_dba", "time_weighting", "min_duration")
               if k in options}
    bands = third_octave_bands(squeal_criteria(crit_kw.pop("setup", None), **crit_kw).band)
    open_kw = {"fs": fs, "scale": dict(scale) if scale else None, "units": dict(units) if units else None}
    analysis_kw = {"mic": mic, "displacement": displacement, "radius": radius, "require_runout": False, **options}
    if rpm is not None:
        analysis_kw["rpm"] = rpm
    items = [{"app": {"application": str(f), "file": str(Path(f).resolve())}, "analysis": analysis_kw,
              "bands": bands, "open": open_kw} for f in files]
    rows: list[dict[str, Any] | None] = [None] * len(items)
    for i, (row, events) in map_tasks(_analyze_application, items, client=client, progress=progress,
                                      name="squealkit-recording"):
        rows[i] = _engine_row(str(files[i]), row, events)
    return _summarize(rows, freq_tol)  # type: ignore[arg-type]

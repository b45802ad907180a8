"""Campaign summary over many recordings (SAE J2521 occurrence, VDA 303 frequencies).

Occurrence is the percentage of recordings (brake applications) with at least one squeal
event; frequencies of all events are grouped within a tolerance so a campaign shows which
squeal frequencies occur and how often.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._validation import InputError
from .analysis import MeasurementResult

__all__ = ["CampaignSummary", "summarize_campaign"]

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
        Share of recordings with squeal [%].
    n_events : int
    frequencies : tuple of dict
        ``frequency_hz`` (event-count-weighted mean), ``n_events``, ``n_recordings``,
        ``max_peak_dba`` per frequency group.
    """

    rows: tuple[dict[str, Any], ...]
    occurrence_percent: float
    n_events: int
    frequencies: tuple[dict[str, Any], ...]

    def to_dict(self) -> dict[str, Any]:
        """Plain dict for JSON."""
        return {"n_recordings": len(self.rows), "occurrence_percent": self.occurrence_percent,
                "n_events": self.n_events, "frequencies": list(self.frequencies), "recordings": list(self.rows)}

    def to_csv(self) -> str:
        """CSV text: ``#`` comment lines with the totals, then one row per recording."""
        buf = io.StringIO()
        buf.write(f"# squealkit campaign summary: n_recordings={len(self.rows)}, "
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
    """
    if not results:
        raise InputError("A campaign summary needs at least one recording.")
    names = list(names) if names is not None else [str(r.attrs.get("source")) for r in results]
    if len(names) != len(results):
        raise InputError(f"Got {len(names)} names for {len(results)} recordings.")
    rows = []
    groups: list[dict[str, Any]] = []
    for name, r in zip(names, results, strict=True):
        rows.append({"recording": name, "synthetic": int(bool(r.attrs.get("synthetic", False))),
                     "duration_s": r.duration_s, "squeal": int(r.squeal), "n_events": len(r.events),
                     "squeal_frequency_hz": r.squeal_frequency_hz, "peak_dba": r.peak_dba,
                     "rising_fraction": r.rising_fraction})
        for e in r.events:
            g = next((g for g in groups if abs(g["frequency_hz"] - e.frequency_hz) <= freq_tol), None)
            if g is None:
                g = {"frequency_hz": e.frequency_hz, "n_events": 0, "recordings": set(), "max_peak_dba": -np.inf}
                groups.append(g)
            g["frequency_hz"] = (g["frequency_hz"] * g["n_events"] + e.frequency_hz) / (g["n_events"] + 1)
            g["n_events"] += 1
            g["recordings"].add(name)
            g["max_peak_dba"] = max(g["max_peak_dba"], e.peak_dba)
    freqs = tuple({"frequency_hz": g["frequency_hz"], "n_events": g["n_events"],
                   "n_recordings": len(g["recordings"]), "max_peak_dba": g["max_peak_dba"]}
                  for g in sorted(groups, key=lambda g: -g["n_events"]))
    occ = 100.0 * sum(r.squeal for r in results) / len(results)
    return CampaignSummary(tuple(rows), occ, sum(len(r.events) for r in results), freqs)

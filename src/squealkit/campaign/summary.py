"""Occurrence as SAE J2521 defines it, overall and by 1/3-octave band, from the campaign store."""

from __future__ import annotations

import itertools
import math
from typing import Any

import numpy as np

__all__ = ["campaign_summary", "third_octave_bands"]


def third_octave_bands(band: tuple[float, float]) -> list[tuple[float, float, float]]:
    """Base-10 1/3-octave bands (IEC 61260-1) whose centre lies in ``band``: ``(centre, lower, upper)`` [Hz].

    Centres are ``1000 * 10**(k / 10)`` Hz (exact, nominally 1000, 1250, 1600, 2000, ...), edges
    ``centre * 10**(-+1 / 20)``; a band counts when its nominal centre lies in ``band`` (the
    exact centre of nominal 2 kHz is 1995 Hz).

    Parameters
    ----------
    band : (float, float)
        ``(freq_lower, freq_upper)`` [Hz], e.g. the squeal criteria's band.

    Returns
    -------
    list of (float, float, float)
        ``(centre, lower, upper)`` [Hz] of each band, in increasing frequency.

    Examples
    --------
    >>> [round(c) for c, _, _ in third_octave_bands((2000.0, 16000.0))][:4]
    [1995, 2512, 3162, 3981]
    """
    k0 = math.ceil(10 * math.log10(band[0] / 1000.0) - 0.05)
    k1 = math.floor(10 * math.log10(band[1] / 1000.0) + 0.05)
    return [(1000 * 10 ** (k / 10), 1000 * 10 ** ((k - 0.5) / 10), 1000 * 10 ** ((k + 0.5) / 10))
            for k in range(k0, k1 + 1)]


def band_of(freq: float, bands: list[tuple[float, float, float]]) -> tuple[float, float, float] | None:
    """The 1/3-octave band holding ``freq`` [Hz], or None."""
    for b in bands:
        if b[1] <= freq < b[2]:
            return b
    return None


def campaign_summary(store, band: tuple[float, float], criteria: str) -> dict[str, Any]:
    """``summary.json``: applications, occurrence (J2521: % of applications with squeal), by band and condition.

    Parameters
    ----------
    store : CampaignStore
        The campaign's store, after the applications were analysed.
    band : (float, float)
        Squeal band ``(freq_lower, freq_upper)`` [Hz], split into 1/3-octave bands
        (:func:`third_octave_bands`).
    criteria : str
        Description of the squeal criteria (stored as the summary's ``criteria``).

    Returns
    -------
    dict
        JSON-ready: ``criteria``, ``applications``, ``applications_with_squeal``,
        ``occurrence_percent``, ``by_band``, ``by_temperature_c``, ``by_pressure_bar``,
        ``max_peak_dba``, ``runout_link``, ``runout_unavailable`` (analysed applications without a
        run-out link: ``application``, ``file``, ``reason``) and ``failed`` (applications that could
        not be read).
    """
    apps = store.query("SELECT * FROM applications WHERE error IS NULL AND {in_matrix} ORDER BY application")
    ev = store.query("SELECT application, band_center_hz FROM events WHERE {in_matrix}")
    failed = store.query("SELECT application, file, error FROM applications WHERE error IS NOT NULL AND {in_matrix} "
                         "ORDER BY application")
    n = len(apps)
    n_sq = int(apps["squeal"].sum()) if n else 0
    by_band = []
    for c, lo, hi in third_octave_bands(band):
        hit = ev.loc[np.isclose(ev["band_center_hz"], c), "application"].nunique() if len(ev) else 0
        by_band.append({"band_hz": [lo, hi], "center_hz": c, "applications_with_squeal": int(hit),
                        "occurrence_percent": 100.0 * hit / n if n else None})

    def by(col: str, edges: list[float]) -> list[dict[str, Any]]:
        out = []
        for lo, hi in itertools.pairwise(edges):
            sel = apps[(apps[col] >= lo) & (apps[col] < hi)]
            if len(sel):
                out.append({"range": [lo, hi], "applications": len(sel),
                            "occurrence_percent": 100.0 * float(sel["squeal"].mean())})
        return out

    sq = apps[apps["squeal"]]
    return {
        "criteria": criteria,
        "applications": n,
        "applications_with_squeal": n_sq,
        "occurrence_percent": 100.0 * n_sq / n if n else None,  # unknown, not 0 %, with nothing analysed
        "by_band": by_band,
        "by_temperature_c": by("temperature_c", [-math.inf, 50, 100, 150, 200, 250, 300, 400, math.inf]),
        "by_pressure_bar": by("pressure_bar", [-math.inf, 5, 10, 15, 20, 30, 40, math.inf]),
        "max_peak_dba": float(apps["peak_dba"].max()) if n else None,
        "runout_link": {
            "median_growth_slope_correlation": float(sq["growth_slope_correlation"].median()) if len(sq) else None,
            "median_rising_fraction": float(sq["rising_fraction"].median()) if len(sq) else None,
        },
        "runout_unavailable": [{"application": r.application, "file": r.file, "reason": r.runout_unavailable}
                               for r in apps.itertuples() if isinstance(r.runout_unavailable, str)],
        "failed": [{"application": a, "file": f, "error": e}
                   for a, f, e in zip(failed["application"], failed["file"], failed["error"], strict=True)],
    }

"""
A noise campaign
================

A brake noise campaign as SAE J2521 counts it (here a SYNTHETIC one with known truth).

Writes a test matrix of brake applications (drags and decelerating stops, each recording with
a tacho), analyses every application into a DuckDB database, and compares the occurrence per
1/3-octave band with the truth.

Run it with ``python examples/05_campaign.py [OUTPUT_DIR]``: it writes its results and figures there.
"""

import shutil
import sys
from pathlib import Path

from squealkit.campaign import run_campaign, synthetic_campaign

out = Path(sys.argv[1] if len(sys.argv) > 1 else "examples-output")
out.mkdir(parents=True, exist_ok=True)

truth = synthetic_campaign(out / "campaign", n_applications=12, duration=1.0, seed=11)  # SYNTHETIC
summary = run_campaign(out / "campaign" / "matrix.csv", out / "campaign" / "out", mic="mic",
                       displacement="displacement", tacho="tacho", radius=0.05)
print(f"[SYNTHETIC] {summary['criteria']}")
print(f"occurrence {summary['occurrence_percent']:.1f} % of {summary['applications']} applications "
      f"(truth {truth['occurrence_percent']:.1f} %)")
for b in summary["by_band"]:
    if b["occurrence_percent"]:
        print(f"  {b['band_hz'][0]:7.0f}-{b['band_hz'][1]:7.0f} Hz: {b['occurrence_percent']:5.1f} %")
print("truth by line:", {f"{float(k):g} Hz": round(v, 1) for k, v in truth["line_occurrence_percent"].items()})
for png in (out / "campaign" / "out" / "figures").glob("*.png"):
    shutil.copy(png, out / f"campaign_{png.name}")

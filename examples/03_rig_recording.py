"""
A rig recording
===============

Analyse a rig recording as the paper's §5 does (here a SYNTHETIC one with known truth).

Run it with ``python examples/03_rig_recording.py [OUTPUT_DIR]``: it writes its results and figures there.
"""

import sys
from pathlib import Path

from squealkit.io import save_dataset, save_figure
from squealkit.measurement import analyze_recording, synthetic_recording
from squealkit.plotting.measurement import measurement_figures

out = Path(sys.argv[1] if len(sys.argv) > 1 else "examples-output")
out.mkdir(parents=True, exist_ok=True)

rec = synthetic_recording(duration=1.0, seed=7)  # SYNTHETIC: 900 rpm, 40 kHz, squeal on rising run-out
save_dataset(rec, out / "synthetic_recording.nc")
res = analyze_recording(out / "synthetic_recording.nc", mic="mic", displacement="displacement", rpm=900, radius=0.05,
                        keep_signals=True)  # also what the figures draw: res.signals
print(f"[SYNTHETIC] criteria: {res.settings.criteria.describe()}")
print(f"squeal {res.squeal_frequency_hz:.1f} Hz, peak {res.peak_dba:.1f} dB(A) on Fast, "
      f"growth/slope correlation {res.growth_slope_correlation:.2f}, "
      f"rising_fraction {res.rising_fraction:.3f} (truth {rec.attrs['truth_rising_fraction']:.3f})")
for name, fig in measurement_figures(res).items():
    save_figure(fig, out / f"{name}.png")

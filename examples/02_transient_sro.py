"""Transient response with the paper's sine run-out (Fig. 4): growth on rising SRO, decay on falling.

Run:  python examples/02_transient_sro.py [OUTPUT_DIR]
"""

import sys
from pathlib import Path

from squealkit.io import save_dataset, save_figure
from squealkit.models import get_preset
from squealkit.plotting.transient import envelope_plot, fig4_plot
from squealkit.transient import SineRunOut, simulate, transient_summary

out = Path(sys.argv[1] if len(sys.argv) > 1 else "examples-output")
out.mkdir(parents=True, exist_ok=True)

model = get_preset("lv2013")  # c1 = c2 = c3 = 220 N s/m, P = 10 N
ds = simulate(model, mu=0.4, profile=SineRunOut(amplitude=0.08e-3, wavelength=1e-3), speed=0.02, duration=0.15)
save_dataset(ds, out / "fig4.nc")
save_figure(fig4_plot(ds), out / "fig4.png")
save_figure(envelope_plot(ds), out / "fig4_envelope.png")

for stage in transient_summary(ds)["stages"]:
    if not stage["partial"]:
        print(f"{stage['stage']:<8} {stage['t_start']:.4f}-{stage['t_end']:.4f} s: envelope "
              f"{stage['rate_per_s']:+6.1f} 1/s (frozen-time sigma {stage['sigma_mean_per_s']:+.1f} 1/s)")

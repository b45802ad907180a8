"""Issue #28, "no import circle": what the two last circles were broken by, kept from coming back.

The circles themselves are found statically in ``tests/test_layout_fe.py`` (every import, function-level
and under TYPE_CHECKING ones included, and through packages' ``__init__``). Here:

- the report's runner starts the warm-up child, which compiled for the report's operating point by
  importing the report's steps; both now read it from ``squealkit._operating_point``, and the values are
  the paper's (Lv et al. 2013: §4 v = 0.02 m/s; §5 900 rpm, 40 kHz sampling, squeal at about 2388 Hz);
- ``plotting.measurement`` draws the signals and the result it is given: a process that draws every
  signals figure from a Dataset made by hand never imports ``squealkit.measurement``.
"""

from __future__ import annotations

import subprocess
import sys


def test_the_report_and_its_warm_up_share_one_operating_point():
    from squealkit import _operating_point as op
    from squealkit.report import steps_measurement, steps_nonlinear
    from squealkit.report.settings import ReportSettings

    # reference: the paper's §4 (v = 0.02 m/s) and §5 (900 rpm, 40 kHz, 2388 Hz); the 50 mm radius is assumed
    assert (op.SPEED, op.RIG_RPM, op.RIG_FS, op.RIG_RADIUS, op.RIG_SQUEAL_FREQ) == (0.02, 900.0, 40_000.0, 0.05,
                                                                                    2388.0)
    assert ReportSettings().speed == ReportSettings.paper().speed == op.SPEED
    assert (steps_measurement.RPM, steps_measurement.FS, steps_measurement.RADIUS, steps_measurement.F_PUBLISHED) \
        == (op.RIG_RPM, op.RIG_FS, op.RIG_RADIUS, op.RIG_SQUEAL_FREQ)
    assert (steps_nonlinear.MU_RANGE, steps_nonlinear.HARMONICS) == (op.CYCLE_MU_RANGE, op.CYCLE_HARMONICS)


_DRAW_WITHOUT_MEASUREMENT = """
import sys
import numpy as np
import xarray as xr
import matplotlib
matplotlib.use("Agg")
from squealkit.plotting import measurement as mp

t = np.arange(400) / 4000.0
f, ft = np.linspace(0.0, 2000.0, 5), np.linspace(0.0, 0.1, 4)
x = np.sin(2 * np.pi * 50 * t)
sig = xr.Dataset(
    {"mic": ("time", x, {"units": "Pa"}), "displacement": ("time", 1e-6 * x), "runout_lowpass": ("time", 1e-6 * x),
     "runout_macro": ("time", 1e-6 * x), "runout_micro": ("time", 0 * x), "displacement_band": ("time", 1e-7 * x),
     "mic_level": (("freq", "frame_time"), np.ones((5, 4)), {"units": "dB re 20 uPa"}),
     "displacement_level": (("freq", "frame_time"), np.ones((5, 4)), {"units": "dB re 1 pm"})},
    coords={"time": t, "freq": f, "frame_time": ft},
    attrs={"kind": "measurement_signals", "lowpass_freq": 1000.0, "macro_orders": 10, "freq_lower": 1000.0,
           "freq_upper": 2500.0},
)
for draw in (mp.time_history_plot, mp.spectrogram_plot, mp.runout_plot, mp.band_vs_pressure_plot):
    draw(sig)
loaded = sorted(m for m in sys.modules if m.startswith("squealkit.measurement"))
assert loaded == [], loaded
print("ok")
"""


def test_measurement_figures_draw_their_data_without_the_analysis():
    # a subprocess: this test process has imported squealkit.measurement already
    out = subprocess.run([sys.executable, "-c", _DRAW_WITHOUT_MEASUREMENT], capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 0 and out.stdout.strip() == "ok", out.stderr[-2000:]

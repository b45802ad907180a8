"""
Stability map and critical friction
===================================

Stability of the paper's rig: Fig. 2, the critical friction and a run-out tolerance.

Run it with ``python examples/01_stability.py [OUTPUT_DIR]``: it writes its results and figures there.
"""

import math
import sys
import warnings
from pathlib import Path

import numpy as np

from squealkit.io import save_dataset, save_figure
from squealkit.models import get_preset, load_model, load_rig
from squealkit.plotting.stability import fig2_plot, stability_map_plot
from squealkit.stability import (
    UnrealisticFrictionWarning,
    critical_friction_curve,
    runout_tolerance,
    stability_map,
    stability_summary,
)

out = Path(sys.argv[1] if len(sys.argv) > 1 else "examples-output")
out.mkdir(parents=True, exist_ok=True)

# %%
# The paper's Fig. 2
# ------------------
# Eigenvalues over friction ``mu`` and run-out incline ``theta`` (radians in Python), without the
# damping, as the paper's eq. 7: two modes coalesce and one grows.

model = get_preset("lv2013")
ds = stability_map(model, np.linspace(0, 0.8, 81), np.radians(np.linspace(-8, 8, 81)), damped=False)
lo, hi = stability_summary(ds)["unstable_omega_rad_s"]
print(f"lock-in band {lo:.0f}-{hi:.0f} rad/s (paper: 14997-15317 rad/s)")
save_dataset(ds, out / "fig2.nc")
save_figure(fig2_plot(ds), out / "fig2.png")

# %%
# Critical friction
# -----------------
# The friction at which the brake becomes unstable moves with the incline, while
# ``mu + tan(theta)`` stays put (paper eq. 6): the map's border.

crit = critical_friction_curve(model, np.radians([-8.0, 0.0, 8.0]), damped=False)
for th, mu, mue in zip(crit.theta_deg.values, crit.mu_critical.values, crit.mu_e_critical.values, strict=True):
    print(f"theta {th:+.0f} deg: mu_crit {mu:.4f}, mu_crit + tan(theta) {mue:.4f}")
border = critical_friction_curve(model, ds.theta.values, damped=False)
save_figure(stability_map_plot(ds, critical=border), out / "map.png")

# %%
# Run-out tolerance
# -----------------
# At a given friction, the largest incline that stays stable, and the run-out amplitude it
# allows at a 1 mm wavelength.

tol = runout_tolerance(model, 0.3, wavelength=1e-3, damped=False)
print(f"at mu = 0.3 keep tan(theta) <= {tol.tan_theta_max:.4f}: q0 <= {tol.q0_max * 1e6:.1f} um at 1 mm wavelength")

# %%
# Your own rig
# ------------
# From a TOML file: the pin bending frequency is not given there, so it comes from Timoshenko
# beam theory (every frequency's source is printed).
path = Path(sys.argv[0]).with_name("myrig.toml")  # beside this script (the docs gallery sets no __file__)
mine, rig = load_model(path), load_rig(path)
print(f"myrig.toml frequencies: {rig.describe()}")
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always", UnrealisticFrictionWarning)
    c = critical_friction_curve(mine, [0.0])
print(f"myrig.toml: mu_crit {float(c.mu_critical[0]):.4f} at {float(c.frequency_hz[0]):.1f} Hz (theta = 0)")
for w in caught:
    print(f"  warning: {w.message}")
assert math.isfinite(float(c.mu_critical[0]))

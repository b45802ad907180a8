"""
Squeal propensity under scatter
===============================

Squeal propensity of the paper's rig with scattered parameters (Monte Carlo).

The rig's stiffnesses, contact stiffness and pin incline are described by distributions in
``uncertain_rig.toml``; every sample's stability is computed over mu (paper eqs. 7-8).
Prints the probability of instability at a few mu and which parameters drive the
critical friction (Sobol' indices).

Run it with ``python examples/04_uncertainty.py [OUTPUT_DIR]``: it writes its results and figures there.
"""

import sys
from pathlib import Path

import numpy as np

from squealkit.io import save_dataset, save_figure
from squealkit.models import load_model
from squealkit.plotting.uncertainty import uncertainty_plot
from squealkit.uncertainty import load_uncertain, propensity_summary, squeal_propensity

out = Path(sys.argv[1] if len(sys.argv) > 1 else "examples-output")
out.mkdir(parents=True, exist_ok=True)

# %%
# Propensity
# ----------
# 512 samples of the rig, each one's stability over ``mu`` from 0 to 1.

rig = Path(sys.argv[0]).with_name("uncertain_rig.toml")  # beside this script (the gallery sets no __file__)
model = load_model(rig)  # the lv2013 preset: nominal mu_crit = 0.4448 at theta = 0
uncertain = load_uncertain(rig)
ds = squeal_propensity(model, uncertain, np.linspace(0.0, 1.0, 41), samples=512, seed=1, damped=False)  # eq. 7
save_dataset(ds, out / "propensity.nc")
save_figure(uncertainty_plot(ds), out / "propensity.png")

s = propensity_summary(ds)
print(f"{s['samples']} samples, nominal mu_crit {s['nominal_mu_critical']:.4f}")
for mu in (0.2, 0.3, 0.4, 0.5):
    i = int(np.argmin(np.abs(ds.mu.values - mu)))
    print(f"P(unstable | mu = {mu:.1f}) = {s['probability_unstable'][i]:.3f} "
          f"[{s['ci_lower'][i]:.3f}, {s['ci_upper'][i]:.3f}]")
# %%
# What drives it
# --------------
# Sobol' indices of the critical friction: the share of its variance each parameter explains.

for name, r in sorted(s["sensitivity"].items(), key=lambda kv: -kv[1]["total"]):
    print(f"{name:<10} Sobol' total {r['total']:.3f}, first order {r['first_order']:.3f}")

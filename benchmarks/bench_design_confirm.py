"""The countermeasure study's confirmation on the built-in brake: band solves per Newton point vs refinement.

Run:  PYTHONPATH=src python benchmarks/bench_design_confirm.py [--n-theta 8] [--repeat 1]

The study of the design guide (``docs/guide/design.md``): the coarse built-in brake (n_theta = 8: 738 DOFs),
four declared changes (K1, KR, D1 and the out-of-plane stiffness of six disc nodes), 500 rpm, mu = 0.6,
band 1-11 kHz: two unstable modes, so 8 searches for the stabilising change. Both confirmations run here,
in this one process, one after the other (``--repeat`` times each, alternating, the best kept):

- ``band``: every Newton point on ``sigma(p) = 0`` solves the changed model in a band of +-20 % around
  the mode (the sparse shift-invert band solver) and follows the mode by MAC (the method before);
- ``none``: ``confirm=False``, the nominal solve and the derivatives only (what both share);
- ``refine``: every point refines the one eigenpair from the derivative's prediction (nonlinear inverse
  iteration, one sparse LU per iteration, to a full-model backward error of 1e-12), and the confirmed
  value alone is checked by one band solve with the same tracking rule.

Prints CPU time (time.process_time, all threads) and wall time of each, their ratio, the number of
solves, and the largest difference of the confirmed changes between the two (they must agree).
"""

from __future__ import annotations

import argparse
import importlib
import tempfile
import time
from pathlib import Path

import numpy as np


def main() -> None:
    from threadpoolctl import threadpool_limits

    from squealkit.fe.demo import build_fe_demo, write_fe_demo
    from squealkit.models import load_model

    ap = argparse.ArgumentParser()
    ap.add_argument("--n-theta", type=int, default=8)
    ap.add_argument("--repeat", type=int, default=1)
    args = ap.parse_args()
    cm = importlib.import_module("squealkit.design.countermeasures")  # the module (its name is also the function's)
    design = {"stiffness": "K1", "friction": "KR", "damping": "D1",
              "inboard": {"part": "K1", "nodes": [8, 9, 10, 11, 12, 13], "components": [3]}}
    with tempfile.TemporaryDirectory() as tmp:
        write_fe_demo(build_fe_demo(n_theta=args.n_theta, n_r=2), Path(tmp) / "brake")
        model = load_model(Path(tmp) / "brake" / "brake.toml")
    print(f"model: built-in brake n_theta={args.n_theta}, {model.n_dof} DOFs")
    best: dict[str, tuple[float, float]] = {}
    result = {}
    with threadpool_limits(1, user_api="blas"):
        cm.countermeasures(model, design, rpm=500, mu=0.6, band=(1e3, 11e3), confirm=False)  # warm caches
        for _ in range(args.repeat):
            for name, refine, confirm in (("none", True, False), ("band", False, True), ("refine", True, True)):
                cm._REFINE = refine
                c0, w0 = time.process_time(), time.perf_counter()
                ds = cm.countermeasures(model, design, rpm=500, mu=0.6, band=(1e3, 11e3), confirm=confirm)
                c, w = time.process_time() - c0, time.perf_counter() - w0
                if name not in best or c < best[name][0]:
                    best[name] = (c, w)
                result[name] = ds
    cm._REFINE = True
    for name, (c, w) in best.items():
        ds = result[name]
        if name == "none":
            print(f"   none: CPU {c:.2f} s, wall {w:.2f} s (confirm=False: the nominal solve and the derivatives)")
            continue
        print(f"{name:>7}: CPU {c:.2f} s, wall {w:.2f} s, solves {int(ds.solves.sum())} "
              f"({int(ds.sizes['mode'])} modes x {int(ds.sizes['parameter'])} parameters), statuses "
              f"{sorted(set(ds.status.values.ravel().tolist()))}")
    a, b = result["band"], result["refine"]
    base_c, base_w = best["none"]
    conf = {k: (best[k][0] - base_c, best[k][1] - base_w) for k in ("band", "refine")}
    print(f"the confirmation alone (minus the study without it, the nominal solve and derivatives): band "
          f"{conf['band'][0]:.2f} s CPU, refine {conf['refine'][0]:.2f} s CPU: "
          f"{conf['band'][0] / conf['refine'][0]:.2f}x "
          f"CPU ({conf['band'][1] / conf['refine'][1]:.2f}x wall)")
    same = bool(np.array_equal(a.status.values, b.status.values))
    diff = np.nanmax(np.abs(a.confirmed_change.values - b.confirmed_change.values)
                     / np.abs(a.confirmed_change.values))
    print(f"ratio band / refine (whole study, nominal solve included): {best['band'][0] / best['refine'][0]:.2f}x CPU, "
          f"{best['band'][1] / best['refine'][1]:.2f}x wall; same statuses: {same}; largest relative difference "
          f"of the confirmed changes: {diff:.2g}")


if __name__ == "__main__":
    main()

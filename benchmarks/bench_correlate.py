"""Throughput of ``squealkit.correlate`` on a SYNTHETIC 2,000-application campaign (not part of the tests).

Usage::

    python benchmarks/bench_correlate.py                        # 2,000 applications, 3-DOF lv2013
    python benchmarks/bench_correlate.py --applications 500 --fe   # and the built-in FE brake (reduced)

The campaign store (``campaign.duckdb``) is written directly, as ``squealkit campaign`` would
leave it after analysing the recordings (conditions, a measured mu per application, squeal
events at the model's unstable frequency with designed misses and over-predictions): the
benchmark times the correlation, not the recording analysis (``bench_campaign.py`` does).

Timed:

1. ``correlate`` end to end (read the store, conditions -> operating points, every unstable mode
   of every application through the batch kernels, matching, rates, noise matrices);
2. baseline A, "per-application eigenvalues loop": ``squealkit.stability.eigenvalues(model, mu)``
   called once per application, as a script over the public API would;
3. baseline B, "per-application critical_friction loop": ``critical_friction(model)`` per
   application (the onset, compared with the application's mu), timed on a subset and scaled;
4. a calibration of ``mu_offset`` (``correlate(..., fit=...)``).

With ``--fe``: the built-in FE brake (``build_fe_demo``, small) over the same campaign with one
POD basis, against a dense solve per application (subset, scaled).
Prints the times and the ratios.
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))


def write_store(out: Path, n: int, model, *, mu_offset: float = 0.05, seed: int = 0, fe: bool = False) -> None:
    """A campaign store of ``n`` applications whose squeal follows ``model`` at mu + mu_offset."""
    from squealkit.campaign.store import CampaignStore
    from squealkit.stability import eigenvalues

    rng = np.random.default_rng(seed)
    T = np.round(rng.uniform(50, 350, n), 1)
    p = np.round(rng.uniform(5, 40, n), 1)
    rpm = np.round(rng.uniform(600, 1200, n))
    mu = np.round(0.35 + 8e-4 * (T - 200) - 4e-3 * (p - 20) + 0.003 * rng.standard_normal(n), 4)
    if fe:
        f_top = np.full(n, np.nan)  # FE: the events are drawn at a fixed line; only the timing matters
        unstable = rng.random(n) < 0.5
        f_top[unstable] = 5000.0
    else:
        lam = eigenvalues(model, mu + mu_offset, damped=True)
        k = np.argmax(lam.real, axis=-1)
        top = lam[np.arange(n), k]
        unstable = top.real > 1e-6 * np.abs(top)
        f_top = top.imag / (2 * math.pi)
    out.mkdir(parents=True, exist_ok=True)
    results = []
    for i in range(n):
        app = f"A{i + 1:05d}"
        squeal = (unstable[i] and i % 7 != 3) or i % 7 == 5
        f = 6300.0 if i % 7 == 5 else f_top[i]
        row = {"application": app, "file": f"recordings/{app}.nc", "section": "S1", "mode": "drag",
               "pressure_bar": p[i], "temperature_c": T[i], "speed_kmh": rpm[i] / 60 * 2 * math.pi * 0.3 * 3.6,
               "duration_s": 10.0, "synthetic": True, "squeal": bool(squeal), "peak_dba": 85.0 if squeal else 60.0,
               "squeal_frequency_hz": f if squeal else None, "n_events": int(squeal), "mean_rpm": rpm[i],
               "criteria": "bench", "mu": mu[i], "error": None}
        ev = [{"application": app, "event": 0, "start_s": 1.0, "end_s": 2.0, "duration_s": 1.0, "frequency_hz": f,
               "peak_dba": 80.0 + 5 * rng.random()}] if squeal else []
        results.append((row, ev))
    with CampaignStore(out / "campaign.duckdb") as store:
        store.put_many(results)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--applications", type=int, default=2000)
    ap.add_argument("--subset", type=int, default=100, help="applications of the critical_friction baseline")
    ap.add_argument("--fe", action="store_true", help="also the built-in FE brake with a reduced basis")
    ap.add_argument("--fe-theta", type=int, default=16, help="sectors of the FE demo (16: 1,422 DOFs; 8: 738)")
    ap.add_argument("--fe-subset", type=int, default=5, help="applications of the dense FE baseline")
    args = ap.parse_args()

    from squealkit.correlate import ConditionMap, correlate
    from squealkit.models import get_preset
    from squealkit.stability import critical_friction, eigenvalues

    model = get_preset("lv2013")
    n = args.applications
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp) / "camp"
        write_store(d, n, model)
        cmap = ConditionMap(mu_offset=0.05)
        correlate(d, model, cmap)  # warm: numba caches, imports
        t0 = time.perf_counter()
        ds = correlate(d, model, cmap)
        t_corr = time.perf_counter() - t0
        print(f"correlate, {n} applications (3-DOF lv2013, damped): {t_corr:.2f} s "
              f"({ds.attrs['distinct_points']} distinct points; hits {ds.attrs['hits']}, misses {ds.attrs['misses']}, "
              f"over-predictions {ds.attrs['over_predictions']}, quiet {ds.attrs['quiet']})")

        mu = ds["mu"].values
        t0 = time.perf_counter()
        for m in mu:
            eigenvalues(model, float(m), damped=True)
        t_a = time.perf_counter() - t0
        print(f"baseline A, per-application eigenvalues loop: {t_a:.2f} s (ratio {t_a / t_corr:.1f}x)")

        k = min(args.subset, n)
        t0 = time.perf_counter()
        for _ in range(k):
            critical_friction(model, damped=True)
        t_b = (time.perf_counter() - t0) * n / k
        print(f"baseline B, per-application critical_friction loop: {t_b:.1f} s for {n} (timed on {k}, scaled; "
              f"ratio {t_b / t_corr:.0f}x)")

        t0 = time.perf_counter()
        cal = correlate(d, model, ConditionMap(), fit={"mu_offset": (-0.01, 0.11)})
        t_cal = time.perf_counter() - t0
        import json

        q = json.loads(cal.attrs["calibration"])["quantities"]["mu_offset"]
        print(f"calibration of mu_offset on {n} applications: {t_cal:.1f} s -> {q['value']:.4f} "
              f"in [{q['interval'][0]:.4f}, {q['interval'][1]:.4f}] (hidden 0.05)")

        if args.fe:
            from squealkit.fe.demo import build_fe_demo
            from squealkit.models import FEModel
            from squealkit.stability.fe_sweep import FESolver

            demo = build_fe_demo(n_theta=args.fe_theta, n_r=2)
            fe = FEModel.from_matrices(**{k: v for k, v in demo.items() if k in ("M", "D1", "DG", "K1", "KR", "KGeo")},
                                       omega_ref=float(demo["omega_ref"]), mu_ref=float(demo["mu_ref"]))
            d2 = Path(tmp) / "camp_fe"
            write_store(d2, n, model, fe=True)
            t0 = time.perf_counter()
            ds = correlate(d2, fe, ConditionMap(), method="pod", band=(1000.0, 12000.0))
            t_fe = time.perf_counter() - t0
            print(f"correlate, {n} applications, FE demo ({fe.n_dof} DOFs, POD basis {ds.attrs['basis_size']}): "
                  f"{t_fe:.1f} s ({ds.attrs['distinct_points']} distinct points)")
            solver = FESolver(fe, "dense", (1000.0, 12000.0))
            k = min(args.fe_subset, n)
            t0 = time.perf_counter()
            for w, m in zip(ds["disc_speed"].values[:k], ds["mu"].values[:k], strict=True):
                solver.solve(float(w), float(m), vectors=False)
            t_dense = (time.perf_counter() - t0) * n / k
            print(f"baseline FE, dense solve per application: {t_dense:.1f} s for {n} (timed on {k}, scaled; "
                  f"ratio {t_dense / t_fe:.1f}x)")


if __name__ == "__main__":
    main()

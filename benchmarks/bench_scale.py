"""Scaling of squealkit's Dask scale-out from one to two workers (not part of the tests).

Usage::

    python benchmarks/bench_scale.py                  # 4e6-point damped stability sweep
    python benchmarks/bench_scale.py --points 1e6 --montecarlo 20000

For each case the same job runs (1) in this process without a cluster (numba on all
cores: the baseline), then on a local Dask cluster of (2) one and (3) two worker
processes with one thread each. Every result streams to a zarr store and is checked
identical to the baseline. Printed: wall time, throughput per worker, the speed-up from
one to two workers, and what that throughput means for a 10^9-point sweep or 10^6
Monte Carlo samples on a cluster of a given size (assuming the measured two-worker
efficiency holds; a real cluster adds network and file-system costs this cannot see).
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))


def _timed(fn):
    t0 = time.perf_counter()
    out = fn()
    return time.perf_counter() - t0, out


def sweep(points: float, workers: list[int]) -> dict[int, float]:
    import numpy as np
    import xarray as xr

    from squealkit.models import get_preset
    from squealkit.scale import cluster_client
    from squealkit.stability import stability_map

    side = round(math.sqrt(points))
    model = get_preset("lv2013")
    mu = np.linspace(0.0, 0.8, side)
    theta = np.radians(np.linspace(-8, 8, side))
    n = side * side
    stability_map(model, mu[:8], theta[:8], damped=True)  # compile / load the numba cache
    with tempfile.TemporaryDirectory() as d:
        t_base, ref = _timed(lambda: stability_map(model, mu, theta, damped=True, store=Path(d) / "base.zarr"))
        print(f"stability sweep {side} x {side} = {n:.3g} points, damped, streamed to zarr")
        print(f"  baseline (this process, numba on all cores, no cluster): {t_base:6.2f} s  "
              f"{n / t_base:.3g} points/s")
        rates = {}
        for w in workers:
            with cluster_client("local", n_workers=w) as client:
                # load the compiled kernels in every worker first (numba cache), as a long job would
                client.run(lambda: stability_map(model, mu[:8], theta[:8], damped=True))
                t, ds = _timed(lambda client=client, w=w: stability_map(
                    model, mu, theta, damped=True, store=Path(d) / f"w{w}.zarr", client=client))
                xr.testing.assert_identical(ref.load(), ds.load())
            rates[w] = n / t / w
            print(f"  Dask, {w} worker(s) x 1 thread:                          {t:6.2f} s  "
                  f"{n / t:.3g} points/s  ({rates[w]:.3g} per worker; identical to the baseline)")
    return rates


def montecarlo(samples: int, workers: list[int]) -> dict[int, float] | None:
    try:
        from squealkit.uncertainty import parse_uncertain, squeal_propensity
    except ImportError:
        print("(Monte Carlo: squealkit.uncertainty not available)")
        return None
    import numpy as np
    import xarray as xr

    from squealkit.models import get_preset
    from squealkit.scale import cluster_client

    model = get_preset("lv2013")
    # the scatter of examples/uncertain_rig.toml
    unc = parse_uncertain({"k3": {"dist": "normal", "mean": 9.452e8, "std": 4.7e7},
                           "k1": {"dist": "normal", "mean": 8.545e6, "std": 4.3e5},
                           "kc": {"dist": "lognormal", "mean": 4.632e7, "std": 4.6e6},
                           "alpha_deg": {"dist": "uniform", "lower": 1.5, "upper": 2.5}}, model)
    mu = np.linspace(0.2, 0.7, 51)
    kw = dict(samples=samples, seed=1, sensitivity=False, batch_size=1024)
    squeal_propensity(model, unc, mu, samples=64, seed=1, sensitivity=False)
    t_base, ref = _timed(lambda: squeal_propensity(model, unc, mu, **kw))
    print(f"Monte Carlo {samples} samples x {mu.size} mu (no sensitivity)")
    print(f"  baseline (this process, no cluster): {t_base:6.2f} s  {samples / t_base:.3g} samples/s")
    rates = {}
    for w in workers:
        with cluster_client("local", n_workers=w) as client:
            client.run(lambda: squeal_propensity(model, unc, mu, samples=64, seed=1, sensitivity=False))
            t, ds = _timed(lambda client=client: squeal_propensity(model, unc, mu, client=client, **kw))
            xr.testing.assert_identical(ref, ds)
        rates[w] = samples / t / w
        print(f"  Dask, {w} worker(s): {t:6.2f} s  {samples / t:.3g} samples/s ({rates[w]:.3g} per worker)")
    return rates


def extrapolate(what: str, amount: float, unit: str, rates: dict[int, float], sizes=(16, 64, 256)) -> None:
    eff = rates[2] / rates[1] if 1 in rates and 2 in rates else 1.0
    print(f"  1 -> 2 workers: speed-up {2 * eff:.2f}x (efficiency {eff:.0%})")
    for k in sizes:
        t = amount / (k * rates[max(rates)])
        print(f"  {what} ({amount:.0e} {unit}) on {k} such workers: about {t / 60:.1f} min")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--points", type=float, default=4e6, help="Grid points of the sweep.")
    ap.add_argument("--montecarlo", type=int, default=0, help="Monte Carlo samples (0: skip).")
    args = ap.parse_args()
    rates = sweep(args.points, [1, 2])
    extrapolate("a sweep", 1e9, "points", rates)
    if args.montecarlo:
        mc = montecarlo(args.montecarlo, [1, 2])
        if mc:
            extrapolate("Monte Carlo", 1e6, "samples", mc)


if __name__ == "__main__":
    main()

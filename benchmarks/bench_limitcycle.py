"""Benchmark: a limit-cycle branch by harmonic balance against transients to the same steady states.

The paper's model (preset ``lv2013``, c = 220 N s/m, P = 10 N, v = 0.02 m/s) with the
transient's nonlinear contact (``Contact.nonlinear()``: loss of contact, friction
``mu tanh(w / v_reg)``) on a smooth disc.

1. The branch: ``limit_cycle_branch`` over mu in [0.3, 0.8] with 100 nominal points,
   H = 10, Floquet stability of every point (wall time, points computed).
2. Transients: ``simulate_batch`` from the static equilibrium with a 1e-9 m perturbation at
   ``--runs`` of the branch's friction values, long enough to grow from 1e-9 m to the cycle
   and settle (``ln(A / 1e-9) / sigma + 0.5 s`` with sigma the linear growth rate); the end
   state is then run 0.03 s more at 400 kHz to measure the amplitude (half peak-to-peak)
   and the frequency (zero crossings) against the branch.
   The time per run, times the number of branch points, is what the same steady states
   cost by transient simulation; the ratio to the branch's time is printed.

Both sides are timed in the same run, best of ``--repeats``, as CPU time (``time.process_time``,
meaningful on a shared machine) and wall time; the ratios are printed for both.

Run:  python benchmarks/bench_limitcycle.py [--runs 6] [--repeats 3]
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from squealkit.models import get_preset
from squealkit.nonlinear import harmonic_balance, limit_cycle_branch
from squealkit.nonlinear.harmonic_balance import contact_system
from squealkit.stability import eigenvalues
from squealkit.transient import Contact, simulate, simulate_batch


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=6, help="transient runs (friction values from the branch)")
    ap.add_argument("--mu-min", type=float, default=0.5,
                    help="smallest friction of the transient runs (growth is slow near mu_crit)")
    ap.add_argument("--repeats", type=int, default=3, help="repeats of each timing (the best is kept)")
    args = ap.parse_args()
    model = get_preset("lv2013")
    contact = Contact.nonlinear()
    limit_cycle_branch(model, (0.3, 0.8), n_points=5, harmonics=4)  # warm-up (compiled stability kernels)

    t_branch, c_branch = math.inf, math.inf
    for _ in range(args.repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        ds = limit_cycle_branch(model, (0.3, 0.8), n_points=100, harmonics=10)
        t_branch = min(t_branch, time.perf_counter() - t0)
        c_branch = min(c_branch, time.process_time() - c0)
    n_pts = ds.sizes["point"]
    print(f"branch: {n_pts} points (H = 10, Floquet stability, 2H check {ds.attrs['harmonics_change']:.1e}) "
          f"in {c_branch:.3f} s CPU, {t_branch:.3f} s wall = {1e3 * c_branch / n_pts:.2f} ms CPU per point")
    print(f"  Hopf point mu = {ds.attrs['hopf_mu']:.6f}, {ds.attrs['hopf_frequency_hz']:.2f} Hz, "
          f"{ds.attrs['kind']} (from {ds.attrs['kind_from']})")

    mu_b = ds.mu.values
    ok = np.flatnonzero((mu_b >= args.mu_min) & ds.stable.values)
    pick = ok[np.linspace(0, ok.size - 1, args.runs).round().astype(int)]
    mus = mu_b[pick]
    sigma = eigenvalues(model, mus, tan_theta=0.0, damped=True).real.max(axis=-1)
    amp = ds.amplitude.values[pick]
    duration = float(np.max(np.log(amp.max(axis=1) / 1e-9) / sigma)) + 0.5
    simulate_batch(model, mu=mus[:1], duration=0.001, contact=contact)  # load the compiled kernel
    names = model.dof_names
    t_tr, c_tr = math.inf, math.inf
    for _ in range(args.repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        grow = simulate_batch(model, mu=mus, duration=duration, fs=4000.0, contact=contact, perturbation=1e-9,
                              rng=np.random.default_rng(0))
        runs = []
        for r in range(mus.size):
            end = grow.isel(run=r, time=-1)
            x0 = [float(end[n]) for n in names]
            v0 = [float(end[f"{n}_dot"]) for n in names]
            runs.append((x0, v0))
        fine = []
        for r, (x0, v0) in enumerate(runs):
            fine.append(simulate(model, mu=float(mus[r]), duration=0.03, fs=400_000.0, contact=contact, x0=x0,
                                 v0=v0))
        t_tr = min(t_tr, time.perf_counter() - t0)
        c_tr = min(c_tr, time.process_time() - c0)
    per_run, per_run_cpu = t_tr / mus.size, c_tr / mus.size
    print(f"transients: {mus.size} runs of {duration:.2f} s (+0.03 s at 400 kHz) in {c_tr:.2f} s CPU, "
          f"{t_tr:.2f} s wall = {per_run_cpu:.3f} s CPU per steady state")
    sys = contact_system(model, contact)
    worst_a, worst_f = 0.0, 0.0
    print(f"{'mu':>8} {'sigma [1/s]':>11} " + " ".join(f"{'dA/A ' + n:>10}" for n in names) + f" {'df/f':>10}")
    for r, i in enumerate(pick):
        lc = harmonic_balance(sys, float(mu_b[i]), omega=float(ds.omega_rad_s[i]), guess=ds.coefficients[i].values,
                              harmonics=10, check_harmonics=False)
        tr = fine[r]
        errs = []
        for j, n in enumerate(names):
            x = tr[n].values
            errs.append(0.5 * (x.max() - x.min()) / lc.amplitude[j] - 1)
        x = tr["x1"].values - tr["x1"].values.mean()
        k = np.flatnonzero((x[:-1] < 0) & (x[1:] >= 0))
        tc = (k - x[k] / (x[k + 1] - x[k])) / 400_000.0
        df = 1 / np.mean(np.diff(tc)) / lc.frequency_hz - 1
        worst_a = max(worst_a, max(abs(e) for e in errs))
        worst_f = max(worst_f, abs(df))
        print(f"{mu_b[i]:8.4f} {sigma[r]:11.2f} " + " ".join(f"{e:10.2e}" for e in errs) + f" {df:10.2e}")
    print(f"worst agreement: amplitude {worst_a:.2e}, frequency {worst_f:.2e}")
    print(f"the branch's {n_pts} steady states by transient simulation: {per_run_cpu * n_pts:.1f} s CPU "
          f"({per_run_cpu:.3f} s x {n_pts}), {per_run * n_pts:.1f} s wall; by harmonic balance {c_branch:.3f} s CPU, "
          f"{t_branch:.3f} s wall: ratio {per_run_cpu * n_pts / c_branch:.0f}x (CPU), "
          f"{per_run * n_pts / t_branch:.0f}x (wall)")
    # Near mu_crit the growth rate tends to 0 and a transient needs ever longer to settle: the
    # durations the branch's other points need, at the throughput just measured.
    rate = t_tr / (mus.size * duration)  # wall seconds per simulated second and run
    above = mu_b > ds.attrs["hopf_mu"] + 0.005
    sig_all = eigenvalues(model, mu_b[above], tan_theta=0.0, damped=True).real.max(axis=-1)
    need = np.log(ds.amplitude.values[above].max(axis=1) / 1e-9) / sig_all + 0.5
    print(f"all {above.sum()} branch points with mu > mu_crit + 0.005 need {need.sum():.0f} s simulated in total "
          f"(longest {need.max():.1f} s): ~{need.sum() * rate:.0f} s at that throughput, "
          f"ratio {need.sum() * rate / t_branch:.0f}x (estimate)")
    if not math.isfinite(worst_a):
        raise SystemExit(1)


if __name__ == "__main__":
    main()

"""Benchmark: compiled ``simulate`` (Dormand-Prince 5(4); RK4) against ``solve_ivp(RK45, rtol=1e-6)``, paper Fig. 4.

The case is the paper's section 4 (mu = 0.4, c1 = c2 = c3 = 220 N s/m, P = 10 N, sine SRO
q0 = 0.08 mm, lambda = 1 mm, v = 0.02 m/s). Both solve the same equations (eq. 4). Accuracy is
the relative RMS difference of the vibration (high-pass above 1 kHz) of x1, y1, y2 against
``solve_ivp(DOP853, rtol=1e-10)`` on the first 0.15 s (the paper's window).

Run:  python benchmarks/bench_transient.py [--duration 1.0]
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np
from scipy.integrate import solve_ivp
from scipy.signal import butter, sosfiltfilt

from squealkit.models import get_preset
from squealkit.transient import SineRunOut, TensileContactWarning, simulate, simulate_batch
from squealkit.transient.reference import first_order_rhs

FS = 40_000.0


def _hp_rel_rms(a: np.ndarray, b: np.ndarray) -> float:
    sos = butter(4, 1000.0, btype="highpass", fs=FS, output="sos")
    fa, fb = sosfiltfilt(sos, a), sosfiltfilt(sos, b)
    return float(np.sqrt(np.mean((fa - fb) ** 2)) / np.sqrt(np.mean(fb**2)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=1.0, help="simulated time [s] of the timed runs")
    args = ap.parse_args()
    model, mu, speed = get_preset("lv2013"), 0.4, 0.02
    profile = SineRunOut(0.08e-3, 1e-3)
    rhs = first_order_rhs(model, mu=mu, profile=profile, speed=speed)
    q0, t0 = profile.evaluate(0.0)
    z0 = np.concatenate([model.static_equilibrium(mu, t0, q0), np.zeros(model.n_dof)])

    simulate(model, mu=mu, profile=profile, speed=speed, duration=0.001, fs=FS)  # load the compiled kernel

    # Accuracy on the paper's 0.15 s window.
    t_acc = np.arange(int(0.15 * FS) + 1) / FS
    ref = solve_ivp(rhs, (0, t_acc[-1]), z0, method="DOP853", rtol=1e-10, atol=1e-16, t_eval=t_acc)
    rk45 = solve_ivp(rhs, (0, t_acc[-1]), z0, method="RK45", rtol=1e-6, t_eval=t_acc)
    ours = simulate(model, mu=mu, profile=profile, speed=speed, duration=0.15, fs=FS)
    rk4 = simulate(model, mu=mu, profile=profile, speed=speed, duration=0.15, fs=FS, method="rk4")
    names = model.dof_names
    err_ours = max(_hp_rel_rms(ours[n].values, ref.y[i]) for i, n in enumerate(names))
    err_rk4 = max(_hp_rel_rms(rk4[n].values, ref.y[i]) for i, n in enumerate(names))
    err_rk45 = max(_hp_rel_rms(rk45.y[i], ref.y[i]) for i, n in enumerate(names))
    print(f"accuracy vs DOP853 (0.15 s, worst of {names}, high-pass 1 kHz, rel. RMS):")
    print(f"  squealkit dopri5 (rtol = {ours.attrs['rtol']:g}): {err_ours:.2e}")
    print(f"  squealkit RK4 (dt = {rk4.attrs['dt']:.3g} s):  {err_rk4:.2e}")
    print(f"  solve_ivp RK45 rtol=1e-6:          {err_rk45:.2e}")

    # Timing on --duration seconds of simulated time.
    T = args.duration
    t_out = np.arange(int(T * FS) + 1) / FS
    t1 = time.perf_counter()
    sol = solve_ivp(rhs, (0, T), z0, method="RK45", rtol=1e-6, t_eval=t_out)
    t_rk45 = time.perf_counter() - t1
    with warnings.catch_warnings():  # the linear law's tensile force is reported, not the point here
        warnings.simplefilter("ignore", TensileContactWarning)
        t1 = time.perf_counter()
        ds = simulate(model, mu=mu, profile=profile, speed=speed, duration=T, fs=FS)
        t_ours = time.perf_counter() - t1
        t1 = time.perf_counter()
        simulate(model, mu=mu, profile=profile, speed=speed, duration=T, fs=FS, method="rk4")
        t_rk4 = time.perf_counter() - t1
    print(f"timing, {T:g} s simulated, output at {FS:g} Hz:")
    print(f"  solve_ivp RK45 rtol=1e-6: {t_rk45:8.3f} s ({sol.nfev} RHS calls)")
    print(f"  squealkit dopri5:         {t_ours:8.3f} s ({ds.attrs['status']}, {ds.attrs['steps']} steps, "
          f"{ds.attrs['rhs_calls']} RHS calls, incl. sigma(t) and labels)")
    print(f"  squealkit RK4:            {t_rk4:8.3f} s")
    print(f"  speed-up (dopri5 vs RK45): {t_rk45 / t_ours:.1f}x")

    # A batch of 8 friction values in parallel over runs (numba prange).
    mus = np.linspace(0.3, 0.65, 8)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TensileContactWarning)
        t1 = time.perf_counter()
        simulate_batch(model, mu=mus, profiles=profile, speed=speed, duration=T, fs=FS)
        t_batch = time.perf_counter() - t1
        t1 = time.perf_counter()
        for m in mus:
            simulate(model, mu=float(m), profile=profile, speed=speed, duration=T, fs=FS)
        t_serial = time.perf_counter() - t1
    print(f"batch of {mus.size} runs: {t_batch:.3f} s in parallel vs {t_serial:.3f} s one by one")


if __name__ == "__main__":
    main()

"""Report step for the paper's §4: transient responses on a smooth disc (Fig. 3) and with SRO (Fig. 4)."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np

from ..io import save_dataset
from ..models import FrictionModel
from ..stability import eigenvalues
from ..transient import SineRunOut, TensileContactWarning, simulate, transient_summary
from .document import Comparison, FigureRef, Section, Table
from .steps_stability import _save_fig, damping_text

# Paper §4: mu = 0.4, v = 0.02 m/s, c1 = c2 = c3 = 220 N s/m, P = 10 N; Fig. 4: q0 = 0.08 mm, lambda = 1 mm.
MU_PAPER, SPEED, Q0, WAVELENGTH = 0.4, 0.02, 0.08e-3, 1e-3
NEUTRAL = 5e-3  # |growth rate| [1/s] below this is neutral (undamped round-off), neither growth nor decay


def _dominant_frequency(ds, var: str, freq_lower: float = 1000.0) -> float:
    """Peak of the windowed spectrum of the second half of a response [Hz]."""
    x = ds[var].values
    x = x[len(x) // 2:] - np.mean(x[len(x) // 2:])
    fs = float(ds.attrs.get("fs", 1.0 / float(ds.time[1] - ds.time[0])))
    spec = np.abs(np.fft.rfft(x * np.hanning(len(x))))
    freqs = np.fft.rfftfreq(len(x), 1.0 / fs)
    spec[freqs < freq_lower] = 0.0
    k = int(np.argmax(spec))
    if 0 < k < len(spec) - 1:  # parabolic refinement on the log spectrum
        a, b, c = np.log(spec[k - 1: k + 2] + 1e-300)
        k = k + 0.5 * (a - c) / (a - 2 * b + c)
    return float(k * fs / len(x))


def _fig3_text(sigma_04: float, sigma_06: float, dur: float, mu_clear: float, f_sim: float, f_eig: float) -> str:
    """Fig. 3's sentence, following the computed growth rates (stable, marginal or clearly unstable)."""
    if sigma_04 < -NEUTRAL:
        first = (f"Fig. 3 (smooth disc): at the paper's mu = {MU_PAPER} the model is stable (largest growth "
                 f"rate {sigma_04:+.2f} 1/s), so a disturbance decays.")
    elif sigma_04 <= NEUTRAL:
        first = (f"Fig. 3 (smooth disc): at the paper's mu = {MU_PAPER} the model is neutrally stable (largest growth "
                 f"rate {sigma_04:+.2f} 1/s: without damping a disturbance neither grows nor decays).")
    elif sigma_04 < 20.0:
        first = (f"Fig. 3 (smooth disc): at the paper's mu = {MU_PAPER} the model is only marginally unstable "
                 f"(largest growth rate {sigma_04:+.2f} 1/s), so in {dur:g} s the self-excited vibration barely grows.")
    else:
        first = (f"Fig. 3 (smooth disc): at the paper's mu = {MU_PAPER} the model is unstable (largest growth "
                 f"rate {sigma_04:+.2f} 1/s).")
    if sigma_06 > NEUTRAL:
        agree = abs(f_sim / f_eig - 1) < 0.01 if f_eig else False
        return first + (f" The figure shows mu = {mu_clear}, where it grows at {sigma_06:+.1f} 1/s, vibrating at "
                        f"{f_sim:.1f} Hz" + (": the unstable mode's frequency." if agree else
                                             f" (the unstable mode's eigenvalue: {f_eig:.1f} Hz)."))
    return first + (f" The figure shows mu = {mu_clear}, where the model does not grow either (largest growth rate "
                    f"{sigma_06:+.2f} 1/s): no self-excited vibration.")


def _fig4_text(rise_rate: float, fall_rate: float) -> str:
    """Fig. 4's sentence, from the envelope rates actually measured on the run."""
    head = (f"Fig. 4 (sine SRO, q0 = {Q0 * 1e3:g} mm, lambda = {WAVELENGTH * 1e3:g} mm, max tan(theta) = "
            f"{2 * math.pi * Q0 / WAVELENGTH:.3f}): ")
    if not (math.isfinite(rise_rate) and math.isfinite(fall_rate)):
        return head + "the run holds no whole rising and falling stage to measure the envelope on."
    if rise_rate > 0 > fall_rate:
        return head + (f"mu_e = mu + tan(theta) swings through the stability boundary, so the response grows on "
                       f"rising stages ({rise_rate:+.1f} 1/s on average) and decays on falling ones "
                       f"({fall_rate:+.1f} 1/s).")
    return head + (f"the envelope changes at {rise_rate:+.1f} 1/s on rising stages and {fall_rate:+.1f} 1/s on "
                   "falling ones: not the paper's grow-on-rising, decay-on-falling pattern.")


def transient_step(model: FrictionModel, figures: Path, data: Path, *, quick: bool = False) -> Section:
    """Figs. 3 and 4: self-excited vibration on a smooth disc; growth on rising SRO, decay on falling."""
    from ..plotting.transient import envelope_plot, fig3_plot, fig4_plot

    rng = np.random.default_rng(2013)
    dur4 = 0.075 if quick else 0.15
    dur3 = 0.2 if quick else 0.5
    mu_clear = 0.6
    with warnings.catch_warnings():  # a tensile normal force is reported in the text below instead
        warnings.simplefilter("ignore", TensileContactWarning)
        smooth_paper = simulate(model, mu=MU_PAPER, speed=SPEED, duration=dur4, perturbation=1e-9, rng=rng)
        smooth_clear = simulate(model, mu=mu_clear, speed=SPEED, duration=dur3, perturbation=1e-9, rng=rng)
        sro = simulate(model, mu=MU_PAPER, profile=SineRunOut(Q0, WAVELENGTH), speed=SPEED, duration=dur4)
    for name, ds in (("fig3_smooth_mu04.nc", smooth_paper), ("fig3_smooth_mu06.nc", smooth_clear),
                     ("fig4_sine_sro.nc", sro)):
        save_dataset(ds, data / name)
    _save_fig(fig3_plot(smooth_clear), figures, "fig3_smooth_disc")
    _save_fig(fig4_plot(sro, smooth=smooth_paper), figures, "fig4_sine_sro")
    # the paper plots the pin's x1''; another model's first acceleration stands in for it
    accels = [str(v) for v in sro.data_vars if str(v).endswith("_ddot")]
    var = "x1_ddot" if "x1_ddot" in accels else accels[0]

    sigma_04 = float(eigenvalues(model, MU_PAPER, 0.0, damped=True).real.max())
    lam_06 = eigenvalues(model, mu_clear, 0.0, damped=True)
    k = int(np.argmax(lam_06.real))
    f_eig = abs(float(lam_06.imag[k] / (2 * math.pi)))
    # the paper high-passes at 1000 Hz (its squeal is near 2.4 kHz); a model vibrating lower gets half its frequency
    f_low = min(1000.0, 0.5 * f_eig) if f_eig > 0 else 1000.0
    _save_fig(envelope_plot(sro, var=var, highpass_freq=f_low), figures, "fig4_envelope_vs_sigma")
    sigma_06 = float(lam_06.real[k])
    f_sim = _dominant_frequency(smooth_clear, var, f_low)
    summary = transient_summary(sro, highpass_freq=f_low)
    whole = [s for s in summary["stages"] if not s["partial"]]
    rising = [s["rate_per_s"] for s in whole if s["stage"] == "rising"]
    falling = [s["rate_per_s"] for s in whole if s["stage"] == "falling"]
    rise_rate = float(np.mean(rising)) if rising else math.nan
    fall_rate = float(np.mean(falling)) if falling else math.nan
    comps = (
        Comparison("vibration frequency on a smooth disc (mu = 0.6)", None, f_sim, "Hz",
                   abs(f_sim / f_eig - 1) < 0.01 if sigma_06 > NEUTRAL else None,
                   f"eigenvalue of the unstable mode: {f_eig:.1f} Hz; paper: 'consistent with the coupling frequency'"
                   if sigma_06 > NEUTRAL else "no growing mode at mu = 0.6: no self-excited frequency to check"),
        Comparison("envelope growth rate on rising SRO (Fig. 4)", None, rise_rate, "1/s",
                   rise_rate > 0, "paper: responses diverge while the SRO rises"),
        Comparison("envelope decay rate on falling SRO (Fig. 4)", None, fall_rate, "1/s",
                   fall_rate < 0, "paper: responses converge while the SRO falls"),
    )
    tensile = sro.attrs.get("tensile_fraction", 0.0)
    note = (f" Note: with the paper's linear contact law the normal force of the Fig. 4 run was tensile "
            f"{100 * tensile:.1f} % of the time (down to {sro.attrs['min_normal_force']:.0f} N, against "
            f"{float(sro.normal_force.max()):.0f} N at most in compression): a real contact would open. Run with "
            "contact loss (contact='nonlinear', CLI --contact nonlinear) to see the bounded response."
            if tensile > 0 else "")
    params = model.parameters()
    setting = [f"mu = {MU_PAPER}", f"v = {SPEED} m/s"]
    if damping_text(model):
        setting.append(damping_text(model))
    if isinstance(params.get("P"), int | float):
        setting.append(f"P = {params['P']:g} N")
    paragraphs = [
        f"Time integration of eq. (4) ({sro.attrs['integrator']}, rtol = {sro.attrs.get('rtol', 0):g}, "
        f"{sro.attrs.get('steps', 0)} steps) at the paper's §4 operating point with this model's parameters: "
        + ", ".join(setting) + "." + note
        + ("" if var == "x1_ddot" else f" The model has no pin x1; its {var} is shown and analysed instead."),
        _fig3_text(sigma_04, sigma_06, dur4, mu_clear, f_sim, f_eig),
        _fig4_text(rise_rate, fall_rate),
    ]
    table = Table(
        "Envelope growth per SRO stage (Fig. 4; partial stages at the record's ends left out)",
        ("stage", "from [s]", "to [s]", "envelope rate [1/s]", "mean frozen-time sigma [1/s]"),
        tuple((s["stage"], s["t_start"], s["t_end"], s["rate_per_s"], s["sigma_mean_per_s"]) for s in whole),
    )
    return Section(
        "transient", "§4: transient responses (Figs. 3 and 4)", tuple(paragraphs), comps, (table,),
        (FigureRef("fig3_smooth_disc", f"Fig. 3: accelerations on a smooth disc, mu = {mu_clear}"),
         FigureRef("fig4_sine_sro", "Fig. 4: accelerations with the sine SRO drawn alongside (grey: smooth disc)"),
         FigureRef("fig4_envelope_vs_sigma", "Response envelope against the frozen-time growth rate sigma(t)")),
        ("fig3_smooth_mu04.nc", "fig3_smooth_mu06.nc", "fig4_sine_sro.nc"),
        numbers={"sigma_mu04": sigma_04, "f_smooth_hz": f_sim, "f_eigen_hz": f_eig, "rise_rate": rise_rate,
                 "fall_rate": fall_rate, "fig4_tensile_fraction": float(tensile)},
    )

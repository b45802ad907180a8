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
from .settings import ReportSettings
from .steps_stability import _save_fig, damping_text

# The operating point (paper §4: mu = 0.4, v = 0.02 m/s; Fig. 4: q0 = 0.08 mm, lambda = 1 mm) comes
# from ReportSettings: the paper's for the paper's model, the user's [report] table or the model's onset.
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


def _fig3_text(sigma_04: float, sigma_06: float, dur: float, mu_clear: float, f_sim: float, f_eig: float,
               settings: ReportSettings | None = None) -> str:
    """Fig. 3's sentence, following the computed growth rates (stable, marginal or clearly unstable)."""
    settings = settings or ReportSettings.paper()
    at = f"at {'the paper' if settings.is_paper else 'the report'}'s mu = {settings.mu_transient:g}"
    if sigma_04 < -NEUTRAL:
        first = (f"Fig. 3 (smooth disc): {at} the model is stable (largest growth "
                 f"rate {sigma_04:+.2f} 1/s), so a disturbance decays.")
    elif sigma_04 <= NEUTRAL:
        first = (f"Fig. 3 (smooth disc): {at} the model is neutrally stable (largest growth "
                 f"rate {sigma_04:+.2f} 1/s: without damping a disturbance neither grows nor decays).")
    elif sigma_04 < 20.0:
        first = (f"Fig. 3 (smooth disc): {at} the model is only marginally unstable "
                 f"(largest growth rate {sigma_04:+.2f} 1/s), so in {dur:g} s the self-excited vibration barely grows.")
    else:
        first = f"Fig. 3 (smooth disc): {at} the model is unstable (largest growth rate {sigma_04:+.2f} 1/s)."
    if sigma_06 > NEUTRAL:
        agree = abs(f_sim / f_eig - 1) < 0.01 if f_eig else False
        return first + (f" The figure shows mu = {mu_clear:g}, where it grows at {sigma_06:+.1f} 1/s, vibrating at "
                        f"{f_sim:.1f} Hz" + (": the unstable mode's frequency." if agree else
                                             f" (the unstable mode's eigenvalue: {f_eig:.1f} Hz)."))
    return first + (f" The figure shows mu = {mu_clear:g}, where the model does not grow either (largest growth rate "
                    f"{sigma_06:+.2f} 1/s): no self-excited vibration.")


def _rates(rates: list[float]) -> str:
    """Envelope rates of the stages of one kind as text: one rate, or the first to the last."""
    if len(rates) == 1:
        return f"{rates[0]:+.1f} 1/s"
    return f"from {rates[0]:+.1f} 1/s on the first to {rates[-1]:+.1f} 1/s on the last"


#: A stage's envelope rate is the self-excited growth (or decay) when it lies within this factor of the
#: stage's mean frozen-time growth rate, with its sign (the paper's run: 34.3 against 25.0 1/s rising,
#: -39.6 against -25.7 falling); far beyond it the envelope follows what the run-out itself excites.
SELF_EXCITED_FACTOR = 3.0


def _self_excited(rates: list[float], sigmas: list[float]) -> bool:
    """Whether every stage's envelope rate is its own frozen-time growth rate, within the factor."""
    return all(s != 0 and 1 / SELF_EXCITED_FACTOR <= r / s <= SELF_EXCITED_FACTOR
               for r, s in zip(rates, sigmas, strict=True))


def _sigma_span(sigmas: list[float]) -> str:
    """Mean frozen-time growth rates of the stages of one kind, as text."""
    lo, hi = min(sigmas), max(sigmas)
    return f"{lo:+.1f} 1/s" if abs(hi - lo) < 0.05 else f"{lo:+.1f} to {hi:+.1f} 1/s"


def _fig4_text(rising: list[float], falling: list[float], settings: ReportSettings | None = None,
               sigma_range: tuple[float, float] | None = None,
               stage_sigma: tuple[list[float], list[float]] | None = None) -> str:
    """Fig. 4's sentence, from the envelope rate of each whole stage of the run (in time order).

    The rates are quoted stage by stage (first and last), never averaged: on a linear law the
    response blows up, and a mean of its stages' exponential rates describes none of them.
    ``stage_sigma`` holds the mean frozen-time growth rate of each rising and falling stage: an
    envelope that swings far beyond it is not called the instability's growth and decay."""
    st = settings or ReportSettings.paper()
    head = (f"Fig. 4 (sine SRO, q0 = {st.sro_amplitude * 1e3:g} mm, lambda = {st.sro_wavelength * 1e3:g} mm, "
            f"max tan(theta) = {st.sro_slope:.3f}, mu = {st.mu_transient:g}): ")
    if not (rising and falling):
        return head + "the run holds no whole rising and falling stage to measure the envelope on."
    if sigma_range is not None and sigma_range[1] <= NEUTRAL:  # nothing grows anywhere on the run
        return head + (f"the frozen-time growth rate stays between {sigma_range[0]:+.2f} and {sigma_range[1]:+.2f} "
                       "1/s over the whole run: mu + tan(theta) never reaches a stability boundary, so the run-out "
                       f"neither starts nor stops a self-excited vibration (envelope rates per stage: rising "
                       f"{_rates(rising)}, falling {_rates(falling)}).")
    n_up, n_down = sum(r > 0 for r in rising), sum(r < 0 for r in falling)
    stages = (f"{len(rising)} rising stage{'s' if len(rising) > 1 else ''} ({_rates(rising)}) and "
              f"{len(falling)} falling one{'s' if len(falling) > 1 else ''} ({_rates(falling)})")
    if n_up == len(rising) and n_down == len(falling) and stage_sigma is not None and not (
            _self_excited(rising, stage_sigma[0]) and _self_excited(falling, stage_sigma[1])):
        return head + (f"the envelope grows on every rising stage and decays on every falling one ({stages}), but "
                       "far beyond the self-excited growth and decay the frozen-time analysis gives on the same "
                       f"stages (mean growth rate {_sigma_span(stage_sigma[0])} rising, "
                       f"{_sigma_span(stage_sigma[1])} falling): the envelope follows what the run-out itself "
                       "excites, not the instability, so this run does not show the paper's self-excited "
                       "intermittency.")
    if n_up == len(rising) and n_down == len(falling):
        return head + (f"mu_e = mu + tan(theta) swings through the stability boundary, so the response grows on "
                       f"every rising stage and decays on every falling one: envelope rates on {stages}.")
    return head + (f"the envelope grows on {n_up} of {len(rising)} rising stages and decays on {n_down} of "
                   f"{len(falling)} falling ones (rates on {stages}): not the paper's grow-on-rising, "
                   "decay-on-falling pattern.")


def transient_step(model: FrictionModel, figures: Path, data: Path, *, quick: bool = False,
                   settings: ReportSettings | None = None, published: bool = True) -> Section:
    """Figs. 3 and 4: self-excited vibration on a smooth disc; growth on rising SRO, decay on falling.

    ``settings`` is the operating point (default: the paper's); ``published`` keeps the checks of
    the paper's claims as verdicts (the paper's model only)."""
    from ..plotting.transient import envelope_plot, fig3_plot, fig4_plot

    st = settings or ReportSettings.paper()
    rng = np.random.default_rng(2013)
    period = st.sro_wavelength / st.speed  # one run-out period [s] (paper: 50 ms)
    dur4 = (1.5 if quick else 3.0) * period  # whole rising and falling stages for any run-out (paper: 75/150 ms)
    dur3 = 0.2 if quick else 0.5
    mu_first, mu_clear, speed = st.mu_transient, st.mu_unstable, st.speed
    with warnings.catch_warnings():  # a tensile normal force is reported in the text below instead
        warnings.simplefilter("ignore", TensileContactWarning)
        smooth_paper = simulate(model, mu=mu_first, speed=speed, duration=dur4, perturbation=1e-9, rng=rng)
        smooth_clear = simulate(model, mu=mu_clear, speed=speed, duration=dur3, perturbation=1e-9, rng=rng)
        sro = simulate(model, mu=mu_first, profile=SineRunOut(st.sro_amplitude, st.sro_wavelength), speed=speed,
                       duration=dur4)
    for name, ds in (("fig3_smooth_mu04.nc", smooth_paper), ("fig3_smooth_mu06.nc", smooth_clear),
                     ("fig4_sine_sro.nc", sro)):
        save_dataset(ds, data / name)
    _save_fig(fig3_plot(smooth_clear), figures, "fig3_smooth_disc")
    _save_fig(fig4_plot(sro, smooth=smooth_paper), figures, "fig4_sine_sro")
    # the paper plots the pin's x1''; another model's first acceleration stands in for it
    accels = [str(v) for v in sro.data_vars if str(v).endswith("_ddot")]
    var = "x1_ddot" if "x1_ddot" in accels else accels[0]

    sigma_04 = float(eigenvalues(model, mu_first, tan_theta=0.0, damped=True).real.max())
    lam_06 = eigenvalues(model, mu_clear, tan_theta=0.0, damped=True)
    k = int(np.argmax(lam_06.real))
    f_eig = abs(float(lam_06.imag[k] / (2 * math.pi)))
    # the paper high-passes at 1000 Hz (its squeal is near 2.4 kHz); a model vibrating lower gets half its frequency
    f_low = min(1000.0, 0.5 * f_eig) if f_eig > 0 else 1000.0
    _save_fig(envelope_plot(sro, var=var, highpass_freq=f_low), figures, "fig4_envelope_vs_sigma")
    sigma_06 = float(lam_06.real[k])
    f_sim = _dominant_frequency(smooth_clear, var, f_low)
    summary = transient_summary(sro, highpass_freq=f_low)
    whole = [s for s in summary["stages"] if not s["partial"]]
    rising = [float(s["rate_per_s"]) for s in whole if s["stage"] == "rising"]
    falling = [float(s["rate_per_s"]) for s in whole if s["stage"] == "falling"]
    stage_sigma = ([float(s["sigma_mean_per_s"]) for s in whole if s["stage"] == "rising"],
                   [float(s["sigma_mean_per_s"]) for s in whole if s["stage"] == "falling"])
    self_excited = _self_excited(rising, stage_sigma[0]) and _self_excited(falling, stage_sigma[1])
    # the last whole stage of each kind: a blow-up's early stages start from the run-out's forcing
    rise_rate = rising[-1] if rising else math.nan
    fall_rate = falling[-1] if falling else math.nan
    comps = [
        Comparison(f"vibration frequency on a smooth disc (mu = {mu_clear:g})", None, f_sim, "Hz",
                   abs(f_sim / f_eig - 1) < 0.01 if sigma_06 > NEUTRAL else None,
                   f"eigenvalue of the unstable mode: {f_eig:.1f} Hz"
                   + ("; paper: 'consistent with the coupling frequency'" if published else "")
                   if sigma_06 > NEUTRAL else f"no growing mode at mu = {mu_clear:g}: no self-excited frequency to "
                   "check"),
    ]
    if published:  # the paper's claims about its own Fig. 4, checked on its model
        comps += [
            Comparison("envelope growth rate on the last rising SRO stage (Fig. 4)", None, rise_rate, "1/s",
                       bool(rising) and all(r > 0 for r in rising),
                       "paper: responses diverge while the SRO rises (every rising stage grows)"),
            Comparison("envelope decay rate on the last falling SRO stage (Fig. 4)", None, fall_rate, "1/s",
                       bool(falling) and all(r < 0 for r in falling),
                       "paper: responses converge while the SRO falls (every falling stage decays)"),
        ]
    tensile = sro.attrs.get("tensile_fraction", 0.0)
    note = (f" Note: with the paper's linear contact law the normal force of the Fig. 4 run was tensile "
            f"{100 * tensile:.1f} % of the time (down to {sro.attrs['min_normal_force']:.0f} N, against "
            f"{float(sro.normal_force.max()):.0f} N at most in compression): a real contact would open. Run with "
            "contact loss (contact='nonlinear', CLI --contact nonlinear) to see the bounded response."
            if tensile > 0 else "")
    params = model.parameters()
    setting = [f"mu = {mu_first:g}", f"v = {speed:g} m/s"]
    if damping_text(model):
        setting.append(damping_text(model))
    if isinstance(params.get("P"), int | float):
        setting.append(f"P = {params['P']:g} N")
    where = ("the paper's §4 operating point with this model's parameters" if st.is_paper else
             f"this report's operating point ({st.source})")
    paragraphs = [
        f"Time integration of eq. (4) ({sro.attrs['integrator']}, rtol = {sro.attrs.get('rtol', 0):g}, "
        f"{sro.attrs.get('steps', 0)} steps) at {where}: "
        + ", ".join(setting) + "." + note
        + ("" if var == "x1_ddot" else f" The model has no pin x1; its {var} is shown and analysed instead."),
        _fig3_text(sigma_04, sigma_06, dur4, mu_clear, f_sim, f_eig, st),
        _fig4_text(rising, falling, st, (float(sro["growth_rate"].min()), float(sro["growth_rate"].max())),
                   stage_sigma),
    ]
    table = Table(
        "Envelope growth per SRO stage (Fig. 4; partial stages at the record's ends left out)",
        ("stage", "from [s]", "to [s]", "envelope rate [1/s]", "mean frozen-time sigma [1/s]"),
        tuple((s["stage"], s["t_start"], s["t_end"], s["rate_per_s"], s["sigma_mean_per_s"]) for s in whole),
    )
    return Section(
        "transient", "§4: transient responses (Figs. 3 and 4)", tuple(paragraphs), tuple(comps), (table,),
        (FigureRef("fig3_smooth_disc", f"Fig. 3: accelerations on a smooth disc, mu = {mu_clear:g}"),
         FigureRef("fig4_sine_sro", "Fig. 4: accelerations with the sine SRO drawn alongside (grey: smooth disc)"),
         FigureRef("fig4_envelope_vs_sigma", "Response envelope against the frozen-time growth rate sigma(t)")),
        ("fig3_smooth_mu04.nc", "fig3_smooth_mu06.nc", "fig4_sine_sro.nc"),
        numbers={"sigma_mu04": sigma_04, "f_smooth_hz": f_sim, "f_eigen_hz": f_eig, "rise_rate": rise_rate,
                 "fall_rate": fall_rate, "rising_stages_growing": float(sum(r > 0 for r in rising)),
                 "rising_stages": float(len(rising)), "falling_stages_decaying": float(sum(r < 0 for r in falling)),
                 "falling_stages": float(len(falling)), "fig4_tensile_fraction": float(tensile),
                 "fig4_self_excited": float(self_excited), "fig4_sigma_max": float(sro["growth_rate"].max()),
                 "mu_transient": mu_first},
    )

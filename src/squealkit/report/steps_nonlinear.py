"""How loud: the squeal limit cycles at the paper's parameters, on a flat disc and with run-out.

Eigenvalues say where squeal can start; the limit cycle the growing vibration settles on says
how large it gets. This step follows the branch of cycles over friction on a flat disc and over
the run-out slope at the paper's Fig. 4 friction (harmonic balance with the transient's
nonlinear contact), and runs the Fig. 4 case with that contact law to put its vibration
envelope beside the limit-cycle amplitude of each instant's slope. The prose is written from
the numbers.
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import xarray as xr

from ..io import save_dataset
from ..models import FrictionModel
from .document import FigureRef, Section, Table

__all__ = ["nonlinear_step"]

# Paper §4: v = 0.02 m/s; Fig. 4: mu = 0.4, sine SRO q0 = 0.08 mm, lambda = 1 mm (max slope 0.503).
MU_FIG4, SPEED, Q0, WAVELENGTH = 0.4, 0.02, 0.08e-3, 1e-3
#: Friction range of the flat-disc branch, and the harmonics of every cycle.
MU_RANGE, HARMONICS = (0.3, 1.0), 10
#: The DOF whose amplitude the section reports (the pin's, as the paper's Fig. 3-4 accelerations).
DOF = "x1"


def _at(ds: xr.Dataset, param: str, value: float, var: str = "amplitude") -> float:
    """``var`` of ``DOF`` interpolated at ``param = value`` on the stable part beyond the onset."""
    x = ds[param].values
    y = ds[var].sel(dof=DOF).values if var == "amplitude" else ds[var].values
    keep = ds["stable"].values.astype(bool) & (x > float(ds.attrs["hopf_mu"]) + 1e-9)
    if keep.sum() < 2 or not x[keep].min() <= value <= x[keep].max():
        return math.nan
    order = np.argsort(x[keep])
    return float(np.interp(value, x[keep][order], y[keep][order]))


def _um(x: float) -> str:
    return f"{x * 1e6:.3f} um" if math.isfinite(x) else "no cycle"


def nonlinear_step(model: FrictionModel, figures: Path, data: Path, *, quick: bool = False) -> Section:
    """The section "How loud": limit cycles over friction and run-out slope, beside the Fig. 4 transient."""
    from ..stability.critical import UnrealisticFrictionWarning

    with warnings.catch_warnings():  # the critical-friction section already says so
        warnings.simplefilter("ignore", UnrealisticFrictionWarning)
        return _nonlinear_step(model, figures, data, quick=quick)


def _nonlinear_step(model: FrictionModel, figures: Path, data: Path, *, quick: bool) -> Section:
    from .._validation import InputError
    from ..nonlinear import limit_cycle_branch, limit_cycle_branch_slope
    from ..plotting.limitcycle import how_loud_plot
    from ..stability import critical_friction
    from ..transient import Contact, SineRunOut, TensileContactWarning, simulate
    from ..transient.simulate import response_envelope
    from .steps_stability import _save_fig

    title = "How loud: squeal limit cycles"
    if DOF not in model.dof_names:
        return Section("how_loud", title, (f"This model has no DOF {DOF!r} (the pin's); the limit-cycle section is "
                                           "written for the pin-on-disc model.",))
    crit = critical_friction(model, 0.0, damped=True, mu_max=2.0)
    if crit.status != "onset":
        return Section("how_loud", title, (f"The damped model has no squeal onset on a flat disc up to mu = 2 "
                                           f"({crit.status}): there is no limit cycle to follow.",))
    # the paper's range, widened for a model whose onset lies outside it
    mu_range = (min(MU_RANGE[0], 0.9 * crit.mu_critical), max(MU_RANGE[1], crit.mu_critical + 0.3))
    n = 11 if quick else 26
    try:
        branch = limit_cycle_branch(model, mu_range, harmonics=HARMONICS, n_points=n, speed=SPEED)
    except InputError as e:
        return Section("how_loud", title, (f"The limit cycles could not be followed for this model: {e}",))
    t_max = 2 * math.pi * Q0 / WAVELENGTH  # the steepest slope of the Fig. 4 run-out (eq. 11)
    try:
        slope = limit_cycle_branch_slope(model, (-t_max, t_max), mu=MU_FIG4, harmonics=HARMONICS, n_points=n,
                                         speed=SPEED)
    except InputError:  # no onset within the run-out's slopes at this friction
        slope = None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TensileContactWarning)
        run = simulate(model, mu=MU_FIG4, profile=SineRunOut(Q0, WAVELENGTH), speed=SPEED,
                       duration=0.05 if quick else 0.15, contact=Contact.nonlinear())
    env = response_envelope(run, DOF, highpass_freq=1000.0)
    # the limit-cycle amplitude at each instant's slope (0 where the quiet state is stable)
    inst = run["tan_theta"].values
    if slope is not None:
        tt = slope["tan_theta"].values
        amp = slope["amplitude"].sel(dof=DOF).values
        ok = slope["stable"].values.astype(bool)
        order = np.argsort(tt[ok])
        t_c = float(slope.attrs["hopf_mu"])
        cyc = np.where(inst > t_c, np.interp(inst, tt[ok][order], amp[ok][order]), 0.0)
    else:
        t_c, cyc = math.nan, np.zeros_like(inst)
    cycle = xr.DataArray(cyc, coords={"time": run["time"].values}, dims="time", name=f"{DOF}_limit_cycle",
                         attrs={"units": "m", "long_name": f"limit-cycle amplitude of {DOF} at the instant's slope"})
    save_dataset(branch, data / "limit_cycles_mu.nc")
    if slope is not None:
        save_dataset(slope, data / "limit_cycles_runout.nc")
    save_dataset(xr.Dataset({"envelope": env, "limit_cycle": cycle, "tan_theta": run["tan_theta"]}),
                 data / "fig4_nonlinear_envelope.nc")
    _save_fig(how_loud_plot(branch, slope, env, cycle, dof=DOF), figures, "how_loud")

    a = branch.attrs
    mu_c, f_c = float(a["hopf_mu"]), float(a["hopf_frequency_hz"])
    mu_hi = float(branch["mu"].values.max())
    mu_1 = 0.5 if mu_c < 0.45 else round(mu_c + 0.1, 2)  # the paper's case: mu = 0.5
    a_05, a_hi = _at(branch, "mu", mu_1), _at(branch, "mu", mu_hi)
    loss_05, loss_hi = (_at(branch, "mu", m, "contact_loss_fraction") for m in (mu_1, mu_hi))
    f_hi = _at(branch, "mu", mu_hi, "frequency_hz")
    kind = str(a["kind"])
    followed = math.isfinite(a_05) or math.isfinite(a_hi)
    if not followed and a["kind_from"] == "branch":
        kind = ""  # too short a branch to read the onset's type from
    onset = ("a soft (supercritical) onset: small stable cycles grow out of the quiet state beyond it"
             if kind == "supercritical" else
             "a hard (subcritical) onset: cycles exist below it and a quiet and a squealing state coexist"
             if kind == "subcritical" else "an onset whose type the branch does not settle")
    p1 = (f"On a flat disc (v = {SPEED:g} m/s, the model's own damping) squeal sets in at mu = {mu_c:.4f} "
          f"({f_c:.1f} Hz), {onset}"
          + (" (read from the branch: the contact law is piecewise linear about steady sliding, so the first "
             "Lyapunov coefficient is 0)." if a["kind_from"] == "branch" and kind else
             "." if not kind else f" (first Lyapunov coefficient {float(a['lyapunov_coefficient']):.3g}).")
          + (f" The squeal then settles on a limit cycle bounded by loss of contact: {DOF} swings {_um(a_05)} at "
             f"mu = {mu_1:g} with the contact open over {100 * loss_05:.0f} % of the period, and {_um(a_hi)} at "
             f"mu = {mu_hi:g} ({100 * loss_hi:.0f} %), while the frequency falls to {f_hi:.1f} Hz. "
             f"(Harmonic balance with H = {HARMONICS}; doubling H changes the amplitudes by "
             f"{float(a['harmonics_change']):.1e}.)" if followed else
             f" The continuation stopped after {branch.sizes['point']} cycles next to the onset "
             f"({str(a['stop_reason']).replace('_', ' ')}), so this model's squeal amplitude is not followed here."))
    # run-out: onset slope and the cycles against the flat disc at the same mu_e
    a_steep = _at(slope, "tan_theta", t_max) if slope is not None else math.nan
    a_flat_same = _at(branch, "mu", MU_FIG4 + t_max)
    same = abs(a_steep / a_flat_same - 1) if math.isfinite(a_steep) and math.isfinite(a_flat_same) else math.nan
    if math.isfinite(t_c) and -t_max <= t_c <= t_max:
        p2 = (f"With run-out at the paper's Fig. 4 friction mu = {MU_FIG4:g}, squeal sets in where the slope reaches "
              f"tan(theta) = {t_c:.4f} ({math.degrees(math.atan(t_c)):.2f} deg): mu + tan(theta) = "
              f"{MU_FIG4 + t_c:.4f} against the flat disc's {mu_c:.4f}. At the steepest slope of Fig. 4 "
              f"({t_max:.3f}) the cycle's {DOF} amplitude is {_um(a_steep)}")
        p2 += (f", and on a flat disc at mu = {MU_FIG4 + t_max:.3f} it is {_um(a_flat_same)}: "
               + (f"the limit cycles too depend on mu + tan(theta) alone (within {100 * same:.1f} %), as eq. (6) "
                  "says of the onset." if same < 0.02 else
                  f"they differ by {100 * same:.1f} %, so the slope is not simply added friction once the "
                  "contact opens.") if math.isfinite(same) else ".")
    else:
        p2 = (f"With run-out at the paper's Fig. 4 friction mu = {MU_FIG4:g} no slope within +-{t_max:.3f} starts "
              f"squeal in this model (its flat-disc threshold is mu = {mu_c:.4f}).")
    # the Fig. 4 transient with the nonlinear contact against the frozen-slope cycles: the envelope's
    # median where the slope makes the quiet state unstable (its short bursts are reported apart)
    cmax = float(cyc.max())
    unstable = cyc > 0
    emax = float(env.values.max())
    emed = float(np.median(env.values[unstable])) if unstable.any() else math.nan
    grow = float(np.max(run["growth_rate"].values))
    half = WAVELENGTH / SPEED / 2
    ratio = emed / float(np.median(cyc[unstable])) if unstable.any() else math.nan
    p3 = (f"The Fig. 4 run with this contact law (sine run-out, q0 = {Q0 * 1e3:g} mm, lambda = {WAVELENGTH * 1e3:g} mm,"
          f" mu = {MU_FIG4:g}, {float(run['time'].values[-1]):.3g} s): ")
    if math.isfinite(ratio):
        p3 += (f"while the slope makes the quiet state unstable the vibration envelope of {DOF} above 1 kHz has a "
               f"median of {_um(emed)}, {100 * ratio:.2g} % of the limit cycle of the instant's slope (median "
               f"{_um(float(np.median(cyc[unstable])))}); its peaks, {_um(emax)}, are short bursts. ")
        p3 += (f"Each unstable stage lasts about {1e3 * half * unstable.mean() * 2:.0f} ms and the linear growth rate "
               f"is at most {grow:.1f} 1/s (a factor {math.exp(grow * half):.1f} per stage), so the self-excited "
               "vibration has no time to settle on the cycle: with this run-out the steady limit cycle is an upper "
               "bound on the level, not what is heard." if ratio < 0.5 else
               "The vibration settles on the limit cycle within the unstable stages: the squeal is as loud as the "
               "steady state of the instant's slope.")
    else:
        p3 += "no slope of the run reaches a limit cycle."
    rows = tuple((float(m), float(f), float(x) * 1e6, float(lf), "yes" if s else "no")
                 for m, f, x, lf, s in list(zip(branch["mu"].values, branch["frequency_hz"].values,
                                                branch["amplitude"].sel(dof=DOF).values,
                                                branch["contact_loss_fraction"].values, branch["stable"].values,
                                                strict=True))[:: max(1, branch.sizes["point"] // 12)])
    every = max(1, branch.sizes["point"] // 12)
    table = Table("Limit cycles on a flat disc" + (f" (one point in {every} of the branch)" if every > 1 else ""),
                  ("mu", "frequency [Hz]", f"{DOF} amplitude [um]", "contact open [fraction]", "stable"), rows)
    numbers = {"hopf_mu": mu_c, "hopf_frequency_hz": f_c, "amplitude_mu05": a_05, "amplitude_mu_max": a_hi,
               "onset_tan_theta": t_c, "amplitude_steepest_slope": a_steep, "amplitude_flat_same_mu_e": a_flat_same,
               "fig4_envelope_max": emax, "fig4_envelope_median_unstable": emed, "fig4_cycle_max": cmax,
               "fig4_envelope_ratio": ratio}
    fig = FigureRef("how_loud", f"Top: limit-cycle amplitude of {DOF} over mu_e = mu + tan(theta), on a flat disc "
                    f"(over mu) and with run-out at mu = {MU_FIG4:g} (over tan(theta)); stable solid, unstable "
                    "dashed. Bottom: the Fig. 4 run with the nonlinear contact, its vibration envelope beside the "
                    "limit-cycle amplitude of each instant's slope.")
    return Section("how_loud", "How loud: squeal limit cycles", (p1, p2, p3), (), (table,), (fig,),
                   ("limit_cycles_mu.nc",) + (("limit_cycles_runout.nc",) if slope is not None else ())
                   + ("fig4_nonlinear_envelope.nc",), numbers=numbers)

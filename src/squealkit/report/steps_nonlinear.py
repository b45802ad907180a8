"""How loud: the squeal limit cycles at the paper's parameters, on a flat disc and with run-out.

Eigenvalues say where squeal can start; the limit cycle the growing vibration settles on says
how large it gets. This step follows the branch of cycles over friction on a flat disc and over
the run-out slope at the paper's Fig. 4 friction (harmonic balance with the transient's
nonlinear contact), and runs the Fig. 4 case with that contact law to put its vibration
envelope beside the limit-cycle amplitude of each instant's slope. The prose is written from
the numbers.
"""

from __future__ import annotations

import itertools
import math
import warnings
from pathlib import Path

import numpy as np
import xarray as xr

from .._operating_point import CYCLE_HARMONICS, CYCLE_MU_RANGE
from ..io import save_dataset
from ..models import FrictionModel
from .context import ReportContext, flat_onset
from .document import FigureRef, Section, Table
from .settings import ReportSettings

__all__ = []

# The operating point (paper §4: v = 0.02 m/s; Fig. 4: mu = 0.4, sine SRO q0 = 0.08 mm, lambda = 1 mm,
# max slope 0.503) comes from ReportSettings.
#: Reference velocity of the vibration velocity level [m/s] (ISO 1683: 1 nm/s).
V_REF = 1e-9
#: Contact open over less than this fraction of the period: the cycle is not bounded by loss of contact.
OPEN_MIN = 0.01
#: Friction range of the flat-disc branch, and the harmonics of every cycle.
MU_RANGE, HARMONICS = CYCLE_MU_RANGE, CYCLE_HARMONICS
#: The DOF whose amplitude the section reports (the pin's, as the paper's Fig. 3-4 accelerations).
DOF = "x1"


def _segments(ds: xr.Dataset, param: str) -> list[np.ndarray]:
    """The branch's points split into runs along which ``param`` goes one way, in continuation (arclength) order.

    A run ends at each fold the continuation found (the ``fold`` flags of
    :func:`~squealkit.nonlinear.limit_cycle_branch`; a branch saved without them: wherever ``param``
    turns back), and the fold point belongs to both runs it joins."""
    x = ds[param].values
    if "fold" in ds:
        cuts = [int(i) for i in np.flatnonzero(ds["fold"].values.astype(bool)) if 0 < i < x.size - 1]
    else:
        step = np.sign(np.diff(x))
        moves = np.flatnonzero(step)  # a vertical stretch (the start of a piecewise-linear law's branch) has none
        cuts = [int(j) for i, j in itertools.pairwise(moves) if step[i] != step[j]]
    ends = [0, *cuts, x.size - 1]
    return [np.arange(a, b + 1) for a, b in itertools.pairwise(ends) if b > a]


def _cycles_at(ds: xr.Dataset, param: str, value: float, var: str = "amplitude") -> list[tuple[float, bool]]:
    """Every cycle of the branch at ``param = value``: ``(var of DOF, stable)`` for each monotone run of the
    branch (:func:`_segments`) that brackets ``value``, interpolated between the two points of that run
    around it (in arclength order, never across a fold); stable when both points are. A fold sitting
    exactly at ``value`` is one cycle, not two."""
    x = ds[param].values
    y = ds[var].sel(dof=DOF).values if var == "amplitude" else ds[var].values
    stable = ds["stable"].values.astype(bool)
    found: dict[float, tuple[float, bool]] = {}
    for run in _segments(ds, param):
        for i, j in itertools.pairwise(run):
            if x[i] == x[j] or not min(x[i], x[j]) <= value <= max(x[i], x[j]):
                continue  # a vertical step (the onset of a piecewise-linear law) has no one cycle at value
            w = (value - x[i]) / (x[j] - x[i])
            found.setdefault(round(i + w, 9), (float(y[i] + w * (y[j] - y[i])), bool(stable[i] and stable[j])))
            break  # the first crossing of the run: a run is monotone in param up to the branch's sampling
    return list(found.values())


def _at(ds: xr.Dataset, param: str, value: float, var: str = "amplitude") -> float:
    """``var`` of ``DOF`` on the stable cycle at ``param = value`` (:func:`_cycles_at`): the first in arclength
    order (the one joined to the onset) where several are stable, nan where none is."""
    if value <= float(ds.attrs["hopf_mu"]) + 1e-9:  # the quiet state, not a cycle, up to the onset
        return math.nan
    stable = [v for v, s in _cycles_at(ds, param, value, var) if s]
    return stable[0] if stable else math.nan


def _stable_along(ds: xr.Dataset, param: str, values: np.ndarray, var: str = "amplitude") -> np.ndarray:
    """:func:`_at` at each of ``values`` (an array), nan where the branch has no stable cycle."""
    return np.array([_at(ds, param, float(v), var) for v in values])


def _fold_text(ds: xr.Dataset, param: str, mu_1: float) -> str:
    """What a branch that folds, or that has several cycles at ``mu_1``, does: in words, or ``""``."""
    text = ""
    cycles = _cycles_at(ds, param, mu_1)
    if len(cycles) > 1:
        each = ", ".join(f"{_um(a)} ({'stable' if s else 'unstable'})" for a, s in cycles)
        text += (f" At mu = {mu_1:g} this branch has {len(cycles)} limit cycles ({DOF}: {each}, in the order "
                 "followed from the onset); the amplitude quoted is the first stable one.")
    folds = [float(v) for v in ds["fold_mu"].values] if "fold_mu" in ds else []
    if folds:
        x = ds[param].values
        detail = str(ds.attrs.get("stop_detail", "")) or str(ds.attrs.get("stop_reason", "")).replace("_", " ")
        text += f" The branch folds at mu = {', '.join(f'{f:.4g}' for f in folds)}"
        # the largest mu reached is a fold: no cycle of this branch beyond it (else the branch goes on past it)
        text += (f": the cycles followed from the onset turn back there, so this branch has none beyond mu = "
                 f"{max(folds):.4g}" if max(folds) >= float(x.max()) else ", turning back and forth in mu")
        text += f"; the continuation went on to mu = {x[-1]:.4g} and stopped ({detail})."
    return text


def _um(x: float) -> str:
    return f"{x * 1e6:.3f} um" if math.isfinite(x) else "no cycle"


def _db(x: float) -> str:
    return f"{x:.1f} dB" if math.isfinite(x) else "no cycle"


def _with_level(ds: xr.Dataset) -> xr.Dataset:
    """``ds`` with ``velocity_level_db``: the vibration velocity level of ``DOF`` [dB re 1 nm/s] (ISO 1683)."""
    from ..nonlinear import sound_level

    v = sound_level(ds, radiation_factor=1.0, dof=DOF)["velocity_rms"]
    with np.errstate(divide="ignore"):  # a cycle of zero amplitude (the onset itself) has no level: nan
        level = np.where(v.values > 0, 20.0 * np.log10(v.values / V_REF), np.nan)
    return ds.assign(velocity_level_db=(v.dims, level, {
        "units": "dB", "long_name": f"vibration velocity level of {DOF}, re 1 nm/s (ISO 1683)"}))


def _open_text(loss: float) -> str:
    """What the contact does over a cycle, and whether that is what bounds it."""
    if not math.isfinite(loss):
        return "no cycle there"
    if loss < OPEN_MIN:
        return (f"the contact open over {100 * loss:.1f} % of the period: loss of contact does not bound this "
                "cycle")
    return f"the contact open over {100 * loss:.0f} % of the period: bounded by loss of contact"


def _settle_text(low: tuple[float, float, float, float], high: tuple[float, float, float, float],
                 f_high: float) -> str:
    """The limit cycles at two frictions, each ``(mu, amplitude [m], contact-open fraction, level [dB])``, in
    words true to each: loss of contact is named as the bound only where the contact opens."""
    (mu_1, a_1, open_1, l_1), (mu_2, a_2, open_2, l_2) = low, high
    return (f"The squeal then settles on a limit cycle: {DOF} swings {_um(a_1)} at mu = {mu_1:g} ({_open_text(open_1)})"
            f" and {_um(a_2)} at mu = {mu_2:.4g} ({_open_text(open_2)}), while the frequency moves to {f_high:.1f} Hz. "
            f"As a vibration velocity level of {DOF} (dB re 1 nm/s, ISO 1683; the model has no acoustics): "
            f"{_db(l_1)} at mu = {mu_1:g} and {_db(l_2)} at mu = {mu_2:.4g}.")


def nonlinear_step(model: FrictionModel, figures: Path, data: Path, *, quick: bool = False,
                   settings: ReportSettings | None = None, context: ReportContext | None = None) -> Section:
    """The section "How loud": limit cycles over friction and run-out slope, beside the Fig. 4 transient."""
    from ..stability.critical import UnrealisticFrictionWarning

    with warnings.catch_warnings():  # the critical-friction section already says so
        warnings.simplefilter("ignore", UnrealisticFrictionWarning)
        return _nonlinear_step(model, figures, data, quick=quick, settings=settings or ReportSettings.paper(),
                               context=context)


def _nonlinear_step(model: FrictionModel, figures: Path, data: Path, *, quick: bool,
                    settings: ReportSettings, context: ReportContext | None) -> Section:
    from .._validation import InputError
    from ..nonlinear import limit_cycle_branch, limit_cycle_branch_slope
    from ..plotting.limitcycle import how_loud_level_plot, how_loud_plot
    from ..transient import Contact, SineRunOut, TensileContactWarning, simulate
    from ..transient.simulate import response_envelope
    from .steps_stability import _save_fig

    title = "How loud: squeal limit cycles"
    mu4, speed = settings.mu_transient, settings.speed
    q0, wavelength = settings.sro_amplitude, settings.sro_wavelength
    fig4 = "the paper's Fig. 4" if settings.is_paper else "the report's Fig. 4"
    if DOF not in model.dof_names:
        return Section("how_loud", title, (f"This model has no DOF {DOF!r} (the pin's); the limit-cycle section is "
                                           "written for the pin-on-disc model.",))
    crit = flat_onset(model, context)  # up to mu = 2 (critical_friction's mu_max)
    if crit.status != "onset":
        why = {"stable_in_range": "stays stable for every mu up to 2",
               "unstable_at_start": "is already unstable without friction (mu = 0)",
               }.get(crit.status, "has an onset that could not be decided (indeterminate) up to mu = 2")
        return Section("how_loud", title, (f"On a flat disc the damped model {why}: there is no squeal onset "
                                           "to follow a limit cycle from.",))
    # the paper's range, widened for a model whose onset lies outside it
    mu_range = (min(MU_RANGE[0], 0.9 * crit.mu_critical), max(MU_RANGE[1], crit.mu_critical + 0.3))
    n = 11 if quick else 26
    try:
        branch = limit_cycle_branch(model, mu_range, harmonics=HARMONICS, n_points=n, speed=speed, onset=crit)
    except InputError as e:
        return Section("how_loud", title, (f"The limit cycles could not be followed for this model: {e}",))
    t_max = 2 * math.pi * q0 / wavelength  # the steepest slope of the Fig. 4 run-out (eq. 11)
    try:
        slope = limit_cycle_branch_slope(model, (-t_max, t_max), mu=mu4, harmonics=HARMONICS, n_points=n,
                                         speed=speed)
    except InputError:  # no onset within the run-out's slopes at this friction
        slope = None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TensileContactWarning)
        run = simulate(model, mu=mu4, profile=SineRunOut(q0, wavelength), speed=speed,
                       duration=(1.0 if quick else 3.0) * wavelength / speed, contact=Contact.nonlinear())
    env = response_envelope(run, DOF, highpass_freq=1000.0)
    # the limit-cycle amplitude at each instant's slope (0 where the quiet state is stable)
    inst = run["tan_theta"].values
    if slope is not None:
        t_c = float(slope.attrs["hopf_mu"])
        # along the branch, never across a fold; beyond the last cycle followed the amplitude is not known: nan
        cyc = np.where(inst > t_c, _stable_along(slope, "tan_theta", inst), 0.0)
    else:
        t_c, cyc = math.nan, np.zeros_like(inst)
    cycle = xr.DataArray(cyc, coords={"time": run["time"].values}, dims="time", name=f"{DOF}_limit_cycle",
                         attrs={"units": "m", "long_name": f"limit-cycle amplitude of {DOF} at the instant's slope"})
    branch = _with_level(branch)
    if slope is not None:
        slope = _with_level(slope)
    save_dataset(branch, data / "limit_cycles_mu.nc")
    if slope is not None:
        save_dataset(slope, data / "limit_cycles_runout.nc")
    save_dataset(xr.Dataset({"envelope": env, "limit_cycle": cycle, "tan_theta": run["tan_theta"]}),
                 data / "fig4_nonlinear_envelope.nc")
    _save_fig(how_loud_plot(branch, slope, env, cycle, dof=DOF), figures, "how_loud")
    _save_fig(how_loud_level_plot(branch, slope, dof=DOF), figures, "how_loud_level")

    a = branch.attrs
    mu_c, f_c = float(a["hopf_mu"]), float(a["hopf_frequency_hz"])
    # the largest mu the branch reaches: its end, or the fold where it turns back (said so by _fold_text)
    mu_hi = float(branch["mu"].values.max())
    beyond = [float(f) for f in branch["fold_mu"].values if f > mu_c + 1e-9]
    mu_1 = settings.mu_cycle
    a_05, a_hi = _at(branch, "mu", mu_1), _at(branch, "mu", mu_hi)
    l_05, l_hi = (_at(branch, "mu", m, "velocity_level_db") for m in (mu_1, mu_hi))
    loss_05, loss_hi = (_at(branch, "mu", m, "contact_loss_fraction") for m in (mu_1, mu_hi))
    f_hi = _at(branch, "mu", mu_hi, "frequency_hz")
    kind = str(a["hopf_kind"])
    followed = math.isfinite(a_05) or math.isfinite(a_hi)
    if not followed and a["hopf_kind_from"] == "branch":
        kind = ""  # too short a branch to read the onset's type from
    onset = ("a soft (supercritical) onset: small stable cycles grow out of the quiet state beyond it"
             if kind == "supercritical" else
             "a hard (subcritical) onset: cycles exist below it and a quiet and a squealing state coexist"
             if kind == "subcritical" else "an onset whose type the branch does not settle")
    p1 = (f"On a flat disc (v = {speed:g} m/s, the model's own damping) squeal sets in at mu = {mu_c:.4f} "
          f"({f_c:.1f} Hz), {onset}"
          + (" (read from the branch: the contact law is piecewise linear about steady sliding, so the first "
             "Lyapunov coefficient is 0)." if a["hopf_kind_from"] == "branch" and kind else
             "." if not kind else f" (first Lyapunov coefficient {float(a['lyapunov_coefficient']):.3g}).")
          + (" " + _settle_text((mu_1, a_05, loss_05, l_05), (mu_hi, a_hi, loss_hi, l_hi), f_hi)
             + _fold_text(branch, "mu", mu_1)
             + f" (Harmonic balance with H = {HARMONICS}; doubling H changes the amplitudes by "
             f"{float(a['harmonics_change']):.1e}.)" if followed else
             f" The continuation stopped after {branch.sizes['point']} cycles next to the onset "
             f"({str(a['stop_reason']).replace('_', ' ')}), so this model's squeal amplitude is not followed here."))
    # run-out: onset slope and the cycles against the flat disc at the same mu_e
    a_steep = _at(slope, "tan_theta", t_max) if slope is not None else math.nan
    a_flat_same = _at(branch, "mu", mu4 + t_max)
    same = abs(a_steep / a_flat_same - 1) if math.isfinite(a_steep) and math.isfinite(a_flat_same) else math.nan
    if math.isfinite(t_c) and -t_max <= t_c <= t_max:
        p2 = (f"With run-out at {fig4} friction mu = {mu4:g}, squeal sets in where the slope reaches "
              f"tan(theta) = {t_c:.4f} ({math.degrees(math.atan(t_c)):.2f} deg): mu + tan(theta) = "
              f"{mu4 + t_c:.4f} against the flat disc's {mu_c:.4f}. ")
        if not math.isfinite(a_steep):  # the branch over the slope did not get there: say how far it got
            reached = float(np.max(slope["tan_theta"].values)) if slope is not None else math.nan
            why = str(slope.attrs.get("stop_reason", "")).replace("_", " ") if slope is not None else ""
            p2 += (f"The cycles over the slope were followed only up to tan(theta) = {reached:.4f}"
                   + (f" ({why})" if why else "") + f", short of the steepest slope of {fig4} ({t_max:.3f}): the "
                   "amplitude there is not computed." if math.isfinite(reached) else
                   f"The cycles over the slope were not followed, so the amplitude at the steepest slope of "
                   f"{fig4} ({t_max:.3f}) is not computed.")
    else:
        p2 = ""
    if p2 and math.isfinite(a_steep):
        p2 += f"At the steepest slope of {fig4} ({t_max:.3f}) the cycle's {DOF} amplitude is {_um(a_steep)}"
        p2 += (f", and on a flat disc at mu = {mu4 + t_max:.3f} it is {_um(a_flat_same)}: "
               + (f"the limit cycles too depend on mu + tan(theta) alone (within {100 * same:.1f} %), as eq. (6) "
                  "says of the onset." if same < 0.02 else
                  f"they differ by {100 * same:.1f} %, so the slope is not simply added friction once the "
                  "contact opens.") if math.isfinite(same) else ".")
    elif not p2:
        p2 = (f"With run-out at {fig4} friction mu = {mu4:g} no slope within +-{t_max:.3f} starts "
              f"squeal in this model (its flat-disc threshold is mu = {mu_c:.4f}).")
    # the Fig. 4 transient with the nonlinear contact against the frozen-slope cycles: the envelope's
    # median where the slope makes the quiet state unstable (its short bursts are reported apart)
    unknown = np.isnan(cyc)  # slopes beyond the branch's end
    cmax = float(np.nanmax(cyc)) if not unknown.all() else math.nan
    unstable = cyc > 0
    emax = float(env.values.max())
    emed = float(np.median(env.values[unstable])) if unstable.any() else math.nan
    grow = float(np.max(run["growth_rate"].values))
    half = wavelength / speed / 2
    ratio = emed / float(np.median(cyc[unstable])) if unstable.any() else math.nan
    p3 = (f"The Fig. 4 run with this contact law (sine run-out, q0 = {q0 * 1e3:g} mm, lambda = {wavelength * 1e3:g} mm,"
          f" mu = {mu4:g}, {float(run['time'].values[-1]):.3g} s): ")
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
    if unknown.any():
        p3 += (f" The limit cycle is not known at {100 * unknown.mean():.0f} % of the run's instants, whose slopes lie "
               "beyond the last cycle followed; the figure leaves them out.")
    every = max(1, branch.sizes["point"] // 12)
    rows = tuple((float(m), float(f), float(x) * 1e6, float(db), float(lf), "yes" if s else "no")
                 for m, f, x, db, lf, s in list(zip(branch["mu"].values, branch["frequency_hz"].values,
                                                    branch["amplitude"].sel(dof=DOF).values,
                                                    branch["velocity_level_db"].values,
                                                    branch["contact_loss_fraction"].values, branch["stable"].values,
                                                    strict=True))[::every])
    table = Table("Limit cycles on a flat disc" + (f" (one point in {every} of the branch)" if every > 1 else ""),
                  ("mu", "frequency [Hz]", f"{DOF} amplitude [um]", f"{DOF} velocity level [dB re 1 nm/s]",
                   "contact open [fraction]", "stable"), rows)
    numbers = {"hopf_mu": mu_c, "hopf_frequency_hz": f_c, "amplitude_mu05": a_05, "amplitude_mu_max": a_hi,
               "level_db_mu05": l_05, "level_db_mu_max": l_hi, "contact_open_mu05": loss_05,
               "contact_open_mu_max": loss_hi, "mu_cycle": mu_1,
               "onset_tan_theta": t_c, "amplitude_steepest_slope": a_steep, "amplitude_flat_same_mu_e": a_flat_same,
               "fig4_envelope_max": emax, "fig4_envelope_median_unstable": emed, "fig4_cycle_max": cmax,
               "fig4_envelope_ratio": ratio, "fold_mu": beyond[0] if beyond else math.nan,
               "cycles_at_mu_cycle": len(_cycles_at(branch, "mu", mu_1))}
    fig = FigureRef("how_loud", f"Top: limit-cycle amplitude of {DOF} over mu_e = mu + tan(theta), on a flat disc "
                    f"(over mu) and with run-out at mu = {mu4:g} (over tan(theta)); stable solid, unstable "
                    "dashed. Bottom: the Fig. 4 run with the nonlinear contact, its vibration envelope beside the "
                    "limit-cycle amplitude of each instant's slope.")
    fig_db = FigureRef("how_loud_level", f"Limit-cycle level: vibration velocity level of {DOF} [dB re 1 nm/s] over "
                       "mu_e = mu + tan(theta), on a flat disc and with run-out (stable solid, unstable dashed)")
    return Section("how_loud", "How loud: squeal limit cycles", (p1, p2, p3), (), (table,), (fig, fig_db),
                   ("limit_cycles_mu.nc",) + (("limit_cycles_runout.nc",) if slope is not None else ())
                   + ("fig4_nonlinear_envelope.nc",), numbers=numbers)

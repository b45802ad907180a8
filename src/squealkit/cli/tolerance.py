"""``squealkit tolerance``: the run-out a disc may have and stay quiet."""

from __future__ import annotations

import math

import click

from ._options import (
    RUNOUT_WAVELENGTH,
    NumberOrRange,
    build_model_from_options,
    check_output_suffix,
    damping_option,
    emit_json,
    fe_kwargs_from_options,
    fe_options,
    model_options,
    note_damping,
    output_options,
    refuse_options,
)

#: Slopes are searched up to this incline [deg] (runout_tolerance's slope_max).
SLOPE_MAX_DEG = 80.0
#: The steepest run-out slope the paper considers: its Fig. 4 micro run-out, q0 = 0.08 mm over
#: lambda = 1 mm, "may even reach 26.7 deg" (§4, eq. 11).
PAPER_STEEPEST_DEG = math.degrees(math.atan(2 * math.pi * 0.08e-3 / 1e-3))
#: The largest run-out amplitude the paper considers (Fig. 4: q0 = 0.08 mm) [m].
PAPER_Q0_MAX = 0.08e-3


#: Why a tolerance is flagged, by kind (see :func:`caveats`).
CAVEAT_REASONS = {
    "slope": (f"steeper than any run-out slope the paper considers (Fig. 4's micro run-out: "
              f"{PAPER_STEEPEST_DEG:.1f} deg); the model's point contact at a fixed pin incline (paper §2) does not "
              "describe a surface that steep: read it as 'the slope does not limit here', not as a tolerance"),
    "amplitude": (f"above the largest run-out the paper considers (Fig. 4: {PAPER_Q0_MAX * 1e6:.0f} um), where the "
                  "linear contact is already tensile much of the time ('squealkit simulate' warns): the pin would "
                  "lift off, which this linear stability model does not describe; contact, not stability, limits "
                  "the amplitude there"),
}


def caveats(tol) -> list[dict[str, str]]:
    """Why a tolerance should not go on a drawing as it is: each ``{"kind", "text"}``.

    ``slope``: stable slopes steeper than any the paper considers (its Fig. 4 micro run-out,
    26.7 deg): the point contact with a fixed pin incline (§2, assumptions 2-3) is not a model
    of a surface that steep, so the number says "the slope does not limit here", not "this
    much is fine". ``amplitude``: q0 above the paper's 80 um (Fig. 4), at which the pin's
    linear contact is already tensile much of the time ('simulate' warns): the stability
    model, linear about steady contact, says nothing about a pin that lifts off.
    """
    out = []
    if math.isfinite(tol.tan_theta_max) and tol.theta_max_deg > PAPER_STEEPEST_DEG:
        out.append({"kind": "slope", "text": f"theta_max {tol.theta_max_deg:.1f} deg is {CAVEAT_REASONS['slope']}"})
    if tol.q0_max is not None and math.isfinite(tol.q0_max) and tol.q0_max > PAPER_Q0_MAX:
        out.append({"kind": "amplitude",
                    "text": f"q0_max {tol.q0_max * 1e6:.0f} um is {CAVEAT_REASONS['amplitude']}"})
    return out


def _state_text(tol) -> str:
    """The row's words where the numbers alone would be inf or 0."""
    if not tol.stable_on_flat_disc:
        return "unstable on a flat disc: no run-out is tolerated"
    if math.isinf(tol.tan_theta_max):
        return f"stable at every slope searched (up to {SLOPE_MAX_DEG:g} deg): the run-out slope does not limit"
    return ""


@click.command()
@model_options
@click.option("--mu", "mu_spec", required=True, type=NumberOrRange(), help="Friction coefficient(s).")
@click.option("--wavelength", type=RUNOUT_WAVELENGTH, default=None,
              help="Run-out wavelength lambda [m], or with a unit: '1 mm'; gives the amplitude tolerance q0 "
              "(eq. 11).")
@damping_option
@fe_options()
@click.option("--mu-max", default=2.0, show_default=True, type=float, help="FE models: search friction up to this.")
@output_options()
def tolerance(preset, config, sets, mu_spec, wavelength, damped, rpm_spec, band_spec, method, n_modes, mu_max,
              as_json, out_path, plot_path) -> None:
    """Run-out tolerance: the largest SRO slope and amplitude that stay stable.

    The disc's run-out slope tan(theta) adds to friction (mu_e = mu + tan theta,
    eq. 6). For a given mu this finds the largest slope s such that every slope
    in [-s, s] is stable, and with --wavelength the largest amplitude of a sine
    run-out q0 = s * lambda / (2 pi) (eq. 11): a number for the drawing.

    \b
    Examples:
      squealkit tolerance --mu 0.3 --wavelength 1e-3
      squealkit tolerance --mu 0:0.44:12 --wavelength 0.05 --json
      squealkit tolerance --mu 0:0.44:12 --wavelength 1e-3 --out tol.nc --plot tol.png

    Slopes are searched up to 80 deg. A row says in words when the disc is
    unstable already flat, or stable at every slope searched, and flags a
    tolerance the model cannot vouch for: a slope steeper than the paper's
    steepest (26.7 deg, Fig. 4) or an amplitude above its 80 um run-out.

    \b
    --json keys (one mu): mu, tan_theta_max, theta_max_deg, limiting_side
    (rising | falling | flat), wavelength [m], q0_max [m], stable_on_flat_disc,
    damped, caveats (list of {kind: slope | amplitude, text}). A range of mu
    gives a list "tolerances" of those objects. --out writes them over mu as
    netCDF or zarr; --plot draws the tolerance against mu.

    \b
    FE models (model = "fe" in --config), one --mu, at each disc speed --rpm:
    tan_theta_max = mu_crit(rpm) - mu (rising slope; mu_e = mu + tan theta), and
    with --wavelength q0_max. --json keys: rpm, mu, mu_critical, tan_theta_max,
    theta_max_deg, q0_max (or null), method.
      squealkit tolerance --config brake.toml --mu 0.05 --rpm 60:240:4 --wavelength 0.05
    """
    from .._validation import InputError, parse_range
    from ..stability import runout_tolerance

    check_output_suffix(out_path, (".nc", ".zarr"), "--out")
    check_output_suffix(plot_path, (".png", ".svg", ".pdf"), "--plot")
    model = build_model_from_options(preset, config, sets, allow_fe=True)
    note_damping(model, damped)
    mus = parse_range("--mu", mu_spec)
    fe = fe_kwargs_from_options(model, rpm_spec, band_spec, method, n_modes)
    if not fe:
        refuse_options(("mu_max",), 'applies to FE models only (model = "fe" in the --config file)')
    else:
        refuse_options(("damped",), "applies to the small models only (an FE model's damping is its D1 matrix)")
    if fe:
        if out_path is not None or plot_path is not None:
            raise InputError("--out and --plot are for the small models; for FE models use 'squealkit stability "
                             "--config ... --out/--plot'.")
        return _tolerance_fe(model, fe, mus, wavelength, mu_max, as_json)
    slope_max = math.tan(math.radians(SLOPE_MAX_DEG))
    results = [runout_tolerance(model, float(m), wavelength=wavelength, damped=damped, slope_max=slope_max)
               for m in mus]
    if out_path is not None or plot_path is not None:
        _write(_tolerance_dataset(model, results), out_path, plot_path)
    dicts = [{**r.to_dict(), "caveats": caveats(r)} for r in results]
    if as_json:
        emit_json(dicts[0] if len(results) == 1 else {"tolerances": dicts})
        return
    head = f"{'mu':>8} {'tan(theta)max':>14} {'theta_max [deg]':>16} {'side':>8}"
    if wavelength is not None:
        head += f" {'q0_max [um]':>12}"
    click.echo(head + "  note")
    kinds: list[str] = []
    for r, d in zip(results, dicts, strict=True):
        words = _state_text(r)
        if words and r.stable_on_flat_disc:  # stable at every slope searched: no number to show
            line = f"{r.mu:8.4f} {'-':>14} {'-':>16} {'-':>8}" + (f" {'-':>12}" if wavelength is not None else "")
        else:
            line = f"{r.mu:8.4f} {r.tan_theta_max:14.6f} {r.theta_max_deg:16.4f} {r.limiting_side:>8}"
            if r.q0_max is not None:
                line += f" {r.q0_max * 1e6:12.4f}"
        marks = []
        for c in d["caveats"]:
            if c["kind"] not in kinds:
                kinds.append(c["kind"])
            marks.append(f"[{kinds.index(c['kind']) + 1}] {c['kind']}")
        click.echo((line + "  " + "; ".join([words] * bool(words) + marks)).rstrip())
    for i, kind in enumerate(kinds):
        click.echo(f"[{i + 1}] {kind}: {CAVEAT_REASONS[kind]}")
    for label, path in (("dataset", out_path), ("figure", plot_path)):
        if path is not None:
            click.echo(f"wrote {label}: {path}")


def _tolerance_dataset(model, results):
    """The tolerances over mu as a labelled Dataset (what --out writes and --plot draws)."""
    import numpy as np
    import xarray as xr

    from .. import __version__

    r0 = results[0]
    q0 = np.array([np.nan if r.q0_max is None else r.q0_max for r in results])
    ds = xr.Dataset(
        {
            "tan_theta_max": ("mu", [r.tan_theta_max for r in results],
                              {"units": "1", "long_name": "largest stable run-out slope (inf: every slope searched)"}),
            "theta_max_deg": ("mu", [r.theta_max_deg for r in results], {"units": "deg"}),
            "limiting_side": ("mu", np.array([r.limiting_side for r in results], dtype=str),
                              {"long_name": "run-out stage that sets the limit (flat: unstable on a flat disc)"}),
            "stable_on_flat_disc": ("mu", np.array([r.stable_on_flat_disc for r in results], dtype=np.int8)),
            "q0_max": ("mu", q0, {"units": "m", "long_name": "largest sine run-out amplitude (eq. 11)"}),
        },
        coords={"mu": ("mu", [r.mu for r in results], {"units": "1"})},
        attrs={"model": model.to_json(), "damped": int(r0.damped), "slope_max_deg": SLOPE_MAX_DEG,
               "squealkit_version": __version__},
    )
    if r0.wavelength is not None:
        ds.attrs["wavelength"] = r0.wavelength
    else:
        ds = ds.drop_vars("q0_max")
    return ds


def _write(ds, out_path, plot_path) -> None:
    if out_path is not None:
        from ..io import save_dataset

        save_dataset(ds, out_path)
    if plot_path is not None:
        from ..io import save_figure
        from ..plotting.stability import tolerance_plot

        save_figure(tolerance_plot(ds), plot_path)


def _tolerance_fe(model, fe, mus, wavelength, mu_max, as_json) -> None:
    """Run-out tolerance of an FE model at each disc speed: mu_e = mu + tan(theta) up to mu_crit."""
    import math

    import numpy as np

    from .._validation import InputError, validate_positive
    from ..stability import fe_critical_friction

    if mus.size != 1:
        raise InputError("For FE models --mu takes one value.")
    mu = float(mus[0])
    ds = fe_critical_friction(model, fe["rpm"], mu_max=mu_max, mu_operating=mu, method=fe["method"],
                              band=fe["band"], n_modes=fe["n_modes"])
    tmax = ds.tan_theta_max.values
    q0 = None
    if wavelength is not None:
        q0 = np.where(tmax > 0, tmax * validate_positive("--wavelength", wavelength) / (2 * math.pi), 0.0)
    out = {"rpm": ds.rpm.values, "mu": mu, "mu_critical": ds.mu_critical.values, "tan_theta_max": tmax,
           "theta_max_deg": ds.theta_max_deg.values, "q0_max": q0, "wavelength": wavelength,
           "method": ds.attrs["method"]}
    if as_json:
        emit_json(out)
        return
    click.echo(f"{'rpm':>10} {'mu_crit':>10} {'tan(theta)max':>14} {'theta_max [deg]':>16}"
               + (f" {'q0_max [um]':>12}" if q0 is not None else ""))
    for i, r in enumerate(out["rpm"]):
        line = f"{r:10.4g} {out['mu_critical'][i]:10.6f} {tmax[i]:14.6f} {out['theta_max_deg'][i]:16.4f}"
        if q0 is not None:
            line += f" {q0[i] * 1e6:12.4f}"
        click.echo(line)

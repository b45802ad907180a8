"""``squealkit synth``: write a synthetic rig recording to try ``analyze`` without data."""

from __future__ import annotations

from pathlib import Path

import click

from ._options import check_output_suffix, emit_json


@click.command()
@click.argument("out", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--seed", type=int, default=1, show_default=True, help="Random seed (run-out phases, noise).")
@click.option("--duration", type=float, default=2.0, show_default=True, help="Length [s].")
@click.option("--fs", type=float, default=40000.0, show_default=True, help="Sample rate [Hz].")
@click.option("--rpm", type=float, default=900.0, show_default=True, help="Disc speed [rpm] (at the start).")
@click.option("--rpm-end", type=float, default=None,
              help="Disc speed at the end [rpm]: a decelerating stop (linear); default constant speed.")
@click.option("--probe-offset-deg", type=float, default=0.0, show_default=True,
              help="The probe sits this far upstream of the pin [deg].")
@click.option("--polarity", type=click.Choice(["1", "-1"]), default="1", show_default=True,
              help="-1: the probe reads the run-out reversed.")
@click.option("--acoustic-delay", type=float, default=0.0, show_default=True, help="Pin to microphone delay [s].")
@click.option("--tacho-ppr", type=int, default=1, show_default=True, help="Tacho pulses per revolution.")
@click.option("--radius", type=float, default=0.05, show_default=True, help="Probe radius [m].")
@click.option("--freq", type=float, default=2388.0, show_default=True, help="Squeal frequency [Hz].")
@click.option("--level-dba", type=float, default=90.0, show_default=True, help="Saturated squeal level [dB(A)].")
@click.option("--squeal-on", type=click.Choice(["rising", "falling", "none"]), default="rising",
              show_default=True, help="Run-out stage on which the squeal grows.")
@click.option("--json", "as_json", is_flag=True, help="Print the truth as JSON.")
def synth(out: Path, seed: int, duration: float, fs: float, rpm: float, rpm_end: float | None,
          probe_offset_deg: float, polarity: str, acoustic_delay: float, tacho_ppr: int, radius: float, freq: float,
          level_dba: float, squeal_on: str, as_json: bool) -> None:
    """Write a SYNTHETIC pin-on-disc recording (mic [Pa], displacement [m]) with known truth.

    OUT ends in .nc (netCDF, truth in attributes) or .csv (time column + channels).

    \b
    Example:
      squealkit synth rec.nc --seed 1 --duration 2
      squealkit analyze rec.nc --mic mic --displacement displacement --rpm 900 --radius 0.05
    """
    import numpy as np

    from ..io import save_dataset, write_text
    from ..measurement import synthetic_recording

    check_output_suffix(out, (".nc", ".csv"), "OUT")
    rec = synthetic_recording(duration=duration, fs=fs, rpm=rpm, radius=radius, freq=freq, level_dba=level_dba,
                              squeal_on=squeal_on, seed=seed, rpm_end=rpm_end, probe_offset_deg=probe_offset_deg,
                              polarity=int(polarity), acoustic_delay=acoustic_delay, tacho_ppr=tacho_ppr)
    if out.suffix.lower() == ".nc":
        save_dataset(rec, out)
    else:
        cols = np.column_stack([rec["time"].values, rec["mic"].values, rec["displacement"].values,
                                rec["tacho"].values])
        lines = ["time [s],mic [Pa],displacement [m],tacho [V]"]
        lines += [f"{t:.8g},{p:.8g},{q:.8g},{v:.3g}" for t, p, q, v in cols]
        write_text(out, "\n".join(lines) + "\n")
    truth = {k.removeprefix("truth_"): v for k, v in rec.attrs.items() if k.startswith("truth_")}
    if as_json:
        emit_json({"out": str(out), "synthetic": True, "truth": truth})
    else:
        if len(truth["event_starts_s"]) == 0:
            what = "no squeal"
        else:
            what = (f"squeal {truth['frequency_hz']:.1f} Hz, {len(truth['event_starts_s'])} events, "
                    f"rising fraction {truth['rising_fraction']:.3f}")
        click.echo(f"wrote {out} (SYNTHETIC, {duration:g} s at {fs:g} Hz; truth: {what})")

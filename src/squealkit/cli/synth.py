"""``squealkit synth``: write a synthetic rig recording to try ``analyze`` without data."""

from __future__ import annotations

from pathlib import Path

import click

from .._validation import InputError
from ._options import (
    PENDING_NOTES,
    PROBE_RADIUS,
    NumberOrRange,
    check_output_suffix,
    deprecated_alias,
    emit_json,
    refuse_options,
)


@click.command()
@click.argument("out_arg", metavar="[OUT]", required=False, type=click.Path(path_type=Path))
@click.option("--out", "out_file", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="The recording to write: .nc, .csv, .wav, .tdms, .mf4 or .uff.")
@click.option("--out-dir", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="With --campaign: the folder to write (matrix.csv, recordings/, truth.json).")
@click.option("--seed", type=int, default=1, show_default=True, help="Random seed (run-out phases, noise).")
@click.option("--duration", type=float, default=2.0, show_default=True, help="Length [s].")
@click.option("--fs", type=float, default=40000.0, show_default=True, help="Sample rate [Hz].")
@click.option("--rpm", type=NumberOrRange(single=True, needs="one disc speed (--rpm-end makes a stop)"), default=900.0,
              show_default=True, help="Disc speed [rpm] (at the start).")
@click.option("--rpm-end", type=float, default=None,
              help="Disc speed at the end [rpm]: a decelerating stop (linear); default constant speed.")
@click.option("--probe-offset-deg", type=float, default=0.0, show_default=True,
              help="The probe sits this far upstream of the pin [deg].")
@click.option("--polarity", type=click.Choice(["1", "-1"]), default="1", show_default=True,
              help="-1: the probe reads the run-out reversed.")
@click.option("--acoustic-delay", type=float, default=0.0, show_default=True, help="Pin to microphone delay [s].")
@click.option("--pulses-per-rev", "tacho_ppr", type=int, default=1, show_default=True,
              help="Tacho pulses per revolution.")
@deprecated_alias("--tacho-ppr", "--pulses-per-rev", "tacho_ppr", type=int)
@click.option("--radius", type=PROBE_RADIUS, default=0.05, show_default=True,
              help="Probe radius [m], or with a unit: '50 mm'.")
@click.option("--freq", type=float, default=2388.0, show_default=True, help="Squeal frequency [Hz].")
@click.option("--level-dba", type=float, default=90.0, show_default=True, help="Saturated squeal level [dB(A)].")
@click.option("--squeal-on", type=click.Choice(["rising", "falling", "none"]), default="rising",
              show_default=True, help="Run-out stage on which the squeal grows.")
@click.option("--campaign", "n_campaign", type=int, default=None, metavar="N",
              help="Write a SYNTHETIC J2521-like campaign of N applications into the folder --out-dir instead "
              "(matrix.csv, recordings/, truth.json).")
@click.option("--format", "fmt", type=click.Choice([".nc", ".mf4", ".tdms", ".uff", ".wav", ".csv"]), default=".nc",
              show_default=True, help="Recording format of a --campaign.")
@click.option("--condition-channels", is_flag=True,
              help="A --campaign records pressure [bar] and temperature [C] as channels instead of matrix columns.")
@click.option("--json", "as_json", is_flag=True, help="Print the truth as JSON.")
def synth(out_arg: Path | None, out_file: Path | None, out_dir: Path | None, seed: int, duration: float, fs: float,
          rpm: float, rpm_end: float | None,
          probe_offset_deg: float, polarity: str, acoustic_delay: float, tacho_ppr: int, radius: float, freq: float,
          level_dba: float, squeal_on: str, n_campaign: int | None, fmt: str, condition_channels: bool,
          as_json: bool) -> None:
    """Write a SYNTHETIC pin-on-disc recording (mic [Pa], displacement [m]) with known truth.

    --out ends in .nc (netCDF, truth in attributes), .csv, .wav (32-bit float), .tdms, .mf4
    (ASAM MDF4) or .uff (UFF 58): every format `analyze` reads. All but UFF 58 are
    generated and written block by block (memory bounded whatever --duration).
    --freq (and its 2 harmonics) must lie below fs/2: a squeal the sampling
    cannot represent is refused, not aliased. Channels: mic [Pa],
    displacement [m], tacho [V] (5 V pulses, the first rising edge is the disc's angle 0).

    \b
    Example:
      squealkit synth --out rec.nc --seed 1 --duration 2
      squealkit analyze rec.nc --mic mic --displacement displacement --rpm 900 --radius 0.05
      squealkit synth --out stop.mf4 --rpm 900 --rpm-end 300
      squealkit analyze stop.mf4 --mic mic --displacement displacement --tacho tacho --radius 0.05
      squealkit synth --campaign 12 --out-dir camp

    The output as an argument (``squealkit synth rec.nc``) is deprecated: --out FILE, or
    --out-dir FOLDER with --campaign.
    """
    from ..measurement.formats.writers import FORMATS, write_recording_blocks
    from ..measurement.synthetic import synthetic_attrs, synthetic_source

    out = _output(out_arg, out_file, out_dir, campaign=n_campaign is not None)
    if n_campaign is not None:
        from ..campaign import synthetic_campaign

        # each application draws its own speed and squeal lines; a --level-dba given sets every line's level
        given = click.get_current_context().get_parameter_source("level_dba") == click.core.ParameterSource.COMMANDLINE
        level = {"level_dba": level_dba} if given else {}
        refuse_options(("rpm", "rpm_end", "probe_offset_deg", "polarity", "acoustic_delay", "tacho_ppr", "radius",
                        "freq", "squeal_on"), "describes one recording; a --campaign draws each application's own")
        truth = synthetic_campaign(out, n_applications=n_campaign, duration=duration, fs=fs, suffix=fmt, seed=seed,
                                   condition_channels=condition_channels, **level)
        if as_json:
            emit_json({k: v for k, v in truth.items() if k != "by_application"} | {"out": str(out)})
        else:
            click.echo(f"wrote {out / 'matrix.csv'} and {n_campaign} SYNTHETIC recordings ({fmt}); truth: "
                       f"occurrence {truth['occurrence_percent']:.1f} %, by line "
                       + ", ".join(f"{float(k):g} Hz {v:.1f} %" for k, v in truth["line_occurrence_percent"].items()))
        return

    refuse_options(("fmt", "condition_channels"),
                   "applies to a --campaign only (a recording's format is the suffix of --out)")
    check_output_suffix(out, FORMATS, "--out")
    from ..io import check_output

    check_output(out)  # before the work: the folder exists and takes a file, OUT is not a folder
    src = synthetic_source(duration=duration, fs=fs, rpm=rpm, radius=radius, freq=freq, level_dba=level_dba,
                           squeal_on=squeal_on, seed=seed, rpm_end=rpm_end, probe_offset_deg=probe_offset_deg,
                           polarity=int(polarity), acoustic_delay=acoustic_delay, tacho_ppr=tacho_ppr)
    attrs = synthetic_attrs(src, squeal_on=squeal_on)
    # generated and written block by block: the memory does not grow with --duration
    write_recording_blocks(src.iter_blocks(src.channels), out, fs=src.fs, n_samples=src.n_samples, units=src.units,
                           attrs=attrs)
    truth = {k.removeprefix("truth_"): v for k, v in attrs.items() if k.startswith("truth_")}
    if as_json:
        emit_json({"out": str(out), "synthetic": True, "truth": truth})
    else:
        if len(truth["event_starts_s"]) == 0:
            what = "no squeal"
        else:
            what = (f"squeal {truth['frequency_hz']:.1f} Hz, {len(truth['event_starts_s'])} events, "
                    f"rising fraction {truth['rising_fraction']:.3f}")
        click.echo(f"wrote {out} (SYNTHETIC, {duration:g} s at {fs:g} Hz; truth: {what})")


def _output(out_arg: Path | None, out_file: Path | None, out_dir: Path | None, *, campaign: bool) -> Path:
    """Where synth writes: --out FILE (a recording) or --out-dir FOLDER (a --campaign); the
    deprecated positional OUT stands for the one that applies, with one line on stderr."""
    want, other = ("--out-dir", "--out") if campaign else ("--out", "--out-dir")
    given, wrong = (out_dir, out_file) if campaign else (out_file, out_dir)
    if wrong is not None:
        what = "a --campaign writes a folder" if campaign else "a recording is one file (--out-dir is for --campaign)"
        raise InputError(f"{other} {str(wrong)!r}: {what}; give {want}.")
    if out_arg is not None:
        if given is not None:
            raise InputError(f"Give the output once: {want} {str(given)!r}, not also {str(out_arg)!r}.")
        PENDING_NOTES.append(f"squealkit: warning: the output as an argument is deprecated in 'squealkit synth'; "
                             f"use {want} {out_arg}.")
        return out_arg
    if given is None:
        raise InputError(f"Give the output: {want} {'FOLDER' if campaign else 'FILE (.nc, .csv, .wav, ...)'}.")
    return given

"""A SYNTHETIC SAE J2521-like campaign with known truth (no public dynamometer campaigns exist).

Each application is a synthetic rig recording (:func:`squealkit.measurement.synthetic_recording`)
whose squeal lines follow rules on its conditions, so the truth of every band is known:

- 2.5 kHz when the brake is hot (>= 200 C) at low pressure (< 20 bar);
- 6.3 kHz when it is cold (< 120 C);
- 12.5 kHz at high pressure (>= 30 bar);
- and, on every fifth application, a 1.6 kHz tone at 85 dB(A): below the component setup's
  2 kHz, so it must never count as squeal there.

Drags run at constant speed; stops decelerate (to a third of the start speed). Every file
carries a tacho; every line squeals on the rising run-out, so the run-out link is known too.
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from .._validation import check_budget, validate_int, validate_positive

__all__ = ["SQUEAL_RULES", "synthetic_campaign"]

#: Squeal lines [Hz] and the conditions under which they sound.
SQUEAL_RULES: dict[float, str] = {
    2500.0: "temperature_c >= 200 and pressure_bar < 20",
    6300.0: "temperature_c < 120",
    12500.0: "pressure_bar >= 30",
}
_DISTRACTOR_HZ = 1600.0


def _lines(temperature_c: float, pressure_bar: float) -> list[float]:
    out = []
    if temperature_c >= 200 and pressure_bar < 20:
        out.append(2500.0)
    if temperature_c < 120:
        out.append(6300.0)
    if pressure_bar >= 30:
        out.append(12500.0)
    return out


#: A lower bound of the time one application takes besides its samples (files, truth) [s].
_SECONDS_PER_APPLICATION = 0.01


def synthetic_campaign(
    out: str | Path, *, n_applications: int = 60, duration: float = 2.0, fs: float = 40000.0,
    suffix: str = ".nc", stop_share: float = 0.3, seed: int = 0, level_dba: float = 85.0,
    condition_channels: bool = False,
) -> dict[str, Any]:
    """Write a synthetic campaign: ``out/matrix.csv``, one recording per application, ``out/truth.json``.

    Parameters
    ----------
    out : path
        Folder (created; one squealkit wrote is replaced, one holding other files refused). The
        whole campaign is staged and moved into place when complete (:func:`squealkit.io.output_folder`).
    n_applications : int
        Brake applications.
    duration, fs : float
        Length [s] and sample rate [Hz] of each recording.
    suffix : str
        Recording format (any of :data:`squealkit.measurement.formats.writers.FORMATS`).
    stop_share : float
        Share of decelerating stops (the rest are drags).
    seed : int
        Seed of the conditions and recordings.
    level_dba : float
        Saturated level of every squeal line [dB(A)].
    condition_channels : bool
        Record the brake pressure [bar] and temperature [C] as channels ``pressure`` and
        ``temperature`` (a little noise; the temperature rising by 5 C over a stop) and leave
        those matrix columns empty, as a DAQ that logs its conditions would.

    Returns
    -------
    dict
        The truth: per application its lines, and the occurrence per squeal line.
    """
    from ..io import output_folder

    n_applications = validate_int("n_applications", n_applications, 1)
    from ..measurement.synthetic import SECONDS_PER_SAMPLE

    check_budget(f"A synthetic campaign of {n_applications} applications", points=n_applications,
                 seconds=n_applications * (validate_positive("duration", duration) * validate_positive("fs", fs)
                                           * SECONDS_PER_SAMPLE + _SECONDS_PER_APPLICATION),
                 hint="Use fewer applications.")
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    with output_folder(out) as stage:  # recordings, matrix and truth appear together, or nothing
        truth = _write_campaign(stage, n_applications, duration, fs, suffix, stop_share, seed, level_dba,
                                condition_channels)
    return truth


def _write_campaign(out: Path, n_applications: int, duration: float, fs: float, suffix: str, stop_share: float,
                    seed: int, level_dba: float, condition_channels: bool) -> dict[str, Any]:
    """Write the campaign into the (staging) folder ``out``; the truth."""
    from ..measurement import synthetic_recording
    from ..measurement.formats.writers import write_recording
    from ..measurement.squeal.criteria import P_REF, a_weighting_db

    (out / "recordings").mkdir()
    rng = np.random.default_rng(seed)
    rows, truth_apps = [], {}
    for i in range(n_applications):
        app = f"A{i + 1:04d}"
        temperature = float(np.round(rng.uniform(50.0, 350.0), 1))
        pressure = float(np.round(rng.uniform(5.0, 40.0), 1))
        mode = "stop" if rng.random() < stop_share else "drag"
        rpm = float(np.round(rng.uniform(600.0, 1200.0)))
        rpm_end = rpm / 3 if mode == "stop" else None
        lines = _lines(temperature, pressure)
        rec_seed = seed * 100003 + i
        kw = dict(duration=duration, fs=fs, rpm=rpm, rpm_end=rpm_end, seed=rec_seed, level_dba=level_dba)

        def harm(f: float) -> tuple[float, ...]:
            return (0.05, 0.02) if 3 * f < fs / 2 else ()

        f0 = lines[0] if lines else 2388.0
        rec = synthetic_recording(freq=f0, harmonics=harm(f0), squeal_on="rising" if lines else "none", **kw)
        mic = rec["mic"].values.copy()
        for f in lines[1:]:  # further lines on the same disc (same seed: the same run-out and noise)
            other = synthetic_recording(freq=f, harmonics=harm(f), squeal_on="rising", noise_pa=0.0, **kw)
            mic += other["mic"].values
        if i % 5 == 4:
            t = rec["time"].values
            amp = math.sqrt(2) * P_REF * 10 ** ((85.0 - float(a_weighting_db(_DISTRACTOR_HZ))) / 20)
            mic += amp * np.sin(2 * np.pi * _DISTRACTOR_HZ * t)
        rec = rec.assign(mic=("time", mic, rec["mic"].attrs))
        if condition_channels:
            t = rec["time"].values
            crng = np.random.default_rng([seed, i, 7])
            rise = 5.0 * t / duration if mode == "stop" else 0.0 * t
            rec = rec.assign(
                pressure=("time", pressure + 0.05 * crng.standard_normal(t.size), {"units": "bar"}),
                temperature=("time", temperature - 2.5 * (mode == "stop") + rise + 0.2 * crng.standard_normal(t.size),
                             {"units": "C"}))
        name = f"recordings/{app}{suffix}"
        write_recording(rec, out / name)
        truth_apps[app] = {"lines_hz": lines, "runout_phase_deg": float(rec.attrs["truth_runout_phase_deg"])
                           if lines else None, "mode": mode, "temperature_c": temperature, "pressure_bar": pressure}
        rows.append({"application": app, "file": name, "section": f"S{1 + i * 5 // n_applications}", "mode": mode,
                     "pressure_bar": "" if condition_channels else pressure,
                     "temperature_c": "" if condition_channels else temperature,
                     "speed_kmh": round(rpm / 60 * 2 * math.pi * 0.33 * 3.6, 1)})
    with open(out / "matrix.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    n = n_applications
    truth = {
        "synthetic": True,
        "applications": n,
        "rules": {str(k): v for k, v in SQUEAL_RULES.items()},
        "occurrence_percent": 100.0 * sum(bool(a["lines_hz"]) for a in truth_apps.values()) / n,
        "line_occurrence_percent": {str(f): 100.0 * sum(f in a["lines_hz"] for a in truth_apps.values()) / n
                                    for f in SQUEAL_RULES},
        "distractor_hz": _DISTRACTOR_HZ,
        "by_application": truth_apps,
    }
    (out / "truth.json").write_text(json.dumps(truth, indent=2))
    return truth

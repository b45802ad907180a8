"""A SYNTHETIC campaign made from a known model and friction law, with known correlation truth.

Each application gets conditions (temperature, pressure, disc speed), a measured friction
coefficient from a linear friction law (plus noise) and a recording
(:func:`squealkit.measurement.synthetic_recording`). The model, at the measured mu plus a
hidden ``mu_offset``, decides which applications have an unstable mode; the recordings then
follow a known design, so every outcome is known:

- ``hit``: unstable, and the recording squeals at the unstable mode's frequency;
- ``over_prediction``: unstable, the recording is quiet (every ``7k + 3``-th application far
  enough from the stability limit);
- ``miss``: the recording squeals at ``miss_hz``, a line the model never predicts (every
  ``7k + 5``-th application far enough from the limit);
- ``quiet``: stable and quiet.

"Far enough" means the model's mu is more than ``margin`` from the critical friction, so that
a calibration of the offset within ``margin`` cannot change these designed exceptions.
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from .._validation import validate_int

__all__ = ["synthetic_correlation_campaign"]


def _truth(model: Any, mu: np.ndarray, damped: bool) -> tuple[np.ndarray, np.ndarray]:
    """Per application: unstable (sigma > 1e-6 |lambda|) and the frequency [Hz] of its most unstable mode."""
    from ..stability import eigenvalues

    lam = eigenvalues(model, mu, damped=damped)  # the public per-grid API, one call
    sigma = lam.real
    k = np.argmax(sigma, axis=-1)
    top = np.take_along_axis(lam, k[:, None], axis=-1)[:, 0]
    unstable = top.real > 1e-6 * np.abs(top)
    return unstable, top.imag / (2 * math.pi)


def synthetic_correlation_campaign(
    out: str | Path, model: Any = None, *, n_applications: int = 28, mu_offset: float = 0.05,
    law: tuple[float, float, float] = (0.35, 8e-4, -4e-3), mu_noise: float = 0.003, miss_hz: float = 6300.0,
    margin: float = 0.06, damped: bool = True, duration: float = 0.4, fs: float = 20000.0, seed: int = 0,
) -> dict[str, Any]:
    """Write ``out/matrix.csv`` (with a ``mu`` and ``rpm`` column), recordings and ``out/truth.json``.

    Parameters
    ----------
    out : path
        Folder (created; one squealkit wrote is replaced).
    model : FrictionModel, optional
        The known model (default: the ``lv2013`` preset).
    n_applications : int
        Brake applications.
    mu_offset : float
        The hidden offset: the model's mu is the measured mu plus it.
    law : (float, float, float)
        ``(mu0, a_T, a_p)``: ``mu = mu0 + a_T (T - 200 C) + a_p (p - 20 bar)``.
    mu_noise : float
        Standard deviation of the measured mu about the law.
    miss_hz : float
        Frequency [Hz] of the squeal the model does not predict.
    margin : float
        Designed exceptions lie farther than this from the critical friction.
    damped : bool
        Whether the truth's model includes its damping.
    duration, fs : float
        Length [s] and sample rate [Hz] of each recording.
    seed : int
        Seed of conditions, noise and recordings.

    Returns
    -------
    dict
        The truth: ``outcome`` and ``predicted_hz`` per application, ``mu_offset``, ``law``,
        ``mu_critical`` and the counts.
    """
    from ..io import output_folder
    from ..measurement import synthetic_recording
    from ..measurement.formats.writers import write_recording
    from ..models import get_preset
    from ..stability import critical_friction

    model = get_preset("lv2013") if model is None else model
    n_applications = validate_int("n_applications", n_applications, 1)
    rng = np.random.default_rng(seed)
    T = np.round(rng.uniform(50.0, 350.0, n_applications), 1)
    p = np.round(rng.uniform(5.0, 40.0, n_applications), 1)
    rpm = np.round(rng.uniform(600.0, 1200.0, n_applications))
    mu0, a_t, a_p = law
    mu_meas = np.round(mu0 + a_t * (T - 200.0) + a_p * (p - 20.0) + mu_noise * rng.standard_normal(n_applications), 4)
    unstable, f_top = _truth(model, mu_meas + mu_offset, damped)
    mu_c = critical_friction(model, damped=damped).mu_critical
    far = np.abs(mu_meas + mu_offset - mu_c) > margin
    idx = np.arange(n_applications)
    outcome = np.where(unstable, "hit", "quiet").astype(object)
    outcome[(idx % 7 == 3) & unstable & far] = "over_prediction"
    outcome[(idx % 7 == 5) & far] = "miss"
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    rows, by_app = [], {}
    with output_folder(out) as stage:
        (stage / "recordings").mkdir()
        for i in range(n_applications):
            app = f"A{i + 1:04d}"
            kind = outcome[i]
            freq = {"hit": f_top[i], "miss": miss_hz}.get(kind, 2000.0)
            rec = synthetic_recording(duration=duration, fs=fs, rpm=float(rpm[i]), freq=float(freq), harmonics=(),
                                      squeal_on="rising" if kind in ("hit", "miss") else "none",
                                      seed=seed * 100003 + i, level_dba=85.0)
            name = f"recordings/{app}.nc"
            write_recording(rec, stage / name)
            rows.append({"application": app, "file": name, "mode": "drag", "pressure_bar": float(p[i]),
                         "temperature_c": float(T[i]), "speed_kmh": round(float(rpm[i]) / 60 * 2 * math.pi * 0.3 * 3.6,
                                                                          1),
                         "rpm": float(rpm[i]), "mu": float(mu_meas[i])})
            by_app[app] = {"outcome": kind, "predicted_hz": float(f_top[i]) if unstable[i] else None,
                           "measured_hz": float(freq) if kind in ("hit", "miss") else None,
                           "mu": float(mu_meas[i]), "temperature_c": float(T[i]), "pressure_bar": float(p[i])}
        with open(stage / "matrix.csv", "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
        counts = {k: int(np.sum(outcome == k)) for k in ("hit", "miss", "over_prediction", "quiet")}
        truth = {"synthetic": True, "applications": n_applications, "mu_offset": mu_offset,
                 "law": {"mu0": mu0, "temperature_c": a_t, "pressure_bar": a_p, "temperature_c_ref": 200.0,
                         "pressure_bar_ref": 20.0, "noise_std": mu_noise},
                 "mu_critical": float(mu_c), "damped": damped, "counts": counts, "by_application": by_app}
        (stage / "truth.json").write_text(json.dumps(truth, indent=2))
    return truth

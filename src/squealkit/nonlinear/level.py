"""How loud a limit cycle is: the sound pressure level from a DOF's vibration velocity.

The model has no acoustics; the user gives the link from vibration to sound at the listener:
either a radiation factor ``R`` [Pa/(m/s)] (sound pressure per unit velocity, the same at
every frequency) or a measured transfer ``|T(f)|`` [Pa/(m/s)] (e.g. from a hammer test or an
operating-deflection measurement), interpolated linearly in frequency at each harmonic of the
cycle. With the velocity of the chosen DOF written per harmonic ``k`` (amplitude
``V_k = k omega sqrt(a_k^2 + b_k^2)``), the pressure's mean square and level are::

    p_rms^2 = sum_k |T(k f)|^2 V_k^2 / 2,    L = 10 log10(p_rms^2 / p_ref^2)  [dB SPL re 20 uPa]

With a constant ``R`` this is ``R v_rms``. Harmonics above the transfer's last frequency
(or below its first) are left out; the fundamental must lie inside it.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import xarray as xr
from numpy.typing import NDArray

from .._validation import InputError, validate_dataset, validate_positive

__all__ = ["read_transfer_csv", "sound_level"]

#: Reference sound pressure [Pa] of dB SPL.
P_REF = 20e-6


def read_transfer_csv(path: str | Path) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Read a transfer ``frequency [Hz], |p/v| [Pa/(m/s)]`` from a two-column CSV file.

    Parameters
    ----------
    path : str or Path
        Comma-, semicolon- or whitespace-separated; lines starting with ``#`` and one header
        line of text are skipped.

    Returns
    -------
    (ndarray, ndarray)
        Frequencies [Hz] (increasing) and magnitudes [Pa/(m/s)].
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8", errors="strict")
    except (OSError, UnicodeDecodeError) as e:
        raise InputError(f"Cannot read the transfer file {str(path)!r}: {e}") from e
    rows: list[list[float]] = []
    header = False
    for i, line in enumerate(text.splitlines(), 1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        parts = line.replace(";", ",").replace("\t", ",").replace(" ", ",").split(",")
        parts = [p for p in parts if p]
        try:
            vals = [float(p) for p in parts[:2]]
        except ValueError:
            if not rows and not header:
                header = True  # one line of column names
                continue
            raise InputError(f"Transfer file {str(path)!r} line {i}: {line!r} is not two numbers "
                             "(frequency [Hz], |p/v| [Pa/(m/s)]).") from None
        if len(vals) < 2:
            raise InputError(f"Transfer file {str(path)!r} line {i}: {line!r} needs two columns "
                             "(frequency [Hz], |p/v| [Pa/(m/s)]).")
        rows.append(vals)
    if len(rows) < 2:
        raise InputError(f"Transfer file {str(path)!r} holds {len(rows)} data rows; at least 2 are needed.")
    a = np.array(rows)
    f, t = a[:, 0], a[:, 1]
    if not (np.all(np.isfinite(a)) and np.all(np.diff(f) > 0) and f[0] >= 0 and np.all(t >= 0)):
        raise InputError(f"Transfer file {str(path)!r}: frequencies must increase (>= 0 Hz) and the magnitudes "
                         "be finite and >= 0.")
    return f, t


def sound_level(ds: xr.Dataset, *, radiation_factor: float | None = None,
                transfer: tuple[NDArray, NDArray] | None = None, dof: str | None = None) -> xr.Dataset:
    """Add the sound pressure level of each cycle of a branch: ``level_db`` [dB SPL re 20 uPa].

    Parameters
    ----------
    ds : xarray.Dataset
        A branch of :func:`~squealkit.nonlinear.limit_cycle_branch` (it holds the Fourier
        coefficients and frequencies).
    radiation_factor : float, optional
        Sound pressure per unit velocity [Pa/(m/s)], the same at every frequency.
    transfer : (array, array), optional
        Frequencies [Hz] and ``|p/v|`` [Pa/(m/s)] of a measured transfer (e.g.
        :func:`read_transfer_csv`), interpolated linearly at each harmonic.
    dof : str, optional
        The DOF whose velocity radiates (default the first: the pin's ``x1``).

    Returns
    -------
    xarray.Dataset
        ``ds`` with ``velocity_rms`` [m/s] and ``sound_pressure_rms`` [Pa] and ``level_db``
        [dB] over ``point``; attributes ``level_dof`` and ``level_from``.

    Examples
    --------
    >>> from squealkit.models import get_preset
    >>> from squealkit.nonlinear import limit_cycle_branch
    >>> ds = limit_cycle_branch(get_preset("lv2013"), (0.39, 0.6), n_points=5, harmonics=4,
    ...                         check_harmonics=False)
    >>> out = sound_level(ds, radiation_factor=400.0)
    >>> bool(out.level_db[-1] > out.level_db[1])
    True
    """
    validate_dataset(ds, what="limit_cycle_branch")
    if (radiation_factor is None) == (transfer is None):
        raise InputError("Give exactly one of radiation_factor [Pa/(m/s)] and transfer (frequency [Hz], |p/v|).")
    dofs = [str(d) for d in ds["dof"].values]
    dof = dofs[0] if dof is None else str(dof)
    if dof not in dofs:
        raise InputError(f"Parameter dof={dof!r} is not a DOF of this branch; choose one of {', '.join(dofs)}.")
    c = ds["coefficients"].sel(dof=dof).values  # (point, 2H+1)
    H = (c.shape[1] - 1) // 2
    omega = ds["omega_rad_s"].values
    k = np.arange(1, H + 1)
    V = k[None, :] * omega[:, None] * np.hypot(c[:, 1:H + 1], c[:, H + 1:])  # velocity amplitude per harmonic
    if radiation_factor is not None:
        R = validate_positive("radiation_factor", radiation_factor)
        gain = np.full(V.shape, R)
        source = f"radiation factor {R:g} Pa/(m/s)"
    else:
        f_t, t_t = (np.asarray(a, float) for a in transfer)
        if f_t.ndim != 1 or f_t.shape != t_t.shape or f_t.size < 2 or not np.all(np.diff(f_t) > 0):
            raise InputError("Parameter transfer must be two 1-d arrays of equal length >= 2 with increasing "
                             "frequencies [Hz].")
        f0 = omega / (2 * math.pi)
        out = (f0 < f_t[0]) | (f0 > f_t[-1])
        if out.any():
            raise InputError(f"The squeal frequency {f0[out][0]:.1f} Hz lies outside the transfer's range "
                             f"[{f_t[0]:g}, {f_t[-1]:g}] Hz.")
        gain = np.interp(k[None, :] * f0[:, None], f_t, t_t, left=0.0, right=0.0)
        source = f"measured transfer ({f_t.size} points, {f_t[0]:g}-{f_t[-1]:g} Hz)"
    v_rms = np.sqrt(0.5 * np.sum(V**2, axis=1))
    p_rms = np.sqrt(0.5 * np.sum((gain * V) ** 2, axis=1))
    with np.errstate(divide="ignore"):
        level = 20 * np.log10(p_rms / P_REF)
    return ds.assign(
        velocity_rms=("point", v_rms, {"units": "m/s", "long_name": f"RMS vibration velocity of {dof}"}),
        sound_pressure_rms=("point", p_rms, {"units": "Pa", "long_name": "RMS sound pressure"}),
        level_db=("point", level, {"units": "dB", "long_name": "sound pressure level re 20 uPa"}),
    ).assign_attrs(level_dof=dof, level_from=source)

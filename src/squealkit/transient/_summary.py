"""What a transient record shows: the vibration's envelope, and its growth or decay per run-out stage."""

from __future__ import annotations

import itertools
import math

import numpy as np
import xarray as xr

from .._deprecation import renamed_kwargs
from .._validation import InputError, validate_dataset


@renamed_kwargs(freq_lower="highpass_freq")
def response_envelope(ds: xr.Dataset, var: str, *, highpass_freq: float = 1000.0) -> xr.DataArray:
    """Envelope of the vibration of ``var``: high-pass above ``highpass_freq`` [Hz], then ``|Hilbert|``.

    The high-pass (4th-order Butterworth, zero phase) removes the quasi-static response to the
    run-out so that what remains is the self-excited vibration (paper section 5 does the same
    with the rig's displacement).

    Parameters
    ----------
    ds : xarray.Dataset
        A result of :func:`simulate` (or :func:`simulate_batch`), with attribute ``fs`` [Hz].
    var : str
        The variable, e.g. ``"x1_ddot"``; time is its last dimension.
    highpass_freq : float, default 1000.0
        High-pass corner [Hz], in ``(0, fs / 2)`` (formerly ``freq_lower``, still accepted
        with a DeprecationWarning).

    Returns
    -------
    xarray.DataArray
        The envelope, the shape, coordinates and units of ``ds[var]``, named ``{var}_envelope``.
    """
    validate_dataset(ds, variables=("time",), attrs=("fs",), what="simulate")
    from scipy.signal import butter, hilbert, sosfiltfilt

    if var not in ds:
        raise InputError(f"Variable {var!r} is not in the dataset; have {sorted(ds.data_vars)}.")
    fs = float(ds.attrs["fs"])
    y = np.asarray(ds[var].values, dtype=float)
    if not 0 < highpass_freq < fs / 2:
        raise InputError(f"Parameter highpass_freq={highpass_freq!r} Hz must lie between 0 and fs/2 = {fs / 2:g} Hz.")
    if y.shape[-1] > 27:
        sos = butter(4, highpass_freq, btype="highpass", fs=fs, output="sos")
        y = sosfiltfilt(sos, y - y[..., :1], axis=-1)
    env = np.abs(hilbert(y, axis=-1))
    out = xr.DataArray(env, dims=ds[var].dims, coords=ds[var].coords, name=f"{var}_envelope")
    out.attrs = {
        "units": ds[var].attrs.get("units", ""),
        "long_name": f"vibration envelope of {var} (> {highpass_freq:g} Hz)",
    }
    return out


def _stages(tan_theta: np.ndarray) -> list[tuple[int, int, str]]:
    """Contiguous index ranges where the run-out rises, falls or is flat."""
    label = np.where(tan_theta > 1e-12, 1, np.where(tan_theta < -1e-12, -1, 0))
    edges = np.flatnonzero(np.diff(label)) + 1
    bounds = np.concatenate([[0], edges, [label.size]])
    names = {1: "rising", -1: "falling", 0: "flat"}
    return [(int(a), int(b), names[int(label[a])]) for a, b in itertools.pairwise(bounds)]


#: Samples of the record the stage rates of :func:`transient_summary` look at (about 26 s at 40 kHz):
#: the envelope is a whole-record filter, so a longer (streamed) record is summarised by its start.
SUMMARY_STAGE_SAMPLES = 1 << 20


@renamed_kwargs(freq_lower="highpass_freq")
def transient_summary(ds: xr.Dataset, *, max_stages: int = 50, highpass_freq: float = 1000.0) -> dict[str, object]:
    """Peak amplitudes, and growth or decay rate of the vibration per run-out stage.

    The growth rate of a stage [1/s] is the least-squares slope of the log of the envelope
    (see :func:`response_envelope`, first DOF's acceleration) over the stage, leaving out the
    first and last 5 ms of the record (filter end effects); it is positive
    where the vibration grows (paper Fig. 4: rising SRO) and negative where it decays.

    The peaks cover the whole record, read piece by piece when ``ds`` is opened lazily (a
    streamed run: ``xarray.open_dataset(path, chunks={})``), so a record of any length is
    summarised in bounded memory; the stages are those of its first
    :data:`SUMMARY_STAGE_SAMPLES` samples (``stages_truncated`` is then true).

    Parameters
    ----------
    ds : xarray.Dataset
        A result of :func:`simulate` (or the blocks of :func:`simulate_blocks` as written).
    max_stages : int, default 50
        At most this many stages are listed (``stages_truncated`` says whether more were cut).
    highpass_freq : float, default 1000.0
        High-pass corner [Hz] of the envelope (:func:`response_envelope`; formerly
        ``freq_lower``, still accepted with a DeprecationWarning).

    Returns
    -------
    dict
        JSON-ready: the run's ``status``, ``t_stop``, ``duration`` [s], ``fs`` [Hz], ``mu``,
        ``speed``, ``profile``, ``contact``, step statistics, ``peak`` per DOF (displacement
        change [m], velocity [m/s], acceleration [m/s^2]), ``growth_rate_max`` [1/s] and
        ``stages`` (``stage``, ``t_start``, ``t_end``, ``rate_per_s``, ``sigma_mean_per_s``,
        ``partial``) and ``stages_truncated``.
    """
    validate_dataset(ds, variables=("time",), attrs=("fs",), what="simulate")
    model_dofs = [v[: -len("_ddot")] for v in ds.data_vars if str(v).endswith("_ddot")]
    fs = float(ds.attrs["fs"])
    n_time = ds.sizes["time"]
    out: dict[str, object] = {
        "status": ds.attrs.get("status"),
        "t_stop": ds.attrs.get("t_stop"),
        "duration": float(ds.time[-1]) if n_time else 0.0,
        "fs": fs,
        "mu": ds.attrs.get("mu"),
        "speed": ds.attrs.get("speed"),
        "profile": ds.attrs.get("profile"),
        "contact": ds.attrs.get("contact"),
        "dt": ds.attrs.get("dt"),
        "method": ds.attrs.get("method"),
        "steps": ds.attrs.get("steps"),
        "events": ds.attrs.get("events"),
        "tensile_fraction": ds.attrs.get("tensile_fraction"),
        "min_normal_force": ds.attrs.get("min_normal_force"),
        "peak": {},
    }
    reductions = {"growth_rate_max": ds.growth_rate.max()}
    for d in model_dofs:
        start = float(ds[d].isel(time=0))  # a number, not a lazy piece: dask would hold every chunk for it
        reductions[f"{d}/disp"] = abs(ds[d] - start).max()
        reductions[f"{d}/vel"] = abs(ds[f"{d}_dot"]).max()
        reductions[f"{d}/acc"] = abs(ds[f"{d}_ddot"]).max()
    # one pass over a lazily opened record, a piece at a time (no-op for one in memory)
    red = {k: float(v) for k, v in xr.Dataset(reductions).compute(scheduler="synchronous").data_vars.items()}
    for d in model_dofs:
        out["peak"][d] = {  # type: ignore[index]
            "displacement_change_m": red[f"{d}/disp"],
            "velocity_m_s": red[f"{d}/vel"],
            "acceleration_m_s2": red[f"{d}/acc"],
        }
    out["growth_rate_max"] = red["growth_rate_max"]
    cut = n_time > SUMMARY_STAGE_SAMPLES
    head = ds.isel(time=slice(0, SUMMARY_STAGE_SAMPLES)) if cut else ds
    stages = _stage_rates(head, fs, model_dofs[0], highpass_freq)
    if cut and stages:
        stages = stages[:-1]  # the stage the cut runs through is not whole
    out["stages"] = stages[:max_stages]
    out["stages_truncated"] = len(stages) > max_stages or cut
    return out


def _stage_rates(ds: xr.Dataset, fs: float, dof: str, highpass_freq: float) -> list[dict[str, object]]:
    """Growth or decay rate of the envelope per run-out stage (see :func:`transient_summary`)."""
    time = ds.time.values
    stages: list[dict[str, object]] = []
    if time.size > 32 and fs > 2500.0:
        env = response_envelope(ds, f"{dof}_ddot", highpass_freq=highpass_freq).values
        # The zero-phase filter and the Hilbert transform ring for a few ms at both ends of
        # the record: those samples take no part in the rate fits.
        edge = np.zeros(time.size, dtype=bool)
        n_edge = min(int(0.005 * fs), time.size // 4)
        edge[:n_edge] = edge[time.size - n_edge :] = True
        sigma = ds.growth_rate.values
        for a, b, kind in _stages(ds.tan_theta.values):
            if b - a < 16:
                continue
            seg = env[a:b]
            ok = (seg > 0) & ~edge[a:b]
            rate = float(np.polyfit(time[a:b][ok], np.log(seg[ok]), 1)[0]) if ok.sum() > 8 else math.nan
            stages.append({
                "stage": kind, "t_start": float(time[a]), "t_end": float(time[b - 1]), "rate_per_s": rate,
                "sigma_mean_per_s": float(sigma[a:b].mean()),
                "partial": a == 0 or b == time.size,  # cut by the record: rate less reliable
            })
    return stages

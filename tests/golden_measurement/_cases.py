"""The golden cases of the measurement analysis and the arrays compared (shared by make_golden.py
and tests/test_layout_measurement.py)."""

from __future__ import annotations

import hashlib

import numpy as np

from squealkit.measurement import analyze_recording, synthetic_recording

#: Constant speed (paper §5 rig, short) and a decelerating stop read from a 1-pulse tacho.
KW_CONST = dict(mic="mic", displacement="displacement", rpm=900.0, radius=0.05)
KW_TACHO = dict(mic="mic", displacement="displacement", tacho="tacho", radius=0.05)


def cases() -> dict:
    """name -> (recording, result, analysis keywords)."""
    out = {}
    rec = synthetic_recording(duration=0.5, seed=7)
    out["const"] = (rec, analyze_recording(rec, **KW_CONST), KW_CONST)
    rec = synthetic_recording(duration=0.5, rpm=900.0, rpm_end=600.0, tacho_ppr=1, seed=8)
    out["tacho"] = (rec, analyze_recording(rec, **KW_TACHO), KW_TACHO)
    return out


def analysis_arrays(res) -> dict[str, np.ndarray]:
    """Every number of a MeasurementResult, as arrays keyed by name."""
    out: dict[str, np.ndarray] = {}
    for part in ("frames", "revolutions", "polar", "spectrum"):
        ds = getattr(res, part)
        for k in list(ds.data_vars) + list(ds.coords):
            out[f"{part}.{k}"] = np.asarray(ds[k].values)
    scal = [res.squeal_frequency_hz, res.rising_fraction, res.growth_slope_correlation, res.peak_dba,
            res.runout_phase_deg, res.duration_s, res.fs, res.attrs["max_tan_theta"]]
    out["scalars"] = np.array([np.nan if v is None else v for v in scal], dtype=np.float64)
    out["events"] = np.array([[e.start_s, e.end_s, e.frequency_hz, e.peak_dba,
                               np.nan if e.runout_phase_deg is None else e.runout_phase_deg] for e in res.events],
                             dtype=np.float64).reshape(-1, 5)
    out["harmonics"] = np.array([[h["order"], h["frequency_hz"], h["level_db"]] for h in res.harmonics],
                                dtype=np.float64).reshape(-1, 3)
    return out


def _artist_arrays(fig) -> dict[str, np.ndarray]:
    out = {}
    for i, ax in enumerate(fig.axes):
        for j, line in enumerate(ax.get_lines()):
            out[f"ax{i}.line{j}"] = np.asarray(line.get_xydata(), dtype=np.float64)
        for j, coll in enumerate(ax.collections):
            arr = coll.get_array()
            if arr is not None:
                out[f"ax{i}.coll{j}.array"] = np.ma.getdata(arr).astype(np.float64)
            if hasattr(coll, "get_coordinates"):
                out[f"ax{i}.coll{j}.coords"] = np.asarray(coll.get_coordinates(), dtype=np.float64)
            elif len(coll.get_offsets()):
                out[f"ax{i}.coll{j}.offsets"] = np.ma.getdata(coll.get_offsets()).astype(np.float64)
            if hasattr(coll, "get_clim"):
                out[f"ax{i}.coll{j}.clim"] = np.array(coll.get_clim(), dtype=np.float64)
        out[f"ax{i}.xlim"] = np.array(ax.get_xlim())
        out[f"ax{i}.ylim"] = np.array(ax.get_ylim())
        labels = [ax.get_title(), ax.get_xlabel(), ax.get_ylabel()]
        leg = ax.get_legend()
        if leg is not None:
            labels += [t.get_text() for t in leg.get_texts()]
        out[f"ax{i}.text"] = np.array(labels)
    return out


def figure_arrays(rec, res, kw) -> dict[str, np.ndarray]:
    """What each figure of the report draws, keyed ``figure/axes.artist``."""
    from squealkit.plotting import measurement as mp

    figs = _figures(mp, rec, res)
    out = {}
    for name, fig in figs.items():
        out.update({f"{name}/{k}": v for k, v in _artist_arrays(fig).items()})
    return out


def _figures(mp, rec, res):
    from squealkit.measurement import measurement_signals

    figs = mp.measurement_figures(res, measurement_signals(rec, res))
    figs["event_phase"] = mp.event_phase_plot(res)
    return figs


def digest(a: np.ndarray) -> str:
    """SHA-256 of an array's dtype, shape and bytes (equal digests: bit-identical arrays)."""
    a = np.ascontiguousarray(a)
    h = hashlib.sha256(f"{a.dtype.str}{a.shape}".encode())
    h.update(a.tobytes() if a.dtype.kind != "U" else "\x00".join(a.ravel().tolist()).encode())
    return h.hexdigest()

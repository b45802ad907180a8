"""Compiled inner loops of the analysis (numba): per-row time weighting, mean squares, running and angle sums."""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray

from ..signal.spectral import refine_peak


def _refine_rows(power: NDArray[np.float64], k: NDArray[np.intp]) -> NDArray[np.float64]:
    """Refined bin of the peak at ``k`` in each row of a power spectrum (Hann two-bin ratio)."""
    kk = np.clip(k, 1, power.shape[1] - 2)
    mag3 = np.sqrt(np.take_along_axis(power, kk[:, None] + np.array([-1, 0, 1]), axis=1))
    return np.atleast_1d(refine_peak(mag3, np.ones(kk.size, np.intp))) - 1 + kk


@njit(cache=True)
def _ewma_rows(p, a, state, out):  # pragma: no cover - compiled
    """``y_m = a y_(m-1) + (1 - a) p_m`` row after row, ``state`` (float64) holding the last row: the
    same operations per column as a loop down each column, in memory order (six times faster)."""
    b = 1.0 - a
    for m in range(p.shape[0]):
        for j in range(p.shape[1]):
            y = a * state[j] + b * p[m, j]
            out[m, j] = y
            state[j] = y


@njit(cache=True)
def _mean_squares_kernel(x, dec, out):  # pragma: no cover - compiled
    for i in range(out.shape[0]):
        acc = 0.0
        for j in range(i * dec, (i + 1) * dec):
            acc += np.float64(x[j] * x[j])
        out[i] = acc / dec


def _mean_squares(x: NDArray[np.float32], dec: int) -> NDArray[np.float64]:
    """Mean square of each run of ``dec`` samples (``x.size // dec`` of them), squared in single precision
    and summed in double: ``np.square(x).reshape(-1, dec).mean(axis=1, dtype=np.float64)``.

    A compiled loop, four times faster than NumPy's reduction over short rows.
    """
    out = np.empty(x.size // dec)
    _mean_squares_kernel(x, dec, out)
    return out


@njit(cache=True, nogil=True)
def _running_sums_kernel(ms, tan_t, out):  # pragma: no cover - compiled
    e = r = t = 0.0
    for i in range(ms.shape[0]):
        e += ms[i]
        r += ms[i] if tan_t[i] > 0 else 0.0
        t += tan_t[i]
        out[0, i + 1] = e
        out[1, i + 1] = r
        out[2, i + 1] = t


def _running_sums(ms: NDArray[np.float64], tan_t: NDArray[np.float64]) -> NDArray[np.float64]:
    """Cumulative sums from 0 (``size + 1`` each) of the band mean square, of its part on rising
    run-out (``tan_t > 0``) and of the incline: ``np.cumsum`` of ``ms``, ``np.where(tan_t > 0, ms, 0)``
    and ``tan_t`` after a 0, in one compiled pass (six times faster than the three and the where).
    """
    out = np.zeros((3, ms.size + 1))
    _running_sums_kernel(ms, tan_t, out)
    return out


@njit(cache=True, nogil=True)
def _angle_sums_kernel(turns, sro, macro, nb, out):  # pragma: no cover - compiled
    for i in range(turns.shape[0]):
        u = turns[i]
        b = np.int64((u - np.floor(u)) * nb) % nb
        out[0, b] += sro[i]
        out[1, b] += macro[i]
        out[2, b] += 1.0


def _angle_sums(turns: NDArray[np.float64], sro: NDArray[np.float64], macro: NDArray[np.float64],
                nb: int) -> NDArray[np.float64]:
    """SRO, macro run-out and sample count [m, m, 1] summed per disc angle bin, shape ``(3, nb)``:
    bin ``int((turns % 1) nb)`` of each sample at ``turns`` [rev], summed in sample order as
    ``np.bincount`` sums, in one compiled pass (half the time of the three bincounts).
    """
    out = np.zeros((3, nb))
    _angle_sums_kernel(turns, sro, macro, nb, out)
    return out


@njit(cache=True, nogil=True)
def _bin_powers_kernel(spec, scale, w_a, pb, pa):  # pragma: no cover - compiled
    for m in range(spec.shape[0]):
        for k in range(spec.shape[1]):
            re, im = spec[m, k].real, spec[m, k].imag
            x = re * re
            x += im * im
            x *= scale
            pb[m, k] = x
            pa[m, k] = x * w_a[k]


def _bin_powers(spec: NDArray[np.complex64], scale: np.float32, w_a: NDArray[np.float32]
                ) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
    """Power per bin ``pb = (re**2 + im**2) scale`` [Pa^2] of frame spectra and its A-weighted
    ``pa = pb w_a``, in single precision as NumPy computes them, in one compiled pass over the
    (strided) spectra: four times faster than the five array operations.
    """
    pb = np.empty(spec.shape, np.float32)
    pa = np.empty(spec.shape, np.float32)
    _bin_powers_kernel(spec, scale, w_a, pb, pa)
    return pb, pa


def _time_weight_rows(p: NDArray, a: float, state: NDArray[np.float64]) -> tuple[NDArray, NDArray[np.float64]]:
    """Exponential average over rows (frames): ``y_m = a y_(m-1) + (1 - a) p_m``; returns y and its last row.

    A compiled loop: ``scipy.signal.lfilter`` along the frame axis took 9 % of the analysis.
    """
    out = np.empty_like(p)
    st = np.array(state, dtype=np.float64)
    _ewma_rows(p, a, st, out)
    return out, st

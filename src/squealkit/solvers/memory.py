"""Memory of the FE eigen solves, estimated before they start, and the limit they must fit in.

A sparse direct solve fails late and hard when it runs out of memory (the kernel kills the
process after minutes of work). So each large solve estimates its peak first, from the matrix
size, its entries, a fill-in estimate of the ordering and the size of its Krylov or modal basis,
and is refused (one :class:`~squealkit._validation.InputError` line naming the estimate, the
limit and what would fit) or reduced (fewer parallel walks) when it will not fit.

The limit (:func:`memory_limit`) is 80 % of the memory available now (Linux ``MemAvailable``),
or of the cap the environment variable ``SQUEALKIT_MEMORY`` sets (bytes, or with a unit:
``"16G"``, ``"500M"``), whichever is lower.

Fill-in (:func:`factor_entries`): entries of the factors of an FE matrix in a nested-dissection
order grow as ``n^(4/3)`` for a 3-D mesh (George, SIAM J. Numer. Anal. 10 (1973); a plate-like
mesh grows slower, so this overestimates a thin disc). Calibrated on the built-in brake at
33 966 DOFs, whose METIS-ordered LU holds 3.35 times the entries of the matrix; it predicts
7.8e7 entries at 115 326 DOFs, where 6.8e7 were measured (15 % over).
"""

from __future__ import annotations

import math
import os

from .._validation import InputError, available_memory

__all__ = []

#: The environment variable capping the memory of a run.
ENV_VAR = "SQUEALKIT_MEMORY"

#: Fill ratio (factor entries / matrix entries) at the calibration size, and that size.
_FILL_AT, _FILL_N = 3.35, 33_966
#: Peak bytes of a factorisation per factor entry and per byte of its scalar: SuperLU's working
#: storage grows by doubling (8.4 GB measured for the two walks of the 115 326-DOF brake, 6.8e7
#: complex entries each: about 3 x 16 bytes per entry with the Krylov bases); PARDISO's L D L^T
#: stores one triangle in place.
_PEAK_PER_ENTRY = {"superlu": 3.0, "pardiso": 1.5}

_UNITS = {"": 1, "B": 1, "K": 2**10, "KB": 2**10, "KIB": 2**10, "M": 2**20, "MB": 2**20, "MIB": 2**20,
          "G": 2**30, "GB": 2**30, "GIB": 2**30, "T": 2**40, "TB": 2**40, "TIB": 2**40}


def parse_bytes(text: str, name: str = ENV_VAR) -> int:
    """A memory size from ``"16G"``, ``"500 MB"``, ``"2.5GiB"`` or a number of bytes.

    >>> parse_bytes("1.5G")
    1610612736
    """
    s = str(text).strip().upper().replace(" ", "")
    num = s.rstrip("KMGTIB")
    unit = s[len(num):]
    try:
        value = float(num) * _UNITS[unit]
    except (ValueError, KeyError):
        value = float("nan")
    if not (math.isfinite(value) and value > 0):
        raise InputError(f"{name}={text!r} must be a memory size > 0, e.g. 16G, 500M or a number of bytes.")
    return int(value)


def memory_limit() -> int:
    """Bytes a solve may use: 80 % of the lower of the available memory and ``SQUEALKIT_MEMORY``.

    Returns
    -------
    int
    """
    avail = available_memory()
    cap = os.environ.get(ENV_VAR, "").strip()
    if cap:
        avail = min(avail, parse_bytes(cap))
    return int(0.8 * avail)


def factor_entries(n: int, nnz: int) -> float:
    """Estimated entries of the sparse LU of an ``n x n`` FE matrix with ``nnz`` entries in a
    nested-dissection order (module docstring: ``n^(4/3)`` growth, calibrated on the built-in brake).

    Parameters
    ----------
    n : int
        Rows.
    nnz : int
        Entries of the matrix (its pattern: of M + C + K for a shifted matrix).

    Returns
    -------
    float
    """
    return max(1.0, _FILL_AT * (n / _FILL_N) ** (1.0 / 3.0)) * nnz


def _gib(nbytes: float) -> str:
    return f"{nbytes / 2**30:.1f} GiB" if nbytes >= 2**30 else f"{nbytes / 2**20:.0f} MiB"


def band_memory(n: int, nnz: int, *, k: int, workers: int, backend: str = "superlu") -> float:
    """Peak bytes of :func:`~squealkit.solvers.band.band_eigs`: per walk a complex factor of the
    shifted matrix and a Krylov basis of ``2n x (3k + 2)`` complex vectors, plus the matrices.

    Parameters
    ----------
    n, nnz : int
        Size of the model and entries of the pattern of ``M + C + K`` (about those of ``K``).
    k : int
        Eigenvalues per shift.
    workers : int
        Walks at once.
    backend : str
        ``"pardiso"`` or anything else (counted as SuperLU).

    Returns
    -------
    float
    """
    per_entry = _PEAK_PER_ENTRY.get(backend, _PEAK_PER_ENTRY["superlu"])
    factor = per_entry * 16.0 * factor_entries(n, nnz)
    basis = 2 * n * (3 * k + 2) * 16.0
    return workers * (factor + basis) + 3 * 12.0 * nnz


def subspace_memory(n: int, nnz: int, n_modes: int, *, n_band: int = 0, backend: str = "superlu",
                    factor_bytes: float | None = None) -> float:
    """Peak bytes of :func:`~squealkit.solvers.subspace.subspace_eigs`: a real factor of the
    stiffness, the Lanczos basis of ARPACK (``n x (2 n_modes + 1)``), the modes and one
    product with them, and the complex eigenvectors in the band.

    Parameters
    ----------
    n, nnz : int
        Size of the model and entries of ``K_sym`` (the pattern of ``K_sym - s M``).
    n_modes : int
        Real modes of the basis.
    n_band : int
        Complex eigenvectors returned.
    backend : str
        ``"pardiso"`` (a symmetric factor: one triangle) or anything else (SuperLU's LU).
    factor_bytes : float, optional
        The factorisation's peak where known (PARDISO predicts it after its analysis), instead
        of the fill estimate.

    Returns
    -------
    float
    """
    pardiso = backend == "pardiso"
    triangle = 0.5 if pardiso else 1.0  # L D L^T keeps one triangle
    factor = _PEAK_PER_ENTRY["pardiso" if pardiso else "superlu"] * 8.0 * triangle * factor_entries(n, nnz)
    if factor_bytes is not None:
        factor = float(factor_bytes)
    lanczos = n * (2 * n_modes + 1) * 8.0
    modes = 2 * n * n_modes * 8.0
    copies = 2 * 12.0 * nnz  # K_sym - s M and its triangle, 12 bytes an entry
    return factor + lanczos + modes + n * n_band * 16.0 + copies


def check_fits(nbytes: float, what: str, hint: str = "") -> None:
    """Refuse ``what`` (one line naming the estimate and the limit, then ``hint``) if ``nbytes``
    exceeds :func:`memory_limit`.

    Raises
    ------
    InputError
    """
    limit = memory_limit()
    if nbytes > limit:
        cap = os.environ.get(ENV_VAR, "").strip()
        source = f"{ENV_VAR}={cap}" if cap else "available now"
        tail = f" {hint}" if hint else ""
        raise InputError(f"{what} needs about {_gib(nbytes)} of memory; the limit is {_gib(limit)} (80 % of "
                         f"{source}).{tail}")

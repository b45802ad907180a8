"""Data files shipped with squealkit.

``nlevp/``: NLEVP's ``disk_brake100`` problem (BSD-3-Clause; its licence, ``LICENSE-nlevp.txt``,
travels with it), a 100-DOF quadratic eigenvalue problem reduced from an industrial FE disc
brake model (Graebner, Mehrmann, Quraishi, Schroeder, von Wagner, ZAMM 96(12):1388-1405, 2016).
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["nlevp_path"]

_HERE = Path(__file__).resolve().parent


def nlevp_path(name: str = "disk_brake100.mat") -> Path:
    """Path of a shipped NLEVP file (``disk_brake100.mat``, ``disk_brake100.m``, ``LICENSE-nlevp.txt``).

    Parameters
    ----------
    name : str, default "disk_brake100.mat"
        File name in the shipped ``nlevp`` folder.

    Returns
    -------
    Path
        The file's absolute path.

    Raises
    ------
    InputError
        If no such file is shipped (the message lists the known ones).
    """
    p = _HERE / "nlevp" / name
    if not p.is_file():
        from .._validation import InputError

        known = ", ".join(sorted(f.name for f in p.parent.iterdir()))
        raise InputError(f"No shipped NLEVP file {name!r}; known: {known}.")
    return p

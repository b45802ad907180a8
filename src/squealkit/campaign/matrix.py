"""The test matrix: one row per brake application (SAE J2521-like dynamometer campaigns).

A CSV with a header row. Required columns: ``application`` (a unique id) and ``file`` (the
recording, relative to the matrix's folder or absolute). Known optional columns: ``section``,
``mode`` (``drag`` or ``stop``), ``pressure_bar``, ``temperature_c``, ``speed_kmh`` and
``rpm`` (the disc speed when there is no tacho). Any other column is kept as text.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass, field
from pathlib import Path

from .._validation import InputError

__all__ = ["Application", "read_matrix"]

_NUMBERS = ("pressure_bar", "temperature_c", "speed_kmh", "rpm")
_MODES = ("drag", "stop")


@dataclass(frozen=True)
class Application:
    """One brake application of the matrix (conditions in SI-adjacent units named in the field).

    Attributes
    ----------
    application : str
        Unique id of the application.
    file : Path
        Its recording (made absolute against the matrix's folder by :func:`read_matrix`).
    section : str
        Section of the test programme (``""`` when not given).
    mode : {"drag", "stop", ""}
        Kind of application (``""`` when not given).
    pressure_bar, temperature_c, speed_kmh : float
        Brake pressure [bar], temperature [degC] and vehicle speed [km/h]; NaN when not given.
    rpm : float
        Disc speed [rev/min] where there is no tacho; NaN when not given.
    extra : dict of str to str
        Any other column of the matrix, as text.
    """

    application: str
    file: Path
    section: str = ""
    mode: str = ""
    pressure_bar: float = math.nan
    temperature_c: float = math.nan
    speed_kmh: float = math.nan
    rpm: float = math.nan
    extra: dict[str, str] = field(default_factory=dict)


def read_matrix(path: str | Path) -> tuple[Application, ...]:
    """Read and check a test matrix CSV (see the module docstring for its columns).

    Parameters
    ----------
    path : str or Path
        The matrix CSV (UTF-8, header row).

    Returns
    -------
    tuple of Application
        One per row, in file order.

    Raises
    ------
    InputError
        If the file is missing or empty, lacks the ``application`` or ``file`` column, or a
        row has an empty or repeated id, no file, an unknown mode or a non-numeric condition;
        the message names the line.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (d / "m.csv").write_text("application,file,mode,temperature_c\\nA1,a1.nc,drag,150\\n")
    >>> read_matrix(d / "m.csv")[0].temperature_c
    150.0
    """
    p = Path(path)
    if not p.is_file():
        raise InputError(f"Test matrix {str(p)!r} does not exist.")
    with open(p, newline="", encoding="utf-8-sig") as fh:
        rows = list(csv.DictReader(fh))
    if not rows:
        raise InputError(f"Test matrix {str(p)!r} has no application rows.")
    cols = set(rows[0])
    for c in ("application", "file"):
        if c not in cols:
            raise InputError(f"Test matrix {str(p)!r} has no {c!r} column (columns: {', '.join(sorted(cols))}).")
    apps, seen = [], set()
    for line, r in enumerate(rows, start=2):
        app = (r.get("application") or "").strip()
        if not app:
            raise InputError(f"Test matrix {str(p)!r} line {line}: empty application.")
        if app in seen:
            raise InputError(f"Test matrix {str(p)!r} line {line}: application {app!r} appears twice.")
        seen.add(app)
        f = Path((r.get("file") or "").strip())
        if not str(f):
            raise InputError(f"Test matrix {str(p)!r} line {line}: application {app!r} has no file.")
        mode = (r.get("mode") or "").strip().lower()
        if mode and mode not in _MODES:
            raise InputError(f"Test matrix {str(p)!r} line {line}: mode={mode!r} must be 'drag' or 'stop'.")
        nums = {}
        for c in _NUMBERS:
            text = (r.get(c) or "").strip()
            try:
                nums[c] = float(text) if text else math.nan
            except ValueError:
                raise InputError(f"Test matrix {str(p)!r} line {line}: {c}={text!r} is not a number.") from None
        extra = {k: str(v) for k, v in r.items()
                 if k not in ("application", "file", "section", "mode", *_NUMBERS) and k is not None}
        apps.append(Application(app, f if f.is_absolute() else (p.parent / f), (r.get("section") or "").strip(),
                                mode, extra=extra, **nums))
    return tuple(apps)

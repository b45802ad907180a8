"""The test matrix: one row per brake application (SAE J2521-like dynamometer campaigns).

A CSV with a header row. Required columns: ``application`` (a unique id) and ``file`` (the
recording, relative to the matrix's folder or absolute). Known optional columns: ``section``,
``mode`` (``drag`` or ``stop``), ``pressure_bar``, ``temperature_c``, ``speed_kmh`` and
``rpm`` (the disc speed when there is no tacho) and ``mu`` (the friction coefficient the
dynamometer reports for the application). Any other column is kept as text.
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass, field
from pathlib import Path

from .._validation import InputError

__all__ = ["Application", "read_matrix"]

#: The numeric columns and the values each accepts (all finite): (lowest, lowest included, words).
_NUMBER_RANGES = {
    "pressure_bar": (0.0, True, ">= 0"),
    "temperature_c": (-273.15, True, ">= -273.15 (absolute zero)"),
    "speed_kmh": (0.0, True, ">= 0"),
    "rpm": (0.0, False, "> 0"),
    "mu": (0.0, True, ">= 0"),
}
_NUMBERS = tuple(_NUMBER_RANGES)
#: A matrix is a few MB of text at most (2,000 rows for a J2521 matrix are 200 kB).
_MAX_BYTES = 64 * 2**20
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
    mu : float
        Friction coefficient the dynamometer reports for the application [1]; NaN when not given.
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
    mu: float = math.nan
    extra: dict[str, str] = field(default_factory=dict)


def read_matrix(path: str | Path) -> tuple[Application, ...]:
    """Read and check a test matrix CSV (see the module docstring for its columns).

    Parameters
    ----------
    path : str or Path
        The matrix CSV (UTF-8, header row; another encoding is refused, not guessed).

    Returns
    -------
    tuple of Application
        One per row, in file order.

    Raises
    ------
    InputError
        If the file is missing, empty, binary or not UTF-8, lacks the ``application`` or
        ``file`` column, or a row has an empty or repeated id, no file, an unknown mode or a
        condition that is not a finite number in its range (``rpm > 0``, ``pressure_bar`` and
        ``speed_kmh`` and ``mu >= 0``, ``temperature_c >= -273.15``); the message names the line.

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
    rows = list(csv.DictReader(io.StringIO(_read_text(p), newline="")))
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
        f_text = (r.get("file") or "").strip()
        if not f_text:  # (Path("") is ".": check the text)
            raise InputError(f"Test matrix {str(p)!r} line {line}: application {app!r} has no file.")
        f = Path(f_text)
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
            low, inclusive, words = _NUMBER_RANGES[c]
            x = nums[c]
            if text and not (math.isfinite(x) and (x >= low if inclusive else x > low)):
                raise InputError(f"Test matrix {str(p)!r} line {line}: column {c}={text!r} must be finite and "
                                 f"{words} (application {app!r}).")
        extra = {k: str(v) for k, v in r.items()
                 if k not in ("application", "file", "section", "mode", *_NUMBERS) and k is not None}
        apps.append(Application(app, f if f.is_absolute() else (p.parent / f), (r.get("section") or "").strip(),
                                mode, extra=extra, **nums))
    return tuple(apps)


def _read_text(p: Path) -> str:
    """The matrix's text: UTF-8 (a BOM allowed); anything else is refused, not guessed.

    A Latin-1 or Windows-1252 file is refused rather than decoded with a fallback: a guessed
    encoding can turn a file name into another one, and re-saving as UTF-8 is one step.
    """
    try:
        with open(p, "rb") as fh:
            raw = fh.read(_MAX_BYTES + 1)
    except OSError as e:
        raise InputError(f"Test matrix {str(p)!r} cannot be read: {e.strerror or e}.") from e
    if len(raw) > _MAX_BYTES:
        raise InputError(f"Test matrix {str(p)!r} is larger than {_MAX_BYTES // 2**20} MiB; a matrix is a CSV of "
                         "one row per application.")
    if b"\0" in raw[:8192]:
        raise InputError(f"Test matrix {str(p)!r} is not a text CSV (binary data: a NUL byte near the start).")
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        line = raw[: e.start].count(b"\n") + 1
        raise InputError(f"Test matrix {str(p)!r} line {line}: byte 0x{raw[e.start]:02x} is not UTF-8; "
                         "save the matrix as UTF-8 (the encoding is not guessed).") from None

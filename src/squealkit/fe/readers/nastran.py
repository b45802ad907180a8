"""Nastran DMIG matrices (direct matrix input at grid points), from bulk data or a punch file.

A DMIG matrix is a header card and one card per column (MSC/NX Quick Reference Guide, DMIG)::

    DMIG  NAME  0   IFO  TIN  TOUT  POLAR        NCOL
    DMIG  NAME  GJ  CJ        G1    C1     A1    B1
          G2    C2  A2   B2   -etc.-

``IFO`` 6 is symmetric (one triangle given), 1 square, 9 or 2 rectangular; ``TIN`` 1/2 real
single/double, 3/4 complex; each entry is addressed by grid ``G`` and component ``C`` (1-6;
0 for a scalar point). Cards are small field (8 characters), large field (``DMIG*``, 16
characters, ``*`` continuations, as punch files are) or free field (commas).

The field layout is the one pyNastran's ``DMIG._add_column`` reads (index 5 + 4 i: ``G, C, A, B``);
pyNastran's BDF reader itself does not import with NumPy >= 2.4 (``np.in1d`` was removed), so
the cards are split here.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ..._validation import InputError
from ..dofmap import LabelledMatrix

__all__ = ["bulk_cards", "read_dmig", "sniff_dmig"]

_DMIG_LINE = re.compile(r"^DMIG\*?\s*[,\s]", re.IGNORECASE | re.MULTILINE)
_IMPLICIT_EXP = re.compile(r"^([-+]?(?:\d+\.?\d*|\.\d+))([-+]\d+)$")


def sniff_dmig(head: str) -> bool:
    """Whether a text holds a DMIG card (a line starting ``DMIG``, ``DMIG*`` or ``DMIG,``)."""
    return bool(_DMIG_LINE.search(head))


def _real(text: str, where: str) -> float:
    s = text.strip().upper().replace("D", "E")
    try:
        return float(s)
    except ValueError:
        m = _IMPLICIT_EXP.match(s)  # Nastran's 1.5+3 = 1.5e3
        if m:
            return float(f"{m.group(1)}E{m.group(2)}")
        raise InputError(f"{where}: {text.strip()!r} is not a real number.") from None


def _int(text: str, where: str, blank: int | None = None) -> int:
    s = text.strip()
    if not s and blank is not None:
        return blank
    try:
        return int(s)
    except ValueError:
        raise InputError(f"{where}: {text.strip()!r} is not an integer.") from None


def _fields(line: str) -> tuple[str, list[str]]:
    """(first field, data fields) of one physical line: 8 data fields (small, free), 4 (large)."""
    if "," in line:
        parts = line.rstrip("\n").split(",")
        data = [x.strip() for x in parts[1:9]]
        return parts[0].strip(), data + [""] * (8 - len(data))
    line = line.rstrip("\n").expandtabs(8)
    first = line[:8].strip()
    if first.endswith("*") or first.startswith("*"):
        return first, [line[8 + 16 * k: 24 + 16 * k].strip() for k in range(4)]
    return first, [line[8 + 8 * k: 16 + 8 * k].strip() for k in range(8)]


def bulk_cards(text: str, names: tuple[str, ...] = ("DMIG",)) -> list[tuple[int, list[str]]]:
    """(line number, fields) of every card named in ``names``: the card name first, continuations joined.

    Bulk data after ``BEGIN BULK`` (or the whole text, as a punch file has no executive part)
    up to ``ENDDATA``; comments (``$``) skipped; small, large and free field.
    """
    lines = text.splitlines()
    start = next((k + 1 for k, line in enumerate(lines) if line.strip().upper().startswith("BEGIN BULK")), 0)
    cards: list[tuple[int, list[str]]] = []
    current: list[str] | None = None
    for k in range(start, len(lines)):
        line = lines[k]
        stripped = line.split("$", 1)[0]
        if not stripped.strip():
            continue
        if stripped.strip().upper().startswith("ENDDATA"):
            break
        first, data = _fields(stripped)
        is_continuation = first == "" or first[0] in "+*"
        if is_continuation:
            if current is not None:
                current.extend(data)
            continue
        current = None
        card = first.upper().rstrip("*")
        if card in names:
            current = [card, *data]
            cards.append((k + 1, current))
    return cards


def read_dmig(path: str | Path) -> dict[str, LabelledMatrix]:
    """The DMIG matrices of a Nastran bulk data or punch file, by name.

    Parameters
    ----------
    path : path
        A ``.bdf``/``.dat``/``.pch`` file with DMIG cards (other cards are ignored).

    Returns
    -------
    dict of str to LabelledMatrix
        ``{name: matrix}``, entries labelled ``(grid, component)``; ``IFO=6`` matrices are one
        triangle of a symmetric matrix.

    Raises
    ------
    InputError
        One line naming the file and line: a column before its header, a field that is not a
        number, a complex matrix (``TIN`` 3 or 4), an unknown ``IFO``.
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="latin-1")
    except OSError as e:
        raise InputError(f"{p.name}: cannot be read: {e}") from e
    headers: dict[str, tuple[int, int]] = {}
    entries: dict[str, list[tuple[int, int, int, int, float]]] = {}
    for line_no, card in bulk_cards(text):
        where = f"{p.name} line {line_no}"
        card = card + [""] * max(0, 9 - len(card))
        name = card[1].strip().upper()
        if not name:
            raise InputError(f"{where}: a DMIG card without a matrix name.")
        if card[2].strip() == "0":
            ifo, tin = _int(card[3], f"{where} (IFO)"), _int(card[4], f"{where} (TIN)")
            if ifo not in (1, 2, 6, 9):
                raise InputError(f"{where}: DMIG {name} has IFO={ifo}; known: 1 (square), 6 (symmetric), "
                                 "2 or 9 (rectangular).")
            if tin in (3, 4):
                raise InputError(f"{where}: DMIG {name} is complex (TIN={tin}); FE matrices must be real.")
            if tin not in (1, 2):
                raise InputError(f"{where}: DMIG {name} has TIN={tin}; known: 1, 2 (real), 3, 4 (complex).")
            headers[name] = (ifo, tin)
            entries.setdefault(name, [])
            continue
        if name not in headers:
            raise InputError(f"{where}: a DMIG {name} column before its header card (NAME, 0, IFO, TIN, ...).")
        gj, cj = _int(card[2], f"{where} (GJ)"), _int(card[3], f"{where} (CJ)", blank=0)
        rest = card[5:]
        for k in range(0, len(rest), 4):
            group = rest[k:k + 4] + [""] * max(0, 4 - len(rest[k:k + 4]))
            if not any(x.strip() for x in group):
                continue
            gi, ci = _int(group[0], f"{where} (G)"), _int(group[1], f"{where} (C)", blank=0)
            entries[name].append((gi, ci, gj, cj, _real(group[2], f"{where} (A)")))
    if not headers:
        raise InputError(f"{p.name}: no DMIG header card (DMIG, NAME, 0, IFO, TIN, ...).")
    out = {}
    for name, rows in entries.items():
        if not rows:
            raise InputError(f"{p.name}: DMIG {name} has a header but no entries.")
        a = np.array([r[:4] for r in rows], dtype=np.int64)
        v = np.array([r[4] for r in rows], dtype=np.float64)
        out[name] = LabelledMatrix(a[:, 0], a[:, 1], a[:, 2], a[:, 3], v, symmetric=headers[name][0] == 6,
                                   source=f"{p.name} ({name})")
    return out

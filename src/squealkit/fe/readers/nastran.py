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
from .._bulk import bulk_cards, field_int, field_real
from ..dofmap import LabelledMatrix

__all__ = ["read_dmig"]

_DMIG_LINE = re.compile(r"^DMIG\*?\s*[,\s]", re.IGNORECASE | re.MULTILINE)


def sniff_dmig(head: str) -> bool:
    """Whether a text holds a DMIG card (a line starting ``DMIG``, ``DMIG*`` or ``DMIG,``)."""
    return bool(_DMIG_LINE.search(head))


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
            ifo, tin = field_int(card[3], f"{where} (IFO)"), field_int(card[4], f"{where} (TIN)")
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
        gj, cj = field_int(card[2], f"{where} (GJ)"), field_int(card[3], f"{where} (CJ)", blank=0)
        rest = card[5:]
        for k in range(0, len(rest), 4):
            group = rest[k:k + 4] + [""] * max(0, 4 - len(rest[k:k + 4]))
            if not any(x.strip() for x in group):
                continue
            gi, ci = field_int(group[0], f"{where} (G)"), field_int(group[1], f"{where} (C)", blank=0)
            entries[name].append((gi, ci, gj, cj, field_real(group[2], f"{where} (A)")))
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

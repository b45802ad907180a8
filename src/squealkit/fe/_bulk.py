"""Nastran bulk data cards split into fields (small, large and free field), shared by the DMIG
reader (:mod:`squealkit.fe.readers.nastran`) and the mesh reader (:mod:`squealkit.fe.mesh`).

Field rules: MSC/NX Nastran Quick Reference Guide, "Bulk Data Entry Format"; the small field is
8 characters, the large field (``NAME*``) 16 with ``*`` continuations, free field comma-separated.
"""

from __future__ import annotations

import re

from .._validation import InputError

__all__ = ["bulk_cards", "field_int", "field_real"]

_IMPLICIT_EXP = re.compile(r"^([-+]?(?:\d+\.?\d*|\.\d+))([-+]\d+)$")


def field_real(text: str, where: str) -> float:
    """A real field (``1.5``, ``1.5D3``, Nastran's ``1.5+3``), or one line naming ``where``."""
    s = text.strip().upper().replace("D", "E")
    try:
        return float(s)
    except ValueError:
        m = _IMPLICIT_EXP.match(s)  # Nastran's 1.5+3 = 1.5e3
        if m:
            return float(f"{m.group(1)}E{m.group(2)}")
        raise InputError(f"{where}: {text.strip()!r} is not a real number.") from None


def field_int(text: str, where: str, blank: int | None = None) -> int:
    """An integer field (``blank`` for an empty one when given), or one line naming ``where``."""
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

"""Which labelled format a file holds, from its content, and its reader.

Abaqus ``*MATRIX OUTPUT`` text (MATRIX INPUT or COORDINATE), Nastran DMIG cards (bulk data or
punch), ANSYS Harwell-Boeing (HBMAT, with its ``.mapping`` file) and ANSYS ``.full``. A file of
none of these is left to the unlabelled readers (Matrix Market, ``.mat``, OP4).
"""

from __future__ import annotations

from pathlib import Path

from ..._validation import InputError
from ..dofmap import LabelledMatrix

__all__ = ["LABELLED_FORMATS", "read_labelled", "recognise"]

#: The formats recognised here, as named in messages.
LABELLED_FORMATS = ("Abaqus MATRIX INPUT", "Abaqus COORDINATE", "Nastran DMIG", "ANSYS Harwell-Boeing",
                    "ANSYS .full")
_HEAD_BYTES = 8192


def recognise(path: str | Path) -> str | None:
    """The labelled format of a file from its first bytes (one of :data:`LABELLED_FORMATS`), or None."""
    from .abaqus import sniff_abaqus
    from .ansys import sniff_full, sniff_hb
    from .nastran import sniff_dmig

    p = Path(path)
    with open(p, "rb") as f:
        head = f.read(_HEAD_BYTES)
    if sniff_full(head):
        return "ANSYS .full"
    if b"\0" in head:
        return None
    text = head.decode("latin-1")
    if text.lstrip().startswith("%%MatrixMarket"):
        return None
    kind = sniff_abaqus(text)
    if kind is not None:
        return f"Abaqus {kind.upper()}"
    if sniff_dmig(text):
        return "Nastran DMIG"
    if sniff_hb(text):
        return "ANSYS Harwell-Boeing"
    return None


def read_labelled(path: str | Path) -> dict[str, LabelledMatrix] | None:
    """The labelled matrices of a file by name, or None when its content is none of :data:`LABELLED_FORMATS`."""
    p = Path(path)
    try:
        fmt = recognise(p)
    except OSError as e:
        raise InputError(f"{p.name}: cannot be read: {e}") from e
    if fmt is None:
        return None
    if fmt.startswith("Abaqus"):
        from .abaqus import read_abaqus_matrix

        return read_abaqus_matrix(p)
    if fmt == "Nastran DMIG":
        from .nastran import read_dmig

        return read_dmig(p)
    from .ansys import read_full, read_hb

    return read_full(p) if fmt == "ANSYS .full" else read_hb(p)

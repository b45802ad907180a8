"""What stands at an output path, and whether squealkit wrote it: manifests and the names of staged files.

Only a manifest makes a file or folder squealkit's: a folder holding other files is never replaced or
emptied, and a device, a fifo or a socket is never replaced (:func:`_refuse_replacing`).
"""

from __future__ import annotations

import json
import os
import re
import stat
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from .._validation import InputError

__all__ = ["MANIFEST", "ZARR_MANIFEST", "final_name"]


#: Written into every folder squealkit fills (reports, zarr stores, campaigns): the files it
#: wrote there. A folder, or a file in one, is squealkit's only if a manifest lists it.
MANIFEST = ".squealkit-manifest.json"


#: The manifest of a zarr store: a hidden zarr group whose attributes list the files (zarr
#: warns about any other file it finds in a store; a group it reads, and xarray ignores).
ZARR_MANIFEST = ".squealkit/zarr.json"


_MANIFESTS = (MANIFEST, ZARR_MANIFEST)


#: Staging folders inside an output folder that stays (see :func:`output_folder`).
_STAGE_PREFIX = ".squealkit-stage."


#: Beside an output while a run writes it: the lock that keeps a second run out.
_LOCK_SUFFIX = ".squealkit-lock"


#: The names :func:`tempfile.mkstemp` gives staged outputs (``.NAME.XXXXXXXX.part``).
_STAGED_NAME = re.compile(r"^\..+\.[a-z0-9_]{8}\.part$")


def _where(path: Path) -> Path:
    return path.parent if str(path.parent) else Path(".")


def _resolve(path: str | Path) -> Path:
    """The output ``path`` names: a symbolic link stands for what it points to, which is
    written (staged beside it), the link kept."""
    p = Path(path)
    return Path(os.path.realpath(p)) if p.is_symlink() else p


def _kind(path: Path) -> str | None:
    """What stands at ``path``: None (nothing), ``"file"``, ``"folder"``, or what else it is."""
    try:
        mode = os.stat(path).st_mode
    except (FileNotFoundError, NotADirectoryError):
        return None
    if stat.S_ISREG(mode):
        return "file"
    if stat.S_ISDIR(mode):
        return "folder"
    return {stat.S_IFCHR: "a character device", stat.S_IFBLK: "a block device", stat.S_IFIFO: "a named pipe (fifo)",
            stat.S_IFSOCK: "a socket"}.get(stat.S_IFMT(mode), "not a regular file")


def final_name(path: str) -> str:
    """``path`` with squealkit's staging names replaced by the outputs they stand for (for
    messages: an error while writing a staged file names the output the user asked for)."""
    path = re.sub(r"(^|/)\.([^/]+)\.[a-z0-9_]{8}\.part(?=/|$)", r"\1\2", path)
    return re.sub(r"/" + re.escape(_STAGE_PREFIX) + r"[a-z0-9_]{8}(?=/|$)", "", path)


def _transient(name: str) -> bool:
    """A name squealkit gives its staged outputs and locks (left only by a killed run)."""
    base = name.rsplit("/", 1)[-1]
    return bool(_STAGED_NAME.match(base)) or base.endswith(_LOCK_SUFFIX) or base.startswith(".squealkit-probe.")


def _folder_files(folder: Path) -> tuple[list[str], set[str]]:
    """(every file below ``folder``, those squealkit's manifests list), relative posix names.

    A manifest lists the files of its own folder and below, so a squealkit output inside
    another one (a campaign's results in its recordings' folder) counts as squealkit's too.
    Symbolic links are entries, never followed.
    """
    names: list[str] = []
    listed: set[str] = set()
    for root, dirs, files in os.walk(folder):
        here = Path(root)
        rel = here.relative_to(folder)
        links = [d for d in dirs if (here / d).is_symlink()]
        dirs[:] = [d for d in dirs if d not in links and not d.startswith(_STAGE_PREFIX)]
        if MANIFEST in files or ".squealkit" in dirs:
            listed |= {(rel / n).as_posix() for n in [*_read_manifest(here), *_MANIFESTS]}
        names += [(rel / n).as_posix() for n in [*files, *links]]
    return names, listed


def _owned_folder(folder: Path) -> tuple[bool, list[str]]:
    """(squealkit's, foreign files) of an existing folder: empty, or every file in it listed
    in a squealkit manifest. A zarr store, or any other marker, does not make it squealkit's."""
    names, listed = _folder_files(folder)
    foreign = sorted(n for n in names if n not in listed and not _transient(n))
    return not foreign, foreign


def _read_manifest(folder: Path) -> list[str]:
    """The files squealkit's manifest in ``folder`` lists (none without one)."""
    for name in _MANIFESTS:
        try:
            doc = json.loads((folder / name).read_text(encoding="utf-8"))
            if name == ZARR_MANIFEST:
                doc = doc["attributes"]
            return [str(x) for x in doc["files"]]
        except (OSError, ValueError, AttributeError, KeyError, TypeError):
            continue
    return []


def _write_manifest(folder: Path, files: list[str]) -> None:
    """List ``files`` as squealkit's in ``folder`` (replacing its manifest whole)."""
    from .. import __version__

    doc: dict[str, Any] = {"written_by": f"squealkit {__version__}", "files": [f for f in files if f not in _MANIFESTS]}
    name = MANIFEST
    if any((folder / m).is_file() for m in ("zarr.json", ".zgroup")):  # a zarr store squealkit wrote
        name = ZARR_MANIFEST
        (folder / ".squealkit").mkdir(exist_ok=True)
        doc = {"zarr_format": 3, "node_type": "group", "attributes": doc}
    part = folder / f".{Path(name).name}.{os.getpid()}.part"
    part = part if name == MANIFEST else folder / ".squealkit" / part.name
    part.write_text(json.dumps(doc, indent=1), encoding="utf-8")
    os.replace(part, folder / name)


def _files_below(folder: Path) -> list[str]:
    """Every file below ``folder`` but its own manifest, relative posix names."""
    names = (p.relative_to(folder).as_posix() for p in folder.rglob("*") if not p.is_dir())
    return sorted(n for n in names if n not in _MANIFESTS)


def _shown(names: list[str]) -> str:
    return ", ".join(names[:3]) + (f" and {len(names) - 3} more" if len(names) > 3 else "")


def _refuse_replacing(final: Path, directory: bool, *, force: bool = False) -> None:
    """One-line ``InputError`` if writing ``final`` would replace what squealkit did not write:
    anything but a regular file or folder (a device, a fifo, a socket), a file by a folder or
    a folder by a file, a folder holding files no squealkit manifest lists (unless ``force``)."""
    kind = _kind(final)
    if kind is None:
        return
    if kind not in ("file", "folder"):
        raise InputError(f"Output {str(final)!r} is {kind}, not a regular file; squealkit never replaces it.")
    if kind == "folder" and not directory:
        raise InputError(f"Output {str(final)!r} is a folder; give a file name.")
    if kind == "file" and directory:
        raise InputError(f"Output {str(final)!r} is a file; give a folder name (squealkit never replaces a file "
                         "by a folder).")
    if kind == "folder" and not force:
        ok, foreign = _owned_folder(final)
        if not ok:
            raise InputError(
                f"Output folder {str(final)!r} holds files squealkit did not write ({_shown(foreign)}); choose a "
                "new or empty folder, or pass --force to write beside them (they are never deleted).")


def _foreign_among(final: Path, names: Iterable[str]) -> list[str]:
    """Those of ``names`` (files or folders in ``final``) that are, or hold, files squealkit did not write."""
    if not final.is_dir():
        return []
    every, listed = _folder_files(final)
    out = []
    for name in names:
        inside = [n for n in every if n == name or n.startswith(name.rstrip("/") + "/")]
        out += [n for n in inside if n not in listed and not _transient(n)]
    return sorted(set(out))


def _clash_message(final: Path, clash: list[str]) -> str:
    return (f"Output folder {str(final)!r} holds your own {_shown(clash)}; squealkit does not replace them, even "
            "with --force: move them or choose another folder.")

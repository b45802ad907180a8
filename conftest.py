"""Collection rules for the whole repository (``--doctest-modules`` walks ``src`` too)."""

from pathlib import Path


def pytest_ignore_collect(collection_path: Path, config) -> bool | None:
    """Skip the import shims left at moved modules' old paths (their docstring starts "Moved to"):
    importing one warns by design, and they hold no doctest of their own."""
    if collection_path.suffix == ".py" and "src" in collection_path.parts:
        with open(collection_path, encoding="utf-8") as f:
            if f.read(12) == '"""Moved to ':
                return True
    return None

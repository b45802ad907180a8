"""Optional dependencies: imported where they are used, with one line saying how to install them.

squealkit's core (models, stability, transients, recordings in netCDF, CSV, WAV and TDMS,
reports) needs only its declared dependencies. The industry formats, the built-in FE brake,
campaign stores, Dask clusters and the faster sparse LU come with extras; a command that
needs one that is missing stops with :class:`~squealkit._validation.InputError` (exit code 2
on the command line), naming the package and the extra that brings it, never a traceback.

Every import of an optional package in squealkit goes through :func:`require` (checked by
``tests/test_optional_dependencies.py``).
"""

from __future__ import annotations

import importlib
from types import ModuleType

from ._validation import InputError

__all__: list[str] = []

#: Optional top-level module -> (the PyPI distribution, squealkit's extra that installs it).
OPTIONAL: dict[str, tuple[str, str]] = {
    "asammdf": ("asammdf", "daq"),
    "pyuff": ("pyuff", "daq"),
    "skfem": ("scikit-fem", "fe"),
    "meshio": ("meshio", "mesh"),
    "duckdb": ("duckdb", "campaign"),
    "distributed": ("dask.distributed", "distributed"),
    "pypardiso": ("pypardiso", "fast"),
    "pyNastran": ("pyNastran", "nastran"),
    "ansys": ("ansys-mapdl-reader", "ansys"),
}


def require(module: str, purpose: str) -> ModuleType:
    """Import an optional module, or say in one line what to install.

    Parameters
    ----------
    module : str
        The module to import, e.g. ``"asammdf"`` or ``"ansys.mapdl.reader"``; its top-level
        package must be one of :data:`OPTIONAL`.
    purpose : str
        What needs it, as the start of a sentence: ``"Writing MDF4"``.

    Returns
    -------
    module
        The imported module.

    Raises
    ------
    InputError
        If it cannot be imported: "Writing MDF4 needs asammdf: pip install 'squealkit[daq]'."
    """
    dist, extra = OPTIONAL[module.split(".")[0]]
    try:
        return importlib.import_module(module)
    except ImportError as e:
        raise InputError(f"{purpose} needs {dist}: pip install 'squealkit[{extra}]'.") from e


def available(module: str) -> bool:
    """Whether an optional module can be imported (for output that is written only when it is there).

    Parameters
    ----------
    module : str
        As for :func:`require`.

    Returns
    -------
    bool
    """
    try:
        require(module, "")
    except InputError:
        return False
    return True

"""Optional dependencies: imported where they are used, with one line saying how to install them.

squealkit's core (models, stability, transients, recordings in netCDF, CSV, WAV and TDMS,
reports) needs only its declared dependencies. The industry formats, the built-in FE brake,
campaign stores, Dask clusters and the faster sparse LU come with extras; a command that
needs one that is missing stops with :class:`~squealkit._validation.InputError` (exit code 2
on the command line), naming the package and the extra that brings it, never a traceback.

Every import of an optional package in squealkit goes through :func:`require`, and every question
"is it there?" through :func:`available` (both checked by ``tests/test_optional_dependencies.py``).
A package counts as available only if it imports: one found on the path whose import fails (a
broken install, a shared library missing, as pypardiso without MKL) is not, so that what
squealkit picks on its own (the ``"auto"`` LU backend, the FE report's VTK files) never picks it.
"""

from __future__ import annotations

import importlib
import importlib.util
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
    except OSError as e:  # installed, but a shared library it loads is missing
        raise InputError(f"{purpose} needs {dist}, which is installed but does not import ({e}): reinstall it "
                         f"(pip install --force-reinstall 'squealkit[{extra}]').") from e


def available(module: str) -> bool:
    """Whether a module can be used: it is installed and it imports.

    The one check squealkit makes before choosing something optional (output written only when a
    package is there, a backend picked only when it works). ``importlib.util.find_spec`` first
    answers "not installed" without importing anything; a module it finds is then imported, since
    only the import tells a working install from a broken one (and using it imports it anyway).

    Parameters
    ----------
    module : str
        A module name, e.g. ``"meshio"`` or ``"ansys.mapdl.reader"`` (one of :data:`OPTIONAL` or any
        other, e.g. what a registered LU backend requires).

    Returns
    -------
    bool
    """
    try:
        if importlib.util.find_spec(module) is None:
            return False
        importlib.import_module(module)
    except (ImportError, OSError, ValueError):  # ValueError: a module in sys.modules without a spec
        return False
    return True

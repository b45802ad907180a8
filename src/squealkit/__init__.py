"""squealkit: predict and diagnose friction-induced disc brake squeal.

Built on Lv, Zhang & Yu, "Influence of surface run-out on disc brake squeal",
J. Vibroengineering 15(2), 2013.

Modules
-------
squealkit.models      the paper's 3-DOF model, Hoffmann's 2-DOF model, matrix models,
                      rig-derived parameters, TOML model files
squealkit.stability   complex eigenvalues over parameter grids, mode tracking, critical
                      friction, run-out tolerance, sensitivity
squealkit.plotting    figures (imported lazily; computation never imports it)
squealkit.io          atomic saving and loading of results
"""

__version__ = "0.1.0"

from ._validation import InputError, InputTypeError

__all__ = ["InputError", "InputTypeError", "__version__"]

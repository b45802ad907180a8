"""Models of friction-coupled brake systems (paper §2) and their parameters (§3, §5.1)."""

from ..fe.model import FEModel
from ..fe.readers import load_fe_model
from ._base import FrictionModel, SystemMatrices
from .config import (
    PRESETS,
    build_model,
    get_preset,
    load_model,
    load_rig,
    load_rig_model,
    model_from_dict,
    parse_assignments,
)
from .friction import Stribeck
from .hoffmann import Hoffmann2002
from .matrix import MatrixModel
from .pin_on_disc import PinOnDisc3DOF
from .rig import (
    PinOnDiscRig,
    RigModel,
    cantilever_bending_frequency,
    contact_stiffness,
    modal_stiffness,
    rod_axial_frequency,
    rod_mass,
)

__all__ = [
    "PRESETS",
    "FEModel",
    "FrictionModel",
    "Hoffmann2002",
    "MatrixModel",
    "PinOnDisc3DOF",
    "PinOnDiscRig",
    "RigModel",
    "Stribeck",
    "SystemMatrices",
    "build_model",
    "cantilever_bending_frequency",
    "contact_stiffness",
    "get_preset",
    "load_fe_model",
    "load_model",
    "load_rig",
    "load_rig_model",
    "modal_stiffness",
    "model_from_dict",
    "parse_assignments",
    "rod_axial_frequency",
    "rod_mass",
]

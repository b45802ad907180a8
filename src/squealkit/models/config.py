"""Models from presets, TOML files and ``NAME=VALUE`` overrides.

A model file (all sections optional; SI units, angles in rad or as ``*_deg`` in degrees)::

    model = "pin_on_disc"      # pin_on_disc | hoffmann | matrix
    preset = "lv2013"          # start from a built-in preset

    [parameters]               # any parameter of the model
    mu_note = "friction is not a model parameter; it is swept"
    alpha_deg = 2.0
    c1 = 0.0
    kinematics = "consistent"  # or "paper" (the default): see PinOnDisc3DOF

    [rig]                      # or derive the pin-on-disc model from the rig (paper §5.1)
    pin_diameter = 0.030
    pin_length = 0.045
    pin_bending_freq = 2561.0  # omit to use beam theory

    [matrices]                 # model = "matrix": M, K0 (required), C, Kn, Kf, F0, fn, ff
    M = [[1.0, 0.0], [0.0, 1.0]]

Other top-level tables (``[simulation]``, ``[uncertain]``, ...) belong to other commands and
are ignored here.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from .._validation import InputError, validate_finite
from ._base import FrictionModel
from .hoffmann import Hoffmann2002
from .matrix import MatrixModel
from .pin_on_disc import PinOnDisc3DOF
from .rig import PinOnDiscRig

__all__ = ["PRESETS", "build_model", "get_preset", "load_model", "load_rig", "model_from_dict", "parse_assignments"]

#: Built-in presets: name -> (description, factory).
PRESETS: dict[str, tuple[str, Any]] = {
    "lv2013": (
        "Lv, Zhang & Yu (2013) pin-on-disc rig, 3 DOF (paper §3-4); the default",
        PinOnDisc3DOF,
    ),
    "hoffmann2002": (
        "Hoffmann et al. (2002) minimal 2-DOF mode-coupling model (illustrative values)",
        Hoffmann2002,
    ),
}

_MODEL_KINDS: dict[str, type[FrictionModel]] = {
    "pin_on_disc": PinOnDisc3DOF,
    "hoffmann": Hoffmann2002,
    "matrix": MatrixModel,
}
_PRESET_KIND = {"lv2013": "pin_on_disc", "hoffmann2002": "hoffmann"}
_TOP_KEYS = {"model", "preset", "parameters", "rig", "matrices", "description"}


def get_preset(name: str) -> FrictionModel:
    """The built-in model called ``name`` (see :data:`PRESETS`)."""
    if name not in PRESETS:
        raise InputError(f"Unknown preset {name!r}; known: {', '.join(PRESETS)}.")
    return PRESETS[name][1]()


def _rig_from_table(table: Mapping[str, Any]) -> PinOnDiscRig:
    known = {f for f in PinOnDiscRig.__dataclass_fields__ if not f.startswith("_")}
    kwargs: dict[str, Any] = {}
    for key, value in table.items():
        name = key
        if key == "alpha_deg":
            name, value = "alpha", math.radians(validate_finite(key, value))
        if name not in known:
            raise InputError(f"Unknown [rig] key {key!r}; known: {', '.join(sorted(known))}.")
        kwargs[name] = value
    try:
        return PinOnDiscRig(**kwargs)
    except TypeError as e:
        raise InputError(f"Bad [rig] table: {e}") from e


def model_from_dict(doc: Mapping[str, Any]) -> FrictionModel:
    """Build a model from a parsed model file (see the module docstring)."""
    unknown = set(doc) - _TOP_KEYS
    # Tables of other commands are allowed; stray scalar keys are typos.
    stray = sorted(k for k in unknown if not isinstance(doc[k], Mapping))
    if stray:
        raise InputError(f"Unknown top-level key {stray[0]!r} in model file; known: {', '.join(sorted(_TOP_KEYS))}.")
    preset = doc.get("preset")
    kind = doc.get("model", _PRESET_KIND.get(preset, "pin_on_disc") if preset else None)
    if kind is None:
        kind = "matrix" if "matrices" in doc else "pin_on_disc"
    if kind not in _MODEL_KINDS:
        raise InputError(f"Unknown model {kind!r}; known: {', '.join(_MODEL_KINDS)}.")
    if preset is not None and _PRESET_KIND.get(preset) not in (None, kind):
        raise InputError(f"Preset {preset!r} is a {_PRESET_KIND[preset]!r} model, not {kind!r}.")

    if kind == "matrix":
        mats = doc.get("matrices")
        if not isinstance(mats, Mapping):
            raise InputError("A matrix model needs a [matrices] table with at least M and K0.")
        allowed = {"M", "C", "K0", "Kn", "Kf", "F0", "fn", "ff", "sliding", "names"}
        for key in mats:
            if key not in allowed:
                raise InputError(f"Unknown [matrices] key {key!r}; known: {', '.join(sorted(allowed))}.")
        model: FrictionModel = MatrixModel(**dict(mats))
    elif "rig" in doc:
        if kind != "pin_on_disc":
            raise InputError("A [rig] table describes a pin-on-disc rig; set model = \"pin_on_disc\".")
        model = _rig_from_table(doc["rig"]).to_model()
    elif preset is not None:
        model = get_preset(preset)
    else:
        model = _MODEL_KINDS[kind]()

    params = doc.get("parameters", {})
    if not isinstance(params, Mapping):
        raise InputError("[parameters] must be a table of NAME = VALUE.")
    return model.replace(**params) if params else model


def _read_toml(path: str | Path) -> dict[str, Any]:
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise InputError(f"Model file {str(p)!r} does not exist.") from None
    except IsADirectoryError:
        raise InputError(f"Model file {str(p)!r} is a directory.") from None
    except (OSError, UnicodeDecodeError) as e:
        raise InputError(f"Model file {str(p)!r} cannot be read: {e}") from e
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise InputError(f"Model file {str(p)!r} is not valid TOML: {e}") from e
    return doc


def load_model(path: str | Path) -> FrictionModel:
    """Read a model file (TOML). Errors name the file and what is wrong in it."""
    p = Path(path)
    doc = _read_toml(p)
    try:
        return model_from_dict(doc)
    except InputError as e:
        raise InputError(f"{p.name}: {e}") from e


def load_rig(path: str | Path) -> PinOnDiscRig | None:
    """The rig described by a model file's ``[rig]`` table, or None if it has none."""
    doc = _read_toml(path)
    table = doc.get("rig")
    if table is None:
        return None
    try:
        return _rig_from_table(table)
    except InputError as e:
        raise InputError(f"{Path(path).name}: {e}") from e


def parse_assignments(items: Iterable[str]) -> dict[str, float | str]:
    """Parse ``NAME=VALUE`` strings (from ``--set``) into a dict of floats.

    A value that is not a number stays a string, for the model's options (``kinematics=consistent``);
    the model's own check then says whether the parameter takes it.
    """
    out: dict[str, float | str] = {}
    for item in items:
        name, sep, value = item.partition("=")
        name = name.strip()
        if not sep or not name:
            raise InputError(f"--set {item!r} is not NAME=VALUE.")
        try:
            out[name] = validate_finite(name, value.strip())
        except InputError:
            if _is_number(value.strip()):
                raise
            out[name] = value.strip()
    return out


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def build_model(
    preset: str | None = None, config: str | Path | None = None, overrides: Mapping[str, Any] | None = None
) -> FrictionModel:
    """The model a command works on: a preset or a model file, then overrides.

    With neither ``preset`` nor ``config`` the default preset ``lv2013`` is used.
    """
    if preset is not None and config is not None:
        raise InputError("Give either a preset or a model file, not both.")
    model = load_model(config) if config is not None else get_preset(preset or "lv2013")
    return model.replace(**overrides) if overrides else model

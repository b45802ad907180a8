"""Models from presets, TOML files and ``NAME=VALUE`` overrides.

A model file (all sections optional; SI units, angles in rad or as ``*_deg`` in degrees)::

    model = "pin_on_disc"      # pin_on_disc | hoffmann | matrix | fe
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

    [fe]                       # model = "fe": exported FE matrices (see squealkit/fe/)
    file = "brake.mat"         # all matrices in one file (.mat v5/v7.3, .op4, Nastran DMIG .bdf/.pch), or
    # files = {M = "M.mtx", K1 = "K1.mtx", KR = "KR.mtx"}     # one file per matrix
    names = {M = "MAA"}        # the names in the file where they differ (optional)
    disc_speed_ref = 1.0       # rad/s (formerly omega_ref); mu_ref, f_ref likewise (defaults 1)
    mesh = "brake.inp"         # optional: the mesh (.inp, .bdf, .cdb or meshio's), for modes --vtk
    dof_names = "dof_names.txt"  # optional: one DOF name per line (node12.x: mesh point 12, x)
    omit = ["DG"]              # matrices read but left out of the assembly (optional)

File paths are relative to the model file. An ``[uncertain]`` table belongs to
``montecarlo`` and a ``[report]`` table to ``report``; both are ignored here; any other
table or key is an error (a typo such as ``[paramters]`` must not silently give the
default model).
"""

from __future__ import annotations

import difflib
import math
import tomllib
import warnings
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from .._units import parse_quantity
from .._validation import InputError, validate_finite
from ..fe.model import FEModel
from ._base import FrictionModel
from .hoffmann import Hoffmann2002
from .matrix import MatrixModel
from .pin_on_disc import PinOnDisc3DOF
from .rig import PinOnDiscRig, RigModel

__all__ = ["PRESETS", "build_model", "get_preset", "load_model", "load_rig", "load_rig_model", "model_from_dict",
           "parse_assignments", "rig_model_from_dict"]

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
_TOP_KEYS = {"model", "preset", "parameters", "rig", "matrices", "fe", "description"}
#: Tables a model file may hold for other commands (``montecarlo`` reads ``[uncertain]``, ``report``
#: reads ``[report]``: see :mod:`squealkit.report.settings`; ``correlate`` reads ``[correlate]``:
#: see :mod:`squealkit.correlate.conditions`; ``design`` reads ``[design]``: see :mod:`squealkit.design.parameters`).
_OTHER_TABLES = {"uncertain", "report", "correlate", "design"}
#: A model file is text of a few kB (large matrices go in the files an [fe] table names).
_MAX_FILE_BYTES = 16 * 2**20

#: The type of each key a model file may hold, table by table (a mapping's values: ``"files.*"``).
#: One check (:func:`_check_types`) says which key has which type and what is expected.
_NUMBER = (int, float)
_SCHEMA: dict[str, dict[str, type | tuple[type, ...]]] = {
    "": {"model": str, "preset": str, "description": str, "parameters": Mapping, "rig": Mapping,
         "matrices": Mapping, "fe": Mapping, "uncertain": Mapping},
    "fe": {"file": str, "files": Mapping, "files.*": str, "names": Mapping, "names.*": str,
           "disc_speed_ref": _NUMBER, "omega_ref": _NUMBER, "mu_ref": _NUMBER, "f_ref": _NUMBER, "mesh": str,
           "dof_names": str, "omit": (list, str)},
    "rig": {"*": (*_NUMBER, str)},
    "parameters": {"*": (*_NUMBER, str)},
}
_FE_KEYS = tuple(k for k in _SCHEMA["fe"] if "." not in k)
_TOML_TYPE = [(bool, "a boolean"), (int, "an integer"), (float, "a float"), (str, "a string"),
              (Mapping, "a table"), (list, "an array")]


def _toml_type(value: Any) -> str:
    """The TOML name of a parsed value's type ("an integer", "an array", ...)."""
    for t, name in _TOML_TYPE:
        if isinstance(value, t):
            return name
    return f"a {type(value).__name__}"


def _expected(t: type | tuple[type, ...]) -> str:
    names = {int: "number", float: "number", str: "string", Mapping: "table", list: "array", bool: "boolean"}
    ts = t if isinstance(t, tuple) else (t,)
    return " or ".join(dict.fromkeys(f"a {names[x]}" for x in ts))


def _check_types(table: Mapping[str, Any], name: str = "") -> None:
    """Each key of ``table`` (and of its sub-tables) of the type the schema gives, else one line naming it."""
    schema = _SCHEMA.get(name, {})
    for key, value in table.items():
        want = schema.get(key, schema.get("*"))
        if want is None:
            continue  # unknown keys are the caller's (with "did you mean")
        where = f"[{name}] {key}" if name else key
        ok = isinstance(value, want) and not (isinstance(value, bool) and bool not in (want if isinstance(
            want, tuple) else (want,)))
        if not ok:
            raise InputError(f"{where} = {value!r} is {_toml_type(value)}; expected {_expected(want)}.")
        if isinstance(value, Mapping):
            if name == "":
                _check_types(value, key)
            elif f"{key}.*" in schema:
                sub = schema[f"{key}.*"]
                for k, v in value.items():
                    if not isinstance(v, sub) or isinstance(v, bool):
                        raise InputError(f"[{name}] {key}.{k} = {v!r} is {_toml_type(v)}; expected {_expected(sub)}.")


def get_preset(name: str) -> FrictionModel:
    """The built-in model called ``name`` (see :data:`PRESETS`).

    Parameters
    ----------
    name : str
        A key of :data:`PRESETS`: ``"lv2013"`` (the paper's rig) or ``"hoffmann2002"``.

    Returns
    -------
    FrictionModel
        A new model with the preset's values.

    Raises
    ------
    InputError
        If ``name`` is not a preset.
    """
    if name not in PRESETS:
        raise InputError(f"Unknown preset {name!r}; known: {', '.join(PRESETS)}.")
    return PRESETS[name][1]()


def _rig_from_table(table: Mapping[str, Any], changes: Mapping[str, Any] | None = None) -> PinOnDiscRig:
    """The rig of a [rig] table, with ``changes`` (rig fields, e.g. from [parameters]) applied last."""
    known = {f for f in PinOnDiscRig.__dataclass_fields__ if not f.startswith("_")}
    kwargs: dict[str, Any] = {}
    for key, value in [*table.items(), *(changes or {}).items()]:
        name = key
        if key == "alpha_deg":
            name, value = "alpha", math.radians(validate_finite(key, parse_quantity(key, value, "deg")))
        if name not in known:
            raise InputError(f"Unknown [rig] key {key!r}; known: {', '.join(sorted(known))}.")
        kwargs[name] = value
    try:
        return PinOnDiscRig(**kwargs)
    except TypeError as e:
        raise InputError(f"Bad [rig] table: {e}") from e


def _split_rig_parameters(params: Mapping[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    """Model parameters a rig also has (P, alpha, the dampers, sliding) and the rest.

    The first go into the rig, so that the rig and its model agree (a P under [parameters] is the
    rig's P, scaled by ``preload`` at the file's alpha); the rest change the derived model.
    """
    shared = set(PinOnDiscRig.__dataclass_fields__) & set(PinOnDisc3DOF.parameter_info())
    to_rig = {k: v for k, v in params.items() if k in shared or (k == "alpha_deg" and "alpha" in shared)}
    return to_rig, {k: v for k, v in params.items() if k not in to_rig}


def _parameters(doc: Mapping[str, Any], overrides: Mapping[str, Any] | None) -> dict[str, Any]:
    params = doc.get("parameters", {})
    if not isinstance(params, Mapping):
        raise InputError("[parameters] must be a table of NAME = VALUE.")
    return {**params, **(overrides or {})}


def _fe_from_table(table: Any, base_dir: Path | None) -> FEModel:
    from ..fe.readers import load_fe_model

    if not isinstance(table, Mapping):
        raise InputError('An FE model needs an [fe] table with file = "..." or files = {M = "...", ...}.')
    for key in table:
        if key not in _FE_KEYS:
            raise InputError(f"Unknown [fe] key {key!r}; known: {', '.join(_FE_KEYS)}.")
    refs = {k: validate_finite(k, table[k]) for k in ("disc_speed_ref", "mu_ref", "f_ref") if k in table}
    if "omega_ref" in table:  # the disc speed's older name (omega is an eigenfrequency elsewhere)
        if "disc_speed_ref" in table:
            raise InputError("[fe] has both omega_ref (deprecated) and disc_speed_ref; give disc_speed_ref only.")
        warnings.warn("[fe] omega_ref is deprecated; use disc_speed_ref (same meaning).", DeprecationWarning,
                      stacklevel=3)
        refs["disc_speed_ref"] = validate_finite("omega_ref", table["omega_ref"])
    omit = table.get("omit", [])
    if isinstance(omit, str):
        omit = [omit]
    if not (isinstance(omit, list) and all(isinstance(k, str) for k in omit)):
        raise InputError(f'[fe] omit={omit!r} must be a list of matrix names, e.g. omit = ["DG"].')
    return load_fe_model(table.get("file"), files=table.get("files"), names=table.get("names"),
                         base_dir=base_dir, omit=omit, mesh=table.get("mesh"), dof_names=table.get("dof_names"),
                         **refs)


def model_from_dict(doc: Mapping[str, Any], base_dir: str | Path | None = None,
                    overrides: Mapping[str, Any] | None = None) -> FrictionModel | FEModel:
    """Build a model from a parsed model file (see the module docstring).

    Parameters
    ----------
    doc : mapping
        The parsed TOML document: top-level keys ``model``, ``preset``, ``description`` and
        tables ``[parameters]``, ``[rig]``, ``[matrices]``, ``[fe]`` (``[uncertain]`` is
        ignored here).
    base_dir : str or Path, optional
        The folder relative matrix file paths of an ``[fe]`` table start from (default: the
        current directory).
    overrides : mapping, optional
        Parameter values applied after the ``[parameters]`` table, in the same way (``--set``).

    Returns
    -------
    FrictionModel or FEModel
        The model, with the ``[parameters]`` table and ``overrides`` applied. With a ``[rig]``
        table, the parameters the rig also has (``P``, ``alpha``, the dampers, ``sliding``) are
        set on the rig before the model is derived, and the others on the derived model before
        a ``preload = "contact_force"`` is scaled: one file gives one model, whichever command
        reads it.

    Raises
    ------
    InputError
        On an unknown table or key (with "did you mean"), a key of the wrong type (the key,
        its type and the expected one), a preset of another model kind, or any invalid value.
    """
    if not isinstance(doc, Mapping):
        raise InputError(f"doc must be a mapping (a parsed model file), not {type(doc).__name__}.")
    _check_types(doc)
    unknown = sorted(set(doc) - _TOP_KEYS - _OTHER_TABLES)
    if unknown:
        # a typo ([paramters]) must not silently give the default model
        key = unknown[0]
        what = f"table [{key}]" if isinstance(doc[key], Mapping) else f"top-level key {key!r}"
        close = difflib.get_close_matches(key, sorted(_TOP_KEYS | _OTHER_TABLES), n=1)
        hint = f"did you mean {close[0]!r}? " if close else ""
        raise InputError(f"Unknown {what} in model file; {hint}known: {', '.join(sorted(_TOP_KEYS | _OTHER_TABLES))}.")
    preset = doc.get("preset")
    kind = doc.get("model", _PRESET_KIND.get(preset, "pin_on_disc") if preset else None)
    if kind is None:
        kind = "matrix" if "matrices" in doc else "fe" if "fe" in doc else "pin_on_disc"
    if kind == "fe":
        extra = sorted(k for k in ("preset", "rig", "matrices", "parameters") if k in doc)
        if extra:
            raise InputError(f"An FE model is described by its [fe] table only; remove {extra[0]!r}.")
        return _fe_from_table(doc.get("fe"), Path(base_dir) if base_dir is not None else None)
    if kind not in _MODEL_KINDS:
        raise InputError(f"Unknown model {kind!r}; known: {', '.join([*_MODEL_KINDS, 'fe'])}.")
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
        return rig_model_from_dict(doc, overrides).to_model()  # type: ignore[union-attr]
    elif preset is not None:
        model = get_preset(preset)
    else:
        model = _MODEL_KINDS[kind]()

    params = _parameters(doc, overrides)
    return model.replace(**params) if params else model


def _read_toml(path: str | Path) -> dict[str, Any]:
    p = Path(path)
    try:
        with open(p, "rb") as f:
            raw = f.read(_MAX_FILE_BYTES + 1)  # bounded: /dev/zero or a wrong file is not read without end
        if len(raw) > _MAX_FILE_BYTES:
            raise InputError(f"Model file {str(p)!r} is larger than {_MAX_FILE_BYTES // 2**20} MiB; a model file is "
                             "a few kB of TOML (large matrices go in the files an [fe] table names).")
        text = raw.decode("utf-8")
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


def load_model(path: str | Path, overrides: Mapping[str, Any] | None = None) -> FrictionModel | FEModel:
    """Read a model file (TOML). Errors name the file and what is wrong in it.

    Parameters
    ----------
    path : str or Path
        The model file (TOML, at most 16 MiB; see the module docstring for its tables).
    overrides : mapping, optional
        Parameter values applied after the file's ``[parameters]`` (see :func:`model_from_dict`).

    Returns
    -------
    FrictionModel or FEModel
        The model it describes (see :func:`model_from_dict`).

    Raises
    ------
    InputError
        If the file is missing, unreadable, not TOML, or describes an invalid model.
    """
    p = Path(path)
    doc = _read_toml(p)
    try:
        return model_from_dict(doc, base_dir=p.parent, overrides=overrides)
    except InputError as e:
        raise InputError(f"{p.name}: {e}") from e


def load_rig(path: str | Path, overrides: Mapping[str, Any] | None = None) -> PinOnDiscRig | None:
    """The rig described by a model file's ``[rig]`` table, or None if it has none.

    The ``[parameters]`` the rig also has (``P``, ``alpha``, the dampers, ``sliding``), then those
    of ``overrides``, are applied to it: it is the rig of :func:`load_model`'s model.

    Parameters
    ----------
    path : str or Path
        The model file (TOML).
    overrides : mapping, optional
        Parameter values applied after the file's ``[parameters]`` (``--set``).

    Returns
    -------
    PinOnDiscRig or None
        The rig (fields as in :class:`PinOnDiscRig`), or ``None`` without a ``[rig]`` table.
    """
    try:
        return rig_from_dict(_read_toml(path), overrides)
    except InputError as e:
        raise InputError(f"{Path(path).name}: {e}") from e


def rig_from_dict(doc: Mapping[str, Any], overrides: Mapping[str, Any] | None = None) -> PinOnDiscRig | None:
    """The rig of a parsed model file's ``[rig]`` table (None without one), as :func:`load_rig`.

    Parameters
    ----------
    doc : mapping
        The parsed model file.
    overrides : mapping, optional
        Parameter values applied after its ``[parameters]`` (``--set``).

    Returns
    -------
    PinOnDiscRig or None
    """
    rm = rig_model_from_dict(doc, overrides)
    return None if rm is None else rm.rig


def rig_model_from_dict(doc: Mapping[str, Any], overrides: Mapping[str, Any] | None = None) -> RigModel | None:
    """The rig of a parsed model file and the model changes after its derivation (None without a [rig]).

    ``rig_model_from_dict(doc).to_model()`` is :func:`model_from_dict`'s model; its ``to_model(**changes)``
    derives the model anew with rig quantities changed (a Monte Carlo over ``disc_freq``, pin sizes...).

    Parameters
    ----------
    doc : mapping
        The parsed model file.
    overrides : mapping, optional
        Parameter values applied after its ``[parameters]`` (``--set``).

    Returns
    -------
    RigModel or None
    """
    table = doc.get("rig")
    if table is None:
        return None
    to_rig, rest = _split_rig_parameters(_parameters(doc, overrides))
    return RigModel(_rig_from_table(table, to_rig), rest)


def load_rig_model(path: str | Path, overrides: Mapping[str, Any] | None = None) -> RigModel | None:
    """:func:`rig_model_from_dict` of a model file (None without a [rig] table); errors name the file.

    Parameters
    ----------
    path : str or Path
        The model file (TOML).
    overrides : mapping, optional
        Parameter values applied after the file's ``[parameters]`` (``--set``).

    Returns
    -------
    RigModel or None
        The rig and the model changes after its derivation; ``.to_model()`` is :func:`load_model`'s model.
    """
    try:
        return rig_model_from_dict(_read_toml(path), overrides)
    except InputError as e:
        raise InputError(f"{Path(path).name}: {e}") from e


def parse_assignments(items: Iterable[str]) -> dict[str, float | str]:
    """Parse ``NAME=VALUE`` strings (from ``--set``) into a dict of floats.

    A value that is not a number stays a string, for the model's options (``kinematics=consistent``);
    the model's own check then says whether the parameter takes it.

    Parameters
    ----------
    items : iterable of str
        Assignments such as ``"m1=0.05"`` or ``"alpha_deg=2"`` (SI units, or a ``*_deg`` name).

    Returns
    -------
    dict of str to float or str
        Name -> value, in the order given (a later assignment to a name wins).

    Raises
    ------
    InputError
        If an item is not a ``NAME=VALUE`` string or a number is not finite.

    Examples
    --------
    >>> parse_assignments(["m1=0.05", "kinematics=consistent"])
    {'m1': 0.05, 'kinematics': 'consistent'}
    """
    if isinstance(items, str | bytes):
        raise InputError(f"items must be a list of NAME=VALUE strings, not one str ({items!r}).")
    out: dict[str, float | str] = {}
    for item in items:
        if not isinstance(item, str):
            raise InputError(f"--set {item!r} is not NAME=VALUE (a string), it is {type(item).__name__}.")
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
) -> FrictionModel | FEModel:
    """The model a command works on: a preset or a model file, then overrides.

    With neither ``preset`` nor ``config`` the default preset ``lv2013`` is used.

    Parameters
    ----------
    preset : str, optional
        A key of :data:`PRESETS`.
    config : str or Path, optional
        A model file (TOML), read with :func:`load_model`; not together with ``preset``.
    overrides : mapping, optional
        Parameter values applied last with ``model.replace(**overrides)`` (SI units, or
        ``*_deg`` names in degrees).

    Returns
    -------
    FrictionModel or FEModel
        The model.

    Raises
    ------
    InputError
        If both ``preset`` and ``config`` are given, or any part is invalid.
    """
    if preset is not None and config is not None:
        raise InputError("Give either a preset or a model file, not both.")
    if config is not None:
        return load_model(config, overrides)
    model = get_preset(preset or "lv2013")
    return model.replace(**overrides) if overrides else model

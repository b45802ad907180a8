"""Design parameters: declared changes of a brake model, each with its derivative matrices.

A design parameter ``p`` changes the model linearly about its nominal value ``p0``, so that its
derivative matrices ``dM, dC, dK`` are exact and the same at every value. It is declared in the
model file's ``[design]`` table (or as the same mapping in Python)::

    [design]
    pad = "K1"                                   # scales the part K1; nominal 1
    friction = "KR"                              # the friction stiffness (mu's share of K)
    damping = "C"                                # the whole C(disc_speed, mu); "K" likewise
    shim = {part = "D1", nodes = [12, 13, 14]}   # scales D1 among the DOFs of these nodes
    back = {part = "K1", dofs = [3, 4, 5], step = 0.2}
    disc_mass = {mass = 0.0, nodes = [40]}       # a point mass [kg] on node 40 (x, y, z)

- ``NAME = "PART"`` (``PART`` one of ``M, D1, DG, DR, D4, K1, KR, KGeo``, or ``C``/``K`` for the
  whole damping/stiffness at the operating point): ``A(p) = A + (p - 1) A``, nominal 1, so the
  derivative is the part with the factor it has at the operating point (``KR`` enters K as
  ``mu_e / mu_ref KR``, ``DG`` as ``v / v_ref DG``, ``KGeo`` as ``(v / v_ref)^2 KGeo``).
- ``{part = "PART", nodes = [...]}`` or ``dofs = [...]``: the scale acts on the entries whose row
  and column are both DOFs of the set, ``A(p) = A + (p - 1) E A E`` with ``E`` the 0/1 diagonal of
  the set: every coupling among those DOFs, including the set's share of the springs at its edge.
  Node labels are those of the model's DOF map (:class:`~squealkit.fe.dofmap.DofMap`), or, without
  one, of DOF names ``node<k>.<x|y|z>`` (the built-in brake); ``components = [1, 2, 3]`` keeps
  those DOF numbers of each node (default every DOF of the node).
- ``{mass = M0, nodes = [...]}``: a point mass on each node, added to its translational DOFs;
  ``p`` is that mass [kg], nominal ``M0`` (the mass the model already holds there, usually 0),
  ``dM = E``.
- Small models (:mod:`squealkit.models`): ``NAME = "k3"`` names a model parameter, nominal its
  value, derivative matrices by a central difference of the model's matrices.

Each parameter also has a ``step``: the size of change the countermeasure study compares
parameters by (default 0.1 of the nominal for a scale or a model parameter, and for a point mass
a tenth of the mass the set's DOFs carry in M).
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from .._threads import honour_thread_limit
from .._validation import InputError
from ..fe.model import FE_MATRICES, FEModel

__all__ = ["DESIGN_PARTS", "DesignParameter", "design_parameters", "load_design"]

#: Parts a design parameter may scale: the FE matrices, and C / K at the operating point.
DESIGN_PARTS: tuple[str, ...] = (*FE_MATRICES, "C", "K")
_DAMPING = ("D1", "DR", "DG", "D4")
_STIFFNESS = ("K1", "KR", "KGeo")
_KEYS = ("part", "nodes", "dofs", "components", "mass", "step")
_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
#: Relative step of the central difference of a small model's matrices (eps^(1/3)).
_MATRIX_STEP = float(np.finfo(float).eps) ** (1.0 / 3.0)


@dataclass(frozen=True, eq=False)
class DesignParameter:
    """One declared change of a model (module docstring), linear in its value.

    Attributes
    ----------
    name : str
        The name given in the ``[design]`` table.
    kind : {"scale", "mass", "model"}
        A scale of a matrix part, a point mass [kg], or a parameter of a small model.
    part : str or None
        The part scaled (``kind="scale"``), or the model parameter (``kind="model"``).
    dofs : ndarray of int64 or None
        DOF indices of the set (None: every DOF).
    nominal : float
        The value of the model as given (1 for a scale).
    step : float
        The size of change the countermeasure study compares parameters by (> 0).
    unit : str
        Unit of the parameter (``"1"`` for a scale, ``"kg"`` for a mass).
    spec : dict
        The declaration as given in the ``[design]`` table.
    """

    name: str
    kind: str
    part: str | None = None
    dofs: Any = None
    nominal: float = 1.0
    step: float = 0.1
    unit: str = "1"
    spec: Any = field(default=None, repr=False)

    @property
    def lower(self) -> float:
        """Smallest value a countermeasure may give the parameter (a scale or a mass cannot go below 0)."""
        return 0.0 if self.kind in ("scale", "mass") else -math.inf

    def describe(self) -> str:
        """A short phrase naming the change (for reports)."""
        where = "" if self.dofs is None else f" on {len(self.dofs)} DOFs"
        if self.kind == "scale":
            return f"scale of {self.part}{where}"
        if self.kind == "mass":
            return f"point mass{where} [kg]"
        return f"model parameter {self.part} [{self.unit}]"

    def to_dict(self) -> dict[str, Any]:
        """What the parameter is, for result attributes and JSON."""
        return {"name": self.name, "kind": self.kind, "part": self.part, "nominal": self.nominal, "step": self.step,
                "unit": self.unit, "n_dofs": None if self.dofs is None else len(self.dofs)}

    # -- the model at a value ---------------------------------------------------------------
    @honour_thread_limit
    def apply(self, model: Any, value: float) -> Any:
        """The model with this parameter at ``value`` (``model`` is the nominal one).

        Parameters
        ----------
        model : FEModel or FrictionModel
            The nominal model the parameter was declared on.
        value : float
            The parameter's value (in its unit).

        Returns
        -------
        FEModel or FrictionModel
        """
        value = float(value)
        if not math.isfinite(value):
            raise InputError(f"Design parameter {self.name}={value!r} must be finite.")
        if self.kind == "model":
            return model.replace(**{self.part: value})
        delta = value - self.nominal
        if delta == 0.0:
            return model
        if self.kind == "mass":
            return model.replace(M=model.M + delta * self._mask(model.n_dof))
        changes = {name: getattr(model, name) + delta * self._masked(getattr(model, name))
                   for name in self._parts(model)}
        return model.replace(**changes)

    def _parts(self, model: FEModel) -> tuple[str, ...]:
        names = _DAMPING if self.part == "C" else _STIFFNESS if self.part == "K" else (self.part,)
        return tuple(n for n in names if getattr(model, n) is not None)

    def _mask(self, n: int) -> sp.csr_matrix:
        if self.dofs is None:
            return sp.identity(n, format="csr")
        e = np.zeros(n)
        e[self.dofs] = 1.0
        return sp.diags(e, format="csr")

    def _masked(self, A: sp.csr_matrix) -> sp.csr_matrix:
        if self.dofs is None:
            return A
        E = self._mask(A.shape[0])
        return (E @ A @ E).tocsr()

    # -- derivative matrices ---------------------------------------------------------------
    def matrix_derivatives(self, model: Any, *, disc_speed: float | None = None, mu: float = 0.0,
                           tan_theta: float = 0.0) -> tuple[Any, Any, Any]:
        """``(dM, dC, dK)``: the derivatives of ``M, C, K`` at the operating point per unit of the parameter.

        Parameters
        ----------
        model : FEModel or FrictionModel
            The model (for a scale or a mass the derivatives do not depend on its value).
        disc_speed : float, optional
            Disc speed [rad/s] (FE models).
        mu : float
            Friction coefficient.
        tan_theta : float
            Run-out slope; ``mu + tan_theta`` enters the friction parts.

        Returns
        -------
        (dM, dC, dK)
            Sparse CSR matrices for an FE model, dense arrays for a small model; shape (n, n).
        """
        if self.kind == "model":
            return _model_derivatives(model, self.part, mu, tan_theta)
        n = model.n_dof
        zero = sp.csr_matrix((n, n))
        if self.kind == "mass":
            return self._mask(n), zero, zero
        f = model.factors(disc_speed, mu, tan_theta)
        f["M"] = 1.0
        total = {"M": zero, "C": zero, "K": zero}
        for name in self._parts(model):
            slot = "M" if name == "M" else "C" if name in _DAMPING else "K"
            total[slot] = total[slot] + f[name] * self._masked(getattr(model, name))
        return total["M"].tocsr(), total["C"].tocsr(), total["K"].tocsr()


def _model_derivatives(model: Any, name: str, mu: float, t: float) -> tuple[NDArray, NDArray, NDArray]:
    """Central difference of a small model's ``M, C, K(mu, t)`` in the parameter ``name`` (exact for
    matrices linear in it; one-sided where a step leaves the parameter's range)."""
    from ..stability.modes import _parts, _stiffness

    value = float(getattr(model, name))
    h = _MATRIX_STEP * (abs(value) or 1.0)

    def at(v: float) -> tuple[NDArray, ...] | None:
        try:
            m = model.replace(**{name: v})
        except InputError:
            return None
        M, C, K0, Kn, Kf = _parts(m, True)
        return M, C, _stiffness(m, K0, Kn, Kf, mu, t)

    up, dn = at(value + h), at(value - h)
    lo, hi, span = (dn, up, 2 * h) if up is not None and dn is not None else \
        (at(value), up, h) if up is not None else (dn, at(value), h)
    if lo is None or hi is None:
        raise InputError(f"Model parameter {name}={value!r} cannot be stepped by +-{h:.3g} within its range.")
    return tuple((b - a) / span for a, b in zip(lo, hi, strict=True))  # type: ignore[return-value]


# -- declaration ----------------------------------------------------------------------------


def _node_dofs(model: FEModel, name: str, nodes: Any, components: Any) -> NDArray[np.int64]:
    """DOF indices of the nodes' DOFs (DOF map labels, or names ``node<k>.<x|y|z>``)."""
    try:
        nodes = np.asarray(nodes, dtype=np.int64).reshape(-1)
    except (TypeError, ValueError):
        raise InputError(f"[design] {name}: nodes = {nodes!r} must be a list of node labels (integers).") from None
    if model.dof_map is not None:
        node_of, dof_of = model.dof_map.node, model.dof_map.dof
    else:
        pattern = re.compile(r"^node(-?\d+)\.([xyz])$")
        hits = [pattern.match(s) for s in model.dof_names]
        if not all(hits):
            raise InputError(f"[design] {name}: the model has no DOF map and its DOFs are not named node<k>.<x|y|z>; "
                             "select DOFs by index: dofs = [...].")
        node_of = np.array([int(m.group(1)) for m in hits])  # type: ignore[union-attr]
        dof_of = np.array(["xyz".index(m.group(2)) + 1 for m in hits])  # type: ignore[union-attr]
    keep = np.isin(node_of, nodes)
    missing = np.setdiff1d(nodes, node_of)
    if missing.size:
        raise InputError(f"[design] {name}: node {int(missing[0])} has no DOF in the model.")
    if components is not None:
        comps = np.asarray(components, dtype=np.int64).reshape(-1)
        keep &= np.isin(dof_of, comps)
    idx = np.flatnonzero(keep)
    if idx.size == 0:
        raise InputError(f"[design] {name}: no DOF of nodes {nodes.tolist()[:5]} with components {components!r}.")
    return idx


def _dof_set(model: FEModel, name: str, spec: Mapping[str, Any], *, translational: bool) -> NDArray[np.int64] | None:
    if "nodes" in spec and "dofs" in spec:
        raise InputError(f"[design] {name}: give nodes or dofs, not both.")
    if "dofs" in spec:
        try:
            dofs = np.unique(np.asarray(spec["dofs"], dtype=np.int64).reshape(-1))
        except (TypeError, ValueError):
            raise InputError(f"[design] {name}: dofs = {spec['dofs']!r} must be a list of DOF indices.") from None
        if dofs.size == 0 or dofs.min() < 0 or dofs.max() >= model.n_dof:
            raise InputError(f"[design] {name}: dofs must be indices in 0..{model.n_dof - 1}, got {spec['dofs']!r}.")
        return dofs
    if "nodes" in spec:
        comps = spec.get("components", [1, 2, 3] if translational else None)
        return _node_dofs(model, name, spec["nodes"], comps)
    return None


def _step(name: str, spec: Mapping[str, Any], default: float) -> float:
    step = spec.get("step", default)
    if isinstance(step, bool) or not isinstance(step, int | float) or not (math.isfinite(step) and step > 0):
        raise InputError(f"[design] {name}: step = {step!r} must be a positive number.")
    return float(step)


def _one(model: Any, name: str, spec: Any) -> DesignParameter:
    if not isinstance(name, str) or not _NAME.match(name):
        raise InputError(f"[design] name {name!r} must be an identifier (letters, digits, _).")
    if isinstance(spec, str):
        spec = {"part": spec}
    if not isinstance(spec, Mapping):
        raise InputError(f'[design] {name} = {spec!r} must be a part name ("K1") or a table {{part = ..., nodes = '
                         "[...]}.")
    for key in spec:
        if key not in _KEYS:
            raise InputError(f"[design] {name}: unknown key {key!r}; known: {', '.join(_KEYS)}.")
    if not isinstance(model, FEModel):
        info = model.parameter_info()
        part = spec.get("part")
        if set(spec) - {"part", "step"} or part not in info or info[part]["kind"] not in (
                "positive", "nonnegative", "angle", "finite"):
            known = ", ".join(k for k, v in info.items() if v["kind"] in ("positive", "nonnegative", "angle", "finite"))
            raise InputError(f"[design] {name} = {spec.get('part')!r}: a {model.kind!r} model takes a scalar model "
                             f"parameter; known: {known}.")
        value = float(getattr(model, part))
        return DesignParameter(name, "model", part, None, value, _step(name, spec, 0.1 * (abs(value) or 1.0)),
                               info[part]["unit"], dict(spec))
    if "mass" in spec:
        if "part" in spec:
            raise InputError(f"[design] {name}: a point mass (mass = ...) takes no part.")
        mass = spec["mass"]
        if isinstance(mass, bool) or not isinstance(mass, int | float) or not (math.isfinite(mass) and mass >= 0):
            raise InputError(f"[design] {name}: mass = {mass!r} must be the nominal point mass [kg], >= 0.")
        if "nodes" not in spec and "dofs" not in spec:
            raise InputError(f"[design] {name}: a point mass needs nodes = [...] (or dofs = [...]).")
        dofs = _dof_set(model, name, spec, translational=True)
        carried = float(model.M.diagonal()[dofs].sum()) / 3.0
        return DesignParameter(name, "mass", None, dofs, float(mass), _step(name, spec, 0.1 * (carried or 1.0)),
                               "kg", dict(spec))
    part = spec.get("part")
    if part not in DESIGN_PARTS:
        raise InputError(f"[design] {name}: part = {part!r}; known: {', '.join(DESIGN_PARTS)}.")
    present = [n for n in (_DAMPING if part == "C" else _STIFFNESS if part == "K" else (part,))
               if getattr(model, n) is not None]
    if not present:
        raise InputError(f"[design] {name}: the model has no {part} (it has {', '.join(model.present)}).")
    if "components" in spec and "nodes" not in spec:
        raise InputError(f"[design] {name}: components need nodes = [...].")
    dofs = _dof_set(model, name, spec, translational=False)
    return DesignParameter(name, "scale", part, dofs, 1.0, _step(name, spec, 0.1), "1", dict(spec))


def design_parameters(table: Mapping[str, Any] | Sequence[DesignParameter], model: Any) -> tuple[DesignParameter, ...]:
    """The design parameters of a ``[design]`` table (module docstring) on ``model``.

    Parameters
    ----------
    table : mapping or sequence of DesignParameter
        ``NAME -> "PART"`` or ``NAME -> {part = ..., nodes = [...], ...}``; parameters already
        declared are passed through.
    model : FEModel or FrictionModel
        The nominal model the parameters act on.

    Returns
    -------
    tuple of DesignParameter

    Raises
    ------
    InputError
        For an empty table, a bad name, an unknown key or part, a part the model lacks, or nodes
        or DOFs not in the model (one line naming it).

    Examples
    --------
    >>> from squealkit.fe import FEModel
    >>> m = FEModel.from_matrices(M=np.eye(2), K1=np.diag([4.0, 9.0]), KR=[[0, 1.0], [-1.0, 0]])
    >>> [p.describe() for p in design_parameters({"pad": "K1", "tip": {"part": "K1", "dofs": [1]}}, m)]
    ['scale of K1', 'scale of K1 on 1 DOFs']
    """
    if not isinstance(table, Mapping):
        params = tuple(table)
        if not params or not all(isinstance(p, DesignParameter) for p in params):
            raise InputError("design parameters must be a [design] table (mapping) or DesignParameter objects.")
        return params
    if not table:
        raise InputError("The [design] table is empty: declare at least one parameter, e.g. pad = \"K1\".")
    return tuple(_one(model, name, spec) for name, spec in table.items())


def load_design(path: str | Path, model: Any) -> tuple[DesignParameter, ...]:
    """The design parameters of the ``[design]`` table of a model file (TOML).

    Parameters
    ----------
    path : str or Path
        The model file (the one the model was read from).
    model : FEModel or FrictionModel
        The model it describes.

    Returns
    -------
    tuple of DesignParameter

    Raises
    ------
    InputError
        If the file has no ``[design]`` table, or it is invalid (see :func:`design_parameters`).
    """
    from ..models.config import _read_toml

    doc = _read_toml(path)
    table = doc.get("design")
    if not isinstance(table, Mapping):
        raise InputError(f"{Path(path).name}: no [design] table; declare the parameters, e.g. [design] pad = \"K1\".")
    try:
        return design_parameters(table, model)
    except InputError as e:
        raise InputError(f"{Path(path).name}: {e}") from e

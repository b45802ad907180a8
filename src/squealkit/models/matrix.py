"""A model given directly by its matrices, e.g. from modal data or a finite element model."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from .._validation import InputError, validate_array_finite, validate_sign
from ._base import FrictionModel

__all__ = ["MatrixModel"]


def _square(name: str, value: Any, n: int | None) -> NDArray[np.float64]:
    arr = validate_array_finite(name, value)
    if arr.ndim != 2 or arr.shape[0] != arr.shape[1]:
        raise InputError(f"Parameter {name} must be a square matrix, got shape {arr.shape}.")
    if n is not None and arr.shape[0] != n:
        raise InputError(f"Parameter {name} must be {n}x{n} like M, got shape {arr.shape}.")
    return arr


def _vector(name: str, value: Any, n: int) -> NDArray[np.float64]:
    arr = validate_array_finite(name, value)
    if arr.shape != (n,):
        raise InputError(f"Parameter {name} must be a vector of length {n}, got shape {arr.shape}.")
    return arr


@dataclass(frozen=True, eq=False)
class MatrixModel(FrictionModel):
    """A linear friction-coupled model given by its matrices.

    ``K = K0 + (1 - mu tan_theta) Kn + s (mu + tan_theta) Kf`` and
    ``F = F0 + q [(1 - mu tan_theta) fn + s (mu + tan_theta) ff]`` as for every model.
    Matrices not given default to zero; ``dof_names`` default to ``q0, q1, ...``.

    Parameters
    ----------
    M : array_like, shape (n, n)
        Mass matrix [kg], symmetric positive definite (required).
    K0 : array_like, shape (n, n)
        Structural stiffness without contact [N/m] (required).
    C : array_like, shape (n, n), optional
        Viscous damping [N s/m].
    Kn, Kf : array_like, shape (n, n), optional
        Normal-contact and friction stiffness parts [N/m], scaled by ``1 - mu tan_theta``
        and ``s (mu + tan_theta)``.
    F0 : array_like, shape (n,), optional
        Static load [N].
    fn, ff : array_like, shape (n,), optional
        Normal-contact and friction load parts [N/m], multiplied by the surface height ``q`` [m].
    sliding : {+1, -1}, default +1
        Sliding direction ``s``.
    names : sequence of str, optional
        DOF names, one per row of ``M``; default ``q0, q1, ...``.

    Raises
    ------
    InputError
        If ``M`` or ``K0`` is missing, a matrix or vector has the wrong shape, or ``M`` is
        not positive definite.

    Examples
    --------
    Two modal DOFs coupled by friction (a Hoffmann-like system from modal data):

    >>> m = MatrixModel(M=[[1, 0], [0, 1]], K0=[[1.2e6, 1.7e5], [1.7e5, 4e5]],
    ...                 Kn=[[0, 0], [0, 8e5]], Kf=[[0, -8e5], [0, 0]])
    >>> m.n_dof
    2
    """

    kind: ClassVar[str] = "matrix"

    M: Any = None
    K0: Any = None
    C: Any = None
    Kn: Any = None
    Kf: Any = None
    F0: Any = None
    fn: Any = None
    ff: Any = None
    sliding: int = 1
    names: tuple[str, ...] | None = None

    def __post_init__(self) -> None:
        if self.M is None or self.K0 is None:
            raise InputError("A matrix model needs at least M and K0.")
        M = _square("M", self.M, None)
        n = M.shape[0]
        set_ = object.__setattr__
        set_(self, "M", M)
        for name in ("K0", "C", "Kn", "Kf"):
            value = getattr(self, name)
            set_(self, name, np.zeros((n, n)) if value is None else _square(name, value, n))
        for name in ("F0", "fn", "ff"):
            value = getattr(self, name)
            set_(self, name, np.zeros(n) if value is None else _vector(name, value, n))
        set_(self, "sliding", validate_sign("sliding", self.sliding))
        names = tuple(f"q{i}" for i in range(n)) if self.names is None else tuple(map(str, self.names))
        if len(names) != n:
            raise InputError(f"Parameter names has {len(names)} entries for {n} DOFs.")
        set_(self, "names", names)
        self._check_mass_matrix()

    @property
    def dof_names(self) -> tuple[str, ...]:  # type: ignore[override]
        return self.names  # type: ignore[return-value]

    @property
    def sliding_direction(self) -> int:
        return self.sliding

    @classmethod
    def parameter_info(cls) -> dict[str, dict[str, str]]:
        units = {"M": "kg", "C": "N s/m", "K0": "N/m", "Kn": "N/m", "Kf": "N/m",
                 "F0": "N", "fn": "N/m", "ff": "N/m", "sliding": "1"}
        return {k: {"unit": u, "doc": f"matrix {k}", "kind": "array"} for k, u in units.items()}

    def parameters(self) -> dict[str, Any]:
        out = super().parameters()
        out["names"] = list(self.names)  # type: ignore[arg-type]
        return out

    def mass_matrix(self):
        return self.M

    def damping_matrix(self):
        return self.C

    def stiffness_parts(self):
        return self.K0, self.Kn, self.Kf

    def load_parts(self):
        return self.F0, self.fn, self.ff

"""A finite element brake model given by its sparse matrices, as industrial workflows export it.

The matrices carry the names of the TU Berlin / NLEVP disc brake workflow (Graebner et al.,
ZAMM 96(12), 2016): ``M`` mass, ``D1`` material damping, ``DR`` friction-induced damping,
``DG`` gyroscopic (skew), ``D4`` a damping scaled by ``1/f_ref``, ``K1`` structural stiffness
(symmetric), ``KR`` friction stiffness (non-symmetric), ``KGeo`` centrifugal stiffening.
At disc speed ``disc_speed`` [rad/s] and friction ``mu``::

    C(v, mu) = D1 + (mu/mu_ref) (v_ref/v) DR + (v/v_ref) DG + D4/f_ref
    K(v, mu) = K1 + (mu/mu_ref) KR + (v/v_ref)^2 KGeo      (v = disc_speed, v_ref = disc_speed_ref)

``KR`` and ``DR`` are exported at friction ``mu_ref`` and scale linearly with ``mu``;
``disc_speed_ref`` is the speed at which ``DG`` and ``KGeo`` were exported. (``omega`` is an
eigenfrequency everywhere else in squealkit; the older names ``omega=`` and ``omega_ref`` of the
disc speed still work for one release, with a :class:`DeprecationWarning`.) The run-out slope of the
disc acts like extra friction (Lv, Zhang & Yu 2013, eqs. 5-6): ``mu_e = mu + tan(theta)``
replaces ``mu`` in the friction parts when ``tan_theta`` is given.
"""

from __future__ import annotations

import dataclasses
import json
import math
import warnings
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numpy.typing import NDArray

from .._deprecation import renamed_kwargs
from .._validation import InputError, register_model_type, validate_finite, validate_positive

__all__ = ["FE_MATRICES", "FEModel", "rpm_to_disc_speed", "rpm_to_omega"]

#: The matrix names of an FE brake model, in a fixed order.
FE_MATRICES: tuple[str, ...] = ("M", "D1", "DG", "DR", "D4", "K1", "KR", "KGeo")
_DAMPING = ("D1", "DR", "DG", "D4")
_STIFFNESS = ("K1", "KR", "KGeo")
#: Largest n whose mass matrix is checked for definiteness by a dense eigenvalue solve.
_DENSE_CHECK_MAX = 3000


#: Smallest largest mass entry accepted (the small models refuse masses below 1e-30 kg).
_MIN_MASS = 1e-30
#: Largest frequency scale sqrt(max|K1| / max|M|) / (2 pi) [Hz] accepted: far above any structural
#: vibration (an element of 0.1 mm of steel is near 1e7 Hz); beyond it M or K1 is in the wrong units.
_MAX_FREQ_SCALE = 1e9


def _real_matrix(name: str, value: Any) -> Any:
    """One matrix, sparse (as given) or a dense 2-D float array: real, square and finite, else one line naming it.

    Nothing of size n is allocated for a sparse matrix here: the declared size is checked
    against its entries (:func:`_check_dofs`) before the CSR form (n + 1 row pointers) is built.
    """
    if sp.issparse(value):
        mat = value
        dtype = mat.dtype
    else:
        try:
            mat = np.asarray(value)
        except (TypeError, ValueError) as e:
            raise InputError(f"Matrix {name} must be a numeric matrix: {e}") from e
        dtype = mat.dtype
    if dtype.kind == "c":
        raise InputError(f"Matrix {name} is complex ({dtype}); FE matrices must be real "
                         "(a complex part would be dropped).")
    if dtype.kind not in "biuf":
        raise InputError(f"Matrix {name} must be a real numeric matrix, got dtype {dtype}.")
    if mat.ndim != 2 or mat.shape[0] != mat.shape[1]:
        raise InputError(f"Matrix {name} must be square, got shape {mat.shape}.")
    values = mat.data if sp.issparse(mat) else mat
    if not np.all(np.isfinite(values)):
        raise InputError(f"Matrix {name} contains a non-finite value.")
    return mat if sp.issparse(mat) else mat.astype(np.float64)


def _check_dofs(mats: dict[str, Any]) -> None:
    """Every DOF has an entry in some matrix, checked in O(entries) before anything of size n is built.

    A DOF whose row is empty in M, every C and every K makes ``det(lambda^2 M + lambda C + K)``
    zero for every lambda (a singular pencil): no eigenvalue means anything. This also refuses
    a declared size far beyond the entries given (1e8 x 1e8 with one entry) before allocating.
    """
    n = next(iter(mats.values())).shape[0]
    if sum((m.nnz if sp.issparse(m) else n * n) for m in mats.values()) < n:
        entries = sum(m.nnz for m in mats.values() if sp.issparse(m))
        raise InputError(f"The matrices declare {n} DOFs but hold only {entries} entries: a DOF with no entry in "
                         "any matrix (no mass, damping or stiffness) makes the problem singular.")
    rows = [sp.coo_matrix(m).row for m in mats.values() if sp.issparse(m)]
    dense = [np.flatnonzero(np.any(m != 0, axis=1)) for m in mats.values() if not sp.issparse(m)]
    covered = np.zeros(n, dtype=bool)
    for r in (*rows, *dense):
        covered[r] = True
    if not covered.all():
        first = int(np.flatnonzero(~covered)[0])
        raise InputError(f"DOF {first} (of {n}) has no entry in any matrix (no mass, damping or stiffness): "
                         f"the problem is singular; {int((~covered).sum())} DOFs are like it.")


def _as_csr(mat: Any) -> sp.csr_matrix:
    out = sp.csr_matrix(mat, dtype=np.float64)
    out.sum_duplicates()
    out.eliminate_zeros()
    return out


def _check_scale(M: sp.csr_matrix, K1: sp.csr_matrix) -> None:
    """M and K1 of plausible scale: M not vanishing, the frequency scale sqrt(|K1|/|M|) not absurd."""
    m = abs(M).max() if M.nnz else 0.0
    if 0.0 < m < _MIN_MASS:
        raise InputError(f"Matrix M is implausibly small: its largest entry is {m:.3g} (below {_MIN_MASS:g} kg); "
                         "check the units of the matrices.")
    k = abs(K1).max() if K1.nnz else 0.0
    if m > 0.0 and k > 0.0:
        f = math.sqrt(k / m) / (2.0 * math.pi)
        if not f <= _MAX_FREQ_SCALE:
            raise InputError(f"Matrices M and K1 are of implausible relative scale: sqrt(max|K1| / max|M|) / 2 pi = "
                             f"{f:.3g} Hz (above {_MAX_FREQ_SCALE:g} Hz); check the units of M and K1.")


def _check_mass(M: sp.csr_matrix) -> None:
    """M symmetric positive semidefinite (definiteness checked densely up to a few thousand DOF)."""
    scale = abs(M).max() if M.nnz else 0.0
    if scale == 0.0:
        raise InputError("Matrix M is zero.")
    asym = abs(M - M.T).max() if M.nnz else 0.0
    if asym > 1e-10 * scale:
        raise InputError(f"Matrix M must be symmetric: max |M - M^T| = {asym:.3g} (max |M| = {scale:.3g}).")
    if M.diagonal().min() < 0.0:
        raise InputError(f"Matrix M must be positive semidefinite: a diagonal entry is {M.diagonal().min():.3g}.")
    if M.shape[0] <= _DENSE_CHECK_MAX:
        low = float(np.linalg.eigvalsh(M.toarray()).min())
        if low < -1e-10 * scale * M.shape[0]:
            raise InputError(f"Matrix M must be positive semidefinite: its smallest eigenvalue is {low:.3g}.")


@dataclass(frozen=True, eq=False)
class FEModel:
    """A finite element brake model: sparse ``M, D1, DG, DR, D4, K1, KR, KGeo`` (module docstring).

    Attributes
    ----------
    M, D1, DG, DR, D4, K1, KR, KGeo : scipy.sparse.csr_matrix or None, shape (n, n)
        The matrices; absent ones are None. ``M`` and ``K1`` are required.
    disc_speed_ref : float
        Disc speed [rad/s] at which ``DG``, ``KGeo`` (and ``DR``) were exported (formerly
        ``omega_ref``, still accepted with a DeprecationWarning).
    mu_ref : float
        Friction coefficient at which ``KR`` and ``DR`` were exported.
    f_ref : float
        Reference value dividing ``D4`` (NLEVP's ``Fref``).
    dof_names : tuple of str, optional
        A name per DOF (e.g. ``node12.uz``); default ``q0, q1, ...``.
    mesh : object, optional
        Mesh metadata (a :class:`~squealkit.fe.mesh.FEMesh`, or a ``meshio.Mesh`` whose points
        carry the DOFs), for mode shape export.
    source : str, optional
        Where the matrices came from (a file name), recorded in results.
    dof_map : DofMap, optional
        The ``(node, DOF)`` label of each unknown (:class:`~squealkit.fe.dofmap.DofMap`), as read
        from labelled files; it names the DOFs when ``dof_names`` is not given.

    Examples
    --------
    >>> m = FEModel.from_matrices(M=np.eye(2), K1=np.diag([4.0, 9.0]), KR=[[0, 1.0], [-1.0, 0]])
    >>> m.n_dof
    2
    >>> m.stiffness_matrix(disc_speed=1.0, mu=0.5).toarray().tolist()
    [[4.0, 0.5], [-0.5, 9.0]]
    """

    kind: ClassVar[str] = "fe"

    M: Any = None
    D1: Any = None
    DG: Any = None
    DR: Any = None
    D4: Any = None
    K1: Any = None
    KR: Any = None
    KGeo: Any = None
    disc_speed_ref: float = 1.0
    mu_ref: float = 1.0
    f_ref: float = 1.0
    dof_names: tuple[str, ...] | None = None
    mesh: Any = None
    source: str | None = None
    dof_map: Any = None

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        for name in ("M", "K1"):
            if getattr(self, name) is None:
                raise InputError(f"An FE model needs matrix {name}.")
        mats: dict[str, Any] = {}
        for name in FE_MATRICES:
            value = getattr(self, name)
            if value is None:
                continue
            mat = _real_matrix(name, value)
            n = mats["M"].shape[0] if mats else mat.shape[0]
            if mat.shape[0] != n:
                raise InputError(f"Matrix {name} must be {n}x{n} like M, got shape {mat.shape}.")
            mats[name] = mat
        _check_dofs(mats)
        for name, mat in mats.items():
            set_(self, name, _as_csr(mat))
        n = self.M.shape[0]
        _check_mass(self.M)
        _check_scale(self.M, self.K1)
        for name in ("disc_speed_ref", "mu_ref", "f_ref"):
            set_(self, name, validate_positive(name, getattr(self, name)))
        if self.dof_map is not None:
            from .dofmap import DofMap

            if not isinstance(self.dof_map, DofMap) or self.dof_map.n_dof != n:
                raise InputError(f"Parameter dof_map must be a DofMap of {n} DOFs, got {self.dof_map!r:.60}.")
            if self.dof_names is None:
                set_(self, "dof_names", self.dof_map.names)
        names = tuple(f"q{i}" for i in range(n)) if self.dof_names is None else tuple(map(str, self.dof_names))
        if len(names) != n:
            raise InputError(f"Parameter dof_names has {len(names)} entries for {n} DOFs.")
        set_(self, "dof_names", names)

    @property
    def omega_ref(self) -> float:
        """Deprecated name of :attr:`disc_speed_ref` (``omega`` is an eigenfrequency elsewhere)."""
        warnings.warn("FEModel.omega_ref is deprecated; use disc_speed_ref (same meaning).",
                      DeprecationWarning, stacklevel=2)
        return self.disc_speed_ref

    @classmethod
    @renamed_kwargs(omega_ref="disc_speed_ref")
    def from_matrices(cls, *, disc_speed_ref: float = 1.0, mu_ref: float = 1.0, f_ref: float = 1.0,
                      dof_names: Any = None, mesh: Any = None, source: str | None = None, dof_map: Any = None,
                      **mats: Any) -> FEModel:
        """The model of the matrices given by name (``M=..., K1=..., KR=...``), validated.

        Parameters
        ----------
        disc_speed_ref, mu_ref, f_ref : float, default 1.0
            Reference values (see the class: disc speed [rad/s], friction coefficient, ``Fref``);
            ``omega_ref=`` is the deprecated name of ``disc_speed_ref=``.
        dof_names : tuple of str, optional
            A name per DOF.
        mesh : object, optional
            Mesh metadata for mode shape export.
        source : str, optional
            Where the matrices came from.
        dof_map : DofMap, optional
            The ``(node, DOF)`` label of each DOF.
        **mats : array_like or sparse matrix
            The matrices by name (``M``, ``D1``, ``DG``, ``DR``, ``D4``, ``K1``, ``KR``, ``KGeo``).

        Returns
        -------
        FEModel

        Raises
        ------
        InputError
            For an unknown matrix name, a matrix that is complex, not square, of another size than
            ``M`` or not finite, a DOF with no entry in any matrix, ``M`` not symmetric positive
            semidefinite, or ``M`` of implausible scale (largest entry below 1e-30, or
            ``sqrt(max|K1|/max|M|)/2 pi`` above 1e9 Hz); the message names it.
        """
        for name in mats:
            if name not in FE_MATRICES:
                raise InputError(f"Unknown FE matrix {name!r}; known: {', '.join(FE_MATRICES)}.")
        return cls(**mats, disc_speed_ref=disc_speed_ref, mu_ref=mu_ref, f_ref=f_ref, dof_names=dof_names, mesh=mesh,
                   source=source, dof_map=dof_map)

    # -- size and parts ----------------------------------------------------------------
    @property
    def n_dof(self) -> int:
        """Number of degrees of freedom n."""
        return self.M.shape[0]

    @property
    def present(self) -> tuple[str, ...]:
        """Names of the matrices the model has."""
        return tuple(name for name in FE_MATRICES if getattr(self, name) is not None)

    @renamed_kwargs(omega="disc_speed")
    def factors(self, disc_speed: float, mu: float, tan_theta: float = 0.0) -> dict[str, float]:
        """The scalar multiplying each present damping and stiffness matrix at ``(disc_speed, mu)``.

        ``C = sum f[D] D`` over the damping matrices and ``K = sum f[K] K`` over the stiffness
        matrices; ``mu_e = mu + tan_theta`` is the friction (run-out slope as extra friction).

        Parameters
        ----------
        disc_speed : float
            Disc speed [rad/s] (> 0 when ``DR`` is present); ``omega=`` is its deprecated keyword.
        mu : float
            Friction coefficient.
        tan_theta : float, default 0.0
            Run-out slope [1]; ``mu_e = mu + tan_theta`` replaces ``mu``.

        Returns
        -------
        dict of str to float
            Matrix name -> factor, for the matrices present.
        """
        disc_speed = validate_finite("disc_speed", disc_speed)
        mu_e = validate_finite("mu", mu) + validate_finite("tan_theta", tan_theta)
        if self.DR is not None and not disc_speed > 0.0:
            raise InputError(f"Parameter disc_speed={disc_speed!r} rad/s must be > 0: "
                             "DR is scaled by disc_speed_ref/disc_speed.")
        f = {
            "D1": 1.0,
            "DR": (mu_e / self.mu_ref) * (self.disc_speed_ref / disc_speed) if disc_speed else 0.0,
            "DG": disc_speed / self.disc_speed_ref,
            "D4": 1.0 / self.f_ref,
            "K1": 1.0,
            "KR": mu_e / self.mu_ref,
            "KGeo": (disc_speed / self.disc_speed_ref) ** 2,
        }
        return {k: v for k, v in f.items() if getattr(self, k) is not None}

    def _combine(self, names: tuple[str, ...], f: dict[str, float]) -> sp.csr_matrix:
        out = sp.csr_matrix(self.M.shape, dtype=np.float64)
        for name in names:
            if name in f and f[name] != 0.0:
                out = out + f[name] * getattr(self, name)
        return out.tocsr()

    # -- the model interface -----------------------------------------------------------
    def mass_matrix(self) -> sp.csr_matrix:
        """Mass matrix M, shape (n, n), sparse."""
        return self.M

    @renamed_kwargs(omega="disc_speed")
    def damping_matrix(self, disc_speed: float, mu: float, tan_theta: float = 0.0) -> sp.csr_matrix:
        """``C = D1 + (mu_e/mu_ref)(v_ref/v) DR + (v/v_ref) DG + D4/f_ref``, v the disc speed, v_ref disc_speed_ref.

        Parameters
        ----------
        disc_speed : float
            Disc speed [rad/s] (> 0 when ``DR`` is present); ``omega=`` is its deprecated keyword.
        mu : float
            Friction coefficient.
        tan_theta : float, default 0.0
            Run-out slope [1]; ``mu_e = mu + tan_theta`` replaces ``mu``.

        Returns
        -------
        scipy.sparse.csr_matrix, shape (n, n)
        """
        return self._combine(_DAMPING, self.factors(disc_speed, mu, tan_theta))

    @renamed_kwargs(omega="disc_speed")
    def stiffness_matrix(self, disc_speed: float, mu: float, tan_theta: float = 0.0) -> sp.csr_matrix:
        """``K(disc_speed, mu) = K1 + (mu_e/mu_ref) KR + (disc_speed/disc_speed_ref)^2 KGeo``.

        Parameters
        ----------
        disc_speed : float
            Disc speed [rad/s] (> 0 when ``DR`` is present); ``omega=`` is its deprecated keyword.
        mu : float
            Friction coefficient.
        tan_theta : float, default 0.0
            Run-out slope [1]; ``mu_e = mu + tan_theta`` replaces ``mu``.

        Returns
        -------
        scipy.sparse.csr_matrix, shape (n, n)
        """
        return self._combine(_STIFFNESS, self.factors(disc_speed, mu, tan_theta))

    # -- derived models ------------------------------------------------------------------
    @renamed_kwargs(omega_ref="disc_speed_ref")
    def replace(self, **changes: Any) -> FEModel:
        """A new model with reference values (``disc_speed_ref``, ``mu_ref``, ``f_ref``) or matrices changed."""
        allowed = {"disc_speed_ref", "mu_ref", "f_ref", *FE_MATRICES}
        for key in changes:
            if key not in allowed:
                raise InputError(f"Unknown parameter {key!r} for model 'fe'; known: disc_speed_ref, mu_ref, f_ref.")
        return dataclasses.replace(self, **changes)

    def project(self, V: Any) -> FEModel:
        """The reduced model ``V^T A V`` of every matrix A, for a real basis V (n x k).

        The reduced model keeps the reference values; its DOFs are the basis vectors.

        Parameters
        ----------
        V : array_like, shape (n, k)
            A real, finite basis.

        Returns
        -------
        FEModel
            The k-DOF model, DOFs named ``b0, b1, ...``.
        """
        V = np.asarray(V, dtype=np.float64)
        if V.ndim != 2 or V.shape[0] != self.n_dof or not np.all(np.isfinite(V)):
            raise InputError(f"Basis V must be a finite {self.n_dof} x k matrix, got shape {V.shape}.")
        mats = {name: V.T @ (getattr(self, name) @ V) for name in self.present}
        return FEModel(**mats, disc_speed_ref=self.disc_speed_ref, mu_ref=self.mu_ref, f_ref=self.f_ref,
                       dof_names=tuple(f"b{i}" for i in range(V.shape[1])), source=self.source)

    def to_dict(self) -> dict[str, Any]:
        """What the model is, for result attributes (not the matrices)."""
        return {"kind": self.kind, "n_dof": self.n_dof, "matrices": list(self.present),
                "disc_speed_ref": self.disc_speed_ref, "mu_ref": self.mu_ref, "f_ref": self.f_ref,
                "source": self.source}

    def to_json(self) -> str:
        """:meth:`to_dict` as a JSON string."""
        return json.dumps(self.to_dict(), sort_keys=True)

    @renamed_kwargs(omega="disc_speed")
    def norms(self, disc_speed: float, mu: float, tan_theta: float = 0.0) -> tuple[float, float, float]:
        """Frobenius norms of M, C and K at ``(disc_speed, mu)`` (for backward errors).

        Parameters
        ----------
        disc_speed : float
            Disc speed [rad/s] (> 0 when ``DR`` is present); ``omega=`` is its deprecated keyword.
        mu : float
            Friction coefficient.
        tan_theta : float, default 0.0
            Run-out slope [1]; ``mu_e = mu + tan_theta`` replaces ``mu``.

        Returns
        -------
        (float, float, float)
        """
        f = self.factors(disc_speed, mu, tan_theta)
        return (float(spla.norm(self.M)), float(spla.norm(self._combine(_DAMPING, f))),
                float(spla.norm(self._combine(_STIFFNESS, f))))


register_model_type("fe", FEModel)  # validate_model knows it without importing fe/

# ``FEModel(..., omega_ref=...)``: the dataclass' own constructor takes the old name for one release too
FEModel.__init__ = renamed_kwargs(omega_ref="disc_speed_ref")(FEModel.__init__)  # type: ignore[method-assign]


def rpm_to_disc_speed(rpm: Any) -> NDArray[np.float64]:
    """Disc speed [rad/s] of ``rpm`` revolutions per minute: ``disc_speed = 2 pi rpm / 60``.

    Parameters
    ----------
    rpm : array_like
        Revolutions per minute.

    Returns
    -------
    ndarray of float64, shape of ``rpm``

    Examples
    --------
    >>> float(rpm_to_disc_speed(60.0))  # one revolution per second
    6.283185307179586
    """
    return np.asarray(rpm, dtype=np.float64) * (2.0 * math.pi / 60.0)


def rpm_to_omega(rpm: Any) -> NDArray[np.float64]:
    """Deprecated name of :func:`rpm_to_disc_speed` (``omega`` is an eigenfrequency elsewhere).

    Parameters
    ----------
    rpm : array_like
        Revolutions per minute.

    Returns
    -------
    ndarray of float64, shape of ``rpm``
    """
    warnings.warn("rpm_to_omega is deprecated; use rpm_to_disc_speed (same meaning).", DeprecationWarning,
                  stacklevel=2)
    return rpm_to_disc_speed(rpm)

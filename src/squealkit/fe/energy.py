"""Energy of the complex modes of an FE brake: friction work per node, and the body that carries the mode.

Friction work
-------------
A mode ``x(t) = Re(phi e^{lambda t})``, ``lambda = sigma + j omega``, feels the friction force
``f = -K_f x - D_f x'`` with ``K_f = (mu_e/mu_ref) KR`` and ``D_f = (mu_e/mu_ref)(v_ref/v) DR`` the
friction parts of ``K`` and ``C`` (:class:`~squealkit.fe.model.FEModel`). Over one cycle
``T = 2 pi / omega`` (of the harmonic part) its work on unknown ``i`` is
``W_i = int_0^T f_i x_i' dt = (T/2) Re(conj(F_i) j omega phi_i)`` with ``F = -(K_f + j omega D_f) phi``::

    W_i = -pi Im(conj(phi_i) (K_f phi)_i) - pi omega Re(conj(phi_i) (D_f phi)_i)      [J per cycle]

(the energy friction feeds in through DOF ``i``; positive: fed in). Summed over a node's DOFs it is
the work per node, drawn on the contact surface.

Energy balance
--------------
``phi^H (lambda^2 M + lambda C + K) phi = 0`` with ``m = phi^H M phi`` (real), ``c = phi^H C phi``,
``k = phi^H K phi``: its imaginary part is ``2 sigma omega m + omega Re(c) + sigma Im(c) + Im(k) = 0``.
Splitting ``C = D_f + C_o`` and ``K = K_f + K_o`` gives exactly::

    W_friction - W_other = pi sigma (2 omega m + Im(c)),    W_friction = sum_i W_i,
    W_other = pi omega Re(phi^H C_o phi) + pi Im(phi^H K_o phi)

(``W_other`` is what the other forces remove: material damping; the gyroscopic ``DG`` is skew
and only enters ``Im(c)``). ``2 pi sigma omega m`` is the growth ``2 sigma T E`` of the energy
``E = omega^2 m / 2`` over one cycle: a mode grows exactly when friction feeds in more than the
rest removes. :func:`mode_energy` returns both sides (``net_work``, ``growth_work``).

Dominant body
-------------
The kinetic energy ``omega^2/2 Re(conj(phi_i)(M phi)_i)`` and the strain energy
``1/2 Re(conj(phi_i)(K1 phi)_i)`` per DOF, summed over the DOFs of each body of the mesh
(:func:`~squealkit.fe.surface.bodies`), say which part carries the mode.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from .._deprecation import TAN_THETA_WHY, keyword_only
from .._validation import InputError, validate_model
from .surface import bodies, dof_places, mesh_of

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["friction_parts", "mode_energy"]

#: Points closer than this fraction of the mesh size are one contact point (a node-to-node pair).
_COINCIDENT_RTOL = 1e-7
#: Bodies whose energy shares differ by less than this (relative) share the lead (twin pads).
_TIE = 0.02


@keyword_only("tan_theta", why=TAN_THETA_WHY)
def friction_parts(model: Any, disc_speed: float, mu: float, *, tan_theta: float = 0.0
                   ) -> tuple[sp.csr_matrix, sp.csr_matrix]:
    """The friction parts ``(K_f, D_f)`` of the stiffness and damping at one operating point.

    ``K_f = (mu_e/mu_ref) KR`` and ``D_f = (mu_e/mu_ref)(disc_speed_ref/disc_speed) DR`` (zero
    matrices where the model has no ``KR`` or ``DR``), ``mu_e = mu + tan_theta``.

    Parameters
    ----------
    model : FEModel
    disc_speed : float
        Disc speed [rad/s].
    mu : float
        Friction coefficient.
    tan_theta : float, default 0.0
        Run-out slope [1] (keyword-only; by position it warns, for one release).

    Returns
    -------
    (scipy.sparse.csr_matrix, scipy.sparse.csr_matrix), each shape (n, n)
    """
    f = model.factors(disc_speed, mu, tan_theta)
    zero = sp.csr_matrix(model.M.shape, dtype=np.float64)
    Kf = f["KR"] * model.KR if model.KR is not None else zero
    Df = f["DR"] * model.DR if model.DR is not None else zero
    return sp.csr_matrix(Kf), sp.csr_matrix(Df)


def _shapes(ds: xr.Dataset) -> NDArray[np.complex128]:
    if ds.attrs.get("kind") != "fe_modes" or "shape_real" not in ds:
        raise InputError("mode_energy takes a result of fe_modes (kind 'fe_modes', with shape_real/shape_imag).")
    return (ds["shape_real"].values + 1j * ds["shape_imag"].values).astype(np.complex128)


def _per_dof(A: sp.spmatrix, X: NDArray) -> NDArray[np.complex128]:
    """``conj(X) * (A X)``: each DOF's share of ``x^H A x``, shape (n, modes)."""
    return X.conj() * (A @ X)


def mode_energy(model: Any, ds: xr.Dataset) -> xr.Dataset:
    """Friction work per DOF, node and contact point, the energy balance, and the body carrying each mode.

    Parameters
    ----------
    model : FEModel
        The model the modes were computed for.
    ds : xarray.Dataset
        A result of :func:`~squealkit.stability.fe_modes` (its shapes, eigenvalues and
        operating point ``disc_speed``, ``mu``, ``tan_theta``).

    Returns
    -------
    xarray.Dataset
        ``kind = "fe_mode_energy"``; the eigenvalue variables of ``ds`` and, over ``mode``:
        ``friction_work``, ``other_work``, ``net_work`` (friction minus other), ``growth_work``
        (``pi sigma (2 omega m + Im c)``: equal to ``net_work``) [J per cycle for the shape
        scaled to 1 m largest amplitude; NaN for a real root], ``modal_mass`` [kg],
        ``dominant_body`` (text: the body with the largest kinetic energy, or those within 2 %
        of it joined by ``" + "``), ``dominant_dof`` (the DOF with the largest kinetic
        energy) and ``dominant_dof_share``; over ``(dof, mode)``: ``friction_work_dof``; over
        ``(body, mode)``: ``kinetic_share``, ``strain_share`` (sum 1 over the bodies and the
        DOFs off them, ``body = "off the mesh"`` last). With a mesh, over
        ``(contact_point, mode)``: ``friction_work_contact``, the work summed over the
        coincident nodes of each contact pair (disc node and pad node), at ``contact_x``,
        ``contact_y``, ``contact_z`` [m] on ``contact_body`` (the smaller body of the pair,
        the pad), and ``friction_work_drawn`` over ``mode``: their sum (below
        ``friction_work`` where friction acts on nodes off the mesh, e.g. the mid-side
        nodes of a mesh given by its vertices).

    Examples
    --------
    >>> from squealkit.fe import FEModel
    >>> from squealkit.stability import fe_modes
    >>> m = FEModel.from_matrices(M=np.eye(2), K1=4.0 * np.eye(2), KR=[[0.0, 1.0], [-1.0, 0.0]])
    >>> e = mode_energy(m, fe_modes(m, 60.0, 1.0))
    >>> bool(np.allclose(e.net_work, e.growth_work))
    True
    """
    import xarray as xr

    validate_model(model, kind="fe")
    X = _shapes(ds)
    if X.shape[0] != model.n_dof:
        raise InputError(f"The modes have {X.shape[0]} DOFs, the model {model.n_dof}: not this model's modes.")
    v, mu, t = float(ds.attrs["disc_speed"]), float(ds.attrs["mu"]), float(ds.attrs["tan_theta"])
    Kf, Df = friction_parts(model, v, mu, tan_theta=t)
    C, K = model.damping_matrix(v, mu, t), model.stiffness_matrix(v, mu, t)
    sigma = ds["growth_rate"].values
    omega = 2.0 * math.pi * ds["frequency_hz"].values
    oscillating = omega > 0.0
    w_dof = -math.pi * _per_dof(Kf, X).imag - math.pi * omega * _per_dof(Df, X).real
    w_dof[:, ~oscillating] = np.nan
    m = _per_dof(model.M, X).real.sum(axis=0)
    c = _per_dof(C, X).sum(axis=0)
    other = math.pi * omega * _per_dof(C - Df, X).real.sum(axis=0) + math.pi * _per_dof(K - Kf, X).imag.sum(axis=0)
    friction = w_dof.sum(axis=0)
    nan = np.where(oscillating, 1.0, np.nan)
    growth = math.pi * sigma * (2.0 * omega * m + c.imag) * nan

    # the shares of omega^2/2 Re(conj(phi_i)(M phi)_i): omega^2 cancels (and real roots get shares too)
    kinetic = 0.5 * _per_dof(model.M, X).real
    strain = 0.5 * _per_dof(model.K1, X).real
    parts = bodies(model) if getattr(model, "mesh", None) is not None else None
    body_vars, names, attrs = _body_shares(model, parts, kinetic, strain)
    top = np.argmax(np.abs(kinetic), axis=0)
    body_vars["dominant_dof"] = ("mode", np.array([ds["dof"].values[i] for i in top], dtype=str),
                                 {"long_name": "DOF with the largest kinetic energy"})
    with np.errstate(invalid="ignore", divide="ignore"):
        share = kinetic[top, np.arange(top.size)] / kinetic.sum(axis=0)
    body_vars["dominant_dof_share"] = ("mode", share, {"units": "1", "long_name": "its share of the kinetic energy"})
    md = ("mode",)
    out = xr.Dataset(
        {
            **{k: ds[k] for k in ("growth_rate", "frequency_hz", "damping_ratio", "unstable") if k in ds},
            "friction_work_dof": (("dof", "mode"), w_dof,
                                  {"units": "J", "long_name": "friction work per cycle through each DOF"}),
            "friction_work": (md, friction * nan, {"units": "J", "long_name": "energy fed in by friction per cycle"}),
            "other_work": (md, other * nan, {"units": "J", "long_name": "energy removed per cycle by the other forces "
                                                                      "(material damping)"}),
            "net_work": (md, (friction - other) * nan, {"units": "J", "long_name": "friction work minus other work"}),
            "growth_work": (md, growth, {"units": "J", "long_name": "pi sigma (2 omega m + Im c): the energy gain per "
                                                                    "cycle of the growth rate"}),
            "modal_mass": (md, m, {"units": "kg", "long_name": "phi^H M phi"}),
            **body_vars,
        },
        coords={"mode": ds["mode"].values, "dof": ds["dof"].values, "body": list(names)},
        attrs={**{k: ds.attrs[k] for k in ("rpm", "disc_speed", "mu", "theta", "tan_theta", "verdict", "model",
                                           "model_kind") if k in ds.attrs},
               "kind": "fe_mode_energy", "title": "Friction work and energy of the complex modes",
               "scale": "shapes scaled to 1 m largest amplitude; energies scale with amplitude^2",
               **attrs},
    )
    if getattr(model, "mesh", None) is not None:
        out = out.merge(_contact_points(model, parts, w_dof, out["mode"].values))
        out.attrs["kind"] = "fe_mode_energy"
    return out


def _body_shares(model: Any, b: Any, kinetic: NDArray, strain: NDArray) -> tuple[dict, tuple[str, ...], dict]:
    """Kinetic and strain energy shares per body (and off the mesh), the dominant body of each mode."""
    if b is None:
        of = np.zeros(model.n_dof, dtype=np.int64)
        names: tuple[str, ...] = ("model",)
        attrs = {"bodies": "model: no mesh, one body"}
    else:
        of = b.of_dof
        names = b.names
        attrs = {"bodies": "; ".join(b.describe(k) for k in range(len(b.names)))}
    off = of < 0
    labels = np.where(off, len(names), of)
    n_b = len(names) + 1
    S = sp.csr_matrix((np.ones(of.size), (labels, np.arange(of.size))), shape=(n_b, of.size))
    with np.errstate(invalid="ignore", divide="ignore"):
        kin = (S @ kinetic) / kinetic.sum(axis=0)
        pot = (S @ strain) / strain.sum(axis=0)
    all_names = (*names, "off the mesh")
    if not off.any():
        kin, pot, all_names = kin[:-1], pot[:-1], names
    dominant = np.array([_dominant(all_names, k) for k in kin.T], dtype=str)
    dims = ("body", "mode")
    return ({"kinetic_share": (dims, kin, {"units": "1", "long_name": "share of the kinetic energy"}),
             "strain_share": (dims, pot, {"units": "1", "long_name": "share of the strain energy (K1)"}),
             "dominant_body": ("mode", dominant, {"long_name": "body with the largest share of the kinetic energy"})},
            all_names, attrs)


def _dominant(names: tuple[str, ...], share: NDArray) -> str:
    """The body with the largest share, or the bodies within 2 % of it (``body 2 + body 3``: twin pads)."""
    if not np.any(np.isfinite(share)):
        return ""
    top = np.nanmax(share)
    return " + ".join(names[i] for i in np.flatnonzero(share >= top - _TIE * abs(top)))


def _contact_points(model: Any, b: Any, w_dof: NDArray, modes: NDArray) -> xr.Dataset:
    """The friction work summed per node and over coincident nodes (contact pairs), on the mesh."""
    import xarray as xr
    points, _cells = mesh_of(model)
    dof, point, _comp = dof_places(model)
    active = np.flatnonzero(np.nan_to_num(np.abs(w_dof[dof])).max(axis=1, initial=0.0) > 0.0)
    friction_rows = _friction_dofs(model)
    on = np.isin(dof, friction_rows)
    sel = np.union1d(active, np.flatnonzero(on))
    pts = np.unique(point[sel])
    per_point = np.zeros((pts.size, w_dof.shape[1]))
    np.add.at(per_point, np.searchsorted(pts, point[sel]), w_dof[dof[sel]])
    # coincident nodes (a disc node and the pad node on it) are one contact point
    size = float(np.ptp(points, axis=0).max()) or 1.0
    xyz = points[pts]
    groups = _coincident_groups(xyz, _COINCIDENT_RTOL * size)
    n_g = int(groups.max(initial=-1)) + 1
    work = np.zeros((n_g, w_dof.shape[1]))
    np.add.at(work, groups, per_point)
    first = np.zeros(n_g, dtype=np.int64)
    first[groups[::-1]] = np.arange(groups.size)[::-1]
    # the surface it is drawn on: the smaller body of the pair (the pad, not the disc)
    body_of_point = np.full(len(points), -1, dtype=np.int64)
    body_of_point[point] = b.of_dof[dof]
    member_body = body_of_point[pts]
    surface = np.full(n_g, -1, dtype=np.int64)
    np.maximum.at(surface, groups, member_body)  # bodies are numbered largest first
    dims = ("contact_point",)
    return xr.Dataset(
        {"friction_work_contact": (("contact_point", "mode"), work,
                                   {"units": "J", "long_name": "friction work per cycle at each contact point"}),
         "friction_work_drawn": (("mode",), work.sum(axis=0),
                                 {"units": "J", "long_name": "friction work through DOFs on the mesh's nodes (the "
                                                            "rest acts on nodes off the mesh)"})},
        coords={"mode": modes, "contact_point": np.arange(n_g),
                "contact_x": (dims, xyz[first, 0], {"units": "m"}), "contact_y": (dims, xyz[first, 1], {"units": "m"}),
                "contact_z": (dims, xyz[first, 2], {"units": "m"}),
                "contact_body": (dims, np.array([b.names[s] if s >= 0 else "" for s in surface], dtype=str))},
    )


def _friction_dofs(model: Any) -> NDArray[np.int64]:
    """DOFs a friction force acts on: the non-empty rows of KR and DR."""
    rows = [np.flatnonzero(np.diff(sp.csr_matrix(A).indptr)) for A in (model.KR, model.DR) if A is not None]
    return np.unique(np.concatenate(rows)) if rows else np.zeros(0, dtype=np.int64)


def _coincident_groups(xyz: NDArray, tol: float) -> NDArray[np.int64]:
    """A group number per point, points within ``tol`` of each other in one group (numbered 0..g-1)."""
    if not len(xyz):
        return np.zeros(0, dtype=np.int64)
    from scipy.spatial import cKDTree

    pairs = cKDTree(xyz).query_pairs(tol, output_type="ndarray")
    from scipy.sparse.csgraph import connected_components

    g = sp.coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(xyz), len(xyz)))
    _, labels = connected_components(g, directed=False)
    return labels.astype(np.int64)

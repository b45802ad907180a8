"""A built-in finite element disc brake: annular cast-iron disc and two pads (scikit-fem).

The model ships with squealkit so that the FE path (sparse matrices, band eigenvalues,
reduction) can be tried and benchmarked without a commercial FE code. It is exported in the
matrix form of industrial complex eigenvalue analysis (Abaqus/ANSYS/Nastran)::

    M u'' + C(v, mu) u' + K(v, mu) u = 0      (v the disc speed [rad/s], v_ref = disc_speed_ref)
    C = D1 + (v / v_ref) DG
    K = K1 + (mu / mu_ref) KR + (v / v_ref)**2 KGeo

What is in it
-------------
* Disc: annulus ``r_inner <= r <= r_outer``, ``0 <= z <= thickness``, solid 27-node
  (triquadratic) hexahedra on a structured (r, theta, z) grid with ``n_theta`` equal sectors,
  so the disc alone is cyclically symmetric and its n-nodal-diameter modes come in exact
  doublets (n < n_theta / 2). All nodes at ``r = r_inner`` are fixed (clamped hat joint).
* Pads: two blocks of friction material (inboard ``z < 0`` and outboard ``z > thickness``),
  meshed on the same (r, theta) grid so their contact faces have the disc's surface nodes.
  Their back faces sit on distributed springs to ground (piston/finger normal, abutment
  tangential: ``k_back_normal``, ``k_back_tangential`` [N/m^3]).
* Contact: node-to-node normal springs between coincident pad and disc surface nodes,
  ``k_i = k_contact * a_i`` with ``a_i = integral(N_i dA)`` over the pad face (positive for
  27-node faces). No tangential contact stiffness (the pad slides).
* Friction ``KR`` (at ``mu_ref``): the change of the normal force ``dN_i`` at each contact
  pair gives a friction force ``-mu dN_i e_theta`` on the disc node and ``+mu dN_i e_theta``
  on the pad node (disc turning about +z, ``e_theta`` at the node): the follower-friction
  coupling of mode-coupling squeal. ``KR`` is non-symmetric, its forces sum to zero (action
  equals reaction) and a common normal motion of a pair gives none.
* Rotation (disc only), at ``disc_speed_ref``: the transport (Eulerian) terms of the out-of-plane
  displacement ``w`` of a disc seen from the non-rotating pads,
  ``DG = disc_speed_ref int rho (N_i d_theta N_j - d_theta N_i N_j) dV`` (skew, Coriolis of the
  travelling waves) and the convective softening ``-disc_speed_ref^2 int rho d_theta N_i d_theta N_j dV``;
  plus the centrifugal stress stiffening ``disc_speed_ref^2 int sigma : (grad N_i grad N_j) dV``
  of all three components with the plane-stress stress of a spinning annulus clamped at
  ``r_inner`` and free at ``r_outer`` (Timoshenko & Goodier, Theory of Elasticity, §32).
  ``KGeo`` is the sum of the last two. Omitted: the in-plane Coriolis and spin-softening
  terms, and the change of geometry under the centrifugal load.
* Damping ``D1 = alpha M + beta K1`` (Rayleigh). ``DR`` and ``D4`` are not generated.

Example
-------
>>> from squealkit.fe.demo import build_fe_demo
>>> demo = build_fe_demo(n_theta=16, n_r=2)
>>> demo["M"].shape == demo["K1"].shape and demo["KR"].nnz > 0
True
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import scipy.sparse as sp

from .._deprecation import renamed_kwargs
from .._optional import available, require
from .._validation import InputError, check_budget
from .dofmap import DofMap
from .mesh import FEMesh, abaqus_inp_text

__all__ = ["FEDemoGeometry", "build_fe_demo", "demo_dof_map", "demo_mesh", "fe_demo_dofs", "write_fe_demo"]

#: Matrix names of the exported form (absent ones are ``None``).
FE_MATRIX_NAMES = ("M", "D1", "DG", "DR", "D4", "K1", "KR", "KGeo")


@dataclass(frozen=True)
class FEDemoGeometry:
    """Dimensions [m] and materials (SI) of the built-in disc brake.

    Defaults: a ventilated-size solid cast-iron disc (grey iron ``E = 125 GPa``,
    ``rho = 7200 kg/m^3``, ``nu = 0.25``) and organic friction material pads.

    Attributes
    ----------
    r_inner, r_outer : float
        Inner and outer radius of the disc [m].
    thickness : float
        Disc thickness [m].
    E_disc, nu_disc, rho_disc : float
        Young's modulus [Pa], Poisson's ratio and density [kg/m^3] of the disc.
    pad_r_inner : float
        Inner radius of the pads [m] (between ``r_inner`` and ``r_outer``).
    pad_arc_deg : float
        Angle the pads span [deg].
    pad_thickness : float
        Pad thickness [m].
    E_pad, nu_pad, rho_pad : float
        Young's modulus [Pa], Poisson's ratio and density [kg/m^3] of the friction material.
    k_contact : float
        Normal contact stiffness per unit area between disc and pads [N/m^3].
    k_back_normal : float
        Stiffness per unit area of the piston and fingers behind the pads [N/m^3].
    k_back_tangential : float
        Stiffness per unit area of the abutments in the pads' plane [N/m^3].
    """

    r_inner: float = 0.08
    r_outer: float = 0.14
    thickness: float = 0.015
    E_disc: float = 125e9
    nu_disc: float = 0.25
    rho_disc: float = 7200.0
    pad_r_inner: float = 0.095
    pad_arc_deg: float = 50.0
    pad_thickness: float = 0.012
    E_pad: float = 5e9
    nu_pad: float = 0.3
    rho_pad: float = 2500.0
    k_contact: float = 5e12  # N/m^3: normal contact stiffness per unit area
    k_back_normal: float = 2e12  # N/m^3: piston/fingers behind the pad
    k_back_tangential: float = 5e11  # N/m^3: abutment of the pad in its plane

    def validate(self) -> None:
        for name, value in vars(self).items():
            if not (math.isfinite(value) and value > 0):
                raise InputError(f"FE demo geometry: {name}={value!r} must be a finite positive number.")
        if not self.r_inner < self.pad_r_inner < self.r_outer:
            raise InputError(
                f"FE demo geometry: pad_r_inner={self.pad_r_inner} must lie between "
                f"r_inner={self.r_inner} and r_outer={self.r_outer}."
            )
        if not 0 < self.pad_arc_deg < 180:
            raise InputError(f"FE demo geometry: pad_arc_deg={self.pad_arc_deg} must be in (0, 180).")


#: Lower bounds of the memory [bytes] and time [s] one 27-node element costs to build (budget).
_BYTES_PER_ELEMENT = 2.5e5
_SECONDS_PER_ELEMENT = 2.5e-3


def fe_demo_dofs(n_theta: int, n_r: int | None = None, n_z: int = 1) -> int:
    """Unknowns of the disc alone before clamping (27-node hexahedra, 3 per node): a size guide.

    Parameters
    ----------
    n_theta : int
        Elements around the disc, as :func:`build_fe_demo` takes it.
    n_r : int, optional
        Elements across the friction ring; default keeps them about square (as :func:`build_fe_demo`).
    n_z : int, default 1
        Elements through the disc thickness.

    Returns
    -------
    int
        Unknowns of the disc's mesh alone, before clamping (the pads add some, the clamping
        removes some: 7 776 here for the 8 802 of ``build_fe_demo(48)``).

    Examples
    --------
    >>> fe_demo_dofs(128, 13, 2)
    103680
    """
    n_r = _default_n_r(n_theta) if n_r is None else n_r
    return 3 * (2 * n_r + 1) * (2 * n_theta) * (2 * n_z + 1)


def _default_n_r(n_theta: int, geom: FEDemoGeometry | None = None) -> int:
    g = geom or FEDemoGeometry()
    r_mean = 0.5 * (g.r_inner + g.r_outer)
    return max(2, round(n_theta * (g.r_outer - g.r_inner) / (2 * math.pi * r_mean)))


# ----------------------------------------------------------------------------- mesh


def _annular_hex(r: np.ndarray, theta: np.ndarray, z: np.ndarray, periodic: bool):
    """Hexahedra of a (r, theta, z) tensor grid mapped to Cartesian; merges theta = 2 pi."""
    MeshHex = require("skfem", "The built-in FE brake").MeshHex

    box = MeshHex.init_tensor(r, theta, z)
    rr, tt, zz = box.p
    p = np.vstack([rr * np.cos(tt), rr * np.sin(tt), zz])
    t = box.t
    if periodic:
        # the nodes at theta = 2 pi are those at theta = 0
        last = np.isclose(tt, theta[-1])
        key = np.round(np.vstack([rr, np.where(last, theta[0], tt), zz]).T, 12)
        _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
        keep = np.sort(first)
        new_index = np.empty(len(keep), dtype=np.int64)
        new_index[np.searchsorted(keep, first)] = np.arange(len(first))
        # map each original point to the kept representative, then renumber compactly
        rep = first[inverse.ravel()]
        compact = np.full(p.shape[1], -1, dtype=np.int64)
        compact[keep] = np.arange(len(keep))
        t = compact[rep[t]]
        p = p[:, keep]
    return p, t


def _build_mesh(geom: FEDemoGeometry, n_theta: int, n_r: int, n_z: int):
    """Disc + two pads as one (disconnected) MeshHex; returns mesh and element masks."""
    MeshHex = require("skfem", "The built-in FE brake").MeshHex

    r = np.linspace(geom.r_inner, geom.r_outer, n_r + 1)
    theta = np.linspace(0.0, 2 * math.pi, n_theta + 1)
    z = np.linspace(0.0, geom.thickness, n_z + 1)
    p_disc, t_disc = _annular_hex(r, theta, z, periodic=True)

    # pads on the disc's (r, theta) grid: radial nodes from the one nearest pad_r_inner,
    # an arc of whole sectors centred on theta = 0
    i_r = int(np.argmin(np.abs(r - geom.pad_r_inner)))
    i_r = min(max(i_r, 1), n_r - 1)
    n_arc = max(1, round(geom.pad_arc_deg / 360.0 * n_theta))
    theta_pad = (np.arange(n_arc + 1) - n_arc // 2) * (2 * math.pi / n_theta)
    n_zp = 1 if n_z == 1 else 2
    parts_p, parts_t = [p_disc], [t_disc]
    offset = p_disc.shape[1]
    for z0, z1 in ((geom.thickness, geom.thickness + geom.pad_thickness), (-geom.pad_thickness, 0.0)):
        pp, tp = _annular_hex(r[i_r:], theta_pad, np.linspace(z0, z1, n_zp + 1), periodic=False)
        parts_p.append(pp)
        parts_t.append(tp + offset)
        offset += pp.shape[1]
    mesh = MeshHex(np.hstack(parts_p), np.hstack(parts_t))
    n_disc = t_disc.shape[1]
    is_disc = np.zeros(mesh.t.shape[1], dtype=bool)
    is_disc[:n_disc] = True
    return mesh, is_disc


# ----------------------------------------------------------------------------- assembly kernels

_CHUNK = 400  # elements per vectorised block (bounds the memory of element matrices)


def _element_blocks(basis, is_rotating: bool, material: dict[str, float], spin: dict[str, float] | None):
    """Yield (dofs, {name: element matrices (e, 81, 81)}) for blocks of elements.

    Unknown ``3 * node + component``; element matrices ordered (node, component).
    """
    N = np.stack([np.asarray(phi[0]) for phi in basis.basis])  # (27, e, q)
    dN = np.stack([phi[0].grad for phi in basis.basis])  # (27, 3, e, q)
    dx = basis.dx  # (e, q)
    X = np.asarray(basis.global_coordinates())  # (3, e, q)
    dofs = basis.element_dofs  # (27, e)
    lam, mu, rho = material["lam"], material["mu"], material["rho"]
    n_loc = N.shape[0]
    eye3 = np.eye(3)
    for s in range(0, dx.shape[0], _CHUNK):
        sl = slice(s, s + _CHUNK)
        n_, g_, w_, x_ = N[:, sl], dN[:, :, sl], dx[sl], X[:, sl]
        ne = w_.shape[0]
        S = np.einsum("iceq,jdeq,eq->eijcd", g_, g_, w_, optimize=True)  # (e, 27, 27, 3, 3)
        tr = np.einsum("eijcc->eij", S)
        Ke = lam * S + mu * (tr[..., None, None] * eye3 + S.transpose(0, 1, 2, 4, 3))
        out = {"K": Ke.transpose(0, 1, 3, 2, 4).reshape(ne, 3 * n_loc, 3 * n_loc)}
        mass = rho * np.einsum("ieq,jeq,eq->eij", n_, n_, w_, optimize=True)
        out["M"] = _times_identity(mass)
        if is_rotating:
            T = -x_[1] * g_[:, 0] + x_[0] * g_[:, 1]  # d_theta N, (27, e, q)
            gyro = rho * (np.einsum("ieq,jeq,eq->eij", n_, T, w_) - np.einsum("ieq,jeq,eq->eij", T, n_, w_))
            conv = -rho * np.einsum("ieq,jeq,eq->eij", T, T, w_)
            rad = np.hypot(x_[0], x_[1])
            c, sn = x_[0] / rad, x_[1] / rad
            sr = spin["c1"] - spin["c2"] / rad**2 - spin["a_r"] * rad**2
            st = spin["c1"] + spin["c2"] / rad**2 - spin["a_t"] * rad**2
            sig = np.zeros((3, 3, *rad.shape))
            sig[0, 0], sig[1, 1] = sr * c**2 + st * sn**2, sr * sn**2 + st * c**2
            sig[0, 1] = sig[1, 0] = (sr - st) * sn * c
            pre = np.einsum("iaeq,abeq,jbeq,eq->eij", g_, sig, g_, w_, optimize=True)
            out["DG"] = _z_only(gyro)
            out["KGeo"] = _z_only(conv) + _times_identity(pre)
        yield dofs[:, sl], out


def _times_identity(a: np.ndarray) -> np.ndarray:
    """(e, n, n) scalar element matrix -> (e, 3n, 3n) acting on each component alike."""
    e, n, _ = a.shape
    out = np.zeros((e, n, 3, n, 3))
    for c in range(3):
        out[:, :, c, :, c] = a
    return out.reshape(e, 3 * n, 3 * n)


def _z_only(a: np.ndarray) -> np.ndarray:
    e, n, _ = a.shape
    out = np.zeros((e, n, 3, n, 3))
    out[:, :, 2, :, 2] = a
    return out.reshape(e, 3 * n, 3 * n)


def _assemble(basis, n_nodes: int, **kwargs) -> dict[str, sp.csr_matrix]:
    """Sum element matrices into global CSR matrices of size 3 * n_nodes."""
    n = 3 * n_nodes
    total: dict[str, sp.csr_matrix] = {}
    for dofs, blocks in _element_blocks(basis, **kwargs):
        vdofs = (3 * dofs.T[:, :, None] + np.arange(3)).reshape(dofs.shape[1], -1)  # (e, 81)
        rows = np.repeat(vdofs, vdofs.shape[1], axis=1).ravel()
        cols = np.tile(vdofs, (1, vdofs.shape[1])).ravel()
        for name, Ae in blocks.items():
            A = sp.csr_matrix((Ae.ravel(), (rows, cols)), shape=(n, n))
            total[name] = total[name] + A if name in total else A
    return total


def _spin_stress_constants(geom: FEDemoGeometry) -> dict[str, float]:
    """Plane-stress stress of an annulus spinning at 1 rad/s, clamped inside, free outside.

    ``sigma_r = c1 - c2/r^2 - (3+nu)/8 rho r^2``, ``sigma_t = c1 + c2/r^2 - (1+3nu)/8 rho r^2``
    (Timoshenko & Goodier §32), with ``u_r(r_inner) = 0`` and ``sigma_r(r_outer) = 0``.
    """
    nu, rho, a, b = geom.nu_disc, geom.rho_disc, geom.r_inner, geom.r_outer
    # u_r = r/E [(1-nu) c1 + (1+nu) c2/r^2 - (1-nu^2)/8 rho r^2]
    lhs = np.array([[1 - nu, (1 + nu) / a**2], [1.0, -1.0 / b**2]])
    rhs = np.array([(1 - nu**2) / 8 * rho * a**2, (3 + nu) / 8 * rho * b**2])
    c1, c2 = np.linalg.solve(lhs, rhs)
    return {"c1": c1, "c2": c2, "a_r": (3 + nu) / 8 * rho, "a_t": (1 + 3 * nu) / 8 * rho}


# ----------------------------------------------------------------------------- assembly


@renamed_kwargs(omega_ref="disc_speed_ref")
def build_fe_demo(
    n_theta: int = 48,
    n_r: int | None = None,
    n_z: int = 1,
    *,
    geometry: FEDemoGeometry | None = None,
    pads: bool = True,
    disc_speed_ref: float = 10.0,
    mu_ref: float = 0.4,
    rayleigh: tuple[float, float] = (0.0, 2e-8),
) -> dict[str, Any]:
    """Assemble the built-in FE disc brake in the exported matrix form.

    Parameters
    ----------
    n_theta : int
        Elements around the disc (>= 8, even); the refinement option. Unknowns (with the
        pads, after clamping): 16 -> 1 422, 48 -> 8 802, 96 -> 33 966, 176 -> 115 326
        (``n_z=1``); :func:`fe_demo_dofs` estimates them.
    n_r : int, optional
        Elements across the friction ring; default keeps them about square.
    n_z : int
        Elements through the disc thickness (quadratic elements: 1 already bends well).
    geometry : FEDemoGeometry, optional
        Dimensions, materials and spring stiffnesses.
    pads : bool
        ``False`` gives the disc alone (no pads, contact or friction): its doublets.
    disc_speed_ref : float
        Disc speed [rad/s] at which ``DG`` and ``KGeo`` are given.
    mu_ref : float
        Friction coefficient at which ``KR`` is given.
    rayleigh : (alpha, beta)
        ``D1 = alpha M + beta K1`` [1/s, s]; the default gives a damping ratio of
        ``beta omega / 2``: 3e-4 at 5 kHz.

    Returns
    -------
    dict
        ``M, D1, DG, DR, D4, K1, KR, KGeo`` (CSR, or ``None`` when absent; restrained
        unknowns removed) and ``disc_speed_ref``, ``mu_ref``, ``f_ref`` (1.0), ``dof_names``
        (``"node<k>.<x|y|z>"``), ``dof_node``/``dof_component`` (mesh node and component of
        each unknown, for shapes on the mesh), ``mesh`` (``points`` (n, 3), ``cells``
        {"hexahedron": (e, 8)} of the element vertices, ``disc`` element mask) and
        ``n_dofs``.
    """
    skfem = require("skfem", "The built-in FE brake")
    Basis, BilinearForm, ElementHex2, FacetBasis, LinearForm = (
        skfem.Basis, skfem.BilinearForm, skfem.ElementHex2, skfem.FacetBasis, skfem.LinearForm)

    geom = geometry or FEDemoGeometry()
    geom.validate()
    if int(n_theta) != n_theta or n_theta < 8 or n_theta % 2:
        raise InputError(f"FE demo: n_theta={n_theta!r} must be an even integer >= 8.")
    n_r = _default_n_r(int(n_theta), geom) if n_r is None else n_r
    if int(n_r) != n_r or n_r < 2:
        raise InputError(f"FE demo: n_r={n_r!r} must be an integer >= 2.")
    if int(n_z) != n_z or n_z < 1:
        raise InputError(f"FE demo: n_z={n_z!r} must be an integer >= 1.")
    if not (math.isfinite(disc_speed_ref) and disc_speed_ref > 0 and math.isfinite(mu_ref) and mu_ref > 0):
        raise InputError(f"FE demo: disc_speed_ref={disc_speed_ref!r} and mu_ref={mu_ref!r} must be positive.")
    alpha, beta = rayleigh
    if not (alpha >= 0 and beta >= 0):
        raise InputError(f"FE demo: rayleigh={rayleigh!r} must be two non-negative numbers.")
    # measured on the default disc (192 elements): 2.2 s and 170 MB, i.e. about 10 ms and 1 MB an
    # element; a quarter of each is the lower bound the budget takes
    elements = float(n_theta) * n_r * n_z
    check_budget(f"The FE demo of {elements:.3g} elements ({fe_demo_dofs(int(n_theta), int(n_r), int(n_z)):.3g} DOFs)",
                 nbytes=_BYTES_PER_ELEMENT * elements, seconds=_SECONDS_PER_ELEMENT * elements,
                 hint="Use a smaller --size or --n-z.")

    mesh, is_disc = _build_mesh(geom, int(n_theta), int(n_r), int(n_z))
    if not pads:
        MeshHex = require("skfem", "The built-in FE brake").MeshHex

        used = np.unique(mesh.t[:, is_disc])
        renumber = np.full(mesh.p.shape[1], -1, dtype=np.int64)
        renumber[used] = np.arange(len(used))
        mesh = MeshHex(mesh.p[:, used], renumber[mesh.t[:, is_disc]])
        is_disc = np.ones(mesh.t.shape[1], dtype=bool)

    elem = ElementHex2()
    disc = Basis(mesh, elem, elements=np.flatnonzero(is_disc), intorder=5)
    n_nodes = disc.N
    nu_d = geom.nu_disc
    steel = {
        "lam": geom.E_disc * nu_d / ((1 + nu_d) * (1 - 2 * nu_d)),
        "mu": geom.E_disc / (2 * (1 + nu_d)),
        "rho": geom.rho_disc,
    }
    mats = _assemble(disc, n_nodes, is_rotating=True, material=steel, spin=_spin_stress_constants(geom))
    K, M = mats["K"], mats["M"]
    DG = disc_speed_ref * mats["DG"]
    KGeo = disc_speed_ref**2 * mats["KGeo"]
    node_xyz = disc.doflocs.T  # (n_nodes, 3): location of each scalar node
    KR = None
    if pads:
        pad_elems = np.flatnonzero(~is_disc)
        pad = Basis(mesh, elem, elements=pad_elems, intorder=5)
        nu_p = geom.nu_pad
        lining = {
            "lam": geom.E_pad * nu_p / ((1 + nu_p) * (1 - 2 * nu_p)),
            "mu": geom.E_pad / (2 * (1 + nu_p)),
            "rho": geom.rho_pad,
        }
        pmats = _assemble(pad, n_nodes, is_rotating=False, material=lining, spin=None)
        K, M = K + pmats["K"], M + pmats["M"]
        # facets of the pads: back faces on springs, contact faces on the disc
        pad_facets = np.unique(mesh.t2f[:, pad_elems])
        boundary = np.intersect1d(pad_facets, mesh.boundary_facets())
        fz = mesh.p[2][mesh.facets[:, boundary]]
        flat = np.ptp(fz, axis=0) < 1e-12
        zf = fz[0]
        h, tp = geom.thickness, geom.pad_thickness
        back = boundary[flat & (np.isclose(zf, h + tp) | np.isclose(zf, -tp))]
        contact = boundary[flat & (np.isclose(zf, h) | np.isclose(zf, 0.0))]
        fmass = BilinearForm(lambda u, v, w: u * v).assemble(FacetBasis(mesh, elem, facets=back, intorder=5))
        K = K + _component_springs(fmass, (geom.k_back_tangential, geom.k_back_tangential, geom.k_back_normal))
        area = LinearForm(lambda v, w: v).assemble(FacetBasis(mesh, elem, facets=contact, intorder=5))
        disc_node = np.zeros(n_nodes, dtype=bool)
        disc_node[np.unique(disc.element_dofs)] = True
        KC, KR = _contact_and_friction(area, node_xyz, disc_node, geom=geom, mu_ref=mu_ref)
        K = K + KC

    # clamp the hat joint: every node of the inner face (its vertices at r = r_inner, the
    # mid-side nodes of its straight edges slightly inside)
    r_node = np.hypot(node_xyz[:, 0], node_xyz[:, 1])
    fixed_node = r_node <= geom.r_inner * (1 + 1e-12)
    free = np.flatnonzero(~np.repeat(fixed_node, 3))

    def restrict(A, sym: int = 0):
        A = sp.csr_matrix(A)[free][:, free]
        if sym:  # symmetric (+1) or skew (-1) by construction: remove assembly rounding
            A = (A + sym * A.T) * 0.5
        A = sp.csr_matrix(A)
        A.sum_duplicates()
        A.eliminate_zeros()
        return A

    K1, Mr = restrict(K, 1), restrict(M, 1)
    D1 = sp.csr_matrix(alpha * Mr + beta * K1) if (alpha or beta) else None
    node_of, comp_of = free // 3, free % 3
    names = np.array([f"node{k}.{'xyz'[c]}" for k, c in zip(node_of, comp_of, strict=True)])
    return {
        "M": Mr,
        "D1": D1,
        "DG": restrict(DG, -1),
        "DR": None,
        "D4": None,
        "K1": K1,
        "KR": restrict(KR) if KR is not None else None,
        "KGeo": restrict(KGeo, 1),
        "disc_speed_ref": float(disc_speed_ref),
        "mu_ref": float(mu_ref),
        "f_ref": 1.0,
        "dof_names": names,
        "dof_node": node_of,
        "dof_component": comp_of,
        "node_points": node_xyz.copy(),
        "mesh": {
            "points": mesh.p.T.copy(),
            "cells": {"hexahedron": _vtk_hex_order(mesh.t.T)},
            "disc": is_disc.copy(),
        },
        "n_dofs": len(free),
    }


def _component_springs(facet_mass: sp.spmatrix, k: tuple[float, float, float]) -> sp.csr_matrix:
    """Distributed springs ``k_c int N_i N_j dA`` on each component c (unknown 3 node + c)."""
    A = sp.coo_matrix(facet_mass)
    n = 3 * A.shape[0]
    rows = np.concatenate([3 * A.row + c for c in range(3)])
    cols = np.concatenate([3 * A.col + c for c in range(3)])
    vals = np.concatenate([k[c] * A.data for c in range(3)])
    return sp.csr_matrix((vals, (rows, cols)), shape=(n, n))


def _contact_and_friction(area, node_xyz, disc_node, *, geom: FEDemoGeometry, mu_ref: float):
    """Node-to-node contact springs (symmetric) and the friction coupling ``KR`` at mu_ref."""
    from scipy.spatial import cKDTree

    n = 3 * len(area)
    p_node = np.flatnonzero(area > 1e-9 * area.max())  # nodes of the pad contact faces
    disc_nodes = np.flatnonzero(disc_node)
    dist, j = cKDTree(node_xyz[disc_nodes]).query(node_xyz[p_node])
    if np.max(dist) > 1e-9:
        raise RuntimeError("FE demo: pad contact nodes do not coincide with disc surface nodes.")
    d_node = disc_nodes[j]
    k = geom.k_contact * area[p_node]
    dz, pz = 3 * d_node + 2, 3 * p_node + 2
    # top pad (z = thickness) pushes down: dN = k (w_disc - w_pad); bottom pad: dN = k (w_pad - w_disc)
    s = np.where(node_xyz[p_node, 2] > 0.5 * geom.thickness, 1.0, -1.0)
    rows = np.concatenate([dz, dz, pz, pz])
    cols = np.concatenate([dz, pz, dz, pz])
    KC = sp.csr_matrix((np.concatenate([k, -k, -k, k]), (rows, cols)), shape=(n, n))
    x, y = node_xyz[d_node, 0], node_xyz[d_node, 1]
    rad = np.hypot(x, y)
    e_t = (-y / rad, x / rad)  # sliding direction of the disc surface (disc turns about +z)
    r_list, c_list, v_list = [], [], []
    # friction on the disc node: -mu dN e_t, on the pad node: +mu dN e_t; K = -dF/du
    for comp in (0, 1):
        f = mu_ref * k * s * e_t[comp]
        d_row, p_row = 3 * d_node + comp, 3 * p_node + comp
        r_list += [d_row, d_row, p_row, p_row]
        c_list += [dz, pz, dz, pz]
        v_list += [f, -f, -f, f]
    KR = sp.csr_matrix((np.concatenate(v_list), (np.concatenate(r_list), np.concatenate(c_list))), shape=(n, n))
    return KC, KR


def _vtk_hex_order(t: np.ndarray) -> np.ndarray:
    """skfem's tensor-grid vertex order -> VTK_HEXAHEDRON order (bottom quad, then top)."""
    # skfem init_tensor order: (000)(010)(100)(001)(110)(011)(101)(111) in (r, theta, z) indices
    return t[:, [0, 2, 4, 1, 3, 6, 7, 5]]


# ----------------------------------------------------------------------------- export


def demo_mesh(demo: Any) -> FEMesh:
    """The mesh of the built-in FE brake (:func:`build_fe_demo`), nodes labelled 1..N.

    Every scalar node of the quadratic elements is a point (``node_points``), labelled ``k + 1``
    for the demo's node k, so a DOF ``node<k>.<x|y|z>`` is ``(k + 1, 1|2|3)`` in the DOF map
    (:func:`demo_dof_map`); the elements are the 8-vertex hexahedra.

    Parameters
    ----------
    demo : dict
        The built-in brake, as :func:`build_fe_demo` returns it.

    Returns
    -------
    squealkit.fe.mesh.FEMesh
        Points [m], node labels ``1..N`` and the hexahedra; write it with
        :func:`squealkit.fe.mesh.write_abaqus_inp` or give it to
        :meth:`squealkit.fe.FEModel.from_matrices` (``mesh=``).
    """
    pts = np.asarray(demo["node_points"], dtype=np.float64)
    hexes = np.asarray(demo["mesh"]["cells"]["hexahedron"], dtype=np.int64)
    return FEMesh(pts, np.arange(1, len(pts) + 1), (("hexahedron", hexes),), source="built-in FE brake")


def demo_dof_map(demo: Any) -> DofMap:
    """The DOF map of the built-in FE brake: unknown i is ``(dof_node[i] + 1, dof_component[i] + 1)``.

    Parameters
    ----------
    demo : dict
        The built-in brake, as :func:`build_fe_demo` returns it.

    Returns
    -------
    squealkit.fe.dofmap.DofMap
        Node label (as in :func:`demo_mesh`) and component (1, 2, 3: x, y, z) of each unknown.
    """
    return DofMap(np.asarray(demo["dof_node"]) + 1, np.asarray(demo["dof_component"]) + 1)


def write_fe_demo(model: Mapping[str, Any], out_dir: str | Path) -> Path:
    """Write the matrices as Matrix Market files, a ``brake.toml`` and the mesh (VTU, and Abaqus ``.inp``).

    The folder is staged and moved into place only when complete (:func:`squealkit.io.atomic_path`).
    The TOML reads ``model = "fe"`` with ``[fe] files = {M = "M.mtx", ...}``, ``disc_speed_ref``,
    ``mu_ref``, ``f_ref``, ``dof_names = "dof_names.txt"`` and (when meshio is installed)
    ``mesh = "mesh.vtu"``, the element vertices for viewing mode shapes (``modes --vtk``). The
    mesh is also written as an Abaqus input deck ``brake.inp`` (:func:`demo_mesh`: every node a
    point, labelled ``k + 1``), for FE codes and for ``mesh = "brake.inp"``.

    Parameters
    ----------
    model : dict
        The built-in brake, as :func:`build_fe_demo` returns it.
    out_dir : str or Path
        The folder to write (created; refused if it exists and holds other files).

    Returns
    -------
    Path
        The TOML file.
    """
    import scipy.io

    from ..io import atomic_path

    out = Path(out_dir)
    with atomic_path(out, directory=True) as stage:
        stage.mkdir()
        files = {}
        for name in FE_MATRIX_NAMES:
            A = model.get(name)
            if A is None:
                continue
            scipy.io.mmwrite(stage / f"{name}.mtx", sp.coo_matrix(A), precision=17)
            files[name] = f"{name}.mtx"
        (stage / "dof_names.txt").write_text("\n".join(map(str, model.get("dof_names", []))) + "\n")
        file_table = ", ".join(f'{k} = "{v}"' for k, v in files.items())
        toml = (
            "# built-in FE disc brake (squealkit.fe.demo), "
            f"{model['M'].shape[0]} unknowns\n"
            'model = "fe"\n\n[fe]\n'
            f"files = {{ {file_table} }}\n"
            f"disc_speed_ref = {model['disc_speed_ref']!r}  # rad/s: disc speed of DG and KGeo\n"
            f"mu_ref = {model['mu_ref']!r}  # friction coefficient of KR\n"
            f"f_ref = {model.get('f_ref', 1.0)!r}  # Hz: reference of D4\n"
        )
        toml += 'dof_names = "dof_names.txt"  # node{k}.x/y/z: mesh point k\n'
        mesh = model.get("mesh")
        if mesh is not None:
            if available("meshio"):  # the mesh file is written when meshio is there; the matrices do not need it
                meshio = require("meshio", "The demo's mesh file")
                meshio.write(
                    stage / "mesh.vtu",
                    meshio.Mesh(mesh["points"], [("hexahedron", mesh["cells"]["hexahedron"])],
                                cell_data={"disc": [mesh["disc"].astype(np.int8)]}),
                )
                toml += 'mesh = "mesh.vtu"  # element vertices, for modes --vtk\n'
        if "node_points" in model and model.get("mesh") is not None:
            (stage / "brake.inp").write_text(abaqus_inp_text(demo_mesh(model)))
        (stage / "brake.toml").write_text(toml)
    return out / "brake.toml"

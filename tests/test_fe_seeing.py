"""Seeing the instability of an FE brake (issue #25, item 3): the unstable modes' table, friction work
per node with its energy balance, the modes on the mesh (plotly, VTK), tracking over mu and speed."""

from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest

from squealkit.fe import FEModel
from squealkit.fe.energy import mode_energy
from squealkit.fe.surface import bodies, mode_surface, surface_triangles
from squealkit.stability import fe_modes

# the coarse demo brake: 738 DOFs, one disc and two pads; a POD basis (residuals ~1e-9) keeps the solves short
KW = {"method": "pod", "band": (1000.0, 20000.0)}
RPM, MU = 1000.0, 0.6


@pytest.fixture(scope="module")
def demo():
    from squealkit.fe.demo import build_fe_demo

    return build_fe_demo(n_theta=8, n_r=2)


@pytest.fixture(scope="module")
def brake(demo):
    from squealkit.fe.demo import demo_dof_map, demo_mesh

    mats = {k: demo[k] for k in ("M", "D1", "DG", "K1", "KR", "KGeo")}
    return FEModel.from_matrices(**mats, disc_speed_ref=demo["disc_speed_ref"], mu_ref=demo["mu_ref"],
                                 mesh=demo_mesh(demo), dof_map=demo_dof_map(demo))


@pytest.fixture(scope="module")
def modes(brake):
    ds = fe_modes(brake, RPM, MU, **KW)
    assert ds.unstable.values.sum() >= 2  # the demo brake squeals at mu 0.6 in this band
    return ds


@pytest.fixture(scope="module")
def energy(brake, modes):
    return mode_energy(brake, modes)


# ----------------------------------------------------------------------------- friction work: known answers


def test_friction_work_of_the_two_dof_follower_force_in_closed_form():
    # M = I, K = [[k, a], [-a, k]] (K1 = k I, friction KR = [[0, 1], [-1, 0]] at mu = a, mu_ref = 1):
    # K [1, -j] = (k - j a) [1, -j], so lambda^2 = -(k - j a) with phi = [1, -j] (closed form). There
    # 2 sigma omega = Im(lambda^2) = a exactly, and W_i = -pi Im(conj(phi_i)(K_f phi)_i) = +pi a on each DOF.
    k, a = 4.0, 0.5
    m = FEModel.from_matrices(M=np.eye(2), K1=k * np.eye(2), KR=[[0.0, 1.0], [-1.0, 0.0]])
    ds = fe_modes(m, 60.0, a)
    e = mode_energy(m, ds)
    lam = np.sqrt(-(k - 1j * a) + 0j)
    lam = lam if lam.imag > 0 else -lam
    grow = int(np.argmax(ds.growth_rate.values))
    np.testing.assert_allclose(float(ds.growth_rate[grow]), lam.real, rtol=1e-12)
    np.testing.assert_allclose(e.friction_work_dof.values[:, grow], [math.pi * a, math.pi * a], rtol=1e-12)
    # the decaying mode [1, +j] takes the same energy out
    np.testing.assert_allclose(e.friction_work_dof.values[:, 1 - grow], [-math.pi * a, -math.pi * a], rtol=1e-12)
    np.testing.assert_allclose(e.net_work, e.growth_work, rtol=1e-12)
    # 2 pi sigma omega m with m = |phi|^2 = 2: the energy growth per cycle
    np.testing.assert_allclose(float(e.growth_work[grow]), 2 * math.pi * a, rtol=1e-12)


def test_energy_balance_with_friction_damping_gyroscopic_and_material_damping():
    # the imaginary part of phi^H (lambda^2 M + lambda C + K) phi = 0 (module docstring of fe.energy):
    # W_friction - W_other = pi sigma (2 omega m + Im c) for every eigenpair; a sign slip in the DR
    # (friction damping) or KR term, or a missing gyroscopic Im(c), breaks it
    rng = np.random.default_rng(11)
    n = 6
    A = rng.standard_normal((n, n))
    M = A @ A.T + n * np.eye(n)
    B = rng.standard_normal((n, n))
    K1 = 1e4 * (B @ B.T + n * np.eye(n))
    S = rng.standard_normal((n, n))
    m = FEModel.from_matrices(M=M, K1=K1, KR=3e3 * rng.standard_normal((n, n)), DR=2.0 * rng.standard_normal((n, n)),
                              DG=5.0 * (S - S.T), D1=0.5 * M, mu_ref=0.4, disc_speed_ref=10.0)
    ds = fe_modes(m, 300.0, 0.7, method="dense")
    e = mode_energy(m, ds)
    osc = ds.frequency_hz.values > 0
    scale = np.maximum(np.abs(e.friction_work), np.abs(e.other_work)).values[osc]
    np.testing.assert_allclose(e.net_work.values[osc], e.growth_work.values[osc], atol=1e-9 * scale.max())
    assert np.all(np.sign(e.net_work.values[osc]) == np.sign(ds.growth_rate.values[osc]))
    # DR does work: without it the friction work changes
    no_dr = mode_energy(m.replace(DR=np.zeros((n, n))), ds)
    assert not np.allclose(no_dr.friction_work.values[osc], e.friction_work.values[osc])


def test_demo_brake_friction_work_sums_to_the_growth_of_each_mode(energy, modes):
    osc = modes.frequency_hz.values > 0
    # the reduced eigenpairs are Galerkin: phi^H (..) phi = 0 holds exactly in the full model too
    scale = np.abs(energy.friction_work.values[osc]).max()
    np.testing.assert_allclose(energy.net_work.values[osc], energy.growth_work.values[osc], atol=1e-8 * scale)
    u = modes.unstable.values
    assert np.all(energy.net_work.values[u] > 0) and np.all(energy.friction_work.values[u] > 0)
    # per node on the contact surfaces: the contact points hold all of it (disc node + pad node per pair)
    np.testing.assert_allclose(energy.friction_work_contact.sum("contact_point").values[osc],
                               energy.friction_work.values[osc], rtol=1e-10)


def test_demo_brake_bodies_and_the_pad_contact_surfaces(brake, demo, energy):
    b = bodies(brake)
    assert b.names == ("body 1", "body 2", "body 3")
    # body 1 is the disc, the twin pads 2 and 3 mirror each other in z; the disc's nodes, independently of
    # the mesh: those whose out-of-plane DOF carries the gyroscopic DG (the disc alone turns)
    dg_rows = np.flatnonzero(np.diff(demo["DG"].tocsr().indptr))
    disc_dofs = np.isin(demo["dof_node"], demo["dof_node"][dg_rows])
    assert np.all(b.of_dof[disc_dofs] == 0) and np.all(b.of_dof[~disc_dofs] > 0)
    np.testing.assert_allclose(b.extent[1], b.extent[2], rtol=1e-12)
    assert set(energy.contact_body.values) == {"body 2", "body 3"}  # drawn on the pads, not the disc
    # contact points: one per pad contact-face node, each a coincident disc/pad pair
    # (KR's columns: the normal DOF of the disc node and of the pad node of each pair)
    n_pad_face = np.count_nonzero(np.diff(demo["KR"].tocsc().indptr)) // 2
    assert energy.sizes["contact_point"] == n_pad_face
    shares = energy.kinetic_share.sum("body").values
    np.testing.assert_allclose(shares[np.isfinite(shares)], 1.0, rtol=1e-10)


# ----------------------------------------------------------------------------- the surface and the 3D view


def test_surface_of_two_hexahedra_sharing_a_face():
    # a 2 x 1 x 1 box of two unit cubes: 10 outer quads -> 20 triangles of total area 2 (2x1 faces) x 2 + ... = 10
    p = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1, 2)], dtype=float)
    idx = {tuple(v): i for i, v in enumerate(p.astype(int).tolist())}
    def hexa(x0):  # VTK order: bottom quad counter-clockwise, then top
        c = [(x0, 0, 0), (x0 + 1, 0, 0), (x0 + 1, 1, 0), (x0, 1, 0)]
        return [idx[v] for v in c] + [idx[(a, b, 1)] for a, b, _ in c]
    tri = surface_triangles(p, [("hexahedron", np.array([hexa(0), hexa(1)]))])
    assert tri.shape == (20, 3)
    area = 0.5 * np.linalg.norm(np.cross(p[tri[:, 1]] - p[tri[:, 0]], p[tri[:, 2]] - p[tri[:, 0]]), axis=1).sum()
    assert area == pytest.approx(10.0)  # 2 x (2 + 2 + 1): the box's surface, the shared face left out


def test_mode_view_animates_the_unstable_modes_over_the_phase(brake, modes, energy):
    pytest.importorskip("plotly")
    from squealkit.plotting.fe_modes import mode_view

    u = modes.mode.values[modes.unstable.values]
    srf = mode_surface(brake, modes.sel(mode=u), energy.sel(mode=u))
    fig = mode_view(srf, int(u[0]), energy=energy, n_frames=8)
    assert len(fig.frames) == 8
    spec = json.loads(fig.to_json())
    x0 = spec["frames"][0]["data"][0]["x"]
    assert x0["dtype"] == "f4"  # float32 coordinates, base64: a small page
    # frame at phase 180 deg is the mirror of phase 0 about the mesh: Re(phi e^{j pi}) = -Re(phi)
    pos = [np.frombuffer(__import__("base64").b64decode(spec["frames"][k]["data"][0]["x"]["bdata"]), np.float32)
           for k in (0, 4)]
    np.testing.assert_allclose(pos[0] + pos[1], 2 * srf.x.values, atol=1e-6)
    assert spec["data"][1]["type"] == "scatter3d"  # the friction work per contact point


def test_friction_work_and_tracking_figures(brake, modes, energy):
    from squealkit.plotting.fe_modes import friction_work_plot, mode_tracking_plot
    from squealkit.stability import fe_stability_map

    top = int(modes.mode.values[np.argmax(modes.growth_rate.values)])
    fig = friction_work_plot(energy, top)
    assert len([a for a in fig.axes if a.get_label() != "<colorbar>"]) == 2  # one panel per pad
    mp = fe_stability_map(brake, [500.0, RPM], np.linspace(0.0, 0.8, 5), **KW)
    fig = mode_tracking_plot(mp, over="mu", at=1)
    grown = int(mp.isel(rpm=1).unstable.any("mu").sum())
    assert grown >= 2
    # a coloured, labelled line per branch that becomes unstable on the line
    assert len(fig.axes[0].get_legend().get_texts()) == grown
    fig = mode_tracking_plot(mp, over="rpm", at=-1)
    assert fig.axes[1].get_xlabel() == "disc speed [rpm]"


def test_modes_to_vtk_carries_every_unstable_mode_and_its_friction_work(brake, modes, energy, tmp_path):
    meshio = pytest.importorskip("meshio")
    from squealkit.stability.fe_sweep import modes_to_vtk

    u = modes.mode.values[modes.unstable.values]
    modes_to_vtk(modes.sel(mode=u), brake, tmp_path / "m.vtu", energy=energy)
    back = meshio.read(tmp_path / "m.vtu")
    for k in u:
        assert {f"mode{k}_re", f"mode{k}_im", f"mode{k}_friction_work"} <= set(back.point_data)
        # every demo DOF is on a node of its mesh: the per-node work sums to the mode's
        np.testing.assert_allclose(back.point_data[f"mode{k}_friction_work"].sum(), float(energy.friction_work.sel(
            mode=k)), rtol=1e-9)


# ----------------------------------------------------------------------------- the CLI table


@pytest.fixture(scope="module")
def brake_toml(demo, tmp_path_factory):
    from squealkit.fe.demo import write_fe_demo

    return write_fe_demo(demo, tmp_path_factory.mktemp("seeing") / "brake")


@pytest.mark.slow
def test_cli_modes_lists_every_unstable_mode_with_its_component(run, brake_toml, modes):
    args = ("modes", "--config", str(brake_toml), "--rpm", str(RPM), "--mu", str(MU), "--method", "pod",
            "--eigen-band", "9000:20000")
    r = run(*args, "--json")
    assert r.exit_code == 0, (r.output, r.exception)
    got = json.loads(r.stdout)
    n_unstable = sum(m["unstable"] for m in got["modes"])
    # more unstable modes than the old table's one line: the fixture's (Python route) in this band
    assert n_unstable == int((modes.unstable & (modes.frequency_hz >= 9000)).sum()) >= 2
    assert len(got["unstable_modes"]) == n_unstable
    rates = [m["growth_rate"] for m in got["unstable_modes"]]
    assert rates == sorted(rates, reverse=True)
    assert all(m["dominant_component"].startswith("body") and m["friction_work"] > 0 for m in got["unstable_modes"])
    text = run(*args)
    assert text.exit_code == 0
    assert text.stdout.count("<- UNSTABLE") == n_unstable


# ----------------------------------------------------------------------------- the report


@pytest.mark.slow
def test_report_of_an_fe_model_shows_every_unstable_mode_offline(run, brake_toml, tmp_path):
    pytest.importorskip("plotly")
    toml = brake_toml.parent / "report.toml"
    text = brake_toml.read_text().replace('mesh = "mesh.vtu"', 'mesh = "brake.inp"')  # every node a point
    toml.write_text(text + '\n[report]\nrpm = 1000\nmu = 0.6\neigen_band = [9000, 20000]\nmethod = "pod"\n'
                           'mu_sweep = [0.0, 0.8, 3]\nrpm_sweep = [500, 1000, 2]\nmax_views = 2\nn_frames = 4\n')
    r = run("report", "--config", str(toml), "--out-dir", str(tmp_path / "rep"), "--quick", "--json")
    assert r.exit_code == 0, (r.output, r.exception)
    numbers = json.loads(r.stdout)["numbers"]
    n = int(numbers["fe_modes"]["unstable"])
    assert n >= 2
    html = (tmp_path / "rep" / "report.html").read_text()
    # offline: plotly.js inlined once, no script loaded from the network
    assert html.count("plotly.js v") == 1 and not re.search(r"<script[^>]*\bsrc=", html)
    assert html.count("class='view'") == min(n, 2)  # max_views
    assert html.count("<tr><td>1</td>") == n  # one table row per unstable mode of load case 1
    assert (tmp_path / "rep" / "report.html").stat().st_size < 8e6
    # every node on the mesh: the friction work maps show all of it
    assert "acts on nodes that are not points of the mesh" not in html
    assert (tmp_path / "rep" / "figures" / "fe_tracking_mu.png").is_file()
    if pytest.importorskip("meshio"):  # every unstable mode for ParaView, not only the ones drawn
        vtu = __import__("meshio").read(tmp_path / "rep" / "data" / "fe_modes_case1.vtu")
        assert sum(k.endswith("_friction_work") for k in vtu.point_data) == n
    # a bad [report] key: one line, before any work
    toml.write_text(text + "\n[report]\nrpms = 1000\n")
    bad = run("report", "--config", str(toml), "--out-dir", str(tmp_path / "bad"))
    assert bad.exit_code == 2 and "unknown key 'rpms'" in bad.stderr


def test_modes_to_pvd_is_the_phase_animation_as_a_time_series(brake, modes, energy, tmp_path):
    meshio = pytest.importorskip("meshio")
    import xml.etree.ElementTree as ET

    from squealkit.stability.fe_sweep import modes_to_vtk

    u = modes.mode.values[modes.unstable.values]
    modes_to_vtk(modes.sel(mode=u), brake, tmp_path / "m.pvd", energy=energy, n_frames=4)
    sets = ET.parse(tmp_path / "m.pvd").getroot().findall(".//DataSet")
    assert [float(d.get("timestep")) for d in sets] == [0.0, 90.0, 180.0, 270.0]
    f0, f1 = (meshio.read(tmp_path / d.get("file")) for d in sets[:2])
    k = u[0]
    # phase 0 is Re(phi), phase 90 deg is Re(j phi) = -Im(phi): the two parts of the complex shape
    modes_to_vtk(modes.sel(mode=u), brake, tmp_path / "m.vtu")
    parts = meshio.read(tmp_path / "m.vtu")
    np.testing.assert_allclose(f0.point_data[f"mode{k}"], parts.point_data[f"mode{k}_re"], atol=1e-12)
    np.testing.assert_allclose(f1.point_data[f"mode{k}"], -parts.point_data[f"mode{k}_im"], atol=1e-12)


def test_cli_modes_vtk_without_a_mesh_is_refused_before_the_solve(run, tmp_path, monkeypatch):
    import scipy.io

    from squealkit import stability

    scipy.io.mmwrite(tmp_path / "M.mtx", np.eye(2))
    scipy.io.mmwrite(tmp_path / "K1.mtx", 4.0 * np.eye(2))
    (tmp_path / "b.toml").write_text('model = "fe"\n[fe]\nfiles = { M = "M.mtx", K1 = "K1.mtx" }\n')
    monkeypatch.setattr(stability, "fe_modes", lambda *a, **k: pytest.fail("solved before refusing"))
    r = run("modes", "--config", str(tmp_path / "b.toml"), "--rpm", "60", "--vtk", str(tmp_path / "m.pvd"))
    assert r.exit_code == 2 and "has no mesh" in r.stderr and len(r.stderr.strip().splitlines()) == 1


def test_energy_and_surface_results_follow_the_schema_and_draw_themselves(brake, modes, energy):
    from test_vocabulary import schema_problems

    u = modes.mode.values[modes.unstable.values]
    srf = mode_surface(brake, modes.sel(mode=u), energy.sel(mode=u))
    assert schema_problems(energy) == [] and schema_problems(srf) == []
    fig = energy.squeal.plot(mode=int(u[0]))  # the friction work map, by the result's kind
    assert "Friction work" in fig._suptitle.get_text()

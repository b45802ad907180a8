"""Issue 27's smaller items and its code-review findings, and item 6 of issue 24.

References are named per test: the verdicts of the stability pipeline (flutter against
divergence, decided from the eigenvalues' imaginary parts), LAPACK's QZ on a companion pencil
built here from the raw NLEVP arrays (scipy.linalg.eig), mpmath's polynomial roots at 50
digits, threadpoolctl's report of the BLAS thread count, and tracemalloc's peak.
"""

import numpy as np
import pytest

from squealkit.data import nlevp_path
from squealkit.models import get_preset, load_fe_model
from squealkit.stability import VERDICTS, fe_stability_map, lock_in, stability_map

FLUTTER = VERDICTS.index("flutter")

# -- 1. lock-in is mode coupling: flagged at flutter points, never at divergence ------------------


@pytest.fixture(scope="module")
def nlevp():
    return load_fe_model(nlevp_path())


def test_lock_in_on_the_nlevp_map_is_its_flutter_region(nlevp):
    # disk_brake100 over mu: stable, then a real root crosses zero (divergence, mu ~ 0.08), then
    # a complex pair with positive real part (flutter, mu > ~0.6): the verdicts are the reference
    ds = fe_stability_map(nlevp, rpm=[60.0, 240.0], mu=np.linspace(0.01, 1.5, 12), method="dense")
    verdict = ds.verdict.values
    assert {0, 1, 2} <= set(np.unique(verdict))  # the grid reaches all three
    np.testing.assert_array_equal(ds.lock_in.values, verdict == FLUTTER)


@pytest.mark.parametrize("damped", [False, True])
def test_lock_in_on_the_paper_model_is_its_flutter_region(damped):
    # Lv et al. 2013's 3-DOF model: every instability is mode coupling (paper §3); with its
    # dampers the coupled pair's frequencies approach (2371 and 2226 Hz) without meeting exactly
    ds = stability_map(get_preset("lv2013"), np.linspace(0, 1, 21), np.radians([-10.0, 0.0, 10.0]), damped=damped)
    verdict = ds.verdict.values
    assert (verdict == FLUTTER).any() and (verdict == 0).any()
    np.testing.assert_array_equal(ds.lock_in.values, verdict == FLUTTER)


def test_lock_in_function_ignores_real_roots_and_lone_negative_damping():
    # two real roots (omega 0), one growing: divergence, no coupling
    assert not lock_in(np.array([0.0, 0.0]), np.array([5.0, -3.0]))
    # a coupled pair: equal frequency, growth rates split (undamped mode coupling)
    assert lock_in(np.array([100.0, 100.0]), np.array([5.0, -5.0]))
    # damped coupling: the frequencies approach closer than the growth rates split
    assert lock_in(np.array([100.0, 97.0]), np.array([2.0, -8.0]))
    # one mode with negative damping, far in frequency from every other: not a lock-in
    assert not lock_in(np.array([100.0, 300.0]), np.array([1.0, -2.0]))


# -- 6. the 50-digit stage of the verdict pipeline (stability._solve.mp_roots) ----------------------


def test_mp_roots_decides_a_growth_rate_that_double_precision_cannot():
    # M = I, C = diag(-4e-9, 0), K = [[1, 1], [0, 1]]: K is triangular, so the characteristic
    # polynomial is (s^2 - 4e-9 s + 1)(s^2 + 1), roots 2e-9 +- j sqrt(1 - 4e-18) and +-j
    # (closed form, evaluated here in 60-digit mpmath from the same doubles). The cluster at
    # +-j is nearly defective: LAPACK's error radius (~1e-5) covers the growth rate 2e-9 and
    # the verdict threshold (1e-9 |lambda|_max); the 50-digit stage's discs must not.
    import mpmath

    from squealkit.stability._solve import lapack_roots, mp_roots

    M, C, K = np.eye(2), np.diag([-4e-9, 0.0]), np.array([[1.0, 1.0], [0.0, 1.0]])
    _, lapack_radius = lapack_roots(M[None], C[None], K[None])
    assert lapack_radius.min() > 1e-6  # double precision cannot tell 2e-9 from 0
    z, radius = mp_roots(M, C, K, scale=1.5)
    with mpmath.workdps(60):
        c = mpmath.mpf(-4e-9)
        w = mpmath.sqrt(1 - c * c / 4)
        want = [-c / 2 + 1j * w, -c / 2 - 1j * w, mpmath.mpc(0, 1), mpmath.mpc(0, -1)]
        for ref in want:
            d = [float(abs(mpmath.mpc(zk) - ref)) for zk in z]
            j = int(np.argmin(d))
            assert d[j] <= radius[j] < 1e-15  # the root lies in its disc (with the rounding to double)
    thr = 1e-9 * np.abs(z).max()  # the verdict's threshold, _kernels.UNSTABLE_RTOL
    growing = z.real - radius > thr
    assert growing.sum() == 2  # the 2e-9 pair, decided beyond the threshold
    np.testing.assert_allclose(z.real[growing], 2e-9, rtol=1e-12)
    assert np.all(np.abs(z.real[~growing]) <= radius[~growing])  # the +-j pair, on the axis


def test_public_verdict_reaches_the_50_digit_stage(monkeypatch):
    # The exact stage (Routh/Sturm in integers) hands a point on to mpmath only at a zero Routh
    # pivot, a root exactly on the threshold, which a model in doubles meets only by rounding
    # coincidence; here it is made to decline every point, so stability_verdict's undecided
    # points (a doublet split by 1e-10, issue 10's models) go through mp_roots. References: the
    # closed forms of those models (stable one-way coupling; skew coupling unstable exactly on
    # [(K3 - K_D)/(D + 2c), (K3 - K_D)/(D - 2c)] = [0.1735, 0.289167]).
    from squealkit.models import MatrixModel
    from squealkit.stability import _solve, stability_verdict

    calls = []
    real_mp_roots = _solve.mp_roots

    def spy(*args, **kwargs):
        calls.append(args)
        return real_mp_roots(*args, **kwargs)

    monkeypatch.setattr(_solve, "exact_verdict", lambda *a, **kw: None)
    monkeypatch.setattr(_solve, "mp_roots", spy)
    k_d, d, c, k3 = 1e6, 0.8e6, 0.1e6, 1.1735e6
    k0 = np.diag([k_d, k_d * (1 + 1e-10), k3])
    one_way = MatrixModel(M=np.eye(3), K0=k0, Kf=[[d, 0.3 * d, 0], [0, d, 0], [0, 0, 0]])
    skew = MatrixModel(M=np.eye(3), K0=k0, Kf=[[d, 0, 0], [0, d, c], [0, -c, 0]])
    assert stability_verdict(one_way, [0.5, 1.0]).tolist() == ["stable", "stable"]
    assert calls, "no point reached the 50-digit stage"
    calls.clear()
    assert stability_verdict(skew, [0.1, 0.2, 0.25, 0.4]).tolist() == ["stable", "flutter", "flutter", "stable"]


# -- 5. SQUEALKIT_THREADS bounds BLAS threads in every public compute entry point ----------------


@pytest.fixture()
def blas_threads_seen(monkeypatch):
    """The BLAS thread count (threadpoolctl's report) at each LAPACK call the FE engines make."""
    import scipy.linalg as sla
    from threadpoolctl import threadpool_info

    seen = []

    def spying(fn):
        def wrapper(*args, **kwargs):
            seen.append(max(i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"))
            return fn(*args, **kwargs)
        return wrapper

    for name in ("eig", "eigh", "eigvals", "qr"):
        monkeypatch.setattr(sla, name, spying(getattr(sla, name)))
    return seen


def test_squealkit_threads_bounds_blas_in_reduction_called_directly(monkeypatch, blas_threads_seen, nlevp):
    from threadpoolctl import threadpool_limits

    from squealkit.solvers.band import dense_eigs
    from squealkit.solvers.reduction import modal_basis, reduce, reduced_eigs

    monkeypatch.setenv("SQUEALKIT_THREADS", "1")
    with threadpool_limits(2, user_api="blas"):  # BLAS's own default on this 2-core machine
        V = modal_basis(nlevp, n_modes=30)
        seen_modal = len(blas_threads_seen)
        red = reduce(nlevp, V)
        seen_reduce = len(blas_threads_seen)
        reduced_eigs(red, 2 * np.pi, 1.0, band=(1e-4, 1.0))
        dense_eigs(nlevp, 2 * np.pi, 1.0)
    assert 0 < seen_modal < seen_reduce < len(blas_threads_seen)  # each entry point made LAPACK calls
    assert set(blas_threads_seen) == {1}


def test_thread_bound_never_raises_an_enclosing_blas_limit(monkeypatch, blas_threads_seen, nlevp):
    from threadpoolctl import threadpool_limits

    from squealkit.solvers.reduction import modal_basis

    monkeypatch.setenv("SQUEALKIT_THREADS", "2")
    with threadpool_limits(1, user_api="blas"):
        modal_basis(nlevp, n_modes=30)
    assert set(blas_threads_seen) == {1}


def test_every_public_stability_computation_honours_the_thread_limit():
    # one decorator (squealkit._threads.honour_thread_limit) on every public entry point that
    # calls LAPACK; the ones below only relabel or summarise arrays already computed
    import inspect

    import squealkit.stability as stability
    from squealkit._threads import honour_thread_limit
    from squealkit.solvers import band, lu, reduction

    no_lapack = {"lock_in", "modes_summary", "stability_summary", "track_modes", "unstable_threshold",
                 "fill_reducing_order", "validate_band",
                 # solvers/: the LU registry, and helpers called inside the decorated entry points
                 "register_lu_backend", "get_lu_backend", "lu_backend", "set_lu_backend", "use_lu_backend",
                 "real_times", "as_fe_model", "reduced_solve",
                 # writes mode shapes already computed to a VTK file
                 "modes_to_vtk"}
    names = [(m, n) for m in (stability, reduction, band, lu) for n in m.__all__
             if inspect.isfunction(getattr(m, n)) and n not in no_lapack]
    assert len(names) > 20
    wrapper_code = honour_thread_limit(lambda: None).__code__
    undecorated = [n for m, n in names if getattr(m, n).__code__ is not wrapper_code]
    assert not undecorated


# -- 4. opening a UFF 58 file reads its headers, not its samples ----------------------------------


def test_opening_uff_reads_headers_only(tmp_path, monkeypatch):
    import tracemalloc

    pyuff = pytest.importorskip("pyuff")
    from squealkit.measurement import open_recording, synthetic_recording
    from squealkit.measurement.formats.writers import write_recording

    rec = synthetic_recording(duration=2.0, seed=1)  # 3 channels x 80000 samples: 1.9 MB of float64
    path = write_recording(rec, tmp_path / "rec.uff")  # ASCII, about 5 MB
    # reference for the header fields: pyuff's own reading of the same file (before the mock)
    uff = pyuff.UFF(str(path))
    ref = [uff.read_sets(i, header_only=True) for i in range(len(uff.get_set_types()))]

    def reads_data(*args, **kwargs):
        raise AssertionError("opening a UFF file went through pyuff, which reads the whole file")

    monkeypatch.setattr(pyuff.UFF, "__init__", reads_data)
    tracemalloc.start()
    try:
        src = open_recording(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    data_bytes = sum(rec[n].nbytes for n in rec.data_vars)
    assert peak < data_bytes / 2, (peak, data_bytes)  # measured: 11.4 MB through pyuff, 0.53 MB by headers
    assert list(src.channels) == [d["id1"] for d in ref]
    assert src.n_samples == ref[0]["num_pts"] == rec.sizes["time"]
    assert src.fs == pytest.approx(1.0 / ref[0]["abscissa_inc"], rel=1e-5)
    assert [src.units[n] for n in src.channels] == [d["ordinate_axis_units_lab"] for d in ref]
    # and the samples, read later block by block, are the recording's
    got = np.concatenate([blk["mic"] for _, blk in src.iter_blocks(["mic"], block=50_000)])
    np.testing.assert_allclose(got, rec["mic"].values, rtol=1e-10)


# -- 3. a campaign does not need what J2521 occurrence does not: rpm, tacho -----------------------


@pytest.fixture(scope="module")
def small_campaign(tmp_path_factory):
    """Three synthetic applications (0.5 s each) and a fourth, a slow drag whose once-per-rev tacho
    has only 2 marks (300 rpm for 0.5 s), squealing at 2388 Hz (the generator's default line)."""
    from squealkit.campaign import synthetic_campaign
    from squealkit.measurement import synthetic_recording
    from squealkit.measurement.formats.writers import write_recording

    d = tmp_path_factory.mktemp("camp27")
    truth = synthetic_campaign(d, n_applications=3, duration=0.5, seed=5, stop_share=0.0)
    slow = synthetic_recording(duration=0.5, rpm=300, seed=11)
    write_recording(slow, d / "recordings" / "slow.nc")
    with open(d / "matrix.csv", "a") as fh:
        fh.write("A0004,recordings/slow.nc,S4,drag,10.0,100.0,10.0\n")
    return d, truth, slow


def _campaign(d, out, *extra):
    import json

    from click.testing import CliRunner

    from squealkit.cli.main import cli

    res = CliRunner().invoke(cli, ["campaign", str(d / "matrix.csv"), "--out-dir", str(d / out), "--mic", "mic",
                                   "--displacement", "displacement", "--radius", "0.05", "--no-report", "--json",
                                   *extra])
    return res, json.loads(res.stdout) if res.stdout.strip() else None


def _applications(d, out):
    import duckdb

    con = duckdb.connect(str(d / out / "campaign.duckdb"), read_only=True)
    try:
        cols = ["application", "status", "squeal", "squeal_frequency_hz", "runout_phase_deg", "runout_unavailable"]
        rows = con.execute(f"SELECT {', '.join(cols)} FROM applications ORDER BY application").fetchall()
    finally:
        con.close()
    return {r[0]: dict(zip(cols, r, strict=True)) for r in rows}


def test_campaign_without_rpm_or_tacho_analyses_the_squeal(small_campaign):
    # reference: the generator's truth (which applications squeal) and J2521 occurrence, which
    # needs the microphone alone
    d, truth, _ = small_campaign
    res, summary = _campaign(d, "out_nospeed")
    assert res.exit_code == 0, res.output
    assert summary["failed"] == [] and summary["applications"] == 4
    squealing = sum(bool(a["lines_hz"]) for a in truth["by_application"].values()) + 1  # + the slow drag
    assert summary["applications_with_squeal"] == squealing
    assert {r["application"] for r in summary["runout_unavailable"]} == {"A0001", "A0002", "A0003", "A0004"}
    assert all("no disc speed" in r["reason"] for r in summary["runout_unavailable"])
    apps = _applications(d, "out_nospeed")
    assert all(a["status"] == "ok" and "no disc speed" in a["runout_unavailable"] for a in apps.values())
    assert apps["A0004"]["squeal_frequency_hz"] == pytest.approx(2388.0, abs=5.0)
    assert all(a["runout_phase_deg"] is None for a in apps.values())


def test_campaign_tacho_with_two_marks_keeps_the_application(small_campaign):
    d, truth, _ = small_campaign
    res, summary = _campaign(d, "out_tacho", "--tacho", "tacho")
    assert res.exit_code == 0, res.output  # before: A0004 failed whole ("at least 3 marks")
    apps = _applications(d, "out_tacho")
    assert apps["A0004"]["status"] == "ok" and apps["A0004"]["squeal"]
    assert "tacho" in apps["A0004"]["runout_unavailable"] and "3 marks" in apps["A0004"]["runout_unavailable"]
    assert "got 2" in apps["A0004"]["runout_unavailable"]
    assert [r["application"] for r in summary["runout_unavailable"]] == ["A0004"]
    for app, t in truth["by_application"].items():  # the others keep their run-out link
        assert apps[app]["runout_unavailable"] is None
        if t["lines_hz"]:
            err = (apps[app]["runout_phase_deg"] - t["runout_phase_deg"] + 180) % 360 - 180
            assert abs(err) < 15.0


def test_analysis_without_speed_finds_the_same_squeal():
    # the squeal alone (require_runout=False) against the full analysis at the known speed
    from squealkit import InputError
    from squealkit.measurement import analyze_recording, synthetic_recording

    rec = synthetic_recording(duration=0.5, rpm=900, seed=4)
    kw = dict(mic="mic", displacement="displacement", radius=0.05)
    with pytest.raises(InputError, match="rpm"):
        analyze_recording(rec, **kw)  # required by default, as before
    full = analyze_recording(rec, rpm=900, **kw)
    alone = analyze_recording(rec, require_runout=False, **kw)
    assert alone.runout_unavailable and full.runout_unavailable is None
    assert alone.peak_dba == full.peak_dba
    assert alone.squeal_frequency_hz == full.squeal_frequency_hz
    assert [(e.start_s, e.end_s, e.frequency_hz) for e in alone.events] == \
        [(e.start_s, e.end_s, e.frequency_hz) for e in full.events]
    assert alone.rising_fraction is None and alone.runout_phase_deg is None
    assert alone.to_dict()["runout_unavailable"] == alone.runout_unavailable


# -- 2. NLEVP disk_brake100: both assemblies against an independent dense solve -------------------


def _mfile_assembly(omega):
    """M, D, K exactly as NLEVP's disk_brake100.m writes them: its ``D = ...;`` and ``K = ...;``
    lines evaluated over the raw arrays of disk_brake100.mat (the MATLAB expressions are valid
    NumPy here: sums, products and quotients of matrices and the scalar omega); and the D formula."""
    import re

    import scipy.io

    text = nlevp_path("disk_brake100.m").read_text()
    raw = {k: v for k, v in scipy.io.loadmat(nlevp_path()).items() if not k.startswith("__")}
    formula = {name: re.search(rf"^{name} = (.+);$", text, re.M).group(1) for name in ("D", "K")}
    D, K = (eval(formula[name], {"__builtins__": {}}, {**raw, "omega": omega}) for name in ("D", "K"))
    return raw, D, K, formula["D"]


def _companion_eigs(M, D, K):
    """All 2n eigenvalues of lambda^2 M + lambda D + K from LAPACK's QZ on the companion pencil."""
    import scipy.linalg as sla

    n = M.shape[0]
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-K, -D]])
    B = sla.block_diag(np.eye(n), M)
    return sla.eig(A, B, right=False)


def _match(got, ref):
    """Largest distance from each computed eigenvalue to the nearest reference one, over |lambda|_max."""
    return float(np.max(np.min(np.abs(got[:, None] - ref[None, :]), axis=1)) / np.max(np.abs(ref)))


@pytest.mark.parametrize("omega", [2 * np.pi, 8 * np.pi])
def test_nlevp_assemblies_against_an_independent_dense_solve(omega):
    from squealkit.solvers.band import dense_eigs

    raw, D_mfile, K, formula = _mfile_assembly(omega)
    assert formula == "D1 + DR/omega + omega*DG"  # what the shipped .m file writes
    ref_with_dg = _companion_eigs(raw["M"], D_mfile, K)
    ref_without_dg = _companion_eigs(raw["M"], raw["D1"] + raw["DR"] / omega, K)
    assert _match(ref_with_dg, ref_without_dg) > 1e-6  # the two assemblies are told apart (4e-5 at 2 pi)

    default = load_fe_model(nlevp_path())  # squealkit's default keeps DG: the .m file's assembly
    no_gyro = load_fe_model(nlevp_path(), omit=["DG"])
    assert "DG" in default.present and "DG" not in no_gyro.present
    for model, ref in ((default, ref_with_dg), (no_gyro, ref_without_dg)):
        lam = dense_eigs(model, omega, 1.0, vectors=False).eigenvalues  # one per mode (omega > 0)
        assert lam.size == 100
        assert _match(lam, ref) < 1e-9
        upper = ref[ref.imag > 1e-12 * np.abs(ref)]
        assert np.sum(lam.imag > 1e-12 * np.abs(lam)) == upper.size  # every oscillating mode, once


def test_omit_is_checked_and_reaches_the_toml(tmp_path):
    import shutil

    from squealkit import InputError
    from squealkit.models import load_model

    with pytest.raises(InputError, match="M and K1 are required"):
        load_fe_model(nlevp_path(), omit=["K1"])
    with pytest.raises(InputError, match="omit='DX'"):
        load_fe_model(nlevp_path(), omit=["DX"])
    shutil.copy(nlevp_path(), tmp_path / "disk_brake100.mat")
    p = tmp_path / "brake.toml"
    p.write_text('model = "fe"\n[fe]\nfile = "disk_brake100.mat"\nomit = ["DG"]\n')
    assert "DG" not in load_model(p).present

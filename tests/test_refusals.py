"""Refusals before work: runs without limit, extreme values and options found late.

Each case comes from the adversarial round of 2026-12-02 (shared/reference/adversarial-2026-12-02.md,
sections HANG/MEM, WRONG and TRACEBACK); its id is the parameter id. A refusal is one line on
stderr with exit code 2 (CLI) or an :class:`~squealkit._validation.InputError` (API), and it comes
before any heavy work: every case here runs in well under a second of squealkit's own time.
"""

from __future__ import annotations

import socket
import threading
import time

import numpy as np
import pytest
import xarray as xr

from squealkit import InputError

NLEVP_TOML = 'model = "fe"\n[fe]\nfile = "{path}"\n'


@pytest.fixture()
def fe_toml(tmp_path):
    from squealkit.data import nlevp_path

    p = tmp_path / "nlevp.toml"
    p.write_text(NLEVP_TOML.format(path=nlevp_path()))
    return str(p)


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    from squealkit.measurement import synthetic_recording

    path = tmp_path_factory.mktemp("rec") / "rec.nc"
    synthetic_recording(duration=0.5, seed=1).to_netcdf(path)
    return str(path)


def _refused(result, *words):
    """Exit 2, one line on stderr naming ``words``, no traceback."""
    err = result.stderr if hasattr(result, "stderr") else result.output
    assert result.exit_code == 2, (result.exit_code, result.output, result.exception)
    lines = [ln for ln in err.splitlines() if ln.startswith("squealkit: error:")]
    assert len(lines) == 1, err
    assert "Traceback" not in err
    for w in words:
        assert w in lines[0], (w, lines[0])


# -- A. work and memory estimated before starting ------------------------------------------------

#: (id, arguments, words of the refusal). The work is far beyond the budget (points, memory or
#: hours: each estimate is a lower bound, see check_budget), so the refusal does not depend on the
#: machine.
HUGE = [
    ("stab-grid-1e9-zarr", ["stability", "--mu", "0:0.8:31623", "--theta", "-8:8:31623", "--out", "{tmp}/big.zarr"],
     ["31623 x 31623", "1e+08"]),
    ("sim-dur-1e300-out", ["simulate", "--duration", "1e300", "--out", "{tmp}/x.nc"],
     ["1e+300 s", "SQUEALKIT_MAX_HOURS"]),
    ("sim-rk4-long", ["simulate", "--method", "rk4", "--duration", "1e6", "--fs", "1"], ["1e+06 s", "h"]),
    ("synth-campaign-huge", ["synth", "--out-dir", "{tmp}/camp", "--campaign", "1000000000"],
     ["1000000000 applications"]),
    ("synth-huge-dur", ["synth", "--out", "{tmp}/r.nc", "--duration", "1e300"], ["1e+300 s"]),
    ("synth-huge-fs", ["synth", "--out", "{tmp}/r.nc", "--fs", "1e300"], ["1e+300 Hz"]),
    ("fedemo-nz-huge", ["fe-demo", "--size", "16", "--n-z", "100000", "--out-dir", "{tmp}/b"], ["elements", "memory"]),
    ("fedemo-size-huge", ["fe-demo", "--size", "100000", "--out-dir", "{tmp}/b"], ["elements", "memory"]),
    ("floq-map-huge", ["floquet", "--mu", "0:1:100000", "--sro-amplitude", "0:1e-4:100000"], ["100000 x 100000"]),
    ("floq-speed-1e-300", ["floquet", "--speed", "1e-300"], ["steps per period"]),
    ("floq-wl-1e300", ["floquet", "--sro-wavelength", "1e300"], ["steps per period"]),
]


@pytest.mark.parametrize("args, words", [c[1:] for c in HUGE], ids=[c[0] for c in HUGE])
def test_huge_work_is_refused_up_front(run, tmp_path, args, words):
    t0 = time.perf_counter()
    result = run(*(a.format(tmp=tmp_path) for a in args))
    _refused(result, *words)
    assert time.perf_counter() - t0 < 10  # refused, not started (a started run takes hours)
    assert not any(tmp_path.iterdir())  # nothing written, no staging left


# FE grids: the per-axis grid check passes (1e7 points is a fine axis), but the map is too much
# WORK (a solve per point: 2e7 dense 200 x 200 eigenproblems) and the onset search too.
@pytest.mark.parametrize("args", [
    ["stability", "--rpm", "60:240:20000000"],
    ["stability", "--rpm", "60", "--mu", "0:1:20000000"],
    ["critical", "--rpm", "60:240:20000000"],
], ids=["fe-stab-rpm-huge-n", "fe-stab-mu-range-huge", "fe-crit-rpm-huge-n"])
def test_huge_fe_grids_are_refused_as_work(run, fe_toml, args):
    _refused(run(*args, "--config", fe_toml), "FE ", "20000000")


def test_budget_names_points_memory_and_hours(monkeypatch):
    from squealkit._validation import MAX_POINTS, check_budget

    with pytest.raises(InputError, match="points, above"):
        check_budget("A map", points=MAX_POINTS + 1)
    with pytest.raises(InputError, match="of memory"):
        check_budget("A map", nbytes=1e20)
    with pytest.raises(InputError, match="at least 3 h, above the 2 h"):
        check_budget("A run", seconds=3 * 3600)
    monkeypatch.setenv("SQUEALKIT_MAX_HOURS", "4")
    check_budget("A run", seconds=3 * 3600)  # the environment raises the limit
    monkeypatch.setenv("SQUEALKIT_MAX_HOURS", "nan")
    with pytest.raises(InputError, match="SQUEALKIT_MAX_HOURS"):
        check_budget("A run", seconds=1.0)
    with pytest.raises(InputError, match="inf"):
        monkeypatch.delenv("SQUEALKIT_MAX_HOURS")
        check_budget("A run", seconds=float("inf"))


def test_api_entry_points_share_the_budget():
    from squealkit.measurement import synthetic_recording
    from squealkit.models import get_preset
    from squealkit.stability import stability_map
    from squealkit.transient import simulate
    from squealkit.transient.floquet import floquet_map

    model = get_preset("lv2013")
    grid = np.linspace(0.0, 0.8, 20000)
    with pytest.raises(InputError, match="20000 x 20000"):  # lazily broadcast grids: no allocation first
        stability_map(model, grid, np.radians(np.linspace(-8, 8, 20000)), store="never.zarr")
    with pytest.raises(InputError, match="Floquet map of 20000 x 20000"):
        floquet_map(model, mu=grid, amplitude=np.linspace(0, 1e-4, 20000), wavelength=1e-3, speed=0.02)
    with pytest.raises(InputError, match="transient run"):
        simulate(model, mu=0.4, duration=1e9)
    with pytest.raises(InputError, match="synthetic recording"):
        synthetic_recording(duration=1e12)


# -- B. extreme finite values: refused with the value and the accepted range ----------------------

EXTREME = [
    ("stab-mu-1e300", ["stability", "--mu", "1e300", "--theta", "0", "--json"], ["1e+300", "1e+30 N/m"]),
    ("crit-mumax-1e300", ["critical", "--mu-max", "1e300", "--json"], ["mu_max=1e+300", "[0, 100]"]),
    ("modes-mu-1e300", ["modes", "--mu", "1e300", "--json"], ["1e+300", "1e+30 N/m"]),
    ("floq-amp-huge", ["floquet", "--sro-amplitude", "1", "--json"], ["amplitude=1.0 m", "[0, 0.01] m"]),
    ("synth-level-huge", ["synth", "--out", "{tmp}/r.nc", "--level-dba", "1e300"], ["level_dba=1e+300", "[-50, 200]"]),
    ("synth-level-nan", ["synth", "--out", "{tmp}/r.nc", "--level-dba", "nan"], ["level_dba=nan", "finite"]),
    ("sim-speed-1e300", ["simulate", "--speed", "1e300", "--duration", "0.001", "--json"],
     ["speed=1e+300 m/s", "[0, 1000] m/s"]),
    ("an-rpm-tiny", ["analyze", "{rec}", "--mic", "mic", "--displacement", "displacement", "--rpm", "1e-6",
                     "--radius", "0.05", "--json"], ["rpm=1e-06", "[0.001, 1e+06]"]),
    ("an-delay-huge", ["analyze", "{rec}", "--mic", "mic", "--displacement", "displacement", "--rpm", "900",
                       "--radius", "0.05", "--acoustic-delay", "1e300"], ["acoustic_delay=1e+300 s", "[0, 1] s"]),
]


@pytest.mark.parametrize("args, words", [c[1:] for c in EXTREME], ids=[c[0] for c in EXTREME])
def test_extreme_values_are_refused_with_the_range(run, tmp_path, recording, args, words):
    _refused(run(*(a.format(tmp=tmp_path, rec=recording) for a in args)), *words)
    assert not any(tmp_path.iterdir())


def test_api_refuses_what_overflows_the_kernels():
    from squealkit.models import get_preset
    from squealkit.stability import eigenvalues, stability_map

    model = get_preset("lv2013")
    # mu = 1e300 makes the friction stiffness mu kc ~ 1e307 N/m: inf/NaN in any solver
    with pytest.raises(InputError, match="1e\\+300"):
        stability_map(model, mu=[1e300], theta=[0.0])
    with pytest.raises(InputError, match="1e\\+300"):
        eigenvalues(model, 1e300)
    assert np.all(np.isfinite(eigenvalues(model, 0.5)))  # a physical value still goes through


def test_floquet_overflow_within_a_period_is_one_line():
    from squealkit.models import get_preset
    from squealkit.transient.floquet import floquet

    # 5 mm of run-out on a 1 mm wavelength (a slope of 31): the motion overflows within one period
    with pytest.raises(InputError, match="beyond double precision"):
        floquet(get_preset("lv2013"), mu=0.4, amplitude=5e-3, wavelength=1e-3, speed=0.02)


def test_non_physical_sound_pressure_names_the_channel():
    from squealkit.measurement import analyze_recording, synthetic_recording

    rec = synthetic_recording(duration=0.5, seed=1)
    rec = rec.assign(mic=rec["mic"] * 1e297)  # ~1e299 Pa: overflowed the float32 level (gave -2906 dB(A))
    with pytest.raises(InputError, match=r"Microphone channel 'mic' holds a sound pressure of .* Pa"):
        analyze_recording(rec, mic="mic", displacement="displacement", rpm=900, radius=0.05)


def test_fourier_samples_carry_more_harmonics_than_the_grid_has_points():
    from squealkit.nonlinear.continuation import _sample

    # reference: the series a_0 + sum a_k cos(k tau) + b_k sin(k tau), summed directly
    H, n, N = 40, 3, 64  # 64 instants, 40 harmonics (floquet_steps samples 64: H > 32 broke it)
    rng = np.random.default_rng(0)
    Z = rng.normal(size=(2 * H + 1, n))
    tau = 2 * np.pi * np.arange(N) / N
    k = np.arange(1, H + 1)
    direct = Z[0] + np.cos(np.outer(tau, k)) @ Z[1:H + 1] + np.sin(np.outer(tau, k)) @ Z[H + 1:]
    np.testing.assert_allclose(_sample(Z, N), direct, atol=1e-12)


def test_limit_cycle_branch_beyond_32_harmonics():
    from squealkit.models import get_preset
    from squealkit.nonlinear import limit_cycle_branch

    # limitcycle --harmonics 33 broadcast (33, 3) into (32, 3) in the Floquet step estimate
    ds = limit_cycle_branch(get_preset("lv2013"), (0.39, 0.45), harmonics=33, n_points=2)
    assert ds.attrs["harmonics"] == 33 and ds.sizes["harmonic_row"] == 2 * 33 + 1
    assert np.all(np.isfinite(ds["floquet_max"]))


# -- C. bad options found before any work; options that would be ignored are refused -------------

def test_campaign_options_checked_before_anything_is_written(run, tmp_path, recording):
    from squealkit.campaign import run_campaign

    matrix = tmp_path / "matrix.csv"
    matrix.write_text(f"application,file\nA1,{recording}\n")
    common = ["campaign", str(matrix), "--mic", "mic", "--displacement", "displacement"]
    _refused(run(*common, "--radius", "0", "--rpm", "900", "--out-dir", str(tmp_path / "o1")), "radius=0.0")
    _refused(run(*common, "--radius", "0.05", "--tacho", "tacho", "--pulses-per-rev", "0",
                 "--out-dir", str(tmp_path / "o2")), "pulses_per_rev=0")
    with pytest.raises(InputError, match="radius=-1"):
        run_campaign(matrix, tmp_path / "o3", mic="mic", displacement="displacement", radius=-1, rpm=900,
                     report=False)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["matrix.csv"]  # no store, summary or report


IGNORED = [
    ("tol-mumax-nonfe", ["tolerance", "--mu", "0.3", "--mu-max", "0.5"], ["--mu-max", "FE models only"]),
    ("report-radius-no-rec", ["report", "--quick", "--radius", "0.05", "--out-dir", "{tmp}/r"],
     ["--radius", "--recording"]),
    ("report-rpm-no-rec", ["report", "--quick", "--rpm", "900", "--out-dir", "{tmp}/r"], ["--rpm", "--recording"]),
    ("tol-damped-fe", ["tolerance", "--config", "{fe}", "--mu", "0.3", "--rpm", "60", "--damped"],
     ["--damped", "small models"]),
    ("synth-rpm-campaign", ["synth", "--out-dir", "{tmp}/c", "--campaign", "2", "--rpm", "900"],
     ["--rpm", "--campaign"]),
    ("synth-format-one", ["synth", "--out", "{tmp}/r.nc", "--format", ".csv"], ["--format", "--campaign only"]),
]


@pytest.mark.parametrize("args, words", [c[1:] for c in IGNORED], ids=[c[0] for c in IGNORED])
def test_options_that_would_be_ignored_are_refused(run, tmp_path, fe_toml, args, words):
    _refused(run(*(a.format(tmp=tmp_path, fe=fe_toml) for a in args)), *words)
    assert [p.name for p in tmp_path.iterdir()] == ["nlevp.toml"]  # nothing written beside the fixture


# -- D. single cases: text parameters, a closed stdout, a scheduler that is not one ---------------

def test_presets_lists_text_parameters(run):
    result = run("presets")
    assert result.exit_code == 0, result.output
    assert "kinematics = paper" in result.output


def test_closed_stdout_is_one_line():
    import subprocess
    import sys

    code = "import sys; sys.stdout = None; from squealkit.cli.main import main; main()"
    proc = subprocess.run([sys.executable, "-c", code, "critical", "--json"], capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.strip().splitlines() == ["squealkit: error: cannot write to standard output (it is closed)"]


@pytest.fixture()
def junk_server():
    """A loopback server that answers every connection with an SSH banner, then closes."""
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(8)

    def serve():
        while True:
            try:
                conn, _ = srv.accept()
            except OSError:
                return
            with conn:
                conn.sendall(b"SSH-2.0-OpenSSH_9.2\r\n")

    threading.Thread(target=serve, daemon=True).start()
    yield f"tcp://127.0.0.1:{srv.getsockname()[1]}"
    srv.close()


def test_scheduler_that_speaks_another_protocol_is_one_line(run, tmp_path, junk_server):
    pytest.importorskip("distributed")
    t0 = time.perf_counter()
    result = run("stability", "--mu", "0:0.8:11", "--theta", "0", "--out", str(tmp_path / "m.zarr"),
                 "--scheduler", junk_server)
    _refused(result, junk_server, "Dask")
    assert time.perf_counter() - t0 < 15
    assert not any(tmp_path.iterdir())


def test_refusals_leave_xarray_results_alone():
    # a physical map still computes (the checks are bounds, not behaviour changes)
    from squealkit.models import get_preset
    from squealkit.stability import stability_map

    ds = stability_map(get_preset("lv2013"), np.linspace(0, 0.8, 5), np.radians([0.0]))
    assert isinstance(ds, xr.Dataset) and ds.sizes["mu"] == 5

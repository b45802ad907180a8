"""Scale-out on a real Dask cluster: a scheduler and worker processes started on loopback.

The cluster here is what a user starts by hand (``dask scheduler`` / ``dask worker``),
not an in-process one: tasks are pickled over TCP to separate Python processes. Every
distributed result is compared with the same job run in this process: they must be
identical, bit for bit, including when a worker is killed mid-run.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from click.testing import CliRunner

distributed = pytest.importorskip("distributed")

from squealkit.campaign import analyze_campaign  # noqa: E402
from squealkit.cli.main import cli  # noqa: E402
from squealkit.measurement import synthetic_recording  # noqa: E402
from squealkit.models import get_preset  # noqa: E402
from squealkit.scale import map_tasks  # noqa: E402
from squealkit.stability import stability_map, stability_summary  # noqa: E402
from squealkit.transient import SineRunOut, simulate_batch  # noqa: E402

_WORKER = [sys.executable, "-m", "distributed.cli.dask_worker", "--nthreads", "1", "--no-nanny",
           "--no-dashboard", "--host", "127.0.0.1"]


class Loopback:
    """A scheduler and worker processes on 127.0.0.1."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self.scheduler_file = folder / "scheduler.json"
        self.procs: list[subprocess.Popen] = []
        self._log = open(folder / "cluster.log", "w")
        self.procs.append(self._start([sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
                                       "--port", "0", "--no-dashboard", "--scheduler-file", str(self.scheduler_file)]))
        deadline = time.monotonic() + 60
        while not self.scheduler_file.exists():
            if time.monotonic() > deadline:
                raise RuntimeError("the Dask scheduler did not start")
            time.sleep(0.1)
        self.client = distributed.Client(scheduler_file=str(self.scheduler_file), timeout="30s")

    def _start(self, cmd: list[str]) -> subprocess.Popen:
        env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(Path(__file__).parents[1] / "src"),
                                                            os.environ.get("PYTHONPATH", "")])}
        return subprocess.Popen(cmd, stdout=self._log, stderr=subprocess.STDOUT, env=env, start_new_session=True)

    def add_workers(self, n: int) -> None:
        have = len(self.client.scheduler_info()["workers"])
        for _ in range(n):
            self.procs.append(self._start([*_WORKER, "--scheduler-file", str(self.scheduler_file)]))
        self.client.wait_for_workers(have + n, timeout=120)

    def worker_pids(self) -> dict[str, int]:
        return self.client.run(os.getpid)

    def close(self) -> None:
        self.client.close()
        for p in self.procs:
            if p.poll() is None:
                os.killpg(p.pid, signal.SIGTERM)
        for p in self.procs:
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                os.killpg(p.pid, signal.SIGKILL)
        self._log.close()


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    lb = Loopback(tmp_path_factory.mktemp("dask"))
    try:
        lb.add_workers(2)
        yield lb
    finally:
        lb.close()


@pytest.mark.slow
def test_workers_are_separate_processes(cluster):
    pids = cluster.worker_pids()
    assert len(pids) >= 2 and os.getpid() not in pids.values()
    assert all(addr.startswith("tcp://127.0.0.1:") for addr in pids)


@pytest.mark.slow
def test_stability_map_on_cluster_is_identical_to_local(cluster, tmp_path):
    model = get_preset("lv2013")
    mu = np.linspace(0.0, 0.8, 161)
    theta = np.radians(np.linspace(-8, 8, 97))
    seen = []
    for damped in (False, True):
        local = stability_map(model, mu, theta, damped=damped)
        ds = stability_map(model, mu, theta, damped=damped, store=tmp_path / f"map{damped}.zarr",
                           client=cluster.client, tile_points=1000, progress=lambda d, t: seen.append((d, t)))
        assert ds["growth_rate"].chunks is not None  # opened lazily from the store, not gathered
        xr.testing.assert_identical(local, ds.load())
        assert stability_summary(ds) == stability_summary(local)
    assert seen[-1] == (mu.size * theta.size,) * 2


@pytest.mark.slow
def test_worker_killed_mid_run_job_finishes_correctly(cluster, tmp_path):
    """SIGKILL a worker while it computes tiles: the scheduler reruns its tasks elsewhere."""
    cluster.add_workers(1)
    model = get_preset("lv2013")
    mu = np.linspace(0.0, 0.8, 1200)
    theta = np.radians(np.linspace(-8, 8, 1001))
    pids = cluster.worker_pids()
    killed: list[int] = []

    def progress(done: int, total: int) -> None:
        if killed or done < total // 8:
            return
        busy = [addr for addr, tasks in cluster.client.processing().items() if tasks]
        addr = busy[-1]
        os.kill(pids[addr], signal.SIGKILL)
        killed.append(done)

    ds = stability_map(model, mu, theta, damped=True, store=tmp_path / "big.zarr", client=cluster.client,
                       tile_points=30_000, progress=progress)
    assert killed and killed[0] < mu.size * theta.size  # killed mid-run, while tiles were running
    assert len(cluster.client.scheduler_info()["workers"]) == len(pids) - 1
    xr.testing.assert_identical(stability_map(model, mu, theta, damped=True), ds.load())


@pytest.mark.slow
def test_transient_batch_on_cluster_is_identical_to_local(cluster, tmp_path):
    model = get_preset("lv2013")
    kw = dict(mu=np.linspace(0.3, 0.7, 7), profiles=SineRunOut(amplitude=0.08e-3, wavelength=1e-3),
              duration=0.01, perturbation=1e-9)
    local = simulate_batch(model, rng=np.random.default_rng(4), **kw)
    ds = simulate_batch(model, rng=np.random.default_rng(4), store=tmp_path / "runs.zarr", client=cluster.client,
                        runs_per_task=2, **kw)
    xr.testing.assert_identical(local, ds.load())


@pytest.mark.slow
def test_campaign_on_cluster_matches_local(cluster, tmp_path):
    files = []
    for seed in range(4):
        rec = synthetic_recording(duration=1.0, seed=seed, squeal_on="none" if seed == 2 else "rising")
        files.append(tmp_path / f"rec{seed}.nc")
        rec.to_netcdf(files[-1], engine="h5netcdf")
    kw = dict(mic="mic", displacement="displacement", rpm=900.0, radius=0.05)
    local = analyze_campaign(files, **kw)
    remote = analyze_campaign(files, client=cluster.client, **kw)
    assert remote.to_dict() == local.to_dict()
    # truth: recording 2 was made without squeal, the others with it
    assert remote.occurrence_percent == pytest.approx(75.0)
    assert [r["squeal"] for r in remote.rows] == [1, 1, 0, 1]


@pytest.mark.slow
def test_montecarlo_on_cluster_is_identical_to_local(cluster):
    from squealkit.uncertainty import parse_uncertain, squeal_propensity

    model = get_preset("lv2013")
    unc = parse_uncertain({"k3": {"dist": "normal", "mean": 9.452e8, "std": 4.7e7},
                           "alpha_deg": {"dist": "uniform", "lower": 1.5, "upper": 2.5}}, model)
    kw = dict(samples=256, seed=3, batch_size=40)
    mu = np.linspace(0.3, 0.6, 16)
    local = squeal_propensity(model, unc, mu, **kw)
    remote = squeal_propensity(model, unc, mu, client=cluster.client, **kw)
    xr.testing.assert_identical(local, remote)


@pytest.mark.slow
def test_cli_stability_with_scheduler_matches_local(cluster, tmp_path):
    runner = CliRunner()
    args = ["stability", "--mu", "0:0.8:41", "--theta", "-8:8:21", "--json"]
    local = runner.invoke(cli, [*args, "--out", str(tmp_path / "a.zarr")])
    remote = runner.invoke(cli, [*args, "--out", str(tmp_path / "b.zarr"),
                                 "--scheduler", str(cluster.scheduler_file)])
    assert local.exit_code == 0 and remote.exit_code == 0, remote.output
    assert json.loads(remote.stdout) == json.loads(local.stdout)
    xr.testing.assert_identical(xr.open_zarr(tmp_path / "a.zarr", consolidated=False).load(),
                                xr.open_zarr(tmp_path / "b.zarr", consolidated=False).load())


@pytest.mark.slow
def test_cli_analyze_campaign_with_scheduler(cluster, tmp_path):
    for seed in (0, 1):
        synthetic_recording(duration=1.0, seed=seed).to_netcdf(tmp_path / f"r{seed}.nc", engine="h5netcdf")
    runner = CliRunner()
    args = [str(tmp_path / "r0.nc"), str(tmp_path / "r1.nc"), "--mic", "mic", "--displacement", "displacement",
            "--rpm", "900", "--radius", "0.05", "--json"]
    local = runner.invoke(cli, ["analyze", *args])
    remote = runner.invoke(cli, ["analyze", *args, "--scheduler", str(cluster.scheduler_file),
                                 "--summary", str(tmp_path / "c.csv")])
    assert remote.exit_code == 0, remote.output
    assert json.loads(remote.stdout) == json.loads(local.stdout)
    assert (tmp_path / "c.csv").read_text().count("\n") >= 3


def test_local_cluster_workers_keep_glibc_malloc_defaults(monkeypatch):
    # Dask's default MALLOC_TRIM_THRESHOLD_=65536 turns off glibc's adaptive mmap threshold:
    # a campaign's application then costs 10-15 ms more CPU in a worker (page faults)
    from squealkit.scale import cluster_client

    monkeypatch.delenv("MALLOC_TRIM_THRESHOLD_", raising=False)
    with cluster_client("local", n_workers=1) as client:
        seen = client.run(os.getenv, "MALLOC_TRIM_THRESHOLD_")
        hash_seed = client.run(os.getenv, "PYTHONHASHSEED")
    assert list(seen.values()) == [None]
    assert list(hash_seed.values()) == ["6640"]  # Dask's other worker settings are kept


def test_map_tasks_without_client_runs_in_order():
    assert list(map_tasks(str, [3, 1, 2])) == [(0, "3"), (1, "1"), (2, "2")]


def test_client_needs_a_store(tmp_path):
    from squealkit import InputError

    with pytest.raises(InputError, match="zarr"):
        stability_map(get_preset("lv2013"), [0.1, 0.2], [0.0], client=object())
    with pytest.raises(InputError, match=r"\.zarr"):
        stability_map(get_preset("lv2013"), [0.1, 0.2], [0.0], store=tmp_path / "x.nc")


@pytest.mark.parametrize("args, message", [
    (["stability", "--scheduler", "local"], "--out FILE.zarr"),
    (["stability", "--out", "x.zarr", "--scheduler", "missing-scheduler.json"], "missing-scheduler.json"),
    (["simulate", "--mu", "0.2:0.4:3"], "--out"),
])
def test_cli_scheduler_errors_are_one_line(args, message, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    res = CliRunner().invoke(cli, args)
    assert res.exit_code == 2
    assert message in res.output and res.output.count("\n") == 1 and "Traceback" not in res.output


def _statuses(arg):
    words = ["completed", "diverged"] if arg == 0 else ["diverged", "diverged"]
    return xr.Dataset({"status": ("run", np.array(words)), "x": ("run", np.arange(2.0) + arg)},
                      coords={"run": [2 * arg, 2 * arg + 1]})


def test_text_of_data_dependent_width_streams_to_zarr(tmp_path, recwarn):
    # issue 15: `simulate --mu 0.2:0.8:64 --out b64.zarr` crashed (status '<U9' in the store, '<U8'
    # in a later piece whose runs had all diverged), and zarr v3 warned about fixed-width text
    from squealkit.scale import lazy_template, stream_to_zarr

    template = lazy_template(_statuses(0), "run", np.arange(6), 2)
    ds = stream_to_zarr(tmp_path / "s.zarr", template, "run", [(_statuses, k, 2 * k, 2 * k + 2) for k in range(3)])
    assert ds["status"].values.tolist() == ["completed"] + ["diverged"] * 5
    assert ds["x"].values.tolist() == [0, 1, 1, 2, 2, 3]
    assert not [w for w in recwarn if "Specification" in type(w.message).__name__]


def test_streamed_text_is_chunked_like_the_pieces(tmp_path):
    # pieces written at once by different workers must never share a zarr chunk: a text variable
    # laid out as one chunk lost whole pieces when two wrote it together (read-modify-write)
    import zarr

    from squealkit.transient import simulate_batch
    from squealkit.transient.profiles import SineRunOut

    kw = dict(mu=np.linspace(0.3, 0.7, 7), profiles=SineRunOut(amplitude=0.08e-3, wavelength=1e-3),
              duration=0.005, perturbation=1e-9)
    simulate_batch(get_preset("lv2013"), rng=np.random.default_rng(4), store=tmp_path / "runs.zarr",
                   runs_per_task=2, **kw)
    group = zarr.open_group(str(tmp_path / "runs.zarr"), mode="r")
    for name in group.array_keys():
        arr = group[name]
        if arr.ndim and arr.shape[0] == 7:
            assert arr.chunks[0] == 2, name

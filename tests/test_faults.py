"""Faults on the output side: every one a single line and exit code 2, checked before the work;
nothing half-written, nothing deleted that squealkit did not write, permissions as the user
expects (issue #15, "Faults on the output side")."""

from __future__ import annotations

import json
import os
import signal
import stat
import subprocess
import sys
import tempfile
import time

import numpy as np
import pytest
import xarray as xr

from squealkit import io
from squealkit.io import MANIFEST, atomic_path, output_folder, save_dataset, write_text

SQUEALKIT = [sys.executable, "-c", "from squealkit.cli.main import main; main()"]


def _one_line(r) -> str:
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr
    return lines[0]


def test_out_naming_a_folder_is_refused_before_the_work(run, tmp_path):
    (tmp_path / "x").mkdir()
    r = run("stability", "--mu", "0:0.8:5", "--theta", "0", "--out", str(tmp_path / "x"))
    assert r.exit_code == 2 and "is a folder" in _one_line(r)
    r = run("stability", "--mu", "0:0.8:5", "--theta", "0", "--plot", str(tmp_path / "no" / "f.png"))
    assert r.exit_code == 2 and "does not exist" in _one_line(r)


def test_unwritable_folder_is_one_line(run, tmp_path, monkeypatch):
    # as root a chmod cannot deny writing, so the OS's answer is injected where it arrives
    def denied(*a, **k):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(tempfile, "mkstemp", denied)
    r = run("stability", "--mu", "0:0.8:5", "--theta", "0", "--out", str(tmp_path / "m.nc"))
    assert r.exit_code == 2 and "Permission denied" in _one_line(r)
    r = run("critical", "--theta", "0", "--json")  # no output file: unaffected
    assert r.exit_code == 0


def test_os_error_during_the_run_is_one_line(run, tmp_path, monkeypatch):
    def full(*a, **k):
        raise OSError(28, "No space left on device", str(tmp_path / "m.nc"))

    monkeypatch.setattr(xr.Dataset, "to_netcdf", full)
    r = run("stability", "--mu", "0:0.8:5", "--theta", "0", "--out", str(tmp_path / "m.nc"))
    assert r.exit_code == 2 and "no space left" in _one_line(r)
    assert os.listdir(tmp_path) == []  # the staged file went with the failure


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full")
def test_stdout_to_a_full_device_is_one_line():
    with open("/dev/full", "w") as full:
        r = subprocess.run([*SQUEALKIT, "presets", "--json"], stdout=full, stderr=subprocess.PIPE, text=True,
                           timeout=120)
    assert r.returncode == 2 and "standard output" in _one_line(r)


@pytest.mark.slow
def test_sigterm_leaves_no_staging_files_and_exits_143(tmp_path):
    out = tmp_path / "map.zarr"
    p = subprocess.Popen([*SQUEALKIT, "stability", "--mu", "0:0.8:3000", "--theta", "-8:8:3000", "--out", str(out)],
                         stderr=subprocess.PIPE, text=True, cwd=tmp_path)
    deadline = time.monotonic() + 60
    while not any(n.startswith(".map.zarr") for n in os.listdir(tmp_path)) and time.monotonic() < deadline:
        if p.poll() is not None:
            pytest.fail(f"finished before the signal: {p.stderr.read()}")
        time.sleep(0.05)
    p.send_signal(signal.SIGTERM)
    err = p.communicate(timeout=60)[1]
    assert p.returncode == 143, err
    assert "terminated" in err and "Traceback" not in err
    assert os.listdir(tmp_path) == []


def test_interrupt_swallowed_by_a_library_still_discards_the_output(tmp_path):
    out = tmp_path / "a.txt"
    try:
        with pytest.raises(KeyboardInterrupt), atomic_path(out) as tmp:
            tmp.write_text("half")
            io.note_interrupt()  # the handler ran, but the exception was caught inside a library
    finally:
        io.clear_interrupt()
    assert os.listdir(tmp_path) == []


def test_new_outputs_follow_the_umask_and_overwritten_keep_their_mode(tmp_path):
    old = os.umask(0o022)
    try:
        f = write_text(tmp_path / "a.json", "{}")
        assert stat.S_IMODE(f.stat().st_mode) == 0o644
        ds = xr.Dataset({"x": ("t", np.arange(3.0))})
        z = save_dataset(ds, tmp_path / "a.zarr")
        assert stat.S_IMODE(z.stat().st_mode) == 0o755
        f.chmod(0o640)
        write_text(f, "[]")
        assert stat.S_IMODE(f.stat().st_mode) == 0o640
        os.umask(0o077)
        assert stat.S_IMODE(write_text(tmp_path / "b.json", "{}").stat().st_mode) == 0o600
    finally:
        os.umask(old)


def test_output_folder_never_deletes_foreign_files(tmp_path, monkeypatch):
    folder = tmp_path / "report"
    folder.mkdir()
    (folder / "notes.txt").write_text("mine")
    with pytest.raises(io.InputError, match=r"did not write.*notes\.txt"):
        with output_folder(folder):
            pass
    # with force the new files go in beside them, and a manifest lists only squealkit's
    with output_folder(folder, force=True) as stage:
        (stage / "figures").mkdir()
        (stage / "figures" / "f.png").write_text("png")
        (stage / "report.html").write_text("new")
    assert (folder / "notes.txt").read_text() == "mine"
    assert (folder / "report.html").read_text() == "new"
    assert json.loads((folder / MANIFEST).read_text())["files"] == ["figures/f.png", "report.html"]
    assert sorted(p.name for p in folder.iterdir()) == [MANIFEST, "figures", "notes.txt", "report.html"]
    # '.' works too (no rename of the working directory)
    monkeypatch.chdir(folder)
    with output_folder(".", force=True) as stage:
        (stage / "report.html").write_text("newer")
    assert (folder / "report.html").read_text() == "newer" and (folder / "notes.txt").exists()


def test_output_folder_replaces_what_squealkit_wrote(tmp_path):
    folder = tmp_path / "report"
    with output_folder(folder) as stage:
        (stage / "old.png").write_text("1")
        (stage / "report.html").write_text("first")
    with output_folder(folder) as stage:  # a squealkit folder: replaced as a whole
        (stage / "report.html").write_text("second")
    assert sorted(p.name for p in folder.iterdir()) == [MANIFEST, "report.html"]
    assert (folder / "report.html").read_text() == "second"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report"]  # no staging left


def test_zarr_output_over_a_foreign_folder_is_refused(run, tmp_path):
    folder = tmp_path / "keep.zarr"
    folder.mkdir()
    (folder / "precious.txt").write_text("x")
    r = run("stability", "--mu", "0:0.8:5", "--theta", "0", "--out", str(folder))
    assert r.exit_code == 2 and "did not write" in _one_line(r)
    assert (folder / "precious.txt").exists()


def test_scheduler_that_is_not_dask_times_out_in_one_line(run, tmp_path, monkeypatch):
    import socket
    import threading

    from squealkit import scale

    # a service that accepts the connection and never answers (the silent hang)
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen()
    held = []
    threading.Thread(target=lambda: held.append(server.accept()), daemon=True).start()
    monkeypatch.setattr(scale, "CONNECT_TIMEOUT", 2.0)
    address = f"tcp://127.0.0.1:{server.getsockname()[1]}"
    t0 = time.monotonic()
    r = run("stability", "--mu", "0:0.8:5", "--theta", "0", "--scheduler", address, "--out", str(tmp_path / "s.zarr"))
    assert r.exit_code == 2 and "No Dask scheduler answered" in _one_line(r)
    assert time.monotonic() - t0 < 30
    server.close()


@pytest.mark.slow
def test_a_failed_connection_leaves_no_half_made_client(monkeypatch):
    """A Client that failed to connect was left half made; garbage collection later closed it from
    whatever thread it ran in, taking distributed's class-wide loop-runner lock, and when that thread
    already held the lock (starting the next client or local cluster) it waited for itself for ever:
    a whole test run hung in LocalCluster's start-up so (seen in py-spy: Client.__del__ inside
    LoopRunner._start_unlocked). A failed attempt now closes its client itself."""
    import gc
    import socket
    import threading

    import distributed

    from squealkit import scale

    silent = socket.socket()  # accepts and never answers: the caller gives up, then the server hangs up
    silent.bind(("127.0.0.1", 0))
    silent.listen()
    held = []
    threading.Thread(target=lambda: held.append(silent.accept()), daemon=True).start()
    address = f"tcp://127.0.0.1:{silent.getsockname()[1]}"
    monkeypatch.setattr(scale, "CONNECT_TIMEOUT", 2.0)
    with pytest.raises(io.InputError, match="No Dask scheduler answered"):
        scale.get_client(address)
    for conn, _ in held:
        conn.close()
    silent.close()
    for t in threading.enumerate():
        if t.name == "squealkit-connect":
            t.join(30)
    left = [c.status for c in gc.get_objects() if isinstance(c, distributed.Client)
            and getattr(c, "_start_arg", None) == address and c.status != "closed"]
    assert not left


def test_no_garbage_collection_while_a_local_cluster_starts(monkeypatch):
    """The other half of the hang above: a collection inside distributed's loop-runner lock (while a
    local cluster starts) that meets an unclosed client waits for itself. Allocations inside the lock
    would trigger automatic collection (as a busy process does); while squealkit starts a cluster
    none runs there."""
    import gc
    import threading

    from distributed.utils import LoopRunner

    from squealkit import scale

    inside = threading.local()
    collected_inside = []
    original = LoopRunner._start_unlocked

    def busy_start(self):
        inside.flag = True
        try:
            junk = [[{}] for _ in range(20000)]  # containers enough for generation-0 collections
            del junk
            return original(self)
        finally:
            inside.flag = False

    def watch(phase, info):
        if phase == "start" and getattr(inside, "flag", False):
            collected_inside.append(info["generation"])

    monkeypatch.setattr(LoopRunner, "_start_unlocked", busy_start)
    gc.callbacks.append(watch)
    try:
        with scale.cluster_client("local", n_workers=1) as client:
            assert client.submit(sum, [1, 2]).result() == 3
    finally:
        gc.callbacks.remove(watch)
    assert gc.isenabled()
    assert collected_inside == []


def test_local_cluster_whose_workers_never_start_is_one_line(run, tmp_path, monkeypatch):
    """A local cluster whose worker processes never come up (seen once under heavy load: a whole CI run then
    waited in LocalCluster's start-up until it was killed) ends within the start-up bound, in one line."""
    import dask

    from squealkit import scale

    preload = tmp_path / "stall.py"  # every worker stalls in its start-up, as a stuck worker would
    preload.write_text("import time\ntime.sleep(600)\n")
    monkeypatch.setattr(scale, "LOCAL_START_TIMEOUT", 3.0)
    t0 = time.monotonic()
    with dask.config.set({"distributed.worker.preload": [str(preload)]}):
        r = run("stability", "--mu", "0:0.8:5", "--theta", "0", "--scheduler", "local",
                "--out", str(tmp_path / "s.zarr"))
    assert r.exit_code == 2 and "did not start within 3 s" in _one_line(r), r.output
    assert time.monotonic() - t0 < 60
    assert not (tmp_path / "s.zarr").exists()


def test_scheduler_file_that_is_not_one_is_one_line(run, tmp_path):
    bad = tmp_path / "sched.json"
    for text in ('{"address": 5}', "not json", "[1, 2]"):
        bad.write_text(text)
        r = run("stability", "--mu", "0:0.8:5", "--theta", "0", "--scheduler", str(bad),
                "--out", str(tmp_path / "s.zarr"))
        assert r.exit_code == 2 and "is not a Dask scheduler file" in _one_line(r)


def test_work_that_will_not_fit_in_memory_is_refused_before_allocating(run, tmp_path, monkeypatch):
    monkeypatch.setattr("squealkit._validation.available_memory", lambda: 1 << 30)  # a 1 GiB machine
    # the grid itself: 1e8 points of mu
    r = run("stability", "--mu", "0:1:100000000", "--theta", "0")
    assert r.exit_code == 2 and "needs about" in _one_line(r) and "available" in r.stderr
    # a map of 2e7 points in memory (about 8 GB): refused, with the way out
    r = run("stability", "--mu", "0:1:2000000", "--theta", "-8:8:10")
    assert r.exit_code == 2 and "--out FILE.zarr" in _one_line(r)
    # streamed, the first column (3e6 points) must still fit
    r = run("stability", "--mu", "0:1:3000000", "--theta", "0", "--out", str(tmp_path / "m.zarr"))
    assert r.exit_code == 2 and "first column" in _one_line(r)
    r = run("critical", "--theta", "0:1:100000000")
    assert r.exit_code == 2 and "needs about" in _one_line(r)
    assert os.listdir(tmp_path) == []


def test_monte_carlo_too_big_is_refused_before_sampling(run, monkeypatch, tmp_path):
    unc = tmp_path / "unc.toml"
    unc.write_text('[uncertain]\nk3 = {dist = "normal", mean = 9e5, std = 1e5}\n')
    monkeypatch.setattr("squealkit._validation.available_memory", lambda: 1 << 30)
    r = run("montecarlo", "--preset", "hoffmann2002", "--uncertain", str(unc), "--samples", "100000000",
            "--mu", "0:1:11")
    assert r.exit_code == 2 and "Monte Carlo of 100000000 samples" in _one_line(r)


@pytest.mark.parametrize(("setting", "says"), [("m1=1e-300", "below 1e-30 kg"), ("kc=1e300", "above 1e+30 N/m"),
                                               ("m1=1e300", "above 1e+30 kg")])
def test_meaningless_magnitudes_are_one_line(run, setting, says):
    # a numba SystemError (an overflow in the characteristic polynomial) before
    for cmd in (["stability", "--mu", "0:0.8:5", "--theta", "0"], ["critical"], ["modes", "--mu", "0.3"]):
        r = run(*cmd, "--set", setting)
        assert r.exit_code == 2 and says in _one_line(r), (cmd, r.output)


def test_meaningless_scatter_is_one_line(run, tmp_path):
    unc = tmp_path / "unc.toml"
    unc.write_text('[uncertain]\nkc = {dist = "lognormal", mean = 4.6e7, std = 1e300}\n')
    r = run("montecarlo", "--uncertain", str(unc), "--samples", "64", "--mu", "0:1:11")
    assert r.exit_code == 2 and "times its mean" in _one_line(r)


def test_typo_table_in_a_model_file_is_an_error_not_the_default_model(run, tmp_path):
    cfg = tmp_path / "rig.toml"
    cfg.write_text("[paramters]\nm1 = -5\n")
    r = run("critical", "--config", str(cfg))
    assert r.exit_code == 2 and "did you mean 'parameters'" in _one_line(r)


@pytest.mark.skipif(not os.path.exists("/dev/zero"), reason="needs /dev/zero")
def test_endless_model_file_is_read_bounded(run):
    t0 = time.monotonic()
    r = run("critical", "--config", "/dev/zero")
    assert r.exit_code == 2 and "larger than 16 MiB" in _one_line(r)
    assert time.monotonic() - t0 < 20


# -- faults on the input side: a bad recording is one line naming the file and where, exit 2 -----------------
def _csv_jumping_at_line_3000(tmp_path):
    t = np.arange(4000) / 40000.0
    t[2998:] += 5.0  # data row 2998 is line 3000 (the header is line 1); the first 64 rows are fine
    f = tmp_path / "jump.csv"
    f.write_text("time,mic,displacement\n" + "".join(f"{x:.8g},0.1,0\n" for x in t))
    return f, "time column 'time' jumps from 0.074925 s to 5.07495 s at line 3000"


def _wav_at_zero_hz(tmp_path):
    from scipy.io import wavfile

    f = tmp_path / "zero.wav"
    wavfile.write(f, 40000, np.zeros((4000, 2), np.float32))
    b = bytearray(f.read_bytes())
    b[24:28] = bytes(4)  # the header's sample rate (RIFF fmt chunk, bytes 24-27)
    f.write_bytes(bytes(b))
    return f, "sample rate (WAV header) is 0 Hz"


def _tdms_text_mic(tmp_path):
    from nptdms import ChannelObject, TdmsWriter

    f = tmp_path / "text.tdms"
    with TdmsWriter(f) as w:
        w.write_segment([ChannelObject("rig", "mic", np.array(["0.1"] * 4000)),
                         ChannelObject("rig", "displacement", np.zeros(4000), properties={"wf_increment": 2.5e-5})])
    return f, "channel 'rig/mic': holds text"


@pytest.mark.parametrize("make", [_csv_jumping_at_line_3000, _wav_at_zero_hz, _tdms_text_mic])
def test_bad_recording_is_one_line_exit_2(run, tmp_path, make):
    f, says = make(tmp_path)
    mic = ["--mic", "0", "--displacement", "1"] if f.suffix == ".wav" else ["--mic", "mic", "--displacement",
                                                                          "displacement"]
    r = run("analyze", str(f), *mic, "--rpm", "900", "--radius", "0.05")
    line = _one_line(r)
    assert r.exit_code == 2 and says in line and str(f) in line, line


@pytest.mark.slow
def test_sigterm_during_a_streamed_simulation_leaves_no_partial_file(tmp_path):
    # simulate --out streams block by block into the staged file: killed half way, nothing is left
    # --json: no progress bar filling the unread stderr pipe
    p = subprocess.Popen([*SQUEALKIT, "simulate", "--duration", "30", "--out", "long.nc", "--json"],
                         stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, cwd=tmp_path)
    deadline = time.monotonic() + 300  # a loaded machine starts slowly
    while not any(n.startswith(".long.nc") and os.path.getsize(tmp_path / n) > 0 for n in os.listdir(tmp_path)):
        if p.poll() is not None:
            pytest.fail(f"finished before the signal: {p.stderr.read()}")
        if time.monotonic() > deadline:
            p.kill()
            pytest.fail("the staged file never appeared")
        time.sleep(0.05)
    p.send_signal(signal.SIGTERM)
    err = p.communicate(timeout=60)[1]
    assert p.returncode == 143, err
    assert "Traceback" not in err
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize("suffix", [".nc", ".csv", ".wav", ".tdms", ".mf4"])
def test_recording_written_block_by_block_reads_back_whole(tmp_path, suffix):
    # issue #15: synth streams long recordings; blocks of 1000 samples read back as the one-shot dataset
    from squealkit.measurement.formats.writers import write_recording_blocks
    from squealkit.measurement.synthetic import synthetic_attrs, synthetic_source

    src = synthetic_source(duration=0.1, seed=3)
    whole = src.block(0, src.n_samples)
    write_recording_blocks(src.iter_blocks(src.channels, block=1000), tmp_path / f"r{suffix}", fs=src.fs,
                           n_samples=src.n_samples, units=src.units, attrs=synthetic_attrs(src))
    from squealkit.measurement import read_recording

    back = read_recording(tmp_path / f"r{suffix}")
    assert back.sizes["time"] == src.n_samples
    for i, name in enumerate(src.channels):
        got = back[next(v for v in back.data_vars if str(v).endswith(name) or str(v) == f"ch{i}")].values
        # noise is seeded per block (1000 here, not one block of 4000): the noise-free tacho is exact
        if name == "tacho":
            np.testing.assert_array_equal(got, whole[name])
        assert got.shape == whole[name].shape and np.all(np.isfinite(got))
    assert os.listdir(tmp_path) == [f"r{suffix}"]

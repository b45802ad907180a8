"""The user's files are never lost, and a run leaves nothing behind (issues #29 and #31).

Every case is one of the adversarial round of 2026-12-02
(``shared/reference/adversarial-2026-12-02.md``, sections LOST and LEFTOVER and the full-disk
and race cases of TRACEBACK), named by its id there. The reference is squealkit's own promise
(``squealkit.io``): an output is written completely or not at all, a file or folder is
squealkit's only if squealkit's manifest lists it, and nothing else is ever deleted or
replaced; a refusal is one line on stderr and exit code 2 (``InputError`` from the API).
"""

from __future__ import annotations

import contextlib
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

from squealkit import io
from squealkit.io import MANIFEST, InputError, atomic_path, output_folder, save_dataset, write_text

SQUEALKIT = [sys.executable, "-c", "from squealkit.cli.main import main; main()"]
ENV = {**os.environ, "SQUEALKIT_THREADS": "1",
       "PYTHONPATH": os.pathsep.join([str(Path(__file__).parents[1] / "src"), os.environ.get("PYTHONPATH", "")])}


def _one_line(r) -> str:
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr
    return lines[0]


def _tree(folder: Path) -> dict[str, str]:
    """Every entry below ``folder`` (hidden ones too) with what it is: nothing may appear or vanish."""
    out = {}
    for p in sorted(folder.rglob("*")):
        kind = "link" if p.is_symlink() else "dir" if p.is_dir() else "file" if p.is_file() else "special"
        out[p.relative_to(folder).as_posix()] = kind + (":" + p.read_text(errors="replace") if kind == "file"
                                                         and p.stat().st_size < 200 else "")
    return out


def _user_zarr(path: Path) -> None:
    xr.Dataset({"x": ("t", np.arange(10.0))}).to_zarr(path, consolidated=False)
    (path / "NOTES.txt").write_text("my notes")


def _mknod_or_skip(path: Path) -> None:
    try:
        os.mknod(path, 0o666 | 0o020000, os.makedev(1, 7))  # a character device, as /dev/full
    except (PermissionError, AttributeError):
        pytest.skip("creating a device node needs root")


@pytest.fixture(scope="module")
def small_campaign(tmp_path_factory):
    """Two SYNTHETIC applications of 0.2 s: a matrix to run campaigns on."""
    from squealkit.campaign import synthetic_campaign

    d = tmp_path_factory.mktemp("small") / "camp"
    synthetic_campaign(d, n_applications=2, duration=0.2, seed=1)
    return d


CAMPAIGN_OPTS = ["--mic", "mic", "--displacement", "displacement", "--radius", "0.05", "--rpm", "900"]


# ---------------------------------------------------------------------------------------------
# LOST: what the user had stays exactly as it was


def test_fedemo_onto_a_file_is_refused(run, tmp_path):
    # fedemo-out-file, dir-fedemo-file: the file used to become a folder, kept only as '.r.nc.old-NNNN'
    for name in ("r.nc", "b"):
        (tmp_path / name).write_text("the user's recording")
        before = _tree(tmp_path)
        r = run("fe-demo", "--size", "16", "--out-dir", str(tmp_path / name))
        assert r.exit_code == 2 and "is a file" in _one_line(r)
        assert _tree(tmp_path) == before


@pytest.mark.parametrize("make", ["device", "fifo", "socket"])
def test_outputs_onto_a_device_fifo_or_socket_are_refused(run, tmp_path, make):
    # devfull-node-summary, devfull-node-nc: a device node used to be replaced by a regular file
    import socket

    for name, args in (("full.nc", ["stability", "--mu", "0.3", "--theta", "0", "--out"]),
                       ("full.csv", ["analyze", "nothing.nc", "--mic", "mic", "--displacement", "d", "--rpm",
                                     "900", "--radius", "0.05", "--summary"]),
                       ("full.zarr", ["stability", "--mu", "0.3", "--theta", "0", "--out"])):
        target = tmp_path / name
        if make == "device":
            _mknod_or_skip(target)
        elif make == "fifo":
            os.mkfifo(target)
        else:
            s = socket.socket(socket.AF_UNIX)
            s.bind(str(target))
            s.close()
        before = _tree(tmp_path)
        r = run(*args, str(target))
        assert r.exit_code == 2, r.output
        assert "not a regular file" in _one_line(r) and name in r.stderr
        assert _tree(tmp_path) == before
        target.unlink()


def test_api_refuses_special_files_and_the_wrong_kind(tmp_path):
    # api-save-zarr-onto-file: save_dataset turned the user's file into a store (the file hidden as '.old')
    ds = xr.Dataset({"a": ("x", [1.0])})
    (tmp_path / "user.zarr").write_text("my data")
    (tmp_path / "d.nc").mkdir()
    (tmp_path / "d.nc" / "notes.txt").write_text("mine")
    os.mkfifo(tmp_path / "p.json")
    before = _tree(tmp_path)
    with pytest.raises(InputError, match="is a file"):
        save_dataset(ds, tmp_path / "user.zarr")
    with pytest.raises(InputError, match="is a folder"):  # up front: nothing was written first
        save_dataset(ds, tmp_path / "d.nc")
    with pytest.raises(InputError, match="not a regular file"):
        write_text(tmp_path / "p.json", "{}")
    assert _tree(tmp_path) == before


def test_a_users_zarr_store_is_not_squealkits(run, tmp_path):
    # exist-zarr-user-store: any zarr store used to count as squealkit's; NOTES.txt and x were deleted
    _user_zarr(tmp_path / "user.zarr")
    before = _tree(tmp_path)
    r = run("stability", "--mu", "0.3", "--theta", "0", "--out", str(tmp_path / "user.zarr"))
    assert r.exit_code == 2 and "did not write" in _one_line(r) and "NOTES.txt" in r.stderr
    assert _tree(tmp_path) == before
    with pytest.raises(InputError, match="did not write"):
        save_dataset(xr.Dataset({"a": ("x", [1.0])}), tmp_path / "user.zarr")
    assert _tree(tmp_path) == before


def test_a_zarr_marker_does_not_make_a_folder_squealkits(run, tmp_path):
    # exist-report-zarrmarker: thesis.txt beside a zarr.json was deleted by reproduce
    out = tmp_path / "results"
    out.mkdir()
    (out / "zarr.json").write_text("{}")
    (out / "thesis.txt").write_text("thesis draft")
    before = _tree(tmp_path)
    r = run("reproduce", "--quick", "--out-dir", str(out))
    assert r.exit_code == 2 and "did not write" in _one_line(r)
    assert _tree(tmp_path) == before


def test_squealkits_own_store_is_replaced_and_carries_a_manifest(run, tmp_path):
    # the other side of the rule: a store squealkit wrote says so, and re-running onto it works; its
    # manifest is a hidden zarr group, so that zarr does not warn about an unknown file when listing it
    import warnings

    out = tmp_path / "m.zarr"
    for n in ("3", "5"):
        r = run("stability", "--mu", f"0:0.8:{n}", "--theta", "0", "--out", str(out))
        assert r.exit_code == 0, r.output
        assert (out / io.ZARR_MANIFEST).is_file()
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            assert xr.open_zarr(out, consolidated=False).sizes["mu"] == int(n)
    assert sorted(os.listdir(tmp_path)) == ["m.zarr"]


def test_force_never_replaces_a_users_file_of_the_same_name(run, tmp_path):
    # exist-report-force-samename: --force ('leaving them alone') replaced the user's report.html
    out = tmp_path / "results"
    (out / "figures").mkdir(parents=True)
    (out / "report.html").write_text("<html>my own report</html>")
    (out / "figures" / "fig2.png").write_text("mine")
    before = _tree(tmp_path)
    r = run("reproduce", "--quick", "--force", "--out-dir", str(out))
    assert r.exit_code == 2 and "report.html" in _one_line(r) and "does not replace" in r.stderr
    assert _tree(tmp_path) == before


def test_force_refuses_at_the_end_a_users_file_it_would_replace(tmp_path):
    # a name the up-front check cannot know: refused when the outputs are moved in, nothing moved
    out = tmp_path / "results"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    (out / "table.csv").write_text("my table")
    before = _tree(tmp_path)
    with pytest.raises(InputError, match=r"table\.csv"):
        with output_folder(out, force=True) as stage:
            (stage / "new.txt").write_text("new")
            (stage / "table.csv").write_text("squealkit's")
    assert _tree(tmp_path) == before


def test_campaign_refuses_a_folder_of_the_users_files(run, tmp_path, small_campaign):
    # exist-campaign-userfiles: summary.json and report.html were replaced without a check
    out = tmp_path / "results"
    out.mkdir()
    (out / "summary.json").write_text('{"my": "summary"}')
    (out / "report.html").write_text("<html>mine</html>")
    (out / "notes.txt").write_text("notes")
    before = _tree(tmp_path)
    r = run("campaign", str(small_campaign / "matrix.csv"), "--out-dir", str(out), *CAMPAIGN_OPTS)
    assert r.exit_code == 2 and "did not write" in _one_line(r)
    assert _tree(tmp_path) == before


def test_campaign_never_takes_the_users_database_as_its_store(run, tmp_path, small_campaign):
    # exist-campaign-userfiles: the user's own campaign.duckdb got squealkit's tables and view
    import duckdb

    out = tmp_path / "results"
    out.mkdir()
    con = duckdb.connect(str(out / "campaign.duckdb"))
    con.execute("CREATE TABLE mine AS SELECT 42 AS answer")
    con.close()
    before = (out / "campaign.duckdb").read_bytes()
    r = run("campaign", str(small_campaign / "matrix.csv"), "--out-dir", str(out), *CAMPAIGN_OPTS)
    assert r.exit_code == 2 and "campaign.duckdb" in _one_line(r)
    assert (out / "campaign.duckdb").read_bytes() == before
    assert sorted(os.listdir(out)) == ["campaign.duckdb"]


def test_campaign_folder_is_squealkits_and_runs_again(run, tmp_path, small_campaign):
    # the campaign's folder carries a manifest: a second run resumes it; --no-report drops the old report
    out = tmp_path / "o"
    for extra in ([], ["--no-report"]):
        r = run("campaign", str(small_campaign / "matrix.csv"), "--out-dir", str(out), *CAMPAIGN_OPTS, *extra)
        assert r.exit_code == 0, r.output
    listed = json.loads((out / MANIFEST).read_text())["files"]
    assert "campaign.duckdb" in listed and "summary.json" in listed and "report.html" not in listed
    assert sorted(n for n in os.listdir(out) if not n.startswith(".")) == ["campaign.duckdb", "summary.json"]


def test_synth_campaign_refuses_a_folder_of_the_users_files(run, tmp_path):
    # exist-synthcamp-userfiles: the user's matrix.csv was replaced
    out = tmp_path / "results"
    out.mkdir()
    (out / "notes.txt").write_text("notes")
    (out / "matrix.csv").write_text("application,file\n")
    before = _tree(tmp_path)
    r = run("synth", "--out-dir", str(out), "--campaign", "2", "--duration", "0.2")
    assert r.exit_code == 2 and "did not write" in _one_line(r)
    assert _tree(tmp_path) == before


def test_synth_campaign_over_its_own_folder_with_results_inside(tmp_path, small_campaign):
    # a campaign's results inside its recordings' folder are squealkit's too (nested manifests)
    import shutil

    from squealkit.campaign import run_campaign, synthetic_campaign

    camp = tmp_path / "camp"
    shutil.copytree(small_campaign, camp)
    run_campaign(camp / "matrix.csv", camp / "out", mic="mic", displacement="displacement", radius=0.05, rpm=900,
                 report=False)
    io.check_output(camp, directory=True)  # no InputError: every file in it is squealkit's
    synthetic_campaign(camp, n_applications=1, duration=0.2, seed=2)
    assert sorted(p.name for p in (camp / "recordings").iterdir()) == ["A0001.nc"]
    assert sorted(os.listdir(tmp_path)) == ["camp"]


def test_symlinked_outputs_are_written_through_and_leave_nothing(run, tmp_path, monkeypatch):
    # link-zarr-to-dir, link-report-dir: the replaced link stayed as '.link.zarr.old-NNNN' / '.rep.old-NNNN'
    monkeypatch.chdir(tmp_path)
    keep = tmp_path / "keep"
    keep.mkdir()
    assert run("stability", "--mu", "0.2", "--theta", "0", "--out", "keep/real.zarr").exit_code == 0
    os.symlink("keep/real.zarr", "link.zarr")
    r = run("stability", "--mu", "0:0.3:2", "--theta", "0", "--out", "link.zarr")
    assert r.exit_code == 0, r.output
    assert os.readlink("link.zarr") == "keep/real.zarr"  # the link stays, what it points to is the new result
    assert xr.open_zarr(keep / "real.zarr", consolidated=False).sizes["mu"] == 2
    with output_folder(keep / "rep") as stage:
        (stage / "report.html").write_text("first")
    os.symlink("keep/rep", "rep")
    with output_folder("rep") as stage:
        (stage / "report.html").write_text("second")
    assert (keep / "rep" / "report.html").read_text() == "second" and os.path.islink("rep")
    os.symlink("keep/a.json", "a.json")
    write_text("a.json", "[]")
    assert (keep / "a.json").read_text() == "[]" and os.path.islink("a.json")
    assert sorted(os.listdir(tmp_path)) == ["a.json", "keep", "link.zarr", "rep"]
    assert sorted(os.listdir(keep)) == ["a.json", "real.zarr", "rep"]


# ---------------------------------------------------------------------------------------------
# Interrupted runs: whatever signal ends a run, none of its outputs appear, nothing is left


def _interrupt(tmp_path: Path, args: list[str], ready: str, signals: tuple[int, ...], *, gap: float = 0.05,
               timeout: float = 300.0, count: int = 1) -> tuple[int, str, Path]:
    """Run ``squealkit ARGS`` in ``tmp_path/run``; send ``signals`` (``gap`` s apart) as soon as ``count``
    paths matching the glob ``ready`` exist there. (exit code, stderr, the run's folder)."""
    cwd, log = tmp_path / "run", tmp_path / "stderr.txt"
    cwd.mkdir(exist_ok=True)
    with open(log, "w") as err:
        p = subprocess.Popen([*SQUEALKIT, *args], cwd=cwd, env=ENV, stdout=subprocess.DEVNULL, stderr=err)
        deadline = time.monotonic() + timeout  # a loaded machine starts slowly
        while len(list(cwd.glob(ready))) < count:
            if p.poll() is not None:
                pytest.fail(f"finished before the signal: {log.read_text()}")
            if time.monotonic() > deadline:
                p.kill()
                pytest.fail(f"{ready} never appeared")
            time.sleep(0.01)
        for i, s in enumerate(signals):
            if i:
                time.sleep(gap)
            p.send_signal(s)
        p.wait(timeout=120)
    text = log.read_text()
    assert "Traceback" not in text, text
    return p.returncode, text, cwd


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGQUIT])
def test_interrupted_synthetic_campaign_leaves_no_recordings(tmp_path, sig):
    # sig-synth-campaign-int-0, sig2-synth-campaign-term-*: camp2/recordings/A0001-A0006.nc stayed, no matrix.csv
    code, err, cwd = _interrupt(tmp_path, ["synth", "--out-dir", "camp", "--campaign", "40", "--duration", "0.5",
                                           "--json"],
                                ".camp.*/recordings/A0002.nc", (sig,))
    assert code == 128 + sig, err
    assert os.listdir(cwd) == []


@pytest.mark.slow
def test_interrupted_analysis_leaves_neither_figures_nor_result(tmp_path):
    # sig2-an-out-term-1: f_runout.png, f_spectrogram.png, f_time.png, f_zoom.png stayed without r.nc
    # (signalled once a second figure is under way: the first one was done)
    from squealkit.measurement import synthetic_recording

    (tmp_path / "run").mkdir()
    save_dataset(synthetic_recording(duration=3.0, seed=1), tmp_path / "run" / "rec.nc")
    code, err, cwd = _interrupt(tmp_path, ["analyze", "rec.nc", "--mic", "mic", "--displacement", "displacement",
                                           "--rpm", "900", "--radius", "0.05", "--out", "r.nc", "--plot", "f.png",
                                           "--json"], "*f_*", (signal.SIGTERM,), count=2)
    assert code == 143 and "terminated" in err, err
    assert os.listdir(cwd) == ["rec.nc"]


@pytest.mark.slow
def test_sighup_is_handled_like_sigterm(tmp_path):
    # sig2-hup-stab-zarr, sig2-quit-stab-zarr: SIGHUP and SIGQUIT killed the run at once, its '.part' stayed
    code, err, cwd = _interrupt(tmp_path, ["stability", "--mu", "0:0.8:2000", "--theta", "-8:8:400", "--out",
                                           "big.zarr", "--json"], ".big.zarr.*.part/zarr.json", (signal.SIGHUP,))
    assert code == 129 and "SIGHUP" in err, err
    assert os.listdir(cwd) == []


def test_a_second_signal_does_not_break_off_the_cleanup(tmp_path, monkeypatch):
    # sig-double-term-reproduce: two SIGTERMs 50 ms apart left '.rep.8jtiq1zq.part/' (data/*.nc): the
    # second one arrived while the first one's cleanup removed the stage. Here it arrives exactly then.
    import shutil

    from squealkit.cli.main import _on_signal

    remove = shutil.rmtree

    def second_signal_then_remove(path, *a, **k):
        _on_signal(signal.SIGTERM, None)
        return remove(path, *a, **k)

    monkeypatch.setattr(shutil, "rmtree", second_signal_then_remove)
    try:
        with pytest.raises(KeyboardInterrupt), output_folder(tmp_path / "rep") as stage:
            (stage / "data").mkdir()
            (stage / "data" / "a.nc").write_text("x")
            _on_signal(signal.SIGTERM, None)  # the first
    finally:
        io.clear_interrupt()
    assert os.listdir(tmp_path) == []


@pytest.mark.slow
def test_campaign_interrupted_in_its_report_writes_no_summary(tmp_path, small_campaign):
    # sig2-campaign-int-1: summary.json and 2 of 5 figures were written, no report.html
    code, err, cwd = _interrupt(tmp_path, ["campaign", str(small_campaign / "matrix.csv"), "--out-dir", "o",
                                           *CAMPAIGN_OPTS, "--json"], "o/.squealkit-stage.*/figures/*.png",
                                (signal.SIGINT,))
    assert code == 130, err
    # the database stays (a re-run resumes it) and is squealkit's; nothing of the unfinished report
    assert sorted(n for n in os.listdir(cwd / "o") if not n.endswith(".wal")) == [MANIFEST, "campaign.duckdb"]


# ---------------------------------------------------------------------------------------------
# A full disk: one line, exit 2, nothing left (it used to end in SIGSEGV, exit 139)


@pytest.fixture(scope="module")
def tiny_disk(tmp_path_factory):
    """A 5 MB tmpfs (as in the adversarial round); skipped where mounting needs rights we lack."""
    d = tmp_path_factory.mktemp("tiny")
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=5m", "tmpfs", str(d)], capture_output=True)
    if r.returncode != 0:
        pytest.skip("mounting a small tmpfs needs root")
    yield d
    subprocess.run(["umount", "-l", str(d)], check=False)


@pytest.mark.parametrize("args", [
    ["stability", "--mu", "0:0.8:401", "--theta", "-8:8:401", "--out", "{d}/m.nc"],  # full-stab-nc
    ["simulate", "--duration", "3", "--out", "{d}/s.nc", "--json"],  # full-sim-nc: streamed, block by block
    ["simulate", "--duration", "3", "--out", "{d}/s.zarr", "--json"],  # full-sim-zarr: '.part/zarr.json' stayed
    ["synth", "--out", "{d}/r.uff", "--duration", "5"],  # full-synth-uff: pyuff's raw traceback
    ["synth", "--out-dir", "{d}/camp", "--campaign", "30", "--duration", "1", "--json"],  # full-synth-campaign
], ids=["stability-nc", "simulate-nc", "simulate-zarr", "synth-uff", "synth-campaign"])
@pytest.mark.slow
def test_a_full_disk_is_one_line_and_leaves_nothing(tiny_disk, args, tmp_path):
    # also the adversarial table's rows full-stab-nc, full-sim-nc, full-sim-zarr, full-synth-uff,
    # full-synth-campaign (tests/test_adversarial.py runs them here, not twice): TMPDIR a folder of its own
    for p in tiny_disk.iterdir():
        subprocess.run(["rm", "-rf", str(p)], check=True)
    r = subprocess.run([*SQUEALKIT, *(a.format(d=tiny_disk) for a in args)], env={**ENV, "TMPDIR": str(tmp_path)},
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 2, (r.returncode, r.stderr[-2000:])
    line = _one_line(r)
    assert "no space left" in line and ".part" not in line  # the output asked for, not its staged name
    assert os.listdir(tiny_disk) == [] and os.listdir(tmp_path) == []


# ---------------------------------------------------------------------------------------------
# Two runs writing one output: the second is refused in one line (or both succeed), never a traceback


@pytest.mark.parametrize("args", [
    ["stability", "--mu", "0:0.8:3", "--theta", "0", "--out", "same.zarr"],  # race-stab-zarr
    ["campaign", "{camp}/matrix.csv", "--out-dir", "same.zarr", *CAMPAIGN_OPTS, "--no-report"],  # race-campaign
], ids=["stability", "campaign"])
@pytest.mark.slow
def test_an_output_being_written_is_refused_to_a_second_run(tmp_path, small_campaign, args):
    # the first run holds same.zarr (staged, as a run holds it from its check to its end); also the adversarial
    # table's race-stab-zarr and race-campaign (run here, not twice): TMPDIR a folder of its own
    w, tmpdir = tmp_path / "w", tmp_path / "tmpdir"
    w.mkdir()
    tmpdir.mkdir()
    with contextlib.ExitStack() as stack:
        stack.enter_context(atomic_path(w / "same.zarr", directory=True)).mkdir()
        r = subprocess.run([*SQUEALKIT, *(a.format(camp=small_campaign) for a in args)], cwd=w,
                           env={**ENV, "TMPDIR": str(tmpdir)}, capture_output=True, text=True, timeout=300)
        assert r.returncode == 2, r.stderr
        assert "another squealkit run" in _one_line(r)
    assert sorted(os.listdir(w)) == ["same.zarr"]  # the first one's output, no lock file left
    assert os.listdir(tmpdir) == []


@pytest.mark.slow
def test_two_runs_at_once_onto_one_store(tmp_path):
    # race-stab-zarr: one run read back the store after the other had replaced it (a reshape error)
    runs = [subprocess.Popen([*SQUEALKIT, "stability", "--mu", "0:0.8:201", "--theta", f"-8:8:{n}", "--out",
                              "same.zarr", "--json"], cwd=tmp_path, env=ENV, stdout=subprocess.DEVNULL,
                             stderr=subprocess.PIPE, text=True) for n in (201, 101)]
    results = [(p.wait(timeout=600), p.stderr.read()) for p in runs]
    for code, err in results:
        assert code in (0, 2) and "Traceback" not in err, err
        assert code == 0 or "another squealkit run" in err
    assert any(code == 0 for code, _ in results)
    ds = xr.open_zarr(tmp_path / "same.zarr", consolidated=False)
    assert ds.sizes["mu"] == 201 and ds.sizes["theta"] in (201, 101)
    assert sorted(os.listdir(tmp_path)) == ["same.zarr"]


# ---------------------------------------------------------------------------------------------
# What libraries leave in the temporary folder


@pytest.mark.slow
def test_a_local_dask_cluster_leaves_no_scratch_space(tmp_path, monkeypatch):
    # dask-local-mc, dask-local-stab: $TMPDIR/dask-scratch-space/{global.lock,purge.lock} stayed
    import tempfile

    from squealkit.scale import cluster_client

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    with cluster_client("local", n_workers=1) as client:
        assert client.submit(abs, -3).result() == 3
        assert any(tmp_path.rglob("dask-scratch-space"))  # it was used, in the temporary folder given
    assert os.listdir(tmp_path) == []


def test_a_bad_mf4_file_leaves_no_temporary_copy(tmp_path, monkeypatch):
    # rd-mf4-id-garbage-mf4: asammdf copies a file flagged unfinalised to $TMPDIR and left the copy there
    # when the file then failed to read. An MDF4 identification block (ASAM MDF 4.1, 64 bytes) whose
    # unfinalised flags (bytes 60-61) are set, followed by garbage where the header block belongs.
    import tempfile

    from squealkit.measurement import open_recording

    scratch = tmp_path / "tmp"
    scratch.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(scratch))
    ident = b"MDF     4.10    squealki" + bytes(4) + (410).to_bytes(2, "little") + bytes(30) + b"\x01\x00\x00\x00"
    assert len(ident) == 64
    bad = tmp_path / "id_garbage.mf4"
    bad.write_bytes(ident + b"\xff" * 4096)
    with pytest.raises(InputError, match=r"id_garbage\.mf4"):
        open_recording(bad)
    assert os.listdir(scratch) == []

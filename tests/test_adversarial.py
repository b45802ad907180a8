"""Every case of the adversarial round of 2026-12-02, as one table (issue #31).

``tests/adversarial-2026-12-02.md`` (a copy of the round's ``shared/reference`` file) lists the
cases that were not a clean error or a right result. Each is a row of :data:`CASES`, its id
being the case's id in the file, rebuilt small in ``tmp_path``. The reference for every row is
squealkit's documented contract:

* a refusal: exit code 2 and exactly one stderr line ``squealkit: error: ...`` from the CLI (a
  ``squealkit: warning:`` line about an implausible value may precede it), no traceback; an
  :class:`~squealkit._validation.InputError` (``InputTypeError`` for a wrong type, a ``TypeError``
  too) with a one-line message from the API;
* or the right result (exit 0 and what the case checks);
* and in both: every file or folder that existed before is byte for byte as it was (a refusal
  leaves the whole folder as it was), nothing is left behind (no ``.part``, ``.old-``, stage or
  ``dask-scratch-space``; ``TMPDIR`` is a folder of its own and ends empty), and the run is bounded.

Cases covered by a dedicated test elsewhere (signals, timing) delegate to that test's helper.
Sizes are smaller than in the round where the round's size only made the case slow (noted per row).
"""

from __future__ import annotations

import hashlib
import os
import re
import shutil
import signal
import subprocess
import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import xarray as xr

import test_bad_inputs as tbi
import test_output_safety as tos
from squealkit import InputError

CASE_FILE = Path(__file__).with_name("adversarial-2026-12-02.md")
EXAMPLES = Path(__file__).parents[1] / "examples"
SQUEALKIT = tos.SQUEALKIT
LEFTOVER = re.compile(r"\.part$|\.part/|\.old-|dask-scratch-space|\.squealkit-stage|\.tmp$")
TIMEOUT = 120  # seconds: every case is refused or done well within this on a loaded 2-core machine


# ---------------------------------------------------------------------------------------------
# What a case is


@dataclass
class Ctx:
    """A case's working folder ``w`` (the current directory), its TMPDIR, and the shared inputs."""

    tmp: Path
    w: Path
    tmpdir: Path
    shared: Any
    monkeypatch: Any
    notes: dict = field(default_factory=dict)

    def env(self) -> dict[str, str]:
        return {**tos.ENV, "TMPDIR": str(self.tmpdir)}


@dataclass
class Case:
    """``what``: CLI arguments (list, ``{rec}``-style placeholders from :meth:`Shared.fmt`) or a
    callable ``f(ctx)`` (an API expression; or, with ``expect="own"``, a helper that asserts by itself).

    expect: ``"refused"`` (exit 2, one line / InputError), ``"ok"`` (exit 0 / returns), ``"own"``.
    """

    what: Any
    expect: str = "refused"
    setup: Callable[[Ctx], None] | None = None
    words: tuple[str, ...] = ()
    check: Callable[[Ctx, Any], None] | None = None
    sub: bool = False  # in a subprocess (device nodes, mounts, closed stdout, setpriv)
    prefix: tuple[str, ...] = ()
    root: bool = False
    mount: str | None = None  # a tmpfs of this size at w/tiny
    changes: tuple[str, ...] = ()  # paths (relative to w) a right result may change
    # the dedicated test (file::name[id]) that runs this very case with the same checks: the row runs it
    # here only when that test is not part of this run (each costs a process and seconds of CPU)
    elsewhere: str | None = None


# ---------------------------------------------------------------------------------------------
# Shared small inputs (built once, outside every case's folder)


class Shared:
    def __init__(self, root: Path):
        self.root = root
        self._cache: dict[str, Any] = {}

    def _get(self, name, make):
        if name not in self._cache:
            self._cache[name] = make()
        return self._cache[name]

    @property
    def rec(self) -> str:
        def make():
            from squealkit.measurement import synthetic_recording

            p = self.root / "rec.nc"
            synthetic_recording(duration=0.5, seed=1).to_netcdf(p)
            return str(p)
        return self._get("rec", make)

    @property
    def long(self) -> str:
        def make():
            from squealkit.io import save_dataset
            from squealkit.measurement import synthetic_recording

            p = self.root / "long.nc"
            save_dataset(synthetic_recording(duration=3.0, seed=1), p)
            return str(p)
        return self._get("long", make)

    @property
    def camp(self) -> Path:
        def make():
            from squealkit.campaign import synthetic_campaign

            d = self.root / "camp"
            synthetic_campaign(d, n_applications=2, duration=0.2, seed=1)
            return d
        return self._get("camp", make)

    @property
    def good_store(self) -> Path:
        def make():
            from squealkit.campaign.store import CampaignStore

            p = self.root / "good.duckdb"
            with CampaignStore(p) as s:
                s.put_many([({"application": f"A{i}", "file": "x" * 50, "peak_dba": float(i)},
                             [{"application": f"A{i}", "event": j, "frequency_hz": 1.0 * j} for j in range(20)])
                            for i in range(3000)])
            return p
        return self._get("good_store", make)

    @property
    def nlevp_toml(self) -> str:
        def make():
            from squealkit.data import nlevp_path

            p = self.root / "nlevp.toml"
            p.write_text(f'model = "fe"\n[fe]\nfile = "{nlevp_path()}"\n')
            return str(p)
        return self._get("nlevp_toml", make)

    def fmt(self, a: str) -> str:
        for key in ("rec", "long", "nlevp_toml"):
            if "{" + key + "}" in a:
                a = a.replace("{" + key + "}", getattr(self, key))
        if "{camp}" in a:
            a = a.replace("{camp}", str(self.camp))
        return a.replace("{rig}", str(EXAMPLES / "uncertain_rig.toml"))


@pytest.fixture(scope="module")
def shared(tmp_path_factory):
    return Shared(tmp_path_factory.mktemp("shared"))


# ---------------------------------------------------------------------------------------------
# Setup helpers (each a "[setup: ...]" of the file)


def write(name: str, data: str | bytes) -> Callable[[Ctx], None]:
    def f(ctx):
        p = ctx.w / name
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_bytes(data if isinstance(data, bytes) else data.encode())
    return f


def steps(*fs) -> Callable[[Ctx], None]:
    def f(ctx):
        for g in fs:
            g(ctx)
    return f


def mknod(name: str) -> Callable[[Ctx], None]:
    def f(ctx):
        tos._mknod_or_skip(ctx.w / name)
    return f


def fe_toml_of(case: str) -> Callable[[Ctx], None]:
    """``fe.toml`` naming the malformed FE file(s) test_bad_inputs builds for ``case``."""
    def f(ctx):
        kwargs, _ = tbi._fe_case(case, ctx.w)
        if "file" in kwargs:
            fe = f'file = "{Path(kwargs["file"]).name}"'
        else:
            fe = "files = {" + ", ".join(f'{k} = "{Path(v).name}"' for k, v in kwargs["files"].items()) + "}"
        (ctx.w / "fe.toml").write_text(f'model = "fe"\n[fe]\n{fe}\n')
    return f


def store_in_o(kind: str) -> Callable[[Ctx], None]:
    def f(ctx):
        (ctx.w / "o").mkdir()
        tbi._make_store(kind, ctx.w / "o" / "campaign.duckdb", ctx.shared.good_store)
    return f


def matrix(text: str) -> Callable[[Ctx], None]:
    def f(ctx):
        (ctx.w / "m.csv").write_text(text.replace("$REC", ctx.shared.rec))
    return f


def junk_server(ctx: Ctx) -> None:
    """A loopback server answering every connection with an SSH banner (the round's SERVE_JUNK)."""
    import socket
    import threading

    pytest.importorskip("distributed")
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
    ctx.notes["scheduler"] = f"tcp://127.0.0.1:{srv.getsockname()[1]}"
    ctx.notes["cleanup"] = srv.close


TOS = "test_output_safety.py::"
FULL_DISK = TOS + "test_a_full_disk_is_one_line_and_leaves_nothing"
RACE = TOS + "test_an_output_being_written_is_refused_to_a_second_run"
CAMP = ["--mic", "mic", "--displacement", "displacement", "--radius", "0.05", "--rpm", "900"]
ANALYZE = ["analyze", "{rec}", "--mic", "mic", "--displacement", "displacement", "--rpm", "900", "--radius", "0.05"]
CRIT_FE = ["critical", "--config", "fe.toml", "--rpm", "100"]


# ---------------------------------------------------------------------------------------------
# Delegations to the dedicated tests (signals, races, timing)


def _interrupt_synth(sig: int, ready_count: int):
    def f(ctx):
        args = ["synth", "--out-dir", "camp2", "--campaign", "40", "--duration", "0.5", "--json"]
        code, err, cwd = tos._interrupt(ctx.tmp, args,
                                        ".camp2.*/recordings/A000*.nc", (sig,), count=ready_count)
        assert code == 128 + sig, err
        assert os.listdir(cwd) == []
    return f


def _interrupt_quit_zarr(ctx):
    code, err, cwd = tos._interrupt(ctx.tmp, ["stability", "--mu", "0:0.8:2000", "--theta", "-8:8:400", "--out",
                                              "big.zarr", "--json"], ".big.zarr.*.part/zarr.json", (signal.SIGQUIT,))
    assert code == 128 + signal.SIGQUIT, err
    assert os.listdir(cwd) == []


def _link_report_dir(ctx):
    # reproduce --quick takes 90 s on this machine: its output folder is squealkit.io.output_folder,
    # driven here directly through a symlink as reproduce drives it
    from squealkit.io import output_folder

    (ctx.w / "keep").mkdir()
    with output_folder(ctx.w / "keep" / "rep") as stage:
        (stage / "report.html").write_text("first")
    os.symlink("keep/rep", ctx.w / "rep")
    with output_folder(ctx.w / "rep") as stage:
        (stage / "report.html").write_text("second")
    assert os.path.islink(ctx.w / "rep") and (ctx.w / "keep" / "rep" / "report.html").read_text() == "second"
    assert sorted(os.listdir(ctx.w)) == ["keep", "rep"]


def _race(args):
    def f(ctx):
        from squealkit.io import atomic_path

        with atomic_path(ctx.w / "same.zarr", directory=True) as held:
            held.mkdir()
            r = subprocess.run([*SQUEALKIT, *(ctx.shared.fmt(a) for a in args)], cwd=ctx.w, env=ctx.env(),
                               capture_output=True, text=True, timeout=TIMEOUT)
            assert r.returncode == 2, r.stderr
            assert "another squealkit run" in tos._one_line(r)
        assert sorted(os.listdir(ctx.w)) == ["same.zarr"]
    return f


def _stdout_closed(ctx):
    r = subprocess.run(["sh", "-c", '"$@" >&-', "sh", *SQUEALKIT, "critical", "--json"], cwd=ctx.w, env=ctx.env(),
                       capture_output=True, text=True, timeout=TIMEOUT)
    assert r.returncode == 2, r.stderr
    assert r.stderr.strip().splitlines() == ["squealkit: error: cannot write to standard output (it is closed)"]


def _perm_setup(ctx):
    if os.geteuid() == 0 and not shutil.which("setpriv"):
        pytest.skip("needs setpriv to drop root's dac_override")
    from squealkit.campaign import run_campaign

    run_campaign(ctx.shared.camp / "matrix.csv", ctx.w / "o", mic="mic", displacement="displacement", radius=0.05,
                 rpm=900, report=False)
    (ctx.w / "o" / "campaign.duckdb").chmod(0o444)  # a read-only store in a folder one may write


def _csv_huge(ctx):
    from squealkit.measurement import synthetic_recording

    rec = synthetic_recording(duration=0.2, seed=1)
    df = rec[["mic", "displacement"]].to_dataframe().reset_index()
    df["mic"] = df["mic"] * 1e297  # ~1e299 Pa
    df.to_csv(ctx.w / "csv_huge_vals.csv", index=False)


def _mf4_garbage(ctx):
    ident = b"MDF     4.10    squealki" + bytes(4) + (410).to_bytes(2, "little") + bytes(30) + b"\x01\x00\x00\x00"
    (ctx.w / "mf4_id_garbage.mf4").write_bytes(ident + b"\xff" * 4096)


def _fe_demo_vtk(ctx):
    tbi.test_fe_demo_mesh_reaches_modes_vtk(_run(), ctx.w)


def _run():
    from click.testing import CliRunner

    from squealkit.cli.main import cli

    runner = CliRunner()
    return lambda *args: runner.invoke(cli, list(args))


def api(expr: Callable[[Ctx], Any]) -> Callable[[Ctx], Any]:
    return expr


def _model():
    from squealkit.models import get_preset

    return get_preset("lv2013")


def _not_empty_json(ctx, out):
    assert out.strip(), "no output"


def _presets_check(ctx, out):
    assert "kinematics = paper" in out


def _lc_check(harmonics, *, at_least=False):
    """The branch was computed with (at least) ``harmonics`` harmonics, every amplitude finite
    (beyond 32 harmonics the Floquet step estimate broadcast (H, 3) into (32, 3))."""
    def f(ctx, out):
        import json

        data = json.loads(out)
        assert data["harmonics"] >= harmonics if at_least else data["harmonics"] == harmonics, data["harmonics"]
        assert len(data["mu"]) >= 2 and all(np.isfinite(v).all() for v in data["amplitude"].values())
    return f


# ---------------------------------------------------------------------------------------------
# The table: one row per case of the file, in the file's order

CASES: dict[str, Case] = {
    # -- LOST ----------------------------------------------------------------------------------
    "fedemo-out-file": Case(["fe-demo", "--size", "16", "--out-dir", "r.nc"], setup=write("r.nc", b"\x89HDF recording"),
                            words=("is a file",)),
    "devfull-node-summary": Case([*ANALYZE, "--summary", "full.csv"], setup=mknod("full.csv"),
                                 words=("not a regular file",), root=True),
    "devfull-node-nc": Case(["stability", "--mu", "0.3", "--theta", "0", "--out", "full.nc"], setup=mknod("full.nc"),
                            words=("not a regular file",), root=True),
    "dir-fedemo-file": Case(["fe-demo", "--size", "16", "--out-dir", "b"], setup=write("b", "data\n"),
                            words=("is a file",)),
    "exist-zarr-user-store": Case(["stability", "--mu", "0.3", "--theta", "0", "--out", "user.zarr"],
                                  setup=lambda c: tos._user_zarr(c.w / "user.zarr"), words=("did not write",)),
    "exist-report-zarrmarker": Case(["reproduce", "--quick", "--out-dir", "results"],
                                    setup=steps(write("results/zarr.json", "{}"),
                                                write("results/thesis.txt", "thesis draft")),
                                    words=("did not write",)),
    "exist-report-force-samename": Case(["reproduce", "--quick", "--force", "--out-dir", "results"],
                                        setup=steps(write("results/report.html", "<html>my own report</html>"),
                                                    write("results/figures/fig2.png", "mine")),
                                        words=("report.html",)),
    "exist-campaign-userfiles": Case(["campaign", "{camp}/matrix.csv", "--out-dir", "results", *CAMP],
                                     setup=steps(write("results/summary.json", '{"my": "summary"}'),
                                                 write("results/report.html", "<html>mine</html>"),
                                                 write("results/notes.txt", "notes")),
                                     words=("did not write",)),
    "exist-synthcamp-userfiles": Case(["synth", "--out-dir", "results", "--campaign", "2", "--duration", "0.2"],
                                      setup=steps(write("results/notes.txt", "notes"),
                                                  write("results/matrix.csv", "application,file\n")),
                                      words=("did not write",)),
    "api-save-zarr-onto-file": Case(
        api(lambda c: __import__("squealkit.io", fromlist=["x"]).save_dataset(
            xr.Dataset({"a": ("x", [1.0])}), c.w / "user.zarr")),
        setup=write("user.zarr", "my data"), words=("user.zarr", "is a file")),
    # -- HANG/MEM ------------------------------------------------------------------------------
    "stab-grid-1e9-zarr": Case(["stability", "--mu", "0:0.8:31623", "--theta", "-8:8:31623", "--out", "big.zarr"],
                               words=("31623 x 31623",)),
    "sim-dur-1e300-out": Case(["simulate", "--duration", "1e300", "--out", "x.nc"], words=("1e+300 s",)),
    "sim-rk4-long": Case(["simulate", "--method", "rk4", "--duration", "1e6", "--fs", "1"], words=("1e+06 s",)),
    "synth-campaign-huge": Case(["synth", "--out-dir", "camp", "--campaign", "1000000000"],
                                words=("1000000000 applications",)),
    "fedemo-nz-huge": Case(["fe-demo", "--size", "16", "--n-z", "100000", "--out-dir", "b"], words=("elements",)),
    "fe-huge-decl-both": Case(CRIT_FE, setup=fe_toml_of("huge-decl"), words=("100000000",)),
    "fe-stab-rpm-huge-n": Case(["stability", "--config", "{nlevp_toml}", "--rpm", "60:240:100000000"],
                               words=("100000000",)),
    "fe-stab-mu-range-huge": Case(["stability", "--config", "{nlevp_toml}", "--rpm", "60", "--mu", "0:1:100000000"],
                                  words=("100000000",)),
    # -- LEFTOVER ------------------------------------------------------------------------------
    "rd-mf4-id-garbage-mf4": Case(["analyze", "mf4_id_garbage.mf4", "--mic", "mic", "--displacement", "displacement",
                                   "--rpm", "900", "--radius", "0.05"], setup=_mf4_garbage,
                                  words=("mf4_id_garbage.mf4",)),
    "full-sim-nc": Case(["simulate", "--duration", "3", "--out", "tiny/s.nc"], sub=True, mount="5m",
                        words=("no space left",),
                        elsewhere=FULL_DISK + "[simulate-nc]"),
    "full-sim-zarr": Case(["simulate", "--duration", "3", "--out", "tiny/s.zarr"], sub=True, mount="5m",
                          words=("no space left",),
                          elsewhere=FULL_DISK + "[simulate-zarr]"),
    "full-synth-campaign": Case(["synth", "--out-dir", "tiny/camp", "--campaign", "30", "--duration", "1"], sub=True,
                                mount="5m", words=("no space left",),
                                elsewhere=FULL_DISK + "[synth-campaign]"),
    "link-zarr-to-dir": Case(["stability", "--mu", "0.3", "--theta", "0", "--out", "link.zarr"], expect="ok",
                             setup=lambda c: ((c.w / "keep").mkdir(), _run()("stability", "--mu", "0.2", "--theta", "0",
                                                     "--out", "keep/real.zarr"),
                                            os.symlink("keep/real.zarr", "link.zarr")),
                             changes=("keep/real.zarr",),
                             check=lambda c, out: (os.path.islink("link.zarr") and  # the new result, 0.3
                                                   xr.open_zarr("keep/real.zarr", consolidated=False)["mu"].values
                                                   .tolist() == [0.3])),
    "link-report-dir": Case(_link_report_dir, expect="own"),
    "sig-synth-campaign-int-0": Case(_interrupt_synth(signal.SIGINT, 3), expect="own"),
    "sig-double-term-reproduce": Case(lambda c: tos.test_a_second_signal_does_not_break_off_the_cleanup(
        c.w, c.monkeypatch), expect="own"),
    "dask-local-mc": Case(["montecarlo", "--config", "{rig}", "--samples", "16", "--mu", "0:1:3", "--json",
                           "--scheduler", "local"], expect="ok", sub=True, check=_not_empty_json),
    "dask-local-stab": Case(["stability", "--mu", "0:0.8:5", "--theta", "-8:8:5", "--out", "a.zarr",
                             "--scheduler", "local"], expect="ok", sub=True),
    "sig2-campaign-int-1": Case(lambda c: tos.test_campaign_interrupted_in_its_report_writes_no_summary(
        c.tmp, c.shared.camp), expect="own",
                                elsewhere=TOS + "test_campaign_interrupted_in_its_report_writes_no_summary"),
    "sig2-synth-campaign-term-0": Case(_interrupt_synth(signal.SIGTERM, 4), expect="own"),
    "sig2-synth-campaign-term-1": Case(_interrupt_synth(signal.SIGTERM, 1), expect="own"),
    "sig2-synth-campaign-int-0": Case(_interrupt_synth(signal.SIGINT, 1), expect="own"),
    "sig2-synth-campaign-int-1": Case(_interrupt_synth(signal.SIGINT, 2), expect="own"),
    "sig2-an-out-term-1": Case(lambda c: tos.test_interrupted_analysis_leaves_neither_figures_nor_result(c.tmp),
                               expect="own",
                               elsewhere=TOS + "test_interrupted_analysis_leaves_neither_figures_nor_result"),
    "sig2-hup-stab-zarr": Case(lambda c: tos.test_sighup_is_handled_like_sigterm(c.tmp), expect="own",
                               elsewhere=TOS + "test_sighup_is_handled_like_sigterm"),
    "sig2-quit-stab-zarr": Case(_interrupt_quit_zarr, expect="own"),
    # -- WRONG ---------------------------------------------------------------------------------
    "tol-mumax-nonfe": Case(["tolerance", "--mu", "0.3", "--mu-max", "0.5"], words=("--mu-max",)),
    "sim-speed-1e300": Case(["simulate", "--speed", "1e300", "--duration", "0.001", "--json"], words=("speed=1e+300",)),
    "synth-level-nan": Case(["synth", "--out", "r.nc", "--level-dba", "nan"], words=("level_dba=nan",)),
    "an-delay-huge": Case([*ANALYZE, "--acoustic-delay", "1e300"], words=("acoustic_delay=1e+300",)),
    "camp-radius-0": Case(["campaign", "{camp}/matrix.csv", *CAMP, "--out-dir", "o", "--radius", "0"],
                          words=("radius=0",)),
    "camp-ppr-0": Case(["campaign", "{camp}/matrix.csv", "--mic", "mic", "--displacement", "displacement", "--radius",
                        "0.05", "--out-dir", "o", "--tacho", "tacho", "--pulses-per-rev", "0"],
                       words=("pulses_per_rev=0",)),
    "report-radius-no-rec": Case(["report", "--quick", "--radius", "0.05", "--out-dir", "r"], words=("--radius",)),
    "rd-csv-huge-vals": Case(["analyze", "csv_huge_vals.csv", "--mic", "mic", "--displacement", "displacement",
                              "--rpm", "900", "--radius", "0.05", "--json"], setup=_csv_huge, words=("mic",)),
    "cm-no-file": Case(["campaign", "m.csv", "--out-dir", "o", *CAMP, "--no-report"],
                       setup=matrix("application,file\nA1,\n"), words=("m.csv", "no file")),
    "cm-inf-temp": Case(["campaign", "m.csv", "--out-dir", "o", *CAMP, "--no-report"],
                        setup=matrix("application,file,temperature_c\nA1,$REC,inf\n"),
                        words=("m.csv", "temperature_c")),
    "cm-neg-rpm": Case(["campaign", "m.csv", "--out-dir", "o", "--mic", "mic", "--displacement", "displacement",
                        "--radius", "0.05", "--no-report", "--json"],
                       setup=matrix("application,file,rpm\nA1,$REC,-900\n"), words=("m.csv", "rpm")),
    "fe-tiny-M": Case(CRIT_FE, setup=fe_toml_of("tiny-M"), words=("Matrix M",)),
    "fe-mat-cplx-sparse": Case(CRIT_FE, setup=fe_toml_of("mat-cplx-sparse"), words=("complex",)),
    "fe-mat-cplx-M-sparse": Case(CRIT_FE, setup=fe_toml_of("mat-cplx-M-sparse"), words=("complex",)),
    "fe-v73-badir": Case(CRIT_FE, setup=fe_toml_of("v73-badir"), words=("row ind",)),
    "fe-op4-nan": Case(CRIT_FE, setup=fe_toml_of("op4-nan"), words=("non-finite",)),
    "exist-campaign-user-duckdb": Case(["campaign", "{camp}/matrix.csv", "--out-dir", "results", *CAMP, "--no-report"],
                                       setup=lambda c: (c.w / "results").mkdir() or tbi._make_store(
                                           "user-table", c.w / "results" / "campaign.duckdb", None),
                                       words=("campaign.duckdb",)),
    "api-fe-complex-dense": Case(api(lambda c: __import__("squealkit.fe", fromlist=["x"]).FEModel.from_matrices(
        M=np.eye(2), K1=np.eye(2) * (1 + 1j))), words=("complex",)),
    "api-fe-complex-sparse": Case(api(lambda c: __import__("squealkit.fe", fromlist=["x"]).FEModel.from_matrices(
        M=__import__("scipy.sparse", fromlist=["x"]).eye(2, format="csr") * (1 + 0.5j), K1=np.eye(2))),
        words=("complex",)),
    "api-run-campaign-radius-neg": Case(api(lambda c: __import__("squealkit.campaign", fromlist=["x"]).run_campaign(
        c.shared.camp / "matrix.csv", c.w / "o", mic="mic", displacement="displacement", radius=-1, rpm=900,
        report=False)), words=("radius=-1",)),
    "fe-demo-vtk": Case(_fe_demo_vtk, expect="own"),
    # -- TRACEBACK -----------------------------------------------------------------------------
    "presets-plain": Case(["presets"], expect="ok", check=_presets_check),
    "stdout-closed": Case(_stdout_closed, expect="own"),
    "stab-mu-1e300": Case(["stability", "--mu", "1e300", "--theta", "0", "--json"], words=("1e+300",)),
    "crit-mumax-1e300": Case(["critical", "--mu-max", "1e300", "--json"], words=("mu_max=1e+300",)),
    "modes-mu-1e300": Case(["modes", "--mu", "1e300", "--json"], words=("1e+300",)),
    "floq-map-huge": Case(["floquet", "--mu", "0:1:100000", "--sro-amplitude", "0:1e-4:100000"],
                          words=("100000 x 100000",)),
    "floq-speed-1e-300": Case(["floquet", "--speed", "1e-300"], words=("steps per period",)),
    "floq-wl-1e300": Case(["floquet", "--sro-wavelength", "1e300"], words=("steps per period",)),
    "floq-amp-huge": Case(["floquet", "--sro-amplitude", "1", "--json"], words=("amplitude=1.0 m",)),
    "synth-huge-dur": Case(["synth", "--out", "r.nc", "--duration", "1e300"], words=("1e+300 s",)),
    "synth-huge-fs": Case(["synth", "--out", "r.nc", "--fs", "1e300"], words=("1e+300 Hz",)),
    "synth-level-huge": Case(["synth", "--out", "r.nc", "--level-dba", "1e300"], words=("level_dba=1e+300",)),
    "an-rpm-tiny": Case(["analyze", "{rec}", "--mic", "mic", "--displacement", "displacement", "--rpm", "1e-6",
                         "--radius", "0.05", "--json"], words=("rpm=1e-06",)),
    "fedemo-size-huge": Case(["fe-demo", "--size", "100000", "--out-dir", "b"], words=("elements",)),
    "cm-binary": Case(["campaign", "m.csv", "--out-dir", "o", *CAMP, "--no-report"],
                      setup=lambda c: (c.w / "m.csv").write_bytes(Path(c.shared.rec).read_bytes()[:5000]),
                      words=("m.csv",)),
    "cm-latin1": Case(["campaign", "m.csv", "--out-dir", "o", *CAMP, "--no-report"],
                      setup=lambda c: (c.w / "m.csv").write_bytes(
                          b"application,file,section\nA1," + c.shared.rec.encode() + b",\xe9t\xe9\n"),
                      words=("m.csv", "UTF-8")),
    "fe-mat-zeros": Case(CRIT_FE, setup=fe_toml_of("mat-zeros"), words=("z.mat",)),
    "fe-v73-nojc": Case(CRIT_FE, setup=fe_toml_of("v73-nojc"), words=("jc",)),
    "fe-v73-bigrows": Case(CRIT_FE, setup=fe_toml_of("v73-bigrows"), words=("1000000000000",)),
    "fe-v73-strattr": Case(CRIT_FE, setup=fe_toml_of("v73-strattr"), words=("MATLAB_sparse",)),
    "fe-file-int": Case(CRIT_FE, setup=write("fe.toml", 'model = "fe"\n[fe]\nfile = 5\n'), words=("[fe] file",)),
    "fe-files-value-int": Case(CRIT_FE, setup=write("fe.toml", 'model = "fe"\n[fe]\nfiles = {M = 5, K1 = "K1.mtx"}\n'),
                               words=("[fe] files.M",)),
    "toml-model-list": Case(["critical", "--config", "m.toml"], setup=write("m.toml", 'model = ["fe"]\n'),
                            words=("model",)),
    "toml-preset-list": Case(["critical", "--config", "m.toml"], setup=write("m.toml", 'preset = ["lv2013"]\n'),
                             words=("preset",)),
    "toml-rig-int": Case(["critical", "--config", "m.toml"], setup=write("m.toml", "rig = 5\n"), words=("rig",)),
    "perm-campaign-existing-db": Case(["campaign", "{camp}/matrix.csv", "--out-dir", "o", *CAMP, "--no-report"],
                                      setup=_perm_setup, sub=True, words=("campaign.duckdb",),
                                      prefix=("setpriv", "--bounding-set=-dac_override,-dac_read_search", "--")),
    "full-stab-nc": Case(["stability", "--mu", "0:0.8:401", "--theta", "-8:8:401", "--out", "tiny/m.nc"], sub=True,
                         mount="5m", words=("no space left",),
                         elsewhere=FULL_DISK + "[stability-nc]"),
    "full-synth-nc": Case(["synth", "--out", "tiny/r.nc", "--duration", "30"], sub=True, mount="5m",
                          words=("no space left",)),
    "full-synth-uff": Case(["synth", "--out", "tiny/r.uff", "--duration", "5"], sub=True, mount="5m",
                           words=("no space left",),
                           elsewhere=FULL_DISK + "[synth-uff]"),
    "full-reproduce": Case(["reproduce", "--quick", "--out-dir", "tiny/rep"], sub=True, mount="5m",
                           words=("no space left",)),
    "race-stab-zarr": Case(_race(["stability", "--mu", "0:0.8:3", "--theta", "0", "--out", "same.zarr"]),
                           expect="own",
                           elsewhere=RACE + "[stability]"),
    "race-campaign": Case(_race(["campaign", "{camp}/matrix.csv", "--out-dir", "same.zarr", *CAMP, "--no-report"]),
                          expect="own",
                          elsewhere=RACE + "[campaign]"),
    "api-model-from-dict-list": Case(api(lambda c: __import__("squealkit.models.config", fromlist=["x"])
                                         .model_from_dict({"model": ["fe"]})), words=("model",)),
    "api-parse-assign-notstr": Case(api(lambda c: __import__("squealkit.models.config", fromlist=["x"])
                                        .parse_assignments([5])), words=("5",)),
    "api-map-mu-1e300": Case(api(lambda c: __import__("squealkit.stability", fromlist=["x"]).stability_map(
        _model(), mu=[1e300], theta=[0.0])), words=("1e+300",)),
    "api-eig-mu-1e300": Case(api(lambda c: __import__("squealkit.stability", fromlist=["x"]).eigenvalues(
        _model(), 1e300)), words=("1e+300",)),
    "api-crit-model-str": Case(api(lambda c: __import__("squealkit.stability", fromlist=["x"]).critical_friction(
        "lv2013")), words=("model must be",)),
    "api-fe-band-k-0": Case(api(lambda c: tbi._e_case("band-k-0", c.w)[0]()), words=("k=0",)),
    "api-summary-not-ds": Case(api(lambda c: tbi._e_case("summary-dict", c.w)[0]()), words=("ds must be",)),
    "api-lc-harm-0": Case(api(lambda c: tbi._e_case("lc-harmonics-0", c.w)[0]()), words=("harmonics=0",)),
    "api-load-garbage": Case(api(lambda c: __import__("squealkit.io", fromlist=["x"]).load_dataset(c.w / "g.nc")),
                             setup=write("g.nc", np.random.default_rng(2).bytes(5000)), words=("g.nc",)),
    "api-load-empty-zarr": Case(api(lambda c: __import__("squealkit.io", fromlist=["x"]).load_dataset(c.w / "e.zarr")),
                                setup=lambda c: (c.w / "e.zarr").mkdir(), words=("e.zarr",)),
    "api-save-blocks-mismatch": Case(api(lambda c: tbi._e_case("save-blocks-mismatch", c.w)[0]()),
                                     words=("block 1",)),
    "api-save-nc-onto-dir": Case(api(lambda c: __import__("squealkit.io", fromlist=["x"]).save_dataset(
        xr.Dataset({"a": ("x", [1.0])}), c.w / "d.nc")), setup=write("d.nc/notes.txt", "mine"),
        words=("d.nc", "is a folder")),
    "api-store-corrupt": Case(api(lambda c: __import__("squealkit.campaign.store", fromlist=["x"]).CampaignStore(
        c.w / "c.duckdb")), setup=write("c.duckdb", np.random.default_rng(3).bytes(100_000)), words=("c.duckdb",)),
    "api-store-dir": Case(api(lambda c: __import__("squealkit.campaign.store", fromlist=["x"]).CampaignStore(
        c.w / "c.duckdb")), setup=lambda c: (c.w / "c.duckdb").mkdir(), words=("c.duckdb",)),
    "api-matrix-binary": Case(api(lambda c: __import__("squealkit.campaign.matrix", fromlist=["x"]).read_matrix(
        c.w / "m.csv")), setup=write("m.csv", np.random.default_rng(4).bytes(3000)), words=("m.csv",)),
    **{f"duck-{name}": Case(["campaign", "{camp}/matrix.csv", "--out-dir", "o", *CAMP, "--no-report"],
                            setup=store_in_o(kind), words=("campaign.duckdb",))
       for name, kind in (("random", "random"), ("truncated", "truncated"), ("zero", "zero"), ("flipped", "flipped"),
                          ("other-schema", "other-columns"), ("view-named-events", "view-events"), ("dir", "folder"),
                          ("sqlite", "sqlite"), ("text", "text"))},
    **{f"dask-junk-{name}": Case([*args, "--scheduler", "{scheduler}"], setup=junk_server, words=("Dask",))
       for name, args in (
           ("stab", ["stability", "--mu", "0:0.8:11", "--theta", "0", "--out", "m.zarr"]),
           ("mc", ["montecarlo", "--config", "{rig}", "--samples", "64"]),
           ("sim", ["simulate", "--mu", "0.2:0.4:2", "--duration", "0.01", "--out", "b.zarr"]),
           ("an", ANALYZE),
           ("camp", ["campaign", "{camp}/matrix.csv", "--out-dir", "o", *CAMP, "--no-report"]),
           ("fe", ["stability", "--config", "{nlevp_toml}", "--rpm", "60:240:3"]))},
    "full2-an-out": Case(["analyze", "{long}", "--mic", "mic", "--displacement", "displacement", "--rpm", "900",
                          "--radius", "0.05", "--out", "tiny/r.nc"], sub=True, mount="100k", words=("no space left",)),
    # full2-mc-out, full2-tol-out: fewer samples and points than the round's (still 3-6 times the tmpfs)
    "full2-mc-out": Case(["montecarlo", "--config", "{rig}", "--samples", "64", "--mu", "0:1:201", "--out",
                          "tiny/mc.nc", "--no-sensitivity"], sub=True, mount="64k", words=("no space left",)),
    "full2-lc-out": Case(["limitcycle", "--mu", "0.3:0.6:16", "--out", "tiny/l.nc", "--plot", "tiny/l.png"], sub=True,
                         mount="32k", words=("no space left",)),
    "full2-crit-out": Case(["critical", "--theta", "-8:8:401", "--out", "tiny/c.nc"], sub=True, mount="16k",
                           words=("no space left",)),
    "full2-tol-out": Case(["tolerance", "--mu", "0:0.44:40", "--out", "tiny/t.nc", "--plot", "tiny/t.png"], sub=True,
                          mount="16k", words=("no space left",)),
    "full2-modes-out": Case(["modes", "--mu", "0.6", "--out", "tiny/m.nc", "--plot", "tiny/m.png"], sub=True,
                            mount="8k", words=("no space left",)),
    # the round's --mu 0.3:0.8:11 takes 19 s at 200 harmonics: two points near the onset test the same path
    "lc-harm-33": Case(["limitcycle", "--mu", "0.39:0.45:2", "--harmonics", "33", "--json"], expect="ok",
                       check=_lc_check(33)),
    "lc-harm-40": Case(["limitcycle", "--mu", "0.39:0.45:2", "--harmonics", "40", "--json"], expect="ok",
                       check=_lc_check(40)),
    "lc-harm-200": Case(["limitcycle", "--mu", "0.39:0.45:2", "--harmonics", "200", "--json"], expect="ok",
                        check=_lc_check(200)),
    "lc-harmtol-doubling": Case(["limitcycle", "--mu", "0.39:0.45:2", "--harmonics", "20", "--harmonics-tol",
                                 "1e-12", "--json"], expect="ok", check=_lc_check(40, at_least=True)),
}

XFAIL: dict[str, str] = {}


# ---------------------------------------------------------------------------------------------
# Running a case


def _tree(folder: Path) -> dict[str, str]:
    """Every entry below ``folder`` (hidden ones too), its kind and, for a file, a hash of its bytes."""
    out = {}
    for p in sorted(folder.rglob("*")):
        if p.is_symlink():
            kind = "link:" + os.readlink(p)
        elif p.is_dir():
            kind = "dir"
        elif p.is_file():
            try:
                kind = "file:" + hashlib.sha1(p.read_bytes()).hexdigest()
            except PermissionError:
                kind = "file:unreadable"
        else:
            kind = "special:" + oct(p.lstat().st_mode)
        out[p.relative_to(folder).as_posix()] = kind
    return out


def _one_line_error(code: int, err: str, words) -> None:
    assert "Traceback" not in err, err[-3000:]
    assert code == 2, (code, err[-3000:])
    # one error line; a warning about an implausible value may come before it, on lines of its own
    lines = [ln for ln in err.strip().splitlines() if not ln.startswith("squealkit: warning:")]
    assert len(lines) == 1, err[-3000:]
    assert lines[0].startswith("squealkit: error:"), lines[0]
    for w in words:
        assert w in lines[0], (w, lines[0])


def _mount(ctx: Ctx, size: str) -> Path:
    if os.geteuid() != 0:
        pytest.skip("mounting a small tmpfs needs root")
    d = ctx.w / "tiny"
    d.mkdir()
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(d)], capture_output=True)
    if r.returncode != 0:
        pytest.skip(f"mounting a tmpfs failed: {r.stderr.decode(errors='replace').strip()}")
    ctx.notes.setdefault("umount", []).append(d)
    return d


def _run_case(case: Case, ctx: Ctx):
    """(exit code, stdout, stderr) of a CLI case; (result or exception) of an API case."""
    args = [ctx.shared.fmt(a).replace("{scheduler}", ctx.notes.get("scheduler", "")) for a in case.what]
    if case.sub:
        prefix = case.prefix if os.geteuid() == 0 else ()  # setpriv drops what root has; others lack it anyway
        r = subprocess.run([*prefix, *SQUEALKIT, *args], cwd=ctx.w, env=ctx.env(), capture_output=True,
                           text=True, timeout=TIMEOUT)
        return r.returncode, r.stdout, r.stderr
    from click.testing import CliRunner

    from squealkit.cli.main import cli

    r = CliRunner().invoke(cli, args)
    if r.exception is not None and not isinstance(r.exception, SystemExit):
        import traceback

        return 1, r.stdout, "Traceback\n" + "".join(traceback.format_exception(r.exception))
    return r.exit_code, r.stdout, r.stderr


#: rows that spawn processes or run real work (seconds of CPU each): ``-m "not slow"`` leaves them out
SLOW = {"full-reproduce", "link-zarr-to-dir", "lc-harm-200", "fe-stab-rpm-huge-n"}


def _params():
    out = []
    for cid in CASES:
        marks = [pytest.mark.xfail(strict=True, reason=XFAIL[cid])] if cid in XFAIL else []
        case = CASES[cid]
        if case.sub or case.expect == "own" or cid in SLOW:
            marks.append(pytest.mark.slow)
        out.append(pytest.param(cid, id=cid, marks=marks))
    return out


def _in_this_run(request, test: str) -> bool:
    """Whether the test ``file::name[id]`` is collected and selected in this session."""
    return any(item.nodeid.endswith("/" + test) or item.nodeid == test for item in request.session.items)


@pytest.mark.parametrize("cid", _params())
def test_adversarial_case(cid, tmp_path, shared, monkeypatch, request):
    case = CASES[cid]
    if case.elsewhere is not None and _in_this_run(request, case.elsewhere):
        return  # the dedicated test runs this case in this session (not twice)
    if case.root and os.geteuid() != 0:
        pytest.skip("needs root (device nodes)")
    w, tmpdir = tmp_path / "w", tmp_path / "tmpdir"
    w.mkdir()
    tmpdir.mkdir()
    monkeypatch.chdir(w)
    monkeypatch.setenv("TMPDIR", str(tmpdir))
    monkeypatch.setenv("SQUEALKIT_THREADS", "1")
    monkeypatch.setattr(tempfile, "tempdir", str(tmpdir))
    ctx = Ctx(tmp_path, w, tmpdir, shared, monkeypatch)
    import dask

    def dask_default():  # in-process runs leave dask's scheduler and default client as they were
        try:
            from distributed.client import default_client

            client = default_client()
        except (ImportError, ValueError):
            client = None
        return dask.config.get("scheduler", None), client

    scheduler = dask_default()
    try:
        if case.mount:
            _mount(ctx, case.mount)
        if case.setup:
            case.setup(ctx)
        before = _tree(w)
        if case.expect == "own":
            case.what(ctx)
        elif callable(case.what):  # an API expression
            if case.expect == "refused":
                with pytest.raises(InputError) as e:  # InputTypeError (a TypeError too) for a wrong type
                    case.what(ctx)
                msg = str(e.value)
                assert "\n" not in msg.strip(), msg
                for word in case.words:
                    assert word in msg, (word, msg)
            else:
                case.what(ctx)
        else:
            code, out, err = _run_case(case, ctx)
            if case.expect == "refused":
                _one_line_error(code, err, case.words)
            else:
                assert code == 0 and "Traceback" not in err, (code, err[-3000:])
                if case.check:
                    assert case.check(ctx, out) is not False
        after = _tree(w)
        if case.expect == "refused":
            assert after == before  # nothing written, nothing changed, nothing left
        else:
            for name, kind in before.items():
                if not any(name == c or name.startswith(c + "/") for c in case.changes):
                    assert after.get(name) == kind, f"{name} changed"
        leftovers = [n for n in after if LEFTOVER.search(n)]
        assert not leftovers, leftovers
        assert os.listdir(tmpdir) == [], os.listdir(tmpdir)
        assert dask_default() == scheduler  # no client of a refused scheduler left as default
    finally:
        if "cleanup" in ctx.notes:
            ctx.notes["cleanup"]()
        for d in ctx.notes.get("umount", []):
            subprocess.run(["umount", "-l", str(d)], check=False)
        for p in w.rglob("*"):  # the read-only store of perm-campaign-existing-db
            if p.is_dir() and not p.is_symlink():
                p.chmod(0o755)


def _file_ids() -> list[str]:
    return re.findall(r"^- \*\*([^*]+)\*\*", CASE_FILE.read_text(), flags=re.M)


def test_the_table_is_the_file():
    # the case file and this module cannot drift: every id of the file is a row, and only those
    # (the file's headings add up to 131, its TRACEBACK section lists 72 of the 74 it announces: 129 cases)
    ids = _file_ids()
    assert len(ids) == len(set(ids)) == 129
    assert sorted(CASES) == sorted(ids)

"""The thread limit of the compiled kernels: SQUEALKIT_THREADS, limit_threads, threads_for, --threads."""

import json

import numba
import numpy as np
import pytest
from click.testing import CliRunner

from squealkit import InputError
from squealkit.cli.main import cli
from squealkit.models import get_preset
from squealkit.scale import ENV_VAR, SERIAL_BELOW, env_threads, limit_threads, thread_limit, threads_for
from squealkit.stability import eigenvalues, stability_map

POOL = numba.config.NUMBA_NUM_THREADS


@pytest.mark.parametrize("value", ["0", "-1", "two", "1.5", "2 threads", "1e3"])
def test_bad_environment_variable_is_rejected_naming_it(monkeypatch, value):
    monkeypatch.setenv(ENV_VAR, value)
    with pytest.raises(InputError, match=rf"Environment variable {ENV_VAR}='.*' must be an integer >= 1"):
        env_threads()
    with pytest.raises(InputError, match=ENV_VAR):
        threads_for(10 * SERIAL_BELOW)


def test_environment_variable_sets_the_limit_capped_by_the_pool(monkeypatch):
    monkeypatch.setenv(ENV_VAR, " 1 ")
    assert env_threads() == 1 and thread_limit() == 1 and threads_for(10**9) == 1
    monkeypatch.setenv(ENV_VAR, "1000")
    assert thread_limit() == POOL  # never more than numba's pool
    monkeypatch.setenv(ENV_VAR, "")
    assert env_threads() is None and thread_limit() == POOL
    monkeypatch.delenv(ENV_VAR)
    assert thread_limit() == POOL


def test_small_work_runs_serially_large_work_uses_the_limit(monkeypatch):
    monkeypatch.delenv(ENV_VAR, raising=False)
    assert threads_for(1) == 1 and threads_for(SERIAL_BELOW - 1) == 1
    assert threads_for(SERIAL_BELOW) == POOL
    assert threads_for(1, serial_below=1) == POOL


def test_limit_threads_nests_restores_and_wins_over_the_environment(monkeypatch):
    monkeypatch.setenv(ENV_VAR, "1")
    before = numba.get_num_threads()
    with limit_threads(POOL) as n:  # explicit beats the environment variable
        assert n == POOL and numba.get_num_threads() == POOL and threads_for(10**9) == POOL
        with limit_threads(1) as inner:
            assert inner == 1 and numba.get_num_threads() == 1 and threads_for(10**9) == 1
            with limit_threads(POOL + 5) as capped:  # an inner block can only lower the count
                assert capped == 1
        assert numba.get_num_threads() == POOL
    assert numba.get_num_threads() == before


@pytest.mark.parametrize("n", [0, -2, 1.5, "x", True])
def test_limit_threads_rejects_bad_counts(n):
    with pytest.raises(InputError, match="threads"):
        with limit_threads(n):
            pass


def test_serial_and_parallel_give_identical_eigenvalues(monkeypatch):
    # each mu row is solved on its own (eigen.py), so the thread count cannot change a bit
    monkeypatch.delenv(ENV_VAR, raising=False)
    model = get_preset("lv2013")
    mu = np.linspace(0.0, 0.8, 161)
    theta = np.radians(np.linspace(-8.0, 8.0, 161))  # 25921 points: above SERIAL_BELOW
    assert mu.size * theta.size >= SERIAL_BELOW
    ref = stability_map(model, mu, theta, damped=True)
    with limit_threads(1):
        one = stability_map(model, mu, theta, damped=True)
    np.testing.assert_array_equal(one.growth_rate.values, ref.growth_rate.values)
    np.testing.assert_array_equal(one.omega.values, ref.omega.values)
    lam = eigenvalues(model, mu[:, None], tan_theta=np.tan(theta)[None, :])
    with limit_threads(1):
        np.testing.assert_array_equal(eigenvalues(model, mu[:, None], tan_theta=np.tan(theta)[None, :]), lam)


@pytest.fixture()
def runner():
    return CliRunner()


def test_cli_threads_1_gives_the_default_numbers(runner):
    args = ["critical", "--theta", "-8:8:3", "--json"]
    default = runner.invoke(cli, args)
    serial = runner.invoke(cli, ["--threads", "1", *args])
    assert default.exit_code == 0 and serial.exit_code == 0, serial.output
    assert json.loads(serial.stdout) == json.loads(default.stdout)
    args = ["stability", "--mu", "0:0.8:161", "--theta", "-8:8:161", "--damped", "--json"]  # parallel by default
    assert json.loads(runner.invoke(cli, ["--threads", "1", *args]).stdout) == json.loads(
        runner.invoke(cli, args).stdout)


def test_cli_threads_limit_holds_during_the_command_and_is_released(runner, monkeypatch):
    monkeypatch.delenv(ENV_VAR, raising=False)  # the suite runs with SQUEALKIT_THREADS=1: the pool after the command
    seen = []
    import squealkit.stability.eigen as eigen

    solve = eigen._solve_block

    def spy(*a, **k):
        seen.append(numba.get_num_threads())
        return solve(*a, **k)

    monkeypatch.setattr(eigen, "_solve_block", spy)
    r = runner.invoke(cli, ["--threads", "1", "stability", "--mu", "0:0.8:201", "--theta", "-8:8:201", "--json"])
    assert r.exit_code == 0, r.output
    assert seen and set(seen) == {1}
    assert thread_limit() == POOL  # the limit ended with the command


@pytest.mark.parametrize(
    ("args", "env", "message"),
    [
        (["--threads", "0", "critical"], {}, "Invalid value for '--threads': 0 is not in the range x>=1"),
        (["--threads", "many", "critical"], {}, "Invalid value for '--threads'"),
        (["critical"], {ENV_VAR: "0"}, f"Environment variable {ENV_VAR}='0' must be an integer >= 1"),
    ],
)
def test_cli_bad_thread_count_is_one_line_exit_2(runner, args, env, message):
    r = runner.invoke(cli, args, env=env)
    assert r.exit_code == 2
    assert message in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1


def test_blas_loaded_after_the_first_bounded_call_is_bounded_too():
    # found by the suite under load (tests/test_smaller_27.py saw 2 BLAS threads under SQUEALKIT_THREADS=1):
    # the BLAS controller was made once, at the first bounded call; a BLAS library loaded later (scipy's
    # own OpenBLAS, MKL with PARDISO) was not in it and kept its threads. Reference: threadpoolctl's own
    # report of every BLAS loaded, inside the bounded block, in a fresh process.
    import subprocess
    import sys

    code = (
        "import numpy\n"
        "from squealkit._threads import honour_thread_limit\n"
        "honour_thread_limit(lambda: None)()\n"  # the first bounded call: numpy's BLAS only
        "import scipy.linalg\n"
        "from threadpoolctl import threadpool_info, threadpool_limits\n"
        "seen = []\n"
        "with threadpool_limits(2, user_api='blas'):\n"
        "    honour_thread_limit(lambda: seen.extend(i['num_threads'] for i in threadpool_info()\n"
        "                                             if i['user_api'] == 'blas'))()\n"
        "print(sorted(set(seen)))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], env={**__import__("os").environ, ENV_VAR: "1"},
                         capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[1]"

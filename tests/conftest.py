import matplotlib
import pytest
from click.testing import CliRunner

matplotlib.use("Agg")


@pytest.fixture()
def run():
    """``run("stability", "--json")``: the squealkit CLI, in-process."""
    from squealkit.cli.main import cli

    runner = CliRunner()
    return lambda *args: runner.invoke(cli, list(args))


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    """No warm-up child outside tests/test_warmup.py.

    A report run (``reproduce``) starts a child process that compiles the later steps' kernels on the
    other core (:mod:`squealkit._warmup`) unless ``SQUEALKIT_THREADS=1``. In the suite each kernel is
    compiled once, by the first test that needs it, and loaded from numba's on-disk cache afterwards;
    a child per report test would import squealkit and run its kernels once more for nothing. Patched
    around the whole item (setup too: the report fixtures are module-scoped), not in test_warmup.py,
    which tests the child itself.
    """
    if getattr(item, "module", None) is not None and item.module.__name__.endswith("test_warmup"):
        yield
        return
    from squealkit import _warmup

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(_warmup, "start", lambda groups: False)
        yield

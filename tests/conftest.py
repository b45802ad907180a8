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

"""An optional package that is not installed gives one line naming what to install, never a traceback.

Found on a fresh ``pip install -e .`` (issue 27's new-user path): ``squealkit synth --out rec.mf4`` and
``--out rec.uff`` stopped with ``ModuleNotFoundError: No module named 'asammdf'`` / ``'pyuff'`` and
``squealkit fe-demo`` with ``No module named 'skfem'``, each a traceback. The class: every import of an
optional package goes through :func:`squealkit._optional.require`; the static test below holds the
source to it, the behavioural ones run the commands with the package made unimportable.
"""

import sys

import pytest
from click.testing import CliRunner

from squealkit.cli.main import cli


def _blocked(monkeypatch, *modules):
    """Make ``import m`` raise ImportError, as when the package is not installed."""
    for m in modules:
        for name in [k for k in sys.modules if k == m or k.startswith(m + ".")]:
            monkeypatch.delitem(sys.modules, name)
        monkeypatch.setitem(sys.modules, m, None)


@pytest.mark.parametrize(("module", "args", "extra"), [
    ("asammdf", ["synth", "--duration", "0.05", "--out", "{d}/rec.mf4"], "daq"),
    ("pyuff", ["synth", "--duration", "0.05", "--out", "{d}/rec.uff"], "daq"),
    ("skfem", ["fe-demo", "--size", "16", "--out-dir", "{d}/fe"], "fe"),
])
def test_missing_optional_package_is_one_line_and_exit_2(monkeypatch, tmp_path, module, args, extra):
    _blocked(monkeypatch, module)
    r = CliRunner().invoke(cli, [a.format(d=tmp_path) for a in args])
    assert r.exit_code == 2, r.output
    err = r.stderr.strip()
    assert "Traceback" not in r.output and len(err.splitlines()) == 1, err
    assert f"squealkit[{extra}]" in err
    assert not any(p.name.startswith(("rec", "fe")) for p in tmp_path.iterdir())  # nothing half-written

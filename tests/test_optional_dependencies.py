"""An optional package that is not installed gives one line naming what to install, never a traceback.

Found on a fresh ``pip install -e .`` (issue 27's new-user path): ``squealkit synth --out rec.mf4`` and
``--out rec.uff`` stopped with ``ModuleNotFoundError: No module named 'asammdf'`` / ``'pyuff'`` and
``squealkit fe-demo`` with ``No module named 'skfem'``, each a traceback. The class: every import of an
optional package goes through :func:`squealkit._optional.require`; the static test below holds the
source to it, the behavioural ones run the commands with the package made unimportable.
"""

import ast
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

from squealkit._optional import OPTIONAL
from squealkit.cli.main import cli

SRC = Path(__file__).resolve().parents[1] / "src" / "squealkit"


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


def _optional_imports(tree: ast.AST):
    """(line, top-level package) of every import of an optional package in a parsed module."""
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names = [node.module]
        else:
            continue
        for n in names:
            if n.split(".")[0] in OPTIONAL:
                yield node.lineno, n.split(".")[0]


def _required_in(fn: ast.AST) -> dict[str, int]:
    """Top-level package -> first line where ``require("pkg...", ...)`` is called in this function."""
    out: dict[str, int] = {}
    for node in ast.walk(fn):
        if (isinstance(node, ast.Call) and getattr(node.func, "id", getattr(node.func, "attr", None)) == "require"
                and node.args and isinstance(node.args[0], ast.Constant) and isinstance(node.args[0].value, str)):
            pkg = node.args[0].value.split(".")[0]
            out[pkg] = min(out.get(pkg, node.lineno), node.lineno)
    return out


def test_every_optional_import_goes_through_require():
    """An optional package is imported only inside a function that first called ``require`` for it (a
    submodule's private helpers may then be imported directly); never at module level."""
    bad = []
    for path in SRC.rglob("*.py"):
        if path.name == "_optional.py":
            continue
        tree = ast.parse(path.read_text(), str(path))
        functions = [n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef | ast.AsyncFunctionDef)]
        for line, pkg in _optional_imports(tree):
            owner = min((f for f in functions if f.lineno <= line <= f.end_lineno),
                        key=lambda f: f.end_lineno - f.lineno, default=None)
            first = _required_in(owner).get(pkg) if owner is not None else None
            if first is None or first > line:
                bad.append(f"{path.relative_to(SRC)}:{line} imports {pkg} without require()")
    assert not bad, "\n".join(bad)

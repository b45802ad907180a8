"""The example scripts run and print what they promise (the docs' gallery runs them too, and
shows their output and figures: tests/test_docs.py)."""

import ast
import re
import runpy
import sys
from pathlib import Path

import pytest

EXAMPLES = sorted((Path(__file__).parents[1] / "examples").glob("*.py"))


@pytest.mark.parametrize("script", EXAMPLES, ids=[p.name for p in EXAMPLES])
def test_example_runs(script, tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(sys, "argv", [str(script), str(tmp_path)])
    runpy.run_path(str(script), run_name="__main__")
    out = capsys.readouterr().out
    assert out.strip()
    assert list(tmp_path.glob("*.png")), "the example writes figures"


def test_examples_exist():
    assert len(EXAMPLES) >= 5
    assert (EXAMPLES[0].parent / "GALLERY_HEADER.rst").is_file()  # the gallery's front page


@pytest.mark.parametrize("script", EXAMPLES, ids=[p.name for p in EXAMPLES])
def test_example_follows_the_gallery_convention(script):
    # sphinx-gallery: runs NN_*.py (conf.py's filename_pattern) and titles the page with the
    # docstring's first reST heading; it sets no __file__, so the scripts do not use it
    assert re.fullmatch(r"\d\d_\w+\.py", script.name)
    tree = ast.parse(script.read_text(encoding="utf-8"))
    doc = ast.get_docstring(tree) or ""
    title, underline = [*doc.splitlines(), "", ""][:2]
    assert title and underline == "=" * len(title), f"{script.name}: the docstring starts with a reST title"
    assert not [n for n in ast.walk(tree) if isinstance(n, ast.Name) and n.id == "__file__"]

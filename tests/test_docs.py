"""The documentation site builds from the docstrings, the README, the examples and the CLI
with no warning (warnings are errors), as CI builds it."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow
def test_docs_build_without_warnings(tmp_path):
    r = subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-E", "-b", "html", str(ROOT / "docs"),
         str(tmp_path / "html")],
        capture_output=True, text=True, timeout=600,
    )
    assert r.returncode == 0, r.stderr[-4000:]
    for page in ("index", "tour", "theory", "howto", "examples", "cli", "api"):
        assert (tmp_path / "html" / f"{page}.html").stat().st_size > 2000
    cli = (tmp_path / "html" / "cli.html").read_text(encoding="utf-8")
    assert "squealkit stability" in cli and "--mu" in cli  # generated from the commands
    # required options are marked in bold, not with literal asterisks
    assert "**Required**" not in cli and "<strong>Required</strong>" in cli
    # long code lines wrap (docs/_static/wrap.css) instead of being cut at the page's edge
    assert "wrap.css" in cli and "pre-wrap" in (tmp_path / "html" / "_static" / "wrap.css").read_text()
    for page in ("models", "stability", "fe-models", "transient", "measurement", "command-line", "speed"):
        assert (tmp_path / "html" / "guide" / f"{page}.html").stat().st_size > 5000  # the guide
    api = (tmp_path / "html" / "api.html").read_text(encoding="utf-8")
    assert "critical_friction" in api and "stability_map" in api
    # the equations render offline: MathJax is bundled with the pages
    assert any((tmp_path / "html" / "_static").rglob("tex-chtml*.js"))

"""The documentation site builds from the docstrings, the README, the examples and the CLI
with no warning (warnings are errors), as CI builds it; the API reference has one page per
public name, reached from the task pages (docs/api/*.md), and the gallery shows every example's
output and figures.

The site is built once per test run (about 40 s of CPU, most of it the gallery running the
examples) and shared by the tests below.
"""

from __future__ import annotations

import ast
import importlib
import re
import subprocess
import sys
from pathlib import Path

import pytest

from test_api_docs import _public_modules as public_modules

ROOT = Path(__file__).resolve().parents[1]
pytestmark = pytest.mark.slow  # one Sphinx build (the gallery runs the examples) for the module


@pytest.fixture(scope="module")
def html(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("docs") / "html"
    r = subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-E", "-b", "html", str(ROOT / "docs"), str(out)],
        capture_output=True, text=True, timeout=900,
    )
    assert r.returncode == 0, r.stderr[-4000:]
    return out


def test_docs_build_without_warnings(html):
    for page in ("index", "tour", "theory", "howto", "examples/index", "cli", "api", "dev/index"):
        assert (html / f"{page}.html").stat().st_size > 2000
    cli = (html / "cli.html").read_text(encoding="utf-8")
    assert "squealkit stability" in cli and "--mu" in cli  # generated from the commands
    # required options are marked in bold, not with literal asterisks
    assert "**Required**" not in cli and "<strong>Required</strong>" in cli
    # long code lines wrap (docs/_static/wrap.css) instead of being cut at the page's edge
    assert "wrap.css" in cli and "pre-wrap" in (html / "_static" / "wrap.css").read_text()
    for page in ("models", "stability", "fe-models", "transient", "measurement", "design", "command-line", "speed"):
        assert (html / "guide" / f"{page}.html").stat().st_size > 5000  # the guide
    # the equations render offline: MathJax is bundled with the pages
    assert any((html / "_static").rglob("tex-chtml*.js"))


def _public_modules() -> list[str]:
    """The public modules, as tests/test_api_docs.py defines them (squealkit, its public subpackages,
    recursively, its public top-level modules and the modules of squealkit.plotting)."""
    return [m.__name__ for m in public_modules()]


def _resolve(qualname: str):
    """The object a dotted public path names, attribute by attribute (a package's function
    ``stability.modes`` before its submodule of the same name), importing modules as needed."""
    first, *rest = qualname.split(".")
    obj, path = importlib.import_module(first), first
    for part in rest:
        path = f"{path}.{part}"
        obj = getattr(obj, part) if hasattr(obj, part) else importlib.import_module(path)
    return obj


def _documented(html: Path) -> dict[int, str]:
    """id(object) -> the page of each name a task page (api/*.html) links to its own page."""
    pages: dict[int, str] = {}
    for task in sorted((html / "api").glob("*.html")):
        for qualname in re.findall(r'href="generated/([\w.]+)\.html', task.read_text(encoding="utf-8")):
            page = html / "api" / "generated" / f"{qualname}.html"
            assert page.is_file(), f"{task.name} links to a missing page {page.name}"
            pages[id(_resolve(qualname))] = qualname
    return pages


def test_every_public_name_has_its_page_on_a_task_page(html):
    # the same object re-exported at two public paths (a moved module's shim) needs one page
    documented = _documented(html)
    missing = []
    for modname in _public_modules():
        mod = importlib.import_module(modname)
        for name in getattr(mod, "__all__", ()):
            if not name.startswith("__") and id(getattr(mod, name)) not in documented:
                missing.append(f"{modname}.{name}")
    assert not missing, f"no page reached from a task page (docs/api/*.md) for: {', '.join(missing)}"
    assert len(documented) > 150


def _taught_names() -> set[tuple[str, str]]:
    """(module, name) of everything README.md, the guide, the how-tos and the examples import
    from squealkit, and of the public functions their prose names as `name(...)`."""
    pages = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")), *sorted((ROOT / "docs" / "guide").glob("*.md"))]
    texts = [p.read_text(encoding="utf-8") for p in pages]
    blocks = [b for t in texts for b in re.findall(r"```python\n(.*?)```", t, flags=re.S)]
    blocks += [p.read_text(encoding="utf-8") for p in sorted((ROOT / "examples").glob("*.py"))]
    taught = set()
    for block in blocks:
        try:
            tree = ast.parse(block)
        except SyntaxError:  # a fragment: its import lines alone
            tree = ast.parse("\n".join(line for line in block.splitlines() if line.startswith("from squealkit")))
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("squealkit"):
                taught |= {(node.module, a.name) for a in node.names}
    public = {name: modname for modname in _public_modules()
              for name in getattr(importlib.import_module(modname), "__all__", ())}
    for text in texts:
        taught |= {(public[n], n) for n in re.findall(r"`(\w+)\(", text) if n in public}
    return taught


def test_every_name_the_readme_and_guide_teach_is_documented(html):
    documented = _documented(html)
    missing = []
    for modname, name in sorted(_taught_names()):
        obj = getattr(importlib.import_module(modname), name)
        if not isinstance(obj, type(sys)) and id(obj) not in documented:
            missing.append(f"{modname}.{name}")
    assert not missing, f"taught in README.md, docs/ or examples/ but without a page: {', '.join(missing)}"


def test_gallery_shows_each_example_with_output_and_figures(html):
    for script in sorted((ROOT / "examples").glob("[0-9][0-9]_*.py")):
        page = (html / "examples" / f"{script.stem}.html").read_text(encoding="utf-8")
        assert "sphx-glr-script-out" in page, f"{script.name}: no printed output on its page"
        images = re.findall(r'<img[^>]+src="(\.\./_images/sphx_glr_[^"]+\.png)"', page)
        assert images, f"{script.name}: no figure on its page"
        assert all((html / "examples" / src).is_file() for src in images)
    index = (html / "examples" / "index.html").read_text(encoding="utf-8")
    assert "05_campaign.html" in index

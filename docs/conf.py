"""Sphinx configuration of squealkit's documentation (built in CI with warnings as errors:
``python -m sphinx -W -b html docs docs/_build``, run by ``tests/test_docs.py``)."""

from __future__ import annotations

import squealkit

project = "squealkit"
author = "squealkit developers"
copyright = "2026, squealkit developers"
release = version = squealkit.__version__

extensions = [
    "myst_parser",  # the pages are Markdown, like the README they share text with
    "sphinx.ext.autodoc",
    "sphinx.ext.mathjax",
    "sphinx-mathjax-offline",  # MathJax bundled: the docs render their equations without a network
    "numpydoc",  # the docstrings are numpydoc
    "sphinx_click",  # the CLI reference, generated from the commands themselves
]
source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
myst_enable_extensions = ["dollarmath", "amsmath"]
myst_heading_anchors = 3
exclude_patterns = ["_build"]
smartquotes = False  # "--out" stays two hyphens
highlight_language = "text"  # literal blocks are help texts and console sessions; code blocks name their language
html_theme = "furo"
html_title = f"squealkit {release}"
autodoc_default_options = {"members": True, "show-inheritance": False}
autodoc_member_order = "bysource"
autodoc_typehints = "none"  # numpydoc's Parameters sections say the types
numpydoc_show_class_members = False
numpydoc_xref_param_type = False
# no network on the build machines: nothing is fetched (no intersphinx)
suppress_warnings = ["myst.header"]


def _plain_help(app, ctx, lines) -> None:
    """Help texts are plain text, not reStructuredText: click's unwrapped (``\\b``) blocks,
    examples and key lists, become literal blocks, exactly as ``--help`` prints them; glob
    patterns like ``runs/*.nc`` elsewhere stay asterisks."""
    out: list[str] = []
    block: list[str] = []

    def flush() -> None:
        if block:
            out.extend(["::", "", *("    " + b for b in block), ""])
            block.clear()

    for line in lines:
        if line.startswith("| ") or line == "|":
            block.append(line[2:])
            continue
        flush()
        # plain text: a literal *, but sphinx-click's own "**Required**" marker stays bold
        out.append(line.replace("*", r"\*").replace(r"\*\*Required\*\*", "**Required**"))
    flush()
    lines[:] = out


def setup(app) -> None:
    app.connect("sphinx-click-process-description", _plain_help)
    app.connect("sphinx-click-process-options", _plain_help)
    app.connect("sphinx-click-process-epilog", _plain_help)

# long code lines wrap instead of being cut at the edge of the page
html_static_path = ["_static"]
html_css_files = ["wrap.css"]

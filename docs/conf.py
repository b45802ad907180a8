"""Sphinx configuration of squealkit's documentation (built in CI with warnings as errors:
``python -m sphinx -W -b html docs docs/_build``, run by ``tests/test_docs.py``)."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import squealkit

sys.path.insert(0, str(Path(__file__).parent))  # _gallery.py: the examples' argv and figure scraper

project = "squealkit"
author = "squealkit developers"
copyright = "2026, squealkit developers"
release = version = squealkit.__version__

extensions = [
    "myst_parser",  # the pages are Markdown, like the README they share text with
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",  # one page per public name, listed on the task pages of api/
    "sphinx.ext.mathjax",
    "sphinx-mathjax-offline",  # MathJax bundled: the docs render their equations without a network
    "numpydoc",  # the docstrings are numpydoc
    "sphinx_click",  # the CLI reference, generated from the commands themselves
    "sphinx_gallery.gen_gallery",  # examples/*.py run and shown with their output and figures
]
source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
myst_enable_extensions = ["dollarmath", "amsmath"]
myst_heading_anchors = 3
exclude_patterns = ["_build", "examples/*.ipynb"]
templates_path = ["_templates"]  # autosummary: a class page documents its members itself
autosummary_generate = True  # the stubs go to api/generated/ (not in git)
smartquotes = False  # "--out" stays two hyphens
highlight_language = "text"  # literal blocks are help texts and console sessions; code blocks name their language
html_theme = "furo"
html_title = f"squealkit {release}"
autodoc_default_options = {"members": True, "show-inheritance": False}
autodoc_member_order = "bysource"
autodoc_typehints = "none"  # numpydoc's Parameters sections say the types
numpydoc_show_class_members = False
numpydoc_xref_param_type = False
# The gallery: every examples/NN_*.py runs once per build (about 40 s of CPU with the compiled
# kernels cached; `-D plot_gallery=0` builds the pages without running them). A script writes
# its figures to the folder given as its first argument; _gallery.py passes a temporary one
# and shows the PNGs the script wrote, in the order written.
sphinx_gallery_conf = {
    "examples_dirs": "../examples",
    "gallery_dirs": "examples",
    "filename_pattern": r"/\d\d_",  # run every numbered example, not only plot_*.py
    "reset_argv": "_gallery.reset_argv",
    "image_scrapers": ("_gallery.png_scraper",),
    "reset_modules": ("matplotlib",),
    "download_all_examples": False,
    "within_subsection_order": "FileNameSortKey",  # 01_, 02_, ... in their order
    "remove_config_comments": True,
    "show_memory": False,
    "line_numbers": False,
    "min_reported_time": 3600,  # no timing line on each page: it differs between machines
    "write_computation_times": False,
}
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


def _api_pages_off_the_sidebar(app, doctree) -> None:
    """The task pages (api/*.md) link each name to its own page through their autosummary
    tables; those ~200 pages are orphans (docs/_templates/autosummary), not entries of the
    sidebar's navigation tree, which furo renders on every page: in the tree they made the
    build four times slower and the sidebar a list of every function."""
    from sphinx.ext.autosummary import autosummary_toc

    for node in list(doctree.findall(autosummary_toc)):
        node.parent.remove(node)


def _constant_docs(app, what, name, obj, options, lines) -> None:
    """A constant re-exported by its package (``squealkit.stability.VERDICTS``) is described by
    the ``#:`` comment where it is defined, not by the docstring of its type (``tuple``)."""
    first = (type(obj).__doc__ or "").strip().partition("\n")[0]
    if what not in ("data", "attribute") or not first or not any(first in line for line in lines):
        return  # its own docstring (a class's or a function's), or a #: comment autodoc found
    from sphinx.errors import PycodeError
    from sphinx.pycode import ModuleAnalyzer

    short = name.rpartition(".")[2]
    for modname, mod in sorted(sys.modules.items()):
        if not modname.startswith("squealkit") or getattr(mod, short, None) is not obj:
            continue
        try:
            comment = ModuleAnalyzer.for_module(modname).find_attr_docs().get(("", short))
        except PycodeError:  # a module without source (none in squealkit); try the next one
            continue
        if comment:  # |lambda| is an absolute value there, not a reST substitution
            lines[:] = [re.sub(r"\|(\w+)\|", r"\\|\1\\|", line) for line in comment]
            return
    lines[:] = []


def setup(app) -> None:
    app.connect("autodoc-process-docstring", _constant_docs)
    # before Sphinx's toctree collector (priority 500) records the pages the toctrees include
    app.connect("doctree-read", _api_pages_off_the_sidebar, priority=100)
    app.connect("sphinx-click-process-description", _plain_help)
    app.connect("sphinx-click-process-options", _plain_help)
    app.connect("sphinx-click-process-epilog", _plain_help)

# long code lines wrap instead of being cut at the edge of the page
html_static_path = ["_static"]
html_css_files = ["wrap.css"]

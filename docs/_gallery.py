"""How the gallery runs the examples (``sphinx_gallery_conf`` in ``conf.py`` names these).

Each ``examples/NN_*.py`` writes its results and figures to the folder given as its first
argument, as a user runs it. :func:`reset_argv` gives every example its own temporary folder and
:func:`png_scraper` shows, after each code block, the PNG files the example has written there
since, in the order written: the page shows exactly the figures the script saves.
"""

from __future__ import annotations

import atexit
import shutil
import tempfile
from pathlib import Path

_OUTPUT: dict[str, Path] = {}  # example source file -> its output folder
_SHOWN: dict[str, set[Path]] = {}  # example source file -> the PNGs already on its page


def _remove_outputs() -> None:
    for folder in _OUTPUT.values():
        shutil.rmtree(folder, ignore_errors=True)


atexit.register(_remove_outputs)


def reset_argv(gallery_conf, script_vars) -> list[str]:
    """The example's arguments: a new, empty output folder."""
    src = str(script_vars["src_file"])
    old = _OUTPUT.pop(src, None)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)
    _OUTPUT[src] = Path(tempfile.mkdtemp(prefix="squealkit-gallery-"))
    _SHOWN[src] = set()
    return [str(_OUTPUT[src])]


def png_scraper(block, block_vars, gallery_conf) -> str:
    """The reST showing the PNG files the example wrote since the last block, one under another."""
    from sphinx_gallery.scrapers import figure_rst

    src = str(block_vars["src_file"])
    folder = _OUTPUT.get(src)
    if folder is None:
        return ""
    new = [p for p in folder.glob("*.png") if p not in _SHOWN[src]]
    new.sort(key=lambda p: (p.stat().st_mtime_ns, p.name))
    rst = []
    for png, image_path in zip(new, block_vars["image_path_iterator"], strict=False):
        shutil.copyfile(png, image_path)
        _SHOWN[src].add(png)
        rst.append(figure_rst([image_path], gallery_conf["src_dir"], fig_titles=png.stem))
    return "".join(rst)

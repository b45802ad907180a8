"""Render report sections as one self-contained HTML file (figures embedded as PNG data URIs)."""

from __future__ import annotations

import base64
import datetime as _dt
import html
import math
from collections.abc import Sequence
from pathlib import Path

from .. import __version__
from .document import Comparison, FigureRef, Section, Table

__all__ = []

_CSS = """
body { font-family: system-ui, -apple-system, "Segoe UI", sans-serif; max-width: 1100px; margin: 2em auto;
       padding: 0 1em; color: #1d1d1f; line-height: 1.45; }
h1 { font-size: 1.7em; margin-bottom: 0.2em; } h2 { border-bottom: 1px solid #ccc; padding-bottom: 0.2em;
margin-top: 2em; }
.meta { color: #666; font-size: 0.9em; }
table { border-collapse: collapse; margin: 0.8em 0 1.2em; font-size: 0.92em; }
th, td { border: 1px solid #ccc; padding: 0.3em 0.6em; text-align: right; }
th { background: #f2f2f2; } td:first-child, th:first-child { text-align: left; }
caption { caption-side: top; text-align: left; font-weight: 600; padding-bottom: 0.3em; }
td.txt { text-align: left; } td.ok { background: #e7f6e7; } td.off { background: #fbe9e7; }
figure { margin: 1em 0 1.6em; } figure img { max-width: 100%; border: 1px solid #ddd; }
figcaption { color: #444; font-size: 0.92em; margin-top: 0.3em; }
.synthetic { background: #fff4ce; border-left: 4px solid #e0a800; padding: 0.4em 0.8em; }
nav ol { columns: 2; } code { background: #f4f4f4; padding: 0 0.2em; }
"""


def _fmt(value: object) -> str:
    if value is None:
        return "&mdash;"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            return "&mdash;"
        if value != 0 and (abs(value) >= 1e5 or abs(value) < 1e-3):
            return f"{value:.4g}"  # 8.545e+06: the digits the paper gives, not 8.5450e+06
        return f"{value:.6g}"
    if isinstance(value, tuple):
        return " &ndash; ".join(_fmt(v) for v in value)
    return html.escape(str(value))


def _comparisons(items: Sequence[Comparison]) -> str:
    rows = []
    for c in items:
        verdict = "" if c.agrees is None else (' class="ok"' if c.agrees else ' class="off"')
        if c.agrees is None:
            mark = ""
        elif c.published is None:  # nothing published to agree with: the check stated in the note holds or not
            mark = "holds" if c.agrees else "does not hold"
        else:
            mark = "agrees" if c.agrees else "differs"
        rows.append(
            f"<tr><td>{html.escape(c.quantity)}</td><td>{_fmt(c.published)}</td><td>{_fmt(c.computed)}</td>"
            f"<td>{html.escape(c.unit)}</td><td>{c.difference()}</td><td{verdict}>{mark}</td>"
            f"<td>{html.escape(c.note)}</td></tr>"
        )
    # a table without a published number is a table of checks, not a comparison with the paper
    caption = "Published beside computed" if any(c.published is not None for c in items) else "Checks"
    return (
        f"<table><caption>{caption}</caption><tr><th>quantity</th><th>published</th>"
        "<th>squealkit</th><th>unit</th><th>difference</th><th>verdict</th><th>note</th></tr>"
        + "".join(rows) + "</table>"
    )


def _table(t: Table) -> str:
    head = "".join(f"<th>{html.escape(h)}</th>" for h in t.header)
    percent = [h.endswith("[%]") for h in t.header]

    def cell(v: object, pct: bool) -> str:
        if isinstance(v, str):
            return f"<td class='txt'>{_fmt(v)}</td>"
        if pct and isinstance(v, float) and math.isfinite(v):  # a difference in %: one decimal, signed
            return f"<td>{v:+.1f}</td>"
        return f"<td>{_fmt(v)}</td>"

    body = "".join("<tr>" + "".join(cell(v, p) for v, p in zip(row, percent, strict=False)) + "</tr>"
                   for row in t.rows)
    return f"<table><caption>{html.escape(t.caption)}</caption><tr>{head}</tr>{body}</table>"


def render_html(sections: Sequence[Section], figures_dir: Path, *, title: str, subtitle: str = "") -> str:
    """The whole report as one HTML string; figures are read from ``figures_dir`` (PNG)."""
    now = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    parts = [
        "<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>",
        f"<title>{html.escape(title)}</title><style>{_CSS}</style></head><body>",
        f"<h1>{html.escape(title)}</h1>",
        f"<p class='meta'>{html.escape(subtitle)} &middot; squealkit {__version__} &middot; {now}</p>",
        "<nav><ol>" + "".join(f"<li><a href='#{s.key}'>{html.escape(s.title)}</a></li>" for s in sections)
        + "</ol></nav>",
    ]
    for s in sections:
        parts.append(f"<section id='{s.key}'><h2>{html.escape(s.title)}</h2>")
        for p in s.paragraphs:
            cls = " class='synthetic'" if p.startswith("SYNTHETIC") else ""
            parts.append(f"<p{cls}>{html.escape(p)}</p>")
        if s.comparisons:
            parts.append(_comparisons(s.comparisons))
        for t in s.tables:
            parts.append(_table(t))
        for v in s.views:
            parts.append(f"<div class='view'>{v}</div>")
        for f in s.figures:
            png = (figures_dir / f"{f.stem}.png").read_bytes()
            uri = "data:image/png;base64," + base64.b64encode(png).decode("ascii")
            parts.append(
                f"<figure id='fig-{f.stem}'><img alt='{html.escape(f.caption)}' src='{uri}'>"
                f"<figcaption>{html.escape(f.caption)} (<code>figures/{f.stem}.png</code>"
                + (", <code>.svg</code>" if (figures_dir / f"{f.stem}.svg").is_file() else "")
                + ")</figcaption></figure>"
            )
        if s.data:
            files = ", ".join(f"<code>data/{html.escape(d)}</code>" for d in s.data)
            parts.append(f"<p class='meta'>Data behind these figures: {files}</p>")
        parts.append("</section>")
    # a reader's browser records whether every figure decoded (checked by the test suite)
    parts.append(
        "<script>window.addEventListener('load', function () {"
        "var imgs = document.querySelectorAll('figure img'); var ok = 0;"
        "imgs.forEach(function (im) { if (im.complete && im.naturalWidth > 0) { ok++; } });"
        "document.body.setAttribute('data-figures', imgs.length);"
        "document.body.setAttribute('data-figures-loaded', ok);});</script>"
    )
    parts.append("</body></html>")
    return "\n".join(parts)


def save_figures(figs: dict, figures_dir: Path) -> tuple[FigureRef, ...]:
    """Save each ``stem -> (figure, caption)`` as ``figures_dir/stem.png`` (the folder made if need be), close it,
    and return the references."""
    import matplotlib.pyplot as plt

    from ..io import save_figure

    figures_dir.mkdir(exist_ok=True)
    refs = []
    for stem, (fig, caption) in figs.items():
        save_figure(fig, figures_dir / f"{stem}.png")
        plt.close(fig)
        refs.append(FigureRef(stem, caption))
    return tuple(refs)


def write_report(sections: Sequence[Section], out: Path, *, title: str, subtitle: str = "") -> Path:
    """``out/report.html`` rendered from ``sections`` (figures in ``out/figures``), written whole or not at all."""
    from ..io import atomic_path

    page = render_html(sections, out / "figures", title=title, subtitle=subtitle)
    with atomic_path(out / "report.html") as tmp:
        tmp.write_text(page, encoding="utf-8")
    return out / "report.html"

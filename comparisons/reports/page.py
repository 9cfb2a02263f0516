"""The one HTML shell of every signcast report (comparison, live, sweep), and the pieces the pages share.

`page(title, body)` fills `templates/page.html` (the standard library's `string.Template`): the title, the
shared style sheet, the body's sections, and a footer that checks the page when a browser loads it (every chart
decoded, every table with rows, no table wider than the page; it writes "rendered C/C charts, T/T tables; all ok"
into `#render-check`, which the browser tests read).
"""
from __future__ import annotations

import base64
import html
from importlib import resources
from string import Template

_TEMPLATE = Template(resources.files("comparisons.reports").joinpath("templates/page.html").read_text("utf-8"))


def page(title: str, body: str, *, max_width_px: int = 1150, extra_style: str = "") -> str:
    """The whole page: `title` (plain text, escaped here), `body` (HTML sections), the shared shell around them."""
    return _TEMPLATE.substitute(title=html.escape(title), body=body, max_width=int(max_width_px),
                                extra_style=extra_style)


def table(name: str, header: list[str], rows: list[list], *, escape: bool = True) -> str:
    """A table with `data-table=name` (the render check finds it): header cells are plain text; row cells are
    escaped plain text unless `escape=False`, where they are HTML already."""
    head = "".join(f"<th>{html.escape(str(h))}</th>" for h in header)
    cell = (lambda v: html.escape("" if v is None else str(v))) if escape else (lambda v: str(v))
    body = "".join("<tr>" + "".join(f"<td>{cell(v)}</td>" for v in row) + "</tr>" for row in rows)
    return f'<table data-table="{html.escape(name)}"><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>'


def image(name: str, png: bytes, alt: str) -> str:
    """A PNG chart inlined as a data URL, with `data-chart=name` (the render check finds it)."""
    encoded = base64.b64encode(png).decode("ascii")
    return (f'<img class="chart" data-chart="{html.escape(name)}" alt="{html.escape(alt)}" '
            f'src="data:image/png;base64,{encoded}">')

"""Matplotlib figures as the reports need them: a title that fits its figure, and the PNG bytes."""
from __future__ import annotations

import io
import textwrap


def suptitle(figure, text: str, fontsize: float = 9) -> None:
    """The figure's title, each of its lines wrapped to the figure's width (a title wider than its figure is cut
    off at both sides); a character is taken as 0.6 of the font size wide."""
    width_pt = figure.get_figwidth() * 72
    per_line = max(10, int(width_pt / (0.6 * fontsize)))
    lines = [wrapped for line in text.split("\n") for wrapped in (textwrap.wrap(line, per_line) or [""])]
    figure.suptitle("\n".join(lines), fontsize=fontsize)


def figure_png(figure, *, empty: str | None = None) -> bytes:
    """The PNG bytes of a matplotlib figure (closed after), or of a one-line placeholder figure saying `empty`
    when figure is None."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as pyplot
    if figure is None:
        figure = pyplot.figure(figsize=(6, 1))
        figure.text(0.5, 0.5, empty or "nothing to plot", ha="center")
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=100)
    pyplot.close(figure)
    return buffer.getvalue()

"""Chart titles fit their figures (issue 38: the sweep's and the lab's titles were cut off at both sides)."""
from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pytest  # noqa: E402

from comparisons.reports.figures import suptitle  # noqa: E402

LONG = ("Model-based coders (seed 002 ch. 8), two waveform coders and MPEG-4 FBA/BBA: VPSNR vs rate\n"
        "mean joint position error (mm) <= 2; where the motion has a face, worst face point's error (mm, 90th "
        "percentile over frames) <= 2")


@pytest.mark.parametrize("width_in, fontsize", [(5.2, 11), (7.0, 9), (3.0, 10), (14.0, 9)])
def test_a_long_title_stays_inside_its_figure(width_in, fontsize):
    figure = plt.figure(figsize=(width_in, 4))
    suptitle(figure, LONG, fontsize)
    figure.canvas.draw()
    box = figure._suptitle.get_window_extent(figure.canvas.get_renderer())
    inside = figure.bbox
    plt.close(figure)
    assert box.x0 >= inside.x0 and box.x1 <= inside.x1, (box, inside)
    assert figure._suptitle.get_text().replace("\n", " ") == LONG.replace("\n", " ")

"""Landmarks of what a viewer sees, extracted several times under invisible sub-pixel shifts, and the mean of what
each extraction measures.

The landmark extractor's answer on a picture is one draw of a noisy process: shifting the picture by a fraction of
a pixel (bilinear, invisible) gives it new pixels and moves its answer. On the demo (ASL HELLO, 352x288, 28
measured frames) one extraction's hand PCK@0.2 varies with the shift by a standard deviation of 0.7 points on the
uncoded render and 0.9-1.6 points on the decoded renders, so a single draw can put a nearly lossless decode (FBA at
Q 1: 94.8 % at no shift, 98.5 % as the mean of eight shifts) under a threshold 2 points below the ceiling. The
mean over several shifts estimates what the extractor reads of the picture itself; its spread over the draws is
kept with it.

Every subject (the uncoded reference that sets the ceiling, and every coded point) is extracted at the same first
`count` shifts of SHIFTS, so all are draws from the same perturbations; the first is the half-pixel diagonal shift
the ceiling has always used. No shift is zero: the reference at zero shift is its own landmarks (100 %).

This module is pure: the shifts, moving a picture by one (`shifted`) and its landmarks back (`unshift`), and the
statistics of the draws (`mean_fields`, `draw_values`, `standard_error`, `interval`). One convention throughout:
the spread over the draws is the sample standard deviation (ddof 1), and an interval is a t-interval with K - 1
degrees of freedom (with 2-4 extractions a "2 standard errors" bar would cover 70-86 %, not 95 %). Running the landmark model
on the shifted pictures, with progress bars, is the study layer's (pipeline.studies.shared.extract_draws).
"""
from __future__ import annotations

import cv2
import numpy as np

from media.lexicon import SignClip

# (dx, dy) pixels, right and down: the half-pixel diagonal first, then the axes, then finer offsets spread over the
# pixel (a (0, 1)^2 grid of eighths, no two alike)
SHIFTS = ((0.5, 0.5), (0.5, 0.0), (0.0, 0.5), (0.25, 0.75), (0.75, 0.25), (0.25, 0.25), (0.75, 0.75),
          (0.125, 0.625), (0.625, 0.125), (0.375, 0.875), (0.875, 0.375), (0.125, 0.125), (0.625, 0.625),
          (0.375, 0.375), (0.875, 0.875), (0.5, 0.75))
MAX_EXTRACTIONS = len(SHIFTS)


def shifted(frames: np.ndarray, shift: tuple[float, float]) -> np.ndarray:
    """frames (T, H, W, 3) uint8 moved by shift (dx, dy) pixels right and down (bilinear, edges replicated)."""
    matrix = np.float32([[1, 0, shift[0]], [0, 1, shift[1]]])
    return np.stack([cv2.warpAffine(frame, matrix, frame.shape[1::-1], flags=cv2.INTER_LINEAR,
                                    borderMode=cv2.BORDER_REPLICATE) for frame in frames])


def unshift(observed: SignClip, shift: tuple[float, float]) -> SignClip:
    """observed (landmarks found on frames moved by shift, pixels) moved back by the shift onto the frames' own pixel
    grid, in place (missing points, confidence 0, stay at 0); returns observed. World components (metres, about
    the body or the hand: names ending in WORLD_LANDMARKS) do not move with the picture and are left as they are."""
    for name, points in observed.points.items():
        if name.endswith("WORLD_LANDMARKS"):
            continue
        seen = observed.confidence[name] > 0
        points[..., 0] -= shift[0] * seen
        points[..., 1] -= shift[1] * seen
    return observed


def mean_fields(draws: list[dict]) -> dict:
    """The mean over draws (one dict of measured fields per extraction) of each numeric field, over the draws that
    define it (None where none does); with several draws also draw_sd: each such field's standard deviation over
    them (the sample standard deviation, ddof 1; 0 for one draw), draw_values: each such field's value in every draw, in the draws' (the
    shifts') order, None where a draw does not define it (so that two subjects extracted under the same shifts can
    be compared shift by shift), and extractions: their number."""
    names = list(dict.fromkeys(name for fields in draws for name in fields))
    mean, spread, values_by_draw = {}, {}, {}
    for name in names:
        values = [fields[name] for fields in draws if _number(fields.get(name))]
        if not values:
            mean[name] = None
            continue
        mean[name] = float(np.mean(values))
        spread[name] = float(np.std(values, ddof=1)) if len(values) > 1 else 0.0
        values_by_draw[name] = [float(fields[name]) if _number(fields.get(name)) else None for fields in draws]
    if len(draws) > 1:
        mean["draw_sd"] = spread
        mean["draw_values"] = values_by_draw
    mean["extractions"] = len(draws)
    return mean


def draw_values(record: dict, field: str) -> list[float | None] | None:
    """A record's field in each of its extractions (`mean_fields`' draw_values), None for a record extracted once."""
    values = (record.get("draw_values") or {}).get(field)
    return list(values) if isinstance(values, list) else None


def standard_error(record: dict, field: str) -> float | None:
    """The standard error of a record's field over its landmark extractions (their standard deviation, `mean_fields`'
    draw_sd, over the square root of their number); None for a record extracted once or without the field's spread."""
    spread, count = (record.get("draw_sd") or {}).get(field), record.get("extractions")
    if not _number(spread) or not isinstance(count, int) or count < 2:
        return None
    return spread / count ** 0.5


def interval(record: dict, field: str, level: float = 0.95) -> float | None:
    """The half width of the t-interval (level, K - 1 degrees of freedom) of a record's field over its K landmark
    extractions: t quantile x `standard_error`; None where that is None."""
    error = standard_error(record, field)
    if error is None:
        return None
    from scipy.stats import t
    return float(t.ppf(0.5 + level / 2, record["extractions"] - 1) * error)


def _number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and np.isfinite(value)

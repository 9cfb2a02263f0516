"""Temporal filters against keypoint jitter: the One-Euro filter and a [1, 2, 1] / 4 binomial.

One-Euro (Casiez, Roussel and Vogel, CHI 2012): a first-order low-pass filter whose cutoff rises
with the signal's speed, so a still point is smoothed strongly (jitter gone) while a moving one
lags little. Per coordinate, at sample i (time t_i, seconds):

    dx_i  = (x_i - xhat_{i-1}) / (t_i - t_{i-1})            speed, units per second
    dxh_i = dxh_{i-1} + a(d_cutoff) (dx_i - dxh_{i-1})       its low-passed value
    fc_i  = min_cutoff + beta |dxh_i|                        Hz
    xhat_i = xhat_{i-1} + a(fc_i) (x_i - xhat_{i-1})
    a(fc) = 1 / (1 + tau / dt),  tau = 1 / (2 pi fc),  dt = t_i - t_{i-1}

Missing samples (valid False) are skipped: they are neither read nor written (their output is the
input, unchanged, still marked missing), and the next seen sample is filtered with dt the time
since the last seen one, so after a long gap a(fc) is near 1 and the filter restarts at the new
value instead of dragging the old one in. A point's first seen sample passes unchanged.

The units of x are the caller's (the retargeting passes keypoints in shoulder widths, see
media.retarget); beta is per (unit / second).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from media.errors import SigncastError

FILTERS = ("one-euro", "binomial", "off")


@dataclass(frozen=True)
class OneEuro:
    """min_cutoff: Hz, the cutoff of a still signal; beta: Hz per (unit / s), how fast the cutoff
    rises with speed; d_cutoff: Hz, the cutoff of the speed estimate."""
    min_cutoff: float = 1.0
    beta: float = 0.5
    d_cutoff: float = 1.0

    def __post_init__(self) -> None:
        for name in ("min_cutoff", "beta", "d_cutoff"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0) or (name != "beta" and value == 0):
                raise SigncastError(f"bad One-Euro {name} {value}: must be a {'non-negative' if name == 'beta' else 'positive'} number")


def _alpha(cutoff: np.ndarray, dt: np.ndarray) -> np.ndarray:
    tau = 1.0 / (2.0 * np.pi * cutoff)
    return 1.0 / (1.0 + tau / dt)


def one_euro(points: np.ndarray, valid: np.ndarray, fps: float, settings: OneEuro = OneEuro()) -> np.ndarray:
    """One-Euro filtered points (T, N, D), each coordinate over time; invalid (T, N) samples are
    returned as given and do not enter the filter (module docstring). fps: samples per second."""
    points = np.asarray(points, dtype=np.float64)
    valid = np.asarray(valid, dtype=bool)
    if points.ndim != 3 or valid.shape != points.shape[:2]:
        raise SigncastError(f"One-Euro filter needs points (T, N, D) and valid (T, N), got {points.shape} and {valid.shape}")
    if not (np.isfinite(fps) and fps > 0):
        raise SigncastError(f"bad frame rate {fps} for the One-Euro filter")
    n_points, n_dims = points.shape[1:]
    out = points.copy()
    estimate = np.zeros((n_points, n_dims))
    speed = np.zeros((n_points, n_dims))
    last_seen = np.full(n_points, np.nan)            # time (s) of each point's last seen sample
    for t in range(len(points)):
        now = t / fps
        seen = valid[t]
        first = seen & np.isnan(last_seen)
        going = seen & ~np.isnan(last_seen)
        estimate[first] = points[t, first]
        speed[first] = 0.0
        if going.any():
            dt = (now - last_seen[going])[:, None]                       # (n, 1) seconds
            x = points[t, going]
            raw_speed = (x - estimate[going]) / dt
            speed[going] += _alpha(np.float64(settings.d_cutoff), dt) * (raw_speed - speed[going])
            cutoff = settings.min_cutoff + settings.beta * np.abs(speed[going])
            estimate[going] += _alpha(cutoff, dt) * (x - estimate[going])
            out[t, going] = estimate[going]
        last_seen[seen] = now
    return out


def binomial(points: np.ndarray) -> np.ndarray:
    """The [1, 2, 1] / 4 temporal filter of points (T, N, D), ends repeated; needs no gaps (fill first)."""
    points = np.asarray(points, dtype=np.float64)
    if len(points) < 3:
        return points
    padded = np.concatenate([points[:1], points, points[-1:]])
    return 0.25 * padded[:-2] + 0.5 * padded[1:-1] + 0.25 * padded[2:]


def check_filter(name: str) -> str:
    if name not in FILTERS:
        raise SigncastError(f"unknown jitter filter {name!r}: choose one of {', '.join(FILTERS)}")
    return name

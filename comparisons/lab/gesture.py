"""Numba kernel of the seed-002 gesture coder's time warp (comparisons/lab/model.py documents the coder).

warp_rows is the linear time warp of comparisons/lab/model.warp (np.interp of every column of each segment onto
a uniform grid, to rounding) for every segment of a clip in one call: the source and target grids are
np.linspace(0, 1, n)'s values (i * (1 / (n - 1)), the last exactly 1.0), the interval of a target time t is
searchsorted(source, t, "right") - 1 clipped to the last interval, and a row is
(y[j + 1] - y[j]) / (x[j + 1] - x[j]) * (t - x[j]) + y[j], or the sample itself where t hits one.

Arrays: source (R, K) float64; starts, counts, lengths (S,) int64 (segment s is source[starts[s]:
starts[s] + counts[s]], counts >= 2, warped to lengths[s] >= 1 rows); out (sum(lengths), K) float64.
"""
import numpy as np
from numba import njit


@njit(cache=True, inline="always")
def _grid(i: int, n: int) -> float:
    """np.linspace(0.0, 1.0, n)[i]."""
    if n > 1 and i == n - 1:
        return 1.0
    return i * (1.0 / (n - 1)) + 0.0 if n > 1 else 0.0


@njit(cache=True)
def warp_rows(source: np.ndarray, starts: np.ndarray, counts: np.ndarray, lengths: np.ndarray,
              out: np.ndarray) -> None:
    row = 0
    k_count = source.shape[1]
    for s in range(len(starts)):
        a, n, m = starts[s], counts[s], lengths[s]
        j = 0
        for i in range(m):
            t = _grid(i, m)
            while j < n - 2 and _grid(j + 1, n) <= t:
                j += 1
            x0, x1 = _grid(j, n), _grid(j + 1, n)
            if t == x0 or t == 1.0:
                at = a + (n - 1 if t == 1.0 else j)
                for k in range(k_count):
                    out[row, k] = source[at, k]
            else:
                offset, spacing = t - x0, x1 - x0
                for k in range(k_count):
                    y0 = source[a + j, k]
                    out[row, k] = (source[a + j + 1, k] - y0) / spacing * offset + y0
            row += 1

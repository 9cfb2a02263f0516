"""Numba kernel of the retargeter's two-option Viterbi (media/retarget.py `smooth_choice`).

`smooth_choice` is the NumPy loop's operations, frame by frame: through[i, j] = total[i] + pairwise[t - 1, i, j],
the back pointer of each option j the first i of least cost (np.argmin: a NaN counts as the least, its first
occurrence), the new total that cost plus unary[t, j], and the backtrack from the first least total. The same
additions in the same order, so the same choices (tests/test_retarget.py compares the two). Imports nothing
of signcast.
"""
import math

import numpy as np
from numba import njit


@njit(cache=True)
def _first_least(values, n):
    """np.argmin(values[:n]): the first least value, or the first NaN where there is one."""
    best = 0
    for i in range(n):
        if math.isnan(values[i]):
            return i
        if values[i] < values[best]:
            best = i
    return best


@njit(cache=True)
def smooth_choice(unary, pairwise):
    """unary (T, K) float64 cost of each option per frame, pairwise (T - 1, K, K) float64 cost of moving from
    option i to option j between frames t and t + 1. Returns the choice (T,) int64 minimising their sum."""
    n_frames, n_options = unary.shape
    total = unary[0].copy()
    back = np.zeros((n_frames, n_options), np.int64)
    column = np.empty(n_options)
    through = np.empty((n_options, n_options))
    for t in range(1, n_frames):
        for i in range(n_options):
            for j in range(n_options):
                through[i, j] = total[i] + pairwise[t - 1, i, j]
        for j in range(n_options):
            for i in range(n_options):
                column[i] = through[i, j]
            back[t, j] = _first_least(column, n_options)
        for j in range(n_options):
            total[j] = through[back[t, j], j] + unary[t, j]
    choice = np.empty(n_frames, np.int64)
    choice[n_frames - 1] = _first_least(total, n_options)
    for t in range(n_frames - 1, 0, -1):
        choice[t - 1] = back[t, choice[t]]
    return choice

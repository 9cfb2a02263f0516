"""Numba-compiled arithmetic of media/rotations.slerp for the BBA decoder's key-frame expansion
(comparisons/keyframes.py `expand`), with its transcendental functions left to the caller's NumPy calls.

slerp's steps, element for element: dot = q0 . q1 (NumPy's add.reduce over the last axis of 4: ((a0 + a1)
+ a2) + a3), q1 negated where dot < 0, |dot| clipped to [-1, 1] (`prepare`); then NumPy's arccos and sin
(the caller's); then the weights where(sin(alpha) < 1e-9, linear, sin(.) / sin(alpha)), w0 q0 + w1 q1 and its
normalisation by sqrt of the same ordered sum of squares (`combine`). The same IEEE operations in the
same order, so the results are bitwise slerp's (tests/test_bba_decode_speed.py). Imports nothing of signcast.
"""
import math

import numpy as np
from numba import njit


@njit(cache=True)
def prepare(q0, q1):
    """q0, q1 (N, 4) float64 -> (|dot| clipped (N,), q1 on q0's side (N, 4))."""
    n = q0.shape[0]
    cosines, side = np.empty(n), np.empty((n, 4))
    for i in range(n):
        dot = q0[i, 0] * q1[i, 0] + q0[i, 1] * q1[i, 1]
        dot = dot + q0[i, 2] * q1[i, 2]
        dot = dot + q0[i, 3] * q1[i, 3]
        sign = -1.0 if dot < 0 else 1.0
        for k in range(4):
            side[i, k] = -q1[i, k] if sign < 0 else q1[i, k]
        dot = abs(dot)
        cosines[i] = min(max(dot, -1.0), 1.0)
    return cosines, side


@njit(cache=True)
def combine(q0, q1, t, sin_alpha, sin_first, sin_second):
    """Normalised w0 q0 + w1 q1 (N, 4): q0, q1 (N, 4) (q1 from prepare), t (N,), sin_alpha, sin_first =
    sin((1 - t) alpha), sin_second = sin(t alpha) (N,)."""
    n = q0.shape[0]
    out = np.empty((n, 4))
    for i in range(n):
        if sin_alpha[i] < 1e-9:
            w0, w1 = 1.0 - t[i], t[i]
        else:
            w0, w1 = sin_first[i] / sin_alpha[i], sin_second[i] / sin_alpha[i]
        r0 = w0 * q0[i, 0] + w1 * q1[i, 0]
        r1 = w0 * q0[i, 1] + w1 * q1[i, 1]
        r2 = w0 * q0[i, 2] + w1 * q1[i, 2]
        r3 = w0 * q0[i, 3] + w1 * q1[i, 3]
        norm = r0 * r0 + r1 * r1
        norm = norm + r2 * r2
        norm = math.sqrt(norm + r3 * r3)
        out[i, 0], out[i, 1], out[i, 2], out[i, 3] = r0 / norm, r1 / norm, r2 / norm, r3 / norm
    return out

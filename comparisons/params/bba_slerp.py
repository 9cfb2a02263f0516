"""Numba-compiled arithmetic of media/rotations.slerp for the BBA decoder's key-frame expansion
(comparisons/params/keyframes.py `expand`), with its transcendental functions left to the caller (NumPy).

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


@njit(cache=True)
def gap_setup(key_q, key_t, kfi):
    """The key frames of a decoded stream placed at their display frames and the slerp inputs of the frames
    between them. key_q (F, B, 4), key_t (F, 3) float64 the decoded frames, kfi (F,) int64 their KeyFrameIndex
    (kfi[0] ignored: a first frame regenerates nothing). Returns (quats (D, B, 4) with the key frames set and
    the inner frames left to `combine_into`, translations (D, 3) complete (linear: (1 - x) t0 + x t1), q0 (N, 4),
    q1 on q0's side (N, 4), |dot| clipped (N,), t (N,)), D = F + sum kfi[1:], N = sum kfi[1:] x B: the inner
    frames gap after gap, x = k / (kfi + 1), k = 1..kfi; per frame its B bones. keyframes.expand's operations."""
    n_keys, n_bones = key_q.shape[0], key_q.shape[1]
    n_inner = 0
    for f in range(1, n_keys):
        n_inner += kfi[f]
    quats, trans = np.empty((n_keys + n_inner, n_bones, 4)), np.empty((n_keys + n_inner, 3))
    n = n_inner * n_bones
    q0, side, cosines, t = np.empty((n, 4)), np.empty((n, 4)), np.empty(n), np.empty(n)
    d, i = 0, 0
    for f in range(n_keys):
        gap = kfi[f] if f else 0
        for k in range(1, gap + 1):
            x = k / (gap + 1)
            for c in range(3):
                trans[d, c] = (1 - x) * key_t[f - 1, c] + x * key_t[f, c]
            for b in range(n_bones):
                a0, a1, a2, a3 = key_q[f - 1, b, 0], key_q[f - 1, b, 1], key_q[f - 1, b, 2], key_q[f - 1, b, 3]
                b0, b1, b2, b3 = key_q[f, b, 0], key_q[f, b, 1], key_q[f, b, 2], key_q[f, b, 3]
                dot = a0 * b0 + a1 * b1
                dot = dot + a2 * b2
                dot = dot + a3 * b3
                if dot < 0:
                    b0, b1, b2, b3 = -b0, -b1, -b2, -b3
                q0[i, 0], q0[i, 1], q0[i, 2], q0[i, 3] = a0, a1, a2, a3
                side[i, 0], side[i, 1], side[i, 2], side[i, 3] = b0, b1, b2, b3
                cosines[i] = min(max(abs(dot), -1.0), 1.0)
                t[i] = x
                i += 1
            d += 1
        quats[d] = key_q[f]
        trans[d] = key_t[f]
        d += 1
    return quats, trans, q0, side, cosines, t


@njit(cache=True)
def combine_into(quats, kfi, q0, q1, t, sin_alpha, sin_first, sin_second) -> None:
    """`combine` of gap_setup's slerp inputs written into the inner frames of its quats (D, B, 4)."""
    n_bones = quats.shape[1]
    out = combine(q0, q1, t, sin_alpha, sin_first, sin_second)
    d, i = 0, 0
    for f in range(len(kfi)):
        gap = kfi[f] if f else 0
        for _ in range(gap):
            for b in range(n_bones):
                quats[d, b, 0], quats[d, b, 1], quats[d, b, 2], quats[d, b, 3] = out[i, 0], out[i, 1], out[i, 2], out[i, 3]
                i += 1
            d += 1
        d += 1

"""Numba kernel of the key-frame analyser's greedy search (comparisons/params/keyframes.py documents the rule).

`search` runs key_frames' greedy walk: from each key, the next key is the last frame before the first
candidate (at most max_gap + 1 frames on) whose interpolation fails the thresholds. The test of one
candidate is _within_each's, computed otherwise (`_test`: each bone's slerp arc once, the weights by
turning through the arc, the angle compared as the cosine of its half), so its values differ from NumPy's
in the last digits (below 1e-13): a decision is taken here only where every tested value lies farther
than `margin_rad` / `margin_m` from its threshold (far more than such differences can move it) and is
finite; otherwise the candidate is "undecided" and the search stops and asks the caller, which decides it
with the NumPy reference and calls again with the answer in `decided`. So the keys are exactly the reference's.
"""
import math

import numpy as np
from numba import njit

UNDECIDED, PASS, FAIL = 0, 1, 2


@njit(cache=True)
def _test(q, translation, first, last, threshold_rad, threshold_m, margin_rad, margin_m, arc):
    """PASS / FAIL / UNDECIDED of interpolating frames first+1..last-1 from keys first and last: q (T, B, 4),
    translation (T, 3); arc (>= last - first + 1,) scratch. Every value is tested: one within the margin of its
    threshold, or not finite, makes the candidate UNDECIDED whatever else fails.

    Bone by bone, the slerp's arc between the keys (the sign of their dot product, alpha = arccos |dot|,
    sin alpha) is taken once; the weights of inner frame k = inner - first, sin((span - k) alpha / span) and
    sin(k alpha / span), come from arc[k] = sin(k alpha / span), made by turning (cos, sin) through the step
    alpha / span k times (relative error below ~k * 4 eps, so below 1e-13 for the span <= 32 the walk tries),
    and the angle test is made on the cosine of half the angle, c = |<slerp, q>| / |slerp|: angle > threshold
    where c < cos(threshold / 2). The band of undecided c, cos((threshold +- margin) / 2), is more than 20
    times wider than those errors can move c at the smallest threshold the caller admits (1e-3 rad)."""
    near = False
    fail = False
    span = last - first
    # c below c_fail: the angle is clearly above the threshold; above c_pass: clearly below (half angles in [0, pi / 2])
    c_fail = math.cos(0.5 * min(threshold_rad + margin_rad, math.pi))
    c_pass = math.cos(0.5 * max(threshold_rad - margin_rad, 0.0))
    for b in range(q.shape[1]):
        a0, a1, a2, a3 = q[first, b, 0], q[first, b, 1], q[first, b, 2], q[first, b, 3]
        b0, b1, b2, b3 = q[last, b, 0], q[last, b, 1], q[last, b, 2], q[last, b, 3]
        dot = a0 * b0 + a1 * b1 + a2 * b2 + a3 * b3
        if dot < 0:
            b0, b1, b2, b3 = -b0, -b1, -b2, -b3
        alpha = math.acos(min(max(abs(dot), -1.0), 1.0))
        sin_alpha = math.sin(alpha)
        linear = sin_alpha < 1e-9
        if not linear:
            step = alpha / span
            cos_step, sin_step = math.cos(step), math.sin(step)
            cosine, sine = 1.0, 0.0
            arc[0] = 0.0
            for k in range(1, span + 1):
                cosine, sine = cosine * cos_step - sine * sin_step, sine * cos_step + cosine * sin_step
                arc[k] = sine
        for k in range(1, span):
            inner = first + k
            if linear:
                x = k / span
                w0, w1 = 1.0 - x, x
            else:
                w0, w1 = arc[span - k] / sin_alpha, arc[k] / sin_alpha
            e0, e1, e2, e3 = w0 * a0 + w1 * b0, w0 * a1 + w1 * b1, w0 * a2 + w1 * b2, w0 * a3 + w1 * b3
            norm = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2 + e3 * e3)
            c = abs((e0 * q[inner, b, 0] + e1 * q[inner, b, 1] + e2 * q[inner, b, 2] + e3 * q[inner, b, 3]) / norm)
            if c < c_fail:
                fail = True
            elif not c > c_pass:                # within the band, or NaN
                near = True
    for inner in range(first + 1, last):
        x = (inner - first) / span
        d0 = (1 - x) * translation[first, 0] + x * translation[last, 0] - translation[inner, 0]
        d1 = (1 - x) * translation[first, 1] + x * translation[last, 1] - translation[inner, 1]
        d2 = (1 - x) * translation[first, 2] + x * translation[last, 2] - translation[inner, 2]
        distance = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        if not math.isfinite(distance) or abs(distance - threshold_m) <= margin_m:
            near = True
        elif distance > threshold_m:
            fail = True
    if near:
        return UNDECIDED
    return FAIL if fail else PASS


@njit(cache=True)
def search(q, translation, threshold_rad, threshold_m, margin_rad, margin_m, max_gap, decided, keys):
    """The greedy key-frame walk over q (T, B, 4) rotations and translation (T, 3), T >= 1. decided (T, max_gap + 2)
    int8: the caller's decisions, decided[first, last - first] (UNDECIDED where it has none). keys (T,) int64
    receives the keys. Returns (count of keys, 0, 0) when done, or (-1, first, last): the candidate
    that needs the caller's decision."""
    n = q.shape[0]
    arc = np.empty(max_gap + 2)
    keys[0] = 0
    count = 1
    current = 0
    while current < n - 1:
        end = min(n - 1, current + max_gap + 1)
        nxt = end
        for last in range(current + 2, end + 1):
            verdict = decided[current, last - current]
            if verdict == UNDECIDED:
                verdict = _test(q, translation, current, last, threshold_rad, threshold_m, margin_rad, margin_m, arc)
            if verdict == UNDECIDED:
                return -1, current, last
            if verdict == FAIL:
                nxt = last - 1
                break
        keys[count] = nxt
        count += 1
        current = nxt
    return count, 0, 0


@njit(cache=True)
def moving(q):
    """(B,) bool of q (T, B, 4), T >= 1: keyframes._moving compiled, the same values. A bone is still when every
    frame's quaternion equals the first's (==: a NaN is never equal) and unit when its first quaternion's squared
    norm, summed in order as NumPy sums four values, is within 1e-9 of 1; it moves unless both."""
    n_frames, n_bones = q.shape[0], q.shape[1]
    out = np.empty(n_bones, np.bool_)
    for b in range(n_bones):
        still = True
        for t in range(1, n_frames):
            if not (q[t, b, 0] == q[0, b, 0] and q[t, b, 1] == q[0, b, 1] and q[t, b, 2] == q[0, b, 2]
                    and q[t, b, 3] == q[0, b, 3]):
                still = False
                break
        if still:      # a NaN in the first frame is not equal to itself
            still = q[0, b, 0] == q[0, b, 0] and q[0, b, 1] == q[0, b, 1] and q[0, b, 2] == q[0, b, 2] and q[0, b, 3] == q[0, b, 3]
        norm = ((q[0, b, 0] * q[0, b, 0] + q[0, b, 1] * q[0, b, 1]) + q[0, b, 2] * q[0, b, 2]) + q[0, b, 3] * q[0, b, 3]
        out[b] = not (still and abs(norm - 1.0) < 1e-9)
    return out


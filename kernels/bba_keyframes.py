"""Numba kernel of the key-frame analyser's greedy search (comparisons/keyframes.py documents the rule).

`search` runs key_frames' greedy walk: from each key, the next key is the last frame before the first
candidate (at most max_gap + 1 frames on) whose interpolation fails the thresholds. The test of one
candidate is _within_each's arithmetic (slerp, 2 arccos |dot|, linear translation, Euclidean distance)
with Numba's arccos and sin, which may differ from NumPy's vectorised ones in the last ulp: a decision
is taken here only where every tested value lies farther than `margin_rad` / `margin_m` from its
threshold (far more than such differences can move it) and is finite; otherwise the candidate is
"undecided" and the search stops and asks the caller, which decides it with the NumPy reference and
calls again with the answer in `decided`. So the keys are exactly the reference's.
"""
import math

from numba import njit

UNDECIDED, PASS, FAIL = 0, 1, 2


@njit(cache=True)
def _test(q, translation, first, last, threshold_rad, threshold_m, margin_rad, margin_m):
    """PASS / FAIL / UNDECIDED of interpolating frames first+1..last-1 from keys first and last: q (T, B, 4),
    translation (T, 3)."""
    near = False
    fail = False
    span = last - first
    n_bones = q.shape[1]
    for inner in range(first + 1, last):
        x = (inner - first) / span
        for b in range(n_bones):
            a0, a1, a2, a3 = q[first, b, 0], q[first, b, 1], q[first, b, 2], q[first, b, 3]
            b0, b1, b2, b3 = q[last, b, 0], q[last, b, 1], q[last, b, 2], q[last, b, 3]
            dot = a0 * b0 + a1 * b1 + a2 * b2 + a3 * b3
            if dot < 0:
                b0, b1, b2, b3 = -b0, -b1, -b2, -b3
            dot = abs(dot)
            alpha = math.acos(min(max(dot, -1.0), 1.0))
            sin_alpha = math.sin(alpha)
            if sin_alpha < 1e-9:
                w0, w1 = 1.0 - x, x
            else:
                w0, w1 = math.sin((1.0 - x) * alpha) / sin_alpha, math.sin(x * alpha) / sin_alpha
            e0, e1, e2, e3 = w0 * a0 + w1 * b0, w0 * a1 + w1 * b1, w0 * a2 + w1 * b2, w0 * a3 + w1 * b3
            norm = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2 + e3 * e3)
            c = abs((e0 * q[inner, b, 0] + e1 * q[inner, b, 1] + e2 * q[inner, b, 2] + e3 * q[inner, b, 3]) / norm)
            angle = 2.0 * math.acos(min(max(c, 0.0), 1.0))
            if not math.isfinite(angle) or abs(angle - threshold_rad) <= margin_rad:
                near = True
            elif angle > threshold_rad:
                fail = True
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
    keys[0] = 0
    count = 1
    current = 0
    while current < n - 1:
        end = min(n - 1, current + max_gap + 1)
        nxt = end
        for last in range(current + 2, end + 1):
            verdict = decided[current, last - current]
            if verdict == UNDECIDED:
                verdict = _test(q, translation, current, last, threshold_rad, threshold_m, margin_rad, margin_m)
            if verdict == UNDECIDED:
                return -1, current, last
            if verdict == FAIL:
                nxt = last - 1
                break
        keys[count] = nxt
        count += 1
        current = nxt
    return count, 0, 0

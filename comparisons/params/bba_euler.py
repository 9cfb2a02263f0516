"""Numba kernel of the BBA encoder's Euler split: quaternions -> Euler angles, bitwise scipy's as_euler.

`euler_angles` does what media/rotations.py `to_euler` does through scipy 1.17 (Rotation.from_quat, then
as_euler of the Cython backend, `_rotation_cy`): from_quat's normalisation (sqrt((x x + y y + z z) + w w),
then each component divided), then Bernardes & Viollet 2022 (PLoS ONE 17(11): e0276302) as scipy writes
it: the sequence as extrinsic axes (i, j, k) (an intrinsic sequence reversed), the quaternion's elements
permuted into a, b, c, d, the second angle 2 atan2(hypot(c, d), hypot(a, b)), the half sum and half
difference atan2(b, a) and atan2(d, c), scipy's gimbal-lock cases (second angle within 1e-7 of 0 or pi:
the third angle 0), the Tait-Bryan correction and the wrap into [-pi, pi]. Every operation is the same
IEEE operation in the same order and atan2 / hypot are libm's, as scipy's, so the angles are bitwise
scipy's (comparisons/lab/rotations.py does the same for one sequence; tests/test_bba_encode_speed.py checks
this one against scipy, gimbal lock included). A zero quaternion (scipy raises) is reported, not divided.

`motion_values` is the analysis after the split (comparisons/params/bba.py `_motion_arrays`): rounding to the
stream's units, the sent columns and the bone masks, integer work but for one division and rint per value
(tests/test_bba_encode_speed.py compares it with the NumPy form).
"""
import math

import numpy as np
from numba import njit


@njit(cache=True)
def euler_angles(q: np.ndarray, bits: np.ndarray, stride: int, i: int, j: int, k: int, extrinsic: bool
                 ) -> tuple[np.ndarray, bool]:
    """q (N, 4) float64 quaternions (w, x, y, z), not necessarily unit; bits: the same array viewed as int64;
    (i, j, k) the extrinsic axes (0 x, 1 y, 2 z; an intrinsic sequence reversed), extrinsic: whether the
    sequence was -> (angles (N, 3) radians, ok): ok False when a quaternion has zero norm (scipy raises;
    the caller falls back to it). A quaternion bit for bit the one `stride` rows before it (a bone held
    from the previous frame, rows frame-major) takes that one's angles: equal inputs, equal outputs."""
    n = q.shape[0]
    out = np.zeros((n, 3))
    pi = math.pi
    symmetric = i == k
    if symmetric:
        k = 3 - i - j
    sign = (i - j) * (j - k) * (k - i) // 2
    third_index = 2 if extrinsic else 0
    e = np.empty(3)
    for t in range(n):
        if (t >= stride > 0 and bits[t, 0] == bits[t - stride, 0] and bits[t, 1] == bits[t - stride, 1]
                and bits[t, 2] == bits[t - stride, 2] and bits[t, 3] == bits[t - stride, 3]):
            out[t, 0], out[t, 1], out[t, 2] = out[t - stride, 0], out[t - stride, 1], out[t - stride, 2]
            continue
        w, x, y, z = q[t, 0], q[t, 1], q[t, 2], q[t, 3]
        norm = math.sqrt(x * x + y * y + z * z + w * w)
        if norm == 0.0:
            return out, False
        e[0], e[1], e[2] = x / norm, y / norm, z / norm
        w = w / norm
        qi, qj, qk = e[i], e[j], e[k]
        if symmetric:
            a, b, c, d = w, qi, qj, qk * sign
        else:
            a, b, c, d = w - qj, qi + qk * sign, qj + w, qk * sign - qi
        second = 2 * math.atan2(math.hypot(c, d), math.hypot(a, b))
        half_sum = math.atan2(b, a)
        half_diff = math.atan2(d, c)
        angles = (0.0, second, 0.0)
        if abs(second) <= 1e-7:
            angles = (2 * half_sum, second, 0.0)
        elif abs(second - pi) <= 1e-7:
            angles = (2 * half_diff * (-1 if extrinsic else 1), second, 0.0)
        elif extrinsic:
            angles = (half_sum - half_diff, second, half_sum + half_diff)
        else:
            angles = (half_sum + half_diff, second, half_sum - half_diff)
        for index in range(3):
            angle = angles[index]
            if not symmetric:
                if index == third_index:
                    angle *= sign
                elif index == 1:
                    angle -= pi / 2
            if angle < -pi:
                angle += 2 * pi
            elif angle > pi:
                angle -= 2 * pi
            out[t, index] = angle
    return out, True


@njit(cache=True)
def _to_int(x: float) -> int:
    """np.round(x).astype(np.int64) of one value: round half to even; out of int64's range (or NaN) the
    x86 conversion's answer, -2**63, as NumPy's cast gives there."""
    r = np.rint(x)
    if not -9.223372036854775e18 <= r <= 9.223372036854775e18:
        return -9223372036854775807 - 1
    return int(r)


@njit(cache=True)
def motion_values(angles, translation, source, steps, is_angle, q, rotation_unit, translation_unit, period,
                  first, key_order, key_bone, key_bit):
    """The BBA encoder's values and mask (comparisons/params/bba.py `_motion_arrays`) from the Euler split.

    angles (K, B, 3) radians, translation (K, 3) metres; source (C,) each candidate column's index in
    [translation (3), bone j axis a (3 + 3 j + a)]; steps (C,) base steps; is_angle (C,); q the global
    quantisation; first (C,) each column's first column of its (boneID, bit); key_order (U,) the first
    columns sorted by (boneID, bit), key_bone / key_bit (U,) theirs. Values are round(angle / rotation_unit)
    and round(translation / translation_unit) (np.round: half to even). A column is sent when a frame's
    value, folded into (-period / 2, period / 2] where it is an angle, quantises to a non-zero level at
    steps * q, i.e. 2 |v| > steps * q (param_coding.quantize); a value out of int64's range (-2**63) is sent,
    so that the writer rejects it. Returns (values (K, P) int64 of the sent
    (boneID, bit) in stream order, bones (M,) int64 ascending with masks (M,) int64 their sent bits, and
    order (M,) each bone's first sent column: `_motion_arrays` builds its mask dict in that order)."""
    n, n_bones = angles.shape[0], angles.shape[1]
    n_columns = len(source)
    raw = np.empty((n, 3 + 3 * n_bones), np.int64)
    for t in range(n):
        for a in range(3):
            raw[t, a] = _to_int(translation[t, a] / translation_unit)
        for b in range(n_bones):
            for a in range(3):
                raw[t, 3 + 3 * b + a] = _to_int(angles[t, b, a] / rotation_unit)
    half = period // 2
    sent = np.zeros(n_columns, np.bool_)
    sent_at = np.full(n_columns, n_columns, np.int64)      # key (its first column) -> first sent column of it
    for c in range(n_columns):
        limit = steps[c] * q
        s = source[c]
        for t in range(n):
            v = raw[t, s]
            if is_angle[c]:
                v = half - (half - v) % period
            if abs(v) > limit // 2 or v == -9223372036854775807 - 1:    # 2 |v| > limit, without overflow
                sent[first[c]] = True
                sent_at[first[c]] = min(sent_at[first[c]], c)
                break
    n_sent = 0
    n_masks = 0
    last = 0
    for u in range(len(key_order)):
        if sent[key_order[u]]:
            n_sent += 1
            if n_sent == 1 or key_bone[u] != key_bone[last]:
                n_masks += 1
            last = u
    values = np.empty((n, n_sent), np.int64)
    bones = np.empty(n_masks, np.int64)
    masks = np.zeros(n_masks, np.int64)
    order = np.full(n_masks, n_columns, np.int64)
    p = 0
    m = -1
    for u in range(len(key_order)):
        c = key_order[u]
        if sent[c]:
            if m < 0 or key_bone[u] != bones[m]:
                m += 1
                bones[m] = key_bone[u]
            masks[m] |= np.int64(1) << key_bit[u]
            order[m] = min(order[m], sent_at[c])
            s = source[c]
            for t in range(n):
                values[t, p] = raw[t, s]
            p += 1
    return values, bones, masks, order

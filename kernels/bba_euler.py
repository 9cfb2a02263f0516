"""Numba kernel of the BBA encoder's Euler split: quaternions -> Euler angles, bitwise scipy's as_euler.

`euler_angles` does what media/rotations.py `to_euler` does through scipy 1.17 (Rotation.from_quat, then
as_euler of the Cython backend, `_rotation_cy`): from_quat's normalisation (sqrt((x x + y y + z z) + w w),
then each component divided), then Bernardes & Viollet 2022 (PLoS ONE 17(11): e0276302) as scipy writes
it: the sequence as extrinsic axes (i, j, k) (an intrinsic sequence reversed), the quaternion's elements
permuted into a, b, c, d, the second angle 2 atan2(hypot(c, d), hypot(a, b)), the half sum and half
difference atan2(b, a) and atan2(d, c), scipy's gimbal-lock cases (second angle within 1e-7 of 0 or pi:
the third angle 0), the Tait-Bryan correction and the wrap into [-pi, pi]. Every operation is the same
IEEE operation in the same order and atan2 / hypot are libm's, as scipy's, so the angles are bitwise
scipy's (kernels/lab_rotations.py does the same for one sequence; tests/test_bba_encode_speed.py checks
this one against scipy, gimbal lock included). A zero quaternion (scipy raises) is reported, not divided.
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

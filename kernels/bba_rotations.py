"""Numba-compiled Euler angles -> quaternions of the BBA decoder (comparisons/bba_codec.py `stream_to_motion`).

`from_euler` is scipy 1.17's Rotation.from_euler(sequence, angles).as_quat(canonical=True) (what
media.rotations.from_euler calls) operation for operation, so its results are bitwise scipy's: per angle
an elementary quaternion (cos(a / 2), sin(a / 2) along its axis), composed left to right for intrinsic
(rotating-frame) sequences and right to left for extrinsic (static-frame) ones with scipy's product
(vector part p_w q_v + q_w p_v + p_v x q_v, scalar part p_w q_w - p_v . q_v, in that order of terms), not
normalised, then made canonical (w > 0, or the first non-zero of x, y, z positive where w = 0). Output
is (w, x, y, z), media/rotations.py's convention. tests/test_bba_speed_identity.py compares it with scipy
bitwise on random angles in all 24 orders. Imports nothing of signcast.
"""
import math

import numpy as np
from numba import njit


@njit(cache=True)
def from_euler(angles: np.ndarray, axes: np.ndarray, intrinsic: bool) -> np.ndarray:
    """angles (N, 3) float64 radians, axes (3,) int64 (0 x, 1 y, 2 z) -> (N, 4) (w, x, y, z) canonical."""
    n = angles.shape[0]
    out = np.empty((n, 4))
    p = np.empty(4)       # (x, y, z, w) as scipy keeps them
    e = np.empty(4)
    for i in range(n):
        p[0] = p[1] = p[2] = 0.0
        p[3] = math.cos(angles[i, 0] / 2.0)
        p[axes[0]] = math.sin(angles[i, 0] / 2.0)
        for k in range(1, 3):
            e[0] = e[1] = e[2] = 0.0
            e[3] = math.cos(angles[i, k] / 2.0)
            e[axes[k]] = math.sin(angles[i, k] / 2.0)
            if intrinsic:
                ax, ay, az, aw, bx, by, bz, bw = p[0], p[1], p[2], p[3], e[0], e[1], e[2], e[3]
            else:
                ax, ay, az, aw, bx, by, bz, bw = e[0], e[1], e[2], e[3], p[0], p[1], p[2], p[3]
            cx = ay * bz - az * by
            cy = az * bx - ax * bz
            cz = ax * by - ay * bx
            p[0] = aw * bx + bw * ax + cx
            p[1] = aw * by + bw * ay + cy
            p[2] = aw * bz + bw * az + cz
            p[3] = aw * bw - ax * bx - ay * by - az * bz
        x, y, z, w = p[0], p[1], p[2], p[3]
        flip = w < 0.0 or (w == 0.0 and (x < 0.0 or (x == 0.0 and (y < 0.0 or (y == 0.0 and z < 0.0)))))
        if flip:
            w, x, y, z = -w, -x, -y, -z
        out[i, 0], out[i, 1], out[i, 2], out[i, 3] = w, x, y, z
    return out

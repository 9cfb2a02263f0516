"""Numba-compiled Euler angles -> quaternions of the BBA decoder (comparisons/params/bba.py `stream_to_motion`).

`from_euler` is scipy 1.17's Rotation.from_euler(sequence, angles).as_quat(canonical=True) (what
media.rotations.from_euler calls) operation for operation, so its results are bitwise scipy's: per angle
an elementary quaternion (cos(a / 2), sin(a / 2) along its axis), composed left to right for intrinsic
(rotating-frame) sequences and right to left for extrinsic (static-frame) ones with scipy's product
(vector part p_w q_v + q_w p_v + p_v x q_v, scalar part p_w q_w - p_v . q_v, in that order of terms), not
normalised, then made canonical (w > 0, or the first non-zero of x, y, z positive where w = 0). Output
is (w, x, y, z), media/rotations.py's convention. tests/test_bba_speed_identity.py compares it with scipy
bitwise on random angles in all 24 orders. `from_euler_table` is from_euler of a decoder's held-value table
(angle units x the unit), reusing a column's cosine and sine while its value is held (bitwise the same:
tests/test_bba_decode_speed.py). Imports nothing of signcast.
"""
import math

import numpy as np
from numba import njit


@njit(cache=True, inline="always")
def _compose(cos0: float, sin0: float, cos1: float, sin1: float, cos2: float, sin2: float, axes, intrinsic: bool,
             out, i: int) -> None:
    """out[i] = the canonical (w, x, y, z) of the three elementary quaternions (cos(a_k / 2), sin(a_k / 2) along
    axes[k]) composed in scipy's order and with scipy's products."""
    p0, p1, p2, p3 = 0.0, 0.0, 0.0, cos0       # (x, y, z, w) as scipy keeps them
    if axes[0] == 0:
        p0 = sin0
    elif axes[0] == 1:
        p1 = sin0
    else:
        p2 = sin0
    for k in range(1, 3):
        e0, e1, e2 = 0.0, 0.0, 0.0
        e3 = cos1 if k == 1 else cos2
        sin_k = sin1 if k == 1 else sin2
        if axes[k] == 0:
            e0 = sin_k
        elif axes[k] == 1:
            e1 = sin_k
        else:
            e2 = sin_k
        if intrinsic:
            ax, ay, az, aw, bx, by, bz, bw = p0, p1, p2, p3, e0, e1, e2, e3
        else:
            ax, ay, az, aw, bx, by, bz, bw = e0, e1, e2, e3, p0, p1, p2, p3
        cx = ay * bz - az * by
        cy = az * bx - ax * bz
        cz = ax * by - ay * bx
        p0 = aw * bx + bw * ax + cx
        p1 = aw * by + bw * ay + cy
        p2 = aw * bz + bw * az + cz
        p3 = aw * bw - ax * bx - ay * by - az * bz
    x, y, z, w = p0, p1, p2, p3
    flip = w < 0.0 or (w == 0.0 and (x < 0.0 or (x == 0.0 and (y < 0.0 or (y == 0.0 and z < 0.0)))))
    if flip:
        w, x, y, z = -w, -x, -y, -z
    out[i, 0], out[i, 1], out[i, 2], out[i, 3] = w, x, y, z


@njit(cache=True)
def from_euler(angles: np.ndarray, axes: np.ndarray, intrinsic: bool) -> np.ndarray:
    """angles (N, 3) float64 radians, axes (3,) int64 (0 x, 1 y, 2 z) -> (N, 4) (w, x, y, z) canonical."""
    n = angles.shape[0]
    out = np.empty((n, 4))
    for i in range(n):
        _compose(math.cos(angles[i, 0] / 2.0), math.sin(angles[i, 0] / 2.0), math.cos(angles[i, 1] / 2.0),
                 math.sin(angles[i, 1] / 2.0), math.cos(angles[i, 2] / 2.0), math.sin(angles[i, 2] / 2.0), axes,
                 intrinsic, out, i)
    return out


@njit(cache=True)
def from_euler_table(table: np.ndarray, n_rotated: int, unit: float, axes: np.ndarray, intrinsic: bool) -> np.ndarray:
    """from_euler of the angles table[:, :3 R] x unit (R = n_rotated; table (F, C) float64 in angle units,
    column 3 r + k angle k of bone r) -> (F, R, 4). The cosine and sine of an angle equal (and non-zero) to
    the same column's in the frame before are that frame's (the same function of the same value), not
    computed again, and zero angles take cos 1 and sin +-0: held and zero values cost no transcendentals."""
    n_frames = table.shape[0]
    out = np.empty((n_frames * n_rotated, 4))
    n_columns = 3 * n_rotated
    last = np.zeros(n_columns)                 # the angle (0: none) whose cos, sin are held
    cos_half, sin_half = np.empty(n_columns), np.empty(n_columns)
    for f in range(n_frames):
        for c in range(n_columns):
            angle = table[f, c] * unit
            if angle == 0.0:                   # cos(+-0) = 1 and sin(+-0) = +-0 exactly: no libm call
                cos_half[c] = 1.0
                sin_half[c] = angle / 2.0
                last[c] = 0.0
            elif angle != last[c]:
                cos_half[c] = math.cos(angle / 2.0)
                sin_half[c] = math.sin(angle / 2.0)
                last[c] = angle
        for r in range(n_rotated):
            _compose(cos_half[3 * r], sin_half[3 * r], cos_half[3 * r + 1], sin_half[3 * r + 1], cos_half[3 * r + 2],
                     sin_half[3 * r + 2], axes, intrinsic, out, f * n_rotated + r)
    return out.reshape(n_frames, n_rotated, 4)

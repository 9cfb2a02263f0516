"""Numba kernel of the face rig's turns (media/face_rig.py): rotation vectors -> quaternions, bitwise scipy's.

`from_rotvec` is scipy 1.17's Rotation.from_rotvec (Cython backend) followed by as_quat in (w, x, y, z) order:
the angle is sqrt((x x + y y) + z z); below 1e-3 rad the scale sin(angle / 2) / angle is its Taylor
series 0.5 - angle^2 / 48 + angle^4 / 3840 (scipy's), else sin(angle / 2) / angle; w = cos(angle / 2).
sin and cos are libm's, as scipy's, so the quaternions are bitwise scipy's (tests/test_face_rig_speed.py
checks it on random and real rotation vectors).
"""
import math

import numpy as np
from numba import njit


@njit(cache=True)
def from_rotvec(rotvec: np.ndarray) -> np.ndarray:
    """rotvec (N, 3) radians (axis times angle) -> (N, 4) float64 quaternions (w, x, y, z)."""
    n = rotvec.shape[0]
    out = np.empty((n, 4))
    for t in range(n):
        x, y, z = rotvec[t, 0], rotvec[t, 1], rotvec[t, 2]
        angle = math.sqrt(x * x + y * y + z * z)
        if angle <= 1e-3:
            angle2 = angle * angle
            scale = 0.5 - angle2 / 48 + angle2 * angle2 / 3840
        else:
            scale = math.sin(angle / 2) / angle
        out[t, 0] = math.cos(angle / 2)
        out[t, 1], out[t, 2], out[t, 3] = scale * x, scale * y, scale * z
    return out

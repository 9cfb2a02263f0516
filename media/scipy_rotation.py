"""Numba kernels of media/rotations.py's scipy calls, operation for operation, so bitwise scipy 1.17's (its Cython
backend, `_rotation_cy`), without scipy's per-call cost (tens of microseconds on the retargeter's small arrays).

`rotate` is Rotation.from_quat(q).apply(v) for many rotations. from_quat divides each quaternion by
sqrt(((x x + y y) + z z) + w w) (zero norm: scipy raises; reported here, not divided); as_matrix builds the matrix
from the squares and products of the unit quaternion's components (x2 - y2 - z2 + w2, 2 (xy - zw), ...); apply, for
a stack of rotations and as many vectors, is np.einsum('ijk,ik->ij'). For C-contiguous vectors its SIMD loop
(NumPy 2, x86 with AVX2 or AVX-512) puts the three products in lanes 0-2 of a zeroed register and reduces the
halves first: (m[j, 0] v[0] + m[j, 2] v[2]) + m[j, 1] v[1], then adds it to the zeroed output (+ 0.0: a -0 becomes
+0). Vectors in another layout take einsum's plain loop, which sums in index order, and a single vector goes
through np.matmul (BLAS): the caller keeps those cases for scipy.

`from_rotvec` is Rotation.from_rotvec then as_quat in (w, x, y, z) order: angle = sqrt((x x + y y) + z z), scale
= sin(angle / 2) / angle (the series 0.5 - a2 / 48 + a2 a2 / 3840 at or below 1e-3 rad), the quaternion
(cos(angle / 2), scale x, scale y, scale z); sin and cos are libm's, as scipy's. `from_axis_angle` is
media/rotations.py's axis / max(|axis|, 1e-300) * angle (NumPy's norm of three: the sum (x x + y y) + z z), then
`from_rotvec`.

`cross` is np.cross of 3-vectors (each component one product less another, as NumPy computes it), and
`multiply` is media/rotations.py's Hamilton product, each component's four products summed left to right as
NumPy evaluates the expression.

`axis_matrices` is media/ik.py's Rodrigues matrices cos I + sin [a]x + (1 - cos) a a^T as NumPy broadcasts them,
element by element in the same order (the products with the zeros of I and [a]x included, so the signs of
zeros too); NumPy's float64 sin and cos are libm's on these machines, as Numba's (tests/test_ik.py checks the
matrices bitwise).

tests/test_rotations.py compares rotate, from_axis_angle and multiply with scipy or NumPy bitwise on random and edge-case inputs. Imports
nothing of signcast.
"""
import math

import numpy as np
from numba import njit


@njit(cache=True)
def rotate(q, v):
    """q (N, 4) float64 quaternions (w, x, y, z), not necessarily unit; v (N, 3) float64 vectors. Returns
    (rotated (N, 3), ok): ok False when a quaternion has zero norm (scipy raises; the caller asks it)."""
    n = q.shape[0]
    out = np.empty((n, 3))
    for t in range(n):
        w, x, y, z = q[t, 0], q[t, 1], q[t, 2], q[t, 3]
        norm = math.sqrt(x * x + y * y + z * z + w * w)
        if norm == 0.0:
            return out, False
        x, y, z, w = x / norm, y / norm, z / norm, w / norm
        x2, y2, z2, w2 = x * x, y * y, z * z, w * w
        xy, zw, xz, yw, yz, xw = x * y, z * w, x * z, y * w, y * z, x * w
        m00, m01, m02 = x2 - y2 - z2 + w2, 2.0 * (xy - zw), 2.0 * (xz + yw)
        m10, m11, m12 = 2.0 * (xy + zw), -x2 + y2 - z2 + w2, 2.0 * (yz - xw)
        m20, m21, m22 = 2.0 * (xz - yw), 2.0 * (yz + xw), -x2 - y2 + z2 + w2
        v0, v1, v2 = v[t, 0], v[t, 1], v[t, 2]
        out[t, 0] = ((m00 * v0 + m02 * v2) + m01 * v1) + 0.0
        out[t, 1] = ((m10 * v0 + m12 * v2) + m11 * v1) + 0.0
        out[t, 2] = ((m20 * v0 + m22 * v2) + m21 * v1) + 0.0
    return out, True


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


@njit(cache=True)
def from_axis_angle(axis, angle):
    """axis (N, 3) float64, need not be unit (a zero axis gives the identity); angle (N,) float64 radians. Returns
    (N, 4) (w, x, y, z) quaternions (cos(angle / 2), sin(angle / 2) unit axis): `from_rotvec` of the unit axis
    times the angle."""
    n = axis.shape[0]
    rotvec = np.empty((n, 3))
    for t in range(n):
        a0, a1, a2 = axis[t, 0], axis[t, 1], axis[t, 2]
        length = math.sqrt((a0 * a0 + a1 * a1) + a2 * a2)
        if not length >= 1e-300 and not math.isnan(length):         # np.maximum(length, 1e-300), NaN kept
            length = 1e-300
        rotvec[t, 0], rotvec[t, 1], rotvec[t, 2] = a0 / length * angle[t], a1 / length * angle[t], a2 / length * angle[t]
    return from_rotvec(rotvec)


@njit(cache=True)
def axis_matrices(axes, angles):
    """axes (K, 3) float64 unit axes, angles (T, K) float64 radians -> (T, K, 3, 3) rotation about each axis by
    each angle: (cos I + sin [axis]x) + (1 - cos) axis axis^T, entry by entry."""
    n_frames, n_axes = angles.shape
    out = np.empty((n_frames, n_axes, 3, 3))
    cross = np.zeros((n_axes, 3, 3))
    for k in range(n_axes):
        cross[k, 0, 1], cross[k, 0, 2], cross[k, 1, 2] = -axes[k, 2], axes[k, 1], -axes[k, 0]
        cross[k, 1, 0], cross[k, 2, 0], cross[k, 2, 1] = axes[k, 2], -axes[k, 1], axes[k, 0]
    for t in range(n_frames):
        for k in range(n_axes):
            sin, cos = math.sin(angles[t, k]), math.cos(angles[t, k])
            for r in range(3):
                for c in range(3):
                    identity = 1.0 if r == c else 0.0
                    out[t, k, r, c] = (cos * identity + sin * cross[k, r, c]) + (1.0 - cos) * (axes[k, r] * axes[k, c])
    return out


@njit(cache=True)
def multiply(a, b):
    """Hamilton products a * b of (N, 4) float64 quaternions (w, x, y, z) row by row -> (N, 4)."""
    n = a.shape[0]
    out = np.empty((n, 4))
    for t in range(n):
        aw, ax, ay, az = a[t, 0], a[t, 1], a[t, 2], a[t, 3]
        bw, bx, by, bz = b[t, 0], b[t, 1], b[t, 2], b[t, 3]
        out[t, 0] = aw * bw - ax * bx - ay * by - az * bz
        out[t, 1] = aw * bx + ax * bw + ay * bz - az * by
        out[t, 2] = aw * by - ax * bz + ay * bw + az * bx
        out[t, 3] = aw * bz + ax * by - ay * bx + az * bw
    return out


@njit(cache=True)
def cross(a, b):
    """a x b of (N, 3) float64 vectors row by row -> (N, 3): a1 b2 - a2 b1, a2 b0 - a0 b2, a0 b1 - a1 b0."""
    n = a.shape[0]
    out = np.empty((n, 3))
    for t in range(n):
        a0, a1, a2 = a[t, 0], a[t, 1], a[t, 2]
        b0, b1, b2 = b[t, 0], b[t, 1], b[t, 2]
        out[t, 0] = a1 * b2 - a2 * b1
        out[t, 1] = a2 * b0 - a0 * b2
        out[t, 2] = a0 * b1 - a1 * b0
    return out

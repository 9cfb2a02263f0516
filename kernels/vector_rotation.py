"""Numba kernel of media/rotations.py `rotate` for many rotations: scipy 1.17's Rotation.from_quat(q).apply(v),
operation for operation, so bitwise scipy's.

From scipy's Cython backend (`_rotation_cy`): from_quat divides each quaternion by
sqrt(((x x + y y) + z z) + w w) (zero norm: scipy raises; reported here, not divided); as_matrix builds the matrix
from the squares and products of the unit quaternion's components (x2 - y2 - z2 + w2, 2 (xy - zw), ...); apply, for
a stack of rotations and as many vectors, is np.einsum('ijk,ik->ij'). For C-contiguous vectors its SIMD loop
(NumPy 2, x86 with AVX2 or AVX-512) puts the three products in lanes 0-2 of a zeroed register and reduces the
halves first: (m[j, 0] v[0] + m[j, 2] v[2]) + m[j, 1] v[1], then adds it to the zeroed output (+ 0.0: a -0 becomes
+0). Vectors in another layout take einsum's plain loop, which sums in index order, and a single vector goes
through np.matmul (BLAS): the caller keeps those cases for scipy. tests/test_rotations.py compares the kernel with scipy bitwise on random and
edge-case inputs. Imports nothing of signcast.
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

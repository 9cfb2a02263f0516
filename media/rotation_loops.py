"""Compiled loops behind media/rotations.py where scipy's per-call cost or a missing batch form would dominate.

scipy.spatial.transform.Rotation costs tens of microseconds a call on the retargeter's and face rig's small
arrays, and its from_euler about 1.7 us a rotation (scipy 1.17), too slow for the BBA decoder; these loops do the
same conversions in one compiled pass over frames. They are signcast's own code, written in the textbook form
(Hamilton products, Rodrigues' formula, q v q^-1 as v + 2 w (u x v) + 2 u x (u x v), the Euler split of
Bernardes & Viollet 2022, PLoS ONE 17(11): e0276302), not in any other library's order of operations: they agree
with scipy to rounding, and tests/test_rotations.py checks them against scipy and NumPy within 1e-12 (quaternion
components, vector components of unit-scale vectors, radians away from gimbal lock).

Quaternions are (w, x, y, z) rows of float64 arrays; axes are indices 0 x, 1 y, 2 z. Imports nothing of signcast.
"""
import math

import numpy as np
from numba import njit


@njit(cache=True)
def multiply(a, b):
    """Hamilton products a * b of (N, 4) quaternions row by row -> (N, 4)."""
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
    """a x b of (N, 3) vectors row by row -> (N, 3)."""
    n = a.shape[0]
    out = np.empty((n, 3))
    for t in range(n):
        out[t, 0] = a[t, 1] * b[t, 2] - a[t, 2] * b[t, 1]
        out[t, 1] = a[t, 2] * b[t, 0] - a[t, 0] * b[t, 2]
        out[t, 2] = a[t, 0] * b[t, 1] - a[t, 1] * b[t, 0]
    return out


@njit(cache=True)
def rotate(q, v):
    """q (N, 4) quaternions, not necessarily unit (each is normalised); v (N, 3) -> (rotated (N, 3), ok): ok False
    when a quaternion has zero norm (the caller raises). v' = v + 2 w (u x v) + 2 u x (u x v), u the vector part."""
    n = q.shape[0]
    out = np.empty((n, 3))
    for t in range(n):
        w, x, y, z = q[t, 0], q[t, 1], q[t, 2], q[t, 3]
        norm = math.sqrt(w * w + x * x + y * y + z * z)
        if norm == 0.0:
            return out, False
        w, x, y, z = w / norm, x / norm, y / norm, z / norm
        v0, v1, v2 = v[t, 0], v[t, 1], v[t, 2]
        c0, c1, c2 = 2.0 * (y * v2 - z * v1), 2.0 * (z * v0 - x * v2), 2.0 * (x * v1 - y * v0)
        out[t, 0] = v0 + w * c0 + (y * c2 - z * c1)
        out[t, 1] = v1 + w * c1 + (z * c0 - x * c2)
        out[t, 2] = v2 + w * c2 + (x * c1 - y * c0)
    return out, True


@njit(cache=True)
def from_rotvec(rotvec):
    """Rotation vectors (N, 3) radians (axis times angle) -> (N, 4) quaternions (cos(a / 2), sin(a / 2) axis)."""
    n = rotvec.shape[0]
    out = np.empty((n, 4))
    for t in range(n):
        x, y, z = rotvec[t, 0], rotvec[t, 1], rotvec[t, 2]
        angle = math.sqrt(x * x + y * y + z * z)
        if angle < 1e-4:                       # sin(a / 2) / a by its series: exact to rounding below 1e-4
            scale = 0.5 - angle * angle / 48.0
        else:
            scale = math.sin(0.5 * angle) / angle
        out[t, 0] = math.cos(0.5 * angle)
        out[t, 1], out[t, 2], out[t, 3] = scale * x, scale * y, scale * z
    return out


@njit(cache=True)
def from_axis_angle(axis, angle):
    """axis (N, 3), need not be unit (a zero axis gives the identity); angle (N,) radians -> (N, 4)."""
    n = axis.shape[0]
    out = np.empty((n, 4))
    for t in range(n):
        a0, a1, a2 = axis[t, 0], axis[t, 1], axis[t, 2]
        length = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
        half = 0.5 * angle[t]
        s = math.sin(half) / length if length > 0.0 else 0.0
        out[t, 0] = math.cos(half) if length > 0.0 else 1.0
        out[t, 1], out[t, 2], out[t, 3] = s * a0, s * a1, s * a2
    return out


@njit(cache=True)
def axis_matrices(axes, angles):
    """axes (K, 3) unit, angles (T, K) radians -> (T, K, 3, 3) rotations about each axis by each angle
    (Rodrigues: cos I + sin [a]x + (1 - cos) a a^T)."""
    n_frames, n_axes = angles.shape
    out = np.empty((n_frames, n_axes, 3, 3))
    for t in range(n_frames):
        for k in range(n_axes):
            s, c = math.sin(angles[t, k]), math.cos(angles[t, k])
            x, y, z = axes[k, 0], axes[k, 1], axes[k, 2]
            v = 1.0 - c
            out[t, k, 0, 0], out[t, k, 0, 1], out[t, k, 0, 2] = c + v * x * x, v * x * y - s * z, v * x * z + s * y
            out[t, k, 1, 0], out[t, k, 1, 1], out[t, k, 1, 2] = v * x * y + s * z, c + v * y * y, v * y * z - s * x
            out[t, k, 2, 0], out[t, k, 2, 1], out[t, k, 2, 2] = v * x * z - s * y, v * y * z + s * x, c + v * z * z
    return out


@njit(cache=True, inline="always")
def _compose(cos_half, sin_half, c0, c1, c2, axes, intrinsic, out, i):
    """out[i] = the (w, x, y, z), w >= 0, of the three elementary rotations (cos, sin of half angle c0, c1, c2 of
    cos_half / sin_half, about axes[0], axes[1], axes[2]) composed: first applied first, about the moving axes
    (intrinsic: q0 q1 q2) or the fixed ones (q2 q1 q0)."""
    w, x, y, z = cos_half[c0], 0.0, 0.0, 0.0
    if axes[0] == 0:
        x = sin_half[c0]
    elif axes[0] == 1:
        y = sin_half[c0]
    else:
        z = sin_half[c0]
    for k in range(1, 3):
        c = c1 if k == 1 else c2
        ew, ex, ey, ez = cos_half[c], 0.0, 0.0, 0.0
        if axes[k] == 0:
            ex = sin_half[c]
        elif axes[k] == 1:
            ey = sin_half[c]
        else:
            ez = sin_half[c]
        if intrinsic:                          # p e
            aw, ax, ay, az, bw, bx, by, bz = w, x, y, z, ew, ex, ey, ez
        else:                                  # e p
            aw, ax, ay, az, bw, bx, by, bz = ew, ex, ey, ez, w, x, y, z
        w = aw * bw - ax * bx - ay * by - az * bz
        x = aw * bx + ax * bw + ay * bz - az * by
        y = aw * by - ax * bz + ay * bw + az * bx
        z = aw * bz + ax * by - ay * bx + az * bw
    if w < 0.0:
        w, x, y, z = -w, -x, -y, -z
    out[i, 0], out[i, 1], out[i, 2], out[i, 3] = w, x, y, z


@njit(cache=True)
def from_euler(angles, axes, intrinsic):
    """angles (N, 3) radians, axes (3,) int64 -> (N, 4) quaternions, w >= 0."""
    n = angles.shape[0]
    out = np.empty((n, 4))
    cos_half, sin_half = np.empty(3), np.empty(3)
    for i in range(n):
        for k in range(3):
            cos_half[k], sin_half[k] = math.cos(0.5 * angles[i, k]), math.sin(0.5 * angles[i, k])
        _compose(cos_half, sin_half, 0, 1, 2, axes, intrinsic, out, i)
    return out


@njit(cache=True)
def from_euler_table(table, n_rotated, unit, axes, intrinsic):
    """from_euler of the angles table[:, :3 R] x unit (table (F, C) in angle units, column 3 r + k angle k of
    rotated bone r, R = n_rotated) -> (F, R, 4). A column whose value is the one of the frame before (a held
    value, about half of signing's) reuses that frame's cosine and sine."""
    n_frames = table.shape[0]
    n_columns = 3 * n_rotated
    out = np.empty((n_frames * n_rotated, 4))
    cos_half, sin_half = np.ones(n_columns), np.zeros(n_columns)
    last = np.zeros(n_columns)
    for f in range(n_frames):
        for c in range(n_columns):
            value = table[f, c]
            if value != last[c]:
                cos_half[c], sin_half[c] = math.cos(0.5 * value * unit), math.sin(0.5 * value * unit)
                last[c] = value
        for r in range(n_rotated):
            _compose(cos_half, sin_half, 3 * r, 3 * r + 1, 3 * r + 2, axes, intrinsic, out, f * n_rotated + r)
    return out.reshape(n_frames, n_rotated, 4)


# atan2_series: atan2 of y / x folded onto [0, pi / 8] (the octant, then t -> (t - 1) / (t + 1) above tan(pi / 8), then
# the half-angle step u -> u / (1 + sqrt(1 + u^2)), |v| <= tan(pi / 16)), where the Taylor series to v^23 is below one
# ulp (its first omitted term, v^25 / 25, is < 1e-19 of v). No call and no branch: the loops that use it vectorise
# (about 2.5 ns a value against 21 ns for glibc's atan2, which the compiler cannot vectorise).
TAN_PI_8 = math.sqrt(2.0) - 1.0


@njit(cache=True, inline="always", error_model="numpy")
def atan2_series(y, x):
    """atan2(y, x) in radians, [-pi, pi], of finite y, x: within 5e-16 rad of glibc's (tests/test_rotations.py, 1e5
    pairs over ten decades), signed zeros and the axes exact (atan2(0, -1) = pi, atan2(-0.0, -1) = -pi)."""
    ax, ay = abs(x), abs(y)
    t = min(ax, ay) / max(max(ax, ay), 1e-300)
    far = t > TAN_PI_8
    u = (t - 1.0) / (t + 1.0) if far else t
    v = u / (1.0 + math.sqrt(1.0 + u * u))
    v2 = v * v
    series = 1.0 / 23.0
    for n in range(21, 0, -2):
        series = 1.0 / n - v2 * series
    angle = 2.0 * v * series + (0.25 * math.pi if far else 0.0)
    angle = 0.5 * math.pi - angle if ay > ax else angle
    angle = math.pi - angle if math.copysign(1.0, x) < 0.0 else angle
    return -angle if math.copysign(1.0, y) < 0.0 else angle


@njit(cache=True, inline="always")
def _wrap(angle):
    """angle folded into [-pi, pi]."""
    if angle < -math.pi:
        return angle + 2.0 * math.pi
    if angle > math.pi:
        return angle - 2.0 * math.pi
    return angle


@njit(cache=True, inline="always")
def _permuted(w, x, y, z, i, j, k):
    """Bernardes & Viollet's (a, b, c, d) of a quaternion (w, x, y, z) for the fixed axes (i, j, k) (k = i: a
    proper Euler sequence), scaled by its largest component (the angles do not depend on the scale; the squares
    that follow then neither overflow nor vanish)."""
    scale = 1.0 / max(max(abs(w), abs(x)), max(abs(y), abs(z)))
    symmetric = i == k
    if symmetric:
        k = 3 - i - j
    sign = (i - j) * (j - k) * (k - i) // 2
    qi = scale * (x if i == 0 else (y if i == 1 else z))
    qj = scale * (x if j == 0 else (y if j == 1 else z))
    qk = scale * (x if k == 0 else (y if k == 1 else z)) * sign
    w = scale * w
    if symmetric:
        return w, qi, qj, qk
    return w - qj, qi + qk, qj + w, qk - qi


@njit(cache=True, inline="always")
def _assembled(second, half_sum, half_diff, i, j, k, extrinsic):
    """The three angles (the sequence's order) from the middle angle 2 atan2(|(c, d)|, |(a, b)|) and the half sum
    atan2(b, a) and half difference atan2(d, c) of the outer ones: angles 1 and 3 in [-pi, pi], angle 2 in
    [-pi / 2, pi / 2] (Tait-Bryan) or [0, pi] (proper Euler); within 1e-7 of gimbal lock the third angle is 0."""
    symmetric = i == k
    if symmetric:
        k = 3 - i - j
    sign = (i - j) * (j - k) * (k - i) // 2
    if abs(second) <= 1e-7:
        first, last = 2.0 * half_sum, 0.0
    elif abs(second - math.pi) <= 1e-7:
        first, last = (-2.0 if extrinsic else 2.0) * half_diff, 0.0
    elif extrinsic:
        first, last = half_sum - half_diff, half_sum + half_diff
    else:
        first, last = half_sum + half_diff, half_sum - half_diff
    if not symmetric:
        second -= 0.5 * math.pi
        if extrinsic:
            last *= sign
        else:
            first *= sign
    return _wrap(first), _wrap(second), _wrap(last)


@njit(cache=True, inline="always")
def euler_of(w, x, y, z, i, j, k, extrinsic):
    """The Euler angles (radians, the sequence's order) of one quaternion (w, x, y, z), not necessarily unit but not
    zero; (i, j, k) the sequence as fixed axes (an intrinsic sequence reversed), extrinsic whether it was
    (`_assembled` gives the ranges). Bernardes & Viollet 2022: the quaternion permuted to (a, b, c, d), the middle
    angle 2 atan2(|(c, d)|, |(a, b)|), the outer angles from atan2(b, a) +- atan2(d, c)."""
    a, b, c, d = _permuted(w, x, y, z, i, j, k)
    second = 2.0 * atan2_series(math.sqrt(c * c + d * d), math.sqrt(a * a + b * b))
    return _assembled(second, atan2_series(b, a), atan2_series(d, c), i, j, k, extrinsic)


@njit(cache=True, error_model="numpy")
def to_euler(q, stride, i, j, k, extrinsic):
    """q (N, 4) quaternions, not necessarily unit -> (angles (N, 3) `euler_of` each, ok): ok False when a quaternion
    has zero norm (the caller raises). A row equal to the one `stride` rows before it (a bone held from the previous
    frame, rows frame-major; stride 0: none) takes its angles; a row with x = y = z = 0 (the identity, or its
    negative) is (0, 0, 0), as `euler_of` gives it. The other rows go through the three atan2 as one loop, which
    the compiler vectorises."""
    n = q.shape[0]
    out = np.zeros((n, 3))
    held = np.zeros(n, np.bool_)
    rows = np.empty(n, np.int64)
    m = 0
    for t in range(n):
        if (t >= stride > 0 and q[t, 0] == q[t - stride, 0] and q[t, 1] == q[t - stride, 1]
                and q[t, 2] == q[t - stride, 2] and q[t, 3] == q[t - stride, 3]):
            held[t] = True
        elif q[t, 1] != 0.0 or q[t, 2] != 0.0 or q[t, 3] != 0.0:
            rows[m] = t
            m += 1
        elif q[t, 0] == 0.0:
            return out, False
    middle, half_sum, half_diff = np.empty(m), np.empty(m), np.empty(m)
    permuted = np.empty((4, m))
    for r in range(m):
        t = rows[r]
        permuted[0, r], permuted[1, r], permuted[2, r], permuted[3, r] = _permuted(q[t, 0], q[t, 1], q[t, 2], q[t, 3],
                                                                                   i, j, k)
    a, b, c, d = permuted[0], permuted[1], permuted[2], permuted[3]
    for r in range(m):
        middle[r] = 2.0 * atan2_series(math.sqrt(c[r] * c[r] + d[r] * d[r]), math.sqrt(a[r] * a[r] + b[r] * b[r]))
        half_sum[r] = atan2_series(b[r], a[r])
        half_diff[r] = atan2_series(d[r], c[r])
    for r in range(m):
        t = rows[r]
        out[t, 0], out[t, 1], out[t, 2] = _assembled(middle[r], half_sum[r], half_diff[r], i, j, k, extrinsic)
    for t in range(n):
        if held[t]:
            out[t, 0], out[t, 1], out[t, 2] = out[t - stride, 0], out[t - stride, 1], out[t - stride, 2]
    return out, True


@njit(cache=True)
def slerp(q0, q1, t):
    """Spherical linear interpolation of (N, 4) unit quaternion pairs at t (N,) along the shortest arc -> (N, 4)
    unit, on q0's side of the sign; normalised linear interpolation where sin(alpha) < 1e-9 (media.rotations.slerp)."""
    n = q0.shape[0]
    out = np.empty((n, 4))
    for r in range(n):
        dot = q0[r, 0] * q1[r, 0] + q0[r, 1] * q1[r, 1] + q0[r, 2] * q1[r, 2] + q0[r, 3] * q1[r, 3]
        side = 1.0
        if dot < 0.0:
            side, dot = -1.0, -dot
        alpha = math.acos(min(dot, 1.0))
        sin_alpha = math.sin(alpha)
        if sin_alpha < 1e-9:
            w0, w1 = 1.0 - t[r], t[r]
        else:
            w0, w1 = math.sin((1.0 - t[r]) * alpha) / sin_alpha, math.sin(t[r] * alpha) / sin_alpha
        w1 *= side
        a, b = w0 * q0[r, 0] + w1 * q1[r, 0], w0 * q0[r, 1] + w1 * q1[r, 1]
        c, d = w0 * q0[r, 2] + w1 * q1[r, 2], w0 * q0[r, 3] + w1 * q1[r, 3]
        norm = math.sqrt(a * a + b * b + c * c + d * d)
        out[r, 0], out[r, 1], out[r, 2], out[r, 3] = a / norm, b / norm, c / norm, d / norm
    return out

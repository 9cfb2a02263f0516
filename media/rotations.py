"""Quaternion and Euler-angle arithmetic on arrays.

Quaternions are float64 arrays of shape (..., 4) in (w, x, y, z) order, unit length.
Rotation matrices are (..., 3, 3) and act on column vectors. Angles are radians.
Euler orders follow Shoemake (Graphics Gems IV): an order is a string of three axes
("XYZ", "ZXY", ...) plus a frame: "s" static (axes of the parent) or "r" rotating
(axes of the bone), e.g. "XYZs"; the first angle is applied first.
"""
from __future__ import annotations

import numpy as np

IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])
_AXIS = {"X": 0, "Y": 1, "Z": 2}


def multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product a*b (rotate by b, then by a)."""
    aw, ax, ay, az = np.moveaxis(np.asarray(a, dtype=np.float64), -1, 0)
    bw, bx, by, bz = np.moveaxis(np.asarray(b, dtype=np.float64), -1, 0)
    return np.stack([
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    ], axis=-1)


def conjugate(q: np.ndarray) -> np.ndarray:
    """Inverse of a unit quaternion."""
    return np.asarray(q, dtype=np.float64) * np.array([1.0, -1.0, -1.0, -1.0])


def normalize(q: np.ndarray) -> np.ndarray:
    q = np.asarray(q, dtype=np.float64)
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def canonical(q: np.ndarray) -> np.ndarray:
    """The same rotation with w >= 0 (q and -q are one rotation)."""
    q = np.asarray(q, dtype=np.float64)
    return np.where(q[..., :1] < 0, -q, q)


def from_axis_angle(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """axis: (..., 3) (need not be unit); angle: (...) radians."""
    axis = np.asarray(axis, dtype=np.float64)
    axis = axis / np.maximum(np.linalg.norm(axis, axis=-1, keepdims=True), 1e-300)
    half = 0.5 * np.asarray(angle, dtype=np.float64)[..., None]
    return np.concatenate([np.cos(half), np.sin(half) * axis], axis=-1)


def to_axis_angle(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Returns (axis (..., 3) unit, angle (...) in [0, pi])."""
    q = canonical(q)
    s = np.linalg.norm(q[..., 1:], axis=-1)
    angle = 2.0 * np.arctan2(s, q[..., 0])
    axis = np.where(s[..., None] > 1e-12, q[..., 1:] / np.maximum(s, 1e-300)[..., None], np.array([1.0, 0.0, 0.0]))
    return axis, angle


def to_matrix(q: np.ndarray) -> np.ndarray:
    q = np.asarray(q, dtype=np.float64)
    w, x, y, z = np.moveaxis(q, -1, 0)
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], axis=-1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], axis=-1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=-1),
    ], axis=-2)


def from_matrix(m: np.ndarray) -> np.ndarray:
    """Rotation matrix (..., 3, 3) to unit quaternion (w >= 0), robust in every branch."""
    m = np.asarray(m, dtype=np.float64)
    shape = m.shape[:-2]
    m = m.reshape(-1, 3, 3)
    q = np.empty((len(m), 4))
    trace = m[:, 0, 0] + m[:, 1, 1] + m[:, 2, 2]
    for i, r in enumerate(m):
        if trace[i] > 0:
            s = 2.0 * np.sqrt(trace[i] + 1.0)
            q[i] = [0.25 * s, (r[2, 1] - r[1, 2]) / s, (r[0, 2] - r[2, 0]) / s, (r[1, 0] - r[0, 1]) / s]
        elif r[0, 0] > r[1, 1] and r[0, 0] > r[2, 2]:
            s = 2.0 * np.sqrt(1.0 + r[0, 0] - r[1, 1] - r[2, 2])
            q[i] = [(r[2, 1] - r[1, 2]) / s, 0.25 * s, (r[0, 1] + r[1, 0]) / s, (r[0, 2] + r[2, 0]) / s]
        elif r[1, 1] > r[2, 2]:
            s = 2.0 * np.sqrt(1.0 + r[1, 1] - r[0, 0] - r[2, 2])
            q[i] = [(r[0, 2] - r[2, 0]) / s, (r[0, 1] + r[1, 0]) / s, 0.25 * s, (r[1, 2] + r[2, 1]) / s]
        else:
            s = 2.0 * np.sqrt(1.0 + r[2, 2] - r[0, 0] - r[1, 1])
            q[i] = [(r[1, 0] - r[0, 1]) / s, (r[0, 2] + r[2, 0]) / s, (r[1, 2] + r[2, 1]) / s, 0.25 * s]
    return canonical(normalize(q)).reshape(*shape, 4)


def rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vectors v (..., 3) by q (..., 4)."""
    return np.einsum("...ij,...j->...i", to_matrix(q), np.asarray(v, dtype=np.float64))


def between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Shortest-arc rotation taking direction a (..., 3) onto direction b (..., 3)."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    a = a / np.linalg.norm(a, axis=-1, keepdims=True)
    b = b / np.linalg.norm(b, axis=-1, keepdims=True)
    cross = np.cross(a, b)
    dot = np.sum(a * b, axis=-1, keepdims=True)
    q = np.concatenate([1.0 + dot, cross], axis=-1)
    # Opposite directions: rotate by pi about any axis perpendicular to a.
    opposite = (dot[..., 0] < -1.0 + 1e-12)
    if np.any(opposite):
        helper = np.where(np.abs(a[..., :1]) < 0.9, np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]))
        perpendicular = np.cross(a, helper)
        q = np.where(opposite[..., None], np.concatenate([np.zeros_like(dot), perpendicular], axis=-1), q)
    return normalize(q)


def slerp(q0: np.ndarray, q1: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Spherical linear interpolation (seed 000 eq. 3.9) along the shortest arc.

    q0, q1: (..., 4); t: (...) in [0, 1]. Falls back to normalised linear interpolation when
    the two rotations are nearly equal (sin(alpha) ~ 0).
    """
    q0 = np.asarray(q0, dtype=np.float64)
    q1 = np.asarray(q1, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64)[..., None]
    dot = np.sum(q0 * q1, axis=-1, keepdims=True)
    q1 = np.where(dot < 0, -q1, q1)
    dot = np.abs(dot)
    alpha = np.arccos(np.clip(dot, -1.0, 1.0))
    sin_alpha = np.sin(alpha)
    near = sin_alpha < 1e-9
    safe = np.where(near, 1.0, sin_alpha)
    w0 = np.where(near, 1.0 - t, np.sin((1.0 - t) * alpha) / safe)
    w1 = np.where(near, t, np.sin(t * alpha) / safe)
    return normalize(w0 * q0 + w1 * q1)


def angle_between(q0: np.ndarray, q1: np.ndarray) -> np.ndarray:
    """Rotation angle (radians, [0, pi]) of q0^-1 q1."""
    dot = np.abs(np.sum(np.asarray(q0) * np.asarray(q1), axis=-1))
    return 2.0 * np.arccos(np.clip(dot, 0.0, 1.0))


def _parse_order(order: str) -> tuple[list[int], bool]:
    if len(order) != 4 or order[3] not in "sr" or any(c not in _AXIS for c in order[:3]):
        raise ValueError(f"bad Euler order {order!r}: expected three of X/Y/Z and 's' or 'r', e.g. 'XYZs'")
    axes = [_AXIS[c] for c in order[:3]]
    if axes[0] == axes[1] or axes[1] == axes[2]:
        raise ValueError(f"bad Euler order {order!r}: the middle axis must differ from its neighbours")
    return axes, order[3] == "r"


def _axis_quaternion(axis: int, angle: np.ndarray) -> np.ndarray:
    unit = np.zeros(3)
    unit[axis] = 1.0
    return from_axis_angle(np.broadcast_to(unit, np.shape(angle) + (3,)), angle)


def from_euler(angles: np.ndarray, order: str = "XYZs") -> np.ndarray:
    """Euler angles (..., 3) radians -> quaternion (..., 4), seed 000 eq. 3.7.

    Static frame: rho = R(a3, A3) R(a2, A2) R(a1, A1) about the parent's axes.
    Rotating frame: the same angles about the bone's moving axes, i.e. R(a1, A1) R(a2, A2) R(a3, A3).
    """
    axes, rotating = _parse_order(order)
    angles = np.asarray(angles, dtype=np.float64)
    q1, q2, q3 = (_axis_quaternion(axes[k], angles[..., k]) for k in range(3))
    if rotating:
        return canonical(multiply(multiply(q1, q2), q3))
    return canonical(multiply(multiply(q3, q2), q1))


def to_euler(q: np.ndarray, order: str = "XYZs") -> np.ndarray:
    """Quaternion (..., 4) -> Euler angles (..., 3) radians in `order` (inverse of from_euler).

    Angles 1 and 3 lie in (-pi, pi]; angle 2 in [-pi/2, pi/2] for Tait-Bryan orders and
    [0, pi] for proper Euler orders (repeated first and last axis).
    """
    axes, rotating = _parse_order(order)
    m = to_matrix(q)
    if rotating:  # R1 R2 R3 about moving axes == static R3' R2' R1' with the order reversed
        static_axes = axes[::-1]
    else:
        static_axes = axes
    i, j, k = static_axes
    repeated = i == k
    if repeated:
        k = 3 - i - j
    parity = 1.0 if (j - i) % 3 == 1 else -1.0
    # Static frame: M = R_c(t3) R_b(t2) R_a(t1) with axes (a, b, c) = static_axes.
    if not repeated:
        # Tait-Bryan, axes i -> j -> k.
        s2 = -parity * m[..., k, i]
        t2 = np.arcsin(np.clip(s2, -1.0, 1.0))
        t1 = np.arctan2(parity * m[..., k, j], m[..., k, k])
        t3 = np.arctan2(parity * m[..., j, i], m[..., i, i])
        gimbal = np.abs(s2) > 1.0 - 1e-12
        if np.any(gimbal):
            t1 = np.where(gimbal, 0.0, t1)
            t3 = np.where(gimbal, np.arctan2(-parity * m[..., i, j], m[..., j, j]), t3)
    else:
        # Proper Euler i -> j -> i; k is the remaining axis.
        c2 = m[..., i, i]
        t2 = np.arccos(np.clip(c2, -1.0, 1.0))
        t1 = np.arctan2(m[..., i, j], parity * m[..., i, k])
        t3 = np.arctan2(m[..., j, i], -parity * m[..., k, i])
        gimbal = np.abs(np.sin(t2)) < 1e-9
        if np.any(gimbal):
            # Angles 1 and 3 share one axis: put it all in angle 3, from M R_j(t2)^-1 = R_i(t3).
            rest = np.einsum("...ab,...cb->...ac", m, to_matrix(_axis_quaternion(j, t2)))
            t1 = np.where(gimbal, 0.0, t1)
            t3 = np.where(gimbal, np.arctan2(parity * rest[..., k, j], rest[..., j, j]), t3)
    angles = np.stack([t1, t2, t3], axis=-1)
    return angles[..., ::-1] if rotating else angles

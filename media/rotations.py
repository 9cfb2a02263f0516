"""Rotations in signcast's conventions: scipy.spatial.transform.Rotation behind a thin adapter.

Quaternions are float64 arrays of shape (..., 4) in (w, x, y, z) order (scalar first), unit
length. Rotation matrices are (..., 3, 3) and act on column vectors. Angles are radians.
Euler orders follow Shoemake (Graphics Gems IV): an order is a string of three axes ("XYZ",
"ZXY", "ZYZ", ...) plus a frame: "s" static (axes of the parent; scipy's extrinsic lower-case
sequence) or "r" rotating (axes of the bone; scipy's intrinsic upper-case sequence), e.g.
"XYZs"; the first angle is applied first.

scipy does the conversions (matrix, axis-angle, Euler) and rotates vectors; this module adapts
its conventions (scalar-last quaternions, flat (N, 4) batches, sequence names). Kept in NumPy:
what scipy does not do (the shortest arc between two directions, sign handling), and the three
element-wise operations scipy 1.17 does 8-50x slower on signcast's hot paths (benchmarks/rotations.py):
multiply (its compose allocates per quaternion), and slerp and angle_between, which in scipy
go through compose (forward kinematics, FBA mapping, resampling, key-frame analysis). multiply, cross, rotate,
from_axis_angle, from_euler_table, euler_split and slerp_rows run as compiled loops (media/rotation_loops.py):
scipy's per-call cost dominates on the small arrays of the retargeter and the face rig, and its from_euler
costs about 1.7 us a rotation. They agree with scipy and NumPy to rounding (tests/test_rotations.py: within
1e-12), not bit for bit; nothing in signcast relies on the last bit of a float (the streams' integers are the
contract: docs/parameters.md).
"""
from __future__ import annotations

import warnings

import numpy as np
from scipy.spatial.transform import Rotation

from media import rotation_loops

IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])
_AXES = "XYZ"
_XYZW = [1, 2, 3, 0]                  # (w, x, y, z) -> scipy's (x, y, z, w)
_WXYZ = [3, 0, 1, 2]


def as_rotation(q: np.ndarray) -> Rotation:
    """A flat scipy Rotation of N = prod(q.shape[:-1]) quaternions q (..., 4) (w, x, y, z).

    scipy normalises them. Flat (N, 4) is the input every scipy >= 1.13 takes."""
    return Rotation.from_quat(np.asarray(q, dtype=np.float64).reshape(-1, 4)[:, _XYZW])


def as_quaternion(rotation: Rotation, shape: tuple[int, ...] = (), *, canonical: bool = False) -> np.ndarray:
    """(*shape, 4) float64 (w, x, y, z) quaternions of a flat scipy Rotation; canonical: w >= 0."""
    return rotation.as_quat(canonical=canonical).reshape(-1, 4)[:, _WXYZ].reshape(tuple(shape) + (4,))


def scipy_sequence(order: str) -> str:
    """Shoemake order name -> scipy Euler sequence: "XYZs" -> "xyz" (extrinsic), "ZYXr" -> "ZYX"
    (intrinsic). The angles keep their order: the first angle is the first axis's."""
    if len(order) != 4 or order[3] not in "sr" or any(c not in _AXES for c in order[:3]):
        raise ValueError(f"bad Euler order {order!r}: expected three of X/Y/Z and 's' or 'r', e.g. 'XYZs'")
    if order[0] == order[1] or order[1] == order[2]:
        raise ValueError(f"bad Euler order {order!r}: the middle axis must differ from its neighbours")
    return order[:3] if order[3] == "r" else order[:3].lower()


def _rows(x: np.ndarray, shape: tuple[int, ...], width: int | None) -> np.ndarray:
    """x broadcast to shape + (width,) and flattened to C-contiguous rows (N, width), or to shape and flattened to (N,)
    for width None, without a copy where x already has that shape and layout (NumPy's broadcast_to costs more than
    these kernels)."""
    full = shape if width is None else shape + (width,)
    if x.shape != full:
        x = np.broadcast_to(x, full)
    return np.ascontiguousarray(x).reshape(-1) if width is None else np.ascontiguousarray(x).reshape(-1, width)


def multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product a*b (rotate by b, then by a) of (..., 4) quaternions (broadcast), compiled
    (media/rotation_loops.py; `_multiply_numpy` is the NumPy form)."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    shape = np.broadcast_shapes(a.shape[:-1], b.shape[:-1])
    return rotation_loops.multiply(_rows(a, shape, 4), _rows(b, shape, 4)).reshape(shape + (4,))


def _multiply_numpy(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """`multiply` in NumPy."""
    aw, ax, ay, az = np.moveaxis(np.asarray(a, dtype=np.float64), -1, 0)
    bw, bx, by, bz = np.moveaxis(np.asarray(b, dtype=np.float64), -1, 0)
    return np.stack([
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    ], axis=-1)


def conjugate(q: np.ndarray) -> np.ndarray:
    """Inverse of unit quaternions (..., 4): (w, -x, -y, -z)."""
    return np.asarray(q, dtype=np.float64) * np.array([1.0, -1.0, -1.0, -1.0])


def normalize(q: np.ndarray) -> np.ndarray:
    """(..., 4) quaternions scaled to unit length."""
    q = np.asarray(q, dtype=np.float64)
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def canonical(q: np.ndarray) -> np.ndarray:
    """The same rotation with w >= 0 (q and -q are one rotation); (..., 4), not renormalised."""
    q = np.asarray(q, dtype=np.float64)
    return np.where(q[..., :1] < 0, -q, q)


def from_axis_angle(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """axis: (..., 3) (need not be unit; a zero axis gives the identity); angle: (...) radians
    -> (..., 4) (w, x, y, z) = (cos(angle / 2), sin(angle / 2) axis) (broadcast)."""
    axis = np.asarray(axis, dtype=np.float64)
    angle = np.asarray(angle, dtype=np.float64)
    shape = np.broadcast_shapes(axis.shape[:-1], angle.shape)
    quaternions = rotation_loops.from_axis_angle(_rows(axis, shape, 3), _rows(angle, shape, None))
    return quaternions.reshape(shape + (4,))


def to_axis_angle(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(..., 4) quaternions -> (axis (..., 3) unit, angle (...) in [0, pi]); axis (1, 0, 0) at angle 0."""
    q = np.asarray(q, dtype=np.float64)
    rotvec = as_rotation(q).as_rotvec().reshape(q.shape[:-1] + (3,))
    angle = np.linalg.norm(rotvec, axis=-1)
    axis = np.where(angle[..., None] > 2e-12, rotvec / np.maximum(angle, 1e-300)[..., None], np.array([1.0, 0.0, 0.0]))
    return axis, angle


def to_matrix(q: np.ndarray) -> np.ndarray:
    """(..., 4) quaternions -> (..., 3, 3) rotation matrices."""
    q = np.asarray(q, dtype=np.float64)
    return as_rotation(q).as_matrix().reshape(q.shape[:-1] + (3, 3))


def from_matrix(m: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) -> unit quaternions (..., 4) with w >= 0."""
    m = np.array(m, dtype=np.float64)                  # a writable copy: scipy's Cython needs one
    return as_quaternion(Rotation.from_matrix(m.reshape(-1, 3, 3)), m.shape[:-2], canonical=True)


def rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vectors v (..., 3) by q (..., 4) (broadcast; q need not be unit) -> (..., 3), as scipy's
    Rotation.from_quat(q).apply(v) to rounding, compiled (media/rotation_loops.py). A zero quaternion raises
    ValueError."""
    q = np.asarray(q, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    shape = np.broadcast_shapes(q.shape[:-1], v.shape[:-1])
    rotated, ok = rotation_loops.rotate(_rows(q, shape, 4), _rows(v, shape, 3))
    if not ok:
        raise ValueError("Found zero norm quaternions in `quat`.")
    return rotated.reshape(shape + (3,))


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b (..., 3) of 3-vectors a, b (..., 3) broadcast together, compiled (media/rotation_loops.py) without
    np.cross's axis handling, which costs ~10 us a call on small arrays."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    shape = np.broadcast_shapes(a.shape[:-1], b.shape[:-1])
    return rotation_loops.cross(_rows(a, shape, 3), _rows(b, shape, 3)).reshape(shape + (3,))


def between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Shortest-arc rotation (..., 4) taking direction a (..., 3) onto direction b (..., 3)."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    a = a / np.linalg.norm(a, axis=-1, keepdims=True)
    b = b / np.linalg.norm(b, axis=-1, keepdims=True)
    normal = cross(a, b)
    dot = np.sum(a * b, axis=-1, keepdims=True)
    q = np.concatenate([1.0 + dot, normal], axis=-1)
    # Opposite directions: rotate by pi about any axis perpendicular to a.
    opposite = (dot[..., 0] < -1.0 + 1e-12)
    if np.any(opposite):
        helper = np.where(np.abs(a[..., :1]) < 0.9, np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]))
        perpendicular = cross(a, helper)
        q = np.where(opposite[..., None], np.concatenate([np.zeros_like(dot), perpendicular], axis=-1), q)
    return normalize(q)


def slerp(q0: np.ndarray, q1: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Spherical linear interpolation (seed 000 eq. 3.9) of each pair along the shortest arc.

    q0, q1: (..., 4); t: (...) in [0, 1] -> (..., 4), on q0's side of the sign. Falls back to
    normalised linear interpolation when the two rotations are nearly equal (sin(alpha) ~ 0).
    (scipy's Slerp takes one key sequence, not pairs; its formula on pairs, q0 exp(t log(q0^-1 q1)),
    is 8-18x slower in scipy 1.17: benchmarks/rotations.py.)
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
    """Rotation angle (radians, [0, pi]) of q0^-1 q1; (..., 4) each (broadcast) -> (...)."""
    dot = np.abs(np.sum(np.asarray(q0) * np.asarray(q1), axis=-1))
    return 2.0 * np.arccos(np.clip(dot, 0.0, 1.0))


def from_euler(angles: np.ndarray, order: str = "XYZs") -> np.ndarray:
    """Euler angles (..., 3) radians -> quaternion (..., 4) (w, x, y, z), w >= 0; seed 000 eq. 3.7.

    Static frame: rho = R(a3, A3) R(a2, A2) R(a1, A1) about the parent's axes.
    Rotating frame: the same angles about the bone's moving axes, i.e. R(a1, A1) R(a2, A2) R(a3, A3).
    """
    sequence = scipy_sequence(order)
    angles = np.array(angles, dtype=np.float64)
    return as_quaternion(Rotation.from_euler(sequence, angles.reshape(-1, 3)), angles.shape[:-1], canonical=True)


def to_euler(q: np.ndarray, order: str = "XYZs") -> np.ndarray:
    """Quaternion (..., 4) -> Euler angles (..., 3) radians in `order` (inverse of from_euler).

    Angles 1 and 3 lie in [-pi, pi]; angle 2 in [-pi/2, pi/2] for Tait-Bryan orders and [0, pi]
    for proper Euler orders (repeated first and last axis). In gimbal lock (angle 2 at a limit)
    angles 1 and 3 turn about one axis and only their sum (or difference) is defined: the third
    angle is then 0 (scipy's choice).
    """
    sequence = scipy_sequence(order)
    q = np.asarray(q, dtype=np.float64)
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Gimbal lock detected", category=UserWarning)
        angles = as_rotation(q).as_euler(sequence)
    return angles.reshape(q.shape[:-1] + (3,))


def from_euler_table(table: np.ndarray, n_rotated: int, unit: float, order: str) -> np.ndarray:
    """from_euler of a decoder's angle table: table (F, C) float64 in angle units, column 3 r + k angle k of
    rotated bone r (r < n_rotated), times unit (radians per unit) -> (F, n_rotated, 4), w >= 0. Compiled; a value
    held from the frame before reuses its cosine and sine."""
    sequence = scipy_sequence(order)
    axes = np.array(["xyz".index(axis) for axis in sequence.lower()], dtype=np.int64)
    return rotation_loops.from_euler_table(np.ascontiguousarray(table, dtype=np.float64), n_rotated, unit, axes,
                                           sequence.isupper())


def euler_split(q: np.ndarray, order: str) -> np.ndarray:
    """to_euler(q, order) of quaternions (..., 4) compiled, the same angles to rounding (scipy's conventions,
    gimbal lock included). With q (T, B, 4) a bone whose quaternion equals its previous frame's takes that frame's
    angles without recomputing them. A zero quaternion raises ValueError."""
    sequence = scipy_sequence(order)
    extrinsic = sequence.islower()
    axes = ["xyz".index(axis) for axis in sequence.lower()]
    i, j, k = axes if extrinsic else axes[::-1]
    q = np.asarray(q, dtype=np.float64)
    flat = np.ascontiguousarray(q).reshape(-1, 4)
    stride = q.shape[-2] if q.ndim >= 3 else 0
    angles, ok = rotation_loops.to_euler(flat, stride, i, j, k, extrinsic)
    if not ok:
        raise ValueError("Found zero norm quaternions in `quat`.")
    return angles.reshape(q.shape[:-1] + (3,))


def slerp_rows(q0: np.ndarray, q1: np.ndarray, t: np.ndarray) -> np.ndarray:
    """`slerp` of (N, 4) pairs at t (N,) in one compiled pass (the same to rounding)."""
    return rotation_loops.slerp(np.ascontiguousarray(q0, dtype=np.float64), np.ascontiguousarray(q1, dtype=np.float64),
                                np.ascontiguousarray(t, dtype=np.float64))

"""Rotation arithmetic: signcast's hand-written NumPy functions against scipy.spatial.transform.

The NumPy side is media/rotations.py as it was before it used scipy (the functions it replaced are copied
below unchanged; those it still computes in NumPy are taken from it);
the scipy side is each function written as scipy calls through media.rotations' scalar-first
adapter. Both are timed on the sizes signcast uses: a whole motion (T = 250 frames x B = 163
avatar bones) at once, and the per-call sizes of the loops that call them many times (FBA
mapping: one bone's (T,) per call; BBA decoding: one frame of 27 rotated bones per from_euler;
forward kinematics: one depth level, about 8 bones x T, per multiply; key-frame analysis: one
gap of a few frames x 61 driven bones per slerp). Each row: the best of --repeats rounds
(microseconds per call), numpy / scipy (> 1: scipy is faster), and the largest difference
between the two results (quaternions: radians; Euler angles: radians between the rotations they
stand for; matrices and vectors: entries). media.rotations uses scipy where it does not lose
more than 2x on a hot path (the last column), NumPy for multiply, slerp and angle_between.

    python benchmarks/rotations.py [--repeats 7]
"""
from __future__ import annotations

import argparse
import sys
import timeit
import warnings
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from media import rotations  # noqa: E402

# ---- the NumPy baseline (media/rotations.py before it used scipy) ---------------------------------

_AXIS = {"X": 0, "Y": 1, "Z": 2}

# multiply, slerp, angle_between, normalize and canonical are still NumPy in media.rotations: the baseline is the
# module itself
np_multiply, np_canonical, np_normalize = rotations.multiply, rotations.canonical, rotations.normalize
np_slerp, np_angle_between = rotations.slerp, rotations.angle_between








def np_from_axis_angle(axis, angle):
    axis = np.asarray(axis, dtype=np.float64)
    axis = axis / np.maximum(np.linalg.norm(axis, axis=-1, keepdims=True), 1e-300)
    half = 0.5 * np.asarray(angle, dtype=np.float64)[..., None]
    return np.concatenate([np.cos(half), np.sin(half) * axis], axis=-1)


def np_to_matrix(q):
    w, x, y, z = np.moveaxis(np.asarray(q, dtype=np.float64), -1, 0)
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], axis=-1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], axis=-1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=-1)], axis=-2)


def np_from_matrix(m):
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
    return np_canonical(np_normalize(q)).reshape(*shape, 4)


def np_rotate(q, v):
    return np.einsum("...ij,...j->...i", np_to_matrix(q), v)






def _axis_quaternion(axis, angle):
    unit = np.zeros(3)
    unit[axis] = 1.0
    return np_from_axis_angle(np.broadcast_to(unit, np.shape(angle) + (3,)), angle)


def np_from_euler(angles, order):
    axes = [_AXIS[c] for c in order[:3]]
    q1, q2, q3 = (_axis_quaternion(axes[k], angles[..., k]) for k in range(3))
    if order[3] == "r":
        return np_canonical(np_multiply(np_multiply(q1, q2), q3))
    return np_canonical(np_multiply(np_multiply(q3, q2), q1))


def np_to_euler(q, order):
    axes, rotating = [_AXIS[c] for c in order[:3]], order[3] == "r"
    m = np_to_matrix(q)
    i, j, k = axes[::-1] if rotating else axes
    repeated = i == k
    if repeated:
        k = 3 - i - j
    parity = 1.0 if (j - i) % 3 == 1 else -1.0
    if not repeated:
        s2 = -parity * m[..., k, i]
        t2 = np.arcsin(np.clip(s2, -1.0, 1.0))
        t1 = np.arctan2(parity * m[..., k, j], m[..., k, k])
        t3 = np.arctan2(parity * m[..., j, i], m[..., i, i])
        gimbal = np.abs(s2) > 1.0 - 1e-12
        if np.any(gimbal):
            t1 = np.where(gimbal, 0.0, t1)
            t3 = np.where(gimbal, np.arctan2(-parity * m[..., i, j], m[..., j, j]), t3)
    else:
        t2 = np.arccos(np.clip(m[..., i, i], -1.0, 1.0))
        t1 = np.arctan2(m[..., i, j], parity * m[..., i, k])
        t3 = np.arctan2(m[..., j, i], -parity * m[..., k, i])
        gimbal = np.abs(np.sin(t2)) < 1e-9
        if np.any(gimbal):
            rest = np.einsum("...ab,...cb->...ac", m, np_to_matrix(_axis_quaternion(j, t2)))
            t1 = np.where(gimbal, 0.0, t1)
            t3 = np.where(gimbal, np.arctan2(parity * rest[..., k, j], rest[..., j, j]), t3)
    angles = np.stack([t1, t2, t3], axis=-1)
    return angles[..., ::-1] if rotating else angles


# ---- scipy: each function as scipy calls through media.rotations' scalar-first adapter -------------

_as_rotation, _as_quaternion = rotations.as_rotation, rotations.as_quaternion


def _pair(a, b):
    return np.broadcast_arrays(np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64))


def sp_multiply(a, b):
    a, b = _pair(a, b)
    return _as_quaternion(_as_rotation(a) * _as_rotation(b), a.shape[:-1])


def sp_slerp(q0, q1, t):
    """scipy Slerp's own formula, q0 exp(t log(q0^-1 q1)), on pairs (Slerp itself takes one key sequence)."""
    q0, q1 = _pair(q0, q1)
    r0 = _as_rotation(q0)
    step = (r0.inv() * _as_rotation(q1)).as_rotvec()
    t = np.broadcast_to(np.asarray(t, dtype=np.float64), q0.shape[:-1]).reshape(-1, 1)
    return _as_quaternion(r0 * Rotation.from_rotvec(step * t), q0.shape[:-1])


def sp_angle_between(q0, q1):
    q0, q1 = _pair(q0, q1)
    return (_as_rotation(q0).inv() * _as_rotation(q1)).magnitude().reshape(q0.shape[:-1])


def sp_from_euler(angles, order):
    angles = np.asarray(angles, dtype=np.float64)
    return _as_quaternion(Rotation.from_euler(rotations.scipy_sequence(order), angles.reshape(-1, 3)),
                          angles.shape[:-1], canonical=True)


def sp_to_euler(q, order):
    q = np.asarray(q, dtype=np.float64)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)        # gimbal lock
        return _as_rotation(q).as_euler(rotations.scipy_sequence(order)).reshape(q.shape[:-1] + (3,))


def sp_to_matrix(q):
    q = np.asarray(q, dtype=np.float64)
    return _as_rotation(q).as_matrix().reshape(q.shape[:-1] + (3, 3))


def sp_from_matrix(m):
    m = np.asarray(m, dtype=np.float64)
    return _as_quaternion(Rotation.from_matrix(m.reshape(-1, 3, 3)), m.shape[:-2], canonical=True)


def sp_rotate(q, v):
    q = np.asarray(q, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    shape = np.broadcast_shapes(q.shape[:-1], v.shape[:-1])
    vectors = np.array(np.broadcast_to(v, shape + (3,)).reshape(-1, 3))
    return _as_rotation(np.broadcast_to(q, shape + (4,))).apply(vectors).reshape(shape + (3,))


def sp_from_axis_angle(axis, angle):
    axis = np.asarray(axis, dtype=np.float64)
    unit = axis / np.maximum(np.linalg.norm(axis, axis=-1, keepdims=True), 1e-300)
    rotvec = unit * np.asarray(angle, dtype=np.float64)[..., None]
    return _as_quaternion(Rotation.from_rotvec(rotvec.reshape(-1, 3)), rotvec.shape[:-1])


# ---- the measurement ------------------------------------------------------------------------------

def _quaternion_distance(a, b):
    """Largest angle (radians) between two arrays of quaternions, accurate near zero."""
    return float(np.max(2 * np.arcsin(np.minimum(1.0, 0.5 * np.linalg.norm(
        np_canonical(np_normalize(a)) - np_canonical(np_normalize(b)), axis=-1)))))


def _best_us(call, repeats: int) -> float:
    timer = timeit.Timer(call)
    number, _ = timer.autorange()
    return min(timer.repeat(repeats, number)) / number * 1e6


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    T, B = 250, 163                                        # 10 s at 25 fps, every avatar bone

    def quaternions(*shape):
        return np_canonical(np_from_axis_angle(rng.normal(size=shape + (3,)), rng.uniform(0, 3, shape)))

    q, q2 = quaternions(T, B), quaternions(T, B)
    t = rng.uniform(0, 1, (T, B))
    v = rng.normal(size=(T, B, 3))
    m = np_to_matrix(q)
    euler = rng.uniform(-1, 1, (T, B, 3)) * [3.0, 1.4, 3.0]
    bone_q, bone_q2, bone_euler = q[:, 0], q2[:, 0], euler[:, 0]   # FBA mapping, retargeting: one bone (T,)
    frame_euler = euler[0, :27]                           # BBA decoding: one frame, 27 rotated bones
    level_a, level_b = q[:, :8], q2[:, :8]                # forward kinematics: one depth level
    key_q0 = np.broadcast_to(q[0, :61], (6, 61, 4))       # key-frame analysis: one gap of 6 frames,
    key_q1 = np.broadcast_to(q[7, :61], (6, 61, 4))       # 61 driven bones
    key_t = np.broadcast_to((np.arange(1, 7) / 7)[:, None], (6, 61))

    cases = [  # (function (size), hot path, numpy call, scipy call, compare: q, m, a, e<order>)
        ("to_matrix (T,B)", "bone_matrices: render, joint metrics", lambda: np_to_matrix(q), lambda: sp_to_matrix(q), "m"),
        ("from_matrix (T,)", "retargeting: per hand fit", lambda: np_from_matrix(m[:, 0]), lambda: sp_from_matrix(m[:, 0]), "q"),
        ("from_matrix (T,B)", "", lambda: np_from_matrix(m), lambda: sp_from_matrix(m), "q"),
        ("multiply (T,)", "FBA map/unmap: 4 per bone", lambda: np_multiply(bone_q, bone_q2),
         lambda: sp_multiply(bone_q, bone_q2), "q"),
        ("multiply (T,8)", "world_rotations: per level", lambda: np_multiply(level_a, level_b),
         lambda: sp_multiply(level_a, level_b), "q"),
        ("multiply (T,B)", "", lambda: np_multiply(q, q2), lambda: sp_multiply(q, q2), "q"),
        ("rotate (T,)", "retargeting: per phalanx", lambda: np_rotate(bone_q, v[:, 0]), lambda: sp_rotate(bone_q, v[:, 0]), "m"),
        ("rotate (T,B)", "", lambda: np_rotate(q, v), lambda: sp_rotate(q, v), "m"),
        ("from_axis_angle (T,)", "retargeting, IK: per joint", lambda: np_from_axis_angle(v[:, 0], t[:, 0]),
         lambda: sp_from_axis_angle(v[:, 0], t[:, 0]), "q"),
        ("from_axis_angle (T,B)", "", lambda: np_from_axis_angle(v, t), lambda: sp_from_axis_angle(v, t), "q"),
        ("slerp (T,B)", "resample: every fps point", lambda: np_slerp(q, q2, t), lambda: sp_slerp(q, q2, t), "q"),
        ("slerp (6,61)", "key_frames: per gap tried", lambda: np_slerp(key_q0, key_q1, key_t),
         lambda: sp_slerp(key_q0, key_q1, key_t), "q"),
        ("angle_between (6,61)", "key_frames: per gap tried", lambda: np_angle_between(key_q0, q[1:7, :61]),
         lambda: sp_angle_between(key_q0, q[1:7, :61]), "a"),
        ("angle_between (T,B)", "", lambda: np_angle_between(q, q2), lambda: sp_angle_between(q, q2), "a"),
        ("to_euler XYZs (T,B)", "BBA encode", lambda: np_to_euler(q, "XYZs"), lambda: sp_to_euler(q, "XYZs"), "eXYZs"),
        ("to_euler ZYXr (T,B)", "BBA encode", lambda: np_to_euler(q, "ZYXr"), lambda: sp_to_euler(q, "ZYXr"), "eZYXr"),
        ("to_euler ZYZs (T,B)", "BBA encode", lambda: np_to_euler(q, "ZYZs"), lambda: sp_to_euler(q, "ZYZs"), "eZYZs"),
        ("to_euler XZYr (T,)", "FBA encode: per bone", lambda: np_to_euler(bone_q, "XZYr"),
         lambda: sp_to_euler(bone_q, "XZYr"), "eXZYr"),
        ("from_euler XYZs (27,)", "BBA decode: per frame", lambda: np_from_euler(frame_euler, "XYZs"),
         lambda: sp_from_euler(frame_euler, "XYZs"), "q"),
        ("from_euler XZYr (T,)", "FBA decode: per bone", lambda: np_from_euler(bone_euler, "XZYr"),
         lambda: sp_from_euler(bone_euler, "XZYr"), "q"),
        ("from_euler XYZs (T,B)", "", lambda: np_from_euler(euler, "XYZs"), lambda: sp_from_euler(euler, "XYZs"), "q"),
    ]

    print(f"{'function (size)':26s} {'numpy us':>10s} {'scipy us':>10s} {'numpy/scipy':>11s} {'max diff':>9s}  hot path")
    for name, hot, numpy_call, scipy_call, compare in cases:
        a, b = numpy_call(), scipy_call()
        if compare == "q":
            diff = _quaternion_distance(a, b)
        elif compare.startswith("e"):  # Euler angles: compare the rotations they stand for
            diff = _quaternion_distance(np_from_euler(a, compare[1:]), np_from_euler(b, compare[1:]))
        else:
            diff = float(np.max(np.abs(a - b)))
        numpy_us, scipy_us = _best_us(numpy_call, args.repeats), _best_us(scipy_call, args.repeats)
        print(f"{name:26s} {numpy_us:10.1f} {scipy_us:10.1f} {numpy_us / scipy_us:11.2f} {diff:9.1e}  {hot}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

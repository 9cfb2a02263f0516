"""Numba kernels of the Motion <-> BAP conversion (comparisons/fba_mapping.py documents the mapping).

Per frame t and mapped bone b, with F the bone's anatomical frame and N its neutral rotation
((B, 4) quaternions (w, x, y, z)):

- `anatomical_rotations`: a = F^-1 (N^-1 q) F of the motion's local rotations q (T, B, 4), the
  rotation the Euler split reads. Each product is media.rotations.multiply's expression, term for
  term in the same order, and the inverse is a negation, so the result is bitwise NumPy's.
- `bap_rotations`: q = N ((F E) F^-1) from Euler angles (T, B, 3) radians (flexion, abduction,
  twist, rotating axes X, Z, Y: E = R_X(f) R_Z(a) R_Y(t)), normalised, w >= 0. This replaces
  scipy's from_euler plus three NumPy products (one pass, no temporaries); it agrees with them to
  about 1e-15 (sin and cos are Numba's, not NumPy's: the result is not bitwise theirs).
"""
import math

import numpy as np
from numba import njit


@njit(cache=True, inline="always")
def _multiply(aw, ax, ay, az, bw, bx, by, bz):
    """Hamilton product a*b, media.rotations.multiply's expressions."""
    return (aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw)


@njit(cache=True)
def anatomical_rotations(q: np.ndarray, frames: np.ndarray, neutrals: np.ndarray) -> np.ndarray:
    """q (T, B, 4) local rotations -> (T, B, 4) F^-1 (N^-1 q) F (unnormalised, as the products give them)."""
    n_frames, n_bones = q.shape[0], q.shape[1]
    out = np.empty((n_frames, n_bones, 4))
    for b in range(n_bones):
        nw, nx, ny, nz = neutrals[b, 0], -neutrals[b, 1], -neutrals[b, 2], -neutrals[b, 3]
        fw, fx, fy, fz = frames[b, 0], frames[b, 1], frames[b, 2], frames[b, 3]
        for t in range(n_frames):
            rw, rx, ry, rz = _multiply(nw, nx, ny, nz, q[t, b, 0], q[t, b, 1], q[t, b, 2], q[t, b, 3])
            sw, sx, sy, sz = _multiply(fw, -fx, -fy, -fz, rw, rx, ry, rz)
            out[t, b, 0], out[t, b, 1], out[t, b, 2], out[t, b, 3] = _multiply(sw, sx, sy, sz, fw, fx, fy, fz)
    return out


@njit(cache=True)
def bap_rotations(angles: np.ndarray, frames: np.ndarray, neutrals: np.ndarray) -> np.ndarray:
    """angles (T, B, 3) radians (flexion, abduction, twist) -> (T, B, 4) unit quaternions N (F E F^-1), w >= 0."""
    n_frames, n_bones = angles.shape[0], angles.shape[1]
    out = np.empty((n_frames, n_bones, 4))
    for b in range(n_bones):
        nw, nx, ny, nz = neutrals[b, 0], neutrals[b, 1], neutrals[b, 2], neutrals[b, 3]
        fw, fx, fy, fz = frames[b, 0], frames[b, 1], frames[b, 2], frames[b, 3]
        for t in range(n_frames):
            cf, sf = math.cos(0.5 * angles[t, b, 0]), math.sin(0.5 * angles[t, b, 0])
            ca, sa = math.cos(0.5 * angles[t, b, 1]), math.sin(0.5 * angles[t, b, 1])
            ct, st = math.cos(0.5 * angles[t, b, 2]), math.sin(0.5 * angles[t, b, 2])
            # R_X(f) R_Z(a), then R_Y(t)
            ew, ex, ey, ez = _multiply(cf, sf, 0.0, 0.0, ca, 0.0, 0.0, sa)
            ew, ex, ey, ez = _multiply(ew, ex, ey, ez, ct, 0.0, st, 0.0)
            if ew < 0.0:
                ew, ex, ey, ez = -ew, -ex, -ey, -ez
            rw, rx, ry, rz = _multiply(fw, fx, fy, fz, ew, ex, ey, ez)
            rw, rx, ry, rz = _multiply(rw, rx, ry, rz, fw, -fx, -fy, -fz)
            w, x, y, z = _multiply(nw, nx, ny, nz, rw, rx, ry, rz)
            norm = math.sqrt(w * w + x * x + y * y + z * z)
            if w < 0.0:
                norm = -norm
            out[t, b, 0], out[t, b, 1], out[t, b, 2], out[t, b, 3] = w / norm, x / norm, y / norm, z / norm
    return out


@njit(cache=True)
def anatomical_euler(rotations: np.ndarray, mapped: np.ndarray, source: np.ndarray, frames: np.ndarray,
                     neutrals: np.ndarray) -> np.ndarray:
    """The Euler split of the BAPs: rotations (T, J, 4) of a motion's bones, mapped (K,) / source (K,) the
    bones b of frames / neutrals (B, 4) that the motion carries and their index in rotations (the others
    are at the rig's rest, identity) -> (T, B, 3) angles (flexion, abduction, twist) radians of
    a = F^-1 (N^-1 q) F in rotating axes X, Z, Y.

    Bitwise what anatomical_rotations followed by media.rotations.to_euler(a, "XZYr") gives: scipy's
    from_quat normalisation (sqrt((x x + y y + z z) + w w), then each divided) and its as_euler for
    intrinsic "XZY" (Bernardes & Viollet 2022, scipy's _rotation_cy: the sequence reversed to extrinsic
    y, z, x; sign +1; atan2 and hypot of libm), term for term and in the same order; scipy's gimbal-lock
    cases (second angle within 1e-7 of 0 or pi: third angle 0) included. tests/test_fba_speed_identity.py
    checks it against scipy."""
    n_frames, n_bones = rotations.shape[0], frames.shape[0]
    source_of = np.full(n_bones, -1, dtype=np.int64)
    for k in range(len(mapped)):
        source_of[mapped[k]] = source[k]
    out = np.empty((n_frames, n_bones, 3))
    pi = math.pi
    for b in range(n_bones):
        nw, nx, ny, nz = neutrals[b, 0], -neutrals[b, 1], -neutrals[b, 2], -neutrals[b, 3]
        fw, fx, fy, fz = frames[b, 0], frames[b, 1], frames[b, 2], frames[b, 3]
        j = source_of[b]
        for t in range(n_frames):
            if j >= 0:
                qw, qx, qy, qz = rotations[t, j, 0], rotations[t, j, 1], rotations[t, j, 2], rotations[t, j, 3]
            else:
                qw, qx, qy, qz = 1.0, 0.0, 0.0, 0.0
            rw, rx, ry, rz = _multiply(nw, nx, ny, nz, qw, qx, qy, qz)
            sw, sx, sy, sz = _multiply(fw, -fx, -fy, -fz, rw, rx, ry, rz)
            w, x, y, z = _multiply(sw, sx, sy, sz, fw, fx, fy, fz)
            norm = math.sqrt(x * x + y * y + z * z + w * w)
            w, x, y, z = w / norm, x / norm, y / norm, z / norm
            # extrinsic sequence y, z, x: i = 1, j = 2, k = 0, sign +1 (scipy's quat is x, y, z, w)
            a = w - z
            bb = y + x
            c = z + w
            d = x - y
            second = 2 * math.atan2(math.hypot(c, d), math.hypot(a, bb))
            half_sum = math.atan2(bb, a)
            half_diff = math.atan2(d, c)
            if abs(second) <= 1e-7:
                first, third = 2 * half_sum, 0.0           # angles[0], angles[2] of scipy's gimbal case
            elif abs(second - pi) <= 1e-7:
                first, third = 2 * half_diff, 0.0
            else:
                third = half_sum - half_diff              # intrinsic: angles[2] = half_sum - half_diff
                first = half_sum + half_diff              # angles[0]
            second -= pi / 2
            if first < -pi:
                first += 2 * pi
            elif first > pi:
                first -= 2 * pi
            if second < -pi:
                second += 2 * pi
            elif second > pi:
                second -= 2 * pi
            if third < -pi:
                third += 2 * pi
            elif third > pi:
                third -= 2 * pi
            out[t, b, 0], out[t, b, 1], out[t, b, 2] = first, second, third
    return out

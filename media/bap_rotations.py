"""Compiled loops of the Motion <-> BAP conversion (comparisons/params/fba_mapping.py documents the mapping), for
speed: one pass over frames and bones instead of scipy calls and NumPy products with their temporaries.

Per frame t and mapped bone b, with F the bone's anatomical frame and N its neutral rotation
((B, 4) quaternions (w, x, y, z)):

- `anatomical_rotations`: a = F^-1 (N^-1 q) F of the motion's local rotations q (T, B, 4), the
  rotation the Euler split reads.
- `anatomical_euler`: a's Euler angles (flexion, abduction, twist) in rotating axes X, Z, Y
  (media/rotation_loops.euler_of, scipy's as_euler conventions).
- `bap_rotations`: q = N ((F E) F^-1) from Euler angles (T, B, 3) radians (E = R_X(f) R_Z(a) R_Y(t)),
  normalised, w >= 0.
- `anatomical_bap_levels` / `bap_value_rotations`: the same two directions straight from and to BAP
  integers, skipping a bone whose input in a frame equals its previous frame's (held poses are about half
  of signing's bone-frames).

tests/test_fba_speed_identity.py checks them against media.rotations (scipy's from_euler / as_euler and NumPy
products): rotations within 1e-12 per component, angles within 1e-9 rad away from gimbal lock, and the BAP levels
the same but for values within rounding of a half step.
"""
import math

import numpy as np
from numba import njit

from media.rotation_loops import euler_of

@njit(cache=True, inline="always")
def _multiply(aw, ax, ay, az, bw, bx, by, bz):
    """Hamilton product a*b."""
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


@njit(cache=True, inline="always")
def _bap_rotation(f, a, t, nw, nx, ny, nz, fw, fx, fy, fz):
    """N (F E F^-1) of one bone's angles (radians), normalised, w >= 0."""
    cf, sf = math.cos(0.5 * f), math.sin(0.5 * f)
    ca, sa = math.cos(0.5 * a), math.sin(0.5 * a)
    ct, st = math.cos(0.5 * t), math.sin(0.5 * t)
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
    return w / norm, x / norm, y / norm, z / norm


@njit(cache=True)
def bap_rotations(angles: np.ndarray, frames: np.ndarray, neutrals: np.ndarray) -> np.ndarray:
    """angles (T, B, 3) radians (flexion, abduction, twist) -> (T, B, 4) unit quaternions N (F E F^-1), w >= 0."""
    n_frames, n_bones = angles.shape[0], angles.shape[1]
    out = np.empty((n_frames, n_bones, 4))
    for b in range(n_bones):
        nw, nx, ny, nz = neutrals[b, 0], neutrals[b, 1], neutrals[b, 2], neutrals[b, 3]
        fw, fx, fy, fz = frames[b, 0], frames[b, 1], frames[b, 2], frames[b, 3]
        for t in range(n_frames):
            out[t, b, 0], out[t, b, 1], out[t, b, 2], out[t, b, 3] = _bap_rotation(
                angles[t, b, 0], angles[t, b, 1], angles[t, b, 2], nw, nx, ny, nz, fw, fx, fy, fz)
    return out


@njit(cache=True)
def bap_value_rotations(values: np.ndarray, columns: np.ndarray, signs: np.ndarray, unit: float,
                        frames: np.ndarray, neutrals: np.ndarray) -> np.ndarray:
    """BAP values (T, V) int64 -> (T, B, 4) rotations: bap_rotations of the angles
    values[:, columns].astype(float64) * unit * signs (columns, signs (B, 3)). A bone whose three values
    equal its previous frame's (a held pose) copies that frame's rotation."""
    n_frames, n_bones = values.shape[0], frames.shape[0]
    out = np.empty((n_frames, n_bones, 4))
    for b in range(n_bones):
        nw, nx, ny, nz = neutrals[b, 0], neutrals[b, 1], neutrals[b, 2], neutrals[b, 3]
        fw, fx, fy, fz = frames[b, 0], frames[b, 1], frames[b, 2], frames[b, 3]
        c0, c1, c2 = columns[b, 0], columns[b, 1], columns[b, 2]
        s0, s1, s2 = signs[b, 0], signs[b, 1], signs[b, 2]
        for t in range(n_frames):
            v0, v1, v2 = values[t, c0], values[t, c1], values[t, c2]
            if t > 0 and v0 == values[t - 1, c0] and v1 == values[t - 1, c1] and v2 == values[t - 1, c2]:
                out[t, b, 0], out[t, b, 1], out[t, b, 2], out[t, b, 3] = (
                    out[t - 1, b, 0], out[t - 1, b, 1], out[t - 1, b, 2], out[t - 1, b, 3])
                continue
            out[t, b, 0], out[t, b, 1], out[t, b, 2], out[t, b, 3] = _bap_rotation(
                float(v0) * unit * s0, float(v1) * unit * s1, float(v2) * unit * s2, nw, nx, ny, nz, fw, fx, fy, fz)
    return out


@njit(cache=True, inline="always")
def _euler(qw, qx, qy, qz, nw, nx, ny, nz, fw, fx, fy, fz):
    """(flexion, abduction, twist) radians of a = F^-1 (N^-1 q) F (n = N^-1 given): intrinsic X, Z, Y, i.e. the
    fixed axes y, z, x."""
    rw, rx, ry, rz = _multiply(nw, nx, ny, nz, qw, qx, qy, qz)
    sw, sx, sy, sz = _multiply(fw, -fx, -fy, -fz, rw, rx, ry, rz)
    w, x, y, z = _multiply(sw, sx, sy, sz, fw, fx, fy, fz)
    return euler_of(w, x, y, z, 1, 2, 0, False)


@njit(cache=True)
def anatomical_euler(rotations: np.ndarray, mapped: np.ndarray, source: np.ndarray, frames: np.ndarray,
                     neutrals: np.ndarray) -> np.ndarray:
    """The Euler split of the BAPs: rotations (T, J, 4) of a motion's bones, mapped (K,) / source (K,) the
    bones b of frames / neutrals (B, 4) that the motion carries and their index in rotations (the others
    are at the rig's rest, identity) -> (T, B, 3) angles (flexion, abduction, twist) radians of
    a = F^-1 (N^-1 q) F in rotating axes X, Z, Y.

    anatomical_rotations followed by media.rotations.to_euler(a, "XZYr"), to rounding."""
    n_frames, n_bones = rotations.shape[0], frames.shape[0]
    source_of = np.full(n_bones, -1, dtype=np.int64)
    for k in range(len(mapped)):
        source_of[mapped[k]] = source[k]
    out = np.empty((n_frames, n_bones, 3))
    for b in range(n_bones):
        nw, nx, ny, nz = neutrals[b, 0], -neutrals[b, 1], -neutrals[b, 2], -neutrals[b, 3]
        fw, fx, fy, fz = frames[b, 0], frames[b, 1], frames[b, 2], frames[b, 3]
        j = source_of[b]
        for t in range(n_frames):
            if j >= 0:
                qw, qx, qy, qz = rotations[t, j, 0], rotations[t, j, 1], rotations[t, j, 2], rotations[t, j, 3]
            else:
                qw, qx, qy, qz = 1.0, 0.0, 0.0, 0.0
            out[t, b, 0], out[t, b, 1], out[t, b, 2] = _euler(qw, qx, qy, qz, nw, nx, ny, nz, fw, fx, fy, fz)
    return out


@njit(cache=True, inline="always")
def _level(x):
    """np.round(x).astype(np.int64): half to even; NaN (a zero quaternion) as NumPy's cast gives it on x86."""
    if math.isnan(x):
        return np.int64(-(2 ** 63))
    return np.int64(np.rint(x))


@njit(cache=True)
def anatomical_bap_levels(rotations: np.ndarray, mapped: np.ndarray, source: np.ndarray, frames: np.ndarray,
                          neutrals: np.ndarray, columns: np.ndarray, signs: np.ndarray, unit: float,
                          values: np.ndarray) -> None:
    """anatomical_euler's angles x signs (B, 3), / unit, rounded half to even (np.round) into
    values[:, columns] (values (T, V) int64, columns (B, 3)):
    np.round(anatomical_euler(...) * signs / unit).astype(np.int64). A bone's rotation equal to its previous
    frame's (a held pose; every frame of a bone the motion lacks) is not split again."""
    n_frames, n_bones = rotations.shape[0], frames.shape[0]
    source_of = np.full(n_bones, -1, dtype=np.int64)
    for k in range(len(mapped)):
        source_of[mapped[k]] = source[k]
    for b in range(n_bones):
        nw, nx, ny, nz = neutrals[b, 0], -neutrals[b, 1], -neutrals[b, 2], -neutrals[b, 3]
        fw, fx, fy, fz = frames[b, 0], frames[b, 1], frames[b, 2], frames[b, 3]
        c0, c1, c2 = columns[b, 0], columns[b, 1], columns[b, 2]
        s0, s1, s2 = signs[b, 0], signs[b, 1], signs[b, 2]
        j = source_of[b]
        qw, qx, qy, qz = 1.0, 0.0, 0.0, 0.0
        v0, v1, v2 = 0, 0, 0
        for t in range(n_frames):
            if j >= 0:
                pw, px, py, pz = rotations[t, j, 0], rotations[t, j, 1], rotations[t, j, 2], rotations[t, j, 3]
            else:
                pw, px, py, pz = 1.0, 0.0, 0.0, 0.0
            if t == 0 or not (pw == qw and px == qx and py == qy and pz == qz):
                qw, qx, qy, qz = pw, px, py, pz
                first, second, third = _euler(qw, qx, qy, qz, nw, nx, ny, nz, fw, fx, fy, fz)
                v0, v1, v2 = _level(first * s0 / unit), _level(second * s1 / unit), _level(third * s2 / unit)
            values[t, c0], values[t, c1], values[t, c2] = v0, v1, v2

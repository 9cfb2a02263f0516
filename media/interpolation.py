"""Key-frame interpolation of a Motion (seed 000 §2.3.1 and §3.4.3).

With more than two keys: a cubic spline through the keys (natural end conditions), on the
quaternion components made sign-consistent key to key and renormalised, and on the root
translation. With exactly two keys: slerp for rotations (eq. 3.9) and linear interpolation for
the translation (eq. 3.8). One key holds still.
"""
from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicSpline

from media import rotations
from media.errors import SigncastError
from media.motion import Motion


def interpolate_keys(key_times_s: np.ndarray, keys: Motion, times_s: np.ndarray, fps: float | None = None) -> Motion:
    """Motion at times_s (seconds) from key poses.

    key_times_s: (K,) strictly increasing key times in seconds; keys: Motion with K frames (its fps is ignored);
    times_s: (T,) output times (clamped to the key span); fps: the output frame rate (default: keys.fps).
    """
    key_times_s = np.asarray(key_times_s, dtype=np.float64)
    times_s = np.clip(np.asarray(times_s, dtype=np.float64), key_times_s[0], key_times_s[-1])
    if len(key_times_s) != keys.n_frames or len(key_times_s) == 0:
        raise SigncastError(f"{len(key_times_s)} key times for {keys.n_frames} key poses")
    if np.any(np.diff(key_times_s) <= 0):
        raise SigncastError("key times must increase strictly")
    fps = fps or keys.fps
    K = len(key_times_s)
    if K == 1:
        return Motion(fps, keys.bone_names, np.repeat(keys.rotations, len(times_s), axis=0),
                      np.repeat(keys.root_translation, len(times_s), axis=0))
    if K == 2:
        t = (times_s - key_times_s[0]) / (key_times_s[1] - key_times_s[0])
        q = rotations.slerp(keys.rotations[0][None], keys.rotations[1][None], np.broadcast_to(t[:, None], (len(t), len(keys.bone_names))))
        translation = (1 - t)[:, None] * keys.root_translation[0] + t[:, None] * keys.root_translation[1]
        return Motion(fps, keys.bone_names, q, translation)
    q = sign_consistent(keys.rotations)
    spline_q = CubicSpline(key_times_s, q, axis=0, bc_type="natural")(times_s)
    translation = CubicSpline(key_times_s, keys.root_translation, axis=0, bc_type="natural")(times_s)
    return Motion(fps, keys.bone_names, rotations.canonical(rotations.normalize(spline_q)), translation)


def sign_consistent(q: np.ndarray) -> np.ndarray:
    """(T, B, 4) quaternions with each frame's sign chosen nearest the previous frame's (no 2-pi flips)."""
    q = np.array(q, dtype=np.float64)
    for t in range(1, len(q)):
        flip = np.sum(q[t] * q[t - 1], axis=-1) < 0
        q[t, flip] *= -1
    return q


def expand_keys(key_indices: np.ndarray, keys: Motion, n_frames: int) -> Motion:
    """Frames 0..n_frames-1 at keys.fps from key poses placed at frame indices key_indices."""
    key_indices = np.asarray(key_indices, dtype=np.float64)
    return interpolate_keys(key_indices / keys.fps, keys, np.arange(n_frames) / keys.fps, keys.fps)

"""Key-frame analyser (seed 000 §3.5, Fig. 3.9; §4.2.4.6) and the decoder's regeneration.

A frame is dropped when interpolating between the key frames around it rebuilds every bone
rotation within `threshold_rad` (slerp, eq. 3.9) and the root translation within `threshold_m`
(linear, eq. 3.8). Greedy, as preda-digest.md §2.6: from the last key, extend the gap while all
frames inside stay within the thresholds; a key frame carries KeyFrameIndex = frames dropped
before it, at most 31 (5 bits).

Chosen here (the thesis gives no value): 0.05 rad (2.9 degrees) per bone rotation and 2 mm for
the root translation, or Q x 64e-5 rad when that is larger (the size of the coder's own step).
"""
from __future__ import annotations

import numpy as np

from media import rotations
from media.motion import Motion

MAX_KFI = 31


def default_threshold_rad(q: int) -> float:
    return max(0.05, q * 64e-5)


def _within(motion: Motion, first: int, last: int, threshold_rad: float, threshold_m: float) -> bool:
    inner = np.arange(first + 1, last)
    if not len(inner):
        return True
    x = (inner - first) / (last - first)
    q0 = np.broadcast_to(motion.rotations[first], (len(inner),) + motion.rotations.shape[1:])
    q1 = np.broadcast_to(motion.rotations[last], q0.shape)
    estimate = rotations.slerp(q0, q1, np.broadcast_to(x[:, None], q0.shape[:2]))
    if np.max(rotations.angle_between(estimate, motion.rotations[inner])) > threshold_rad:
        return False
    t0, t1 = motion.root_translation[first], motion.root_translation[last]
    line = (1 - x)[:, None] * t0 + x[:, None] * t1
    return bool(np.max(np.linalg.norm(line - motion.root_translation[inner], axis=1)) <= threshold_m)


def key_frames(motion: Motion, threshold_rad: float, threshold_m: float = 0.002) -> np.ndarray:
    """Indices of the key frames (always the first and the last frame)."""
    n = motion.n_frames
    keys = [0]
    current = 0
    while current < n - 1:
        nxt = current + 1
        while (nxt + 1 < n and nxt + 1 - current - 1 <= MAX_KFI
               and _within(motion, current, nxt + 1, threshold_rad, threshold_m)):
            nxt += 1
        keys.append(nxt)
        current = nxt
    return np.array(keys, dtype=np.int64)


def expand(previous_q: np.ndarray, previous_t: np.ndarray, key_q: np.ndarray, key_t: np.ndarray,
           kfi: int) -> tuple[np.ndarray, np.ndarray]:
    """The kfi frames a decoder regenerates before a key frame: (kfi, B, 4) rotations (slerp)
    and (kfi, 3) translations (linear), at x = k / (kfi + 1), k = 1..kfi."""
    x = np.arange(1, kfi + 1) / (kfi + 1)
    q0 = np.broadcast_to(previous_q, (kfi,) + previous_q.shape)
    q1 = np.broadcast_to(key_q, q0.shape)
    q = rotations.slerp(q0, q1, np.broadcast_to(x[:, None], q0.shape[:2]))
    t = (1 - x)[:, None] * previous_t + x[:, None] * key_t
    return q, t

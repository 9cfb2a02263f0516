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


def _within_each(motion: Motion, first: int, lasts: np.ndarray, threshold_rad: float, threshold_m: float) -> np.ndarray:
    """(L,) bool: for each candidate key `lasts` (L,) (each > first + 1), whether interpolating between
    `first` and it rebuilds every frame between them within the thresholds (slerp of the rotations,
    linear root translation). All candidates' inner frames in one batch: the per-frame operations are
    those of one candidate at a time, so the decisions are too."""
    counts = lasts - first - 1                               # inner frames of each candidate
    owner = np.repeat(np.arange(len(lasts)), counts)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    inner = first + 1 + (np.arange(len(owner)) - starts[owner])
    x = (inner - first) / (lasts[owner] - first)
    q0 = np.broadcast_to(motion.rotations[first], (len(inner),) + motion.rotations.shape[1:])
    q1 = motion.rotations[lasts[owner]]
    estimate = rotations.slerp(q0, q1, np.broadcast_to(x[:, None], q0.shape[:2]))
    angle = np.maximum.reduceat(rotations.angle_between(estimate, motion.rotations[inner]).max(axis=1), starts)
    t0, t1 = motion.root_translation[first], motion.root_translation[lasts[owner]]
    line = (1 - x)[:, None] * t0 + x[:, None] * t1
    distance = np.maximum.reduceat(np.linalg.norm(line - motion.root_translation[inner], axis=1), starts)
    return ~(angle > threshold_rad) & (distance <= threshold_m)


def key_frames(motion: Motion, threshold_rad: float, threshold_m: float = 0.002) -> np.ndarray:
    """Indices of the key frames (always the first and the last frame). Greedy: from each key, the next
    is the last frame before the first candidate (at most MAX_KFI + 1 frames on) that fails. Candidates
    are tried in batches of 2, 4, 8, ... (a batch costs about as much as one candidate, and most gaps
    are short)."""
    n = motion.n_frames
    keys = [0]
    current = 0
    while current < n - 1:
        end = min(n - 1, current + MAX_KFI + 1)          # the farthest candidate
        nxt, batch = current + 1, 2
        while nxt < end:
            lasts = np.arange(nxt + 1, min(end, nxt + batch) + 1)
            ok = _within_each(motion, current, lasts, threshold_rad, threshold_m)
            if not ok.all():
                nxt += int(np.argmin(ok))
                break
            nxt += len(ok)
            batch *= 2
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

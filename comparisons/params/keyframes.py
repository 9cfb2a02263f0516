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

from comparisons.params import bba_keyframes as key_kernel
from media import rotations
from media.motion import Motion

MAX_KFI = 31


def default_threshold_rad(q: int) -> float:
    return max(0.05, q * 64e-5)


def _within_each(rotations_: np.ndarray, translation: np.ndarray, firsts: np.ndarray, lasts: np.ndarray,
                 threshold_rad: float, threshold_m: float) -> np.ndarray:
    """(L,) bool: for each candidate pair of keys firsts[k] < lasts[k] (L,) (lasts > firsts + 1), whether
    interpolating between them rebuilds every frame between them within the thresholds (slerp of the
    rotations (T, B, 4), linear root translation (T, 3)). All candidates' inner frames in one batch: the
    per-frame operations are those of one candidate at a time, so the decisions are too."""
    counts = lasts - firsts - 1                              # inner frames of each candidate
    owner = np.repeat(np.arange(len(lasts)), counts)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    first = firsts[owner]
    inner = first + 1 + (np.arange(len(owner)) - starts[owner])
    x = (inner - first) / (lasts[owner] - first)
    if rotations_.shape[1]:
        q0 = rotations_[first]
        q1 = rotations_[lasts[owner]]
        estimate = rotations.slerp(q0, q1, np.broadcast_to(x[:, None], q0.shape[:2]))
        angle = np.maximum.reduceat(rotations.angle_between(estimate, rotations_[inner]).max(axis=1), starts)
    else:
        angle = np.zeros(len(lasts))
    t0, t1 = translation[first], translation[lasts[owner]]
    line = (1 - x)[:, None] * t0 + x[:, None] * t1
    distance = np.maximum.reduceat(np.linalg.norm(line - translation[inner], axis=1), starts)
    return ~(angle > threshold_rad) & (distance <= threshold_m)


def _moving(quaternions: np.ndarray) -> np.ndarray:
    """(B,) bool: the bones of quaternions (T, B, 4) that can fail the angle test. A bone whose rotation is
    the same unit quaternion (squared norm within 1e-9 of 1) in every frame is rebuilt by slerp within
    1e-4 rad (rounding), below the thresholds it is left out for (>= 1e-3 rad): no decision changes."""
    if not len(quaternions):
        return np.zeros(quaternions.shape[1], dtype=bool)
    return key_kernel.moving(np.ascontiguousarray(quaternions, dtype=np.float64))     # `_moving_numpy`, compiled


def _moving_numpy(quaternions: np.ndarray) -> np.ndarray:
    """`_moving` in NumPy (its reference; tests compare the two), T >= 1."""
    still = np.all(quaternions == quaternions[:1], axis=(0, 2))
    unit = np.abs(np.sum(quaternions[0] * quaternions[0], axis=-1) - 1.0) < 1e-9
    return ~(still & unit)


def key_frames(motion: Motion, threshold_rad: float, threshold_m: float = 0.002) -> np.ndarray:
    """Indices of the key frames (always the first and the last frame). Greedy: from each key, the next
    is the last frame before the first candidate (at most MAX_KFI + 1 frames on) that fails.

    Compiled (kernels/bba_keyframes.search) where the thresholds are at least 1e-3 rad and 1e-6 m: the
    kernel decides a candidate only where every tested value is clear of its threshold by far more than
    its ulp-level differences from NumPy's arithmetic, and hands the rest (rare) to `_within_each`, the
    NumPy reference, one candidate at a time; so the keys are `_key_frames_numpy`'s, bit for bit."""
    n = motion.n_frames
    if n == 0 or not (threshold_rad >= 1e-3 and threshold_m >= 1e-6):
        return _key_frames_numpy(motion, threshold_rad, threshold_m)
    quaternions = np.ascontiguousarray(motion.rotations, dtype=np.float64)
    quaternions = np.ascontiguousarray(quaternions[:, _moving(quaternions)])
    translation = np.ascontiguousarray(motion.root_translation, dtype=np.float64)
    decided = np.zeros((n, MAX_KFI + 2), dtype=np.int8)
    keys = np.empty(n, dtype=np.int64)
    while True:
        count, first, last = key_kernel.search(quaternions, translation, float(threshold_rad), float(threshold_m),
                                               _MARGIN_RAD, _MARGIN_M, MAX_KFI, decided, keys)
        if count > 0:
            return keys[:count].copy()
        ok = _within_each(quaternions, translation, np.array([first]), np.array([last]), threshold_rad, threshold_m)
        decided[first, last - first] = key_kernel.PASS if ok[0] else key_kernel.FAIL


# Clearances beyond which the kernel's decisions cannot differ from NumPy's: its angles differ by at most
# ~2 eps / sin(threshold / 2) (< 1e-11 rad at 1e-3 rad), its distances by a few ulps of millimetres.
_MARGIN_RAD = 1e-9
_MARGIN_M = 1e-12


def _key_frames_numpy(motion: Motion, threshold_rad: float, threshold_m: float = 0.002) -> np.ndarray:
    """key_frames in NumPy: the reference the compiled search reproduces (tests compare the two). Candidates
    are tried in batches of 2, 4, 8, ... (a batch costs about as much as one candidate, and most gaps
    are short); the first batch of every possible key is tried in one call up front. Bones that never move
    are left out of the angle test (_moving)."""
    n = motion.n_frames
    quaternions = motion.rotations
    if threshold_rad >= 1e-3:
        quaternions = quaternions[:, _moving(quaternions)]
    translation = motion.root_translation
    # Every key's first batch (the candidates 2 and 3 frames on) for every possible key, in one call.
    firsts = np.repeat(np.arange(max(n - 2, 0)), 2)
    lasts = firsts + np.tile([2, 3], max(n - 2, 0))
    valid = lasts <= n - 1
    short = np.ones((max(n - 2, 0), 2), dtype=bool)
    if valid.any():
        short.reshape(-1)[valid] = _within_each(quaternions, translation, firsts[valid], lasts[valid], threshold_rad,
                                                threshold_m)
    keys = [0]
    current = 0
    while current < n - 1:
        end = min(n - 1, current + MAX_KFI + 1)          # the farthest candidate
        nxt, batch = current + 1, 2
        while nxt < end:
            lasts = np.arange(nxt + 1, min(end, nxt + batch) + 1)
            if nxt == current + 1:
                ok = short[current, :len(lasts)]
            else:
                ok = _within_each(quaternions, translation, np.full(len(lasts), current), lasts, threshold_rad,
                                  threshold_m)
            if not ok.all():
                nxt += int(np.argmin(ok))
                break
            nxt += len(ok)
            batch *= 2
        keys.append(nxt)
        current = nxt
    return np.array(keys, dtype=np.int64)


def expand(previous_q: np.ndarray, previous_t: np.ndarray, key_q: np.ndarray, key_t: np.ndarray,
           kfi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The frames a decoder regenerates before each of G key frames, all gaps in one batch: previous_q, key_q
    (G, B, 4) the rotations of the key frames around each gap, previous_t, key_t (G, 3) their root
    translations, kfi (G,) int64 frames dropped in each gap. Returns (sum kfi, B, 4) rotations (slerp, eq. 3.9,
    media.rotations.slerp_rows) and (sum kfi, 3) translations (linear, eq. 3.8), gap after gap, at
    x = k / (kfi + 1), k = 1..kfi."""
    kfi = np.asarray(kfi, dtype=np.int64)
    owner = np.repeat(np.arange(len(kfi)), kfi)
    starts = np.cumsum(kfi) - kfi
    x = (np.arange(len(owner)) - starts[owner] + 1) / (kfi[owner] + 1)
    n_bones = previous_q.shape[1]
    q = rotations.slerp_rows(previous_q[owner].reshape(-1, 4), key_q[owner].reshape(-1, 4), np.repeat(x, n_bones))
    return q.reshape(len(owner), n_bones, 4), (1 - x)[:, None] * previous_t[owner] + x[:, None] * key_t[owner]


def regenerate(key_q: np.ndarray, key_t: np.ndarray, kfi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The display frames of decoded key frames: key_q (F, B, 4) rotations, key_t (F, 3) root translations,
    kfi (F,) int64 KeyFrameIndex of each (frames dropped before it; kfi[0] is ignored). Returns (D, B, 4)
    rotations and (D, 3) translations, D = F + sum kfi[1:]: each key frame at its display frame and `expand`'s
    frames between them."""
    gaps = np.asarray(kfi, dtype=np.int64).copy()
    if len(gaps):
        gaps[0] = 0
    at = np.arange(len(gaps)) + np.cumsum(gaps)                 # each key frame's display frame
    n_display = int(at[-1]) + 1 if len(gaps) else 0
    quats = np.empty((n_display,) + key_q.shape[1:])
    trans = np.empty((n_display, 3))
    quats[at], trans[at] = key_q, key_t
    inner = np.ones(n_display, dtype=bool)
    inner[at] = False
    if inner.any():
        quats[inner], trans[inner] = expand(key_q[:-1], key_t[:-1], key_q[1:], key_t[1:], gaps[1:])
    return quats, trans

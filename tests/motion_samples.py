"""Motions and measures the codec tests share (kept out of the test modules so that no test module imports
another)."""
import numpy as np

from comparisons.params.fba_mapping import avatar_bap_map
from media import rotations
from media.motion import Motion

FPS = 25.0


def signing_like(n_frames: int = 150, seed: int = 0) -> np.ndarray:
    """(T, 5) radians: smooth moves between held postures (as letters), a sinusoid, a still DOF."""
    rng = np.random.default_rng(seed)
    t = np.arange(n_frames) / FPS
    holds = rng.uniform(-1.0, 1.0, size=(n_frames // 25 + 2, 3))
    position = np.arange(n_frames) / 25.0
    k = np.floor(position).astype(int)
    f = position - k
    smooth = f * f * (3 - 2 * f)
    moves = holds[k] + (holds[k + 1] - holds[k]) * smooth[:, None]
    wave = 0.6 * np.sin(2 * np.pi * 1.3 * t)
    still = np.full(n_frames, 0.25)
    return np.column_stack([moves, wave, still])


def psnr(original, decoded):
    spread = np.ptp(original, axis=0)
    moving = spread > 1e-9
    mse = np.mean((original - decoded) ** 2, axis=0)[moving]
    return float(np.mean(10 * np.log10(spread[moving] ** 2 / np.maximum(mse, 1e-30))))


def smooth_motion(n_frames=40, fps=10.0, seed=0, max_angle=0.6, bones=None):
    """Slerps between a few random poses of the avatar's BAP-carrying bones, plus a root drift."""
    rng = np.random.default_rng(seed)
    names = bones or tuple(b.bone for b in avatar_bap_map().bones)
    keys = rotations.from_axis_angle(rng.normal(size=(4, len(names), 3)), rng.uniform(-max_angle, max_angle, (4, len(names))))
    position = np.linspace(0, 3, n_frames)
    left = np.minimum(position.astype(int), 2)
    t = np.broadcast_to((position - left)[:, None], (n_frames, len(names)))
    q = rotations.slerp(keys[left], keys[left + 1], t)
    translation = np.stack([0.02 * np.sin(position), 0.01 * position, np.zeros(n_frames)], axis=1)
    return Motion(fps, names, q, translation)

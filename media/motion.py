"""Motion: what every producer and consumer of animation speaks (DESIGN.md).

A Motion holds, for T frames at `fps` frames per second, the local rotation of each named bone
(unit quaternions (w, x, y, z), float64, in the avatar's world-aligned rest frames: see
media/avatar.py) and the translation of the root in metres. Frame t is at time t / fps seconds.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from media import rotations
from media.domain import check_fps
from media.errors import SigncastError

SUPPORTED_FPS = (10.0, 15.0, 20.0, 25.0, 29.97, 30.0)


@dataclass
class Motion:
    """fps: frames per second; bone_names: B names;
    rotations: (T, B, 4) float64 unit quaternions; root_translation: (T, 3) float64 metres."""
    fps: float
    bone_names: tuple[str, ...]
    rotations: np.ndarray
    root_translation: np.ndarray

    def __post_init__(self) -> None:
        self.bone_names = tuple(self.bone_names)
        self.rotations = np.asarray(self.rotations, dtype=np.float64)
        self.root_translation = np.asarray(self.root_translation, dtype=np.float64)
        if not (np.isfinite(self.fps) and self.fps > 0):
            raise SigncastError(f"bad frame rate {self.fps}: must be a positive number of frames per second")
        if self.rotations.ndim != 3 or self.rotations.shape[1:] != (len(self.bone_names), 4):
            raise SigncastError(f"motion rotations must be (T, {len(self.bone_names)}, 4), got {self.rotations.shape}")
        if self.root_translation.shape != (len(self.rotations), 3):
            raise SigncastError(f"motion root translation must be (T, 3), got {self.root_translation.shape}")
        if not (np.all(np.isfinite(self.rotations)) and np.all(np.isfinite(self.root_translation))):
            raise SigncastError("motion holds NaN or infinite values")

    @property
    def n_frames(self) -> int:
        return len(self.rotations)

    @property
    def duration_s(self) -> float:
        return self.n_frames / self.fps

    @classmethod
    def rest(cls, bone_names, n_frames: int = 1, fps: float = 25.0) -> "Motion":
        """n_frames of the rest pose (identity rotations, no root translation)."""
        q = np.zeros((n_frames, len(bone_names), 4))
        q[..., 0] = 1.0
        return cls(fps, tuple(bone_names), q, np.zeros((n_frames, 3)))

    def bone(self, name: str) -> int:
        try:
            return self.bone_names.index(name)
        except ValueError:
            raise SigncastError(f"motion has no bone {name!r}") from None

    def frames(self, start: int, stop: int) -> "Motion":
        return Motion(self.fps, self.bone_names, self.rotations[start:stop], self.root_translation[start:stop])

    def copy(self) -> "Motion":
        return Motion(self.fps, self.bone_names, self.rotations.copy(), self.root_translation.copy())


def concatenate(motions: list[Motion]) -> Motion:
    """Frames of several motions one after the other (same fps and bones)."""
    if not motions:
        raise SigncastError("nothing to concatenate")
    first = motions[0]
    for m in motions[1:]:
        if m.bone_names != first.bone_names or abs(m.fps - first.fps) > 1e-9:
            raise SigncastError("motions to concatenate must share bones and frame rate")
    return Motion(first.fps, first.bone_names,
                  np.concatenate([m.rotations for m in motions]),
                  np.concatenate([m.root_translation for m in motions]))


def sample(motion: Motion, times_s: np.ndarray) -> Motion:
    """Motion at arbitrary times (seconds): slerp between neighbouring frames, linear for translation.

    The returned Motion's fps is taken from the spacing of times_s when uniform, else kept.
    """
    times_s = np.asarray(times_s, dtype=np.float64)
    position = np.clip(times_s * motion.fps, 0.0, motion.n_frames - 1)
    left = np.minimum(np.floor(position).astype(np.int64), motion.n_frames - 1)
    right = np.minimum(left + 1, motion.n_frames - 1)
    t = position - left
    q = rotations.slerp(motion.rotations[left], motion.rotations[right], np.broadcast_to(t[:, None], (len(t), len(motion.bone_names))))
    translation = (1 - t)[:, None] * motion.root_translation[left] + t[:, None] * motion.root_translation[right]
    fps = 1.0 / (times_s[1] - times_s[0]) if len(times_s) > 1 else motion.fps
    return Motion(fps, motion.bone_names, q, translation)


def resample(motion: Motion, fps: float) -> Motion:
    """The same motion at another frame rate (e.g. 10/15/20/25 fps), same duration.

    Frames are taken at t = k / fps for k = 0 .. floor(duration * fps - eps); values between
    source frames are interpolated (slerp for rotations, linear for translation).
    """
    fps = check_fps(fps, "frame rate")
    if abs(fps - motion.fps) < 1e-9:
        return motion.copy()
    last_time = (motion.n_frames - 1) / motion.fps
    n = int(np.floor(last_time * fps + 1e-9)) + 1
    resampled = sample(motion, np.arange(n) / fps)
    resampled.fps = float(fps)
    return resampled

"""Motion: what every producer and consumer of animation speaks (DESIGN.md).

A Motion holds, for T frames at `fps` frames per second, the local rotation of each named bone
(unit quaternions (w, x, y, z), float64, in the avatar's world-aligned rest frames: see
media/avatar.py) and the translation of the root in metres. Frame t is at time t / fps seconds.
A Motion may also carry the face: the 68 MPEG-4 FAP values of each frame (comparisons/params/fap_table.py), in
FAPU of the face they were measured on, so any face (the avatar's own FAPU) can play them.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from media import rotations
from media.domain import check_fps
from media.errors import SigncastError

N_FAPS = 68     # comparisons/params/fap_table.py (media does not import the encoder layer)

SUPPORTED_FPS = (10.0, 15.0, 20.0, 25.0, 29.97, 30.0)


@dataclass
class Motion:
    """fps: frames per second; bone_names: B names;
    rotations: (T, B, 4) float64 unit quaternions; root_translation: (T, 3) float64 metres;
    faps: None (no face) or (T, 68) int64 FAP values (index = FAP id - 1; FAPU, or 1e-5 rad)."""
    fps: float
    bone_names: tuple[str, ...]
    rotations: np.ndarray
    root_translation: np.ndarray
    faps: np.ndarray | None = None

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
        if self.faps is not None:
            self.faps = np.asarray(self.faps)
            if self.faps.shape != (len(self.rotations), N_FAPS) or not np.issubdtype(self.faps.dtype, np.integer):
                raise SigncastError(f"motion FAPs must be (T, {N_FAPS}) integers, got {self.faps.shape} {self.faps.dtype}")
            self.faps = self.faps.astype(np.int64)

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
        faps = None if self.faps is None else self.faps[start:stop]
        return Motion(self.fps, self.bone_names, self.rotations[start:stop], self.root_translation[start:stop], faps)

    def copy(self) -> "Motion":
        faps = None if self.faps is None else self.faps.copy()
        return Motion(self.fps, self.bone_names, self.rotations.copy(), self.root_translation.copy(), faps)

    def without_face(self) -> "Motion":
        """The same body motion with no FAPs."""
        return Motion(self.fps, self.bone_names, self.rotations, self.root_translation)


def concatenate(motions: list[Motion]) -> Motion:
    """Frames of several motions one after the other (same fps and bones); a part without a face
    gets neutral FAPs (0) when another part has one."""
    if not motions:
        raise SigncastError("nothing to concatenate")
    first = motions[0]
    for m in motions[1:]:
        if m.bone_names != first.bone_names or abs(m.fps - first.fps) > 1e-9:
            raise SigncastError("motions to concatenate must share bones and frame rate")
    faps = None
    if any(m.faps is not None for m in motions):
        faps = np.concatenate([m.faps if m.faps is not None else np.zeros((m.n_frames, N_FAPS), np.int64)
                               for m in motions])
    return Motion(first.fps, first.bone_names,
                  np.concatenate([m.rotations for m in motions]),
                  np.concatenate([m.root_translation for m in motions]), faps)


def sample(motion: Motion, times_s: np.ndarray) -> Motion:
    """Motion at arbitrary times (seconds): slerp between neighbouring frames, linear for translation.

    The returned Motion's fps is taken from the spacing of times_s when uniform, else kept. FAPs
    are interpolated linearly and rounded.
    """
    times_s = np.asarray(times_s, dtype=np.float64)
    position = np.clip(times_s * motion.fps, 0.0, motion.n_frames - 1)
    left = np.minimum(np.floor(position).astype(np.int64), motion.n_frames - 1)
    right = np.minimum(left + 1, motion.n_frames - 1)
    t = position - left
    q = rotations.slerp(motion.rotations[left], motion.rotations[right], np.broadcast_to(t[:, None], (len(t), len(motion.bone_names))))
    translation = (1 - t)[:, None] * motion.root_translation[left] + t[:, None] * motion.root_translation[right]
    fps = 1.0 / (times_s[1] - times_s[0]) if len(times_s) > 1 else motion.fps
    faps = None
    if motion.faps is not None:
        faps = np.round((1 - t)[:, None] * motion.faps[left] + t[:, None] * motion.faps[right]).astype(np.int64)
    return Motion(fps, motion.bone_names, q, translation, faps)


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

"""The avatar's motion written as BVH: a word fingerspelled from real signers' letters retargeted to it, or any
`.pose` file of MediaPipe Holistic keypoints retargeted the same way (media.retarget)."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from media.errors import SigncastError
from pipeline.studies.shared import LEXICON_FPS, check_source, source_motion



@dataclass(frozen=True)
class MotionSettings:
    """language, word: what the avatar fingerspells (or None with `pose`); output: the BVH file; fps: frames per
    second (None: 25 for a word, the file's own rate for a .pose); pose: a .pose file to retarget instead of a
    word; jitter_filter: one-euro, binomial or off for the .pose keypoints (None: media.retarget's default)."""

    language: str | None
    word: str | None
    output: Path
    fps: float | None = LEXICON_FPS
    pose: Path | None = None
    jitter_filter: str | None = None


def check(settings: MotionSettings) -> None:
    check_source(settings.language, settings.word, settings.pose, settings.fps, settings.jitter_filter)


def run(settings: MotionSettings, *, notify: Callable[[str], object] | None = None) -> str:
    """Build the motion and write the BVH; a one-line summary (frames, rate, duration, bones)."""
    from media.avatar import load_avatar
    from media.bvh import write_bvh

    motion, source = source_motion(settings.language, settings.word, settings.pose, settings.fps,
                                   settings.jitter_filter, notify)
    try:
        write_bvh(settings.output, motion, load_avatar().skeleton)
    except OSError as error:
        raise SigncastError(f"cannot write {settings.output}: {error.strerror or error}") from None
    return (f"{settings.output}: {source}, {motion.n_frames} frames at {motion.fps:g} fps "
            f"({motion.duration_s:.2f} s), {len(motion.bone_names)} bones")

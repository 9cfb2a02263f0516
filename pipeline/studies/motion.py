"""The avatar fingerspelling a word from real signers' letters retargeted to it, written as BVH."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from media.errors import SigncastError


@dataclass(frozen=True)
class MotionSettings:
    """language, word: what the avatar fingerspells; output: the BVH file; fps: frames per second."""

    language: str
    word: str
    output: Path
    fps: float = 25.0


def check(settings: MotionSettings) -> None:
    from media.domain import check_fps
    check_fps(settings.fps)


def run(settings: MotionSettings) -> str:
    """Fingerspell and write the BVH; a one-line summary (frames, rate, duration, bones)."""
    from media.avatar import load_avatar
    from media.bvh import write_bvh
    from media.fingerspelling import fingerspell

    motion = fingerspell(settings.language, settings.word, fps=settings.fps)
    try:
        write_bvh(settings.output, motion, load_avatar().skeleton)
    except OSError as error:
        raise SigncastError(f"cannot write {settings.output}: {error.strerror or error}") from None
    return (f"{settings.output}: {settings.language} {settings.word!r}, {motion.n_frames} frames at {motion.fps:g} fps "
            f"({motion.duration_s:.2f} s), {len(motion.bone_names)} bones")

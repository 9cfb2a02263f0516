"""The avatar's motion written as BVH: a word fingerspelled from real signers' letters retargeted to it, or any
`.pose` file of MediaPipe Holistic keypoints retargeted the same way (media.retarget)."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from media.errors import SigncastError
from media.motion import Motion

LEXICON_FPS = 25.0


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


def check_source(language: str | None, word: str | None, pose: Path | None, fps: float | None,
                 jitter_filter: str | None) -> None:
    """Refuse (one-line SigncastError) a motion source that is not exactly one of LANGUAGE WORD and a .pose, a bad
    frame rate (None: the source's own) or an unknown jitter filter (None: the default)."""
    from media.domain import check_fps
    from media.jitter_filter import check_filter
    if fps is not None:
        check_fps(fps)
    if jitter_filter is not None:
        check_filter(jitter_filter)
    if (pose is None) == (language is None or word is None):
        raise SigncastError("give either LANGUAGE WORD or --pose FILE")


def pose_motion(pose: Path, fps: float | None, jitter_filter: str | None,
                notify: Callable[[str], object] | None = None):
    """(Motion, Retargeted) of a .pose file retargeted to the avatar, resampled to `fps` (None: the file's own).

    notify: called with a one-line notice when the file shows neither hand (both arms then rest)."""
    from media.avatar import load_avatar
    from media.motion import resample
    from media.pose_file import read_pose
    from media.retarget import retarget

    clip = read_pose(pose)
    result = retarget(clip, load_avatar().skeleton, jitter_filter=jitter_filter)
    if not result.hands and notify:
        notify(f"{pose} shows no hand in enough frames: both arms rest, only the head and torso move")
    motion = result.motion if fps is None else resample(result.motion, fps)
    return motion, result


def source_motion(language: str | None, word: str | None, pose: Path | None, fps: float | None,
                  jitter_filter: str | None, notify: Callable[[str], object] | None = None) -> tuple[Motion, str]:
    """(the avatar's Motion, a few words naming its source): a .pose retargeted (at its own rate unless fps), or
    LANGUAGE WORD fingerspelled (at fps, else LEXICON_FPS)."""
    from media.fingerspelling import fingerspell

    if pose is not None:
        motion, result = pose_motion(pose, fps, jitter_filter, notify)
        return motion, f"{pose.name} (hands: {', '.join(result.hands) or 'none'})"
    return fingerspell(language, word, fps=fps or LEXICON_FPS), f"{language} {word!r}"


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

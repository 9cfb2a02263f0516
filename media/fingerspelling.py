"""Fingerspelling a word on the avatar from the real lexicon clips.

The word is split into the language's lexicon units (longest match first, case-insensitive:
CH, SCH, LL, RR, doubled letters, Greek, Cyrillic and Arabic letters; media.lexicon.split_word),
each unit's clip is retargeted to the avatar (media.retarget, cached in memory), resampled to
one frame rate, and consecutive letters are joined by a short slerp cross-fade: the last frames
of one letter blend into the first frames of the next with smoothstep weights. A space holds
the last pose for a short pause. Nothing is downloaded.
"""
from __future__ import annotations

import functools
import math

import numpy as np

from media import lexicon, rotations
from media.errors import SigncastError
from media.motion import Motion, resample
from media.retarget import retarget_clip

TRANSITION_S = 0.12     # cross-fade between letters (3 frames at 25 fps)
PAUSE_S = 0.3           # hold for a space between words


def check_fps(fps: float) -> float:
    if not (isinstance(fps, (int, float)) and math.isfinite(fps) and 0 < fps <= 240):
        raise SigncastError(f"bad frame rate {fps}: choose a value in (0, 240], e.g. 10, 15, 20 or 25")
    return float(fps)


@functools.lru_cache(maxsize=2048)
def _native_letter(language: str, unit: str) -> Motion:
    """The retargeted clip of one unit at the clip's own frame rate (cached)."""
    return retarget_clip(lexicon.read_clip(lexicon.lookup(language, unit)))


def letter_motion(language: str, unit: str, fps: float = 25.0) -> Motion:
    """One lexicon unit (e.g. 'A', 'CH') retargeted to the avatar, at `fps` frames per second."""
    fps = check_fps(fps)
    language = lexicon.check_language(language)
    entry = lexicon.lookup(language, unit)
    return resample(_native_letter(language, entry.unit), fps)


def _cross_fade(first: Motion, second: Motion, frames: int) -> Motion:
    """first then second, the last `frames` of first blended into the first `frames` of second."""
    frames = min(frames, first.n_frames - 1, second.n_frames - 1)
    if frames <= 0:
        return Motion(first.fps, first.bone_names, np.concatenate([first.rotations, second.rotations]),
                      np.concatenate([first.root_translation, second.root_translation]))
    x = np.arange(1, frames + 1) / (frames + 1)
    weight = x * x * (3 - 2 * x)                                     # smoothstep
    tail, head = first.rotations[-frames:], second.rotations[:frames]
    blended = rotations.slerp(tail, head, np.broadcast_to(weight[:, None], tail.shape[:2]))
    translation = ((1 - weight)[:, None] * first.root_translation[-frames:]
                   + weight[:, None] * second.root_translation[:frames])
    return Motion(first.fps, first.bone_names,
                  np.concatenate([first.rotations[:-frames], blended, second.rotations[frames:]]),
                  np.concatenate([first.root_translation[:-frames], translation, second.root_translation[frames:]]))


def fingerspell(language: str, word: str, fps: float = 25.0) -> Motion:
    """The avatar fingerspelling `word` in sign language `language` (e.g. 'ase'), at `fps`.

    Raises SigncastError for an unknown language, a letter the language's lexicon lacks, an
    empty word or a bad frame rate; the message names what exists.
    """
    fps = check_fps(fps)
    language = lexicon.check_language(language)
    units = lexicon.split_word(language, word)
    transition = max(1, int(round(TRANSITION_S * fps)))
    motion: Motion | None = None
    pending_pause = False
    for unit in units:
        if unit == " ":
            pending_pause = motion is not None
            continue
        letter = letter_motion(language, unit, fps)
        if motion is None:
            motion = letter
            continue
        if pending_pause:
            hold = max(1, int(round(PAUSE_S * fps)))
            motion = Motion(fps, motion.bone_names,
                            np.concatenate([motion.rotations, np.repeat(motion.rotations[-1:], hold, axis=0)]),
                            np.concatenate([motion.root_translation, np.repeat(motion.root_translation[-1:], hold, axis=0)]))
            pending_pause = False
        motion = _cross_fade(motion, letter, transition)
    if motion is None:
        raise SigncastError(f"nothing to fingerspell in {word!r}")
    motion.fps = fps
    return motion

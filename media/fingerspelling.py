"""Fingerspelling a word on the avatar from the real lexicon clips.

The word is split into the language's lexicon units (longest match first, case-insensitive:
CH, SCH, LL, RR, doubled letters, Greek, Cyrillic and Arabic letters; media.lexicon.split_word),
each unit's clip is retargeted to the avatar (media.retarget, cached in memory), resampled to
one frame rate, and consecutive letters are joined by a short slerp cross-fade: the last frames
of one letter blend into the first frames of the next with smoothstep weights. Every lexicon clip
starts with the hand rising into place and ends with it dropping; inside a word those frames are
cut (the hand stays up between letters, as in real fingerspelling), so only the first letter
rises and the last one drops. A space holds the last pose for a short pause. Nothing is downloaded.

Where a clip's rise ends and its drop begins (held_span) decides whether the arm dips between letters;
interletter_drops measures the dip with the avatar's forward kinematics (metres below both letters'
holds). Over 569 random two-letter words in 19 languages (every language but fsl, the ASL clips
again), a dip of more than 0.3 palm lengths (2.9 cm) happened in 10.4 % of the words with the former
rule (leading / trailing frames each faster than 0.15 palm lengths per frame; a jittery slow frame
ended the cut, and a first step down, the languages' shared first frame, cut nothing) and in 4.0 % with
the present one (95th percentile 0.70 -> 0.23 palm lengths, largest 2.29 -> 0.91); most of the rest are
letters whose own movement goes down (LSE/ESO/LSL H) or clips with broken keypoints (GSS, PSR Y).
"""
from __future__ import annotations

import functools

import numpy as np

from media import lexicon, rotations
from media.avatar import Skeleton, load_avatar
from media.domain import check_fps
from media.errors import SigncastError
from media.kinematics import joint_positions
from media.motion import N_FAPS, Motion, concatenate, resample
from media.retarget import retarget_clip

TRANSITION_S = 0.12     # cross-fade between letters (3 frames at 25 fps)
PAUSE_S = 0.3           # hold for a space between words


HOLD_SPEED = 0.1        # palm lengths per 1/25 s: wrists moving up or down faster (3-frame mean) are not holding
HOLD_SMOOTHING = 3      # frames averaged per speed: one slow (jittery) frame must not end a rise or a drop
RISE_LEAST = 0.75       # palm lengths: a faster run that rises less is a twitch at rest, not the rise into place


def _wrist_heights(clip: lexicon.SignClip) -> np.ndarray | None:
    """(H, T) height of each hand's wrist seen in at least a quarter of the frames, in its palm lengths
    (wrist to middle knuckle, median), up positive, interpolated over the frames it is not seen; None if none."""
    heights = []
    for component in lexicon.HAND_COMPONENTS.values():
        seen = np.all(clip.confidence[component] > 0, axis=1)
        if seen.mean() < 0.25:
            continue
        points = clip.points[component]
        frames = np.flatnonzero(seen)
        palm = max(float(np.median(np.linalg.norm(points[frames, 9, :2] - points[frames, 0, :2], axis=-1))), 1e-6)
        heights.append(-np.interp(np.arange(clip.n_frames), frames, points[frames, 0, 1]) / palm)
    return np.array(heights) if heights else None


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(first, last) indices of each run of True in a 1-D bool array, in order."""
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1))


def held_span(clip: lexicon.SignClip) -> tuple[int, int]:
    """Frames [start, stop) of a clip without the hand rising into place and dropping away.

    The wrists' mean height h (palm lengths) gives a speed per frame step at 25 fps, averaged over
    HOLD_SMOOTHING steps. The rise is the first run of steps starting in the clip's first half that go
    up faster than HOLD_SPEED and rise at least RISE_LEAST in all (else the run that rises most), with
    the frames before it (the hand waiting at rest; every clip's first frame is its language's shared
    start pose). The drop is the last run of steps ending in the second half that go down that fast,
    with the frames after it (the hand slowing down near the thigh). A movement inside the letter (J,
    Z, LSE H going down) separated from them by a slower moment is kept. If less than a third of the
    clip (or 3 frames) would remain, that many frames centred on what remained are kept.
    """
    n_frames = clip.n_frames
    heights = _wrist_heights(clip)
    if heights is None or n_frames < 4:
        return 0, n_frames
    height = heights.mean(axis=0)
    steps = np.diff(height) * (25.0 / clip.fps)                                # + is up
    pad = HOLD_SMOOTHING // 2
    speed = np.convolve(np.pad(steps, (pad, HOLD_SMOOTHING - 1 - pad), mode="edge"),
                        np.ones(HOLD_SMOOTHING) / HOLD_SMOOTHING, mode="valid")
    half = len(speed) // 2
    start, stop = 0, n_frames
    rises = [(first, last) for first, last in _runs(speed > HOLD_SPEED) if first < half]
    if rises:
        gains = [height[last + 1] - height[first] for first, last in rises]
        large = [run for run, gain in zip(rises, gains) if gain >= RISE_LEAST]
        start = int((large[0] if large else rises[int(np.argmax(gains))])[1] + 1)
    drops = [(first, last) for first, last in _runs(speed < -HOLD_SPEED) if last >= half]
    if drops:
        stop = int(drops[-1][0] + 1)                           # the frame the last drop starts from, + 1
    shortest = max(3, n_frames // 3)
    if stop - start < shortest:
        middle = (start + stop) // 2 if stop > start else n_frames // 2
        start = int(np.clip(middle - shortest // 2, 0, n_frames - shortest))
        stop = start + shortest
    return start, stop


@functools.lru_cache(maxsize=2048)
def _native_letter(language: str, unit: str) -> tuple[Motion, tuple[int, int]]:
    """The retargeted clip of one unit at the clip's own frame rate and its held span (cached)."""
    clip = lexicon.read_clip(lexicon.lookup(language, unit))
    return retarget_clip(clip), held_span(clip)


def letter_motion(language: str, unit: str, fps: float = 25.0, *, keep_rise: bool = True,
                  keep_drop: bool = True) -> Motion:
    """One lexicon unit (e.g. 'A', 'CH') retargeted to the avatar, at `fps` frames per second.

    keep_rise / keep_drop: keep the clip's frames of the hand rising into place / dropping away.
    """
    fps = check_fps(fps, "frame rate")
    language = lexicon.check_language(language)
    entry = lexicon.lookup(language, unit)
    motion, (start, stop) = _native_letter(language, entry.unit)
    motion = motion.frames(0 if keep_rise else start, motion.n_frames if keep_drop else stop)
    return resample(motion, fps)


def _cross_fade(first: Motion, second: Motion, frames: int) -> Motion:
    """first then second, the last `frames` of first blended into the first `frames` of second (the faces' FAPs
    too, linearly; a letter without a face counts as a neutral face when the other has one)."""
    frames = min(frames, first.n_frames - 1, second.n_frames - 1)
    with_face = first.faps is not None or second.faps is not None
    first_faps, second_faps = _faps_or_neutral(first), _faps_or_neutral(second)
    if frames <= 0:
        return Motion(first.fps, first.bone_names, np.concatenate([first.rotations, second.rotations]),
                      np.concatenate([first.root_translation, second.root_translation]),
                      np.concatenate([first_faps, second_faps]) if with_face else None)
    x = np.arange(1, frames + 1) / (frames + 1)
    weight = x * x * (3 - 2 * x)                                     # smoothstep
    tail, head = first.rotations[-frames:], second.rotations[:frames]
    blended = rotations.slerp(tail, head, np.broadcast_to(weight[:, None], tail.shape[:2]))
    translation = ((1 - weight)[:, None] * first.root_translation[-frames:]
                   + weight[:, None] * second.root_translation[:frames])
    faps = None
    if with_face:
        blended_faps = np.rint((1 - weight)[:, None] * first_faps[-frames:] + weight[:, None] * second_faps[:frames])
        faps = np.concatenate([first_faps[:-frames], blended_faps.astype(np.int64), second_faps[frames:]])
    return Motion(first.fps, first.bone_names,
                  np.concatenate([first.rotations[:-frames], blended, second.rotations[frames:]]),
                  np.concatenate([first.root_translation[:-frames], translation, second.root_translation[frames:]]),
                  faps)


def _faps_or_neutral(motion: Motion) -> np.ndarray:
    """(T, 68) the motion's FAPs, or a neutral face's (all 0) when it has none."""
    return motion.faps if motion.faps is not None else np.zeros((motion.n_frames, N_FAPS), np.int64)


def fingerspell(language: str, word: str, fps: float = 25.0) -> Motion:
    """The avatar fingerspelling `word` in sign language `language` (e.g. 'ase'), at `fps`.

    Raises SigncastError for an unknown language, a letter the language's lexicon lacks, an
    empty word or a bad frame rate; the message names what exists.
    """
    fps = check_fps(fps, "frame rate")
    language = lexicon.check_language(language)
    units = lexicon.split_word(language, word)
    transition = max(1, int(round(TRANSITION_S * fps)))
    motion: Motion | None = None
    pending_pause = False
    letters = [k for k, unit in enumerate(units) if unit != " "]
    for k, unit in enumerate(units):
        if unit == " ":
            pending_pause = motion is not None
            continue
        letter = letter_motion(language, unit, fps, keep_rise=k == letters[0], keep_drop=k == letters[-1])
        if motion is None:
            motion = letter
            continue
        if pending_pause:
            hold = max(1, int(round(PAUSE_S * fps)))
            last = motion.frames(motion.n_frames - 1, motion.n_frames)
            motion = concatenate([motion] + [last] * hold)
            pending_pause = False
        motion = _cross_fade(motion, letter, transition)
    if motion is None:
        raise SigncastError(f"nothing to fingerspell in {word!r}")
    motion.fps = fps
    return motion


def _held_frames(language: str, unit: str, fps: float, keep_rise: bool, keep_drop: bool) -> tuple[int, int, int]:
    """(n_frames, first held, end held exclusive) of letter_motion(language, unit, fps, keep_rise, keep_drop)."""
    native, (start, stop) = _native_letter(language, lexicon.lookup(language, unit).unit)
    origin = 0 if keep_rise else start
    last = (native.n_frames if keep_drop else stop) - 1 - origin        # native frames after the origin
    n_frames = int(np.floor(last / native.fps * fps + 1e-9)) + 1 if abs(fps - native.fps) >= 1e-9 else last + 1
    first_held = int(np.ceil((start - origin) / native.fps * fps - 1e-9))
    end_held = int(np.floor((stop - 1 - origin) / native.fps * fps + 1e-9)) + 1
    return n_frames, max(0, first_held), min(n_frames, end_held)


def letter_spans(language: str, word: str, fps: float = 25.0) -> list[tuple[str, int, int]]:
    """Where each letter's handshape is held in fingerspell(language, word, fps): (unit, start, end exclusive).

    Frames of a letter's held span (held_span: no rise, no drop) that no cross-fade touches; a pause after
    a letter (a space) holds its last pose and belongs to it. Units as written in the lexicon, in order;
    the spans lie inside the word's motion and do not overlap. Raises SigncastError like fingerspell.
    """
    fps = check_fps(fps, "frame rate")
    language = lexicon.check_language(language)
    units = lexicon.split_word(language, word)
    transition = max(1, int(round(TRANSITION_S * fps)))
    letters = [k for k, unit in enumerate(units) if unit != " "]
    if not letters:
        raise SigncastError(f"nothing to fingerspell in {word!r}")
    placed = []                      # (unit, start in the word, first unblended frame, first held, end held)
    total = 0
    pending_pause = False
    for k, unit in enumerate(units):
        if unit == " ":
            pending_pause = total > 0
            continue
        n_frames, first_held, end_held = _held_frames(language, unit, fps, k == letters[0], k == letters[-1])
        unit = lexicon.lookup(language, unit).unit
        if not placed:
            placed.append((unit, 0, 0, first_held, end_held))
            total = n_frames
            continue
        if pending_pause:
            total += max(1, int(round(PAUSE_S * fps)))
            pending_pause = False
        blend = max(0, min(transition, total - 1, n_frames - 1))   # as _cross_fade
        start = total - blend
        placed.append((unit, start, start + blend, start + first_held, start + end_held))
        total = start + n_frames
    spans = []
    for index, (unit, start, unblended, first_held, end_held) in enumerate(placed):
        last = index + 1 == len(placed)
        next_blend = total if last else placed[index + 1][1]
        span_start = max(unblended, first_held)
        # inside the word a letter's motion ends held (no drop): it holds up to the next cross-fade
        span_end = min(end_held, total) if last else next_blend
        if span_end <= span_start:                       # a letter too short to be clear of the cross-fades
            middle = (unblended + next_blend - 1) // 2
            span_start, span_end = middle, middle + 1
        spans.append((unit, span_start, span_end))
    return spans


def interletter_drops(motion: Motion, spans: list[tuple[str, int, int]], skeleton: Skeleton | None = None) -> np.ndarray:
    """(len(spans) - 1,) metres: how far each wrist dips between consecutive letters, below both holds.

    spans: (unit, start, end exclusive) frames of each letter's hold in `motion` (letter_spans). For each
    pair, with a letter's hold height the median height of its wrist over the third of its span next to
    the transition (a letter's own movement, LSE H going down, moves its hold), the drop is the lower of
    the two hold heights minus the lowest wrist height from the last third of the first span to the
    first third of the next (0 if the wrist stays above): a drop-and-raise of the arm between letters
    shows here, a direct move from one hand position to the next does not. The larger of both wrists.
    """
    skeleton = skeleton or load_avatar().skeleton
    heads = joint_positions(skeleton, motion)
    wrists = heads[:, [skeleton.index("wrist.L"), skeleton.index("wrist.R")], 1]      # (T, 2) metres up
    drops = np.zeros(max(len(spans) - 1, 0))
    for k, ((_, start_a, end_a), (_, start_b, end_b)) in enumerate(zip(spans[:-1], spans[1:])):
        leave = max(start_a, end_a - max(1, (end_a - start_a) // 3))
        arrive = min(end_b, start_b + max(1, (end_b - start_b) // 3))
        held = np.minimum(np.median(wrists[leave:end_a], axis=0), np.median(wrists[start_b:arrive], axis=0))
        lowest = wrists[leave:arrive].min(axis=0)
        drops[k] = float(np.max(np.maximum(held - lowest, 0.0)))
    return drops


def interletter_drop(motion: Motion, spans: list[tuple[str, int, int]], skeleton: Skeleton | None = None) -> float:
    """The largest interletter_drops (metres; 0 for a single letter)."""
    drops = interletter_drops(motion, spans, skeleton)
    return float(drops.max()) if len(drops) else 0.0

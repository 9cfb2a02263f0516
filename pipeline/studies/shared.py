"""What the studies share: reading a clip or a .pose, the signing every comparison carries, rendering frames, and
extracting landmarks, each with its progress bar. Studies import this module and no other study.

- Natural clips: `read_natural_clip` (frames at their own timing, scaled to fit, refused without 2 frames or a face),
  `Timing` (when frames are shown), `segment_clip` (part labels by landmarks or by colour).
- Landmarks: `extract_landmarks` (one extraction, pixels, media.lexicon.SignClip), `extract_draws` (several, each
  under one of comparisons.judging.landmark_draws.SHIFTS, moved back onto the frames' grid), `draw_landmarks`.
- .pose and motion: `read_pose` (at least 2 frames), `source_motion` (a word fingerspelled or a .pose retargeted),
  `pose_file_kbps` (a lexicon clip's .pose size over its duration).
- The signing of `compare` and `live`: `SigningSettings`, `Signing` (reference frames, labels, landmarks, the
  avatar's motion and its lossless render), `load_signing`; `renderers`, `render_frames`.

Every function refuses bad input with a one-line media.errors.SigncastError; progress bars (tqdm, stderr) are shown
unless progress=False.
"""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Callable

import cv2
import numpy as np
from tqdm import tqdm

from comparisons.judging.landmark_draws import SHIFTS, shifted, unshift
from media import faces, segmentation
from media.domain import Solution
from media.errors import SigncastError
from media.lexicon import SignClip
from media.motion import Motion
from media.video_io import Clip, crop_even, fit_size, read_clip, resolve_video, video_info
from pipeline.checks import check_memory

if TYPE_CHECKING:
    from media.framing import Framing
    from media.render import AvatarRenderer

DEFAULT_MAX_SIZE = (352, 288)   # (width, height), CIF: larger clips are scaled down to fit unless asked otherwise
DISPLAY_FPS = 25.0              # frame rate of the avatar scenarios ("word"; "pose" keeps the file's own)
LEXICON_FPS = 25.0              # the lexicon's own frame rate


# ------------------------------------------------------------------------------------------------------------
# natural clips

@dataclass(frozen=True)
class VideoSweep:
    """The video sweep of `video` and `compare`. qs: MPEG-4 quantisers; operating_q: the Q of the frame-rate,
    resolution and codec sweeps; frame_rates: the rates swept (those below source_fps are used); source_fps: the
    rate of the frames given to the study, frames per second; solutions: the video solutions coded; other_codecs:
    today's codecs at matched quality; half_resolution: the half-size sweep."""

    qs: tuple[int, ...] = (2, 6, 12, 24, 31)
    operating_q: int = 12
    frame_rates: tuple[float, ...] = (25.0, 20.0, 15.0, 10.0)
    source_fps: float = 25.0
    solutions: tuple[str, ...] = Solution.natural_family()
    other_codecs: tuple[str, ...] = ("libx264", "libsvtav1")
    half_resolution: bool = True


@dataclass(frozen=True)
class Timing:
    """When the frames given to the study are shown."""

    times_s: np.ndarray      # (T,) presentation time of each frame from the first one, seconds
    duration_s: float        # the clip's real duration for these frames, seconds
    native_fps: float        # the clip's own frame rate, frames per second

    @classmethod
    def regular(cls, n_frames: int, fps: float) -> "Timing":
        """n_frames shown every 1/fps seconds."""
        return cls(np.arange(n_frames) / fps, n_frames / fps, fps)

    @classmethod
    def of_clip(cls, clip: Clip) -> "Timing":
        return cls(clip.times_s, clip.duration_s, clip.native_fps)


def read_natural_clip(name_or_path: str, max_frames: int | None = None,
                      max_size: tuple[int, int] | None = DEFAULT_MAX_SIZE, fps: float | None = None,
                      *, progress: bool = True) -> tuple[Clip, list[str]]:
    """A natural signer clip, and one-line notes on what was read (for the user).

    The frames keep the clip's own timing, or are taken at the lower rate fps (frames per second) by keeping
    the frame on screen at each tick; they are scaled down to fit max_size (width, height) when larger (None:
    keep the size) and cropped to even sides. Refused (SigncastError) before the long work: fewer than 2
    decodable frames, or no face in a sample of frames.
    """
    path = resolve_video(name_or_path)
    info = video_info(path)
    expected = min(filter(None, (info.announced_frames, max_frames)), default=None)
    if expected:                    # the decoded frames alone, before anything else is held
        check_memory(expected, *fit_size(info.width, info.height, max_size), 3, f"reading {path.name}",
                     "choose a smaller --max-size or fewer --frames")
    with tqdm(total=expected, desc=f"read {path.name}", unit="frame", disable=not progress) as bar:
        clip = read_clip(path, max_frames, max_size, progress=bar.update)
    read = len(clip.frames)
    notes = [f"read {read} frames of {path.name}: {clip.source_size[0]}x{clip.source_size[1]} at "
             f"{clip.native_fps:.4g} fps, {clip.duration_s:.2f} s"]
    if clip.announced_frames > read and not (max_frames and read >= max_frames):
        stopped = f" (decoding stopped: {clip.decode_error})" if clip.decode_error else ""
        notes.append(f"warning: read {read} of {clip.announced_frames} frames announced by the container{stopped}")
    if read < 2:
        raise SigncastError(f"video {path} holds {read} decodable frame"
                            f"{f' of {clip.announced_frames} announced' if clip.announced_frames > read else ''}: "
                            f"at least 2 are needed")
    clip = replace(clip, frames=crop_even(clip.frames))
    if clip.size != clip.source_size and max_size is not None:
        notes.append(f"downscaled {path.name} from {clip.source_size[0]}x{clip.source_size[1]} to "
                     f"{clip.size[0]}x{clip.size[1]} to fit --max-size {max_size[0]}x{max_size[1]} "
                     f"(--max-size none keeps the size)")
    with tqdm(total=min(faces.SAMPLED_FRAMES, read), desc="look for a person", unit="frame", disable=not progress) as bar:
        faces.check_person(clip.frames, path.name, progress=bar.update)
    if fps is not None and abs(fps - clip.fps) > 1e-3 * clip.fps:     # 29.97 asks for 30000/1001's own rate
        clip = clip.at_rate(fps)
        notes.append(f"coding at {fps:g} fps: {len(clip.frames)} of {read} frames, kept by presentation time")
    return clip, notes


SEGMENTATIONS = {
    "landmarks": "landmarks (selfie segmentation + face and hand landmarks + skin colour)",
    "colour": "colour (GrabCut border model + clothes clusters)",
}
DEFAULT_SEGMENTATION = "landmarks"


def check_segmentation(method: str) -> str:
    if method not in SEGMENTATIONS:
        raise SigncastError(f"unknown --segmentation {method!r}: choose {' or '.join(SEGMENTATIONS)}")
    return method


def extract_clip_landmarks(frames: np.ndarray, fps: float, *, progress: bool = True):
    """Landmarks (media.lexicon.SignClip, pixels) of frames (T, H, W, 3) uint8 RGB shown at fps, with a progress bar."""
    return extract_landmarks(frames, fps, "landmarks", progress, leave=True)


def segment_clip(frames: np.ndarray, *, progress: bool = True, method: str = DEFAULT_SEGMENTATION,
                 landmarks=None, fps: float = 25.0) -> np.ndarray:
    """Part labels (T, H, W) uint8 of frames (T, H, W, 3) uint8 RGB, with progress bars.

    method: "colour" (media.segmentation) or "landmarks" (media.segmentation_landmarks; landmarks: the clip's
    SignClip, extracted here at fps frames per second when not given)."""
    check_segmentation(method)
    if method == "colour":
        with tqdm(total=len(frames), desc="segment signer", unit="frame", disable=not progress) as bar:
            signer = segmentation.segment_signer(frames, progress=bar.update)
        with tqdm(total=len(frames), desc="segment parts", unit="frame", disable=not progress) as bar:
            return segmentation.segment_parts(frames, signer, progress=bar.update)
    from media.landmarks.person_mask import person_masks
    from media.segmentation_landmarks import segment_by_landmarks

    if landmarks is None:
        landmarks = extract_clip_landmarks(frames, fps, progress=progress)
    with tqdm(total=len(frames), desc="person mask", unit="frame", disable=not progress) as bar:
        person = person_masks(frames, progress=bar.update)
    with tqdm(total=len(frames), desc="segment parts", unit="frame", disable=not progress) as bar:
        return segment_by_landmarks(frames, landmarks, person, progress=bar.update)


# ------------------------------------------------------------------------------------------------------------
# landmarks

EXTRACTION = {"seconds": 0.0, "frames": 0}     # this process's landmark extraction (extract_landmarks), so far


def extract_landmarks(frames: np.ndarray, fps: float, label: str = "landmarks", progress: bool = True, *,
                      leave: bool = False, hands: np.ndarray | None = None) -> SignClip:
    """Landmarks (pixels) of frames (T, H, W, 3) uint8 RGB shown at fps (signcast's Holistic graph), with a progress
    bar (counts, ETA; kept on screen when done with leave). hands: (T, 2) bool, the frames in which the left and the
    right hand are looked for (None: every frame). Its time and frames are added to EXTRACTION."""
    import time
    from media.landmarks.holistic import extract_landmarks as holistic
    started = time.perf_counter()
    try:
        with tqdm(total=len(frames), desc=label, unit="frame", disable=not progress, leave=leave) as bar:
            return holistic(frames, fps, progress=bar.update, hands=hands)
    finally:
        EXTRACTION["seconds"] += time.perf_counter() - started
        EXTRACTION["frames"] += len(frames)


def extract_draws(frames: np.ndarray, fps: float, count: int, label: str, progress: bool, *,
                  shifts: tuple[int, ...] | None = None, cache: "ExtractionCache | None" = None,
                  hands: np.ndarray | None = None) -> list[SignClip]:
    """Extractions of frames (T, H, W, 3) uint8, each at one of the SHIFTS (comparisons.judging.landmark_draws; the
    first count, or those indexed by shifts), with the found points moved back by the shift onto the frames' own
    pixel grid (missing points stay at 0). hands: (T, 2) bool, the frames in which the left and the right hand are
    looked for (None: every frame; comparisons.judging.judge.hands_to_extract).

    Each distinct picture is extracted once (comparisons.judging.judge.distinct_frames: a frame byte-identical to
    an earlier one, held on screen or decoded alike, takes that frame's landmarks, its hands looked for where any
    of those frames needs them), and a subject whose distinct pictures were all extracted before under the same
    shift and hands (cache) is not extracted again."""
    from comparisons.judging.judge import distinct_frames, select_frames
    first, inverse = distinct_frames(frames)
    pictures = frames[first]
    indices = tuple(range(count)) if shifts is None else tuple(shifts)
    if hands is not None:
        wanted = np.zeros((len(first), 2), bool)
        np.logical_or.at(wanted, inverse, np.asarray(hands, bool))
        hands = wanted
    key = ExtractionCache.key(pictures, fps, hands)
    draws = []
    for n, k in enumerate(indices):
        shift = SHIFTS[k]
        found = cache.get(key, k) if cache is not None else None
        if found is None:
            text = label + (f" ({n + 1}/{len(indices)})" if len(indices) > 1 else "")
            found = unshift(extract_landmarks(shifted(pictures, shift), fps, text, progress, hands=hands), shift)
            if cache is not None:
                cache.put(key, k, found)
        draws.append(found if len(first) == len(frames) else select_frames(found, inverse))
    return draws


class ExtractionCache:
    """Landmarks already extracted in this process, by subject (a digest of its distinct pictures and frame rate)
    and shift; the most recent `size` kept; `hits`: subjects taken from it."""

    def __init__(self, size: int = 64) -> None:
        self.size = size
        self._found: dict[tuple, SignClip] = {}
        self.hits = 0

    @staticmethod
    def key(pictures: np.ndarray, fps: float, hands: np.ndarray | None = None) -> bytes:
        import hashlib
        digest = hashlib.blake2b(digest_size=20)
        digest.update(repr((pictures.shape, round(float(fps), 6))).encode())
        digest.update(np.ascontiguousarray(pictures).tobytes())
        digest.update(b"every hand" if hands is None else np.packbits(np.asarray(hands, bool)).tobytes())
        return digest.digest()

    def get(self, key: bytes, shift: int) -> SignClip | None:
        found = self._found.get((key, shift))
        if found is not None:
            self.hits += 1
        return found

    def put(self, key: bytes, shift: int, found: SignClip) -> None:
        self._found[(key, shift)] = found
        while len(self._found) > self.size:
            self._found.pop(next(iter(self._found)))


# ------------------------------------------------------------------------------------------------------------
# a study's independent jobs on both cores

LANDMARK_THREADS_PER_WORKER = 1      # LiteRT threads in each pool worker: the workers share the cores


def default_workers() -> int:
    """Every CPU this process may run on."""
    import os
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


def set_landmark_threads(threads: int) -> None:
    """LiteRT threads of the landmark models loaded from now on in this process (media.landmarks.models.THREADS,
    read when a model is made): a pool worker runs one thread, so that workers x threads = cores."""
    from media.landmarks import models
    models.THREADS = max(1, int(threads))


def _start_worker(initializer, initargs) -> None:
    import signal
    signal.signal(signal.SIGINT, signal.SIG_IGN)       # Ctrl-C is the parent's to handle
    set_landmark_threads(LANDMARK_THREADS_PER_WORKER)
    initializer(*initargs)


class StudyPool:
    """Independent jobs of a study on a process pool of `workers` processes (forkserver: workers start from a process
    that imported `preload` once; each runs initializer(*initargs) once, with LiteRT set to
    LANDMARK_THREADS_PER_WORKER threads), or, with one worker, here in order (initializer run here too, LiteRT threads
    left as they are). `run(function, jobs, done)` returns function(job) of every job, in the jobs' order, calling
    done(index, result) as each finishes; `stream(function, jobs, follow)` also runs the jobs each finished one
    leads to."""

    def __init__(self, workers: int, initializer: Callable, initargs: tuple, preload: tuple[str, ...] = ()):
        self.workers = max(1, int(workers))
        self.pool = None
        if self.workers == 1:
            initializer(*initargs)
            return
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor
        context = multiprocessing.get_context("forkserver")
        context.set_forkserver_preload(list(preload))
        self.pool = ProcessPoolExecutor(max_workers=self.workers, mp_context=context, initializer=_start_worker,
                                        initargs=(initializer, initargs))

    def run(self, function: Callable, jobs: list, done: Callable[[int, object], object] | None = None) -> list:
        results = [None] * len(jobs)
        if self.pool is None:
            for i, job in enumerate(jobs):
                results[i] = function(job)
                if done is not None:
                    done(i, results[i])
            return results
        from concurrent.futures import as_completed
        futures = {self.pool.submit(function, job): i for i, job in enumerate(jobs)}
        try:
            for future in as_completed(futures):
                i = futures[future]
                results[i] = future.result()
                if done is not None:
                    done(i, results[i])
        except BaseException:
            for future in futures:
                future.cancel()
            raise
        return results

    def stream(self, function: Callable, jobs: list, follow: Callable[[object, object], list]) -> None:
        """Run jobs and, as each finishes, the jobs follow(job, function(job)) returns, until none is left: no
        barrier between a job and the ones it leads to, so both cores stay busy while any work is known. follow is
        called here, one finished job at a time, in the order they finish (with one worker: first in, first out)."""
        if self.pool is None:
            queue = deque(jobs)
            while queue:
                job = queue.popleft()
                queue.extend(follow(job, function(job)))
            return
        from concurrent.futures import FIRST_COMPLETED, wait
        running = {self.pool.submit(function, job): job for job in jobs}
        try:
            while running:
                finished, _ = wait(running, return_when=FIRST_COMPLETED)
                for future in finished:
                    job = running.pop(future)
                    for new in follow(job, future.result()):
                        running[self.pool.submit(function, new)] = new
        except BaseException:
            for future in running:
                future.cancel()
            raise

    @property
    def open(self) -> bool:
        """Whether jobs can run: in this process (one worker), or on the pool until it is closed."""
        return self.workers == 1 or self.pool is not None

    def close(self) -> None:
        if self.pool is not None:
            self.pool.shutdown(wait=True, cancel_futures=True)
            self.pool = None

    def __enter__(self) -> "StudyPool":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


# MediaPipe's drawing connections: pose (POSE_CONNECTIONS, without the face) and hand (HAND_CONNECTIONS)
POSE_LINES = ((11, 12), (11, 13), (13, 15), (15, 17), (15, 19), (15, 21), (17, 19), (12, 14), (14, 16), (16, 18),
              (16, 20), (16, 22), (18, 20), (11, 23), (12, 24), (23, 24), (23, 25), (24, 26), (25, 27), (26, 28),
              (27, 29), (28, 30), (29, 31), (30, 32), (27, 31), (28, 32))
HAND_LINES = ((0, 1), (1, 2), (2, 3), (3, 4), (0, 5), (5, 6), (6, 7), (7, 8), (5, 9), (9, 10), (10, 11), (11, 12),
              (9, 13), (13, 14), (14, 15), (15, 16), (13, 17), (0, 17), (17, 18), (18, 19), (19, 20))
COLOURS = {"POSE_LANDMARKS": (255, 255, 255), "LEFT_HAND_LANDMARKS": (255, 128, 0),
           "RIGHT_HAND_LANDMARKS": (0, 200, 255), "FACE_LANDMARKS": (80, 255, 80)}


def draw_landmarks(frames: np.ndarray, clip: SignClip, progress: Callable[[int], object] | None = None) -> np.ndarray:
    """frames (T, H, W, 3) uint8 RGB with the clip's landmarks drawn: skeleton lines for pose and hands, dots for
    the face; only points with confidence > 0. Returns a new (T, H, W, 3) uint8 array."""
    drawn = np.array(frames, copy=True)
    lines = {"POSE_LANDMARKS": POSE_LINES, "LEFT_HAND_LANDMARKS": HAND_LINES, "RIGHT_HAND_LANDMARKS": HAND_LINES}
    for t, picture in enumerate(drawn):
        face = clip.points["FACE_LANDMARKS"][t]
        for x, y in face[clip.confidence["FACE_LANDMARKS"][t] > 0, :2]:
            cv2.circle(picture, (int(round(x)), int(round(y))), 0, COLOURS["FACE_LANDMARKS"], -1)
        for name, connections in lines.items():
            points, seen = clip.points[name][t], clip.confidence[name][t] > 0
            for a, b in connections:
                if seen[a] and seen[b]:
                    cv2.line(picture, tuple(int(round(v)) for v in points[a, :2]),
                             tuple(int(round(v)) for v in points[b, :2]), COLOURS[name], 1, cv2.LINE_AA)
            for x, y in points[seen, :2]:
                cv2.circle(picture, (int(round(x)), int(round(y))), 2, COLOURS[name], -1)
        if progress is not None:
            progress(1)
    return drawn


# ------------------------------------------------------------------------------------------------------------
# .pose files and motion

def read_pose(path: str | Path) -> SignClip:
    """A .pose file's landmarks; SigncastError when it is unreadable or holds fewer than 2 frames."""
    from media.pose_file import read_pose as read
    clip = read(path)
    if clip.n_frames < 2:
        raise SigncastError(f"pose file {path} holds {clip.n_frames} frames: at least 2 are needed")
    return clip


def pose_file_kbps(language: str, unit: str) -> float:
    """Size of the lexicon clip's .pose file over the clip's duration, kbit/s."""
    from media import lexicon
    from media.domain import kbps
    entry = lexicon.lookup(language, unit)
    clip = lexicon.read_clip(entry)
    return kbps(entry.path.stat().st_size * 8, clip.n_frames / clip.fps)


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


def notify_substitutions(language: str, word: str, notify: Callable[[str], object] | None) -> None:
    """One notice per letter of word outside the language's alphabet that is spelled as its base letter."""
    from media import lexicon
    for letter, unit in lexicon.substitutions(language, word) if notify else ():
        notify(f"{letter!r} is not a letter of the {language} alphabet: spelled as {unit!r}")


def source_motion(language: str | None, word: str | None, pose: Path | None, fps: float | None,
                  jitter_filter: str | None, notify: Callable[[str], object] | None = None) -> tuple[Motion, str]:
    """(the avatar's Motion, a few words naming its source): a .pose retargeted (at its own rate unless fps), or
    LANGUAGE WORD fingerspelled (at fps, else LEXICON_FPS)."""
    from media.fingerspelling import fingerspell

    if pose is not None:
        motion, result = pose_motion(pose, fps, jitter_filter, notify)
        return motion, _pose_source(pose, result)
    notify_substitutions(language, word, notify)
    return fingerspell(language, word, fps=fps or LEXICON_FPS), f"{language} {word!r}"


def _pose_source(pose: Path, result) -> str:
    return f"{pose.name} (hands: {', '.join(result.hands) or 'none'})"


def framed_source_motion(language: str | None, word: str | None, pose: Path | None, fps: float | None,
                         jitter_filter: str | None, size: tuple[int, int], framing: str | None,
                         notify: Callable[[str], object] | None = None, *,
                         backend: str = "auto") -> tuple[Motion, str, "Framing | None"]:
    """source_motion's (Motion, source words) and the avatar's framing in a frame of `size` (width, height): like the
    .pose's person where framing is "source" (None: "source" for a .pose), else None (the full figure; always for a
    word)."""
    if pose is None or (framing or "source") != "source":
        return *source_motion(language, word, pose, fps, jitter_filter, notify), None
    motion, result = pose_motion(pose, fps, jitter_filter, notify)
    return motion, _pose_source(pose, result), pose_framing(pose, result.motion, size, notify, backend=backend)


def pose_framing(pose: Path, motion: Motion, size: tuple[int, int], notify: Callable[[str], object] | None = None,
                 *, backend: str = "auto") -> "Framing | None":
    """The framing (source_framing) of the avatar moving as `motion` (the .pose's frames, at its own rate) like the
    person of the .pose in a frame of `size`; None, with a one-line notice, where the file gives no frame size or
    shows no shoulder or face."""
    from media.pose_file import frame_size
    source_size = frame_size(pose)
    if source_size is None:
        if notify:
            notify(f"{pose.name} gives no frame size: the avatar is framed as the full figure")
        return None
    clip = read_pose(pose)
    return source_framing(fit_length(motion, clip.n_frames), clip, source_size, size, pose.name, notify,
                          backend=backend)




# ------------------------------------------------------------------------------------------------------------
# the signing of compare and live

@dataclass(frozen=True)
class ScenarioSettings:
    """The signing of `compare` and `live`. clip: a natural video (file or 'carphone'; None: an avatar scenario);
    pose: a .pose file (with clip: the clip's landmarks, extracted at the clip's size and holding at least its
    frames; alone: the avatar-only scenario's motion); language, word: the fingerspelled word (neither clip nor
    pose); size: (width, height) pixels of the avatar scenarios' render (the video scenario renders at the clip's
    size); max_clip_frames: only the first N frames (None: all); max_clip_size: (width, height) a natural clip is
    scaled down to fit (None keeps it); backend: the kernels' backend; framing: where the avatar stands in the
    video scenario's frame (media.framing.FRAMINGS: "source" like the clip's person, "full-figure" the signing
    space; None: "source" with a clip); the avatar scenarios always render the full figure."""
    language: str = "ase"
    word: str = "HELLO"
    clip: str | None = None
    pose: str | None = None
    size: tuple[int, int] = (352, 288)
    backend: str = "auto"
    max_clip_frames: int | None = None
    max_clip_size: tuple[int, int] | None = DEFAULT_MAX_SIZE
    framing: str | None = None

    @property
    def scenario(self) -> str:
        """"video", "pose" or "word" (see pipeline.studies.compare)."""
        return "video" if self.clip is not None else "pose" if self.pose is not None else "word"


MAX_LANDMARK_STEP = 25       # every 25th frame: one a second at 25 fps


def check_landmark_step(step: int) -> None:
    """Refuse a landmark step (intelligibility measured on every step-th frame) outside 1..MAX_LANDMARK_STEP."""
    if not 1 <= step <= MAX_LANDMARK_STEP:
        raise SigncastError(f"bad landmark step {step}: choose 1 to {MAX_LANDMARK_STEP} (every Nth frame)")


def letter_recogniser(scenario: "Scenario"):
    """The letter recogniser (comparisons.judging.letters.Recogniser.other_signers: templates from the other
    languages' signers only, never a file of the scored language, so never the recording the avatar replays) of a
    fingerspelled scenario's language; None for a scenario without letter spans."""
    if not scenario.spans:
        return None
    from comparisons.judging.letters import Recogniser
    return Recogniser.other_signers(scenario.language)


def check_scenario(settings: ScenarioSettings) -> None:
    """Refuse a bad size or frame count, an unknown language or letter, a missing video (one-line SigncastError)."""
    from media.domain import check_size
    check_size(*settings.size, "the rendered signer")
    if settings.max_clip_frames is not None and settings.max_clip_frames < 2:
        raise SigncastError(f"bad frame count {settings.max_clip_frames}: at least 2")
    if settings.scenario == "word":
        from media import lexicon
        lexicon.split_word(lexicon.check_language(settings.language), settings.word)
    if settings.scenario == "video":
        resolve_video(settings.clip)
    if settings.framing is not None:
        from media.framing import check_framing
        check_framing(settings.framing)
        if settings.framing == "source" and settings.scenario != "video":
            raise SigncastError("framing 'source' frames the avatar like a video's person: give --video "
                                "(the avatar scenarios render the full figure)")


def expected_frames(settings: ScenarioSettings) -> tuple[int, int, int]:
    """(frames, width, height) the scenario will hold, known before reading the video's frames."""
    if settings.scenario == "video":
        info = video_info(resolve_video(settings.clip))
        width, height = settings.max_clip_size or (info.width, info.height)
        count = min(filter(None, (info.announced_frames, settings.max_clip_frames)), default=1)
        return count, min(width, info.width), min(height, info.height)
    if settings.scenario == "pose":
        count = read_pose(settings.pose).n_frames
    else:
        from media.fingerspelling import fingerspell
        count = fingerspell(settings.language, settings.word, fps=DISPLAY_FPS).n_frames
    return min(count, settings.max_clip_frames or count), *settings.size


@dataclass
class Scenario:
    """The signing every solution carries. frames: (T, H, W, 3) uint8 reference frames; labels: (T, H, W) uint8
    part labels of them (for the NSV family); landmarks: the reference's; motion: the avatar's (T frames at fps);
    render, render_labels, render_landmarks: its lossless render (the reference itself in the avatar scenarios);
    spans: (letter, first frame, end frame) of a fingerspelled word, else None; framing: the camera's zoom and shift
    of every render of the avatar (media.framing; None: the full figure)."""
    kind: str
    name: str
    fps: float
    timing: Timing
    frames: np.ndarray
    labels: np.ndarray
    landmarks: SignClip
    motion: Motion
    render: np.ndarray
    render_labels: np.ndarray
    render_landmarks: SignClip
    spans: list | None = None
    language: str | None = None
    framing: Framing | None = None

    @property
    def n_frames(self) -> int:
        return len(self.frames)

    @property
    def size(self) -> tuple[int, int]:
        return self.frames.shape[2], self.frames.shape[1]


def load_scenario(settings: ScenarioSettings, renderer_for: Callable[[int, int], AvatarRenderer], *,
                  progress: bool = True, notify: Callable[[str], object] | None = None) -> Scenario:
    """The reference, its landmarks, the avatar's motion and its lossless render (pipeline.studies.compare's
    module docstring describes the three scenarios). notify: called with each one-line note on a natural clip."""
    if settings.scenario == "video":
        return _video_scenario(settings, renderer_for, progress, notify)
    return _avatar_scenario(settings, renderer_for, progress)


def _video_scenario(settings, renderer_for, progress, notify) -> Scenario:
    from media.avatar import load_avatar
    from media.retarget import retarget
    clip, notes = read_natural_clip(settings.clip, settings.max_clip_frames, settings.max_clip_size,
                                                progress=progress)
    for line in notes:
        if notify:
            notify(line)
    frames = clip.frames
    if settings.pose is not None:
        landmarks = clip_frames(read_pose(settings.pose), len(frames), settings.pose)
        landmarks = SignClip(clip.fps, landmarks.points, landmarks.confidence)
    else:
        landmarks = extract_landmarks(frames, clip.fps, "landmarks: source video", progress)
    if not np.any(landmarks.confidence["POSE_LANDMARKS"] > 0):
        raise SigncastError(f"no person found in {clip.path.name}: no body pose in any of its {len(frames)} frames")
    labels = segment_clip(frames, progress=progress, landmarks=landmarks, fps=clip.fps)
    retargeted = retarget(landmarks, load_avatar().skeleton)
    if not retargeted.hands and notify:
        notify(f"{clip.path.name} shows no hand in enough frames: the avatar's arms rest")
    motion = fit_length(retargeted.motion, len(frames))
    height, width = frames.shape[1:3]
    framing = None
    if (settings.framing or "source") == "source":
        framing = source_framing(motion, landmarks, (width, height), (width, height), clip.path.name, notify,
                                 backend=settings.backend)
    render, render_labels = render_frames(renderer_for(width, height, framing), motion, "render: lossless", progress)
    render_landmarks = extract_landmarks(render, clip.fps, "landmarks: lossless render", progress)
    return Scenario("video", clip.path.stem, clip.fps, Timing.of_clip(clip), frames, labels, landmarks,
                    motion, render, render_labels, render_landmarks, framing=framing)


FRAMING_CHECK_FRAMES = 12     # frames of the framed avatar read back by the landmark extractor to correct the fit


def source_framing(motion: Motion, landmarks: SignClip, source_size: tuple[int, int], size: tuple[int, int],
                   where: str, notify: Callable[[str], object] | None = None, *, backend: str = "auto",
                   read_back: bool = True):
    """The media.framing.Framing that puts the avatar moving as `motion` where the person of `landmarks` stands
    (pose pixels of a source_size (width, height) frame, the same frames as the motion) in a frame of `size`; None,
    with a one-line notice, where the person shows no shoulder or no face point in any frame (the full figure).

    read_back: then render FRAMING_CHECK_FRAMES frames (evenly spread over those where the person shows the anchors)
    framed so, extract their landmarks with the extractor that judges the message, and correct the scale and shift
    by the least-squares fit of those anchors onto the person's: where the landmark model places the avatar's
    shoulders and ears moves with the pose and the picture's size, by 4-8 % of the scale
    (docs/retargeting.md, "Framing the avatar like the person")."""
    from media.avatar import load_avatar
    from media.framing import ANCHOR_POINTS, Framing, fit_framing, fit_similarity, to_frame
    avatar = load_avatar()
    pose = to_frame(landmarks.points["POSE_LANDMARKS"], source_size, size)
    confidence = landmarks.confidence["POSE_LANDMARKS"]
    framing = fit_framing(avatar, motion, pose, confidence, *size)
    if framing is None:
        if notify:
            notify(f"{where}: no shoulders or no face found in any frame: the avatar is framed as the full figure")
        return None
    candidates = np.flatnonzero(np.sum(confidence[:, ANCHOR_POINTS] > 0, axis=1) == len(ANCHOR_POINTS))
    if not read_back or not len(candidates):
        return framing
    from media.render import AvatarRenderer, RenderSettings
    picked = candidates[np.unique(np.linspace(0, len(candidates) - 1, FRAMING_CHECK_FRAMES).round().astype(int))]
    renderer = AvatarRenderer(avatar, RenderSettings(*size, look="shaded", backend=backend, framing=framing))
    shown_motion = Motion(motion.fps, motion.bone_names, motion.rotations[picked], motion.root_translation[picked],
                          None if motion.faps is None else motion.faps[picked])
    frames, _ = render_frames(renderer, shown_motion, "framing: read back", False)
    seen = extract_landmarks(frames, motion.fps, "framing: read back", False)
    shown = seen.confidence["POSE_LANDMARKS"][:, ANCHOR_POINTS] > 0
    if shown.sum() < len(ANCHOR_POINTS):
        return framing
    scale, _, shift = fit_similarity(seen.points["POSE_LANDMARKS"][:, ANCHOR_POINTS, :2][shown],
                                     pose[picked][:, ANCHOR_POINTS][shown], rotate=False)
    shift_pixels = scale * np.multiply(framing.shift, size) + shift
    return Framing(framing.scale * scale, (float(shift_pixels[0]) / size[0], float(shift_pixels[1]) / size[1]),
                   framing.turn)


def _avatar_scenario(settings, renderer_for, progress) -> Scenario:
    spans, language = None, None
    if settings.scenario == "pose":
        from media.avatar import load_avatar
        from media.retarget import retarget
        clip = read_pose(settings.pose)
        motion = retarget(clip, load_avatar().skeleton).motion
        name = Path(settings.pose).stem
    else:
        from media import fingerspelling
        language = settings.language
        motion = fingerspelling.fingerspell(language, settings.word, fps=DISPLAY_FPS)
        spans = fingerspelling.letter_spans(language, settings.word, DISPLAY_FPS)
        name = f"{language}-{settings.word}"
    if settings.max_clip_frames is not None and motion.n_frames > settings.max_clip_frames:
        motion = motion.frames(0, settings.max_clip_frames)
    if spans is not None:
        spans = [(letter, start, end) for letter, start, end in spans if end <= motion.n_frames]
    render, render_labels = render_frames(renderer_for(*settings.size), motion, "render: reference", progress)
    landmarks = extract_landmarks(render, motion.fps, "landmarks: reference", progress)
    labels = segment_clip(render, progress=progress, landmarks=landmarks, fps=motion.fps)
    timing = Timing.regular(motion.n_frames, motion.fps)
    return Scenario(settings.scenario, name, motion.fps, timing, render, labels, landmarks, motion, render,
                    render_labels, landmarks, spans or None, language)


def clip_frames(clip: SignClip, n_frames: int, where: str) -> SignClip:
    """The first n_frames of a clip's landmarks; SigncastError when it holds fewer."""
    if clip.n_frames < n_frames:
        raise SigncastError(f"pose file {where} holds {clip.n_frames} frames, the video {n_frames}: "
                            "give the .pose of the same video (signcast pose, same --max-size)")
    return SignClip(clip.fps, {k: v[:n_frames] for k, v in clip.points.items()},
                    {k: v[:n_frames] for k, v in clip.confidence.items()})


def fit_length(motion: Motion, n_frames: int) -> Motion:
    """The motion cut or held (last pose) to exactly n_frames frames."""
    if motion.n_frames >= n_frames:
        return motion.frames(0, n_frames) if motion.n_frames > n_frames else motion
    pad = n_frames - motion.n_frames
    faps = None if motion.faps is None else np.concatenate([motion.faps, np.repeat(motion.faps[-1:], pad, axis=0)])
    return Motion(motion.fps, motion.bone_names,
                  np.concatenate([motion.rotations, np.repeat(motion.rotations[-1:], pad, axis=0)]),
                  np.concatenate([motion.root_translation, np.repeat(motion.root_translation[-1:], pad, axis=0)]), faps)


def render_frames(renderer: AvatarRenderer, motion: Motion, label: str, progress: bool) -> tuple[np.ndarray, np.ndarray]:
    """frames (T, H, W, 3) uint8 and labels (T, H, W) uint8 of the motion, with a progress bar."""
    s = renderer.settings
    frames = np.empty((motion.n_frames, s.height, s.width, 3), np.uint8)
    labels = np.empty((motion.n_frames, s.height, s.width), np.uint8)
    with tqdm(total=motion.n_frames, desc=label, unit="frame", disable=not progress, leave=False) as bar:
        for t, (rgb, label_frame) in enumerate(renderer.frames(motion)):
            frames[t], labels[t] = rgb, label_frame
            bar.update(1)
    return frames, labels


def renderers(backend: str) -> Callable[..., AvatarRenderer]:
    """renderer_for(width, height, framing=None): the vendored avatar's shaded renderer at that size and framing
    (media.framing.Framing; None: the full figure), made once per size and framing."""
    from media.avatar import load_avatar
    from media.render import AvatarRenderer, RenderSettings
    avatar = load_avatar()
    made: dict[tuple, AvatarRenderer] = {}

    def renderer_for(width: int, height: int, framing: "Framing | None" = None) -> AvatarRenderer:
        if (width, height, framing) not in made:
            made[(width, height, framing)] = AvatarRenderer(avatar, RenderSettings(
                width=width, height=height, look="shaded", backend=backend, framing=framing))
        return made[(width, height, framing)]

    return renderer_for


def backend_name(backend: str) -> str:
    """The backend the kernels run on, in words (auto resolved; the Warp device named)."""
    from kernels.backends import resolve, warp_device
    resolved = resolve(backend)
    return f"warp ({warp_device()})" if resolved == "warp" else resolved



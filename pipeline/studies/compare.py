"""The comparison (seed 000 §4.2.4): one signing through all six solutions, judged by what a viewer can read.

Scenarios (one pipeline):
- "video" (`compare --video FILE [--pose clip.pose]`): the reference is the natural clip (scaled down to fit
  max_clip_size). Its landmarks come from the .pose (which must hold at least the clip's frames, extracted at
  the same size, e.g. by `signcast pose` with the same --max-size) or are extracted here. NSV, NSV2O, NSV3O and
  NSV3O+C code the clip itself (segmented by landmarks). The avatar's motion is those landmarks retargeted
  (media.retarget), at the clip's frame rate, over the same frames; it is rendered losslessly at the clip's
  size (width x height): the "lossless render". Sizes are made equal by rendering at the natural frame's size:
  the renderer frames the signing space for that aspect (hips to above the head, both arms' reach), so the
  avatar fills the frame as the renderer frames it, not as the person filled the camera's frame.
- "word" (`compare LANGUAGE WORD`, the demo): the avatar fingerspells the word at DISPLAY_FPS, rendered
  losslessly at `size`; that render is the reference of every solution: the NSV family codes it as if it were
  a natural video (segmented by landmarks), SSV with the renderer's label buffer; letters are recognised.
- "pose" (`compare --pose clip.pose` without --video): the avatar-only scenario of a .pose: its landmarks
  retargeted, rendered losslessly at `size` and the file's frame rate; that render is the reference (as "word",
  without letters).

SSV codes the lossless render as video objects; FBA and BBA code the motion, and the terminal decodes and
re-renders it at the display size (parameters sent at a reduced frame rate are interpolated back by slerp).
All solutions carry the same frames over the same duration.

Intelligibility (comparisons.judging.intelligibility): landmarks are extracted from what the viewer sees at every point
(the decoded video, or the re-render) and measured against the reference's landmarks ("source video": message
fidelity; for SSV, FBA, BBA this includes the retargeting loss in the video scenario) and, for SSV, FBA and BBA,
against the lossless render's ("lossless render": codec loss). One point record per (point, reference). In the
avatar scenarios the two references are the same landmarks. Image quality: luma PSNR / SSIM against the frames
the solution codes (the reference video for the NSV family, the lossless render for the avatar solutions), the
skin figures over the union of the reference's and the decoded skin masks (the decoded skin objects' shapes for
NSV3O, NSV3O+C and SSV, the re-render's label buffer for FBA and BBA; NSV and NSV2O send no skin shape: the
reference's mask alone).

Landmarks are extracted from every subject (the uncoded reference and each point) `extractions` times, each
under one sub-pixel shift, and every measure is the mean over those draws (comparisons.judging.landmark_draws: one
extraction's PCK moves by 1-1.6 points with the shift).

Matching (comparisons.judging.matching): each solution's (and parameter codec's) operating point is the cheapest rate
whose intelligibility reaches a threshold tied to the uncoded reference: hand PCK@0.2 within PCK_MARGIN points
of the uncoded reference's own, where "own" is the reference's frames resampled by sub-pixel shifts (invisible, but
new pixels) and re-extracted, the landmark extractor's noise floor (against itself the reference scores 100 %,
which no re-rendered or decoded picture can, however close), or, where the reference shows hands in fewer than MIN_HAND_SHARE of its
frames (carphone), face error within FACE_MARGIN interocular distances of the uncoded's; on fingerspelling also
letter top-1 no more than LETTER_MARGIN letters of the word below the uncoded reference's (half a letter: a
letter the ceiling reads may be missed in fewer than half the extractions; none where the ceiling reads no letter of
the word). The NSV family is matched against the source video, the avatar
solutions against the lossless render (in the video scenario the retargeting loss alone keeps them from the
source's threshold; their message fidelity is in the point records). Then up to `refinements` more Q are measured
per series, one at a time (`q_to_refine`; those records say refined): inside the bracket where the match falls
between two swept Q more than one step apart (its geometric middle), at finer Q where even the dearest point misses,
at coarser Q where the cheapest already meets. The rate is interpolated in log-rate between the bracketing Q; the matched record's intelligibility and image-quality fields are interpolated
the same way. At the upper bracket's Q the frame rates are swept and fps_holds is the lowest rate down to
which the threshold holds. Both decisions are taken on each criterion's monotone fit over the swept Q (frame
rates), not on the points one by one (JUDGED_ON): intelligibility does not fall when bits or frames are added, so
where a dearer point reads lower the extractor's noise is pooled (a matched record's criterion fields are the fit's
at the matched rate, the measured values under "measured"). A reached match's rate carries kbps_se, its jackknife
standard error over the extractions (Study.rate_spread). Each matched record also says how clear its verdict is:
verdict_margin_se, the standard errors between the fit at the dearest point and the threshold, taken extraction by
extraction against the ceiling (comparisons.judging.matching.verdict_margin), and verdict_clear, whether that is at least
CLEAR_VERDICT_SE.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import cv2
import numpy as np
from tqdm import tqdm

from comparisons.video import quality as image_quality
from comparisons.judging import matching
from comparisons.judging import metrics
from comparisons.params import codecs as param_codecs
from comparisons.video import objects as video_objects
from comparisons.judging.landmark_draws import MAX_EXTRACTIONS, SHIFTS, draw_values, extract, extract_draws, leave_out, mean_fields
from comparisons.params.study import face_joint_fields
from comparisons.reports.records import INTELLIGIBILITY_FIELDS, make_record, versions, write_records
from comparisons.reports.comparison import build_report, operating_points, verdict_note
from media.avatar import load_avatar
from media.domain import MAX_Q, MIN_Q, SKIN_PARTS, check_q, check_size, solution_of
from media.errors import SigncastError
from media.face_rig import with_face_bones
from media.lexicon import SignClip
from media.motion import Motion, resample
from media.render import AvatarRenderer, RenderSettings
from media.tiling import tile_videos
from media.video_io import frame_indices_at_rate, resolve_video, video_info, write_video
from pipeline.stages import StageClock
from pipeline.studies import video as video_study

DISPLAY_FPS = 25.0           # frame rate of the avatar scenarios ("word"; "pose" keeps the file's own)
SOURCE = "source video"      # reference: the reference video's landmarks (message fidelity)
LOSSLESS = "lossless render"  # reference: the lossless render's landmarks (codec loss of an avatar solution)
# the ceiling of each reference: its own frames, resampled by sub-pixel shifts and re-extracted (Judge.uncoded)
UNCODED_SUBJECTS = {SOURCE: "uncoded reference, resampled", LOSSLESS: "uncoded lossless render, resampled"}
NATURAL_SOLUTIONS = ("NSV", "NSV2O", "NSV3O", "NSV3O+C")
AVATAR_SOLUTIONS = ("SSV", "FBA", "BBA")
PCK_MARGIN = 2.0             # hand PCK@0.2 points below the uncoded reference's (re-extracted after resampling)
# letter top-1 below the uncoded reference's, in letters of the word: with several extractions, a letter the ceiling
# reads may be missed in fewer than half of them (one extraction: no letter may be lost)
LETTER_MARGIN = 0.5
MAX_LANDMARK_STEP = 25       # every 25th frame: one a second at 25 fps
MAX_REFINEMENTS = 5           # halving a Q 1-31 bracket five times leaves adjacent Q
FACE_MARGIN = 0.02           # face error, interocular distances above the uncoded reference's
JUDGED_ON = ("each criterion's monotone fit over the swept Q (and frame rates) of the means over the extractions "
             "(comparisons.judging.matching, monotone=True)")
# a verdict (reached or not) this many standard errors from its threshold is clear; nearer, too close to call for the
# extractions made (comparisons.judging.matching.verdict_margin)
CLEAR_VERDICT_SE = 2.0
MIN_HAND_SHARE = 0.1         # a reference showing a hand in fewer frames is matched on the face
ARM_BONES = ("upperarm01", "upperarm02", "lowerarm01", "lowerarm02", "wrist")   # shoulder to wrist
HAND_BONE_PREFIXES = ("metacarpal", "finger")
QUALITY_FIELDS = ("image_psnr", "ssim", "skin_psnr", "skin_ssim")
SIZE_RULE = ("the avatar is rendered at the natural frame's size; the renderer frames the signing space for "
             "that aspect, so the avatar fills the frame as the renderer frames it")


@dataclass(frozen=True)
class CompareSettings:
    """One scenario and its sweeps. clip: a natural video (file or 'carphone'; None: an avatar scenario); pose: a
    .pose file (with clip: the clip's landmarks; alone: the avatar-only scenario's motion); language, word: the
    fingerspelled word (neither clip nor pose). video: video Q and frame rates (its codecs and solutions are
    set here); param_qs: FBA/BBA quantisers; size: (width, height) of the avatar scenarios' render, pixels (the
    video scenario renders at the clip's size); max_clip_frames: only the first N frames of the clip, .pose or
    word (None: all); max_clip_size: (width, height) a natural clip is scaled down to fit (None keeps it);
    landmark_step: intelligibility is measured on every landmark_step-th frame of what the viewer sees (1: all; the
    reference's landmarks at the same frames; letter spans shrink accordingly); extractions: landmarks are
    extracted this many times from every subject, each under one sub-pixel shift, and the measures averaged
    (comparisons.judging.landmark_draws); refinements: after the Q sweep, up to this many more Q are measured per series,
    each inside its matched bracket, or beyond the swept Q where none or all of them meet the threshold
    (Study.refine, `q_to_refine`), so that the match is interpolated between nearer Q."""
    language: str = "ase"
    word: str = "HELLO"
    clip: str | None = None
    pose: str | None = None
    video: video_study.VideoSweep = video_study.VideoSweep(other_codecs=())
    param_codecs: tuple[str, ...] = ("fba-pred", "fba-dct", "bba-pred", "bba-dct", "bba-key")
    param_qs: tuple[int, ...] = (1, 2, 4, 8, 16, 31)
    size: tuple[int, int] = (352, 288)
    backend: str = "auto"
    max_clip_frames: int | None = None
    max_clip_size: tuple[int, int] | None = video_study.DEFAULT_MAX_SIZE
    landmark_step: int = 1
    extractions: int = 4
    refinements: int = 2

    @property
    def scenario(self) -> str:
        return "video" if self.clip is not None else "pose" if self.pose is not None else "word"

    @classmethod
    def demo(cls) -> "CompareSettings":
        """The word scenario on a sweep small enough for under 5 minutes on two CPU cores: video Q 4, 12, 31 and one
        refinement inside each matched bracket;
        frame rates 25 and 12.5; one FBA and one BBA codec at parameter Q 1, 4, 31; 352x288 render (at 176x144
        the hands are about 15 pixels and the landmarks' own noise exceeds the threshold); intelligibility measured
        on every 3rd frame, four extractions each (landmark extraction, 30-70 ms a frame, is most of the work)."""
        return cls(video=video_study.VideoSweep(qs=(4, 12, 31), frame_rates=(25.0, 12.5), other_codecs=()),
                   param_codecs=("fba-pred", "bba-key"), param_qs=(1, 4, 31), size=(352, 288), landmark_step=3,
                   extractions=4, refinements=1)


@dataclass
class Scenario:
    """The signing every solution carries. frames: (T, H, W, 3) uint8 reference frames; labels: (T, H, W) uint8
    part labels of them (for the NSV family); landmarks: the reference's; motion: the avatar's (T frames at fps);
    render, render_labels, render_landmarks: its lossless render (the reference itself in the avatar scenarios);
    spans: (letter, first frame, end frame) of a fingerspelled word, else None."""
    kind: str
    name: str
    fps: float
    timing: video_study.Timing
    frames: np.ndarray
    labels: np.ndarray
    landmarks: SignClip
    motion: Motion
    render: np.ndarray
    render_labels: np.ndarray
    render_landmarks: SignClip
    spans: list | None = None
    language: str | None = None

    @property
    def n_frames(self) -> int:
        return len(self.frames)

    @property
    def size(self) -> tuple[int, int]:
        return self.frames.shape[2], self.frames.shape[1]


@dataclass
class Received:
    """What a viewer sees for one solution: frames (T, H, W, 3) uint8 and a caption."""
    frames: np.ndarray
    caption: str
    solution: str = ""


@dataclass
class CompareResult:
    records: list[dict]
    report: Path
    side_by_side: Path
    out_dir: Path
    operating: list[dict] = field(default_factory=list)
    matched: list[dict] = field(default_factory=list)


# ------------------------------------------------------------------------------------------------------------
# checks

def check(settings: CompareSettings, command: str = "compare") -> None:
    """Refuse bad settings, a missing video, a corrupt .pose and work beyond the memory limit, before any work
    (one-line SigncastError)."""
    from media.render import check_backend
    from pipeline.checks import check_memory
    check_backend(settings.backend)
    check_settings(settings)
    n_frames, width, height = _expected_frames(settings)
    check_memory(n_frames, width, height, bytes_per_pixel(settings), command,
                 "choose a smaller --size or --max-size, or fewer frames")
    if len(range(0, n_frames, settings.landmark_step)) < 2:
        raise SigncastError(f"--landmark-step {settings.landmark_step} measures fewer than 2 of the {n_frames} frames: "
                            "choose a smaller step")


def _expected_frames(settings: CompareSettings) -> tuple[int, int, int]:
    """(frames, width, height) the scenario will hold, known before reading the video's frames."""
    if settings.scenario == "video":
        info = video_info(resolve_video(settings.clip))
        width, height = settings.max_clip_size or (info.width, info.height)
        count = min(filter(None, (info.announced_frames, settings.max_clip_frames)), default=1)
        return count, min(width, info.width), min(height, info.height)
    if settings.scenario == "pose":
        count = _read_pose(settings.pose).n_frames
    else:
        from media.fingerspelling import fingerspell
        count = fingerspell(settings.language, settings.word, fps=DISPLAY_FPS).n_frames
    return min(count, settings.max_clip_frames or count), *settings.size


def bytes_per_pixel(settings: CompareSettings) -> int:
    """What the comparison holds per pixel and frame: the reference, the lossless render and their labels (8),
    the skin masks (2), a point's coding working copies and received frames (about 12), the side-by-side's tiles
    (3 each, 9 tiles)."""
    return 8 + 2 + 12 + 3 * 9


def check_settings(settings: CompareSettings) -> None:
    sweep = settings.video
    if not sweep.qs:
        raise SigncastError("give at least one video Q")
    for q in (*sweep.qs, *settings.param_qs):
        check_q(q, "Q")
    for fps in sweep.frame_rates:
        if not (np.isfinite(fps) and fps > 0):
            raise SigncastError(f"bad frame rate {fps:g}: choose positive rates")
    for name in settings.param_codecs:
        param_codecs.get_codec(name)
    if sweep.other_codecs:
        raise SigncastError(f"compare codes video with MPEG-4 Part 2 only for now: --video-codecs "
                            f"{','.join(sweep.other_codecs)} is not measured; give --video-codecs none")
    check_size(*settings.size, "the rendered signer")
    if settings.max_clip_frames is not None and settings.max_clip_frames < 2:
        raise SigncastError(f"bad frame count {settings.max_clip_frames}: at least 2")
    if not 1 <= settings.extractions <= MAX_EXTRACTIONS:
        raise SigncastError(f"bad extraction count {settings.extractions}: choose 1 to {MAX_EXTRACTIONS}")
    if not 1 <= settings.landmark_step <= MAX_LANDMARK_STEP:
        raise SigncastError(f"bad landmark step {settings.landmark_step}: choose 1 to {MAX_LANDMARK_STEP} (every Nth frame)")
    if not 0 <= settings.refinements <= MAX_REFINEMENTS:
        raise SigncastError(f"bad refinement count {settings.refinements}: choose 0 to {MAX_REFINEMENTS}")
    if settings.scenario == "word":
        from media import lexicon
        lexicon.split_word(lexicon.check_language(settings.language), settings.word)
    if settings.scenario == "video":
        resolve_video(settings.clip)


def _read_pose(path: str) -> SignClip:
    from media.pose_file import read_pose
    clip = read_pose(path)
    if clip.n_frames < 2:
        raise SigncastError(f"pose file {path} holds {clip.n_frames} frames: at least 2 are needed")
    return clip


# ------------------------------------------------------------------------------------------------------------
# the scenario

def load_scenario(settings: CompareSettings, renderer_for: Callable[[int, int], AvatarRenderer], *,
                  progress: bool = True, notify: Callable[[str], object] | None = None) -> Scenario:
    """The reference, its landmarks, the avatar's motion and its lossless render (see the module's description)."""
    if settings.scenario == "video":
        return _video_scenario(settings, renderer_for, progress, notify)
    return _avatar_scenario(settings, renderer_for, progress)


def _video_scenario(settings, renderer_for, progress, notify) -> Scenario:
    from media.retarget import retarget
    clip, notes = video_study.read_natural_clip(settings.clip, settings.max_clip_frames, settings.max_clip_size,
                                                progress=progress)
    for line in notes:
        if notify:
            notify(line)
    frames = clip.frames
    if settings.pose is not None:
        landmarks = _clip_frames(_read_pose(settings.pose), len(frames), settings.pose)
        landmarks = SignClip(clip.fps, landmarks.points, landmarks.confidence)
    else:
        landmarks = extract(frames, clip.fps, "landmarks: source video", progress)
    if not np.any(landmarks.confidence["POSE_LANDMARKS"] > 0):
        raise SigncastError(f"no person found in {clip.path.name}: no body pose in any of its {len(frames)} frames")
    labels = video_study.segment_clip(frames, progress=progress, landmarks=landmarks, fps=clip.fps)
    retargeted = retarget(landmarks, load_avatar().skeleton)
    if not retargeted.hands and notify:
        notify(f"{clip.path.name} shows no hand in enough frames: the avatar's arms rest")
    motion = _fit_length(retargeted.motion, len(frames))
    height, width = frames.shape[1:3]
    render, render_labels = render_frames(renderer_for(width, height), motion, "render: lossless", progress)
    render_landmarks = extract(render, clip.fps, "landmarks: lossless render", progress)
    return Scenario("video", clip.path.stem, clip.fps, video_study.Timing.of_clip(clip), frames, labels, landmarks,
                    motion, render, render_labels, render_landmarks)


def _avatar_scenario(settings, renderer_for, progress) -> Scenario:
    spans, language = None, None
    if settings.scenario == "pose":
        from media.retarget import retarget
        clip = _read_pose(settings.pose)
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
    landmarks = extract(render, motion.fps, "landmarks: reference", progress)
    labels = video_study.segment_clip(render, progress=progress, landmarks=landmarks, fps=motion.fps)
    timing = video_study.Timing.regular(motion.n_frames, motion.fps)
    return Scenario(settings.scenario, name, motion.fps, timing, render, labels, landmarks, motion, render,
                    render_labels, landmarks, spans or None, language)


def _clip_frames(clip: SignClip, n_frames: int, where: str) -> SignClip:
    """The first n_frames of a clip's landmarks; SigncastError when it holds fewer."""
    if clip.n_frames < n_frames:
        raise SigncastError(f"pose file {where} holds {clip.n_frames} frames, the video {n_frames}: "
                            "give the .pose of the same video (signcast pose, same --max-size)")
    return SignClip(clip.fps, {k: v[:n_frames] for k, v in clip.points.items()},
                    {k: v[:n_frames] for k, v in clip.confidence.items()})


def _fit_length(motion: Motion, n_frames: int) -> Motion:
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


def hold_indices(times_s: np.ndarray, fps: float, n_sent: int) -> np.ndarray:
    """(T,) for each reference frame time (seconds), the index of the sent frame on screen then: frames sent at
    the ticks 0, 1/fps, ... are held until the next tick."""
    ticks = np.floor(np.asarray(times_s, np.float64) * fps + 1e-6).astype(int)
    return np.clip(ticks, 0, n_sent - 1)


def select_frames(clip: SignClip, indices: np.ndarray, fps: float | None = None) -> SignClip:
    """The landmarks of the frames at indices (M,), in that order (repeats allowed), at fps (None: the clip's)."""
    return SignClip(clip.fps if fps is None else fps, {k: v[indices] for k, v in clip.points.items()},
                    {k: v[indices] for k, v in clip.confidence.items()})


def _measured_spans(spans: list | None, step: int, n_measured: int) -> list | None:
    """Letter spans (letter, first, end exclusive) in the measured frames' indices (every step-th frame); a span
    keeps at least one measured frame."""
    if not spans:
        return None
    out = []
    for letter, start, end in spans:
        first = min(-(-start // step), n_measured - 1)
        out.append((letter, first, min(max(-(-end // step), first + 1), n_measured)))
    return out


# ------------------------------------------------------------------------------------------------------------
# measuring what the viewer sees

@dataclass
class Viewed:
    """What the viewer sees at one point: frames (T, H, W, 3) uint8 at the reference's times, the decoded skin
    mask (T, H, W) bool or None where the solution sends no skin shape, and the point's record fields."""
    frames: np.ndarray
    skin: np.ndarray | None
    fields: dict


class Judge:
    """Measures what the viewer sees against a scenario's references (intelligibility, letters, image quality)."""

    def __init__(self, scenario: Scenario, progress: bool, step: int = 1, extractions: int = 1):
        self.scenario, self.progress, self.extractions = scenario, progress, extractions
        self.measured = np.arange(0, scenario.n_frames, max(1, step))     # (M,) frames measured
        self.reference = select_frames(scenario.landmarks, self.measured)
        self.render_reference = select_frames(scenario.render_landmarks, self.measured)
        self.spans = _measured_spans(scenario.spans, max(1, step), len(self.measured))
        self.recogniser = None
        if scenario.spans:
            from comparisons.judging.letters import Recogniser
            self.recogniser = Recogniser.from_lexicon([scenario.language])
        self.reference_skin = np.isin(scenario.labels, SKIN_PARTS)
        self.render_skin = np.isin(scenario.render_labels, SKIN_PARTS)

    def letters(self, observed: SignClip) -> dict:
        """letter_top1 / letter_top3 (percent) of a fingerspelled word's letters; {} without a word."""
        if self.recogniser is None:
            return {}
        from comparisons.judging.letters import recognise_spans, top_k
        spans = self.spans
        rankings = recognise_spans(self.recogniser, observed, self.scenario.language, spans)
        truths = [letter for letter, _, _ in spans]
        return {"letter_top1": top_k(rankings, truths, 1), "letter_top3": top_k(rankings, truths, 3)}

    def references(self, solution: str) -> list[tuple[str, SignClip]]:
        """The references a solution's points are measured against, at the measured frames."""
        refs = [(SOURCE, self.reference)]
        if solution in AVATAR_SOLUTIONS:
            refs.append((LOSSLESS, self.render_reference))
        return refs

    def draws(self, frames: np.ndarray, fps: float, label: str) -> list[SignClip]:
        """The landmarks of frames (M, H, W, 3) uint8 (the measured frames of what the viewer sees, shown at fps),
        extracted `extractions` times, each under its sub-pixel shift (comparisons.judging.landmark_draws)."""
        return extract_draws(frames, fps, self.extractions, label, self.progress)

    def intelligibility(self, solution: str, draws: list[SignClip]) -> list[tuple[str, dict]]:
        """(reference name, intelligibility and letter fields, each the mean over the draws, with their spread) for
        each reference of the solution; draws: the landmarks of the measured frames, one SignClip per extraction."""
        from comparisons.judging.intelligibility import measure
        letters = [self.letters(observed) for observed in draws]
        return [(name, mean_fields([{**measure(reference, observed).fields(), **letter}
                                    for observed, letter in zip(draws, letters)]))
                for name, reference in self.references(solution)]

    def records(self, solution: str, viewed: Viewed, draws: list[SignClip]) -> list[dict]:
        """One record per reference of the solution, each with the point's fields, image quality and
        intelligibility (draws: the landmarks of what the viewer sees, one SignClip per extraction)."""
        s = self.scenario
        avatar = solution in AVATAR_SOLUTIONS
        reference_frames = s.render if avatar else s.frames
        reference_skin = self.render_skin if avatar else self.reference_skin
        skin = reference_skin if viewed.skin is None else reference_skin | viewed.skin
        quality = image_quality.quality_fields(reference_frames, viewed.frames, skin)
        return [dict(viewed.fields, **quality, reference=name, **fields)
                for name, fields in self.intelligibility(solution, draws)]

    def uncoded(self) -> list[dict]:
        """The ceilings: each reference's measured frames re-extracted under the same sub-pixel shifts as every
        point (invisible, but new pixels: the landmark extractor's own noise floor), against the reference's
        landmarks, the mean over the draws; and (video scenario) the lossless render's landmarks against the
        source video's (the retargeting loss alone)."""
        s = self.scenario
        source, render = self.reference, self.render_reference
        resampled_source = self.draws(s.frames[self.measured], s.fps, "re-extract the reference")
        resampled_render = (resampled_source if s.render is s.frames
                            else self.draws(s.render[self.measured], s.fps, "re-extract the lossless render"))
        subjects = [(UNCODED_SUBJECTS[SOURCE], SOURCE, source, resampled_source),
                    (UNCODED_SUBJECTS[LOSSLESS], LOSSLESS, render, resampled_render)]
        if s.kind == "video":
            subjects.append(("uncoded lossless render", SOURCE, source, [render]))
        from comparisons.judging.intelligibility import measure
        return [{"kind": "uncoded", "subject": subject, "clip": s.name, "reference": name, "fps": s.fps,
                 **mean_fields([{**measure(reference, observed).fields(), **self.letters(observed)}
                                for observed in draws])}
                for subject, name, reference, draws in subjects]


# ------------------------------------------------------------------------------------------------------------
# coding

class VideoPoints:
    """NSV, NSV2O, NSV3O, NSV3O+C (coding the reference frames) and SSV (coding the lossless render)."""

    def __init__(self, scenario: Scenario):
        self.scenario = scenario
        self.shapes = video_objects.ShapeCache()

    def source(self, solution: str) -> tuple[np.ndarray, np.ndarray, str]:
        s = self.scenario
        return (s.render, s.render_labels, "render") if solution == "SSV" else (s.frames, s.labels, "reference")

    def code(self, solution: str, q: int, fps: float) -> tuple[Viewed, np.ndarray, np.ndarray]:
        """(what the viewer sees, the sent frames (K, H, W, 3), hold (T,) indices of the sent frame on screen)."""
        s = self.scenario
        frames, labels, key = self.source(solution)
        full = fps >= s.fps * (1 - 1e-3)
        kept = np.arange(s.n_frames) if full else frame_indices_at_rate(s.timing.times_s, s.timing.duration_s, fps)
        rate = s.fps if full else fps
        coded = video_objects.code_solution(solution, frames[kept], labels[kept], rate, "mpeg4", q, self.shapes,
                                            f"{key}@{rate:g}")
        hold = np.arange(s.n_frames) if full else hold_indices(s.timing.times_s, fps, len(kept))
        skin_objects = [o.decoded_masks for o in coded.objects if o.name in ("head", "left_hand", "right_hand")]
        skin = np.logical_or.reduce(skin_objects)[hold] if skin_objects else None
        height, width = frames.shape[1:3]
        fields = make_record(solution, s.name, "mpeg4", q, rate, width, height, coded.bits, s.timing.duration_s,
                             sweep="q" if full else "fps", full_resolution=True, frames=len(kept),
                             texture_bits=coded.bits - coded.shape_bits, shape_bits=coded.shape_bits,
                             objects=[{"name": o.name, "q": o.q, "texture_bytes": o.texture_bytes,
                                       "shape_bytes": o.shape_bytes, "area_percent": o.area_percent}
                                      for o in coded.objects])
        return Viewed(coded.picture[hold], skin, fields), coded.picture, hold


class ParamPoints:
    """FBA and BBA: the motion coded, decoded and re-rendered by the terminal at the display size."""

    def __init__(self, scenario: Scenario, renderer: AvatarRenderer):
        self.scenario, self.renderer = scenario, renderer
        skeleton = renderer.avatar.skeleton
        self.skeleton = skeleton
        self.arm_joints = [i for i, n in enumerate(skeleton.names) if n.split(".")[0] in ARM_BONES]
        self.hand_joints = [i for i, n in enumerate(skeleton.names) if n.startswith(HAND_BONE_PREFIXES)]

    def decoded(self, codec_name: str, q: int, fps: float) -> tuple[Motion, int, int]:
        """(the motion the terminal shows at the scenario's rate and length, bits sent, frames sent)."""
        s = self.scenario
        codec = param_codecs.get_codec(codec_name)
        full = fps >= s.fps * (1 - 1e-3)
        sent = s.motion if full else resample(s.motion, fps)
        data = codec.encode(sent, q)
        decoded = codec.decode(data)
        shown = decoded if full else resample(Motion(fps, decoded.bone_names, decoded.rotations,
                                                     decoded.root_translation, decoded.faps), s.fps)
        shown = Motion(s.fps, shown.bone_names, shown.rotations, shown.root_translation, shown.faps)
        return _fit_length(shown, s.n_frames), 8 * len(data), sent.n_frames

    def code(self, codec_name: str, q: int, fps: float, progress: bool = False) -> tuple[Viewed, np.ndarray]:
        """(what the viewer sees, the re-rendered frames (T, H, W, 3))."""
        s = self.scenario
        shown, bits, n_sent = self.decoded(codec_name, q, fps)
        frames, labels = render_frames(self.renderer, shown, f"terminal {codec_name} Q{q}", progress)
        # the face as the terminal plays it: FAPs (FBA) through the face rig, face bones (BBA) as sent
        avatar = self.renderer.avatar
        played, played_shown = with_face_bones(s.motion, avatar), with_face_bones(shown, avatar)
        joint_mm = metrics.joint_position_error_mm(self.skeleton, played, played_shown)
        full = fps >= s.fps * (1 - 1e-3)
        width, height = s.size
        fields = make_record(solution_of(codec_name), s.name, codec_name, q, s.fps if full else fps, width, height,
                             bits, s.timing.duration_s, sweep="q" if full else "fps", full_resolution=True,
                             frames=n_sent, joint_error_mm_mean=float(joint_mm.mean()),
                             joint_error_mm_max=float(joint_mm.max()),
                             hand_joint_error_mm=float(joint_mm[:, self.hand_joints].mean()),
                             arm_joint_error_mm=float(joint_mm[:, self.arm_joints].mean()),
                             **face_joint_fields(s.motion, played, played_shown, avatar))
        return Viewed(frames, np.isin(labels, SKIN_PARTS), fields), frames


# ------------------------------------------------------------------------------------------------------------
# the run

@dataclass(frozen=True)
class Series:
    """One solution with one codec, swept over Q."""
    solution: str
    codec: str

    @property
    def avatar(self) -> bool:
        return self.solution in AVATAR_SOLUTIONS

    @property
    def reference(self) -> str:
        """The reference the series is matched against (see the module's description)."""
        return LOSSLESS if self.avatar else SOURCE

    def points(self, records: list[dict], sweep: str = "q") -> list[dict]:
        return [r for r in records if r.get("kind") == "point" and r["solution"] == self.solution
                and r["codec"] == self.codec and r.get("sweep") == sweep and r.get("reference") == self.reference]


class Study:
    """One run: points measured and appended to records.jsonl as they are measured, observed landmarks kept."""

    def __init__(self, settings: CompareSettings, scenario: Scenario, renderer: AvatarRenderer,
                 records_path: Path, progress: bool):
        self.settings, self.scenario, self.progress = settings, scenario, progress
        self.judge = Judge(scenario, progress, settings.landmark_step, settings.extractions)
        self.video = VideoPoints(scenario)
        self.params = ParamPoints(scenario, renderer)
        self.records_path = records_path
        self.records: list[dict] = []
        self.observed: dict[tuple, SignClip] = {}

    def series(self) -> list[Series]:
        return ([Series(s, "mpeg4") for s in (*NATURAL_SOLUTIONS, "SSV")]
                + [Series(solution_of(c), c) for c in self.settings.param_codecs])

    def lower_rates(self) -> list[float]:
        return sorted({f for f in self.settings.video.frame_rates if f < self.scenario.fps * (1 - 1e-3)}, reverse=True)

    def measure(self, series: Series, q: int, fps: float, bar, **extra) -> list[dict]:
        """Code one point, extract the landmarks of what the viewer sees, measure it; its records (with the extra
        fields)."""
        s = self.scenario
        label = f"landmarks: {series.codec if series.solution in ('FBA', 'BBA') else series.solution} Q{q} {fps:g} fps"
        measured = self.judge.measured
        if series.solution in ("FBA", "BBA"):
            viewed, _ = self.params.code(series.codec, q, fps)
            draws = self.judge.draws(viewed.frames[measured], s.fps, label)
        else:
            viewed, sent, hold = self.video.code(series.solution, q, fps)
            # the distinct sent frames on screen at the measured frames, extracted once each
            distinct, on_screen = np.unique(hold[measured], return_inverse=True)
            draws = [select_frames(observed, on_screen, s.fps)
                     for observed in self.judge.draws(sent[distinct], min(fps, s.fps), label)]
        records = [dict(record, **extra) for record in self.judge.records(series.solution, viewed, draws)]
        self.observed[(series.solution, series.codec, q, records[0]["fps"])] = draws[0]
        self.add(records)
        bar.update(1)
        return records

    def add(self, records: list[dict]) -> None:
        write_records(self.records_path, records, append=True)
        self.records += records

    def sweep_q(self) -> None:
        qs = {False: self.settings.video.qs, True: self.settings.param_qs}
        jobs = [(series, q) for series in self.series() for q in qs[series.solution in ("FBA", "BBA")]]
        with tqdm(total=len(jobs), desc="points (Q sweep)", unit="point", disable=not self.progress) as bar:
            for series, q in jobs:
                self.measure(series, q, self.scenario.fps, bar)

    def match(self) -> list[dict]:
        """The matched record of every series (after refining its Q bracket), with its frame-rate sweep at the upper
        bracket's Q."""
        matched = []
        rates = self.lower_rates()
        with tqdm(total=len(self.series()) * len(rates), desc="points (refined Q, frame rates)", unit="point",
                  disable=not self.progress) as bar:
            for series in self.series():
                criteria = self.criteria(series.reference)
                found = self.refine(series, criteria, bar)
                _mark_operating(series.points(self.records), found.kbps, criteria)
                q = found.upper["q"]
                for fps in rates:
                    self.measure(series, q, fps, bar)
                at_q = [r for r in series.points(self.records, "fps") if r["q"] == q] + [found.upper]
                matched.append(self.matched_record(series, found, criteria,
                                                   matching.lowest_fps_holding(at_q, criteria, monotone=True)))
        self.add(matched)
        return matched

    def refine(self, series: Series, criteria: list[matching.Criterion], bar) -> matching.Match:
        """The series' match, after measuring up to `refinements` more Q at the scenario's rate, each where the match
        found so far asks (`q_to_refine`: inside its bracket, or beyond the swept Q); those records carry
        refined=True."""
        found = matching.cheapest_rate(series.points(self.records), criteria, monotone=True)
        for _ in range(self.settings.refinements):
            q = q_to_refine(found, {r["q"] for r in series.points(self.records)})
            if q is None:
                break
            bar.total += 1
            self.measure(series, q, self.scenario.fps, bar, refined=True)
            found = matching.cheapest_rate(series.points(self.records), criteria, monotone=True)
        return found

    def matched_record(self, series: Series, found: matching.Match, criteria, fps_holds) -> dict:
        """The series at its matched rate: the criteria's fields are their monotone fits there (what the match was
        judged on; the measured values, interpolated, under "measured"), every other field interpolated in log-rate
        between the bracketing points (the point's own without a lower bracket)."""
        lower = found.lower
        qs = [found.upper["q"]] + ([lower["q"]] if lower is not None else [])
        fields_at = "interpolated in log-rate between the bracketing points" if lower is not None else "the point's own"
        fields = matching.fields_at(found, (*INTELLIGIBILITY_FIELDS, *QUALITY_FIELDS, "joint_error_mm_mean"))
        measured = {name: fields.get(name) for name in found.fitted}
        margin = self.verdict_margin(series, criteria)
        return {"kind": "matched", "solution": series.solution, "codec": series.codec, "clip": self.scenario.name,
                "reference": series.reference, "kbps": found.kbps, "kbps_se": self.rate_spread(series, found),
                "q_low": min(qs), "q_high": max(qs),
                "bracket_kbps": [lower["kbps"] if lower is not None else found.upper["kbps"], found.upper["kbps"]],
                "q_shown": found.upper["q"], "threshold": matching.threshold_text(criteria),
                "reached": found.reached, "verdict_margin_se": margin if margin is not None and np.isfinite(margin) else None,
                "verdict_clear": None if margin is None else bool(abs(margin) >= CLEAR_VERDICT_SE),
                "fps_holds": fps_holds, "fields_at": fields_at, "judged_on": JUDGED_ON,
                **fields, **found.fitted, "measured": measured}

    def verdict_margin(self, series: Series, criteria: list[matching.Criterion]) -> float | None:
        """The series' verdict margin in standard errors (comparisons.judging.matching.verdict_margin), each point against
        the threshold draw by draw: the ceiling's extractions moved by the threshold's offset from their mean."""
        ceiling = self.ceiling(series.reference)
        threshold_draws = {c.field: _shifted_draws(draw_values(ceiling, c.field),
                                                   c.threshold - (ceiling.get(c.field) or 0.0)) for c in criteria}
        return matching.verdict_margin(series.points(self.records), criteria, draw_values, threshold_draws)

    def rate_spread(self, series: Series, found: matching.Match) -> float | None:
        """The jackknife standard error (kbps) of a reached match's rate over the landmark extractions: replicate k
        leaves extraction k out of every point of the series and of the ceiling (landmark_draws.leave_out: the same
        draw everywhere, as the draws are paired) and matches again; SE = sqrt((K - 1) / K * sum (rate_k - mean)^2).
        None for a match not reached (its rate is the best point's, not a crossing) or with one extraction."""
        count = self.settings.extractions
        if count < 2 or not found.reached:
            return None
        ceiling, points = self.ceiling(series.reference), series.points(self.records)
        rates = np.array([matching.cheapest_rate([leave_out(point, k) for point in points],
                                                 self.criteria(series.reference, leave_out(ceiling, k)),
                                                 monotone=True).kbps for k in range(count)])
        return float(np.sqrt((count - 1) / count * np.sum((rates - rates.mean()) ** 2)))

    def ceiling(self, reference: str) -> dict:
        return next(r for r in self.records if r.get("kind") == "uncoded" and r["reference"] == reference
                    and r["subject"] == UNCODED_SUBJECTS[reference])

    def criteria(self, reference: str, ceiling: dict | None = None) -> list[matching.Criterion]:
        """The threshold tied to the uncoded reference (see the module's description); ceiling: the reference's
        ceiling record (None: the measured one; `rate_spread` passes its jackknife replicates)."""
        ceiling = self.ceiling(reference) if ceiling is None else ceiling
        landmarks = self.scenario.landmarks if reference == SOURCE else self.scenario.render_landmarks
        return criteria_for(ceiling, _hand_share(landmarks), len(self.judge.spans or ()))


def criteria_for(ceiling: dict, hand_share: float, n_letters: int) -> list[matching.Criterion]:
    """The threshold tied to a ceiling record (the uncoded reference re-extracted): hand PCK@0.2 within PCK_MARGIN
    points of it where the reference shows a hand in at least MIN_HAND_SHARE of its frames (hand_share, 0-1), else
    face error within FACE_MARGIN; and letter top-1 within LETTER_MARGIN letters of a word of n_letters, where the
    ceiling reads any letter (a ceiling that reads none leaves letters nothing to hold)."""
    if hand_share >= MIN_HAND_SHARE and ceiling.get("hand_pck_20") is not None:
        found = [matching.Criterion("hand_pck_20", ceiling["hand_pck_20"] - PCK_MARGIN, label="hand PCK@0.2 %")]
    else:
        found = [matching.Criterion("face_error", (ceiling.get("face_error") or 0.0) + FACE_MARGIN,
                                    higher_is_better=False, label="face error (interocular)")]
    if ceiling.get("letter_top1"):
        margin = 100.0 * LETTER_MARGIN / max(n_letters, 1)
        found.append(matching.Criterion("letter_top1", ceiling["letter_top1"] - margin, label="letter top-1 %"))
    return found


def _shifted_draws(values: list[float | None] | None, offset: float) -> list[float | None] | None:
    """A ceiling's values in each extraction moved by its threshold's offset from its mean: the threshold draw by
    draw."""
    return None if values is None else [None if v is None else v + offset for v in values]


def q_to_refine(found: matching.Match, measured: set[int]) -> int | None:
    """The Q to measure next for a match, one step of its refinement; None when there is none to measure:
    - reached between two swept Q: the rounded geometric middle of the two, moved off them (None where the two are
      adjacent);
    - not reached (even the dearest point misses): the geometric middle of MIN_Q and the finest swept Q, moved off
      it (None where that is MIN_Q): the match is looked for beyond the sweep, at finer Q;
    - reached at the cheapest swept point (no lower bracket): the geometric middle of its Q and MAX_Q, moved off it
      (None where that is MAX_Q), for a bracket below it.
    None also where that Q is measured already. measured: the series' swept Q."""
    if not found.reached:
        finest = min(measured)
        q = _geometric_middle(MIN_Q, finest, MIN_Q, finest - 1) if finest > MIN_Q else None
    elif found.lower is None:
        coarsest = int(found.upper["q"])
        q = _geometric_middle(coarsest, MAX_Q, coarsest + 1, MAX_Q) if coarsest < MAX_Q else None
    else:
        low, high = sorted((int(found.lower["q"]), int(found.upper["q"])))
        q = _geometric_middle(low, high, low + 1, high - 1) if high - low >= 2 else None
    return None if q in measured else q


def _geometric_middle(low: int, high: int, least: int, most: int) -> int:
    """round(sqrt(low * high)), held within least..most."""
    return min(max(round((low * high) ** 0.5), least), most)


def _hand_share(clip: SignClip) -> float:
    """Share of frames showing either hand (all 21 points)."""
    from media.lexicon import HAND_COMPONENTS
    shown = np.zeros(clip.n_frames, bool)
    for component in HAND_COMPONENTS.values():
        shown |= np.all(clip.confidence[component] > 0, axis=1)
    return float(shown.mean()) if clip.n_frames else 0.0


def _mark_operating(points: list[dict], kbps: float, criteria) -> None:
    """operating_point on the swept point nearest the matched rate (log-rate), with the rule."""
    nearest = min(points, key=lambda r: abs(np.log(max(r["kbps"], 1e-9)) - np.log(max(kbps, 1e-9))))
    nearest["operating_point"] = True
    nearest["operating_rule"] = f"nearest the matched rate: {matching.threshold_text(criteria)}"


def renderers(backend: str) -> Callable[[int, int], AvatarRenderer]:
    """renderer_for(width, height): the vendored avatar's shaded renderer at that size, made once per size."""
    avatar = load_avatar()
    made: dict[tuple[int, int], AvatarRenderer] = {}

    def renderer_for(width: int, height: int) -> AvatarRenderer:
        if (width, height) not in made:
            made[(width, height)] = AvatarRenderer(avatar, RenderSettings(width=width, height=height, look="shaded",
                                                                          backend=backend))
        return made[(width, height)]

    return renderer_for


def run(settings: CompareSettings, out_dir: str | Path, *, progress: bool = True,
        notify: Callable[[str], object] | None = None) -> CompareResult:
    """Run the whole comparison; write records.jsonl, report.html, side_by_side.mp4 and summary.csv to out_dir.

    records.jsonl grows as points are measured (an interrupted run keeps them) and is rewritten, complete, at
    the end. notify: called with each one-line note on a natural clip (frames read, downscaling, warnings)."""
    check_settings(settings)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    records_path = write_records(out_dir / "records.jsonl", [])
    clock = StageClock()
    renderer_for = renderers(settings.backend)
    with clock.stage("scenario: reference, landmarks, retargeting, lossless render"):
        scenario = load_scenario(settings, renderer_for, progress=progress, notify=notify)
    study = Study(settings, scenario, renderer_for(*scenario.size), records_path, progress)
    with clock.stage("uncoded references"):
        study.add(study.judge.uncoded())
    with clock.stage("Q sweep: code, view, extract landmarks, measure"):
        study.sweep_q()
    with clock.stage("matching and frame-rate sweep"):
        matched = study.match()
    side_by_side = out_dir / "side_by_side.mp4"
    with clock.stage("side-by-side video"):
        poster = _write_side_by_side(_tiles(study, matched), side_by_side, scenario.fps)
    run_record = {"kind": "run", "backend": _backend_name(settings.backend), "versions": versions(),
                  "scenario": scenario.kind, "clip": scenario.name, "clip_fps": scenario.fps,
                  "clip_duration_s": scenario.timing.duration_s, "clip_frames": scenario.n_frames,
                  "clip_size": list(scenario.size), "display_fps": scenario.fps, "signer_size": list(scenario.size),
                  "size_rule": SIZE_RULE if scenario.kind == "video" else "the reference is the avatar's render",
                  "pck_margin": PCK_MARGIN, "face_margin": FACE_MARGIN, "letter_margin": LETTER_MARGIN,
                  "min_hand_share": MIN_HAND_SHARE,
                  "refinements": settings.refinements,
                  "extractions": settings.extractions, "extraction_shifts": [list(shift) for shift in
                                                                             SHIFTS[:settings.extractions]],
                  "matched_against": {"NSV family": SOURCE, "SSV, FBA, BBA": LOSSLESS}}
    all_records = [run_record] + study.records + clock.records()
    write_records(out_dir / "records.jsonl", all_records)
    (out_dir / "side_by_side_poster.png").write_bytes(poster)
    report = build_report(all_records, out_dir / "report.html", poster_png=poster)
    write_summary_csv(all_records, out_dir / "summary.csv")
    return CompareResult(all_records, report, side_by_side, out_dir, operating_points(all_records), matched)


# ------------------------------------------------------------------------------------------------------------
# the side by side

def _tiles(study: Study, matched: list[dict]) -> list[Received]:
    """The reference (and the lossless render) and each solution at its matched point's upper bracket Q (for FBA and
    BBA the cheapest codec), each with the landmarks extracted from it drawn on it."""
    from pipeline.studies.pose import draw_landmarks
    s = study.scenario
    tiles = [Received(draw_landmarks(s.frames, s.landmarks), f"reference: {s.name} (uncoded)")]
    # each frame shows the landmarks of the last measured frame (every landmark_step-th)
    last_measured = np.maximum(np.searchsorted(study.judge.measured, np.arange(s.n_frames), side="right") - 1, 0)
    if s.kind == "video":
        tiles.append(Received(draw_landmarks(s.render, s.render_landmarks), "avatar: lossless render"))
    for solution in (*NATURAL_SOLUTIONS, *AVATAR_SOLUTIONS):
        candidates = [m for m in matched if m["solution"] == solution]
        if not candidates:
            continue
        best = min(candidates, key=lambda m: (not m["reached"], m["kbps"]))
        q = best["q_shown"]
        if solution in ("FBA", "BBA"):
            _, frames = study.params.code(best["codec"], q, s.fps)
        else:
            viewed, _, _ = study.video.code(solution, q, s.fps)
            frames = viewed.frames
        observed = select_frames(study.observed[(solution, best["codec"], q, s.fps)], last_measured)
        codec = f" {best['codec']}" if solution in ("FBA", "BBA") else ""
        tiles.append(Received(draw_landmarks(frames, observed),
                              f"{solution}{codec} Q{q}, matched {best['kbps']:.1f} kbps"
                              f"{'' if best['reached'] else ' (not reached)'}", solution))
    return tiles


def _write_side_by_side(received: list[Received], path: Path, fps: float) -> bytes:
    """Tile the received videos, encode with H.264 at fps, return a PNG poster frame."""
    tiled = tile_videos([(r.frames, r.caption) for r in received], tile_size=(352, 288), columns=4)
    write_video(path, tiled, fps, codec="libx264", options={"crf": 18, "preset": "veryfast"})
    ok, png = cv2.imencode(".png", cv2.cvtColor(tiled[len(tiled) // 2], cv2.COLOR_RGB2BGR))
    if not ok:
        raise SigncastError("could not encode the poster frame")
    return png.tobytes()


def _backend_name(backend: str) -> str:
    from kernels.backends import resolve, warp_device
    resolved = resolve(backend)
    return f"warp ({warp_device()})" if resolved == "warp" else resolved


# ------------------------------------------------------------------------------------------------------------
# summaries

def summary_rows(records: list[dict]) -> list[dict]:
    """One row per matched series."""
    return [{"solution": r["solution"], "codec": r["codec"], "reference": r["reference"], "kbps": r["kbps"],
             "kbps_se": r.get("kbps_se"),
             "q_low": r["q_low"], "q_high": r["q_high"], "reached": r["reached"],
             "verdict_margin_se": r.get("verdict_margin_se"), "verdict_clear": r.get("verdict_clear"),
             "fps_holds": r.get("fps_holds"),
             "hand_pck_20": r.get("hand_pck_20"), "face_error": r.get("face_error"),
             "letter_top1": r.get("letter_top1"), "skin_psnr": r.get("skin_psnr"), "threshold": r["threshold"]}
            for r in records if r.get("kind") == "matched"]


def write_summary_csv(records: list[dict], path: Path) -> Path:
    import csv
    rows = summary_rows(records)
    with path.open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]) if rows else ["solution"])
        writer.writeheader()
        writer.writerows(rows)
    return path


def _verdict(row: dict) -> str:
    """"reached" or "not reached", with how clear the call is (comparisons.reports.comparison.verdict_note)."""
    note = verdict_note(row)
    return ("reached" if row["reached"] else "not reached") + (f" ({note})" if note else "")


def format_summary(records: list[dict]) -> str:
    """The terminal's summary table: each solution at its matched rate."""
    def fmt(value, spec):
        """value in spec (">W.Pf"), or a dash right-aligned in the same width."""
        ok = isinstance(value, (int, float)) and np.isfinite(value)
        return format(value, spec) if ok else "–".rjust(int(spec[1:].split(".")[0]))
    rows = summary_rows(records)
    thresholds = dict.fromkeys((row["reference"], row["threshold"]) for row in rows)
    lines = [f"matched against the {reference} on: {threshold}" for reference, threshold in thresholds]
    lines += [] if rows else ["no matched point"]
    lines.append(f"{'solution':9} {'codec':9} {'reference':16} {'kbps':>8} {'± SE':>6} {'Q':>6} {'PCK@.2':>7} "
                 f"{'face':>6} {'top-1':>6} {'skin dB':>7} {'holds to':>9}  verdict")
    for row in rows:
        q = f"{row['q_low']}-{row['q_high']}" if row["q_low"] != row["q_high"] else str(row["q_low"])
        holds = f"{row['fps_holds']:g} fps" if row["fps_holds"] is not None else "–"
        kbps = f"{row['kbps']:.1f}{'' if row['reached'] else '*'}"
        lines.append(f"{row['solution']:9} {row['codec']:9} {row['reference']:16} {kbps:>8} "
                     f"{fmt(row['kbps_se'], '>6.1f')} {q:>6} {fmt(row['hand_pck_20'], '>7.1f')} "
                     f"{fmt(row['face_error'], '>6.3f')} {fmt(row['letter_top1'], '>6.0f')} "
                     f"{fmt(row['skin_psnr'], '>7.2f')} {holds:>9}  {_verdict(row)}")
    if any(not row["reached"] for row in rows):
        lines.append("* threshold not reached: the best swept point's rate")
    if any(row["kbps_se"] is not None for row in rows):
        lines.append("± SE: the rate's jackknife standard error over the landmark extractions (each left out in turn)")
    if any(row["verdict_clear"] is False for row in rows):
        lines.append(f"too close to call: the fit at the dearest point is under {CLEAR_VERDICT_SE:g} standard errors of "
                     "the extractions from the threshold (more --extractions narrow it)")
    if rows:
        lines.append("judged on each criterion's monotone fit over Q (the extractor's noise pooled): the criteria's "
                     "columns are the fit at the matched rate")
    return "\n".join(lines)

"""The comparison (seed 000 §4.2.4): one signing through all six solutions, judged by what a viewer can read.

Contract (`run`):
- in: CompareSettings. The signing is a natural clip (`--video FILE`, optional `.pose`), a fingerspelled word
  (`LANGUAGE WORD`, the demo) or a `.pose` alone; the Q sweeps per solution and video codec (MPEG-4 Part 2 Q 1-31,
  H.264 QP 0-51, SVT-AV1 QP 1-63), frame rates (frames/s), extractions per subject (1-MAX_EXTRACTIONS), backend.
  `check` / `check_settings` refuse what can be refused before work starts (SigncastError, one line).
- out, in out_dir: records.jsonl (one Record per measured point and reference, plus the run, uncoded, anchor,
  matched and stage records; comparisons.reports.records; kbps = kilobits per second of measured stream bytes over
  the clip's duration at its own frame rate), report.html, summary.csv, side_by_side.mp4 and its poster PNG.
  records.jsonl grows as points finish, so an interrupted run keeps them. Returns CompareResult.
- Every solution carries the same frames over the same duration. The NSV family codes the reference picture;
  SSV codes the avatar's lossless render (framed like the person in the video scenario: media.framing); FBA and
  BBA code the motion, and the terminal re-renders it at the display size.

What is measured and how it is judged (intelligibility against the source video and against the lossless render,
the extractions under sub-pixel shifts, the ceiling, the thresholds and margins, the monotone fit, the
coarse-to-fine schedule and its early stop, the pool, the per-extraction matches, equal refresh terms) is
documented, with its measurements, in docs/comparison.md; the measurement itself lives in comparisons.judging
(judge, operating, schedule, matching, criteria) and comparisons.video / comparisons.params (the codecs). This
module orders the work: the scenario, the uncoded references and the anchor, the points streamed on the pool,
the matches, the frame-rate sweeps, and the files.
"""
from __future__ import annotations

import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import cv2
import numpy as np
from tqdm import tqdm

from comparisons.judging import matching, metrics
from comparisons.judging import operating, schedule
from comparisons.judging.judge import LOSSLESS, SOURCE, UNCODED_SUBJECTS, Judge, Viewed, hand_share, hold_indices, select_frames
from comparisons.judging.landmark_draws import MAX_EXTRACTIONS, SHIFTS
from comparisons.judging.operating import (ANCHOR_CODEC, ANCHOR_FPS, ANCHOR_KBPS, ANCHOR_SIZE, ANCHOR_SUBJECT,
                                           CEILING_TIED, FACE_MARGIN, HUMAN_ANCHORED, LETTER_MARGIN,
                                           LOCATION_MARGIN, MIN_HAND_SHARE, PCK_MARGIN, SENSITIVITY_MARGINS, Series,
                                           anchored_criteria, criteria_for, q_to_refine)
from comparisons.video import codecs as video_codecs
from comparisons.video.anchor import code_at_rate
from comparisons.params import codecs as param_codecs
from comparisons.params import refresh as param_refresh
from comparisons.params.study import face_joint_fields
from comparisons.reports.comparison import operating_points, verdict_note
from comparisons.reports.records import as_records, make_record, versions
from pipeline.outputs import build_report, write_bytes, write_dicts, write_records
from comparisons.video import objects as video_objects
from comparisons.video import roi as video_roi
from media.domain import SKIN_PARTS, Solution, check_q, kbps, solution_of
from media.errors import SigncastError
from media.face_rig import with_face_bones
from media.lexicon import SignClip
from media.motion import Motion, resample
from media.render import AvatarRenderer
from media.tiling import tile_videos
from media.video_io import frame_indices_at_rate, write_video
from pipeline.stages import StageClock
from pipeline.studies import shared
from pipeline.live.session_cost import session_costs
from pipeline.studies.shared import DISPLAY_FPS, Scenario, ScenarioSettings, fit_length, render_frames, renderers

__all__ = ["CompareSettings", "run", "check", "LOSSLESS", "SOURCE", "UNCODED_SUBJECTS", "PCK_MARGIN", "LETTER_MARGIN",
           "FACE_MARGIN", "MIN_HAND_SHARE", "criteria_for", "q_to_refine", "DISPLAY_FPS"]

MAX_REFINEMENTS = 5           # halving a Q 1-31 bracket five times leaves adjacent Q
# today's codecs beside MPEG-4 Part 2, each swept on its own quantiser scale (constant QP: H.264 0-51, SVT-AV1 1-63),
# for the solutions that code one picture or a few objects (NSV3O's and NSV3O+C's object sets stay MPEG-4 Part 2)
OTHER_QS = (("libx264", (24, 30, 36, 42, 48)), ("libsvtav1", (28, 38, 48, 58)))
DEMO_OTHER_QS = (("libx264", (28, 36, 44)), ("libsvtav1", (34, 46, 58)))
OTHER_SOLUTIONS = ("NSV", "NSV2O", "SSV")
ARM_BONES = ("upperarm01", "upperarm02", "lowerarm01", "lowerarm02", "wrist")   # shoulder to wrist
HAND_BONE_PREFIXES = ("metacarpal", "finger")
SIZE_RULE = ("the avatar is rendered at the natural frame's size; the renderer frames the signing space for "
             "that aspect, so the avatar fills the frame as the renderer frames it")
SOURCE_SIZE_RULE = ("the avatar is rendered at the natural frame's size, framed like the person (one scale and shift "
                    "per clip fitted from its shoulders and face to the person's, as a camera zoom and shift)")


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
    video: shared.VideoSweep = shared.VideoSweep(other_codecs=("libx264", "libsvtav1"))
    param_codecs: tuple[str, ...] = ("fba-pred", "fba-dct", "bba-pred", "bba-dct", "bba-key")
    param_qs: tuple[int, ...] = (1, 2, 4, 8, 16, 31)
    size: tuple[int, int] = (352, 288)
    backend: str = "auto"
    max_clip_frames: int | None = None
    max_clip_size: tuple[int, int] | None = shared.DEFAULT_MAX_SIZE
    landmark_step: int = 1
    extractions: int = 4
    refinements: int = 2
    other_qs: tuple[tuple[str, tuple[int, ...]], ...] = OTHER_QS     # (codec, QP swept) of video.other_codecs
    other_solutions: tuple[str, ...] = OTHER_SOLUTIONS                # the solutions coded with them
    anchor: bool = True           # measure the human anchor (Tran et al.'s point) and match on it
    workers: int | None = None    # processes the points run on (None: every CPU; 1: in this process, in order)
    # measure every swept Q, every frame rate and every extraction (the schedule before issue 36), instead of
    # stopping where the answer is decided, and look for both hands in every measured frame (as all_hands);
    # for checking the faster schedule's figures
    full_schedule: bool = False
    # look for both hands in every measured frame of what the viewer sees; else only where a reference shows the
    # hand signing (or a letter span needs the signing hand: Judge.hands_to_extract), rests scored for the face
    all_hands: bool = False
    framing: str | None = None    # media.framing.FRAMINGS; None: "source" with a clip (the avatar scenarios: full figure)
    # NSV-ROI (comparisons/video/roi.py): one libx264 stream, CRF q with the face and hands at a lower quantiser,
    # swept on libx264's quantisers as CRF, when libx264 is among video.other_codecs
    roi: bool = True
    solutions: tuple[str, ...] | None = None      # only these solutions' series (None: every one)
    roi_offsets: tuple[float, float] = (video_roi.RoiSettings.skin_offset, video_roi.RoiSettings.rest_offset)

    @property
    def every_hand(self) -> bool:
        """Whether the extractor looks for both hands in every measured frame (all_hands or full_schedule)."""
        return self.all_hands or self.full_schedule

    def codec_qs(self, codec: str) -> tuple[int, ...]:
        """The quantisers swept for a video codec (MPEG-4 Part 2: video.qs)."""
        return self.video.qs if codec == "mpeg4" else dict(self.other_qs).get(codec, ())

    @property
    def signing(self) -> ScenarioSettings:
        """The scenario's own settings (pipeline.studies.shared.load_scenario)."""
        return ScenarioSettings(self.language, self.word, self.clip, self.pose, self.size, self.backend,
                                self.max_clip_frames, self.max_clip_size, self.framing)

    @property
    def scenario(self) -> str:
        """"video", "pose" or "word" (see the module's description)."""
        return self.signing.scenario

    @classmethod
    def demo(cls) -> "CompareSettings":
        """The word scenario on a sweep small enough for under 5 minutes on two CPU cores: video Q 4, 12, 31 and one
        refinement inside each matched bracket;
        frame rates 25 and 12.5; one FBA and one BBA codec at parameter Q 1, 4, 31; 352x288 render (at 176x144
        the hands are about 15 pixels and the landmarks' own noise exceeds the threshold); intelligibility measured
        on every 3rd frame, four extractions each (landmark extraction, 30-70 ms a frame, is most of the work)."""
        return cls(video=shared.VideoSweep(qs=(4, 12, 31), frame_rates=(25.0, 12.5),
                                           other_codecs=("libx264", "libsvtav1")),
                   param_codecs=("fba-pred", "bba-key"), param_qs=(1, 4, 31), size=(352, 288), landmark_step=3,
                   extractions=4, refinements=1, other_qs=DEMO_OTHER_QS, other_solutions=("NSV",))


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
    n_frames, width, height = shared.expected_frames(settings.signing)
    check_memory(n_frames, width, height, bytes_per_pixel(settings), command,
                 "choose a smaller --size or --max-size, or fewer frames")
    check_frame_rates(settings)
    if len(range(0, n_frames, settings.landmark_step)) < 2:
        raise SigncastError(f"--landmark-step {settings.landmark_step} measures fewer than 2 of the {n_frames} frames: "
                            "choose a smaller step")


def check_frame_rates(settings: CompareSettings) -> None:
    """Every frame rate the run will code, signalled before any work: the clip's own (the video scenario; 29.97 is
    30000/1001), the swept rates below it, and the human anchor's, by the parameter streams (frame_rate_fields) and
    the video encoders (a rational time base): one-line SigncastError for a rate that cannot be sent."""
    from comparisons.params.coding import frame_rate_fields
    if settings.scenario == "video":
        clip_fps = shared.video_info(shared.resolve_video(settings.clip)).fps
    elif settings.scenario == "pose":
        clip_fps = shared.read_pose(settings.pose).fps
    else:
        clip_fps = DISPLAY_FPS
    rates = [clip_fps] + [f for f in settings.video.frame_rates if f < clip_fps * (1 - 1e-3)]
    rates += [ANCHOR_FPS] if settings.anchor and ANCHOR_FPS < clip_fps * (1 - 1e-3) else []
    for fps in rates:
        try:
            frame_rate_fields(fps)
        except SigncastError as error:
            raise SigncastError(f"frame rate {fps:.6g} fps cannot be sent by the parameter streams ({error}); "
                                "re-time the clip (e.g. to 25 or 30 fps) or choose other --frame-rates") from None
        from fractions import Fraction
        if abs(float(Fraction(fps).limit_denominator(1001)) - fps) > 1e-3 * fps:
            raise SigncastError(f"frame rate {fps:.6g} fps has no time base of denominator <= 1001 for the video "
                                "encoders; re-time the clip")


def bytes_per_pixel(settings: CompareSettings) -> int:
    """What the comparison holds per pixel and frame: the reference, the lossless render and their labels (8),
    the skin masks (2), a point's coding working copies and received frames (about 12), the side-by-side's tiles
    (3 each, 9 tiles)."""
    return 8 + 2 + 12 + 3 * 9


def check_settings(settings: CompareSettings) -> None:
    """Refuse bad sweeps, codecs, counts and scenarios (one-line SigncastError); reads no frames."""
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
    for codec in sweep.other_codecs:
        if codec not in video_codecs.CODECS or codec == "mpeg4":
            raise SigncastError(f"unknown video codec {codec!r}: choose from libx264, libsvtav1 (MPEG-4 Part 2 is "
                                "always coded)")
        low, high = video_codecs.CODECS[codec][1]
        qs = settings.codec_qs(codec)
        if not qs or any(not max(low, 1) <= q <= high for q in qs):
            raise SigncastError(f"{codec}: give quantisers {max(low, 1)}..{high} to sweep, got {qs}")
    if settings.solutions is not None:
        if not settings.solutions:
            raise SigncastError("give at least one solution")
        coded = {*Solution.natural_family(), Solution.SSV, *(solution_of(c) for c in settings.param_codecs)}
        if settings.roi and any(c in video_roi.ROI_CODECS for c in sweep.other_codecs):
            coded.add(Solution.NSV_ROI)
        for name in settings.solutions:
            if Solution.of(name) not in coded:
                raise SigncastError(f"{name} is not coded with these codecs (NSV-ROI needs libx264 among the video "
                                    "codecs, FBA and BBA an fba-* or bba-* codec)")
    if settings.roi:
        video_roi.RoiSettings(skin_offset=settings.roi_offsets[0], rest_offset=settings.roi_offsets[1])
    if not 1 <= settings.extractions <= MAX_EXTRACTIONS:
        raise SigncastError(f"bad extraction count {settings.extractions}: choose 1 to {MAX_EXTRACTIONS}")
    shared.check_landmark_step(settings.landmark_step)
    if not 0 <= settings.refinements <= MAX_REFINEMENTS:
        raise SigncastError(f"bad refinement count {settings.refinements}: choose 0 to {MAX_REFINEMENTS}")
    shared.check_scenario(settings.signing)


# ------------------------------------------------------------------------------------------------------------
# coding

class VideoPoints:
    """NSV, NSV2O, NSV3O, NSV3O+C (coding the reference frames) and SSV (coding the lossless render)."""

    def __init__(self, scenario: Scenario, roi_offsets: tuple[float, float] = CompareSettings.roi_offsets):
        self.scenario = scenario
        self.shapes = video_objects.ShapeCache()
        self.roi_offsets = roi_offsets        # NSV-ROI's addroi qoffsets (face and hands, the rest), -1..1

    def source(self, solution: str) -> tuple[np.ndarray, np.ndarray, str]:
        s = self.scenario
        return (s.render, s.render_labels, "render") if solution == "SSV" else (s.frames, s.labels, "reference")

    def code(self, solution: str, q: int, fps: float, codec: str = "mpeg4") -> tuple[Viewed, np.ndarray, np.ndarray]:
        """(what the viewer sees, the sent frames (K, H, W, 3), hold (T,) indices of the sent frame on screen);
        codec: mpeg4, libx264 or libsvtav1 (each object coded with it at quantiser q)."""
        s = self.scenario
        frames, labels, key = self.source(solution)
        full = fps >= s.fps * (1 - 1e-3)
        kept = np.arange(s.n_frames) if full else frame_indices_at_rate(s.timing.times_s, s.timing.duration_s, fps)
        rate = s.fps if full else fps
        if solution == Solution.NSV_ROI:
            coded = video_objects.code_roi(frames[kept], labels[kept], rate, q, codec, self.roi_offsets)
            extra = {"rate_control": "crf"}     # q is x264's CRF (addroi needs CRF mode), not a constant QP
        else:
            coded = video_objects.code_solution(solution, frames[kept], labels[kept], rate, codec, q, self.shapes,
                                                f"{key}@{rate:g}")
            extra = {}
        hold = np.arange(s.n_frames) if full else hold_indices(s.timing.times_s, fps, len(kept))
        skin_objects = [o.decoded_masks for o in coded.objects if o.name in ("head", "left_hand", "right_hand")]
        skin = np.logical_or.reduce(skin_objects)[hold] if skin_objects else None
        height, width = frames.shape[1:3]
        fields = make_record(solution, s.name, codec, q, rate, width, height, coded.bits, s.timing.duration_s,
                             sweep="q" if full else "fps", full_resolution=True, frames=len(kept),
                             texture_bits=coded.bits - coded.shape_bits, shape_bits=coded.shape_bits,
                             objects=[{"name": o.name, "q": o.q, "texture_bytes": o.texture_bytes,
                                       "shape_bytes": o.shape_bytes, "area_percent": o.area_percent}
                                      for o in coded.objects], **extra)
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
        """(the motion the terminal shows at the scenario's rate and length, bits sent, frames sent). The stream
        refreshes (an intra plane) every video GOP (comparisons.params.refresh: equal terms with the video; its
        size at the codec's default refresh is kept in self.default_bits)."""
        s = self.scenario
        codec = param_codecs.get_codec(codec_name)
        full = fps >= s.fps * (1 - 1e-3)
        sent = s.motion if full else resample(s.motion, fps)
        data = param_refresh.encode(codec_name, sent, q, video_codecs.GOP)
        self.default_bits = 8 * len(codec.encode(sent, q))
        decoded = codec.decode(data)
        shown = decoded if full else resample(Motion(fps, decoded.bone_names, decoded.rotations,
                                                     decoded.root_translation, decoded.faps), s.fps)
        shown = Motion(s.fps, shown.bone_names, shown.rotations, shown.root_translation, shown.faps)
        return fit_length(shown, s.n_frames), 8 * len(data), sent.n_frames

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
                             frames=n_sent, refresh_frames=param_refresh.refresh_frames(codec_name, video_codecs.GOP),
                             default_refresh_frames=param_refresh.default_refresh_frames(codec_name),
                             kbps_default_refresh=kbps(self.default_bits, s.timing.duration_s),
                             joint_error_mm_mean=float(joint_mm.mean()),
                             joint_error_mm_max=float(joint_mm.max()),
                             hand_joint_error_mm=float(joint_mm[:, self.hand_joints].mean()),
                             arm_joint_error_mm=float(joint_mm[:, self.arm_joints].mean()),
                             **face_joint_fields(s.motion, played, played_shown, avatar))
        return Viewed(frames, np.isin(labels, SKIN_PARTS), fields), frames


# ------------------------------------------------------------------------------------------------------------
# the jobs a run is made of, and the process that measures them (issue 36)

FIRST_EXTRACTIONS = 2         # every subject starts with this many extractions; more only where the answer is unclear


@dataclass(frozen=True)
class PointJob:
    """One point to code, view and extract under the shifts (indices into SHIFTS); quality: also measure image
    quality (not when extractions are added to a point already measured); stage: what the job is for."""
    solution: str
    codec: str
    q: int
    fps: float
    shifts: tuple[int, ...]
    stage: str = "Q sweep"
    quality: bool = True
    refined: bool = False


@dataclass(frozen=True)
class CeilingJob:
    """One extraction of an uncoded reference ("source" or "render") under SHIFTS[shift]."""
    subject: str
    shift: int
    stage: str = "ceilings"


@dataclass(frozen=True)
class ExtractJob:
    """One extraction of frames (M, H, W, 3) uint8 shown at fps under SHIFTS[shift]; hands: (M, 2) bool, where the
    left / right hand is looked for (None: everywhere)."""
    frames: np.ndarray
    fps: float
    shift: int
    label: str = "landmarks"
    stage: str = "extraction"
    hands: np.ndarray | None = None


@dataclass
class MeasuredPoint:
    """A point's fields (what was coded and its image quality), its per-extraction intelligibility fields by
    reference and shift, extra record fields, and the records made from them (`records`)."""
    base: dict
    draws: dict[str, dict[int, dict]]
    extra: dict
    held: list[dict]

    def records(self) -> list[dict]:
        from comparisons.judging.landmark_draws import mean_fields
        return [dict(self.base, reference=name, **mean_fields([by_shift[k] for k in sorted(by_shift)]), **self.extra)
                for name, by_shift in self.draws.items()]


@dataclass
class SeriesPlan:
    """Where a series' measurement stands: its extractions per point, its phase ("sweep", "refine", "extract",
    "fps", "done") and the refinements made."""
    extractions: int
    phase: str = "sweep"
    refined: int = 0


class Measurer:
    """Codes points, extracts the landmarks of what the viewer sees and measures them (in a pool worker, or here
    with one worker): what one job needs, and nothing of the run's state."""

    def __init__(self, settings: CompareSettings, scenario: Scenario, recogniser, progress: bool = False):
        self.settings, self.scenario, self.progress = settings, scenario, progress
        self.judge = Judge(scenario, settings.landmark_step, recogniser)
        self.video = VideoPoints(scenario, settings.roi_offsets)
        self.params = ParamPoints(scenario, renderers(settings.backend)(*scenario.size, scenario.framing))
        self.cache = shared.ExtractionCache()

    def extract(self, frames: np.ndarray, fps: float, shifts: tuple[int, ...], label: str,
                hands: np.ndarray | None = None) -> list[SignClip]:
        """Extractions of frames (M, H, W, 3) under the shifts; hands: (M, 2) bool where each hand is looked for
        (ignored with settings.every_hand)."""
        return shared.extract_draws(frames, fps, len(shifts), label, self.progress, shifts=shifts, cache=self.cache,
                                    hands=None if self.settings.every_hand else hands)

    def ceiling(self, job: CeilingJob) -> dict:
        s, measured = self.scenario, self.judge.measured
        frames = s.frames if job.subject == "source" else s.render
        reference = self.judge.reference if job.subject == "source" else self.judge.render_reference
        observed = self.extract(frames[measured], s.fps, (job.shift,), f"re-extract the {job.subject}",
                                self.judge.hands_to_extract([reference]))[0]
        return {"observed": observed}

    def point(self, job: PointJob) -> dict:
        s, measured = self.scenario, self.judge.measured
        parameters = Solution(job.solution).mpeg4_parameters
        label = f"landmarks: {job.codec if parameters else f'{job.solution} {job.codec}'} Q{job.q} {job.fps:g} fps"
        hands = self.judge.hands_for(job.solution)                     # (M, 2) where each hand is read
        if parameters:
            viewed, _ = self.params.code(job.codec, job.q, job.fps)
            draws = self.extract(viewed.frames[measured], s.fps, job.shifts, label, hands)
        else:
            viewed, sent, hold = self.video.code(job.solution, job.q, job.fps, job.codec)
            # the distinct sent frames on screen at the measured frames, extracted once each
            distinct, on_screen = np.unique(hold[measured], return_inverse=True)
            draws = [select_frames(observed, on_screen, s.fps)
                     for observed in self.extract(sent[distinct], min(job.fps, s.fps), job.shifts, label,
                                                  held_hands(hands, on_screen, len(distinct)))]
        base = dict(viewed.fields, **self.judge.quality(job.solution, viewed)) if job.quality else None
        return {"base": base, "draws": dict(self.judge.intelligibility_draws(job.solution, draws)),
                "observed": draws[job.shifts.index(0)] if 0 in job.shifts else None}

    def run(self, job) -> dict:
        seconds, frames, cpu = shared.EXTRACTION["seconds"], shared.EXTRACTION["frames"], time.process_time()
        if isinstance(job, ExtractJob):
            result = {"observed": self.extract(job.frames, job.fps, (job.shift,), job.label, job.hands)[0]}
        else:
            result = self.ceiling(job) if isinstance(job, CeilingJob) else self.point(job)
        result.update(extraction_s=shared.EXTRACTION["seconds"] - seconds,
                      extracted_frames=shared.EXTRACTION["frames"] - frames, cpu_s=time.process_time() - cpu)
        return result


def held_hands(hands: np.ndarray, on_screen: np.ndarray, n_pictures: int) -> np.ndarray:
    """(D, 2) bool: the hands to look for in each of n_pictures pictures, where on_screen (M,) gives the picture shown
    at each measured frame and hands (M, 2) the hands read there: a picture held over several measured frames is
    looked at for every hand read in any of them."""
    wanted = np.zeros((n_pictures, 2), bool)
    np.logical_or.at(wanted, on_screen, hands)
    return wanted


def extractions_of(points: list[dict]) -> int:
    """The extractions every one of a series' points has (each starts with FIRST_EXTRACTIONS; a series whose
    per-extraction matches disagreed has all its Q points extended to settings.extractions): the K its
    per-extraction matches pair with the threshold's draws, shift by shift."""
    return min((int(p.get("extractions") or 1) for p in points), default=1)


_MEASURER: Measurer | None = None


def _start_measurer(settings: CompareSettings, scenario: Scenario, recogniser, progress: bool = False) -> None:
    global _MEASURER
    _MEASURER = Measurer(settings, scenario, recogniser, progress)


def _run_job(job) -> dict:
    return _MEASURER.run(job)


# ------------------------------------------------------------------------------------------------------------
# the run

class Study:
    """One run: points coded, viewed, their landmarks extracted (with progress bars) and judged
    (comparisons.judging.judge, .operating), appended to records.jsonl as they are measured; observed landmarks kept
    for the side by side."""

    def __init__(self, settings: CompareSettings, scenario: Scenario, renderer: AvatarRenderer,
                 records_path: Path, progress: bool, notify: Callable[[str], object] | None = None):
        self.settings, self.scenario, self.progress = settings, scenario, progress
        self.judge = Judge(scenario, settings.landmark_step, shared.letter_recogniser(scenario))
        self.video = VideoPoints(scenario, settings.roi_offsets)
        self.params = ParamPoints(scenario, renderer)
        self.records_path = records_path
        self.records: list[dict] = []
        self.observed: dict[tuple, SignClip] = {}
        self.points: dict[tuple, MeasuredPoint] = {}     # (solution, codec, q, fps) -> its draws and records
        self.pool: shared.StudyPool | None = None
        self.notify = notify
        self.extraction_s, self.extracted_frames = 0.0, 0   # landmark extraction in the pool's jobs
        self.jobs_cpu_s = 0.0                               # CPU seconds of the pool's jobs (all their threads)
        self.round_s: list[tuple[str, float, int]] = []     # (pool phase, wall seconds, frames extracted)

    def series(self) -> list[Series]:
        """Every solution and codec swept. In the video scenario each is matched on the person's message against the
        source video (Series.message)."""
        message = self.scenario.kind == "video"
        every = ([Series(s, "mpeg4", message) for s in (*Solution.natural_family(), Solution.SSV)]
                 + [Series(s, c, message) for c in self.settings.video.other_codecs
                    for s in self.settings.other_solutions]
                 + [Series(Solution.NSV_ROI, c, message) for c in self.settings.video.other_codecs
                    if self.settings.roi and c in video_roi.ROI_CODECS]
                 + [Series(solution_of(c), c, message) for c in self.settings.param_codecs])
        wanted = self.settings.solutions
        return every if wanted is None else [s for s in every if s.solution in wanted]

    def qs(self, series: Series) -> tuple[int, ...]:
        """The quantisers swept for a series: parameter Q, MPEG-4 Part 2 Q, or the codec's own QP."""
        if Solution(series.solution).mpeg4_parameters:
            return self.settings.param_qs
        return self.settings.codec_qs(series.codec)

    def q_range(self, series: Series) -> tuple[int, int]:
        """(finest, coarsest) quantiser of the series' scale, for the refinement."""
        if Solution(series.solution).mpeg4_parameters or series.codec == "mpeg4":
            return operating.MIN_Q, operating.MAX_Q
        low, high = video_codecs.CODECS[series.codec][1]
        return max(low, 1), high

    def lower_rates(self) -> list[float]:
        return sorted({f for f in self.settings.video.frame_rates if f < self.scenario.fps * (1 - 1e-3)}, reverse=True)

    def draws(self, frames: np.ndarray, fps: float, label: str, hands: np.ndarray | None = None) -> list[SignClip]:
        """The landmarks of frames (M, H, W, 3) uint8 shown at fps, extracted `extractions` times, each under its
        sub-pixel shift (pipeline.studies.shared.extract_draws): one job per shift on the pool while it is open,
        else here in this process. hands: (M, 2) bool where each hand is looked for (None, or
        settings.every_hand: everywhere)."""
        hands = None if self.settings.every_hand else hands
        if self.pool is None or not self.pool.open:
            return shared.extract_draws(frames, fps, self.settings.extractions, label, self.progress, hands=hands)
        jobs = [ExtractJob(frames, fps, k, label, hands=hands) for k in range(self.settings.extractions)]
        return [result["observed"] for result in self.run_jobs(jobs, f"{label}: {len(jobs)} extractions")]

    # -------------------------------------------------------------------------------------------------------
    # the execution: independent jobs on the pool (issue 36)

    def start_pool(self) -> shared.StudyPool:
        """The pool the points and ceilings run on (settings.workers processes, each with its own Measurer)."""
        workers = self.settings.workers or shared.default_workers()
        self.pool = shared.StudyPool(workers, _start_measurer,
                                     (self.settings, self.scenario, self.judge.recogniser, workers == 1 and self.progress),
                                     preload=("pipeline.studies.compare",))
        return self.pool

    def run_jobs(self, jobs: list, desc: str) -> list:
        """Run jobs (CeilingJob or ExtractJob) on the pool, with one progress bar whose total is the jobs'."""
        started, frames_before = time.perf_counter(), self.extracted_frames
        with tqdm(total=len(jobs), desc=desc, unit="job", disable=not self.progress) as bar:
            results = self.pool.run(_run_job, jobs, lambda i, result: bar.update(1))
        for result in results:
            self.account(result)
        self.round_s.append((desc, time.perf_counter() - started, self.extracted_frames - frames_before))
        return results

    def account(self, result: dict) -> None:
        """Add a job's landmark-extraction seconds, frames extracted and CPU seconds to the run's."""
        self.extraction_s += result["extraction_s"]
        self.extracted_frames += result["extracted_frames"]
        self.jobs_cpu_s += result["cpu_s"]

    def uncoded(self) -> list[dict]:
        """The ceilings: each reference's measured frames re-extracted under every shift (settings.extractions, one
        job each, on the pool) and judged (Judge.uncoded)."""
        s, count = self.scenario, self.settings.extractions
        subjects = ("source",) if s.render is s.frames else ("source", "render")
        jobs = [CeilingJob(subject, k) for subject in subjects for k in range(count)]
        results = self.run_jobs(jobs, f"ceilings: {len(subjects)} x {count} extractions")
        draws = {subject: [r["observed"] for job, r in zip(jobs, results) if job.subject == subject]
                 for subject in subjects}
        return self.judge.uncoded(draws["source"], draws.get("render", draws["source"]))

    def add(self, records: list[dict]) -> None:
        write_records(self.records_path, records, append=True)
        self.records += records

    def store(self, job: "PointJob", result: dict, extra: dict) -> None:
        """A point's results: its records made (first extractions) or remade with the draws added (later ones), in
        place, appended to records.jsonl again."""
        key = (job.solution, job.codec, job.q, job.fps)
        point = self.points.get(key)
        if point is None:
            point = self.points[key] = MeasuredPoint(result["base"], {}, dict(extra), [])
        for name, fields in result["draws"].items():
            point.draws.setdefault(name, {}).update(zip(job.shifts, fields))
        records = point.records()
        if not point.held:
            point.held = records
            self.records += records
        else:
            for held, record in zip(point.held, records):
                held.clear()
                held.update(record)
        write_records(self.records_path, point.held, append=True)
        if result["observed"] is not None:
            self.observed[(job.solution, job.codec, job.q, point.held[0]["fps"])] = result["observed"]

    def threshold(self, series: Series) -> tuple[dict, Callable, list[matching.Criterion]]:
        """(the threshold's record, criteria_of(record), its criteria) a series is matched on (`primary`)."""
        _, record, criteria_of = self.primary(series.reference)
        return record, criteria_of, criteria_of(record)

    def next_jobs(self, series: Series, plan: "SeriesPlan") -> list["PointJob"]:
        """The series' jobs to run next (none where it is done): the next swept Q (coarse to fine, stopping
        once the fit has crossed the threshold between neighbours), then the refinements, then more extractions
        for all its Q points where the per-extraction matches disagree, then the frame rates from the highest down
        (comparisons.judging.schedule)."""
        s = self.scenario
        points = series.points(self.records)
        record, criteria_of, criteria = self.threshold(series)
        full = (series.solution, series.codec)
        shifts = tuple(range(plan.extractions))
        if plan.phase == "sweep":
            if self.settings.full_schedule:
                q = next((q for q in sorted(self.qs(series), reverse=True) if q not in {r["q"] for r in points}), None)
            else:              # each extraction's own fit asks for points too (the verdict is theirs)
                own = [([operating.pick(p, k) for p in points], criteria_of(operating.pick(record, k)))
                       for k in range(plan.extractions)]
                q = schedule.next_swept_q(self.qs(series), points, criteria, own)
            if q is not None:
                return [PointJob(*full, q, s.fps, shifts, "Q sweep")]
            plan.phase = "refine"
        if plan.phase == "refine":
            if plan.refined < self.settings.refinements:
                found = matching.cheapest_rate(points, criteria, monotone=True)
                q = q_to_refine(found, {int(r["q"]) for r in points}, self.q_range(series))
                if q is not None:
                    plan.refined += 1
                    return [PointJob(*full, q, s.fps, shifts, "refinement", refined=True)]
            plan.phase = "extract"
        if plan.phase == "extract":
            most = self.settings.extractions
            if plan.extractions < most:
                matches = operating.extraction_matches(points, record, criteria_of, plan.extractions)
                if not schedule.extractions_agree(matches):
                    added = tuple(range(plan.extractions, most))
                    plan.extractions = most
                    plan.phase = "sweep"         # the fit may move: the search and refinement go on from there
                    return [PointJob(*full, int(p["q"]), s.fps, added, "more extractions", quality=False,
                                     refined=bool(p.get("refined"))) for p in points]
            plan.phase = "fps"
        if plan.phase == "fps":
            found = matching.cheapest_rate(points, criteria, monotone=True)
            q = int(found.upper["q"])
            at_q = [r for r in series.points(self.records, "fps") if r["q"] == q] + [found.upper]
            if self.settings.full_schedule:
                rate = next((f for f in self.lower_rates() if f not in {r["fps"] for r in at_q}), None)
            else:
                rate = schedule.next_frame_rate(self.lower_rates(), at_q, criteria)
            if rate is not None:
                return [PointJob(*full, q, rate, shifts, "frame rates")]
            plan.phase = "done"
        return []

    def measure_all(self) -> None:
        """Every series measured on the pool as a stream: each series' first jobs start at once, and when a series'
        jobs have all finished its next ones (`next_jobs`) are queued at once, without waiting for the other
        series. A series' jobs depend only on its own points and the thresholds, so the order in which series
        finish changes nothing that is measured; it keeps both cores busy to the end, where rounds left one idle."""
        first = self.settings.extractions if self.settings.full_schedule else FIRST_EXTRACTIONS
        plans = {series: SeriesPlan(min(first, self.settings.extractions)) for series in self.series()}
        self.announce_cost(plans)
        by_key = {(series.solution, series.codec): series for series in plans}
        waiting: dict[Series, int] = {}      # a series' jobs still running
        done = Counter()                      # jobs finished, by stage
        started, frames_before = time.perf_counter(), self.extracted_frames
        initial = []
        for series, plan in plans.items():
            jobs = self.next_jobs(series, plan)
            waiting[series] = len(jobs)
            initial += jobs
        bound = self.jobs_bound(plans)

        def finished() -> str:
            return "points: " + ", ".join(f"{n} {stage}" for stage, n in done.items())

        with tqdm(total=bound, desc="points", unit="job", disable=not self.progress) as bar:
            def follow(job: PointJob, result: dict) -> list[PointJob]:
                self.account(result)
                self.store(job, result, {"refined": True} if job.refined else {})
                done[job.stage] += 1
                bar.set_description(finished())
                bar.update(1)
                if sum(done.values()) == len(initial):
                    self.announce_estimate(plans, time.perf_counter() - started,
                                           self.extracted_frames - frames_before)
                series = by_key[(job.solution, job.codec)]
                waiting[series] -= 1
                if waiting[series]:
                    return []
                jobs = self.next_jobs(series, plans[series])
                waiting[series] = len(jobs)
                return jobs

            self.pool.stream(_run_job, initial, follow)
            bar.total = bar.n              # a bound: the searches stopped early
            bar.refresh()
        self.round_s.append((finished(), time.perf_counter() - started, self.extracted_frames - frames_before))

    def match(self) -> list[dict]:
        """The matched record of every series measured (`measure_all`), with the lowest frame rate holding at its
        upper bracket's Q."""
        matched = []
        for series in self.series():
            _, _, criteria = self.threshold(series)
            found = matching.cheapest_rate(series.points(self.records), criteria, monotone=True)
            operating.mark_operating(series.points(self.records), found.kbps, criteria)
            q = found.upper["q"]
            at_q = [r for r in series.points(self.records, "fps") if r["q"] == q] + [found.upper]
            matched.append(self.matched_record(series, found, criteria,
                                               matching.lowest_fps_holding(at_q, criteria, monotone=True)))
        self.add(matched)
        return matched

    def cost_bound(self, plans: dict) -> tuple[int, int]:
        """(points, frame extractions) at most: per series every swept Q, its refinements and the frame rates, at the
        first extractions, plus the added extractions where every series needs them."""
        frames = len(self.judge.measured)
        points = extractions = 0
        for series, plan in plans.items():
            search = len(self.qs(series))      # a search stops earlier, but may measure every swept Q
            n = search + self.settings.refinements + len(self.lower_rates())
            points += n
            extractions += frames * (n * plan.extractions
                                     + (search + self.settings.refinements)
                                     * (self.settings.extractions - plan.extractions))
        return points, extractions

    def note(self, line: str) -> None:
        if self.notify is not None:
            self.notify(line)
        elif self.progress:
            tqdm.write(line)

    def announce_cost(self, plans: dict) -> None:
        points, extractions = self.cost_bound(plans)
        first = min(plan.extractions for plan in plans.values())
        self.note(f"at most {points} points x {len(self.judge.measured)} frames x {first}"
                  f"{f'-{self.settings.extractions}' if self.settings.extractions > first else ''} extractions "
                  f"(at most {extractions} frame extractions) on {self.pool.workers} process"
                  f"{'es' if self.pool.workers > 1 else ''}")

    def jobs_bound(self, plans: dict) -> int:
        """The point jobs at most: per series every swept Q, its refinements and the frame rates, plus one job per
        swept or refined point where extractions are added."""
        jobs = 0
        for series, plan in plans.items():
            measured = len(self.qs(series)) + self.settings.refinements
            jobs += measured + len(self.lower_rates()) + (measured if plan.extractions < self.settings.extractions else 0)
        return jobs

    def announce_estimate(self, plans: dict, seconds: float, frames: int) -> None:
        """The minutes the rest will take at most, from the first jobs' seconds per frame extracted."""
        if frames:
            _, bound = self.cost_bound(plans)
            self.note(f"first jobs: {frames} frame extractions in {seconds:.0f} s; the rest takes at most about "
                      f"{max(bound - frames, 0) * seconds / frames / 60:.1f} min")

    def matched_record(self, series: Series, found: matching.Match, criteria, fps_holds) -> dict:
        """The series at its matched rate (comparisons.judging.operating.matched_record) under the primary threshold
        (`primary`), each extraction matched on its own (kbps: the median of the K rates, kbps_min/kbps_max their
        range, verdict_clear when all K agree; pooled_kbps the match of the means), the margin at the matched point,
        the face's own verdict and, for an avatar matched on the person's message, its codec loss against the
        lossless render."""
        name, threshold_record, criteria_of = self.primary(series.reference)
        points = series.points(self.records)
        record = operating.matched_record(series, found, criteria, clip=self.scenario.name, fps_holds=fps_holds)
        record.update(pooled_kbps=found.kbps, pooled_reached=found.reached, threshold_name=name,
                      margin_at_match=operating.margin_at(found, points, criteria),
                      **operating.extraction_summary(operating.extraction_matches(
                          points, threshold_record, criteria_of, extractions_of(points))))
        if any(p.get("kbps_default_refresh") is not None for p in points):
            record["default_refresh"] = operating.at_default_refresh(points, threshold_record, criteria_of,
                                                                     extractions_of(points))
        face = operating.face_criterion(threshold_record, margin=0.0 if name == HUMAN_ANCHORED else FACE_MARGIN)
        if face is not None:
            value = matching.fields_at(found, (face.field,)).get(face.field)
            record.update(face_threshold=face.threshold, face_value=value,
                          face_ok=None if value is None else face.met({face.field: value}))
        if series.message and series.avatar:
            loss = series.codec_loss()
            loss_criteria = criteria_for(self.ceiling(LOSSLESS), hand_share(self.scenario.render_landmarks),
                                         len(self.judge.spans or ()))
            lost = matching.cheapest_rate(loss.points(self.records), loss_criteria, monotone=True)
            record["codec_loss"] = {"kbps": lost.kbps, "reached": lost.reached, "q": lost.upper["q"],
                                    "threshold": matching.threshold_text(loss_criteria),
                                    "hand_pck_20": (lost.fitted or {}).get("hand_pck_20")}
        return record

    def anchor(self) -> list[dict]:
        """The human anchor ("anchor" record): the reference coded at Tran et al.'s point (H.264, the frames scaled to
        fit 320x240, 10 fps, 60 kbit/s; comparisons.video.anchor), shown at the reference's size and held at its
        frame times, read by the same extractor under the same shifts as every point, against the source video."""
        s = self.scenario
        fps = min(ANCHOR_FPS, s.fps)
        full = fps >= s.fps * (1 - 1e-3)
        kept = np.arange(s.n_frames) if full else frame_indices_at_rate(s.timing.times_s, s.timing.duration_s, fps)
        coded = code_at_rate(s.frames, kept, fps, ANCHOR_KBPS, ANCHOR_SIZE, ANCHOR_CODEC)
        hold = np.arange(s.n_frames) if full else hold_indices(s.timing.times_s, fps, len(kept))
        distinct, on_screen = np.unique(hold[self.judge.measured], return_inverse=True)
        hands = held_hands(self.judge.hands_for("NSV"), on_screen, len(distinct))
        draws = [select_frames(observed, on_screen, s.fps)
                 for observed in self.draws(coded.decoded[distinct], fps, "landmarks: human anchor (Tran's point)",
                                            hands)]
        fields = {"kind": "anchor", "subject": ANCHOR_SUBJECT, "solution": "NSV", "codec": ANCHOR_CODEC,
                  "clip": s.name, "fps": fps, "frames": len(kept), "kbps": kbps(coded.bits, s.timing.duration_s),
                  "target_kbps": ANCHOR_KBPS, "width": coded.size[0], "height": coded.size[1],
                  "study": "Tran et al., ASSETS 2013; TACCESS 2015"}
        return self.judge.records("NSV", Viewed(coded.decoded[hold], None, fields), draws)

    def primary(self, reference: str):
        """(threshold name, its record, criteria_of(record)) the matches are taken on: the human anchor where measured,
        else the ceiling-tied threshold at PCK_MARGIN."""
        name, _, record, criteria_of = self.thresholds(reference)[0]
        return name, record, criteria_of

    def thresholds(self, reference: str) -> list[tuple]:
        """(name, the ceiling-tied margin or None, threshold record, criteria_of(record)) of every threshold
        reported: the human anchor (where measured), then the ceiling-tied one at PCK_MARGIN and the sensitivity
        table's margins."""
        message = self.scenario.kind == "video"
        landmarks = self.scenario.landmarks if reference == SOURCE else self.scenario.render_landmarks
        share = hand_share(landmarks)
        found = []
        anchor = next((r for r in self.records if r.get("kind") == "anchor"), None)
        if anchor is not None:
            found.append((HUMAN_ANCHORED, None, anchor,
                          lambda record: anchored_criteria(record, share, message=message)))
        for margin in sorted({PCK_MARGIN, *SENSITIVITY_MARGINS}, key=lambda m: (m != PCK_MARGIN, m)):
            found.append((CEILING_TIED, margin, self.ceiling(reference),
                          lambda record, margin=margin: self.criteria(reference, record, margin)))
        return found

    def sensitivity(self) -> list[dict]:
        """"sensitivity" records: every series matched under every threshold (`thresholds`), each extraction on its
        own (comparisons.judging.operating.extraction_summary)."""
        rows = []
        for series in self.series():
            points = series.points(self.records)
            for name, margin, record, criteria_of in self.thresholds(series.reference):
                rows.append({"kind": "sensitivity", "threshold_name": name, "pck_margin": margin,
                             "solution": series.solution, "codec": series.codec, "reference": series.reference,
                             "threshold": matching.threshold_text(criteria_of(record)),
                             **operating.extraction_summary(operating.extraction_matches(
                                 points, record, criteria_of, extractions_of(points)))})
        return rows

    def ceiling(self, reference: str) -> dict:
        return operating.ceiling(self.records, reference)

    def criteria(self, reference: str, ceiling: dict | None = None,
                 margin: float = PCK_MARGIN) -> list[matching.Criterion]:
        """The threshold tied to the uncoded reference (comparisons.judging.operating.criteria_for; on the person's
        message in the video scenario); ceiling: the reference's ceiling record (None: the measured one; the
        per-extraction matches pass one extraction's); margin: the hand margin, points."""
        ceiling = self.ceiling(reference) if ceiling is None else ceiling
        landmarks = self.scenario.landmarks if reference == SOURCE else self.scenario.render_landmarks
        return criteria_for(ceiling, hand_share(landmarks), len(self.judge.spans or ()), pck_margin=margin,
                            message=self.scenario.kind == "video")


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
    extraction_before = shared.EXTRACTION["seconds"]
    renderer_for = renderers(settings.backend)
    with clock.stage("scenario: reference, landmarks, retargeting, lossless render"):
        scenario = shared.load_scenario(settings.signing, renderer_for, progress=progress, notify=notify)
    with clock.stage("start: the terminal's renderer and the worker pool"):
        study = Study(settings, scenario, renderer_for(*scenario.size, scenario.framing), records_path, progress,
                      notify)
        pool = study.start_pool()
    with pool:
        with clock.stage("uncoded references"):
            study.add(study.uncoded())
        if settings.anchor:
            with clock.stage("human anchor: the reference coded at Tran et al.'s point"):
                study.add(study.anchor())
        with clock.stage("points: Q search, refinements, added extractions, frame rates (streamed on the pool)"):
            study.measure_all()
            pool.close()
    with clock.stage("matching"):
        matched = study.match()
        study.add(study.sensitivity())
    # landmark extraction: this process's, and the pool workers' (with one worker the jobs ran here)
    extraction_s = shared.EXTRACTION["seconds"] - extraction_before + (study.extraction_s if pool.workers > 1 else 0.0)
    side_by_side = out_dir / "side_by_side.mp4"
    with clock.stage("side-by-side video"):
        poster = _write_side_by_side(_tiles(study, matched), side_by_side, scenario.fps)
    run_record = {"kind": "run", "backend": shared.backend_name(settings.backend), "versions": versions(),
                  "scenario": scenario.kind, "clip": scenario.name, "clip_fps": scenario.fps,
                  "clip_duration_s": scenario.timing.duration_s, "clip_frames": scenario.n_frames,
                  "clip_size": list(scenario.size), "display_fps": scenario.fps, "signer_size": list(scenario.size),
                  "size_rule": ((SOURCE_SIZE_RULE if scenario.framing else SIZE_RULE) if scenario.kind == "video"
                                else "the reference is the avatar's render"),
                  "framing": ({"framing": "source", "scale": scenario.framing.scale,
                               "shift": list(scenario.framing.shift), "turn_deg": scenario.framing.turn}
                              if scenario.framing
                              else {"framing": "full-figure"}),
                  "pck_margin": PCK_MARGIN, "face_margin": FACE_MARGIN, "letter_margin": LETTER_MARGIN,
                  "min_hand_share": MIN_HAND_SHARE,
                  "refinements": settings.refinements,
                  "extractions": settings.extractions, "extraction_shifts": [list(shift) for shift in
                                                                             SHIFTS[:settings.extractions]],
                  "matched_against": ({"every solution": f"{SOURCE} (message fidelity)"} if scenario.kind == "video"
                                      else {"NSV family": SOURCE, "SSV, FBA, BBA": LOSSLESS}),
                  "synthetic_reference": scenario.kind != "video", "location_margin": LOCATION_MARGIN,
                  "sensitivity_margins": list(SENSITIVITY_MARGINS), "video_codecs": ["mpeg4", *settings.video.other_codecs],
                  "codec_qs": {codec: list(settings.codec_qs(codec)) for codec in ("mpeg4", *settings.video.other_codecs)},
                  "other_solutions": list(settings.other_solutions),
                  "roi": ({"codecs": [c for c in settings.video.other_codecs if c in video_roi.ROI_CODECS],
                           "qoffsets": list(settings.roi_offsets), "rate_control": "crf"} if settings.roi else None),
                  "anchor": ({"codec": ANCHOR_CODEC, "size": list(ANCHOR_SIZE), "fps": ANCHOR_FPS,
                              "kbps": ANCHOR_KBPS, "study": "Tran et al., ASSETS 2013; TACCESS 2015"}
                             if settings.anchor else None),
                  "gop_frames": video_codecs.GOP,
                  "session_costs": session_costs([(x.solution, x.codec) for x in study.series()], fps=scenario.fps,
                                                 n_frames=scenario.n_frames, size=scenario.size, clip=scenario.name,
                                                 refresh=video_codecs.GOP),
                  "workers": pool.workers, "full_schedule": settings.full_schedule,
                  "hands_looked_for": ("every measured frame" if settings.every_hand else
                                       "where a reference shows the hand signing, and the signing hand in letter "
                                       "spans (rests scored for the face and body)"),
                  "first_extractions": (settings.extractions if settings.full_schedule
                                        else min(FIRST_EXTRACTIONS, settings.extractions)),
                  "rounds": [{"round": name, "wall_s": round(seconds, 2), "frames_extracted": frames}
                             for name, seconds, frames in study.round_s],
                  "extraction_s": round(extraction_s, 2),
                  # CPU seconds of the jobs run in pool workers (with one worker they ran in this process)
                  "worker_cpu_s": round(study.jobs_cpu_s, 2) if pool.workers > 1 else 0.0}
    all_records = [run_record] + study.records + clock.records()
    write_records(out_dir / "records.jsonl", all_records)
    write_bytes(out_dir / "side_by_side_poster.png", poster)
    report = build_report(as_records(all_records), out_dir / "report.html", poster_png=poster)
    write_summary_csv(all_records, out_dir / "summary.csv")
    return CompareResult(all_records, report, side_by_side, out_dir, operating_points(all_records), matched)


# ------------------------------------------------------------------------------------------------------------
# the side by side

def _tiles(study: Study, matched: list[dict]) -> list[Received]:
    """The reference (and the lossless render) and each solution at its matched point's upper bracket Q (for FBA and
    BBA the cheapest codec), each with the landmarks extracted from it drawn on it."""
    s = study.scenario
    tiles = [Received(shared.draw_landmarks(s.frames, s.landmarks), f"reference: {s.name} (uncoded)")]
    # each frame shows the landmarks of the last measured frame (every landmark_step-th)
    last_measured = np.maximum(np.searchsorted(study.judge.measured, np.arange(s.n_frames), side="right") - 1, 0)
    if s.kind == "video":
        framed = "framed like the person" if s.framing else "full figure"
        tiles.append(Received(shared.draw_landmarks(s.render, s.render_landmarks), f"avatar: lossless render, {framed}"))
    for solution in (s for s in Solution if s.natural or s.avatar):
        candidates = [m for m in matched if m["solution"] == solution]
        if not candidates:
            continue
        best = min(candidates, key=lambda m: (not m["reached"], m["kbps"]))
        q = best["q_shown"]
        if solution.mpeg4_parameters:
            _, frames = study.params.code(best["codec"], q, s.fps)
        else:
            viewed, _, _ = study.video.code(solution, q, s.fps, best["codec"])
            frames = viewed.frames
        observed = select_frames(study.observed[(solution, best["codec"], q, s.fps)], last_measured)
        codec = f" {best['codec']}"
        rate = (f"matched {best['kbps']:.1f} kbps" if best["reached"]
                else f"best point {best['kbps']:.1f} kbps, below threshold")
        scale = "CRF" if solution == Solution.NSV_ROI else "Q"
        tiles.append(Received(shared.draw_landmarks(frames, observed), f"{solution}{codec} {scale}{q}, {rate}",
                              solution))
    return tiles


def _write_side_by_side(received: list[Received], path: Path, fps: float) -> bytes:
    """Tile the received videos, encode with H.264 at fps, return a PNG poster frame."""
    tiled = tile_videos([(r.frames, r.caption) for r in received], tile_size=(352, 288), columns=4)
    write_video(path, tiled, fps, codec="libx264", options={"crf": 18, "preset": "veryfast"})
    ok, png = cv2.imencode(".png", cv2.cvtColor(tiled[len(tiled) // 2], cv2.COLOR_RGB2BGR))
    if not ok:
        raise SigncastError("could not encode the poster frame")
    return png.tobytes()


# ------------------------------------------------------------------------------------------------------------
# summaries

def summary_rows(records: list[dict]) -> list[dict]:
    """One row per matched series."""
    return [{"solution": r["solution"], "codec": r["codec"], "reference": r["reference"], "kbps": r["kbps"],
             "q_low": r["q_low"], "q_high": r["q_high"], "reached": r["reached"],
             "verdict_clear": r.get("verdict_clear"),
             "extractions": r.get("extractions"), "reached_extractions": r.get("reached_extractions"),
             "kbps_min": r.get("kbps_min"), "kbps_max": r.get("kbps_max"), "threshold_name": r.get("threshold_name"),
             "fps_holds": r.get("fps_holds"),
             "hand_pck_20": r.get("hand_pck_20"), "face_error": r.get("face_error"),
             "face": r.get("face_value", r.get("message_face")), "face_ok": r.get("face_ok"),
             "kbps_default_refresh": (r.get("default_refresh") or {}).get("kbps"),
             "letter_top1": r.get("letter_top1"), "skin_psnr": r.get("skin_psnr"), "threshold": r["threshold"]}
            for r in records if r.get("kind") == "matched"]


def write_summary_csv(records: list[dict], path: Path) -> Path:
    """summary.csv: `summary_rows`."""
    rows = summary_rows(records)
    return write_dicts(path, rows, list(rows[0]) if rows else ["solution"])


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
    lines.append(f"{'solution':9} {'codec':9} {'reference':16} {'kbps':>8} {'range':>13} {'Q':>6} {'PCK@.2':>7} "
                 f"{'face':>7} {'top-1':>6} {'skin dB':>7} {'holds to':>9}  verdict")
    for row in rows:
        q = f"{row['q_low']}-{row['q_high']}" if row["q_low"] != row["q_high"] else str(row["q_low"])
        holds = f"{row['fps_holds']:g} fps" if row["fps_holds"] is not None else "–"
        kbps = f"{row['kbps']:.1f}{'' if row['reached'] else '*'}"
        low, high = row["kbps_min"], row["kbps_max"]
        spread = f"{low:.1f}-{high:.1f}" if low is not None and high is not None and high > low else "–"
        face = fmt(row["face"], ">6.3f") + ("" if row["face_ok"] is None else "✔" if row["face_ok"] else "✘")
        lines.append(f"{row['solution']:9} {row['codec']:9} {row['reference']:16} {kbps:>8} "
                     f"{spread:>13} {q:>6} {fmt(row['hand_pck_20'], '>7.1f')} "
                     f"{face:>7} {fmt(row['letter_top1'], '>6.0f')} "
                     f"{fmt(row['skin_psnr'], '>7.2f')} {holds:>9}  {_verdict(row)}")
    if any(not row["reached"] for row in rows):
        lines.append("* threshold not reached: the best swept point's rate")
    if any(row["kbps_min"] is not None for row in rows):
        lines.append("kbps: the median of the rates matched extraction by extraction; range: their minimum-maximum")
    if any(row["face"] is not None for row in rows):
        lines.append("face: the aligned mouth and eyes/brows error (interocular distances) at the matched rate, "
                     "✔/✘ against its own threshold (a criterion of the match)")
    if any(row["verdict_clear"] is False for row in rows):
        lines.append("too close to call: the extractions, each matched on its own, disagree (more --extractions "
                     "narrow it)")
    if any(row["solution"] == Solution.NSV_ROI for row in rows):
        lines.append("NSV-ROI: one H.264 stream, the face and hands at a lower quantiser (x264 region offsets); its Q "
                     "is x264's CRF, the other libx264 rows' a constant QP")
    params = [row for row in rows if row["kbps_default_refresh"] is not None]
    if params:
        lines.append("FBA/BBA refresh every video GOP (12 frames); at their default refresh: "
                     + ", ".join(f"{row['codec']} {row['kbps_default_refresh']:.1f}" for row in params) + " kbps")
    if rows:
        lines.append("judged on each criterion's monotone fit over Q (the extractor's noise pooled): the criteria's "
                     "columns are the fit at the matched rate")
    return "\n".join(lines)

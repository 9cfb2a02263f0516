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

from comparisons.judging import matching, metrics
from comparisons.judging import operating
from comparisons.judging.judge import LOSSLESS, SOURCE, UNCODED_SUBJECTS, Judge, Viewed, hand_share, hold_indices, select_frames
from comparisons.judging.landmark_draws import MAX_EXTRACTIONS, SHIFTS
from comparisons.judging.operating import (CLEAR_VERDICT_SE, FACE_MARGIN, LETTER_MARGIN, MIN_HAND_SHARE, PCK_MARGIN,
                                           Series, criteria_for, q_to_refine)
from comparisons.params import codecs as param_codecs
from comparisons.params.study import face_joint_fields
from comparisons.reports.comparison import operating_points, verdict_note
from comparisons.reports.records import make_record, versions
from pipeline.outputs import build_report, write_bytes, write_dicts, write_records
from comparisons.video import objects as video_objects
from media.domain import SKIN_PARTS, Solution, check_q, solution_of
from media.errors import SigncastError
from media.face_rig import with_face_bones
from media.lexicon import SignClip
from media.motion import Motion, resample
from media.render import AvatarRenderer
from media.tiling import tile_videos
from media.video_io import frame_indices_at_rate, write_video
from pipeline.stages import StageClock
from pipeline.studies import shared
from pipeline.studies.shared import DISPLAY_FPS, Scenario, ScenarioSettings, fit_length, render_frames, renderers

__all__ = ["CompareSettings", "run", "check", "LOSSLESS", "SOURCE", "UNCODED_SUBJECTS", "PCK_MARGIN", "LETTER_MARGIN",
           "FACE_MARGIN", "MIN_HAND_SHARE", "CLEAR_VERDICT_SE", "criteria_for", "q_to_refine", "DISPLAY_FPS"]

MAX_REFINEMENTS = 5           # halving a Q 1-31 bracket five times leaves adjacent Q
ARM_BONES = ("upperarm01", "upperarm02", "lowerarm01", "lowerarm02", "wrist")   # shoulder to wrist
HAND_BONE_PREFIXES = ("metacarpal", "finger")
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
    video: shared.VideoSweep = shared.VideoSweep(other_codecs=())
    param_codecs: tuple[str, ...] = ("fba-pred", "fba-dct", "bba-pred", "bba-dct", "bba-key")
    param_qs: tuple[int, ...] = (1, 2, 4, 8, 16, 31)
    size: tuple[int, int] = (352, 288)
    backend: str = "auto"
    max_clip_frames: int | None = None
    max_clip_size: tuple[int, int] | None = shared.DEFAULT_MAX_SIZE
    landmark_step: int = 1
    extractions: int = 4
    refinements: int = 2

    @property
    def signing(self) -> ScenarioSettings:
        """The scenario's own settings (pipeline.studies.shared.load_scenario)."""
        return ScenarioSettings(self.language, self.word, self.clip, self.pose, self.size, self.backend,
                                self.max_clip_frames, self.max_clip_size)

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
        return cls(video=shared.VideoSweep(qs=(4, 12, 31), frame_rates=(25.0, 12.5), other_codecs=()),
                   param_codecs=("fba-pred", "bba-key"), param_qs=(1, 4, 31), size=(352, 288), landmark_step=3,
                   extractions=4, refinements=1)


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
    if len(range(0, n_frames, settings.landmark_step)) < 2:
        raise SigncastError(f"--landmark-step {settings.landmark_step} measures fewer than 2 of the {n_frames} frames: "
                            "choose a smaller step")


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
    if sweep.other_codecs:
        raise SigncastError(f"compare codes video with MPEG-4 Part 2 only for now: --video-codecs "
                            f"{','.join(sweep.other_codecs)} is not measured; give --video-codecs none")
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
                             frames=n_sent, joint_error_mm_mean=float(joint_mm.mean()),
                             joint_error_mm_max=float(joint_mm.max()),
                             hand_joint_error_mm=float(joint_mm[:, self.hand_joints].mean()),
                             arm_joint_error_mm=float(joint_mm[:, self.arm_joints].mean()),
                             **face_joint_fields(s.motion, played, played_shown, avatar))
        return Viewed(frames, np.isin(labels, SKIN_PARTS), fields), frames


# ------------------------------------------------------------------------------------------------------------
# the run

class Study:
    """One run: points coded, viewed, their landmarks extracted (with progress bars) and judged
    (comparisons.judging.judge, .operating), appended to records.jsonl as they are measured; observed landmarks kept
    for the side by side."""

    def __init__(self, settings: CompareSettings, scenario: Scenario, renderer: AvatarRenderer,
                 records_path: Path, progress: bool):
        self.settings, self.scenario, self.progress = settings, scenario, progress
        self.judge = Judge(scenario, settings.landmark_step, shared.letter_recogniser(scenario))
        self.video = VideoPoints(scenario)
        self.params = ParamPoints(scenario, renderer)
        self.records_path = records_path
        self.records: list[dict] = []
        self.observed: dict[tuple, SignClip] = {}

    def series(self) -> list[Series]:
        return ([Series(s, "mpeg4") for s in (*Solution.natural_family(), Solution.SSV)]
                + [Series(solution_of(c), c) for c in self.settings.param_codecs])

    def lower_rates(self) -> list[float]:
        return sorted({f for f in self.settings.video.frame_rates if f < self.scenario.fps * (1 - 1e-3)}, reverse=True)

    def draws(self, frames: np.ndarray, fps: float, label: str) -> list[SignClip]:
        """The landmarks of frames (M, H, W, 3) uint8 shown at fps, extracted `extractions` times, each under its
        sub-pixel shift (pipeline.studies.shared.extract_draws)."""
        return shared.extract_draws(frames, fps, self.settings.extractions, label, self.progress)

    def uncoded(self) -> list[dict]:
        """The ceilings: each reference's measured frames re-extracted and judged (Judge.uncoded)."""
        s, measured = self.scenario, self.judge.measured
        source = self.draws(s.frames[measured], s.fps, "re-extract the reference")
        render = source if s.render is s.frames else self.draws(s.render[measured], s.fps,
                                                                 "re-extract the lossless render")
        return self.judge.uncoded(source, render)

    def measure(self, series: Series, q: int, fps: float, bar, **extra) -> list[dict]:
        """Code one point, extract the landmarks of what the viewer sees, measure it; its records (with the extra
        fields)."""
        s = self.scenario
        parameters = Solution(series.solution).mpeg4_parameters
        label = f"landmarks: {series.codec if parameters else series.solution} Q{q} {fps:g} fps"
        measured = self.judge.measured
        if parameters:
            viewed, _ = self.params.code(series.codec, q, fps)
            draws = self.draws(viewed.frames[measured], s.fps, label)
        else:
            viewed, sent, hold = self.video.code(series.solution, q, fps)
            # the distinct sent frames on screen at the measured frames, extracted once each
            distinct, on_screen = np.unique(hold[measured], return_inverse=True)
            draws = [select_frames(observed, on_screen, s.fps)
                     for observed in self.draws(sent[distinct], min(fps, s.fps), label)]
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
        jobs = [(series, q) for series in self.series() for q in qs[Solution(series.solution).mpeg4_parameters]]
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
                operating.mark_operating(series.points(self.records), found.kbps, criteria)
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
        """The series at its matched rate (comparisons.judging.operating.matched_record)."""
        return operating.matched_record(series, found, criteria, clip=self.scenario.name, fps_holds=fps_holds,
                                        kbps_se=self.rate_spread(series, found),
                                        margin=self.verdict_margin(series, criteria))

    def verdict_margin(self, series: Series, criteria: list[matching.Criterion]) -> float | None:
        """The series' verdict margin in standard errors (comparisons.judging.operating.verdict_margin)."""
        return operating.verdict_margin(series.points(self.records), criteria, self.ceiling(series.reference))

    def rate_spread(self, series: Series, found: matching.Match) -> float | None:
        """The jackknife standard error (kbit/s) of a reached match's rate over the landmark extractions
        (comparisons.judging.operating.rate_spread); None where not reached or extracted once."""
        return operating.rate_spread(series.points(self.records), self.ceiling(series.reference),
                                     lambda ceiling: self.criteria(series.reference, ceiling), found,
                                     self.settings.extractions)

    def ceiling(self, reference: str) -> dict:
        return operating.ceiling(self.records, reference)

    def criteria(self, reference: str, ceiling: dict | None = None) -> list[matching.Criterion]:
        """The threshold tied to the uncoded reference (comparisons.judging.operating.criteria_for); ceiling: the
        reference's ceiling record (None: the measured one; `rate_spread` passes its jackknife replicates)."""
        ceiling = self.ceiling(reference) if ceiling is None else ceiling
        landmarks = self.scenario.landmarks if reference == SOURCE else self.scenario.render_landmarks
        return criteria_for(ceiling, hand_share(landmarks), len(self.judge.spans or ()))


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
        scenario = shared.load_scenario(settings.signing, renderer_for, progress=progress, notify=notify)
    study = Study(settings, scenario, renderer_for(*scenario.size), records_path, progress)
    with clock.stage("uncoded references"):
        study.add(study.uncoded())
    with clock.stage("Q sweep: code, view, extract landmarks, measure"):
        study.sweep_q()
    with clock.stage("matching and frame-rate sweep"):
        matched = study.match()
    side_by_side = out_dir / "side_by_side.mp4"
    with clock.stage("side-by-side video"):
        poster = _write_side_by_side(_tiles(study, matched), side_by_side, scenario.fps)
    run_record = {"kind": "run", "backend": shared.backend_name(settings.backend), "versions": versions(),
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
    write_bytes(out_dir / "side_by_side_poster.png", poster)
    report = build_report(all_records, out_dir / "report.html", poster_png=poster)
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
        tiles.append(Received(shared.draw_landmarks(s.render, s.render_landmarks), "avatar: lossless render"))
    for solution in (*Solution.natural_family(), *Solution.avatars()):
        candidates = [m for m in matched if m["solution"] == solution]
        if not candidates:
            continue
        best = min(candidates, key=lambda m: (not m["reached"], m["kbps"]))
        q = best["q_shown"]
        if solution.mpeg4_parameters:
            _, frames = study.params.code(best["codec"], q, s.fps)
        else:
            viewed, _, _ = study.video.code(solution, q, s.fps)
            frames = viewed.frames
        observed = select_frames(study.observed[(solution, best["codec"], q, s.fps)], last_measured)
        codec = f" {best['codec']}" if solution.mpeg4_parameters else ""
        tiles.append(Received(shared.draw_landmarks(frames, observed),
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

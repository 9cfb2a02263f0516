"""The comparison (seed 000 §4.2.4): NSV, NSV2O, NSV3O, NSV3O+C on a natural clip; SSV, FBA and BBA on a
fingerspelled word performed by the avatar; one set of records, one report, one side-by-side video.

The common quality axis (DESIGN.md): SSV frames decoded from video, and FBA/BBA parameters decoded and
re-rendered by the terminal with the same kernels, are all compared with the same reference frames — the
avatar rendered losslessly from the original, full-precision motion. Parameters sent at a reduced frame
rate are interpolated back to the display rate by the terminal (slerp) before rendering.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable

import cv2
import numpy as np
from tqdm import tqdm

from comparisons import image_quality, metrics, param_codecs, video_objects
from comparisons.records import make_record, versions, write_records
from comparisons.report import build_report, operating_points
from media.avatar import load_avatar
from media.domain import SKIN_PARTS, check_q, check_size, solution_of
from media.errors import SigncastError
from media.fingerspelling import fingerspell
from media.motion import Motion, resample
from media.render import AvatarRenderer, RenderSettings
from media.tiling import tile_videos
from media import lexicon
from media.video_io import frame_indices_at_rate, resolve_video, write_video
from pipeline.studies import video as video_study
from pipeline.stages import StageClock

DISPLAY_FPS = 25.0
JOINT_TOLERANCE_MM = 5.0   # fallback operating point of a parameter codec when no SSV quality is there to match


@dataclass(frozen=True)
class CompareSettings:
    """One scenario and its sweeps. video: the video study's sweep (Q, operating Q, frame rates, today's codecs),
    used for the natural clip and for SSV; size: (width, height) of the rendered signer, pixels. The natural clip
    is coded at its own frame rate (video.frame_rates below it are swept by dropping frames) and scaled down to
    fit max_clip_size (width, height; None keeps its size); the avatar is rendered at DISPLAY_FPS."""
    language: str = "ase"
    word: str = "HELLO"
    clip: str = "carphone"
    video: video_study.VideoSweep = video_study.VideoSweep()
    param_codecs: tuple[str, ...] = ("fba-pred", "fba-dct", "bba-pred", "bba-dct", "bba-key")
    param_qs: tuple[int, ...] = (1, 2, 4, 8, 16, 31)
    size: tuple[int, int] = (352, 288)
    backend: str = "auto"
    max_clip_frames: int | None = None
    max_clip_size: tuple[int, int] | None = video_study.DEFAULT_MAX_SIZE

    @classmethod
    def demo(cls) -> "CompareSettings":
        """A small sweep that runs in a few minutes on two CPU cores."""
        return cls(video=video_study.VideoSweep(qs=(2, 12, 31), frame_rates=(25.0, 15.0, 10.0),
                                                other_codecs=("libx264",)),
                   param_qs=(1, 2, 4, 8, 31), max_clip_frames=75)


@dataclass
class Received:
    """What a viewer sees for one solution at its operating point: frames (T, H, W, 3) uint8 and a caption."""
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


def check(settings: CompareSettings, command: str = "compare") -> None:
    """Refuse bad settings, and work beyond the memory limit, before any work (one-line SigncastError)."""
    from media.render import check_backend
    from pipeline.checks import check_memory
    check_backend(settings.backend)
    check_settings(settings)
    n_frames = fingerspell(settings.language, settings.word, fps=DISPLAY_FPS).n_frames
    check_memory(n_frames, *settings.size, bytes_per_pixel(settings), command)


def bytes_per_pixel(settings: CompareSettings) -> int:
    """What the comparison holds per pixel and frame of the rendered signer: the reference and its labels (4),
    the skin mask (1), the SSV study's working copies and operating picture (about 9), and every parameter point's
    re-rendered frames (3 each), which it keeps until the end."""
    points = len(settings.param_codecs) * (len(settings.param_qs) + len(settings.video.frame_rates) - 1)
    return 4 + 1 + 9 + 3 * points


def check_settings(settings: CompareSettings) -> None:
    sweep = settings.video
    if sweep.operating_q not in sweep.qs:
        raise SigncastError(f"the operating Q {sweep.operating_q} must be among the swept Q {sweep.qs}")
    if DISPLAY_FPS not in sweep.frame_rates:
        raise SigncastError(f"the frame rates {sweep.frame_rates} must include {DISPLAY_FPS:g}")
    for q in sweep.qs:
        check_q(q, "video Q")
    for fps in sweep.frame_rates:
        if not 0 < fps <= DISPLAY_FPS:
            raise SigncastError(f"bad frame rate {fps:g}: choose rates in (0, {DISPLAY_FPS:g}]")
    for name in settings.param_codecs:
        param_codecs.get_codec(name)
    check_size(*settings.size, "the rendered signer")
    # Fail before the long video stages: the word must be spellable and the clip must exist.
    lexicon.split_word(lexicon.check_language(settings.language), settings.word)
    resolve_video(settings.clip)


def run(settings: CompareSettings, out_dir: str | Path, *, progress: bool = True,
                notify: Callable[[str], object] | None = None) -> CompareResult:
    """Run the whole comparison; write records.jsonl, report.html, side_by_side.mp4 and CSV tables to out_dir.

    records.jsonl grows as points are measured (an interrupted run keeps them) and is rewritten, complete, at
    the end. notify: called with each one-line note on the natural clip (frames read, downscaling, warnings)."""
    check_settings(settings)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    records_path = write_records(out_dir / "records.jsonl", [])
    clock = StageClock()
    records: list[dict] = []
    received: list[Received] = []

    with clock.stage("natural video: read and segment"):
        clip, notes = video_study.read_natural_clip(settings.clip, settings.max_clip_frames, settings.max_clip_size,
                                                    progress=progress)
        for line in notes:
            if notify:
                notify(line)
        clip_labels = video_study.segment_clip(clip.frames, progress=progress)
    video_settings = replace(settings.video, source_fps=clip.fps, half_resolution=True,
                             solutions=video_study.VideoSweep.solutions)
    operating_q = video_settings.operating_q
    with clock.stage("natural video: NSV, NSV2O, NSV3O, NSV3O+C"):
        coded: dict[str, video_objects.CodedSolution] = {}
        records += _points(video_study.code_clip(clip.frames, clip_labels, clip.path.stem, video_settings,
                                                 timing=video_study.Timing.of_clip(clip), records_path=records_path,
                                                 progress=progress, operating=coded))
        # the side-by-side plays at DISPLAY_FPS: the frames on screen at its ticks
        shown = frame_indices_at_rate(clip.times_s, clip.duration_s, DISPLAY_FPS)
        received += [replace(r, frames=r.frames[shown]) for r in _operating_pictures(
            coded, video_settings.solutions, operating_q, records)]

    avatar = load_avatar()
    render_settings = RenderSettings(width=settings.size[0], height=settings.size[1], look="shaded", backend=settings.backend)
    renderer = AvatarRenderer(avatar, render_settings)
    with clock.stage("synthetic signer: retarget and render the reference"):
        motion = fingerspell(settings.language, settings.word, fps=DISPLAY_FPS)
        reference, reference_labels = _render(renderer, motion, "render reference", progress)
        received.insert(0, Received(reference, f"reference: avatar, {settings.language} {settings.word} (lossless)"))
    scenario = f"{settings.language}-{settings.word}"
    with clock.stage("synthetic signer: SSV"):
        ssv_settings = replace(video_settings, solutions=("SSV",), half_resolution=False, source_fps=DISPLAY_FPS)
        ssv_coded: dict[str, video_objects.CodedSolution] = {}
        ssv_records = _points(video_study.code_clip(reference, reference_labels, scenario, ssv_settings,
                                                    records_path=records_path, progress=progress, operating=ssv_coded))
        records += ssv_records
        received += _operating_pictures(ssv_coded, ("SSV",), operating_q, ssv_records)

    skin = np.isin(reference_labels, SKIN_PARTS)
    with clock.stage("parameters: FBA and BBA, coded, decoded and re-rendered"):
        ssv_operating = next((r for r in ssv_records if r.get("operating_point")), None)
        target_skin_psnr = ssv_operating["skin_psnr"] if ssv_operating else None
        param_records, param_frames = _parameter_points(settings, motion, renderer, reference, skin, scenario,
                                                        target_skin_psnr, progress)
        write_records(records_path, param_records, append=True)
        records += param_records
        received += _best_parameter_tiles(param_records, param_frames)

    run_record = {"kind": "run", "backend": _backend_name(settings.backend), "versions": versions(),
                  "scenario": scenario, "clip": clip.path.stem, "clip_native_fps": clip.native_fps,
                  "clip_fps": clip.fps, "clip_duration_s": clip.duration_s, "clip_frames": len(clip.frames),
                  "clip_source_size": list(clip.source_size), "clip_size": list(clip.size), "display_fps": DISPLAY_FPS,
                  "signer_size": list(settings.size), "joint_tolerance_mm": JOINT_TOLERANCE_MM}
    side_by_side = out_dir / "side_by_side.mp4"
    with clock.stage("side-by-side video"):
        poster = _write_side_by_side(received, side_by_side)
    all_records = [run_record] + records + clock.records()
    write_records(out_dir / "records.jsonl", all_records)
    (out_dir / "side_by_side_poster.png").write_bytes(poster)
    report = build_report(all_records, out_dir / "report.html", poster_png=poster)
    write_summary_csv(all_records, out_dir / "summary.csv")
    return CompareResult(all_records, report, side_by_side, out_dir, operating_points(all_records))


def _points(records: list[dict]) -> list[dict]:
    """Measured points only (the video study's own run record is replaced by the comparison's)."""
    return [r for r in records if r.get("kind", "point") == "point"]


def _render(renderer: AvatarRenderer, motion: Motion, label: str, progress: bool) -> tuple[np.ndarray, np.ndarray]:
    s = renderer.settings
    frames = np.empty((motion.n_frames, s.height, s.width, 3), np.uint8)
    labels = np.empty((motion.n_frames, s.height, s.width), np.uint8)
    with tqdm(total=motion.n_frames, desc=label, unit="frame", disable=not progress, leave=False) as bar:
        for t, (rgb, label_frame) in enumerate(renderer.frames(motion)):
            frames[t], labels[t] = rgb, label_frame
            bar.update(1)
    return frames, labels


def _operating_pictures(coded: dict[str, video_objects.CodedSolution], solutions, q: int,
                        records: list[dict]) -> list[Received]:
    """Decoded pictures of each solution at its operating point (Q, the frames' own rate), as the video study
    coded them, captioned with the measured kbps."""
    shown = []
    for solution in solutions:
        point = next((r for r in records if r["solution"] == solution and r.get("operating_point")), None)
        if point is None or solution not in coded:
            continue
        shown.append(Received(coded[solution].picture, f"{solution} Q{q} {point['kbps']:.0f} kbps", solution))
    return shown


def _parameter_points(settings: CompareSettings, motion: Motion, renderer: AvatarRenderer, reference: np.ndarray,
                      skin: np.ndarray, scenario: str, target_skin_psnr: float | None,
                      progress: bool) -> tuple[list[dict], dict]:
    """Every (codec, Q) at 25 fps and every (codec, frame rate) at the codec's operating Q.

    A codec's operating Q is the cheapest whose re-rendered skin PSNR reaches target_skin_psnr (SSV's at its
    operating point: matched quality on the common axis), else the best Q measured; without a target, the
    cheapest Q whose mean joint position error stays within JOINT_TOLERANCE_MM.
    """
    skeleton = renderer.avatar.skeleton
    width, height = settings.size
    duration_s = motion.n_frames / DISPLAY_FPS
    records, frames_by_key = [], {}
    jobs = [(codec, q, DISPLAY_FPS) for codec in settings.param_codecs for q in settings.param_qs]
    bar = tqdm(total=len(jobs) + len(settings.param_codecs) * (len(settings.video.frame_rates) - 1), desc="parameters",
               unit="point", disable=not progress)

    def measure(codec_name: str, q: int, fps: float, sweep: str) -> dict:
        codec = param_codecs.get_codec(codec_name)
        sent = motion if fps == DISPLAY_FPS else resample(motion, fps)
        data = codec.encode(sent, q)
        decoded = codec.decode(data)
        shown = decoded if fps == DISPLAY_FPS else _to_display_rate(decoded, motion.n_frames)
        frames, _ = _render(renderer, shown, f"terminal {codec_name} Q{q}", False)
        quality = image_quality.quality_fields(reference, frames, skin)
        joint_mm = metrics.joint_position_error_mm(skeleton, motion, shown)
        record = make_record(solution_of(codec_name), scenario, codec_name, q, fps, width, height, 8 * len(data), duration_s,
                             sweep=sweep, full_resolution=True, frames=sent.n_frames,
                             joint_error_mm_mean=float(joint_mm.mean()), joint_error_mm_max=float(joint_mm.max()),
                             **quality)
        frames_by_key[(codec_name, q, fps)] = frames
        bar.update(1)
        return record

    for codec_name, q, fps in jobs:
        records.append(measure(codec_name, q, fps, "q"))
    for codec_name in settings.param_codecs:
        swept = [r for r in records if r["codec"] == codec_name]
        if target_skin_psnr is not None:
            within = [r for r in swept if r["skin_psnr"] >= target_skin_psnr]
        else:
            within = [r for r in swept if r["joint_error_mm_mean"] <= JOINT_TOLERANCE_MM]
        chosen = min(within, key=lambda r: r["kbps"]) if within else min(swept, key=lambda r: r["q"])
        chosen["operating_point"] = True
        chosen["operating_rule"] = ("matched skin PSNR of SSV" if target_skin_psnr is not None
                                    else f"joint error <= {JOINT_TOLERANCE_MM:g} mm") + ("" if within else " (not reached)")
        for fps in settings.video.frame_rates:
            if fps != DISPLAY_FPS:
                records.append(measure(codec_name, chosen["q"], fps, "fps"))
    bar.close()
    # Keep only the frames of the operating points (the side-by-side tiles).
    keep = {(r["codec"], r["q"], r["fps"]) for r in records if r.get("operating_point")}
    return records, {key: frames for key, frames in frames_by_key.items() if key in keep}


def _to_display_rate(decoded: Motion, n_frames: int) -> Motion:
    """The terminal's interpolation of a reduced-rate motion back to the display rate (slerp), same length."""
    shown = resample(decoded, DISPLAY_FPS)
    if shown.n_frames >= n_frames:
        return shown.frames(0, n_frames)
    pad = n_frames - shown.n_frames   # the last received pose holds until the clip ends
    return Motion(DISPLAY_FPS, shown.bone_names,
                  np.concatenate([shown.rotations, np.repeat(shown.rotations[-1:], pad, axis=0)]),
                  np.concatenate([shown.root_translation, np.repeat(shown.root_translation[-1:], pad, axis=0)]))


def _best_parameter_tiles(records: list[dict], frames_by_key: dict) -> list[Received]:
    """The cheapest FBA and the cheapest BBA codec at their operating points, as the terminal renders them."""
    tiles = []
    for solution in ("FBA", "BBA"):
        candidates = [r for r in records if r["solution"] == solution and r.get("operating_point")]
        if candidates:
            best = min(candidates, key=lambda r: r["kbps"])
            tiles.append(Received(frames_by_key[(best["codec"], best["q"], best["fps"])],
                                  f"{best['codec']} Q{best['q']} {best['kbps']:.1f} kbps (terminal)", solution))
    return tiles


def _write_side_by_side(received: list[Received], path: Path) -> bytes:
    """Tile the received videos (25 fps), encode with H.264, return a PNG poster frame."""
    tiled = tile_videos([(r.frames, r.caption) for r in received], tile_size=(352, 288), columns=4)
    write_video(path, tiled, DISPLAY_FPS, codec="libx264", options={"crf": 18, "preset": "veryfast"})
    ok, png = cv2.imencode(".png", cv2.cvtColor(tiled[len(tiled) // 2], cv2.COLOR_RGB2BGR))
    if not ok:
        raise SigncastError("could not encode the poster frame")
    return png.tobytes()


def _backend_name(backend: str) -> str:
    from kernels.backends import resolve, warp_device
    resolved = resolve(backend)
    return f"warp ({warp_device()})" if resolved == "warp" else resolved


def summary_rows(records: list[dict]) -> list[dict]:
    """One row per solution and codec at its operating point."""
    return [{"solution": r["solution"], "codec": r["codec"], "q": r.get("q"), "fps": r["fps"], "kbps": r["kbps"],
             "image_psnr": r.get("image_psnr"), "skin_psnr": r.get("skin_psnr"), "ssim": r.get("ssim"), "skin_ssim": r.get("skin_ssim"),
             "joint_error_mm": r.get("joint_error_mm_mean")} for r in operating_points(records)]


def write_summary_csv(records: list[dict], path: Path) -> Path:
    import csv
    rows = summary_rows(records)
    with path.open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]) if rows else ["solution"])
        writer.writeheader()
        writer.writerows(rows)
    return path


def format_summary(records: list[dict]) -> str:
    """The terminal's summary table."""
    lines = [f"{'solution':9} {'codec':9} {'Q':>3} {'fps':>4} {'kbps':>8} {'PSNR':>6} {'skin':>6} {'SSIM':>6}  joint mm"]
    for row in summary_rows(records):
        def fmt(value, spec):
            return format(value, spec) if isinstance(value, (int, float)) and np.isfinite(value) else "–"
        lines.append(f"{row['solution']:9} {row['codec']:9} {fmt(row['q'], '>3')} {row['fps']:>4.0f} {row['kbps']:>8.1f} "
                     f"{fmt(row['image_psnr'], '>6.2f')} {fmt(row['skin_psnr'], '>6.2f')} {fmt(row['ssim'], '>6.3f')}  "
                     f"{fmt(row['joint_error_mm'], '.2f')}")
    return "\n".join(lines)

"""The video study (seed 000 §4.2.4.6, Tables 4.6-4.16): code a clip as NSV, NSV2O, NSV3O, NSV3O+C (natural
video) or NSV, NSV2O, SSV and NSV3O+C (rendered signer, objects from its label buffer) and measure rate and quality.

A clip is coded at its own timing: its own frame rate (or a lower one the user asks for), and every rate is
measured over the clip's real duration. Sweeps, all with MPEG-4 Part 2 at fixed Q (I B B P B B P B B P B B):
- "q": Q in {2, 6, 12, 24, 31} at the clip's rate, full resolution (Tables 4.6, 4.9, 4.12, 4.16);
- "fps": the rates of 25, 20, 15, 10 fps below the clip's own, at Q = 12, by keeping at each tick the frame on
  screen then (same duration) (Tables 4.7, 4.10, 4.13), with the clip-rate point of the "q" sweep, and a
  linear fit;
- "resolution": half width and height at Q = 12, the clip's rate (Tables 4.8, 4.11, 4.14);
- "codec": H.264 (libx264) and AV1 (SVT-AV1) at matched quality (each object's PSNR inside its shape at least
  that of MPEG-4 at Q = 12); with libx264 also NSV-ROI (comparisons/video/roi.py: one stream, the face and
  hands at a lower quantiser than the rest, at the cheapest CRF whose skin PSNR reaches NSV's at Q = 12).
NSV3O+C's clothes are coded at Q = 31 (Table 4.15). Outputs go to the study's folder: records.jsonl (each
record appended as it is measured), CSV tables, PNG plots and mask overlays.

`run(VideoSettings, out)` is the whole study of `signcast video`: a natural clip (read, its landmarks extracted,
segmented by landmarks or by colour, with the share of frames whose landmark-detected face and hands the masks
cover) or the synthetic signer (rendered shaded and flat, with both segmentations' IoU against the label buffer),
coded by `code_clip` over a `VideoSweep` (which `compare` reuses). A user's clip is read with a progress bar,
scaled down to fit DEFAULT_MAX_SIZE unless asked otherwise, and refused before the long work when it holds fewer
than 2 frames or no face (`media.faces`).
"""
from __future__ import annotations

import csv
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Callable

import cv2
import numpy as np
from tqdm import tqdm

from media.domain import Solution, kbps
from comparisons.video import quality as image_quality
from comparisons.reports import comparison as report
from comparisons.video import codecs as video_codecs
from comparisons.video import objects as video_objects
from comparisons.video import roi as video_roi
from comparisons.video.shape import MAX_SHAPE_ERROR
from comparisons.reports.records import as_records, make_record, versions
from pipeline.outputs import write_records
from media import segmentation
from media.errors import SigncastError
from media.video_io import frame_indices_at_rate
from pipeline.checks import check_memory
from pipeline.studies.shared import (DEFAULT_MAX_SIZE, DEFAULT_SEGMENTATION, SEGMENTATIONS, Timing, VideoSweep,
                                     check_segmentation, extract_clip_landmarks, read_natural_clip, segment_clip)


@dataclass
class _Config:
    """One frame set: which frames, at which size and rate."""

    key: str
    sweep: str
    frames: np.ndarray
    labels: np.ndarray
    fps: float
    full_resolution: bool


def _configs(frames: np.ndarray, labels: np.ndarray, settings: VideoSweep, timing: Timing) -> list[_Config]:
    """The "q" sweep's frame set first, then those of the frame-rate and resolution sweeps."""
    source = settings.source_fps
    configs = [_Config(f"full@{source:g}", "q", frames, labels, source, True)]
    for fps in settings.frame_rates:
        if fps > source * (1 - 1e-3):      # only rates below the frames' own: frames can be dropped, not made
            continue
        kept = frame_indices_at_rate(timing.times_s, timing.duration_s, fps)
        configs.append(_Config(f"full@{fps:g}", "fps", frames[kept], labels[kept], fps, True))
    if settings.half_resolution:
        small, small_labels = video_codecs.half_resolution(frames, labels)
        configs.append(_Config(f"half@{source:g}", "resolution", small, small_labels, source, False))
    return configs


def _record(coded: video_objects.CodedSolution, config: _Config, clip: str, codec: str, q: int, timing: Timing,
            settings: VideoSweep, software: dict, sweep: str, clothes_bits: int | None = None) -> dict:
    duration_s = timing.duration_s
    masks = segmentation.object_masks(config.labels)
    quality = image_quality.quality_fields(config.frames, coded.picture, masks["skin"],
                                           None if coded.solution == "NSV" else coded.region)
    if coded.solution != "NSV":
        # skin SSIM with the unsent pixels taken from the reference: the 7x7 windows along the skin border then
        # measure the coded skin, not the missing background (skin PSNR is the same either way)
        filled = np.where(coded.region[..., None], coded.picture, config.frames)
        skin_only = image_quality.quality_fields(config.frames, filled, masks["skin"])
        quality["skin_ssim"] = skin_only["skin_ssim"]
    areas = segmentation.area_percent(config.labels)
    objects = [{"name": o.name, "q": o.q, "box": list(o.box), "texture_bytes": o.texture_bytes,
                "shape_bytes": o.shape_bytes, "area_percent": o.area_percent} for o in coded.objects]
    fields = dict(
        sweep=sweep, full_resolution=config.full_resolution,
        operating_point=bool(q == settings.operating_q and sweep == "q"),
        native_fps=timing.native_fps,
        texture_bits=coded.bits - coded.shape_bits, shape_bits=coded.shape_bits,
        shape_kbps=kbps(coded.shape_bits, duration_s), shape_error_percent=coded.shape_error,
        signer_area_percent=areas["signer"], skin_area_percent=areas["skin"], clothes_area_percent=areas["clothes"],
        objects=objects, frames=len(config.frames), backend="cpu", versions=software, **quality)
    if clothes_bits is not None:
        fields["clothes_overload_kbps"] = kbps(clothes_bits, duration_s)
    height, width = config.frames.shape[1:3]
    return make_record(coded.solution, clip, codec, q, config.fps, width, height, coded.bits, duration_s, **fields)


COVERED_SHARE = 0.9     # a landmark-detected part is covered when this share of its landmarks is on its own label


def coverage_line(method: str, coverage: dict) -> str:
    """One printed line: the share of frames whose landmark-detected face and hands are covered by their masks."""
    parts = ", ".join(f"{part.replace('_', ' ')} {coverage[f'{part}_covered_percent']:.0f}% of "
                      f"{coverage[f'{part}_detected_frames']}" for part in ("head", "left_hand", "right_hand")
                      if coverage[f"{part}_detected_frames"])
    return (f"{method} segmentation covers every landmark-detected face and hand in "
            f"{coverage['all_covered_percent']:.1f}% of {coverage['frames_with_parts']} frames"
            f"{f' ({parts})' if parts else ''}; covered: >= {COVERED_SHARE:.0%} of a part's landmarks on its label")


def code_clip(frames: np.ndarray, labels: np.ndarray, clip: str, settings: VideoSweep = VideoSweep(),
                    *, timing: Timing | None = None, records_path: str | Path | None = None,
                    progress: bool = True,
                    operating: dict[str, video_objects.CodedSolution] | None = None,
                    shape_error: float = 0.0) -> list[dict]:
    """Every measured point of the study as records. frames (T, H, W, 3) uint8 RGB at settings.source_fps;
    labels (T, H, W) uint8 part labels (0 background, 1 body/clothes, 2 head, 3 left hand, 4 right hand).

    timing: when the frames are shown (default: every 1/source_fps s); kbps are bits over its duration_s.
    records_path: a records.jsonl that each record is appended to as soon as it is measured.
    operating: filled with each solution's coded pictures at the operating Q (the frames' own rate, full size),
    for callers that show them (compare's side by side) without coding them again.
    shape_error: percent of each object's pixels its coded shape may get wrong (0: lossless shape).
    """
    frames, labels = np.asarray(frames), np.asarray(labels)
    if labels.shape != frames.shape[:3]:
        raise SigncastError(f"labels {labels.shape} do not match frames {frames.shape[:3]}")
    if settings.operating_q not in settings.qs:
        raise SigncastError(f"the operating Q {settings.operating_q} must be among the swept Q {settings.qs}")
    timing = timing or Timing.regular(len(frames), settings.source_fps)
    if len(timing.times_s) != len(frames):
        raise SigncastError(f"{len(timing.times_s)} presentation times for {len(frames)} frames")
    software = versions()
    shapes = video_objects.ShapeCache(shape_error=shape_error)
    configs = _configs(frames, labels, settings, timing)
    jobs = [(c, s, q) for c in configs for s in settings.solutions
            for q in (settings.qs if c.sweep == "q" else (settings.operating_q,))]
    jobs += [(configs[0], s, codec) for s in settings.solutions for codec in settings.other_codecs]
    records = []
    operating = {} if operating is None else operating
    for config, solution, q_or_codec in tqdm(jobs, desc=f"video {clip}", unit="point", disable=not progress):
        if isinstance(q_or_codec, str):
            codec = q_or_codec
            coded = video_objects.code_solution_matched(operating[solution], config.frames, config.labels, config.fps,
                                                        codec, shapes, config.key)
            q, sweep = max(o.q for o in coded.objects if o.name != "clothes"), "codec"
        else:
            codec, q, sweep = "mpeg4", q_or_codec, config.sweep
            coded = video_objects.code_solution(solution, config.frames, config.labels, config.fps, codec, q, shapes,
                                                config.key)
            if config.sweep == "q" and q == settings.operating_q:
                operating[solution] = coded
        clothes = sum(o.bits for o in coded.objects if o.name == "clothes") if solution == Solution.NSV3O_C else None
        record = _record(coded, config, clip, codec, q, timing, settings, software, sweep, clothes)
        if sweep == "codec":
            record["object_q"] = {o.name: o.q for o in coded.objects}
        records.append(record)
        if records_path is not None:
            write_records(records_path, [record], append=True)
    if Solution.NSV in operating and any(c in video_roi.ROI_CODECS for c in settings.other_codecs):
        config = configs[0]
        coded, crf = code_roi_matched(operating[Solution.NSV], config.frames, config.labels, config.fps)
        record = _record(coded, config, clip, "libx264", crf, timing, settings, software, "codec")
        record["object_q"] = {"frame": crf}
        record["rate_control"] = "crf"          # q is x264's CRF (addroi needs CRF mode), not a constant QP
        records.append(record)
        if records_path is not None:
            write_records(records_path, [record], append=True)
    run = {"kind": "run", "clip": clip, "frames": len(frames), "source_fps": settings.source_fps,
           "native_fps": timing.native_fps, "duration_s": timing.duration_s, "backend": "cpu", "versions": software,
           "shape_streams": _shape_summary(shapes, timing.duration_s)}
    records.append(run)
    if records_path is not None:
        write_records(records_path, [run], append=True)
    return records


def code_roi_matched(reference: video_objects.CodedSolution, frames: np.ndarray, labels: np.ndarray,
                     fps: float) -> tuple[video_objects.CodedSolution, int]:
    """NSV-ROI (comparisons/video/roi.py): one libx264 stream with the face and hands at a lower quantiser than
    the rest, at the cheapest CRF whose skin PSNR reaches the reference's (the NSV operating point's): the
    skin, not the whole frame, is what the region coding spends its bits on. Returns the solution and its CRF."""
    skin = segmentation.object_masks(labels)["skin"]
    target = image_quality.psnr(frames, reference.picture, skin)

    def encode_at(crf: int):
        coded = video_objects.code_roi(frames, labels, fps, crf)
        return coded, image_quality.psnr(frames, coded.picture, skin)

    crf, coded, _ = video_codecs.match_quality(encode_at, video_roi.CRF_RANGE, target)
    return coded, crf


def _shape_summary(shapes: video_objects.ShapeCache, duration_s: float) -> list[dict]:
    rows = []
    for (name, config_key), (n_bytes, masks, wrong, pixels) in shapes.streams.items():
        rows.append({"object": name, "config": config_key, "frames": len(masks), "bytes": n_bytes,
                     "bits_per_frame": 8.0 * n_bytes / len(masks), "kbps": kbps(8.0 * n_bytes, duration_s),
                     "area_percent": 100.0 * float(masks.mean()),
                     "shape_error_percent": 100.0 * wrong / max(1, pixels)})
    return rows


# ------------------------------------------------------------------------------------------------------------
# outputs

def _write_csv(path: Path, header: list[str], rows: list[list]) -> None:
    with path.open("w", newline="", encoding="utf-8") as handle:
        writer = csv.writer(handle)
        writer.writerow(header)
        for row in rows:
            writer.writerow([f"{v:.2f}" if isinstance(v, float) else v for v in row])


def _area(record: dict) -> float | None:
    return {Solution.NSV: None, Solution.NSV2O: record["signer_area_percent"],
            Solution.NSV3O: record["skin_area_percent"], Solution.NSV3O_C: record["skin_area_percent"],
            Solution.NSV_ROI: record["skin_area_percent"], Solution.SSV: record["skin_area_percent"]}.get(record["solution"])


def write_tables(records: list[dict], out_dir: Path) -> list[Path]:
    """CSV tables shaped like Tables 4.6-4.16, the linear fits and the shape-coding summary."""
    points = [r for r in records if r.get("kind") == "point"]
    run = next((r for r in records if r.get("kind") == "run"), {})
    written = []

    def columns(r: dict) -> list:
        area = _area(r)
        return [r["solution"], r["codec"], r["clip"], f"{r['width']}x{r['height']}", "" if area is None else f"{area:.1f}%",
                r["fps"], r["q"], r["kbps"], r["kbps"] - r["shape_kbps"], r["shape_kbps"], r["image_psnr"],
                r.get("object_psnr", r["image_psnr"]), r.get("skin_psnr"), r.get("skin_ssim")]
    header = ["solution", "codec", "clip", "resolution", "object area", "fps", "Q", "kbps", "texture kbps", "shape kbps",
              "frame PSNR dB", "sent-region PSNR dB", "skin PSNR dB", "skin SSIM"]
    tables = {
        "table_rate_vs_q.csv": [r for r in points if r["sweep"] == "q"],
        "table_rate_vs_fps.csv": [r for r in points if r["sweep"] == "fps" or (r["sweep"] == "q" and r["operating_point"])],
        "table_rate_vs_resolution.csv": [r for r in points if r["sweep"] == "resolution"
                                         or (r["sweep"] == "q" and r["operating_point"])],
        "table_codecs.csv": [r for r in points if r["sweep"] == "codec" or (r["sweep"] == "q" and r["operating_point"])],
    }
    for name, rows in tables.items():
        rows = sorted(rows, key=lambda r: (report._order(r["solution"]), r["codec"], r["width"], -r["fps"], r["q"]))
        path = out_dir / name
        if name == "table_codecs.csv":
            _write_csv(path, header + ["object Q"], [columns(r) + [
                " ".join(f"{k}={v}" for k, v in r.get("object_q", {o["name"]: o["q"] for o in r["objects"]}).items())]
                for r in rows])
        else:
            _write_csv(path, header, [columns(r) for r in rows])
        written.append(path)
    fits = report.linear_fits(points)
    path = out_dir / "fits_rate_vs_fps.csv"
    _write_csv(path, ["series", "Q", "slope kbps per fps", "intercept kbps", "R2"],
               [[f["series"], f["q"], f["slope_kbps_per_fps"], f["intercept_kbps"], f["r2"]] for f in fits])
    written.append(path)
    clothes = [r for r in points if r["solution"] == Solution.NSV3O_C and r["codec"] == "mpeg4" and r["q"] == 12]
    path = out_dir / "table_clothes_overload.csv"
    _write_csv(path, ["clip", "resolution", "clothes area", "fps", "skin Q", "clothes Q", "overload kbps"],
               [[r["clip"], f"{r['width']}x{r['height']}", f"{r['clothes_area_percent']:.1f}%", r["fps"], r["q"],
                 video_objects.CLOTHES_Q, r["clothes_overload_kbps"]] for r in clothes])
    written.append(path)
    path = out_dir / "table_shape_coding.csv"
    _write_csv(path, ["object", "frames", "fps set", "area", "bytes", "bits per frame", "kbps"],
               [[s["object"], s["frames"], s["config"], f"{s['area_percent']:.1f}%", s["bytes"], s["bits_per_frame"],
                 s["kbps"]] for s in run.get("shape_streams", [])])
    written.append(path)
    return written


def write_plots(records: list[dict], out_dir: Path) -> list[Path]:
    """PNG plots: kbps against Q, against frame rate with fits, and quality against rate."""
    import warnings

    import matplotlib.pyplot as plt
    mpeg4 = [r for r in records if r.get("codec") == "mpeg4"]
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="No artists with labels found")  # a sweep of one point
        figures = {"kbps_vs_q.png": report.chart_kbps_vs_q(mpeg4),
                   "kbps_vs_fps.png": report.chart_kbps_vs_fps(mpeg4),
                   "psnr_vs_kbps.png": report.chart_rate_quality(as_records(records), "psnr"),
                   "ssim_vs_kbps.png": report.chart_rate_quality(as_records(records), "ssim")}
    written = []
    for name, figure in figures.items():
        path = out_dir / name
        figure.savefig(path, dpi=110, bbox_inches="tight")
        plt.close(figure)
        written.append(path)
    return written


def write_overlays(frames: np.ndarray, labels: np.ndarray, out_dir: Path, name: str = "masks", count: int = 4) -> Path:
    """One PNG strip of `count` frames spread over the clip with their part labels tinted."""
    picks = np.linspace(0, len(frames) - 1, count).round().astype(int)
    strip = np.hstack([segmentation.overlay(frames[t], labels[t]) for t in picks])
    path = out_dir / f"{name}_overlay.png"
    cv2.imwrite(str(path), strip[:, :, ::-1])
    return path


def main_table(records: list[dict]) -> str:
    """The terminal table: kbps (and skin PSNR) per solution at each Q, then the other codecs at matched quality."""
    points = [r for r in records if r.get("kind") == "point"]
    q_sweep = [r for r in points if r["sweep"] == "q"]
    qs = sorted({r["q"] for r in q_sweep})
    solutions = sorted({r["solution"] for r in q_sweep}, key=report._order)
    rate = f"{q_sweep[0]['fps']:.4g} fps" if q_sweep else "the clip's rate"
    lines = [(f"kbps at {rate}, full resolution, MPEG-4 Part 2 (at Q=12 in brackets: skin PSNR dB; shape kbps and "
              "shape error, wrong shape pixels over the objects' pixels)"),
             f"{'solution':<10}" + "".join(f"{'Q=' + str(q):>9}" for q in qs) + f"{'area':>8}"]
    for solution in solutions:
        row = {r["q"]: r for r in q_sweep if r["solution"] == solution}
        area = _area(next(iter(row.values())))
        cells = "".join(f"{row[q]['kbps']:9.1f}" if q in row else f"{'-':>9}" for q in qs)
        op = next((r for r in row.values() if r["operating_point"]), None)
        extra = f"  [{op['skin_psnr']:.2f}" if op and op.get("skin_psnr") is not None else ""
        if extra and op.get("shape_bits"):
            extra += f"; shape {op['shape_kbps']:.1f} kbps, error {op.get('shape_error_percent', 0.0):.2f}%"
        extra += "]" if extra else ""
        lines.append(f"{solution:<10}{cells}{'' if area is None else f'{area:7.1f}%':>8}{extra}")
    codec_rows = [r for r in points if r["sweep"] == "codec" or (r["sweep"] == "q" and r["operating_point"])]
    if codec_rows:
        lines.append("matched quality (each object's PSNR >= MPEG-4 Q=12): kbps / skin PSNR dB")
        for r in sorted(codec_rows, key=lambda r: (report._order(r["solution"]), r["codec"])):
            lines.append(f"  {r['solution']:<9}{r['codec']:<11}{r['kbps']:8.1f}  {r.get('skin_psnr') or float('nan'):6.2f}")
    return "\n".join(lines)


def write_outputs(records: list[dict], frames: np.ndarray, labels: np.ndarray, out_dir: str | Path) -> list[Path]:
    """records.jsonl, the CSV tables, the plots and the mask overlay in out_dir."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    written = [write_records(out_dir / "records.jsonl", records)]
    written += write_tables(records, out_dir)
    written += write_plots(records, out_dir)
    written.append(write_overlays(frames, labels, out_dir))
    return written


# ------------------------------------------------------------------------------------------------------------
# the study of `signcast video`

# --ssv holds per pixel and frame: the shaded and the flat render with their labels (8 bytes), three
# segmentations and a person mask (4), and the study's decoded pictures and frame-rate / half-size copies (about 6)
SSV_BYTES_PER_PIXEL = 18


@dataclass(frozen=True)
class VideoSettings:
    """One `signcast video` run: a natural clip (video: a file or 'carphone') or the synthetic signer (ssv:
    (language, word)); frames: only the first N; fps: the rate to code at (None: the clip's own, 25 for ssv);
    max_size: (width, height) a natural clip is scaled down to fit (None keeps its size); size: (width, height) of
    the rendered signer; sweep: Q, codecs (its source_fps and solutions are set from the source); segmentation:
    how a natural clip is cut into parts, "landmarks" or "colour" (the rendered signer is coded with its label
    buffer and both methods are measured against it); shape_error: percent of each object's pixels its coded
    shape may get wrong (0: lossless shape; comparisons.video.shape.encode_shape)."""

    video: str | None = None
    ssv: tuple[str, str] | None = None
    frames: int | None = None
    fps: float | None = None
    max_size: tuple[int, int] | None = DEFAULT_MAX_SIZE
    size: tuple[int, int] = (400, 340)
    sweep: VideoSweep = VideoSweep()
    segmentation: str = DEFAULT_SEGMENTATION
    shape_error: float = 0.0


@dataclass
class VideoResult:
    records: list[dict]
    written: list[Path]
    lines: list[str]          # the segmentation lines (IoU, landmark coverage), printed after the main table


def check(settings: VideoSettings) -> None:
    """Refuse bad settings before any work (one-line SigncastError naming the command-line option)."""
    from media.domain import check_fps, check_q, check_size
    if (settings.video is None) == (settings.ssv is None):
        raise SigncastError("give one source: a natural video or the synthetic signer (ssv)")
    if settings.fps is not None:
        check_fps(settings.fps)
    if settings.frames is not None and settings.frames < 2:
        raise SigncastError(f"bad --frames {settings.frames}: at least 2")
    for q in settings.sweep.qs:
        check_q(q, "--video-q")
    if settings.sweep.operating_q not in settings.sweep.qs:
        raise SigncastError(f"--video-q must include {settings.sweep.operating_q}, the operating point of the "
                            f"frame-rate, resolution and codec sweeps (e.g. --video-q "
                            f"{','.join(map(str, sorted({*settings.sweep.qs, settings.sweep.operating_q})))})")
    if settings.ssv is not None:
        check_size(*settings.size)
    check_segmentation(settings.segmentation)
    if not 0.0 <= settings.shape_error <= MAX_SHAPE_ERROR:
        raise SigncastError(f"bad --shape-error {settings.shape_error:g}: 0 (lossless) to {MAX_SHAPE_ERROR:g} "
                            "percent of the object's pixels")


def run(settings: VideoSettings, out: str | Path, *, progress: bool = True,
        notify: Callable[[str], object] | None = None) -> VideoResult:
    """Load the source, code it over the sweep, write records.jsonl (grown as points are measured, so an
    interrupted run keeps them), CSV tables, PNG plots and mask overlays to out. notify: called with each one-line
    note on a natural clip (frames read, downscaling, warnings)."""
    check(settings)
    out = Path(out)
    if settings.video is not None:
        frames, labels, clip, extra = _natural(settings, progress, notify)
        solutions = VideoSweep.solutions
    else:
        frames, labels, clip, extra = _synthetic(settings, progress)
        solutions = (Solution.NSV, Solution.NSV2O, Solution.SSV, Solution.NSV3O_C)   # SSV: NSV3O of the render
    sweep = replace(settings.sweep, source_fps=extra["fps"], solutions=solutions)
    records_path = write_records(out / "records.jsonl", extra["records"])
    records = code_clip(frames, labels, clip, sweep, timing=extra.get("timing"), records_path=records_path,
                        progress=progress, shape_error=settings.shape_error)
    records = extra["records"] + records
    written = write_outputs(records, frames, labels, out)
    for name, (overlay_frames, overlay_labels) in extra.get("overlays", {}).items():
        written.append(write_overlays(overlay_frames, overlay_labels, out, name))
    return VideoResult(records, written, extra.get("lines", []))


def _natural(settings: VideoSettings, progress: bool, notify: Callable[[str], object] | None):
    clip, notes = read_natural_clip(settings.video, settings.frames, settings.max_size, settings.fps,
                                    progress=progress)
    for line in notes:
        if notify:
            notify(line)
    from media.segmentation_landmarks import landmark_coverage

    landmarks = extract_clip_landmarks(clip.frames, clip.fps, progress=progress)
    labels = segment_clip(clip.frames, progress=progress, method=settings.segmentation, landmarks=landmarks)
    areas = segmentation.area_percent(labels)
    coverage = landmark_coverage(labels, landmarks, COVERED_SHARE)
    record = {"kind": "segmentation", "clip": clip.path.stem, "method": SEGMENTATIONS[settings.segmentation],
              "segmentation": settings.segmentation, "native_fps": clip.native_fps, "coded_fps": clip.fps,
              "duration_s": clip.duration_s, "source_size": list(clip.source_size), "coded_size": list(clip.size),
              "announced_frames": clip.announced_frames, **{f"{k}_area_percent": v for k, v in areas.items()},
              "covered_share": COVERED_SHARE, **{f"landmarks_{k}": v for k, v in coverage.items()}}
    return clip.frames, labels, clip.path.stem, {"records": [record], "fps": clip.fps, "timing": Timing.of_clip(clip),
                                                 "lines": [coverage_line(settings.segmentation, coverage)]}


def _synthetic(settings: VideoSettings, progress: bool):
    from kernels.raster import FLAT_PALETTE
    from media.avatar import load_avatar
    from media.fingerspelling import fingerspell
    from media.motion import Motion
    from media.render import RenderSettings, render_motion

    language, word = settings.ssv
    width, height = settings.size
    motion = fingerspell(language, word, fps=settings.fps or 25.0)
    if settings.frames is not None:
        count = min(settings.frames, motion.n_frames)
        motion = Motion(motion.fps, motion.bone_names, motion.rotations[:count], motion.root_translation[:count])
    check_memory(motion.n_frames, width, height, SSV_BYTES_PER_PIXEL, "video --ssv")
    avatar = load_avatar()
    renders = {}
    for look in ("shaded", "flat"):
        with tqdm(total=motion.n_frames, desc=f"render {look}", unit="frame", disable=not progress) as bar:
            renders[look] = render_motion(avatar, motion, RenderSettings(width=width, height=height, look=look),
                                          progress=bar.update)
    frames, truth = renders["shaded"]
    palette = {label: tuple(int(c) for c in colour) for label, colour in enumerate(FLAT_PALETTE)}
    by_flat_colour = segmentation.labels_from_flat(renders["flat"][0], palette)
    by_colour = segment_clip(frames, progress=progress, method="colour")
    landmarks = extract_clip_landmarks(frames, motion.fps, progress=progress)
    by_landmarks = segment_clip(frames, progress=progress, method="landmarks", landmarks=landmarks)
    clip = f"ssv-{language}-{word}"
    records = []
    lines = ["segmentation IoU against the renderer's label buffer:"]
    for method, segmentation_name, labels in (("flat-colour rendering", None, by_flat_colour),
                                              ("colour segmentation of the shaded rendering", "colour", by_colour),
                                              ("landmark segmentation of the shaded rendering", "landmarks",
                                               by_landmarks)):
        iou = segmentation.iou_per_label(labels, truth)
        record = {"kind": "segmentation", "clip": clip, "method": method, **{f"iou_{k}": v for k, v in iou.items()}}
        if segmentation_name:
            record["segmentation"] = segmentation_name
        records.append(record)
        lines.append(f"  {method}: " + ", ".join(f"{k} {v:.3f}" for k, v in iou.items()))
    overlays = {"colour_segmentation": (frames, by_colour), "landmark_segmentation": (frames, by_landmarks),
                "flat_colour": (frames, by_flat_colour)}
    return frames, truth, clip, {"records": records, "lines": lines, "overlays": overlays, "fps": motion.fps}

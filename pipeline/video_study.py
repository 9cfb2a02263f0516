"""The video study (seed 000 §4.2.4.6, Tables 4.6-4.16): code a clip as NSV, NSV2O, NSV3O, NSV3O+C (natural
video) or NSV and SSV (rendered signer) and measure rate and quality.

Sweeps, all with MPEG-4 Part 2 at fixed Q (I B B P B B P B B P B B):
- "q": Q in {2, 6, 12, 24, 31} at 25 fps, full resolution (Tables 4.6, 4.9, 4.12, 4.16);
- "fps": 20, 15, 10 fps at Q = 12 by dropping frames at constant duration (Tables 4.7, 4.10, 4.13), with the
  25 fps point of the "q" sweep, and a linear fit;
- "resolution": half width and height at Q = 12, 25 fps (Tables 4.8, 4.11, 4.14);
- "codec": H.264 (libx264) and AV1 (SVT-AV1) at matched quality (each object's PSNR inside its shape at least
  that of MPEG-4 at Q = 12).
NSV3O+C's clothes are coded at Q = 31 (Table 4.15). Outputs go to the study's folder: records.jsonl, CSV
tables, PNG plots and mask overlays.
"""
from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from tqdm import tqdm

from comparisons import image_quality, report, video_codecs, video_objects
from comparisons.records import make_record, versions, write_records
from media import segmentation
from media.errors import SigncastError


@dataclass(frozen=True)
class VideoStudySettings:
    qs: tuple[int, ...] = (2, 6, 12, 24, 31)
    operating_q: int = 12
    frame_rates: tuple[float, ...] = (25.0, 20.0, 15.0, 10.0)
    source_fps: float = 25.0
    solutions: tuple[str, ...] = ("NSV", "NSV2O", "NSV3O", "NSV3O+C")
    other_codecs: tuple[str, ...] = ("libx264", "libsvtav1")
    half_resolution: bool = True


@dataclass
class _Config:
    """One frame set: which frames, at which size and rate."""

    key: str
    sweep: str
    frames: np.ndarray
    labels: np.ndarray
    fps: float
    full_resolution: bool


def _configs(frames: np.ndarray, labels: np.ndarray, settings: VideoStudySettings) -> list[_Config]:
    configs = [_Config("full@25", "q", frames, labels, settings.source_fps, True)]
    for fps in settings.frame_rates:
        if abs(fps - settings.source_fps) < 1e-9:
            continue
        kept = video_codecs.kept_frame_indices(len(frames), settings.source_fps, fps)
        configs.append(_Config(f"full@{fps:g}", "fps", frames[kept], labels[kept], fps, True))
    if settings.half_resolution:
        small, small_labels = video_codecs.half_resolution(frames, labels)
        configs.append(_Config("half@25", "resolution", small, small_labels, settings.source_fps, False))
    return configs


def _record(coded: video_objects.CodedSolution, config: _Config, clip: str, codec: str, q: int, duration_s: float,
            settings: VideoStudySettings, software: dict, sweep: str, clothes_bits: int | None = None) -> dict:
    masks = segmentation.object_masks(config.labels)
    quality = image_quality.quality_fields(config.frames, coded.picture, masks["skin"],
                                           None if coded.solution == "NSV" else coded.region)
    if coded.solution != "NSV":
        # skin SSIM with the unsent pixels taken from the reference: the 7x7 windows along the skin border then
        # measure the coded skin, not the missing background (skin PSNR is the same either way)
        filled = np.where(coded.region[..., None], coded.picture, config.frames)
        skin_only = image_quality.quality_fields(config.frames, filled, masks["skin"])
        quality["ssim_skin"] = skin_only["ssim_skin"]
    areas = segmentation.area_percent(config.labels)
    objects = [{"name": o.name, "q": o.q, "box": list(o.box), "texture_bytes": o.texture_bytes,
                "shape_bytes": o.shape_bytes, "area_percent": o.area_percent} for o in coded.objects]
    fields = dict(
        sweep=sweep, full_resolution=config.full_resolution,
        operating_point=bool(q == settings.operating_q and config.key == "full@25"),
        texture_bits=coded.bits - coded.shape_bits, shape_bits=coded.shape_bits,
        shape_kbps=coded.shape_bits / duration_s / 1000.0,
        signer_area_percent=areas["signer"], skin_area_percent=areas["skin"], clothes_area_percent=areas["clothes"],
        objects=objects, frames=len(config.frames), backend="cpu", versions=software, **quality)
    if clothes_bits is not None:
        fields["clothes_overload_kbps"] = clothes_bits / duration_s / 1000.0
    height, width = config.frames.shape[1:3]
    return make_record(coded.solution, clip, codec, q, config.fps, width, height, coded.bits, duration_s, **fields)


def load_natural_clip(name_or_path: str, max_frames: int | None = None):
    """A natural signer clip and its colour segmentation: (frames (T, H, W, 3) uint8 cropped to even size,
    labels (T, H, W) uint8 part labels, path, native fps)."""
    from media.video_io import crop_even, read_video, resolve_video

    path = resolve_video(name_or_path)
    frames, native_fps = read_video(path, max_frames=max_frames)
    frames = crop_even(frames)
    return frames, segmentation.segment_parts(frames), path, native_fps


def run_video_study(frames: np.ndarray, labels: np.ndarray, clip: str, settings: VideoStudySettings = VideoStudySettings(),
                    *, progress: bool = True) -> list[dict]:
    """Every measured point of the study as records. frames (T, H, W, 3) uint8 RGB at settings.source_fps;
    labels (T, H, W) uint8 part labels (0 background, 1 body/clothes, 2 head, 3 left hand, 4 right hand)."""
    frames, labels = np.asarray(frames), np.asarray(labels)
    if labels.shape != frames.shape[:3]:
        raise SigncastError(f"labels {labels.shape} do not match frames {frames.shape[:3]}")
    if settings.operating_q not in settings.qs:
        raise SigncastError(f"the operating Q {settings.operating_q} must be among the swept Q {settings.qs}")
    duration_s = len(frames) / settings.source_fps
    software = versions()
    shapes = video_objects.ShapeCache()
    configs = _configs(frames, labels, settings)
    jobs = [(c, s, q) for c in configs for s in settings.solutions
            for q in (settings.qs if c.sweep == "q" else (settings.operating_q,))]
    jobs += [(configs[0], s, codec) for s in settings.solutions for codec in settings.other_codecs]
    records = []
    operating: dict[str, video_objects.CodedSolution] = {}
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
            if config.key == "full@25" and q == settings.operating_q:
                operating[solution] = coded
        clothes = sum(o.bits for o in coded.objects if o.name == "clothes") if solution == "NSV3O+C" else None
        record = _record(coded, config, clip, codec, q, duration_s, settings, software, sweep, clothes)
        if sweep == "codec":
            record["object_q"] = {o.name: o.q for o in coded.objects}
        records.append(record)
    records.append({"kind": "run", "clip": clip, "frames": len(frames), "source_fps": settings.source_fps,
                    "backend": "cpu", "versions": software, "shape_streams": _shape_summary(shapes, duration_s)})
    return records


def _shape_summary(shapes: video_objects.ShapeCache, duration_s: float) -> list[dict]:
    rows = []
    for (name, config_key), (n_bytes, masks) in shapes.streams.items():
        rows.append({"object": name, "config": config_key, "frames": len(masks), "bytes": n_bytes,
                     "bits_per_frame": 8.0 * n_bytes / len(masks), "kbps": 8.0 * n_bytes / duration_s / 1000.0,
                     "area_percent": 100.0 * float(masks.mean())})
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
    return {"NSV": None, "NSV2O": record["signer_area_percent"], "NSV3O": record["skin_area_percent"],
            "NSV3O+C": record["skin_area_percent"], "SSV": record["skin_area_percent"]}.get(record["solution"])


def write_tables(records: list[dict], out_dir: Path) -> list[Path]:
    """CSV tables shaped like Tables 4.6-4.16, the linear fits and the shape-coding summary."""
    points = [r for r in records if r.get("kind") == "point"]
    run = next((r for r in records if r.get("kind") == "run"), {})
    written = []

    def columns(r: dict) -> list:
        area = _area(r)
        return [r["solution"], r["codec"], r["clip"], f"{r['width']}x{r['height']}", "" if area is None else f"{area:.1f}%",
                r["fps"], r["q"], r["kbps"], r["kbps"] - r["shape_kbps"], r["shape_kbps"], r["psnr"],
                r.get("psnr_object", r["psnr"]), r.get("psnr_skin"), r.get("ssim_skin")]
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
    clothes = [r for r in points if r["solution"] == "NSV3O+C" and r["codec"] == "mpeg4" and r["q"] == 12]
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
                   "psnr_vs_kbps.png": report.chart_rate_quality(records, "psnr"),
                   "ssim_vs_kbps.png": report.chart_rate_quality(records, "ssim")}
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
    lines = ["kbps at 25 fps, full resolution, MPEG-4 Part 2 (skin PSNR dB at Q=12 in brackets)",
             f"{'solution':<10}" + "".join(f"{'Q=' + str(q):>9}" for q in qs) + f"{'area':>8}"]
    for solution in solutions:
        row = {r["q"]: r for r in q_sweep if r["solution"] == solution}
        area = _area(next(iter(row.values())))
        cells = "".join(f"{row[q]['kbps']:9.1f}" if q in row else f"{'-':>9}" for q in qs)
        op = next((r for r in row.values() if r["operating_point"]), None)
        extra = f"  [{op['psnr_skin']:.2f}]" if op and op.get("psnr_skin") is not None else ""
        lines.append(f"{solution:<10}{cells}{'' if area is None else f'{area:7.1f}%':>8}{extra}")
    codec_rows = [r for r in points if r["sweep"] == "codec" or (r["sweep"] == "q" and r["operating_point"])]
    if codec_rows:
        lines.append("matched quality (each object's PSNR >= MPEG-4 Q=12): kbps / skin PSNR dB")
        for r in sorted(codec_rows, key=lambda r: (report._order(r["solution"]), r["codec"])):
            lines.append(f"  {r['solution']:<9}{r['codec']:<11}{r['kbps']:8.1f}  {r.get('psnr_skin') or float('nan'):6.2f}")
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

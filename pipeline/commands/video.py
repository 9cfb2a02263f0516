"""`signcast video --video carphone --out DIR` (a natural clip: NSV, NSV2O, NSV3O, NSV3O+C) and
`signcast video --ssv ase HELLO --out DIR` (the rendered synthetic signer: NSV and SSV, plus the colour
segmentation's IoU against the renderer's label buffer): bitrate and quality tables, plots, mask overlays."""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from media.errors import SigncastError


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "video", help="code a signer as video objects (NSV, NSV2O, NSV3O, NSV3O+C, SSV) and measure rate and quality",
        description="Segment a signer video by colour (or render the synthetic signer with its label buffer), code "
                    "each solution's video objects with MPEG-4 Part 2 at fixed Q (GOP I B B P ..., 12 frames) plus "
                    "lossless binary shape, sweep Q, frame rate and resolution, compare with H.264 and AV1 at "
                    "matched quality, and write records.jsonl, CSV tables, PNG plots and mask overlays to --out.")
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("--video", help="a video file, or the bundled clip name 'carphone'")
    source.add_argument("--ssv", nargs=2, metavar=("LANGUAGE", "WORD"),
                        help="render the synthetic signer fingerspelling WORD in LANGUAGE (e.g. ase HELLO)")
    parser.add_argument("--out", required=True, type=Path, help="output folder")
    parser.add_argument("--frames", type=int, default=None, help="use only the first N frames")
    parser.add_argument("--fps", type=float, default=25.0,
                        help="frame rate the clip is coded at (a natural clip is re-timed to it; default 25)")
    parser.add_argument("--q", type=int, nargs="+", default=[2, 6, 12, 24, 31], help="MPEG-4 quantisers to sweep")
    parser.add_argument("--codecs", nargs="*", default=["libx264", "libsvtav1"],
                        help="today's codecs coded at matched quality (default libx264 libsvtav1; none to skip)")
    parser.add_argument("--size", type=int, nargs=2, metavar=("WIDTH", "HEIGHT"), default=[400, 340],
                        help="rendered signer size for --ssv (default 400 340, as the source's Visia)")
    parser.add_argument("--no-progress", action="store_true", help="hide progress bars")
    parser.set_defaults(func=run)


def _check_args(args: argparse.Namespace) -> None:
    if not (math.isfinite(args.fps) and 0 < args.fps <= 240):
        raise SigncastError(f"bad --fps {args.fps}: choose a frame rate in (0, 240]")
    if args.frames is not None and args.frames < 2:
        raise SigncastError(f"bad --frames {args.frames}: at least 2")
    if 12 not in args.q:
        raise SigncastError("--q must include 12, the operating point of the frame-rate, resolution and codec sweeps")
    for q in args.q:
        if not 1 <= q <= 31:
            raise SigncastError(f"bad --q {q}: MPEG-4 quantisers are 1..31")
    from comparisons.video_codecs import CODECS
    for codec in args.codecs:
        if codec not in CODECS or codec == "mpeg4":
            raise SigncastError(f"bad --codecs {codec}: choose from libx264, libsvtav1")


def run(args: argparse.Namespace) -> int:
    _check_args(args)
    from pipeline import video_study

    settings = video_study.VideoStudySettings(qs=tuple(sorted(set(args.q))), source_fps=args.fps,
                                              other_codecs=tuple(args.codecs))
    progress = not args.no_progress
    if args.video is not None:
        frames, labels, clip, extra = _natural(args)
    else:
        frames, labels, clip, extra = _synthetic(args, progress)
        settings = video_study.VideoStudySettings(qs=settings.qs, source_fps=args.fps, other_codecs=settings.other_codecs,
                                                  solutions=("NSV", "SSV"))
    records = video_study.run_video_study(frames, labels, clip, settings, progress=progress)
    records = extra["records"] + records
    written = video_study.write_outputs(records, frames, labels, args.out)
    for name, (overlay_frames, overlay_labels) in extra.get("overlays", {}).items():
        written.append(video_study.write_overlays(overlay_frames, overlay_labels, args.out, name))
    print(video_study.main_table(records))
    for line in extra.get("lines", []):
        print(line)
    print(f"wrote {len(written)} files to {args.out}", file=sys.stdout)
    return 0


def _natural(args: argparse.Namespace):
    from media import segmentation
    from pipeline.video_study import load_natural_clip

    frames, labels, path, native_fps = load_natural_clip(args.video, args.frames)
    areas = segmentation.area_percent(labels)
    record = {"kind": "segmentation", "clip": path.stem, "method": "colour (GrabCut border model + clothes clusters)",
              "native_fps": native_fps, "coded_fps": args.fps, **{f"{k}_area_percent": v for k, v in areas.items()}}
    return frames, labels, path.stem, {"records": [record]}


def _synthetic(args: argparse.Namespace, progress: bool):
    from tqdm import tqdm

    from kernels.raster import FLAT_PALETTE
    from media import segmentation
    from media.avatar import load_avatar
    from media.fingerspelling import fingerspell
    from media.motion import Motion
    from media.render import RenderSettings, render_motion

    language, word = args.ssv
    width, height = args.size
    if width < 32 or height < 32 or width % 2 or height % 2:
        raise SigncastError(f"bad --size {width} {height}: even numbers, at least 32")
    motion = fingerspell(language, word, fps=args.fps)
    if args.frames is not None:
        count = min(args.frames, motion.n_frames)
        motion = Motion(motion.fps, motion.bone_names, motion.rotations[:count], motion.root_translation[:count])
    avatar = load_avatar()
    renders = {}
    for look in ("shaded", "flat"):
        with tqdm(total=motion.n_frames, desc=f"render {look}", unit="frame", disable=not progress) as bar:
            renders[look] = render_motion(avatar, motion, RenderSettings(width=width, height=height, look=look),
                                          progress=bar.update)
    frames, truth = renders["shaded"]
    palette = {label: tuple(int(c) for c in colour) for label, colour in enumerate(FLAT_PALETTE)}
    by_flat_colour = segmentation.labels_from_flat(renders["flat"][0], palette)
    by_colour = segmentation.segment_parts(frames)
    clip = f"ssv-{language}-{word}"
    records = []
    lines = ["segmentation IoU against the renderer's label buffer:"]
    for method, labels in (("flat-colour rendering", by_flat_colour),
                           ("colour segmentation of the shaded rendering", by_colour)):
        iou = segmentation.iou_per_label(labels, truth)
        records.append({"kind": "segmentation", "clip": clip, "method": method,
                        **{f"iou_{k}": v for k, v in iou.items()}})
        lines.append(f"  {method}: " + ", ".join(f"{k} {v:.3f}" for k, v in iou.items()))
    overlays = {"colour_segmentation": (frames, by_colour), "flat_colour": (frames, by_flat_colour)}
    return frames, truth, clip, {"records": records, "lines": lines, "overlays": overlays}

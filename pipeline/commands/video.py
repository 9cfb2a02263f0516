"""`signcast video --video carphone --out DIR` (a natural clip: NSV, NSV2O, NSV3O, NSV3O+C) and
`signcast video --ssv ase HELLO --out DIR` (the rendered synthetic signer: NSV and SSV, plus the colour
segmentation's IoU against the renderer's label buffer): bitrate and quality tables, plots, mask overlays."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from media.errors import SigncastError
from pipeline.outputs import add_force_argument, output_folder

# --ssv holds per pixel and frame: the shaded and the flat render with their labels (8 bytes), two
# segmentations (2), and the study's decoded pictures and frame-rate / half-size copies (about 6)
SSV_BYTES_PER_PIXEL = 16


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
    add_force_argument(parser)
    parser.add_argument("--frames", type=int, default=None, help="use only the first N frames")
    parser.add_argument("--fps", type=float, default=None,
                        help="frame rate to code at: a natural clip's frames are dropped by presentation time down to it "
                             "(default: the clip's own rate; 25 for --ssv)")
    add_max_size_argument(parser)
    parser.add_argument("--q", type=int, nargs="+", default=[2, 6, 12, 24, 31], help="MPEG-4 quantisers to sweep")
    parser.add_argument("--codecs", nargs="*", default=["libx264", "libsvtav1"],
                        help="today's codecs coded at matched quality (default libx264 libsvtav1; none to skip)")
    parser.add_argument("--size", type=int, nargs=2, metavar=("WIDTH", "HEIGHT"), default=[400, 340],
                        help="rendered signer size for --ssv (default 400 340, as the source's Visia)")
    parser.add_argument("--no-progress", action="store_true", help="hide progress bars")
    parser.set_defaults(func=run)


def add_max_size_argument(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--max-size", default="352x288", metavar="WxH",
                        help="scale a larger natural video down to fit WxH, aspect kept (default 352x288, CIF; "
                             "none keeps the size)")


def parse_max_size(text: str) -> tuple[int, int] | None:
    """--max-size: (width, height) in pixels, or None for 'none'."""
    from pipeline.checks import parse_size
    return None if str(text).strip().lower() == "none" else parse_size(text, "--max-size")


def _check_args(args: argparse.Namespace) -> None:
    from media.domain import check_fps, check_q
    if args.fps is not None:
        check_fps(args.fps)
    if args.frames is not None and args.frames < 2:
        raise SigncastError(f"bad --frames {args.frames}: at least 2")
    for q in args.q:
        check_q(q, "--q")
    if 12 not in args.q:
        raise SigncastError("--q must include 12, the operating point of the frame-rate, resolution and codec sweeps")
    from pipeline.checks import check_size, video_codecs
    args.codecs = video_codecs(args.codecs, "--codecs")
    args.max_size = parse_max_size(args.max_size)
    if args.ssv is not None:
        check_size(*args.size)


def run(args: argparse.Namespace) -> int:
    _check_args(args)
    with output_folder(args.out, force=args.force):
        return _study(args)


def _study(args: argparse.Namespace) -> int:
    from comparisons.records import write_records
    from pipeline import video_study

    progress = not args.no_progress
    if args.video is not None:
        frames, labels, clip, extra = _natural(args, progress)
        solutions = video_study.VideoStudySettings.solutions
    else:
        frames, labels, clip, extra = _synthetic(args, progress)
        solutions = ("NSV", "SSV")
    settings = video_study.VideoStudySettings(qs=tuple(sorted(set(args.q))), source_fps=extra["fps"],
                                              other_codecs=tuple(args.codecs), solutions=solutions)
    # records.jsonl grows as points are measured, so an interrupted run keeps what it measured
    records_path = write_records(args.out / "records.jsonl", extra["records"])
    records = video_study.run_video_study(frames, labels, clip, settings, timing=extra.get("timing"),
                                          records_path=records_path, progress=progress)
    records = extra["records"] + records
    written = video_study.write_outputs(records, frames, labels, args.out)
    for name, (overlay_frames, overlay_labels) in extra.get("overlays", {}).items():
        written.append(video_study.write_overlays(overlay_frames, overlay_labels, args.out, name))
    print(video_study.main_table(records))
    for line in extra.get("lines", []):
        print(line)
    print(f"wrote {len(written)} files to {args.out}", file=sys.stdout)
    return 0


def _natural(args: argparse.Namespace, progress: bool):
    from media import segmentation
    from pipeline.video_study import Timing, read_natural_clip, segment_clip

    clip, notes = read_natural_clip(args.video, args.frames, args.max_size, args.fps, progress=progress)
    for line in notes:
        print(f"signcast video: {line}", file=sys.stderr)
    labels = segment_clip(clip.frames, progress=progress)
    areas = segmentation.area_percent(labels)
    record = {"kind": "segmentation", "clip": clip.path.stem, "method": "colour (GrabCut border model + clothes clusters)",
              "native_fps": clip.native_fps, "coded_fps": clip.fps, "duration_s": clip.duration_s,
              "source_size": list(clip.source_size), "coded_size": list(clip.size),
              "announced_frames": clip.announced_frames, **{f"{k}_area_percent": v for k, v in areas.items()}}
    return clip.frames, labels, clip.path.stem, {"records": [record], "fps": clip.fps, "timing": Timing.of_clip(clip)}


def _synthetic(args: argparse.Namespace, progress: bool):
    from tqdm import tqdm

    from kernels.raster import FLAT_PALETTE
    from media import segmentation
    from media.avatar import load_avatar
    from media.fingerspelling import fingerspell
    from media.motion import Motion
    from media.render import RenderSettings, render_motion
    from pipeline.checks import check_memory

    language, word = args.ssv
    width, height = args.size
    motion = fingerspell(language, word, fps=args.fps or 25.0)
    if args.frames is not None:
        count = min(args.frames, motion.n_frames)
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
    return frames, truth, clip, {"records": records, "lines": lines, "overlays": overlays, "fps": motion.fps}

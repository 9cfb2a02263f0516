"""`signcast render LANGUAGE WORD -o out.mkv --labels labels.npz`: the synthetic signer fingerspelling a
word, rendered by the kernels to a lossless FFV1 video (the reference for quality measurements) plus
the per-pixel part labels of every frame."""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

from media.errors import SigncastError

BACKEND_CHOICES = ("auto", "warp", "opencl", "numpy")
VIDEO_SUFFIXES = (".mkv", ".avi", ".nut", ".mp4")   # containers that hold FFV1
BYTES_PER_PIXEL = 4                                 # held until written: RGB frames (3) and labels (1)


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "render", help="render the avatar fingerspelling a word to a lossless video and label frames",
        description="Fingerspell WORD in sign language LANGUAGE on the avatar, render every frame with the "
                    "kernels (skinning, muscles, rasterizer) and write a lossless FFV1 video plus the label "
                    "frames (0 background, 1 body, 2 head, 3 left hand, 4 right hand).")
    parser.add_argument("language", help="sign language code, e.g. ase")
    parser.add_argument("word", help="word to fingerspell, e.g. HELLO")
    parser.add_argument("-o", "--output", required=True, type=Path, help="video file to write (.mkv, .avi, .nut, .mp4)")
    parser.add_argument("--labels", type=Path, help="write the label frames (T, H, W) uint8 to this .npz")
    parser.add_argument("--backend", default="auto", help="kernels backend: auto, warp, opencl or numpy (default auto)")
    parser.add_argument("--size", default="352x288", help="WIDTHxHEIGHT in pixels (default 352x288; also 400x340, 176x144)")
    parser.add_argument("--fps", type=float, default=25.0, help="frame rate (default 25)")
    parser.add_argument("--look", default="shaded", help="shaded (lit) or flat (one colour per part, no light)")
    parser.add_argument("--segmented", action="store_true",
                        help="animate a segmented FBA-style body (each vertex follows one bone) instead of the seamless skin")
    parser.add_argument("--preview", type=Path, help="also write one frame as a PNG")
    parser.add_argument("--preview-frame", type=int, help="frame index for --preview (default: the middle frame)")
    parser.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from media.render import check_backend, check_look
    from pipeline.checks import parse_size
    from pipeline.outputs import output_files

    width, height = parse_size(args.size)
    check_backend(args.backend)
    check_look(args.look)
    if not (math.isfinite(args.fps) and 0 < args.fps <= 240):
        raise SigncastError(f"bad --fps {args.fps}: choose a frame rate in (0, 240], e.g. 10, 15, 20 or 25")
    from kernels import backends
    chosen = backends.describe(args.backend)   # a backend that cannot run here fails now, in one line
    with output_files((args.output, "video", VIDEO_SUFFIXES), (args.labels, "labels", (".npz",)),
                      (args.preview, "preview", (".png",))):
        return _render(args, width, height, chosen)


def _render(args: argparse.Namespace, width: int, height: int, chosen: str) -> int:
    import numpy as np
    from tqdm import tqdm

    from media.avatar import load_avatar
    from media.fingerspelling import fingerspell
    from media.render import RenderSettings, render_motion
    from media.video_io import write_video
    from pipeline.checks import check_memory

    motion = fingerspell(args.language, args.word, fps=args.fps)
    if args.preview_frame is not None and not 0 <= args.preview_frame < motion.n_frames:
        raise SigncastError(f"--preview-frame {args.preview_frame} outside 0..{motion.n_frames - 1}")
    check_memory(motion.n_frames, width, height, BYTES_PER_PIXEL, "render")
    avatar = load_avatar()
    settings = RenderSettings(width=width, height=height, look=args.look, segmented=args.segmented,
                              backend=args.backend)
    if args.backend == "auto":
        print(f"backend auto chose {chosen}", file=sys.stderr)
    started = time.perf_counter()
    with tqdm(total=motion.n_frames, desc="render", unit="frame", file=sys.stderr, leave=False,
              disable=args.no_progress) as bar:
        frames, labels = render_motion(avatar, motion, settings, progress=bar.update)
    rendered = time.perf_counter()
    size = write_video(args.output, frames, motion.fps)
    elapsed = time.perf_counter() - started
    if args.labels is not None:
        np.savez_compressed(args.labels, labels=labels, fps=np.float64(motion.fps),
                            part_names=np.array(["background", "body", "head", "left_hand", "right_hand"]))
    if args.preview is not None:
        _write_png(args.preview, frames[motion.n_frames // 2 if args.preview_frame is None else args.preview_frame])
    print(f"{args.output}: {args.language} {args.word!r}, {motion.n_frames} frames {width}x{height} at "
          f"{motion.fps:g} fps, {args.look}{', segmented' if args.segmented else ''}, {size} bytes; "
          f"rendered at {motion.n_frames / (rendered - started):.1f} frames/s, "
          f"{motion.n_frames / elapsed:.1f} frames/s with encoding")
    return 0


def _write_png(path: Path, rgb) -> None:
    import cv2
    if not cv2.imwrite(str(path), rgb[..., ::-1]):
        raise SigncastError(f"cannot write PNG {path}")

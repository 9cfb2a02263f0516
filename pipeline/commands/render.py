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


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "render", help="render the avatar fingerspelling a word to a lossless video and label frames",
        description="Fingerspell WORD in sign language LANGUAGE on the avatar, render every frame with the "
                    "kernels (skinning, muscles, rasterizer) and write a lossless FFV1 video plus the label "
                    "frames (0 background, 1 body, 2 head, 3 left hand, 4 right hand).")
    parser.add_argument("language", help="sign language code, e.g. ase")
    parser.add_argument("word", help="word to fingerspell, e.g. HELLO")
    parser.add_argument("-o", "--output", required=True, type=Path, help="video file to write (.mkv, .avi)")
    parser.add_argument("--labels", type=Path, help="write the label frames (T, H, W) uint8 to this .npz")
    parser.add_argument("--backend", default="auto", help="kernels backend: auto, warp, opencl or numpy (default auto)")
    parser.add_argument("--size", default="352x288", help="WIDTHxHEIGHT in pixels (default 352x288; also 400x340, 176x144)")
    parser.add_argument("--fps", type=float, default=25.0, help="frame rate (default 25)")
    parser.add_argument("--look", default="shaded", help="shaded (lit) or flat (one colour per part, no light)")
    parser.add_argument("--segmented", action="store_true",
                        help="animate a segmented FBA-style body (each vertex follows one bone) instead of the seamless skin")
    parser.add_argument("--preview", type=Path, help="also write one frame as a PNG")
    parser.add_argument("--preview-frame", type=int, help="frame index for --preview (default: the middle frame)")
    parser.set_defaults(func=run)


def _writable(path: Path, what: str) -> None:
    folder = path.resolve().parent
    if not folder.is_dir():
        raise SigncastError(f"cannot write {what} {path}: folder {folder} does not exist")


def run(args: argparse.Namespace) -> int:
    from media.render import RenderSettings, check_backend, check_look, parse_size

    width, height = parse_size(args.size)
    check_backend(args.backend)
    check_look(args.look)
    if not (math.isfinite(args.fps) and 0 < args.fps <= 240):
        raise SigncastError(f"bad --fps {args.fps}: choose a frame rate in (0, 240], e.g. 10, 15, 20 or 25")
    for path, what in ((args.output, "video"), (args.labels, "labels"), (args.preview, "preview")):
        if path is not None:
            _writable(path, what)
    if args.labels is not None and args.labels.suffix != ".npz":
        raise SigncastError(f"--labels must name a .npz file, got {args.labels}")

    import numpy as np
    from tqdm import tqdm

    from media.avatar import load_avatar
    from media.fingerspelling import fingerspell
    from media.render import render_motion
    from media.video_io import write_video

    avatar = load_avatar()
    motion = fingerspell(args.language, args.word, fps=args.fps)
    if args.preview_frame is not None and not 0 <= args.preview_frame < motion.n_frames:
        raise SigncastError(f"--preview-frame {args.preview_frame} outside 0..{motion.n_frames - 1}")
    settings = RenderSettings(width=width, height=height, look=args.look, segmented=args.segmented,
                              backend=args.backend)
    started = time.perf_counter()
    with tqdm(total=motion.n_frames, desc="render", unit="frame", file=sys.stderr, leave=False) as bar:
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

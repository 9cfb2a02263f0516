"""`signcast render LANGUAGE WORD -o out.mkv --labels labels.npz` (or `--pose clip.pose` instead of LANGUAGE
WORD): the synthetic signer fingerspelling a word, or moving as any .pose of MediaPipe Holistic keypoints says,
rendered by the kernels to a lossless FFV1 video plus the per-pixel part labels of every frame; with --pose the
avatar is framed like the .pose's person (--framing; the study is pipeline.studies.render)."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from pipeline.commands import options
from pipeline.commands.motion import add_source_arguments, check_source
from pipeline.outputs import add_force_argument

BACKEND_CHOICES = ("auto", "warp", "opencl", "numpy")


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "render", help="render the avatar fingerspelling a word to a lossless video and label frames",
        description="Fingerspell WORD in sign language LANGUAGE on the avatar (or retarget a .pose file of "
                    "MediaPipe Holistic keypoints to it: --pose), render every frame with the "
                    "kernels (skinning, muscles, rasterizer) and write a lossless FFV1 video plus the label "
                    "frames (0 background, 1 body, 2 head, 3 left hand, 4 right hand). With --pose the avatar is "
                    "framed like the person of the .pose (same scale and position in the frame; --framing "
                    "full-figure keeps the signing space from the hips to above the head, as for a word).")
    add_source_arguments(parser, "fingerspell")
    parser.add_argument("-o", "--output", required=True, type=Path, help="lossless FFV1 video file to write (.mkv, .avi, .nut)")
    parser.add_argument("--labels", type=Path, help="write the label frames (T, H, W) uint8 to this .npz")
    parser.add_argument("--backend", default="auto", help="kernels backend: auto, warp, opencl or numpy (default auto)")
    options.add_size(parser, "352x288", "frame size (also 400x340, 176x144):")
    parser.add_argument("--fps", type=float, help="frame rate (default 25 for a word, the .pose file's own for --pose)")
    parser.add_argument("--look", default="shaded", help="shaded (lit) or flat (one colour per part, no light)")
    parser.add_argument("--segmented", action="store_true",
                        help="animate a segmented FBA-style body (each vertex follows one bone) instead of the seamless skin")
    parser.add_argument("--framing", default=None, choices=("source", "full-figure"),
                        help="where the avatar stands in the frame: 'source' frames it like the person of the "
                             "--pose (one zoom and shift, and a roll for a tilted picture, of the render camera per "
                             "clip, fitted from the avatar's "
                             "shoulders and face to the person's, so its hands cover the same pixels; the default "
                             "with --pose), 'full-figure' the signing space from the hips to above the head (the "
                             "default, and the only framing, for LANGUAGE WORD)")
    parser.add_argument("--preview", type=Path, help="also write one frame as a PNG")
    parser.add_argument("--preview-frame", type=int, help="frame index for --preview (default: the middle frame)")
    options.add_no_progress(parser)
    add_force_argument(parser, files=True)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from media.domain import parse_size
    from pipeline.outputs import output_files
    from pipeline.studies import render
    check_source(args)
    settings = render.RenderWordSettings(args.language, args.word, args.output, args.labels, args.preview,
                                         args.preview_frame, parse_size(args.size), args.fps, args.look, args.segmented,
                                         args.backend, args.pose, args.jitter_filter, args.framing)
    render.check(settings)
    with output_files((args.output, "video", render.VIDEO_SUFFIXES), (args.labels, "labels", (".npz",)),
                      (args.preview, "preview", (".png",)), force=args.force):
        line = render.run(settings, progress=not args.no_progress, notify=lambda note: print(note, file=sys.stderr))
    print(line)
    return 0

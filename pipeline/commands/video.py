"""`signcast video --video carphone --out DIR` (a natural clip: NSV, NSV2O, NSV3O, NSV3O+C, segmented by
landmarks or, with --segmentation colour, by the source's colour models) and `signcast video --ssv ase HELLO --out
DIR` (the rendered synthetic signer: NSV, NSV2O, SSV, NSV3O+C, plus both segmentations' IoU against the renderer's label
buffer): the study is pipeline.studies.video."""
from __future__ import annotations

import argparse
import sys

from pipeline.commands import options
from pipeline.outputs import output_folder

OPERATING_Q = 12     # pipeline.studies.video.VideoSweep.operating_q, named here without importing the study


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "video", help="code a signer as video objects (NSV, NSV2O, NSV3O, NSV3O+C, SSV) and measure rate and quality",
        description="Segment a signer video into signer, head and hands (or render the synthetic signer with its label buffer), code "
                    "each solution's video objects with MPEG-4 Part 2 at fixed Q (GOP I B B P ..., 12 frames) plus "
                    "binary shape (lossless unless --shape-error), sweep Q, frame rate and resolution, compare with H.264 and AV1 at "
                    "matched quality, and write records.jsonl, CSV tables, PNG plots and mask overlays to --out.")
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("--video", help="a video file, or the bundled clip name 'carphone'")
    source.add_argument("--ssv", nargs=2, metavar=("LANGUAGE", "WORD"),
                        help="render the synthetic signer fingerspelling WORD in LANGUAGE (e.g. ase HELLO)")
    options.add_out(parser)
    parser.add_argument("--frames", type=int, default=None, help="use only the first N frames")
    parser.add_argument("--fps", type=float, default=None,
                        help="frame rate to code at: a natural clip's frames are dropped by presentation time down to it "
                             "(default: the clip's own rate; 25 for --ssv)")
    options.add_max_size(parser)
    options.add_video_q(parser, rule=f"must include {OPERATING_Q}, the operating point of the frame-rate, "
                                     f"resolution and codec sweeps")
    options.add_video_codecs(parser)
    options.add_size(parser, "400x340", "rendered signer size for --ssv, as the source's Visia:")
    parser.add_argument("--segmentation", choices=("landmarks", "colour"), default="landmarks",
                        help="how a natural clip is cut into signer, head and hands: landmarks (selfie segmentation, "
                             "face and hand landmarks, skin colour learnt from the face; default) or colour (the "
                             "source's colour models of background and clothes, skin as the rest)")
    parser.add_argument("--shape-error", type=float, default=0.0, metavar="PERCENT",
                        help="lossy binary shape: each object's decoded shape may get at most this percent of its "
                             "pixels wrong (the standard's alpha threshold; default 0, lossless)")
    options.add_no_progress(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from media.domain import parse_size
    from pipeline.studies import video

    sweep = video.VideoSweep(qs=tuple(sorted(set(options.parse_qs(args.video_q, "--video-q")))),
                             other_codecs=options.parse_video_codecs(args.video_codecs))
    settings = video.VideoSettings(video=args.video, ssv=tuple(args.ssv) if args.ssv else None, frames=args.frames,
                                   fps=args.fps, max_size=options.parse_max_size(args.max_size),
                                   size=parse_size(args.size), sweep=sweep, segmentation=args.segmentation,
                                   shape_error=args.shape_error)
    video.check(settings)
    with output_folder(args.out, force=args.force) as out:
        result = video.run(settings, out, progress=not args.no_progress,
                           notify=lambda line: print(f"signcast video: {line}", file=sys.stderr))
    print(video.main_table(result.records))
    for line in result.lines:
        print(line)
    print(f"wrote {len(result.written)} files to {args.out}")
    return 0

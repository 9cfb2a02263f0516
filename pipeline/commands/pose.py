"""`signcast pose VIDEO -o clip.pose [--preview overlay.mkv]`: MediaPipe Holistic landmarks of a real signer's
video, in the lexicon's .pose layout (the study is pipeline.studies.pose)."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from pipeline.commands import options
from pipeline.outputs import add_force_argument


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "pose", help="extract MediaPipe Holistic landmarks (pose, face, hands) of a signer video to a .pose file",
        description="Track the signer's body pose, both hands and face (478 points with irises) in every frame with "
                    "MediaPipe's Holistic models on the CPU and write them as a .pose file in the lexicon's layout "
                    "(pixels; parts not found in a frame are masked).")
    parser.add_argument("video", help="a video file, or the bundled clip name 'carphone'")
    parser.add_argument("-o", "--output", required=True, type=Path, help=".pose file to write")
    parser.add_argument("--preview", type=Path, help="also write the video with the landmarks drawn (.mkv, .avi, .nut: lossless FFV1; .mp4: H.264)")
    parser.add_argument("--frames", type=int, default=None, help="use only the first N frames")
    options.add_max_size(parser)
    options.add_no_progress(parser)
    add_force_argument(parser, files=True)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from pipeline.outputs import output_files
    from pipeline.studies import pose

    settings = pose.PoseSettings(args.video, args.output, args.preview, options.parse_max_size(args.max_size),
                                 args.frames)
    pose.check(settings)
    with output_files((args.output, ".pose file", pose.POSE_SUFFIXES),
                      (args.preview, "preview", pose.PREVIEW_SUFFIXES), force=args.force):
        result = pose.run(settings, progress=not args.no_progress)
    for note in result.notes:
        print(f"signcast pose: {note}", file=sys.stderr)
    print(pose.summary(settings, result))
    return 0

"""`signcast live [LANGUAGE WORD | --pose FILE] --codecs mpeg4,fba-pred,fba-dct,bba-pred --loss-rates 0,0.5,1,2,5,10
--out DIR`: the loss sweep. Each solution is delivered live over RTP/UDP on the loopback interface through a lossy
relay at each loss rate and judged on what the receiver shows (the study is pipeline.studies.live; the report
comparisons.reports.live)."""
from __future__ import annotations

import argparse

from media.errors import SigncastError
from pipeline.commands import options

DEFAULT_CODECS = "NSV,NSV2O,NSV3O,NSV3O+C,SSV,fba-pred,fba-dct,bba-pred,bba-dct"
DEFAULT_LOSS_RATES = "0,0.5,1,2,5,10"
LIVE_REFRESH = 25


def add_network_arguments(parser: argparse.ArgumentParser) -> None:
    """The relay's model and the units' refresh period (also used by `send`)."""
    parser.add_argument("--burst", type=float, default=1.0,
                        help="mean loss burst, packets: 1 (the default) is Bernoulli loss, more is Gilbert-Elliott")
    parser.add_argument("--jitter-ms", type=float, default=0.0, help="delay spread the relay adds, ms (default 0)")
    parser.add_argument("--reorder", type=float, default=0.0,
                        help="share of datagrams held back past their successor, 0..1 (default 0)")
    parser.add_argument("--refresh", type=int, default=LIVE_REFRESH,
                        help=f"FBA/BBA intra refresh period in frames (default {LIVE_REFRESH}: a lost frame is "
                             f"concealed until the next intra frame, at most a second at 25 fps)")
    parser.add_argument("--units", choices=("frame", "period"), default="frame",
                        help="FBA/BBA units: 'frame' (default, low delay: every frame leaves as it is captured, "
                             "intra every --refresh frames, predicted between) or 'period' (one self-contained "
                             "unit per --refresh frames, sent when its last frame is captured: refresh - 1 frame "
                             "intervals of delay)")
    parser.add_argument("--shape-gop", type=int, default=1,
                        help="frames per shape unit of the video objects (default 1: no look-ahead)")
    parser.add_argument("--seed", type=int, default=1, help="the network model's seed (default 1)")


def add_parser(subparsers) -> None:
    from pipeline.commands.motion import add_source_arguments
    parser = subparsers.add_parser(
        "live", help="loss sweep: deliver each solution live over RTP/UDP through a lossy relay and judge it",
        description="Deliver the signing (LANGUAGE WORD fingerspelled by the avatar, default ase HELLO, or a .pose "
                    "retargeted) live as NSV, NSV2O, NSV3O, NSV3O+C and SSV (video objects with their shape; MPEG-4 "
                    "Part 2 or H.264), FBA and BBA over RTP/UDP on the loopback "
                    "interface, through a relay losing the given share of datagrams, and measure what the receiver "
                    "shows: delivered kbps with headers, frames lost and concealed, hand keypoint error and letters, "
                    "latency. Also muxes each solution with a programme video into an MPEG-2 TS. Writes "
                    "DIR/records.jsonl, DIR/live_table.csv, DIR/live_loss.png, DIR/report.html and DIR/ts/.")
    add_source_arguments(parser, "fingerspell")
    parser.add_argument("--codecs", default=DEFAULT_CODECS,
                        help=f"what to send, comma-separated: a video solution (NSV, NSV2O, NSV3O, NSV3O+C, SSV: MPEG-4 Part 2), "
                             f"SOLUTION:libx264 for H.264, or a parameter codec (fba-pred, fba-dct, bba-pred, "
                             f"bba-dct, bba-key); a last :Q sets that item's quantiser (NSV2O:mpeg4:8, fba-pred:8) "
                             f"(default {DEFAULT_CODECS}, at --video-q and --param-q)")
    parser.add_argument("--video-q", type=int, default=None,
                        help="video quantiser (mpeg4 Q 1..31, libx264 QP 0..51; default: each codec's own, "
                             "mpeg4 Q 4, libx264 QP 28)")
    parser.add_argument("--param-q", type=int, default=4, help="FBA/BBA quantisation 1..31 (default 4)")
    parser.add_argument("--loss-rates", default=DEFAULT_LOSS_RATES,
                        help=f"percent of datagrams lost, comma-separated (default {DEFAULT_LOSS_RATES})")
    add_network_arguments(parser)
    parser.add_argument("--repeats", type=int, default=1,
                        help="sessions per codec and loss rate, each with its own seed; the report shows means "
                             "(default 1)")
    options.add_size(parser, "352x288")
    parser.add_argument("--landmark-step", type=int, default=3,
                        help="measure intelligibility on every Nth frame shown (default 3)")
    parser.add_argument("--backend", default="auto", help="kernels backend: auto, warp, opencl or numpy")
    options.add_out(parser)
    options.add_no_progress(parser)
    parser.set_defaults(func=run)


def settings_from(args: argparse.Namespace):
    from media.domain import parse_size
    from pipeline.studies import live
    if args.pose is None and (args.language is None) != (args.word is None):
        args.command_parser.error("give LANGUAGE WORD (e.g. ase HELLO), --pose FILE, or neither (ase HELLO)")
    if args.pose is not None and args.language is not None:
        args.command_parser.error("give either LANGUAGE WORD or --pose FILE, not both")
    if args.landmark_step < 1:
        raise SigncastError(f"--landmark-step must be at least 1, got {args.landmark_step}")
    return live.LiveSettings(
        codecs=options.names(args.codecs), video_q=args.video_q, param_q=args.param_q,
        loss_rates=tuple(p / 100.0 for p in options.parse_floats(args.loss_rates, "--loss-rates")), burst=args.burst,
        jitter_ms=args.jitter_ms, reorder=args.reorder, refresh=args.refresh, units=args.units, seed=args.seed,
        repeats=args.repeats, shape_gop=args.shape_gop, language=args.language or "ase", word=args.word or "HELLO",
        pose=None if args.pose is None else str(args.pose), size=parse_size(args.size, "--size"),
        landmark_step=args.landmark_step, backend=args.backend)


def run(args: argparse.Namespace) -> int:
    from comparisons.reports import live as live_report
    from pipeline.outputs import output_folder
    from pipeline.studies import live
    settings = settings_from(args)
    live.check(settings)
    with output_folder(args.out, force=args.force) as out:
        records = live.run(settings, out, progress=not args.no_progress)
    print(live_report.summary_text(records))
    print(f"report: {args.out / 'report.html'}")
    return 0

"""`signcast send [LANGUAGE WORD | --pose FILE] --codec fba-pred --q 4 --to [HOST:]PORT [--loss 2]`: send one
signing live over RTP/UDP to a `signcast receive` (pipeline/live; the study functions are
pipeline.studies.live.run_send)."""
from __future__ import annotations

import argparse

from pipeline.commands import options


def add_parser(subparsers) -> None:
    from pipeline.commands.live import add_network_arguments
    from pipeline.commands.motion import add_source_arguments
    parser = subparsers.add_parser(
        "send", help="send a signing live over RTP/UDP to `signcast receive`",
        description="Send LANGUAGE WORD fingerspelled by the avatar (or a .pose retargeted) live to a receiver: "
                    "captured at its own frame rate, encoded as it is captured, packetised in RTP and sent over "
                    "UDP, with the session described over TCP on the same port. With --loss (and --burst, "
                    "--jitter-ms, --reorder) the datagrams go through a lossy relay in this process first.")
    add_source_arguments(parser, "send")
    parser.add_argument("--codec", default="fba-pred",
                        help="fba-pred, fba-dct, bba-pred, bba-dct (FBA, BBA), mpeg4 or libx264 (NSV: the avatar's "
                             "render as video), SSV or SSV:libx264 (its skin objects with shape) (default fba-pred)")
    parser.add_argument("--q", type=int, default=None,
                        help="quantiser of the codec on its own scale (default: FBA/BBA Q 4, mpeg4 Q 4, libx264 QP 28)")
    parser.add_argument("--to", required=True, metavar="[HOST:]PORT", help="the receiver's address")
    parser.add_argument("--loss", type=float, default=0.0, help="percent of datagrams the relay drops (default 0)")
    add_network_arguments(parser)
    options.add_size(parser, "352x288")
    parser.add_argument("--backend", default="auto", help="kernels backend for NSV's render")
    options.add_no_progress(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from media.domain import parse_size
    from pipeline.commands.motion import check_source
    from pipeline.live.network import parse_address
    from pipeline.studies import live
    check_source(args)
    settings = live.SendSettings(
        codec=args.codec.strip(), q=args.q, destination=parse_address(args.to), language=args.language or "ase",
        word=args.word or "HELLO", pose=None if args.pose is None else str(args.pose),
        size=parse_size(args.size, "--size"), refresh=args.refresh, units=args.units, shape_gop=args.shape_gop, loss_rate=args.loss / 100.0, burst=args.burst,
        jitter_ms=args.jitter_ms, reorder=args.reorder, seed=args.seed, backend=args.backend)
    sent = live.run_send(settings, progress=not args.no_progress)
    print(f"sent {sent['clip']} as {sent['solution']} ({sent['codec']} Q{sent['q']}): {sent['frames']} frames at "
          f"{sent['fps']:g} fps in {sent['packets']} packets, {sent['kbps']:.2f} kbit/s of stream, "
          f"{sent['delivered_kbps']:.2f} kbit/s on the wire; the relay dropped {sent['dropped_by_relay']}")
    return 0

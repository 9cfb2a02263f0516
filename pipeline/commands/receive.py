"""`signcast receive --port PORT --out DIR`: receive one live session from `signcast send`, decode, conceal and
render it as it arrives, and write what was shown (DIR/shown.mkv) and the delivery record (DIR/records.jsonl:
frames lost and concealed, latency). The study function is pipeline.studies.live.run_receive."""
from __future__ import annotations

import argparse
import sys

from media.errors import SigncastError
from pipeline.commands import options


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "receive", help="receive one live session from `signcast send` and write what was shown",
        description="Listen on PORT (TCP for the session description, UDP for RTP), receive one session, decode "
                    "and render it as packets arrive (lost frames held), and write DIR/shown.mkv and "
                    "DIR/records.jsonl (frames lost, concealed, latency from capture to ready-to-show).")
    parser.add_argument("--port", type=int, required=True, help="port to listen on (TCP and UDP), 1..65535")
    parser.add_argument("--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1)")
    parser.add_argument("--timeout", type=float, default=60.0, help="seconds to wait for a sender (default 60)")
    parser.add_argument("--backend", default="auto", help="kernels backend for the terminal's render")
    options.add_out(parser)
    options.add_no_progress(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from pipeline.outputs import output_folder
    if not 0 < args.port < 65536:
        raise SigncastError(f"--port must be 1..65535, got {args.port}")
    if not args.timeout > 0:
        raise SigncastError(f"--timeout must be positive, got {args.timeout}")
    # Listen first, on light imports only (issue 37: `receive` listens within 3 s, on a cold start too): a sender
    # that connects now waits in the backlog, and is answered READY once the decoders and renderer are loaded.
    from pipeline.live.session import Listener
    with output_folder(args.out, force=args.force) as out:
        listener = Listener(args.host, args.port)
        print(f"listening on {args.host}:{listener.port}", file=sys.stderr, flush=True)
        from pipeline.studies import live
        record = live.run_receive(args.port, out, timeout_s=args.timeout, backend=args.backend, host=args.host,
                                  listener=listener)
    p50, p95 = record.get("latency_ms_p50"), record.get("latency_ms_p95")
    latency = "no frame arrived" if p50 is None else f"latency median {p50:.0f} ms, 95th percentile {p95:.0f} ms"
    print(f"received {record['clip']} as {record['solution']} ({record['codec']}): {record['frames_lost']} of "
          f"{round(record['duration_s'] * record['fps'])} frames lost, {record['frames_concealed']} concealed; "
          f"{latency}; {record['received_kbps']:.2f} kbit/s arrived; wrote {args.out / 'shown.mkv'}")
    return 0

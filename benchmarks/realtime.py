"""Can every live encoder and decoder keep up with 25 fps on 2 cores? (issue 16)

Each stage of live delivery (pipeline/live/endpoints.py) is run the way a live session runs it, on ASL "HELLO"
fingerspelled by the avatar (80 frames, 25 fps), rendered at --size (default 352x288), pinned to --cores CPU
cores (default 2; os.sched_setaffinity, and the thread pools of NumPy's BLAS and Numba held to as many):
- NSV: the live PyAV encoder (mpeg4 at Q 4, libx264 at QP 26, no B-frames) fed one frame at a time, and the
  live decoder fed the packets one at a time;
- FBA / BBA: a unit of --refresh frames coded by the parameter codec at Q 4 and wrapped (comparisons.transport.fba_units),
  and the receiver's side: the unit scanner, the codec's decoder, then the terminal's render of every frame
  (the avatar drawn by the kernels' default backend);
- the video-object solutions (pipeline/live/objects.py: NSV2O, NSV3O, NSV3O+C, SSV at mpeg4 Q 4): the sender's
  capture (causal padding, every object's texture and shape units of one frame), and the receiver's side (every
  stream's access units decoded, shapes and textures composed), the packets passing through RTP on the way.
The real-time factor is the frame interval (40 ms) over the measured time per frame, median over --repeats
rounds after a warm-up round: above 1 the stage keeps up with 25 fps live. Stages run one at a time, so in a
session (encoder, relay and decoder sharing the cores) the margin is smaller than the factor says.

    python benchmarks/realtime.py [--cores 2] [--repeats 3] [--size 352x288] [--refresh 16]
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def pin(cores: int) -> None:
    """Hold this process (and the thread pools that read these variables at import) to `cores` CPUs."""
    available = sorted(os.sched_getaffinity(0))
    os.sched_setaffinity(0, set(available[:cores]))
    for name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
        os.environ[name] = str(cores)


def timed(run, repeats: int) -> float:
    """Median seconds of run() over `repeats` rounds, after one warm-up round."""
    run()
    times = []
    for _ in range(repeats):
        started = time.perf_counter()
        run()
        times.append(time.perf_counter() - started)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--cores", type=int, default=2)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--size", default="352x288")
    parser.add_argument("--refresh", type=int, default=16)
    args = parser.parse_args()
    pin(args.cores)

    import numpy as np

    from comparisons.transport import fba_units
    from comparisons.params import codecs as param_codecs
    from comparisons.transport.video import LiveDecoder, LiveEncoder
    from media.avatar import load_avatar
    from media.fingerspelling import fingerspell
    from media.render import AvatarRenderer, RenderSettings
    from pipeline.live.endpoints import payload_prefix

    width, height = (int(v) for v in args.size.lower().split("x"))
    motion = fingerspell("ase", "HELLO")
    renderer = AvatarRenderer(load_avatar(), RenderSettings(width=width, height=height))
    rendered = list(renderer.frames(motion))
    frames = np.stack([rgb for rgb, _ in rendered])
    labels = np.stack([label for _, label in rendered])
    n, interval = motion.n_frames, 1.0 / motion.fps
    rows = []

    def add(stage: str, seconds: float) -> None:
        per_frame = seconds / n
        rows.append((stage, 1000 * per_frame, interval / per_frame))

    for codec, q in (("mpeg4", 4), ("libx264", 26)):
        packets = []

        def encode():
            encoder = LiveEncoder(codec, width, height, motion.fps, q)
            packets[:] = [p for i in range(n) for p in encoder.encode(frames[i], i)] + encoder.flush()

        def decode():
            decoder = LiveDecoder(codec, width, height)
            for p in packets:
                decoder.decode(p.data, p.index)
            decoder.flush()

        add(f"NSV {codec} encode", timed(encode, args.repeats))
        add(f"NSV {codec} decode", timed(decode, args.repeats))

    for name in ("fba-pred", "fba-dct", "bba-pred", "bba-dct"):
        codec = param_codecs.get_codec(name)
        units: list[bytes] = []

        def encode():
            units[:] = [fba_units.wrap_unit(s, min(args.refresh, n - s), codec.encode(
                motion.frames(s, min(s + args.refresh, n)), 4)) for s in range(0, n, args.refresh)]

        decoded = []

        def decode():
            scanner = fba_units.UnitScanner(lambda payload, k: codec.decode(payload), payload_prefix(name))
            decoded[:] = [unit.decoded for data in units for unit in scanner.feed(data)]

        def render():
            for shown in decoded:
                for _ in renderer.frames(shown):
                    pass

        add(f"{name} encode (units of {args.refresh})", timed(encode, args.repeats))
        add(f"{name} decode", timed(decode, args.repeats))
        add(f"{name} terminal render {width}x{height}", timed(render, args.repeats))

    from comparisons.transport import rtp
    from pipeline.live.jitter_buffer import DEPACKETIZERS
    from pipeline.live.objects import ObjectSink, ObjectSource
    from pipeline.live.session import SessionDescription, packetizer_for
    from media.domain import Solution
    for solution in (Solution.NSV2O, Solution.NSV3O, Solution.NSV3O_C, Solution.SSV):
        received: list = []

        def capture():
            source = ObjectSource(solution, frames, labels, motion.fps, "mpeg4", 4)
            packetizers = [packetizer_for(payload, seed=k) for k, (_, payload) in enumerate(source.streams)]
            received[:] = []
            for i in range(n):
                for unit in source.capture(i):
                    payload = source.streams[unit.stream][1]
                    first = packetizers[unit.stream].sequence
                    timestamp = rtp.timestamp_of(unit.frame, motion.fps)
                    packets = (packetizers[unit.stream].packetize_units(unit.data, timestamp) if payload == "units"
                               else packetizers[unit.stream].packetize(unit.data, timestamp))
                    received.append((unit.frame, unit.stream, DEPACKETIZERS[payload](packets, first)))
            received.append(source.streams)

        def show():
            streams = received[-1]
            description = SessionDescription(solution, "mpeg4", "objects", 4, motion.fps, n, width, height,
                                             streams=[{"name": name, "payload": payload} for name, payload in streams])
            sink = ObjectSink(description)
            for frame, stream, depacketized in received[:-1]:
                sink.receive(frame, depacketized, stream)
            sink.finish()

        add(f"{solution} capture: pad, texture and shape encode", timed(capture, args.repeats))
        add(f"{solution} receive: decode and compose", timed(show, args.repeats))

    print(f"ASL HELLO, {n} frames at {motion.fps:g} fps, {width}x{height}, pinned to {args.cores} cores; "
          f"median of {args.repeats} rounds")
    print(f"{'stage':52} {'ms/frame':>9} {'x real time':>12}")
    for stage, ms, factor in rows:
        print(f"{stage:52} {ms:9.2f} {factor:12.1f}")


if __name__ == "__main__":
    main()

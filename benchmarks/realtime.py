"""Can every live encoder and decoder keep up with 25 fps on 2 cores? (issue 16)

Each stage of live delivery (pipeline/live/endpoints.py) is run the way a live session runs it, on ASL "HELLO"
fingerspelled by the avatar (80 frames, 25 fps), rendered at --size (default 352x288), pinned to --cores CPU
cores (default 2; os.sched_setaffinity, and the thread pools of NumPy's BLAS and Numba held to as many):
- NSV: the live PyAV encoder (mpeg4 at Q 4, libx264 at QP 26, no B-frames) fed one frame at a time, and the
  live decoder fed the packets one at a time;
- FBA / BBA: a unit of --refresh frames coded by the parameter codec at Q 4 and wrapped (comparisons.fba_units),
  and the receiver's side: the unit scanner, the codec's decoder, then the terminal's render of every frame
  (the avatar drawn by the kernels' default backend);
- shape units (the video objects' binary shape, comparisons.shape_units), one frame per unit.
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

    from comparisons import fba_units, param_codecs, shape_units
    from comparisons.live_video import LiveDecoder, LiveEncoder
    from media import segmentation
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

    masks = segmentation.object_masks(labels)["right_hand"]
    shape_data: list[bytes] = []

    def shape_encode():
        shape_data[:] = [u.data for u in shape_units.encode_shape_units(masks, gop=1)]

    def shape_decode():
        shape_units.find_shape_units(b"".join(shape_data))

    add("shape units encode (right hand, 1 frame a unit)", timed(shape_encode, args.repeats))
    add("shape units decode", timed(shape_decode, args.repeats))

    print(f"ASL HELLO, {n} frames at {motion.fps:g} fps, {width}x{height}, pinned to {args.cores} cores; "
          f"median of {args.repeats} rounds")
    print(f"{'stage':52} {'ms/frame':>9} {'x real time':>12}")
    for stage, ms, factor in rows:
        print(f"{stage:52} {ms:9.2f} {factor:12.1f}")


if __name__ == "__main__":
    main()

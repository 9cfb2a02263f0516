"""Speed of the seed-002 motion coders and what their entropy stages save.

1. Encode and decode speed, frames per second, of each coder (comparisons/lab/codecs.py) on the ASL
   alphabet fingerspelled at 25 fps, at its lowest and highest operating point; median over --repeats.
   Real time is 25 fps, so the factor over real time is fps / 25.
2. Entropy stage: the same streams with fixed-length codes, static Huffman and the adaptive arithmetic
   coder (seed 002 §7.4: a Huffman saving above 20-30 % hints at a front end that leaves redundancy).

    python benchmarks/motion_lab.py [--repeats 3]
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path
from media.domain import kbps  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from comparisons.lab.codecs import LAB_CODEC_NAMES, LabCodec, alphabet_motion, motion_dofs  # noqa: E402

FPS = 25.0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    dofs = motion_dofs(alphabet_motion("ase", FPS))
    seconds = len(dofs) / FPS
    print(f"ASL alphabet: {len(dofs)} frames ({seconds:.1f} s) at {FPS:g} fps, {int((dofs != 0).any(0).sum())} active DOFs")
    print(f"{'coder':>9} {'q':>3} {'enc fps':>9} {'dec fps':>9} {'fixed kb/s':>11} {'huffman':>8} {'arith':>8} {'Huffman saves':>14}")
    for name in LAB_CODEC_NAMES:
        for index in (0, len(LabCodec(name).settings()) - 1):
            rates = {}
            for stage in ("fixed", "huffman", "arithmetic"):
                codec = LabCodec(name, stage)
                data, _ = codec.encode_dofs(dofs, FPS, index)
                rates[stage] = kbps(8 * len(data), seconds)
            codec = LabCodec(name)
            encode_s, decode_s = [], []
            for _ in range(args.repeats):
                start = time.perf_counter()
                data, _ = codec.encode_dofs(dofs, FPS, index)
                encode_s.append(time.perf_counter() - start)
                start = time.perf_counter()
                codec.decode_dofs(data)
                decode_s.append(time.perf_counter() - start)
            print(f"{name:>9} {index + 1:>3} {len(dofs) / statistics.median(encode_s):9.0f} "
                  f"{len(dofs) / statistics.median(decode_s):9.0f} {rates['fixed']:11.3f} {rates['huffman']:8.3f} "
                  f"{rates['arithmetic']:8.3f} {100 * (1 - rates['huffman'] / rates['fixed']):13.0f}%")
    return 0


if __name__ == "__main__":
    sys.exit(main())

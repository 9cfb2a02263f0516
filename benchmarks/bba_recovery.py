"""How much of a BBA stream a resilient decoder keeps when one byte is damaged, and what the
resilience fields cost.

1. Recovery: a real stream (ASL "ABCDEFGHIJ" fingerspelled by the avatar, 25 fps, 165 frames,
   Q = 4) is coded with the predictive coder at intra periods 4, 16 and 32 frames, the DCT coder
   (intra every 4 segments) and the key-frame coder. Each of --trials random single-byte
   damages (seeded: a uniform position, XOR with a uniform nonzero byte) is decoded with
   `read_stream(resilient=True)` and the decoded motion is compared with the clean decode, frame
   by frame at the same frame index: a frame is lost when it is missing or differs. A decode
   that raises loses every frame. Printed per coder: median and mean frames lost per damaged
   byte, the share of damages that lost the whole stream, that gave a wrong frame count, and
   whose `lost` report missed a frame that differs (silent loss). The last row repeats the
   header before every intra unit (header_period=1), so header damage is survivable.
2. Size: mean rate (kbit/s) of the ASL letters A..J at 10 fps (the clips of docs/parameters.md)
   for bba-pred, bba-dct and bba-key at Q = 1, 4, 16.

    python benchmarks/bba_recovery.py [--trials 300] [--seed 1]
"""
from __future__ import annotations

import argparse
import statistics
import string
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from comparisons import bba_codec  # noqa: E402
from comparisons.param_codecs import get_codec  # noqa: E402
from media.errors import SigncastError  # noqa: E402
from media.fingerspelling import fingerspell, letter_motion  # noqa: E402

WORD = "ABCDEFGHIJ"
# label, coding, intra period, key frames, extra motion_to_stream arguments
CODERS = (("pred, intra 4", "pred", 4, False, {}), ("pred, intra 16", "pred", 16, False, {}),
          ("pred, intra 32", "pred", 32, False, {}), ("dct, intra 4 seg", "dct", 4, False, {}),
          ("key, intra 32", "pred", 32, True, {}),
          ("pred 32, hdr copy", "pred", 32, False, {"header_period": 1}))


def frames_lost(clean, decoded) -> tuple[int, set[int]]:
    """(frames of `clean` that `decoded` misses or gets wrong, their indices). Motions."""
    n = clean.n_frames
    m = min(n, decoded.n_frames)
    if decoded.bone_names != clean.bone_names:
        return n, set(range(n))
    same = (np.all(np.abs(decoded.rotations[:m] - clean.rotations[:m]) < 1e-12, axis=(1, 2))
            & np.all(np.abs(decoded.root_translation[:m] - clean.root_translation[:m]) < 1e-12, axis=1))
    wrong = set(np.flatnonzero(~same).tolist()) | set(range(m, n))
    return len(wrong), wrong


def recovery(codec, trials: int, seed: int) -> None:
    motion = fingerspell("ase", WORD, 25)
    print(f"1. recovery: ASL {WORD!r} at 25 fps ({motion.n_frames} frames), Q=4, {trials} single-byte damages")
    print(f"{'coder':>17} {'bytes':>6} {'median lost':>12} {'mean lost':>10} {'whole':>6} {'bad count':>10} {'silent':>7}")
    for label, coding, period, keyframes, extra in CODERS:
        stream = codec.motion_to_stream(motion, 4, coding, keyframes=keyframes, intra_period=period, **extra)
        data = codec.write_stream(stream)
        clean = codec.stream_to_motion(codec.read_stream(data)[0])
        rng = np.random.default_rng(seed)
        losses, whole, bad_count, silent = [], 0, 0, 0
        for _ in range(trials):
            damaged = bytearray(data)
            damaged[int(rng.integers(len(data)))] ^= int(rng.integers(1, 256))
            try:
                decoded_stream, reported = codec.read_stream(bytes(damaged), resilient=True)
                decoded = codec.stream_to_motion(decoded_stream)
            except SigncastError:
                losses.append(clean.n_frames)
                whole += 1
                continue
            n_lost, wrong = frames_lost(clean, decoded)
            losses.append(n_lost)
            bad_count += decoded.n_frames != clean.n_frames
            silent += bool(wrong - set(reported))
        print(f"{label:>17} {len(data):6d} {statistics.median(losses):12.1f} {statistics.mean(losses):10.2f} "
              f"{whole / trials:6.1%} {bad_count / trials:10.1%} {silent / trials:7.1%}")


def sizes() -> None:
    letters = string.ascii_uppercase[:10]
    motions = [letter_motion("ase", letter, 10) for letter in letters]
    print(f"\n2. size: mean kbit/s over ASL {letters[0]}..{letters[-1]} at 10 fps")
    print(f"{'codec':>9} {'Q=1':>7} {'Q=4':>7} {'Q=16':>7}")
    for name in ("bba-pred", "bba-dct", "bba-key"):
        codec = get_codec(name)
        rates = [np.mean([8 * len(codec.encode(m, q)) / (m.n_frames / m.fps) / 1000 for m in motions])
                 for q in (1, 4, 16)]
        print(f"{name:>9} " + " ".join(f"{r:7.2f}" for r in rates))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=300)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    recovery(bba_codec, args.trials, args.seed)
    sizes()


if __name__ == "__main__":
    main()

"""Speed of the MPEG-4 parameter coders and efficiency of their arithmetic coder.

1. Encode and decode speed, frames per second, of each registered MPEG-4 codec (fba-pred, fba-dct,
   bba-pred, bba-dct, bba-key) on real ASL fingerspelling (letters A..J retargeted to the avatar)
   at 10 fps and Q in {1, 8, 31}; the median over --repeats rounds. Real time is the coding frame
   rate (10 fps), so the factor over real time is fps / 10.
2. Arithmetic coder against the zero-order empirical entropy: the quantised P-frame residual levels
   of the FBA predictive coder over all 26 letters (Q = 1 and Q = 8) are coded as one sequence with
   one adaptive model; coded bits (excluding the 32-bit count) are compared with n * H(p).
   Also reported: inside the real streams each BAP has its own model that restarts at every intra
   plane, so on 1-second letters the models' learning cost is part of the measured rate; the
   benchmark prints that in-stream cost against the per-model entropies too.

    python benchmarks/params.py [--repeats 3]
"""
from __future__ import annotations

import argparse
import statistics
import string
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from comparisons import bap_table  # noqa: E402
from comparisons import param_coding as pc  # noqa: E402
from comparisons.bitstream import BitWriter  # noqa: E402
from comparisons.entropy import (ArithmeticEncoder, FrequencyModel, adaptive_code_length_bits,  # noqa: E402
                                 empirical_entropy_bits, encode_sequence)
from comparisons.fba_codec import _changed_mask, coded_order  # noqa: E402
from comparisons.fba_mapping import motion_to_baps  # noqa: E402
from comparisons.param_codecs import get_codec  # noqa: E402
from media.fingerspelling import letter_motion  # noqa: E402

CODECS = ("fba-pred", "fba-dct", "bba-pred", "bba-dct", "bba-key")


def speed(motions, repeats: int) -> None:
    print("1. speed on ASL A..J at 10 fps (frames/s, median of rounds; real time = 10 fps)")
    print(f"{'codec':>9} {'Q':>3} {'encode fps':>11} {'decode fps':>11} {'x real time (slower)':>22}")
    n_frames = sum(m.n_frames for m in motions)
    for name in CODECS:
        codec = get_codec(name)
        for q in (1, 8, 31):
            enc, dec = [], []
            for _ in range(repeats):
                start = time.perf_counter()
                coded = [codec.encode(m, q) for m in motions]
                enc.append(n_frames / (time.perf_counter() - start))
                start = time.perf_counter()
                for data in coded:
                    codec.decode(data)
                dec.append(n_frames / (time.perf_counter() - start))
            e, d = statistics.median(enc), statistics.median(dec)
            print(f"{name:>9} {q:>3} {e:11.0f} {d:11.0f} {min(e, d) / 10:22.0f}")


def residual_levels(values: np.ndarray, q: int) -> tuple[list[int], dict]:
    """P-frame residual levels of the FBA predictive coder (one intra period per clip), pooled,
    and per-BAP lists (what the per-BAP models see)."""
    steps_all = bap_table.steps() * q
    held = np.zeros(bap_table.N_BAPS, dtype=np.int64)
    order = coded_order(_changed_mask(values, held, steps_all))
    _, p_levels, _ = pc.predictive_levels(values[:, order], held[order], steps_all[order], q)
    per_bap = {int(i): p_levels[:, j].tolist() for j, i in enumerate(order)}
    return p_levels.ravel().tolist(), per_bap


def entropy_check() -> None:
    print("\n2. arithmetic coder vs empirical entropy (FBA P-frame residual levels, 26 ASL letters, 10 fps)")
    values = [motion_to_baps(letter_motion("ase", letter, 10)) for letter in string.ascii_uppercase]
    for q in (1, 8, 31):
        pooled, stream_cost, stream_entropy = [], 0, 0.0
        for v in values:
            levels, per_bap = residual_levels(v, q)
            pooled += levels
            for seq in per_bap.values():
                low, high = min(seq), max(seq)
                writer = BitWriter()
                encoder, model = ArithmeticEncoder(writer), FrequencyModel(high - low + 1)
                for s in seq:
                    encoder.encode(model, s - low)
                encoder.finish()
                stream_cost += writer.n_bits
                stream_entropy += empirical_entropy_bits(seq)
        low = min(pooled)
        symbols = [s - low for s in pooled]
        entropy = empirical_entropy_bits(symbols)
        for increment in (1, 4):
            coded_bits = 8 * len(encode_sequence(symbols, max(symbols) + 1, increment)) - 32
            ideal = adaptive_code_length_bits(symbols, max(symbols) + 1, increment)
            print(f"  Q={q:>2} increment {increment}: {len(symbols)} residuals, alphabet {max(symbols) + 1}: coded "
                  f"{coded_bits} bits, n*H = {entropy:.0f} bits, ratio {coded_bits / entropy:.4f} "
                  f"({100 * (coded_bits / entropy - 1):+.2f} %); ideal code length of the same adaptive model "
                  f"{ideal:.0f} bits (coder overhead {100 * (coded_bits / ideal - 1):+.3f} %)")
        print(f"         in-stream (one model per BAP per clip, tight ranges): {stream_cost} bits vs "
              f"{stream_entropy:.0f} bits of per-model entropy ({stream_cost / max(stream_entropy, 1):.2f}x: learning cost of short clips)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    motions = [letter_motion("ase", letter, 10) for letter in "ABCDEFGHIJ"]
    speed(motions, args.repeats)
    entropy_check()


if __name__ == "__main__":
    main()

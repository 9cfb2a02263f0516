"""How much of a coded motion stream a receiver keeps when one byte is damaged: live FBA units, one
FBA stream and BBA streams; and what the BBA resilience fields cost.

1. Recovery: a real clip (ASL "ABCDEFGHIJ" fingerspelled by the avatar, 25 fps, 154 frames, Q = 4)
   is coded as
   - live FBA units (comparisons/transport/fba_units.py, BAPs and FAPs), predictive and DCT, refresh 8, 16
     and 32 frames; received with find_units + assemble (hold concealment);
   - one FBA stream (comparisons/params/fba.py, intra period 32 / 4 DCT segments) for contrast: its
     single CRC-32 turns any damage into the loss of the whole clip;
   - BBA (comparisons/params/bba.py) with the predictive coder at intra periods 4, 16 and 32 frames,
     the DCT coder (intra every 4 segments), the key-frame coder, and the predictive coder with the
     header repeated before every intra unit (header_period=1); read_stream(resilient=True).
   Each of --trials random single-byte damages (seeded: a uniform position, XOR with a uniform
   nonzero byte) is decoded and compared with the clean decode, frame by frame at the same frame
   index: a frame is recovered when it equals the clean decode (concealed frames that happen to
   equal it count as recovered). A decode that raises recovers nothing. Printed per coder: bytes,
   median and mean frames recovered per damage, the share of damages that lost the whole clip,
   that gave a wrong frame count, and whose loss report missed a frame that differs (silent loss).
2. Size: mean rate (kbit/s) of the ASL letters A..J at 10 fps (the clips of docs/parameters.md)
   for bba-pred, bba-dct and bba-key at Q = 1, 4, 16.

    python benchmarks/stream_recovery.py [--trials 300] [--seed 1]
"""
from __future__ import annotations

import argparse
import statistics
import string
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from comparisons.params import bba as bba_codec
from comparisons.params.fba import decode_fba, encode_fba
from comparisons.params.fba_mapping import motion_to_baps
from comparisons.transport.fba_units import assemble, encode_fba_units, find_units
from comparisons.params.codecs import get_codec
from media.errors import SigncastError
from media.fingerspelling import fingerspell, letter_motion

WORD = "ABCDEFGHIJ"
Q = 4
# label, coding, intra period, key frames, extra motion_to_stream arguments
BBA_CODERS = (("bba pred, intra 4", "pred", 4, False, {}), ("bba pred, intra 16", "pred", 16, False, {}),
              ("bba pred, intra 32", "pred", 32, False, {}), ("bba dct, intra 4 seg", "dct", 4, False, {}),
              ("bba key, intra 32", "pred", 32, True, {}),
              ("bba pred 32, hdr copy", "pred", 32, False, {"header_period": 1}))
FBA_REFRESH = (8, 16, 32)


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


# A trial decoder: damaged bytes -> (frames recovered, wrong frame count, silent loss); raises
# SigncastError when the whole clip is lost.
Trial = Callable[[bytes], tuple[int, bool, bool]]


def _fba_frames(baps: np.ndarray, faps: np.ndarray | None) -> np.ndarray:
    """(T, 296 [+ 68]) int64: a decoded clip's BAPs and FAPs side by side, to compare frames."""
    return baps if faps is None else np.concatenate([baps, faps], axis=1)


def fba_units_trial(data: bytes, n_frames: int) -> Trial:
    clean = assemble(find_units(data)[0], n_frames)
    reference = _fba_frames(clean.baps, clean.faps)

    def trial(damaged: bytes) -> tuple[int, bool, bool]:
        received = assemble(find_units(damaged)[0], n_frames)
        same = np.all(_fba_frames(received.baps, received.faps) == reference, axis=1)
        return int(same.sum()), False, bool(np.any(~same & received.received))
    return trial


def fba_stream_trial(data: bytes) -> Trial:
    clean = decode_fba(data)
    reference = _fba_frames(clean.baps, clean.faps)

    def trial(damaged: bytes) -> tuple[int, bool, bool]:
        decoded = decode_fba(damaged)
        frames = _fba_frames(decoded.baps, decoded.faps)
        if frames.shape != reference.shape:
            return 0, True, True
        same = np.all(frames == reference, axis=1)
        return int(same.sum()), False, bool(np.any(~same))             # no loss report: any wrong frame is silent
    return trial


def bba_trial(data: bytes) -> Trial:
    clean = bba_codec.stream_to_motion(bba_codec.read_stream(data)[0])

    def trial(damaged: bytes) -> tuple[int, bool, bool]:
        stream, reported = bba_codec.read_stream(damaged, resilient=True)
        decoded = bba_codec.stream_to_motion(stream)
        n_lost, wrong = frames_lost(clean, decoded)
        return clean.n_frames - n_lost, decoded.n_frames != clean.n_frames, bool(wrong - set(reported))
    return trial


def coders(motion) -> list[tuple[str, bytes, Trial]]:
    """(label, stream bytes, trial decoder) of every coder compared."""
    baps, faps = motion_to_baps(motion), motion.faps
    rows = []
    for coding in ("pred", "dct"):
        for refresh in FBA_REFRESH:
            data = b"".join(u.data for u in encode_fba_units(baps, motion.fps, Q, coding, faps=faps, refresh=refresh))
            rows.append((f"fba {coding}, units {refresh}", data, fba_units_trial(data, motion.n_frames)))
        data = encode_fba(baps, motion.fps, Q, coding, faps=faps)
        rows.append((f"fba {coding}, one stream", data, fba_stream_trial(data)))
    for label, coding, period, keyframes, extra in BBA_CODERS:
        stream = bba_codec.motion_to_stream(motion, Q, coding, keyframes=keyframes, intra_period=period, **extra)
        data = bba_codec.write_stream(stream)
        rows.append((label, data, bba_trial(data)))
    return rows


def recovery(trials: int, seed: int) -> None:
    motion = fingerspell("ase", WORD, 25)
    n = motion.n_frames
    print(f"1. recovery: ASL {WORD!r} at 25 fps ({n} frames), Q={Q}, {trials} single-byte damages; "
          f"frames recovered of {n}")
    print(f"{'coder':>22} {'bytes':>6} {'kbit/s':>7} {'median':>7} {'mean':>7} {'whole':>6} {'bad count':>10} "
          f"{'silent':>7}")
    for label, data, trial in coders(motion):
        rng = np.random.default_rng(seed)
        recovered, whole, bad_count, silent = [], 0, 0, 0
        for _ in range(trials):
            damaged = bytearray(data)
            damaged[int(rng.integers(len(data)))] ^= int(rng.integers(1, 256))
            try:
                kept, wrong_count, silent_loss = trial(bytes(damaged))
            except SigncastError:
                recovered.append(0)
                whole += 1
                continue
            recovered.append(kept)
            whole += kept == 0
            bad_count += wrong_count
            silent += silent_loss
        kbps = 8 * len(data) / (n / motion.fps) / 1000
        print(f"{label:>22} {len(data):6d} {kbps:7.2f} {statistics.median(recovered):7.1f} "
              f"{statistics.mean(recovered):7.2f} {whole / trials:6.1%} {bad_count / trials:10.1%} "
              f"{silent / trials:7.1%}")


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
    recovery(args.trials, args.seed)
    sizes()


if __name__ == "__main__":
    main()

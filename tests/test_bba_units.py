"""The BBA predictive decoder's arithmetic-decoding kernel (kernels/entropy_coding.decode_frame_window, used by
kernels/bba_units.read_predictive_units) against decode_frame_local, the bit-at-a-time decoder it replaces:
the same symbols, statuses, reader states and model updates, on good frames, on frames with emulation-prevention
bits, and on cut, zeroed and random data."""
from __future__ import annotations

import numpy as np
import pytest

from comparisons.params.bits import BitWriter
from comparisons.params.entropy import ModelBank, encode_frame
from comparisons.params import arithmetic as kc


def _frames(rng: np.random.Generator, sizes: np.ndarray, kind: int, n_frames: int) -> list[np.ndarray]:
    frames = []
    for _ in range(n_frames):
        if kind == 0:        # mostly level 0: skewed models, short codes
            frame = rng.integers(0, 3, len(sizes)) * (rng.random(len(sizes)) < 0.1)
        elif kind == 1:      # only level 0: the coded bits run to long zero runs (emulation prevention)
            frame = np.zeros(len(sizes), dtype=np.int64)
        else:
            frame = rng.integers(0, 4000, len(sizes))
        frames.append(np.minimum(frame, sizes - 1))
    return frames


def _decode_both(data: bytes, end_bit: int, state: tuple[int, int, int], sizes: np.ndarray,
                 frames: list[np.ndarray], fresh: bool) -> int:
    """Every frame through both decoders (each with its own bank); asserts they agree. Returns the frames read."""
    array = np.frombuffer(data, dtype=np.uint8)
    states, banks = [state, state], [ModelBank(sizes), ModelBank(sizes)]
    for count, _ in enumerate(frames, start=1):
        results = []
        for i, kernel in enumerate((kc.decode_frame_local, kc.decode_frame_window)):
            bank = banks[i]
            out = np.full(len(sizes) + 2, -7, dtype=np.int64)
            result = kernel(array, end_bit, *states[i], bank.counts, bank.tree, bank.scalars, bank.offsets,
                            bank.members, out, 2, fresh)
            results.append((result, out))
            states[i] = result[1:]
        (got_a, out_a), (got_b, out_b) = results
        assert got_a == got_b
        assert np.array_equal(out_a, out_b)
        for name in ("counts", "tree", "scalars"):
            assert np.array_equal(getattr(banks[0], name), getattr(banks[1], name))
        if got_a[0]:
            return count
    return len(frames)


@pytest.mark.parametrize("seed", range(6))
def test_window_decoder_matches_the_bit_at_a_time_decoder(seed):
    rng = np.random.default_rng(seed)
    n_frames_read = 0
    for trial in range(30):
        n_values = int(rng.integers(1, 60))
        sizes = rng.integers(1, int(rng.choice([3, 20, 400, 3000])), n_values)
        frames = _frames(rng, sizes, trial % 4, int(rng.integers(1, 8)))
        writer, bank = BitWriter(), ModelBank(sizes)
        if rng.random() < 0.5:                  # frames that start mid-byte
            n_bits = int(rng.integers(1, 21))
            writer.write(int(rng.integers(0, 1 << n_bits)), n_bits)
        for frame in frames:
            encode_frame(writer, bank, frame)
        good = writer.getvalue()
        noise = rng.integers(0, 256, len(good), dtype=np.uint8)
        for data in (good, good[:len(good) // 2], bytes(noise), bytes(len(good)),
                     bytes(noise * (rng.random(len(good)) < 0.3))):
            for fresh in (False, True):
                end_bit = 8 * len(data) - int(rng.integers(0, 9))
                start = (int(rng.integers(0, 30)), int(rng.integers(0, kc.MAX_ZERO_RUN)), 0) \
                    if rng.random() < 0.3 else (0, 0, 0)
                n_frames_read += _decode_both(data, end_bit, start, sizes, frames, fresh)
    assert n_frames_read > 300


def test_window_decoder_reads_the_frames_written_with_their_stuffing_bits():
    """Frames of level 0 on large alphabets code to long zero runs: the writer stuffs 1 bits, which the
    window decoder drops once per frame (_strip) and still gives back the reader state bit for bit."""
    sizes = np.full(40, 5)
    frames = [np.zeros(40, dtype=np.int64)] * 30
    writer, bank = BitWriter(), ModelBank(sizes)
    for frame in frames:
        encode_frame(writer, bank, frame)
    data = writer.getvalue()
    array = np.frombuffer(data, dtype=np.uint8)
    assert kc._has_stuffing(array, 8 * len(data), 0, 0)
    assert _decode_both(data, 8 * len(data), (0, 0, 0), sizes, frames, False) == len(frames)
    bank, out, state = ModelBank(sizes), np.empty(40, dtype=np.int64), (0, 0, 0)
    for frame in frames:
        status, *state = kc.decode_frame_window(array, 8 * len(data), *state, bank.counts, bank.tree, bank.scalars,
                                                bank.offsets, bank.members, out, 0, False)
        assert status == 0 and np.array_equal(out, frame)


def test_stuffing_scan_and_leading_zeros_agree_with_bitwise_references():
    rng = np.random.default_rng(7)
    for _ in range(400):
        data = (rng.integers(0, 256, 24) * (rng.random(24) < 0.5)).astype(np.uint8)
        end_bit = int(rng.integers(0, 8 * 24 + 1))
        pos, run = int(rng.integers(0, end_bit + 1)), int(rng.integers(0, kc.MAX_ZERO_RUN))
        zeros, expected = run, False
        for p in range(pos, end_bit):
            zeros = 0 if (data[p >> 3] >> (7 - (p & 7))) & 1 else zeros + 1
            expected = expected or zeros >= kc.MAX_ZERO_RUN
        assert kc._has_stuffing(data, end_bit, pos, run) == expected
    for x in [0, 1, 2, 3, (1 << 31) - 1, 1 << 31, (1 << 32) - 1] + rng.integers(0, 1 << 32, 50).tolist():
        assert kc._clz32(x) == 32 - int(x).bit_length()


def test_window_decoder_leaves_totals_beyond_its_bound_to_the_bit_at_a_time_decoder():
    """A model total above WINDOW_MAX_TOTAL (no bank the coder builds has one) takes decode_frame_local."""
    sizes = np.array([7, 9])
    writer, bank = BitWriter(), ModelBank(sizes)
    encode_frame(writer, bank, np.array([3, 4]))
    data = np.frombuffer(writer.getvalue(), dtype=np.uint8)
    results = []
    for kernel in (kc.decode_frame_local, kc.decode_frame_window):
        scalars = ModelBank(sizes).scalars.copy()
        scalars[:, kc.TOTAL] = kc.WINDOW_MAX_TOTAL + 1
        out = np.zeros(2, dtype=np.int64)
        results.append((kernel(data, 8 * len(data), 0, 0, 0, np.zeros(16, dtype=np.int64),
                               np.zeros(18, dtype=np.int64), scalars, np.array([0, 7]), np.array([0, 1]), out, 0,
                               True), out.tolist()))
    assert results[0] == results[1]


def test_chunked_encoder_renormalisation_is_the_bit_at_a_time_one():
    """renormalise_encoder (the E1/E2 bits and their follow bits as one chunk, the E3 steps counted) writes the bits
    and leaves the registers of renormalise_coder's loop with emulation prevention: wide, narrow and middle-straddling
    intervals, long follow runs (beyond a chunk), zero runs near MAX_ZERO_RUN, any bit position in a byte."""
    rng = np.random.default_rng(11)
    top = (1 << kc.PRECISION) - 1
    for case in range(6000):
        kind = case % 3
        if kind == 0:
            low, high = sorted(int(v) for v in rng.integers(0, top + 1, 2))
        elif kind == 1:
            low = int(rng.integers(0, top + 1))
            high = min(low + int(rng.integers(0, 1 << int(rng.integers(1, 31)))), top)
        else:
            low = kc.HALF - int(rng.integers(1, 1 << int(rng.integers(1, 30))))
            high = kc.HALF + int(rng.integers(0, 1 << int(rng.integers(1, 30))))
        pending = int(rng.integers(0, 70)) if case % 5 == 0 else int(rng.integers(0, 4))
        run = int(rng.integers(0, kc.MAX_ZERO_RUN))
        pos = int(rng.integers(0, 16))
        got, expected = np.zeros(24, dtype=np.uint8), np.zeros(24, dtype=np.uint8)
        assert (kc.renormalise_encoder(got, pos, run, low, high, pending)
                == kc.renormalise_coder(expected, pos, run, low, high, pending, kc.MAX_ZERO_RUN)), (low, high, pending)
        assert got.tobytes() == expected.tobytes(), (low, high, pending, run, pos)

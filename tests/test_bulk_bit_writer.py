"""The encoder's bulk bit output (kernels/entropy_coding.py put_bits_local, put_repeated_local, renormalise_encoder,
finish_encoder) against the bit-at-a-time forms they replace: the same bytes and the same writer and coder state,
on random fields and coder states, zero runs that need emulation-prevention bits included."""
from __future__ import annotations

import numpy as np
import pytest

from kernels import entropy_coding as ec


def _per_bit(buffer, pos, run, value, n_bits):
    for shift in range(n_bits - 1, -1, -1):
        pos, run = ec.put_bit_local(buffer, pos, run, (value >> shift) & 1)
    return pos, run


def _renormalise_per_bit(buffer, pos, run, low, high, pending):
    """The renormalisation loop as it was, one settled bit at a time."""
    while True:
        if high < ec.HALF:
            bit = 0
        elif low >= ec.HALF:
            bit, low, high = 1, low - ec.HALF, high - ec.HALF
        elif low >= ec.QUARTER and high < ec.THREE_QUARTERS:
            pending += 1
            low, high = (low - ec.QUARTER) << 1, ((high - ec.QUARTER) << 1) | 1
            continue
        else:
            break
        pos, run = ec.put_bit_local(buffer, pos, run, bit)
        for _ in range(pending):
            pos, run = ec.put_bit_local(buffer, pos, run, 1 - bit)
        pending = 0
        low, high = low << 1, (high << 1) | 1
    return pos, run, low, high, pending


def _fields(rng, n):
    """Random (value, n_bits) fields, a third of them zero (long zero runs)."""
    for _ in range(n):
        n_bits = int(rng.integers(0, 40))
        value = 0 if rng.random() < 0.35 else int(rng.integers(0, 1 << n_bits)) if n_bits else 0
        yield value, n_bits


@pytest.mark.parametrize("seed", range(4))
def test_put_bits_local_writes_what_put_bit_local_writes(seed):
    rng = np.random.default_rng(seed)
    bulk, single = np.zeros(4096, np.uint8), np.zeros(4096, np.uint8)
    state_bulk = state_single = (int(rng.integers(0, 8)), 0)
    stuffed = 0
    for value, n_bits in _fields(rng, 600):
        if rng.random() < 0.1:                                   # a run of one repeated bit
            bit, count = int(rng.integers(0, 2)), int(rng.integers(0, 70))
            state_bulk = ec.put_repeated_local(bulk, *state_bulk, bit, count)
            state_single = _per_bit(single, *state_single, (1 << count) - 1 if bit else 0, count)
        else:
            before = state_single[0]
            state_bulk = ec.put_bits_local(bulk, *state_bulk, value, n_bits)
            state_single = _per_bit(single, *state_single, value, n_bits)
            stuffed += state_single[0] - before - n_bits
        assert tuple(state_bulk) == tuple(state_single)
    assert bulk.tobytes() == single.tobytes()
    assert stuffed > 0                                            # emulation prevention was exercised


@pytest.mark.parametrize("seed", range(4))
def test_bulk_renormalisation_and_flush_match_the_bit_loop(seed):
    rng = np.random.default_rng(100 + seed)
    bulk, single = np.zeros(1 << 16, np.uint8), np.zeros(1 << 16, np.uint8)
    pos_run = (0, 0)
    for _ in range(3000):
        low = int(rng.integers(0, ec.TOP))
        width = int(rng.choice([1, 2, 7, 1 << 10, 1 << 20, 1 << 29, 1 << 31]))
        high = min(low + int(rng.integers(0, width)), ec.TOP)
        if rng.random() < 0.2:                                   # the underflow case: 01... and 10...
            low = ec.QUARTER + int(rng.integers(0, ec.QUARTER))
            high = ec.HALF + int(rng.integers(0, ec.QUARTER))
        pending = int(rng.integers(0, 40)) if rng.random() < 0.5 else 0
        got = ec.renormalise_encoder(bulk, *pos_run, low, high, pending)
        want = _renormalise_per_bit(single, *pos_run, low, high, pending)
        assert tuple(got) == tuple(want)
        if rng.random() < 0.1:
            got_end = ec.finish_encoder(bulk, got[0], got[1], got[2], got[4])
            want_end = _per_bit(single, want[0], want[1], 0 if want[2] < ec.QUARTER else 1, 1)
            bit = 0 if want[2] < ec.QUARTER else 1
            want_end = _per_bit(single, *want_end, (1 << (want[4] + 1)) - 1 if not bit else 0, want[4] + 1)
            assert tuple(got_end) == tuple(want_end)
            pos_run = got_end
        else:
            pos_run = got[:2]
        if pos_run[0] > 8 * (len(bulk) - 256):
            break
    assert bulk.tobytes() == single.tobytes()

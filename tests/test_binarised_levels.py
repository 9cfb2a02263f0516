"""The binarised level coder (comparisons/params/binarised_levels.py): exact round trip, cost within 3 % of the
zero-order empirical entropy on the FBA predictive coder's Q 1 residuals of a real clip (where one multi-symbol
adaptive model pays far more), and one-line errors on damaged data."""
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from comparisons.params import bap_table
from comparisons.params import coding as pc
from comparisons.params.binarised_levels import MAX_BUCKET, decode_levels, encode_levels
from comparisons.params.entropy import empirical_entropy_bits, encode_sequence
from comparisons.params.fba import _changed_mask, coded_order
from media.errors import SigncastError

DATA = Path(__file__).resolve().parent / "data"


def hello_residuals(q: int) -> np.ndarray:
    """P-frame residual levels (frame by frame) of the FBA predictive coder on ASL HELLO's BAPs (84 frames)."""
    with np.load(DATA / "fba_bap_clips.npz") as clips:
        values = clips["ase_HELLO_25fps"].astype(np.int64)
    steps = bap_table.steps() * q
    held = np.zeros(bap_table.N_BAPS, dtype=np.int64)
    order = coded_order(_changed_mask(values, held, steps))
    _, p_levels, _ = pc.predictive_levels(values[:, order], held[order], steps[order], q)
    return p_levels.ravel()


@settings(max_examples=60, deadline=None)
@given(st.lists(st.integers(-(1 << (MAX_BUCKET + 1)) + 1, (1 << (MAX_BUCKET + 1)) - 1), max_size=300))
def test_any_levels_round_trip_exactly(levels):
    assert decode_levels(encode_levels(np.array(levels, dtype=np.int64))).tolist() == levels


@pytest.mark.parametrize("q", [1, 8])
def test_real_residuals_cost_within_3_percent_of_their_entropy(q):
    levels = hello_residuals(q)
    entropy = empirical_entropy_bits(levels)
    binarised = 8 * len(encode_levels(levels)) - 32
    symbols = levels - levels.min()
    one_model = 8 * len(encode_sequence(symbols, int(symbols.max()) + 1, 4)) - 32
    assert np.array_equal(decode_levels(encode_levels(levels)), levels)
    assert binarised <= 1.03 * entropy < one_model


def test_damaged_data_is_refused_in_one_line():
    data = encode_levels(hello_residuals(8))
    with pytest.raises(SigncastError, match="trailing|ends at byte"):
        decode_levels(data + b"\x00\x00")
    with pytest.raises(SigncastError):
        decode_levels(data[:len(data) // 2])
    with pytest.raises(SigncastError, match="impossible count"):
        decode_levels(b"\xff\xff\xff\xff" + data[4:])
    with pytest.raises(SigncastError, match="truncated"):
        decode_levels(b"\x00")
    with pytest.raises(SigncastError, match="within"):
        encode_levels(np.array([1 << (MAX_BUCKET + 1)]))

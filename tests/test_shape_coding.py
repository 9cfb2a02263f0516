"""Binary shape coding: lossless round trip, mode use, and rejection of damaged streams."""
import numpy as np
import pytest

from comparisons.shape_coding import (BinaryArithmeticDecoder, BinaryArithmeticEncoder, decode_shape,
                                      encode_shape)
from media.errors import SigncastError


def moving_ellipses(frames=8, height=40, width=56, seed=0):
    """A head-like ellipse drifting right and a small 'hand' ellipse moving down, with a ragged edge."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[:height, :width]
    masks = np.zeros((frames, height, width), bool)
    for t in range(frames):
        head = ((yy - 18) / 11.0) ** 2 + ((xx - 16 - 2 * t) / 8.0) ** 2 <= 1.0
        hand = ((yy - 6 - 3 * t) / 4.0) ** 2 + ((xx - 44) / 5.0) ** 2 <= 1.0
        masks[t] = head | hand
        edge = rng.random((height, width)) < 0.05
        masks[t] ^= edge & (np.abs(((yy - 18) / 11.0) ** 2 + ((xx - 16 - 2 * t) / 8.0) ** 2 - 1.0) < 0.2)
    return masks


def test_arithmetic_coder_round_trips_skewed_and_raw_bits():
    rng = np.random.default_rng(1)
    bits = (rng.random(5000) < 0.1).astype(int).tolist()
    raws = rng.integers(0, 1 << 7, 50).tolist()
    encoder = BinaryArithmeticEncoder(n_contexts=4)
    for bit in bits:
        encoder.code(bit & 1, bit)
    for value in raws:
        encoder.code_raw(value, 7)
    payload = encoder.finish()
    decoder = BinaryArithmeticDecoder(payload, n_contexts=4)
    assert [decoder.code(b & 1) for b in bits] == bits
    assert [decoder.code_raw(0, 7) for _ in raws] == raws
    # adaptive probabilities make a 10 % source cost well under 1 bit per symbol (entropy ~0.47)
    assert len(payload) * 8 < 0.62 * len(bits) + 7 * len(raws)


def test_shape_round_trip_is_bit_exact_and_uses_inter_modes():
    masks = moving_ellipses()
    stream, stats = encode_shape(masks, gop=12)
    assert np.array_equal(decode_shape(stream), masks)
    assert stats.n_bytes == len(stream)
    assert stats.mode_counts["intra_cae"] > 0
    assert stats.mode_counts["inter_cae"] + stats.mode_counts["copy"] > 0
    assert stats.mode_counts["transparent"] > 0


def test_shape_round_trip_with_odd_size_empty_and_full_frames():
    masks = np.zeros((5, 21, 35), bool)
    masks[1] = True
    masks[3, 4:15, 30:] = True
    masks[4, 0, 0] = True
    stream, stats = encode_shape(masks, gop=2)
    assert np.array_equal(decode_shape(stream), masks)
    assert stats.mode_counts["opaque"] == 2  # the two whole 16x16 blocks inside 21x35


def test_static_shape_costs_little_after_the_first_frame():
    still = np.repeat(moving_ellipses(frames=1), 12, axis=0)
    one = len(encode_shape(still[:1])[0])
    twelve = len(encode_shape(still)[0])
    assert twelve < one + 11 * 8  # repeated frames cost a few bytes each (copy mode), not a new intra frame


def test_shape_decoder_rejects_truncated_corrupt_and_foreign_streams():
    stream, _ = encode_shape(moving_ellipses(frames=3))
    with pytest.raises(SigncastError, match="truncated"):
        decode_shape(stream[:-3])
    with pytest.raises(SigncastError, match="truncated"):
        decode_shape(stream[:10])
    damaged = bytearray(stream)
    damaged[len(stream) // 2] ^= 0x40
    with pytest.raises(SigncastError, match="corrupt"):
        decode_shape(bytes(damaged))
    with pytest.raises(SigncastError, match="magic"):
        decode_shape(b"XXXX" + stream[4:])


def test_shape_encoder_rejects_bad_input():
    with pytest.raises(SigncastError):
        encode_shape(np.zeros((4, 4), bool))
    with pytest.raises(SigncastError):
        encode_shape(np.zeros((2, 8, 8), bool), gop=0)

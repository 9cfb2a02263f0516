"""Binary shape coding: lossless round trip, mode use, and rejection of damaged streams."""
import numpy as np
import pytest

from comparisons.video.shape import (MAX_PIXELS, MAX_SIDE, BinaryArithmeticDecoder, BinaryArithmeticEncoder,
                                      decode_shape, encode_shape)
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


def with_header_bytes(stream: bytes, changes: dict[int, int]) -> bytes:
    damaged = bytearray(stream)
    for position, value in changes.items():
        damaged[position] = value
    return bytes(damaged)


def recrc(stream: bytes) -> bytes:
    """A crafted stream: the header CRC (bytes 18..21) recomputed over header fields and payload."""
    import struct
    import zlib
    return stream[:18] + struct.pack(">I", zlib.crc32(stream[22:], zlib.crc32(stream[:18]))) + stream[22:]


def test_damaged_frame_count_is_caught_by_the_header_crc():
    """Byte 12 is the low byte of the frame count: set to 1, a 10-frame stream used to decode as 1 frame."""
    stream, _ = encode_shape(moving_ellipses(frames=10))
    with pytest.raises(SigncastError, match="CRC mismatch"):
        decode_shape(with_header_bytes(stream, {12: 1}))


def test_huge_frame_count_is_caught_before_allocating():
    """Byte 10 = 179 announces 11.7 million frames: an 83.9 GiB allocation (MemoryError) before the fix."""
    stream, _ = encode_shape(moving_ellipses(frames=10))
    damaged = with_header_bytes(stream, {10: 179})
    with pytest.raises(SigncastError, match="CRC mismatch"):
        decode_shape(damaged)
    with pytest.raises(SigncastError, match=f"exceed the limit of {MAX_PIXELS} mask pixels"):
        decode_shape(recrc(damaged))


def test_huge_frame_size_is_caught_before_allocating():
    """Width 65535 x height 4096 in the header used to allocate 4.2 GB for 10 s before the payload failed."""
    stream, _ = encode_shape(moving_ellipses(frames=10))
    damaged = with_header_bytes(stream, {5: 0xFF, 6: 0xFF, 7: 0x10, 8: 0x00})
    with pytest.raises(SigncastError, match="CRC mismatch"):
        decode_shape(damaged)
    with pytest.raises(SigncastError, match=f"outside 1..{MAX_SIDE} pixels a side"):
        decode_shape(recrc(damaged))


def test_shape_size_limits_hold_at_both_ends_and_keep_decoded_masks_small():
    assert MAX_PIXELS <= 2 ** 28  # decoded (T, H, W) bool masks: at most 256 MiB
    masks = moving_ellipses(frames=2)
    assert np.array_equal(decode_shape(recrc(encode_shape(masks)[0])), masks)  # recrc reproduces the CRC
    with pytest.raises(SigncastError, match="pixels a side"):
        encode_shape(np.zeros((1, 8, MAX_SIDE + 1), bool))
    with pytest.raises(SigncastError, match="mask pixels"):
        encode_shape(np.broadcast_to(np.zeros((1, 16, 16), bool), (MAX_PIXELS // 256 + 1, 16, 16)))


def test_version_1_stream_is_rejected_with_a_clear_message():
    stream, _ = encode_shape(moving_ellipses(frames=2))
    with pytest.raises(SigncastError, match="version 1 streams, whose header is outside the CRC"):
        decode_shape(with_header_bytes(stream, {4: 1}))


def test_payload_that_ends_early_is_rejected_while_decoding():
    """A valid header announcing more frames than the payload holds: the decoder stops where the payload
    (and its 32-bit read-ahead) ends, not after decoding all announced frames from zeros."""
    import struct
    stream, _ = encode_shape(np.ones((3, 64, 64), bool), gop=255)
    crafted = recrc(stream[:9] + struct.pack(">I", MAX_PIXELS // (64 * 64)) + stream[13:])
    with pytest.raises(SigncastError, match="payload ends before the last frame"):
        decode_shape(crafted)


@pytest.mark.parametrize("shape_error", [0.5, 1.0, 3.0])
def test_lossy_shape_decodes_to_the_encoders_masks_within_the_stated_error(shape_error):
    masks = moving_ellipses(frames=12, height=60, width=75, seed=3)   # BABs past the right and bottom edges
    lossless, _ = encode_shape(masks, gop=6)
    stream, stats = encode_shape(masks, gop=6, shape_error=shape_error)
    decoded = decode_shape(stream)
    assert np.array_equal(decoded, stats.reconstruction)    # the decoder reproduces the encoder bit for bit
    wrong = (decoded != masks).sum(axis=(1, 2))
    # the decoder's masks are the encoder's: the wrong pixels it reports are those the decoder gives
    assert int(wrong.sum()) == stats.error_pixels and stats.object_pixels == int(masks.sum())
    # every frame within its budget, so the clip too
    assert np.all(wrong <= np.floor(shape_error / 100 * masks.sum(axis=(1, 2))))
    assert 0 < stats.shape_error <= shape_error
    assert len(stream) < len(lossless)


def test_shape_error_zero_is_lossless_and_out_of_range_is_refused():
    masks = moving_ellipses(frames=4)
    stream, stats = encode_shape(masks, gop=4, shape_error=0.0)
    assert stream == encode_shape(masks, gop=4)[0] and stats.error_pixels == 0
    for bad in (-0.1, 10.5):
        with pytest.raises(SigncastError, match="shape error"):
            encode_shape(masks, shape_error=bad)


def test_damaged_lossy_shape_stream_is_rejected():
    stream, _ = encode_shape(moving_ellipses(frames=6), gop=6, shape_error=2.0)
    damaged = bytearray(stream)
    damaged[len(stream) // 2] ^= 0x10
    with pytest.raises(SigncastError, match="CRC"):
        decode_shape(bytes(damaged))


def test_default_version_keeps_the_shorter_of_versions_3_and_4():
    masks = moving_ellipses(frames=6)
    boxed, trained = encode_shape(masks, version=3)[0], encode_shape(masks, version=4)[0]
    chosen = encode_shape(masks)[0]
    assert len(chosen) == min(len(boxed), len(trained)) and chosen in (boxed, trained)
    for stream in (boxed, trained, encode_shape(masks, version=2)[0]):
        assert np.array_equal(decode_shape(stream), masks)
    with pytest.raises(SigncastError, match="version"):
        encode_shape(masks, version=6)


# ---------------------------------------------------------------------------------- version 5: size conversion

def rendered_signer(frames=8):
    """(frames, 144, 176) bool signer masks of ASL "AB", rendered by the NumPy backend (label buffer)."""
    from media.avatar import load_avatar
    from media.fingerspelling import fingerspell
    from media.render import AvatarRenderer, RenderSettings

    renderer = AvatarRenderer(load_avatar(), RenderSettings(width=176, height=144, backend="numpy"))
    labels = []
    for _, frame_labels in renderer.frames(fingerspell("ase", "AB")):
        labels.append(frame_labels)
        if len(labels) == frames:
            break
    return np.isin(np.stack(labels), (1, 2, 3, 4))


@pytest.fixture(scope="module")
def signer_masks():
    return rendered_signer()


@pytest.mark.parametrize("shape_error", [0.5, 1.0, 3.0])
def test_version_5_decodes_to_the_encoders_masks_within_the_stated_error(shape_error):
    masks = moving_ellipses(frames=12, height=60, width=75, seed=3)   # BABs past the right and bottom edges
    stream, stats = encode_shape(masks, gop=6, shape_error=shape_error, version=5)
    assert stream[4] == 5 and stats.cr_counts is not None
    decoded = decode_shape(stream)
    assert np.array_equal(decoded, stats.reconstruction)
    wrong = (decoded != masks).sum(axis=(1, 2))
    assert int(wrong.sum()) == stats.error_pixels
    assert np.all(wrong <= np.floor(shape_error / 100 * masks.sum(axis=(1, 2))))
    assert stats.shape_error <= shape_error
    coded = stats.mode_counts["intra_cae"] + stats.mode_counts["inter_cae"]
    assert sum(stats.cr_counts.values()) == coded    # one CR per coded BAB


def test_version_5_uses_size_conversion_on_rendered_masks_and_decodes_exactly(signer_masks):
    for shape_error in (1.0, 3.0):
        stream, stats = encode_shape(signer_masks, gop=4, shape_error=shape_error, version=5)
        decoded = decode_shape(stream)
        assert np.array_equal(decoded, stats.reconstruction)
        assert 100.0 * (decoded != signer_masks).sum() / signer_masks.sum() <= shape_error
        assert stats.cr_counts["1/2"] + stats.cr_counts["1/4"] > 0, stats.cr_counts
    # the default keeps the shortest of versions 3, 4 and 5 when the shape may be lossy
    chosen = encode_shape(signer_masks, gop=4, shape_error=3.0)[0]
    assert len(chosen) <= len(stream) and chosen[4] in (3, 4, 5)


def test_damaged_version_5_stream_is_rejected(signer_masks):
    stream, _ = encode_shape(signer_masks[:4], gop=4, shape_error=3.0, version=5)
    for position in (5, 14, len(stream) // 2, len(stream) - 1):
        damaged = bytearray(stream)
        damaged[position] ^= 0x21
        with pytest.raises(SigncastError, match="CRC|truncated|corrupt"):
            decode_shape(bytes(damaged))
    for cut in (10, len(stream) // 2, len(stream) - 1):
        with pytest.raises(SigncastError, match="truncated"):
            decode_shape(stream[:cut])
    # a damaged payload under a recomputed CRC: a SigncastError or masks of the announced size, never a crash
    rng = np.random.default_rng(5)
    for _ in range(20):
        damaged = bytearray(stream)
        damaged[int(rng.integers(22, len(stream)))] ^= int(rng.integers(1, 256))
        try:
            decoded = decode_shape(recrc(bytes(damaged)))
        except SigncastError:
            continue
        assert decoded.shape == signer_masks[:4].shape


def test_lossless_streams_stay_versions_3_and_4_and_version_5_is_lossy_only():
    masks = moving_ellipses(frames=6)
    lossless = encode_shape(masks)[0]
    assert lossless[4] in (3, 4)
    assert lossless == min((encode_shape(masks, version=v)[0] for v in (3, 4)), key=len)
    assert encode_shape(masks, shape_error=0.0)[0] == lossless
    with pytest.raises(SigncastError, match="version 5 .* lossy shape only"):
        encode_shape(masks, shape_error=0.0, version=5)
    # a lossy stream without size conversion (version 4) still reads
    stream, stats = encode_shape(masks, gop=6, shape_error=1.0, version=4)
    assert np.array_equal(decode_shape(stream), stats.reconstruction) and stats.cr_counts is None

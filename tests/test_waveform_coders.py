"""Waveform coders of seed 002 ch. 7: exact decoders, rate/quality trends, clean failures."""
import numpy as np
import pytest

from comparisons.lab.streams import (StreamReader, StreamWriter, from_magnitude_classes, magnitude_classes,
                                       pack_bits, unpack_bits)
from comparisons.lab.waveform import (WAVEFORM_CODERS, DeadReckoningCoder, UniformQuantizer, haar_forward,
                                         haar_inverse)
from media.errors import SigncastError
from motion_samples import FPS, psnr, signing_like

LOWER, UPPER = np.full(5, -1.6), np.full(5, 1.6)


@pytest.mark.parametrize("name", sorted(WAVEFORM_CODERS))
def test_decoder_reproduces_encoder_reconstruction_exactly_and_quality_rises_with_q(name):
    dofs = signing_like()
    coder = WAVEFORM_CODERS[name](LOWER, UPPER)
    results = []
    for q in (0, len(coder.settings) - 1):
        data, recon = coder.encode(dofs, FPS, q)
        decoded, fps = coder.decode_with_fps(data)
        assert fps == FPS
        assert decoded.shape == dofs.shape
        assert np.array_equal(decoded, recon)
        results.append((len(data), psnr(dofs, recon)))
    (bytes_low, psnr_low), (bytes_high, psnr_high) = results
    assert bytes_high > bytes_low
    assert psnr_high > psnr_low + 10.0
    assert psnr_high > 35.0


@pytest.mark.parametrize("name", sorted(WAVEFORM_CODERS))
def test_corrupt_or_truncated_stream_raises_signcast_error(name):
    coder = WAVEFORM_CODERS[name](LOWER, UPPER)
    data, _ = coder.encode(signing_like(60), FPS, 1)
    damaged = bytearray(data)
    damaged[len(data) // 2] ^= 0x5A
    for bad in (bytes(damaged), data[:-3], data[: len(data) // 2], b"", b"SCM1" + bytes(30)):
        with pytest.raises(SigncastError):
            coder.decode(bad)


def test_stream_of_another_coder_is_rejected():
    data, _ = WAVEFORM_CODERS["dpcm"](LOWER, UPPER).encode(signing_like(40), FPS, 1)
    with pytest.raises(SigncastError, match="coder id"):
        WAVEFORM_CODERS["adpcm"](LOWER, UPPER).decode(data)


def test_bad_input_and_q_raise_signcast_error():
    coder = WAVEFORM_CODERS["dct"](LOWER, UPPER)
    dofs = signing_like(40)
    with pytest.raises(SigncastError):
        coder.encode(dofs[:, :3], FPS, 0)
    broken = dofs.copy()
    broken[3, 1] = np.nan
    with pytest.raises(SigncastError):
        coder.encode(broken, FPS, 0)
    with pytest.raises(SigncastError):
        coder.encode(dofs, FPS, 99)
    with pytest.raises(SigncastError):
        WAVEFORM_CODERS["quant"](UPPER, LOWER)


def test_uniform_quantizer_error_is_within_half_a_step():
    dofs = signing_like()
    levels = 32
    coder = UniformQuantizer(LOWER, UPPER)
    _, recon = coder.encode(dofs, FPS, coder.settings.index(levels))
    assert np.max(np.abs(recon - dofs)) <= (UPPER - LOWER)[0] / levels / 2 + 1e-12


def test_dead_reckoning_error_never_exceeds_its_threshold():
    dofs = signing_like()
    coder = DeadReckoningCoder(LOWER, UPPER)
    for q in (0, 3):
        _, recon = coder.encode(dofs, FPS, q)
        assert np.max(np.abs(recon - dofs)) <= np.radians(coder.settings[q]) + 1e-9


def test_dpcm_with_eight_levels_matches_sixty_four_level_direct_quantization():
    """Seed 002 §7.5: 8-level DPCM has about the error of 64-level direct quantisation, at a lower rate."""
    dofs = signing_like(250)
    dpcm = WAVEFORM_CODERS["dpcm"](LOWER, UPPER)
    quant = WAVEFORM_CODERS["quant"](LOWER, UPPER)
    dpcm_bytes, dpcm_recon = dpcm.encode(dofs, FPS, dpcm.settings.index(8))
    quant_bytes, quant_recon = quant.encode(dofs, FPS, quant.settings.index(64))
    assert psnr(dofs, dpcm_recon) > psnr(dofs, quant_recon) - 6.0
    assert len(dpcm_bytes) < len(quant_bytes)


@pytest.mark.parametrize("stage", ["arithmetic", "huffman", "fixed"])
def test_every_entropy_stage_round_trips(stage):
    dofs = signing_like(80)
    coder = WAVEFORM_CODERS["dpcm"](LOWER, UPPER, stage=stage)
    data, recon = coder.encode(dofs, FPS, 2)
    assert np.array_equal(coder.decode(data), recon)


def test_entropy_coding_shortens_the_fixed_length_code():
    dofs = signing_like(200)
    sizes = {stage: len(WAVEFORM_CODERS["dpcm"](LOWER, UPPER, stage=stage).encode(dofs, FPS, 3)[0])
             for stage in ("fixed", "huffman", "arithmetic")}
    assert sizes["arithmetic"] < sizes["fixed"]
    assert sizes["huffman"] < sizes["fixed"]


def test_bit_packing_and_magnitude_classes_round_trip():
    rng = np.random.default_rng(3)
    widths = rng.integers(0, 20, size=200)
    values = rng.integers(0, 1 << 20, size=200) % np.left_shift(1, widths)
    assert np.array_equal(unpack_bits(pack_bits(values, widths), widths), values)
    widths = np.array([57, 0, 3, 40, 1, 57, 7])  # the widest values, unaligned
    values = np.array([(1 << 57) - 1, 0, 5, (1 << 40) - 2, 1, 1 << 56, 0x55])
    assert np.array_equal(unpack_bits(pack_bits(values, widths), widths), values)
    signed = np.concatenate([[0, 1, -1, 2, -2, 1023, -1024], rng.integers(-10**9, 10**9, size=100)])
    classes, mantissa, mantissa_widths = magnitude_classes(signed)
    assert np.array_equal(classes, [int(abs(v)).bit_length() for v in signed])
    assert np.array_equal(from_magnitude_classes(classes, mantissa), signed)


def test_container_sections_read_back_in_order():
    writer = StreamWriter(7, 3, 10, 2, 30.0)
    writer.header(b"side info")
    writer.symbols(np.array([0, 4, 4, 1]), 5)
    writer.signed(np.array([-5, 0, 12]))
    reader = StreamReader(writer.finish(), 7, "test")
    assert (reader.info.q, reader.info.n_frames, reader.info.n_dofs, reader.info.fps) == (3, 10, 2, 30.0)
    assert reader.header() == b"side info"
    assert reader.symbols(5, 4).tolist() == [0, 4, 4, 1]
    assert reader.signed(20, at_most=True).tolist() == [-5, 0, 12]
    reader.finish()


def test_section_with_more_symbols_than_the_reader_allows_is_rejected():
    writer = StreamWriter(7, 3, 10, 2, 30.0)
    writer.signed(np.array([-5, 0, 12]))
    data = writer.finish()
    for count, at_most in ((2, True), (2, False), (4, False)):
        with pytest.raises(SigncastError, match="does not match the coder's layout"):
            StreamReader(data, 7, "test").signed(count, at_most=at_most)


def test_arithmetic_stage_stops_where_its_data_ends_whatever_count_is_claimed():
    """An adaptive arithmetic decoder can turn no data into symbols for ever; it stops once it has read
    further past the end than its register's read-ahead (it used to decode all MAX_VALUES symbols first)."""
    from comparisons.lab.streams import MAX_VALUES, entropy_stage
    arithmetic = entropy_stage("arithmetic")
    coded = arithmetic.encode(np.arange(100) % 41, 41)
    assert np.array_equal(arithmetic.decode(coded, 100, 41), np.arange(100) % 41)
    for data in (b"", coded):
        with pytest.raises(SigncastError, match="ends before its symbols do"):
            arithmetic.decode(data, MAX_VALUES, 41)


def test_haar_transform_is_orthonormal_and_invertible():
    rng = np.random.default_rng(1)
    blocks = rng.standard_normal((3, 4, 16))
    bands = haar_forward(blocks)
    assert np.allclose(haar_inverse(bands), blocks)
    energy = sum(np.sum(b ** 2) for b in bands)
    assert np.isclose(energy, np.sum(blocks ** 2))


def test_huffman_stage_never_lengthens_the_fixed_length_code():
    """Seed 002 §7.4: on a few symbols the code table would cost more than it saves; the stage then
    falls back to fixed-length codes (one flag bit)."""
    from comparisons.lab.streams import entropy_stage
    huffman, fixed = entropy_stage("huffman"), entropy_stage("fixed")
    for symbols, alphabet in ((np.array([3, 900, 17]), 1024), (np.arange(64) % 7, 8), (np.zeros(500, int), 256)):
        coded = huffman.encode(symbols, alphabet)
        assert len(coded) <= len(fixed.encode(symbols, alphabet)) + 1
        assert np.array_equal(huffman.decode(coded, len(symbols), alphabet), symbols)


def test_crafted_header_with_an_impossible_frame_count_is_rejected_before_allocating():
    import struct
    import zlib
    coder = WAVEFORM_CODERS["dpcm"](LOWER, UPPER)
    data, _ = coder.encode(signing_like(30), FPS, 1)
    body = bytearray(data[:-4])
    body[7:11] = struct.pack("<I", 3_000_000_000)  # T field of the header
    crafted = bytes(body) + struct.pack("<I", zlib.crc32(bytes(body)))
    with pytest.raises(SigncastError, match="impossible header"):
        coder.decode(crafted)


def test_streams_are_bounded_in_frames_times_dofs_at_both_ends():
    """T <= MAX_FRAMES alone let a header announce 2**18 frames x 65535 DOFs; T x D is now bounded too."""
    import struct
    import zlib
    from comparisons.lab.streams import MAX_FRAMES, MAX_VALUES
    wide = 32  # MAX_FRAMES x 32 DOFs > MAX_VALUES
    assert MAX_FRAMES * wide > MAX_VALUES and MAX_VALUES * 8 <= 32 * 2 ** 20  # (T, D) float64 <= 32 MiB
    coder = UniformQuantizer(np.full(wide, -1.0), np.full(wide, 1.0))
    data, recon = coder.encode(np.zeros((10, wide)), FPS, 0)
    assert np.array_equal(coder.decode(data), recon)
    body = bytearray(data[:-4])
    body[7:11] = struct.pack("<I", MAX_FRAMES)  # T field: allowed alone, too many values with 32 DOFs
    crafted = bytes(body) + struct.pack("<I", zlib.crc32(bytes(body)))
    with pytest.raises(SigncastError, match="frames x channels"):
        coder.decode(crafted)
    with pytest.raises(SigncastError, match="frames x channels"):
        StreamWriter(1, 0, MAX_VALUES // wide + 1, wide, FPS)


def test_frame_rate_beyond_the_limit_is_rejected_at_both_ends():
    """The header's fps (u32, milli-Hz) reached 4.3 MHz; ADPCM sizes its predictor window by it."""
    import struct
    import zlib
    from comparisons.lab.streams import MAX_FPS
    coder = WAVEFORM_CODERS["adpcm"](LOWER, UPPER)
    data, _ = coder.encode(signing_like(30), MAX_FPS, 1)
    assert coder.decode_with_fps(data)[1] == MAX_FPS
    body = bytearray(data[:-4])
    body[13:17] = struct.pack("<I", int(1000 * MAX_FPS) + 1)  # fps field of the header
    with pytest.raises(SigncastError, match="frame rate"):
        coder.decode(bytes(body) + struct.pack("<I", zlib.crc32(bytes(body))))
    with pytest.raises(SigncastError, match="fps"):
        coder.encode(signing_like(30), MAX_FPS * 2, 1)

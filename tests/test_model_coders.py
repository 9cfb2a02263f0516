"""Model-based coders of seed 002 ch. 8: segmentation, interpolation, exact decoders, Motion codecs."""
import functools
import numpy as np
import pytest

from comparisons.lab.model import (N_NORM, GestureCoder, HybridCoder, PostureCoder, gesture_boundaries, hermite_fill,
                                      posture_keys, raised_cosine, warp)
from comparisons.lab.vq import train_codebook
from media.errors import SigncastError
from motion_samples import FPS, psnr, signing_like

LOWER, UPPER = np.full(5, -1.6), np.full(5, 1.6)
GROUPS = [np.arange(3), np.arange(3, 5)]


def moves_with_pauses(n_moves: int = 6, move: int = 20, pause: int = 10, seed: int = 0):
    """(T, 3): smooth moves between random postures separated by still pauses; the pause centres."""
    rng = np.random.default_rng(seed)
    postures = rng.uniform(-1, 1, size=(n_moves + 1, 3))
    pieces, centres, t = [np.repeat(postures[:1], pause, axis=0)], [], pause
    for k in range(n_moves):
        f = np.arange(1, move + 1) / move
        s = f * f * (3 - 2 * f)
        pieces.append(postures[k] + (postures[k + 1] - postures[k]) * s[:, None])
        pieces.append(np.repeat(postures[k + 1:k + 2], pause, axis=0))
        t += move + pause
        centres.append(t - pause // 2)
    return np.concatenate(pieces), np.array(centres[:-1])


def test_posture_keys_follow_the_accumulated_change():
    x, _ = moves_with_pauses()
    coarse, fine = posture_keys(x, 1.0), posture_keys(x, 0.25)
    assert coarse[0] == 0 and coarse[-1] == len(x) - 1
    assert len(fine) > len(coarse)
    travelled = np.concatenate([[0], np.cumsum(np.linalg.norm(np.diff(x, axis=0), axis=1))])
    assert len(coarse) - 2 == int(travelled[-1] // 1.0) or len(coarse) - 2 == int(travelled[-1] // 1.0) - 1


def test_gesture_boundaries_fall_in_the_pauses_between_moves():
    x, centres = moves_with_pauses()
    bounds = gesture_boundaries(x, FPS, n_min=5, n_max=60)
    inner = bounds[1:-1]
    assert bounds[0] == 0 and bounds[-1] == len(x) - 1
    for centre in centres:
        assert np.min(np.abs(inner - centre)) <= 6  # one boundary in every pause
    assert len(inner) <= 2 * (len(centres) + 1)  # at most the start and end of each pause


def test_long_segments_are_split_to_at_most_n_max_frames():
    x = np.linspace(0, 3, 200)[:, None] * np.ones((1, 2))  # constant speed: no speed minimum
    bounds = gesture_boundaries(x, FPS, n_min=5, n_max=40)
    assert np.max(np.diff(bounds)) <= 40


def test_hermite_interpolation_passes_through_the_keys_and_raised_cosine_spans_one_to_zero():
    keys = np.array([0, 7, 15, 30])
    values = np.array([[0.0, 1.0], [1.0, 0.5], [0.2, -0.3], [0.4, 0.4]])
    filled = hermite_fill(keys, values, 31)
    assert np.allclose(filled[keys], values)
    w = raised_cosine(9)
    assert w[0] == 1.0 and abs(w[-1]) < 1e-12 and np.all(np.diff(w) <= 0)
    assert warp(np.arange(5.0)[:, None], 9)[:, 0] == pytest.approx(np.linspace(0, 4, 9))


@functools.cache
def tables():
    """Posture and gesture tables of other clips than the coded one (seeds 20..23)."""
    training = np.concatenate([signing_like(300, seed) for seed in range(20, 24)])
    postures = [train_codebook(training[:, g], 64) for g in GROUPS]
    gestures = []
    for g in GROUPS:
        bounds = gesture_boundaries(training[:, g], FPS, 4, 50)
        gestures.append(np.array([warp(training[a:b + 1][:, g], N_NORM) for a, b in zip(bounds[:-1], bounds[1:])]))
    return postures, gestures


@pytest.mark.parametrize("cls", [PostureCoder, GestureCoder, HybridCoder])
def test_model_coders_decode_exactly_and_reject_damage(cls):
    postures, gestures = tables()
    coder = cls(LOWER, UPPER, GROUPS, postures, gestures)
    dofs = signing_like(200, seed=0)
    for q in (0, len(coder.settings) - 1):
        data, recon = coder.encode(dofs, FPS, q)
        assert np.array_equal(coder.decode(data), recon)
        assert recon.shape == dofs.shape and np.all(np.isfinite(recon))
    damaged = bytearray(data)
    damaged[len(data) // 2] ^= 0x21
    for bad in (bytes(damaged), data[:-1], data[:20]):
        with pytest.raises(SigncastError):
            coder.decode(bad)


def test_model_coders_reach_far_lower_rates_than_direct_quantisation():
    from comparisons.lab.waveform import UniformQuantizer
    postures, gestures = tables()
    dofs = signing_like(400, seed=0)
    quant_bytes = len(UniformQuantizer(LOWER, UPPER).encode(dofs, FPS, 0)[0])
    for cls in (PostureCoder, GestureCoder):
        data, recon = cls(LOWER, UPPER, GROUPS, postures, gestures).encode(dofs, FPS, 0)
        assert len(data) < quant_bytes / 3
        assert psnr(dofs, recon) > 5.0


def test_hybrid_error_falls_with_finer_bit_allocation():
    postures, _ = tables()
    coder = HybridCoder(LOWER, UPPER, GROUPS, postures)
    dofs = signing_like(300, seed=0)
    coarse_bytes, coarse = coder.encode(dofs, FPS, 0)
    fine_bytes, fine = coder.encode(dofs, FPS, 7)
    assert len(fine_bytes) > len(coarse_bytes)
    assert psnr(dofs, fine) > psnr(dofs, coarse)


def _varint(value: int) -> bytes:
    out = bytearray()
    while value >= 0x80:
        out.append(value & 0x7F | 0x80)
        value >>= 7
    return bytes(out + bytes([value]))


def _with_key_count(data: bytes, count: int) -> tuple[bytes, int]:
    """The stream with the count field of its first section (the key-frame lags) replaced, CRC recomputed;
    and the count it held."""
    import struct
    import zlib
    body = data[:-4]
    header_size = 17  # "SCM1" coder stage q T(u32) D(u16) fps(u32)
    assert body[header_size:header_size + 2] == b"S" + _varint(41)  # magnitude classes of the lags
    start = header_size + 2
    end, original = start, 0
    while True:
        original |= (body[end] & 0x7F) << 7 * (end - start)
        end += 1
        if not body[end - 1] & 0x80:
            break
    body = body[:start] + _varint(count) + body[end:]
    return body + struct.pack("<I", zlib.crc32(body)), original


@pytest.mark.parametrize("cls", [PostureCoder, GestureCoder, HybridCoder])
def test_model_decoders_reject_a_key_count_beyond_the_clip_before_decoding_it(cls):
    """A crafted stream (valid CRC) whose key-lag section claims 2**56 symbols: the decoder used to trust the
    count and decode symbols out of no data for ever, its memory growing; the count is now bounded by the
    header's frame count."""
    postures, gestures = tables()
    coder = cls(LOWER, UPPER, GROUPS, postures, gestures)
    data, _ = coder.encode(signing_like(40), FPS, 0)
    crafted, original = _with_key_count(data, 2 ** 56)
    assert _with_key_count(data, original)[0] == data and len(crafted) == len(data) + 8
    with pytest.raises(SigncastError, match="at most 39 fit"):
        coder.decode(crafted)
    with pytest.raises(SigncastError, match="at most 39 fit"):
        coder.decode(_with_key_count(data, 40)[0])  # one lag more than 40 frames have


def test_lab_codec_bounds_frames_times_the_whole_dof_layout_at_both_ends():
    """The decoder returns (T, 183) layout DOFs even when one DOF is coded: T x 183 is bounded, checked
    from the inner header before decoding."""
    import struct
    import zlib
    from comparisons.lab.streams import MAX_VALUES
    from comparisons.lab.codecs import LabCodec, dof_layout
    codec, n_dofs = LabCodec("quant"), dof_layout().n_dofs
    too_long = MAX_VALUES // n_dofs + 1
    with pytest.raises(SigncastError, match="frames x channels"):
        codec.encode_dofs(np.zeros((too_long, n_dofs)), FPS, 0)  # calloc'd pages, never touched
    dofs = np.zeros((20, n_dofs))
    dofs[:, 0] = np.linspace(-0.1, 0.1, 20)
    data, recon = codec.encode_dofs(dofs, FPS, 0)
    assert np.array_equal(codec.decode_dofs(data)[0], recon)
    inner_start = 5 + -(-n_dofs // 8)
    inner = bytearray(data[inner_start:-4])
    inner[7:11] = struct.pack("<I", too_long)  # T field of the inner header, inner CRC recomputed
    body = data[:inner_start] + bytes(inner[:-4]) + struct.pack("<I", zlib.crc32(bytes(inner[:-4])))
    with pytest.raises(SigncastError, match="frames x channels"):
        codec.decode_dofs(body + struct.pack("<I", zlib.crc32(body)))


def test_model_coders_need_two_frames():
    postures, gestures = tables()
    with pytest.raises(SigncastError):
        PostureCoder(LOWER, UPPER, GROUPS, postures).encode(signing_like(1), FPS, 0)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["dpcm", "svq", "tvq", "posture", "gesture", "hybrid"])
def test_registered_codec_round_trips_a_fingerspelled_word(name):
    from comparisons.lab.codecs import LabCodec, dofs_motion, motion_dofs
    from comparisons.params.codecs import get_codec
    from media.fingerspelling import fingerspell

    motion = fingerspell("ase", "cab")
    codec = get_codec(name)
    data = codec.encode(motion, 2)
    decoded = codec.decode(data)
    assert decoded.n_frames == motion.n_frames and decoded.fps == motion.fps
    lab = LabCodec(name)
    _, recon = lab.encode_dofs(motion_dofs(motion), motion.fps, 1)
    expected = dofs_motion(recon, motion.fps)  # the decoder's DOFs in BAP units (1e-5 rad) -> rotations
    assert decoded.bone_names == expected.bone_names
    assert np.array_equal(decoded.rotations, expected.rotations)
    with pytest.raises(SigncastError):
        codec.decode(data[:-2])
    with pytest.raises(SigncastError):
        codec.encode(motion, 0)

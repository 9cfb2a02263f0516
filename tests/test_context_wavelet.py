"""The context-modelled wavelet coder (wavelet-cx): exact decoding, fewer bytes than wavelet, damage handling."""
from __future__ import annotations

import struct
import zlib

import numpy as np
import pytest
from motion_samples import FPS, signing_like

from comparisons.coded_streams import StreamReader, StreamWriter
from comparisons.waveform_coders import ContextWaveletCoder, WaveletCoder
from kernels import lab_context
from media.errors import SigncastError

LOWER, UPPER = np.full(5, -1.6), np.full(5, 1.6)


def _with_crc(body: bytes) -> bytes:
    return body + struct.pack("<I", zlib.crc32(body))


@pytest.mark.parametrize("n_frames", [1, 7, 16, 33, 150])
def test_decoder_reproduces_the_encoder_reconstruction_at_every_step(n_frames):
    dofs = signing_like(n_frames)
    coder = ContextWaveletCoder(LOWER, UPPER)
    for q in range(len(coder.settings)):
        data, recon = coder.encode(dofs, FPS, q)
        decoded, fps = coder.decode_with_fps(data)
        assert fps == FPS and np.array_equal(decoded, recon)
        error = np.abs(recon - dofs).max()
        assert error <= coder.settings[q] * 2.0  # orthonormal: at most step / 2 per coefficient, 16 of them


def test_fewer_bytes_than_wavelet_at_equal_steps_and_the_same_reconstruction_quality():
    dofs = signing_like(150)
    cx, plain = ContextWaveletCoder(LOWER, UPPER), WaveletCoder(LOWER, UPPER)
    for q in (2, 5, 8, 10):
        data_cx, recon_cx = cx.encode(dofs, FPS, q)
        data, recon = plain.encode(dofs, FPS, q)
        assert len(data_cx) < 0.95 * len(data)
        assert np.abs(recon_cx - dofs).mean() <= 1.01 * np.abs(recon - dofs).mean()


def test_still_dofs_cost_almost_nothing():
    moving = signing_like(100)
    dofs = np.concatenate([moving, np.full((100, 40), 0.3)], axis=1)
    coder_moving = ContextWaveletCoder(LOWER, UPPER)
    coder_all = ContextWaveletCoder(np.full(45, -1.6), np.full(45, 1.6))
    extra = len(coder_all.encode(dofs, FPS, 8)[0]) - len(coder_moving.encode(moving, FPS, 8)[0])
    assert extra < 40 * 5  # 40 still DOFs of 7 blocks: their first approximations and a few bits each


def test_kernel_round_trips_extreme_values_and_reports_a_short_buffer():
    rng = np.random.default_rng(1)
    limit = (1 << lab_context.MAX_CLASS) - 1
    coeffs = rng.integers(-limit, limit, size=(3, 4, 16)) >> rng.integers(0, 40, size=(3, 4, 16))
    coeffs[0, 0, :4] = [limit, -limit, 0, 1]
    small = np.zeros(8, dtype=np.uint8)
    needed = lab_context.encode(coeffs, small)
    assert needed > len(small)
    out = np.zeros(needed, dtype=np.uint8)
    assert lab_context.encode(coeffs, out) == needed
    decoded = np.zeros_like(coeffs)
    assert lab_context.decode(out, decoded) == 0
    assert np.array_equal(decoded, coeffs)
    assert lab_context.decode(out[:-1].copy(), np.zeros_like(coeffs)) == -1
    assert lab_context.decode(np.concatenate([out, np.zeros(1, np.uint8)]), np.zeros_like(coeffs)) == -1
    too_big = coeffs.copy()
    too_big[1, 1, 1] = limit + 1
    assert lab_context.encode(too_big, out) == -1


def test_values_beyond_the_coder_raise_signcast_error():
    dofs = signing_like(20)
    dofs[3, 2] = 1e12
    with pytest.raises(SigncastError):
        ContextWaveletCoder(LOWER, UPPER).encode(dofs, FPS, 10)


def test_random_damage_raises_signcast_error_or_decodes_to_the_declared_shape():
    """Bit flips and truncations of the payload, with the CRC made to match again (so the kernel and the
    section checks see them): SigncastError or a (T, 5) array, never another exception."""
    coder = ContextWaveletCoder(LOWER, UPPER)
    data, _ = coder.encode(signing_like(60), FPS, 6)
    body = data[:-4]
    rng = np.random.default_rng(7)
    rejected = 0
    for trial in range(400):
        damaged = bytearray(body)
        if trial % 3 == 0:
            damaged = damaged[:rng.integers(1, len(damaged))]
        else:
            for _ in range(rng.integers(1, 4)):
                damaged[rng.integers(0, len(damaged))] ^= 1 << int(rng.integers(0, 8))
        try:
            decoded = coder.decode(_with_crc(bytes(damaged)))
        except SigncastError:
            rejected += 1
            continue
        assert decoded.ndim == 2 and decoded.shape[1] == 5 and np.all(np.isfinite(decoded))  # a header field may change T
    assert rejected > 200
    for bad in (data[:-1], data[:len(data) // 2], b"", bytes(data[:-5]) + bytes([data[-5] ^ 1]) + data[-4:]):
        with pytest.raises(SigncastError):
            coder.decode(bad)


def test_a_section_claiming_another_count_is_rejected_before_allocating():
    writer = StreamWriter(ContextWaveletCoder.coder_id, 3, 20, 5, FPS)
    writer.parts += [b"C", b"\xff\xff\xff\xff\x0f", b"\x00"]
    reader = StreamReader(writer.finish(), ContextWaveletCoder.coder_id, "wavelet-cx")
    with pytest.raises(SigncastError, match="coefficients"):
        reader.context_coded(5, 2)

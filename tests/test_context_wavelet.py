"""The context-modelled wavelet coder (wavelet-cx): exact decoding, fewer bytes than wavelet, damage handling, and
its compact framing with trained priors (what LabCodec sends)."""
from __future__ import annotations

import dataclasses
import struct
import zlib
from pathlib import Path

import numpy as np
import pytest
from motion_samples import FPS, signing_like

from comparisons.lab import streams as coded_streams
from comparisons.lab import waveform as waveform_coders
from comparisons.lab.streams import StreamReader, StreamWriter
from comparisons.lab.waveform import ContextWaveletCoder, WaveletCoder
from comparisons.lab import context as lab_context
from media.errors import SigncastError

LOWER, UPPER = np.full(5, -1.6), np.full(5, 1.6)


def _with_crc(body: bytes) -> bytes:
    """A compact wavelet-cx body sealed as write_compact seals it: CRC-32 from the shipped priors' tag."""
    return body + struct.pack("<I", zlib.crc32(body, waveform_coders.context_priors().tag))


def _damaged(body: bytes, seed: int, trials: int = 400):
    """`trials` damaged copies of body, each with its CRC-32 made to match again: every third one truncated,
    the others with 1-3 flipped bits."""
    rng = np.random.default_rng(seed)
    for trial in range(trials):
        damaged = bytearray(body)
        if trial % 3 == 0:
            damaged = damaged[:rng.integers(1, len(damaged))]
        else:
            for _ in range(rng.integers(1, 4)):
                damaged[rng.integers(0, len(damaged))] ^= 1 << int(rng.integers(0, 8))
        yield _with_crc(bytes(damaged))


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
    rejected = 0
    for damaged in _damaged(body, seed=7):
        try:
            decoded = coder.decode(damaged)
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


# ---------------------------------------------------------------- compact framing (what LabCodec sends)

def _layout_clip(n_frames: int, seed: int = 0) -> np.ndarray:
    """(T, 183) layout DOFs: a signing-like clip on a few DOFs of each group, the rest at rest (0)."""
    from comparisons.lab.codecs import dof_layout
    dofs = np.zeros((n_frames, dof_layout().n_dofs))
    moving = signing_like(n_frames, seed)[:, :4] * 0.5
    columns = np.random.default_rng(seed).choice(dof_layout().n_dofs, size=(12, 4), replace=False)
    for k, cols in enumerate(columns):
        dofs[:, cols] = np.roll(moving, 3 * k, axis=0)
    return dofs


@pytest.mark.parametrize("n_frames, fps", [(1, 25.0), (10, 10.0), (33, 25.0), (40, 12.5)])
def test_lab_codec_sends_the_compact_layout_and_decodes_it_exactly(n_frames, fps):
    from comparisons.lab.codecs import LabCodec
    codec = LabCodec("wavelet-cx")
    dofs = _layout_clip(n_frames)
    for index in (0, 5, 10):
        data, recon = codec.encode_dofs(dofs, fps, index)
        assert data[:2] == coded_streams.COMPACT_MAGIC and data[2] == ContextWaveletCoder.coder_id
        decoded, got_fps = codec.decode_dofs(data)
        assert got_fps == fps and np.array_equal(decoded, recon)
        assert np.all(decoded[:, ~np.any(dofs != 0, axis=0)] == 0)


def _stored_clip(name: str = "ase_J_10fps") -> np.ndarray:
    """(T, 183) signing DOFs of a real clip (tests/data/param_codec_clips.npz, see tests/test_stream_identity.py)."""
    with np.load(Path(__file__).resolve().parent / "data" / "param_codec_clips.npz") as stored:
        return stored[f"{name}/dofs"]


def test_compact_framing_saves_the_container_bytes():
    """The SCL1 wrapper (magic, id, 23-byte mask, CRC) around the SCM1 stream (17-byte header, section header,
    CRC) against the compact stream on a real one-second 10 fps clip (ASL "J", 10 frames): 40 bytes fewer."""
    from comparisons.lab.codecs import LabCodec, dof_ranges
    dofs = _stored_clip()
    active = np.any(dofs != 0, axis=0)
    lower, upper = dof_ranges()
    for index in (0, 8):
        compact, _ = LabCodec("wavelet-cx").encode_dofs(dofs, 10.0, index)
        container, _ = ContextWaveletCoder(lower[active], upper[active]).encode(dofs[:, active], 10.0, index)
        assert len(compact) + 40 <= len(container) + 5 + 23 + 4


def test_fps_codes_round_trip_and_whole_rates_take_one_byte():
    for fps in (0.001, 1.0, 10.0, 12.5, 25.0, 29.97, 59.94, 1000.0):
        code = coded_streams.fps_code(fps)
        assert coded_streams._fps_of_code(code) == round(fps * 1000) / 1000
    assert coded_streams.fps_code(10.0) < 128 and coded_streams.fps_code(25.0) < 128
    for bad in (0.0, -1.0, 1000.5, float("nan")):
        with pytest.raises(SigncastError):
            coded_streams.fps_code(bad)


def test_compact_random_damage_raises_signcast_error_or_decodes_to_the_layout():
    """Bit flips and truncations anywhere (header and payload), the CRC made to match again so that the header
    bounds and the payload's end check see them: SigncastError or a (T, 183) finite array, nothing else."""
    assert _compact_damage_rejected(_layout_clip(30, seed=2), 7, seed=11, trials=400) > 200


def _compact_damage_rejected(dofs: np.ndarray, q: int, seed: int, trials: int) -> int:
    """Codes dofs (T, 183) at 10 fps and q, damages the stream `trials` times (CRC resealed): each decodes to a
    (T', 183) finite array at a valid fps or raises SigncastError. Returns how many raised."""
    from comparisons.lab.codecs import LabCodec, dof_layout
    codec = LabCodec("wavelet-cx")
    data, _ = codec.encode_dofs(dofs, 10.0, q)
    rejected = 0
    for damaged in _damaged(data[:-4], seed=seed, trials=trials):
        try:
            with np.errstate(all="ignore"):
                decoded, fps = codec.decode_dofs(damaged)
        except SigncastError:
            rejected += 1
            continue
        assert decoded.ndim == 2 and decoded.shape[1] == dof_layout().n_dofs and np.all(np.isfinite(decoded))
        assert 0.001 <= fps <= coded_streams.MAX_FPS
    return rejected
    for bad in (data[:-1], data[:len(data) // 2], b"", b"Sc", bytes(data[:-5]) + bytes([data[-5] ^ 1]) + data[-4:]):
        with pytest.raises(SigncastError):
            codec.decode_dofs(bad)


def test_a_compact_header_claiming_huge_sizes_is_rejected_before_allocating():
    from comparisons.lab.codecs import LabCodec
    codec = LabCodec("wavelet-cx")
    for frames_field in (b"\xff\xff\xff\xff\xff\xff\xff\xff\x7f", b"\x80\x80\x80\x80\x80\x80\x80\x80\x80\x01",
                         coded_streams._varint(coded_streams.MAX_FRAMES + 1), b"\x00"):
        head = coded_streams.COMPACT_MAGIC + bytes([ContextWaveletCoder.coder_id, 3]) + frames_field + b"\x14"
        with pytest.raises(SigncastError, match="header|frames"):
            codec.decode_dofs(_with_crc(head + b"\x00" * 8))
    head = coded_streams.COMPACT_MAGIC + bytes([ContextWaveletCoder.coder_id, 11, 10, 20])   # q 11 of 0..10
    with pytest.raises(SigncastError, match="operating point"):
        codec.decode_dofs(_with_crc(head + b"\x00" * 8))
    head = coded_streams.COMPACT_MAGIC + bytes([ContextWaveletCoder.coder_id - 1, 3, 10, 20])
    with pytest.raises(SigncastError, match="coder id"):
        codec.decode_dofs(_with_crc(head + b"\x00" * 8))


def test_shipped_priors_match_the_layout_and_help_on_short_clips():
    """The trained table is for the signing layout, and on a short clip its models beat untrained ones."""
    from comparisons.lab.codecs import dof_layout
    priors = waveform_coders.context_priors()
    with np.load(waveform_coders.PRIORS_PATH) as table:
        assert tuple(str(n) for n in table["dof_names"]) == dof_layout().names
        assert "training languages" in str(table["provenance"])
    dofs = signing_like(10)
    coded = ContextWaveletCoder(LOWER, UPPER)._coded(dofs, ContextWaveletCoder.settings[8])[1]
    sizes = []
    for probs, counts in ((priors.coeff_probs[8], priors.coeff_counts[8]),
                          lab_context.uniform_models(lab_context.N_CONTEXTS)):
        out = np.zeros(lab_context.payload_capacity(coded.size), dtype=np.uint8)
        state = lab_context.encoder_state()
        lab_context.code_coefficients(False, state, out, coded, probs.copy(), counts.copy(), np.zeros((0, 2), np.int64))
        sizes.append(lab_context.finish_encoder(state, out))
    assert sizes[0] < sizes[1]


@pytest.mark.parametrize("payload", [b"", b"\x07\xa4\xa2\x1bb", bytes(range(40))])
def test_decoding_stops_soon_after_the_payload_runs_out(payload):
    """A header may claim ~4 M coefficients for a 20-byte payload (a fuzzer found one): the decoder must stop
    once it has read MAX_OVERRUN bytes past the end instead of decoding the padding, and report damage."""
    data = np.frombuffer(payload, dtype=np.uint8).copy()
    coeffs = np.zeros((183, 1400, lab_context.BLOCK), dtype=np.int64)
    assert lab_context.decode(data, coeffs) == -1
    state = lab_context.decoder_state(data)
    probs, counts = lab_context.uniform_models(lab_context.N_CONTEXTS)
    lab_context.decode_coefficients(state, data, coeffs, probs, counts)
    assert state[lab_context.POS] <= len(data) + lab_context.MAX_OVERRUN + 1
    assert lab_context.finish_decoder(state, data) == -1


# ---------------------------------------------------------------- inter-DOF prediction (compact framing)

def _coupled_clip(n_frames: int, seed: int = 0) -> np.ndarray:
    """(T, 183) layout DOFs in which every DOF the shipped priors predict moves with its source as the trained
    weight says (plus a small independent motion), and the sources move like signing."""
    priors = waveform_coders.context_priors()
    dofs = np.zeros((n_frames, priors.n_layout))
    moving = signing_like(n_frames, seed)
    rng = np.random.default_rng(seed)
    for d in range(priors.n_layout):
        source = priors.predictor[d]
        if source >= 0:
            if not dofs[:, source].any():
                dofs[:, source] = 0.5 * moving[:, source % moving.shape[1]]
            scale = priors.weight[d] / (1 << waveform_coders.PREDICTION_SHIFT)
            dofs[:, d] = scale * dofs[:, source] + 0.02 * np.roll(moving[:, d % moving.shape[1]], int(rng.integers(9)))
    return dofs


def test_prediction_is_undone_exactly_along_chains_and_only_among_active_dofs():
    priors = waveform_coders.context_priors()
    assert np.all(priors.predictor < np.arange(priors.n_layout)) and (priors.predictor >= 0).sum() > 10
    chained = [d for d in range(priors.n_layout) if priors.predictor[d] >= 0 and priors.predictor[priors.predictor[d]] >= 0]
    assert chained  # a predicted DOF that predicts another: its source must be rebuilt first
    rng = np.random.default_rng(3)
    for trial in range(20):
        active = rng.random(priors.n_layout) < 0.6
        active[chained[0]] = active[priors.predictor[chained[0]]] = active[priors.predictor[priors.predictor[chained[0]]]] = True
        pairs = waveform_coders.prediction_pairs(active, priors.predictor, priors.weight)
        targets, sources = pairs[0], pairs[1]
        assert np.all(sources < targets) and np.all(targets < active.sum())
        coded = rng.integers(-5000, 5000, size=(int(active.sum()), 3, 16)) >> rng.integers(0, 12)
        residual = waveform_coders.predict_dofs(coded, pairs)
        assert not np.array_equal(residual, coded)
        assert np.array_equal(waveform_coders.unpredict_dofs(residual.copy(), pairs), coded)
    none = np.zeros(priors.n_layout, dtype=bool)
    none[priors.predictor[chained[0]]] = True      # a source alone: nothing to predict
    assert len(waveform_coders.prediction_pairs(none, priors.predictor, priors.weight)[0]) == 0


def test_prediction_saves_bytes_on_coupled_dofs_without_changing_the_reconstruction():
    from comparisons.lab.codecs import LabCodec
    codec = LabCodec("wavelet-cx")
    dofs = _coupled_clip(40)
    priors = waveform_coders.context_priors()
    for index in (4, 10):
        data, recon = codec.encode_dofs(dofs, 10.0, index)
        decoded, _ = codec.decode_dofs(data)
        assert np.array_equal(decoded, recon)
        active = np.any(dofs != 0, axis=0)
        coded = ContextWaveletCoder(np.zeros(active.sum()), np.ones(active.sum()))._coded(
            dofs[:, active], ContextWaveletCoder.settings[index])[1]
        unpredicted = np.zeros(lab_context.payload_capacity(coded.size) + len(active), dtype=np.uint8)
        n_unpredicted = lab_context.encode_payload(active.astype(np.int64), coded, priors.mask_probs.copy(),
                                                   priors.mask_counts.copy(), priors.coeff_probs[index].copy(),
                                                   priors.coeff_counts[index].copy(), unpredicted)
        assert len(data) - 10 < 0.9 * n_unpredicted


def test_compact_damage_with_predicted_dofs_raises_signcast_error_or_decodes_to_the_layout():
    assert _compact_damage_rejected(_coupled_clip(30, seed=4), 9, seed=13, trials=200) > 100


def test_a_stream_coded_with_other_priors_is_rejected_not_misdecoded(monkeypatch):
    """The compact CRC starts from the priors' tag: a decoder whose trained tables differ (here one predictor
    weight) rejects the stream with a one-line error instead of decoding it to other motion."""
    from comparisons.lab.codecs import LabCodec
    codec = LabCodec("wavelet-cx")
    data, recon = codec.encode_dofs(_layout_clip(40), FPS, 8)
    assert np.array_equal(codec.decode_dofs(data)[0], recon)
    priors = waveform_coders.context_priors()
    weight = priors.weight.copy()
    weight[np.flatnonzero(priors.predictor >= 0)[0]] += 1
    other = dataclasses.replace(priors, weight=weight)
    assert other.tag != priors.tag
    monkeypatch.setattr(waveform_coders, "context_priors", lambda: other)
    with pytest.raises(SigncastError, match="checksum mismatch .*other trained tables"):
        codec.decode_dofs(data)

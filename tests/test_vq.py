"""Vector quantisation (seed 002 §7.9): LBG training, exact decoders, shipped codebooks."""
import functools
import numpy as np
import pytest

from comparisons.lab.codecs import EVALUATION_LANGUAGES, dof_layout, training_languages
from comparisons.lab.vq import (CODEBOOK_SIZES, SpatialVQ, TemporalVQ, group_layout, load_vq_tables,
                                             nearest, temporal_vectors, train_codebook)
from media.errors import SigncastError
from motion_samples import FPS, psnr, signing_like

LOWER, UPPER = np.full(5, -1.6), np.full(5, 1.6)


def test_lbg_finds_the_centres_of_separated_clusters():
    rng = np.random.default_rng(0)
    centres = np.array([[0.0, 0.0], [3.0, 0.0], [0.0, 3.0], [3.0, 3.0]])
    points = np.concatenate([c + 0.05 * rng.standard_normal((200, 2)) for c in centres])
    codebook = train_codebook(points, 4)
    matched = codebook[nearest(centres, codebook)]
    assert np.max(np.abs(matched - centres)) < 0.05


def test_nearest_returns_the_closest_code_vector():
    rng = np.random.default_rng(1)
    codebook, vectors = rng.standard_normal((37, 6)), rng.standard_normal((500, 6))
    brute = np.argmin(((vectors[:, None] - codebook[None]) ** 2).sum(-1), axis=1)
    assert np.array_equal(nearest(vectors, codebook, chunk=64), brute)


@functools.cache
def small_codebooks():
    """Codebooks trained on other clips than the coded one (seeds 10..13)."""
    training = np.concatenate([signing_like(300, seed) for seed in range(10, 14)])
    sizes = CODEBOOK_SIZES[:3]
    spatial = [{s: train_codebook(training[:, :3], s) for s in sizes}, {s: train_codebook(training[:, 3:], s) for s in sizes}]
    temporal = {s: train_codebook(temporal_vectors(training), s) for s in sizes}
    return spatial, temporal


def test_spatial_and_temporal_vq_decode_exactly_and_gain_with_codebook_size():
    spatial, temporal = small_codebooks()
    dofs = signing_like(200, seed=0)
    svq = SpatialVQ(LOWER, UPPER, [np.arange(3), np.arange(3, 5)], spatial)
    tvq = TemporalVQ(LOWER, UPPER, temporal)
    for coder in (svq, tvq):
        coder.settings = CODEBOOK_SIZES[:3]
        quality = []
        for q in (0, 2):
            data, recon = coder.encode(dofs, FPS, q)
            assert np.array_equal(coder.decode(data), recon)
            quality.append(psnr(dofs, recon))
        assert quality[1] > quality[0]
        damaged = bytearray(data)
        damaged[-6] ^= 0xFF
        with pytest.raises(SigncastError):
            coder.decode(bytes(damaged))


def test_temporal_vq_beats_direct_quantization_at_a_lower_rate():
    """Seed 002 §7.9.2: temporal VQ always beats 1-D direct quantisation at equal rate."""
    from comparisons.lab.waveform import UniformQuantizer
    _, temporal = small_codebooks()
    dofs = signing_like(300, seed=0)
    tvq = TemporalVQ(LOWER, UPPER, temporal)
    tvq.settings = CODEBOOK_SIZES[:3]
    tvq_bytes, tvq_recon = tvq.encode(dofs, FPS, 2)
    quant = UniformQuantizer(LOWER, UPPER)
    quant_bytes, quant_recon = quant.encode(dofs, FPS, 0)
    assert len(tvq_bytes) < len(quant_bytes)
    assert psnr(dofs, tvq_recon) > psnr(dofs, quant_recon)


def test_training_split_excludes_the_evaluation_languages():
    languages = training_languages()
    assert len(languages) >= 10
    assert not set(languages) & set(EVALUATION_LANGUAGES)


def test_shipped_codebooks_cover_the_signing_dof_layout():
    tables = load_vq_tables()
    layout = dof_layout()
    groups = group_layout(tables, list(layout.names))
    assert {g for g, _, _ in groups} == {"torso_head", "left_arm", "left_hand", "right_arm", "right_hand"}
    for group, idx, columns in groups:
        for size in CODEBOOK_SIZES:
            book = tables[f"svq_{group}_{size}"]
            assert book.shape == (size, len(idx))
            assert np.all(np.isfinite(book))
    for size in CODEBOOK_SIZES:
        assert tables[f"tvq_{size}"].shape == (size, 6)
    # a subset of DOFs (the ones a clip moves) still forms valid groups
    subset = [n for n in layout.names if n.startswith("r_")]
    assert {g for g, _, _ in group_layout(tables, subset)} == {"right_arm", "right_hand"}

"""The compiled Motion -> BAP split (media/bap_rotations.py anatomical_euler) against the NumPy/scipy path:
F^-1 (N^-1 q) F, then media.rotations.to_euler (scipy's from_quat and as_euler), on real retargeted letters and on
poses at the awkward places of the Euler split (angles near +-pi, the abduction at +-pi/2 where the split is in
gimbal lock, and just off it). Stated tolerances: angles within ANGLE_TOLERANCE (1e-9 rad) away from gimbal lock
and the +-pi wrap; the BAP levels (rounded angles) equal wherever the reference angle is not within 1e-6 of a
rounding tie, the wrap or gimbal lock, and elsewhere the decoded rotations within 3 rotation units
(the rotation, not the split, is what gimbal lock defines). BAPs -> rotations within 1e-12 per component.

Also the speed-ups that must not change an integer: the sparse P-frame models against the Fenwick banks
(comparisons/params/frames.py), and the DCT kernels around NumPy's matrix products."""
from __future__ import annotations

import functools

import numpy as np
import pytest

from comparisons.params import bap_table
from comparisons.params import fba as fba_codec
from comparisons.params import coding as pc
from comparisons.params.bits import BitReader, BitWriter
from comparisons.params.entropy import MAX_TOTAL
from comparisons.params.fba import decode_fba, encode_fba
from comparisons.params.fba_mapping import (
    EULER_ORDER,
    _bone_rotations,
    _bone_sources,
    avatar_bap_map,
    baps_to_motion,
    motion_to_baps,
)
from comparisons.params import frames as pf
from media import bap_rotations as bap_loops
from media import rotations
from media.fingerspelling import letter_motion
from media.motion import Motion


def scipy_baps(motion: Motion) -> np.ndarray:
    """motion_to_baps as it was before the compiled split (strict check left out)."""
    bap_map = avatar_bap_map()
    frames, neutrals, columns, signs = bap_map.arrays
    anatomical = bap_loops.anatomical_rotations(_bone_rotations(motion, bap_map), frames, neutrals)
    angles = rotations.to_euler(anatomical, EULER_ORDER) * signs
    values = np.zeros((motion.n_frames, bap_table.N_BAPS), dtype=np.int64)
    values[:, columns] = np.round(angles / bap_table.ROTATION_UNIT_RAD).astype(np.int64)
    translation_mm = np.round(motion.root_translation / bap_table.TRANSLATION_UNIT_M).astype(np.int64)
    values[:, [180, 181, 182]] = translation_mm[:, [1, 0, 2]]
    return values


def scipy_angles(motion: Motion) -> np.ndarray:
    frames, neutrals, _, _ = avatar_bap_map().arrays
    anatomical = bap_loops.anatomical_rotations(_bone_rotations(motion, avatar_bap_map()), frames, neutrals)
    return rotations.to_euler(anatomical, EULER_ORDER)


def compiled_angles(motion: Motion) -> np.ndarray:
    bap_map = avatar_bap_map()
    frames, neutrals, _, _ = bap_map.arrays
    mapped, source = _bone_sources(motion.bone_names, bap_map.bone_names)
    return bap_loops.anatomical_euler(motion.rotations, mapped, source, frames, neutrals)


@functools.lru_cache(maxsize=8)
def _letter(letter: str) -> Motion:
    return letter_motion("ase", letter, 25.0)


ANGLE_TOLERANCE = 1e-9


def _check(motion: Motion) -> None:
    """compiled_angles and motion_to_baps against scipy's, within the stated tolerances."""
    got, expected = compiled_angles(motion), scipy_angles(motion)
    middle = expected[..., 1]
    locked = np.abs(np.abs(middle) - np.pi / 2) < 1e-6                           # (T, B)
    wrap = np.abs(np.abs(expected) - np.pi) < 1e-6                               # (T, B, 3)
    clear = ~locked[..., None] & ~wrap
    assert np.max(np.abs(got - expected)[clear], initial=0.0) < ANGLE_TOLERANCE
    # the rotation itself, everywhere
    assert np.max(np.abs(1.0 - np.abs(np.sum(rotations.from_euler(got, EULER_ORDER)
                                              * rotations.from_euler(expected, EULER_ORDER), axis=-1)))) < 1e-12
    baps, reference = motion_to_baps(motion), scipy_baps(motion)
    _, _, columns, signs = avatar_bap_map().arrays
    scaled = expected * signs / bap_table.ROTATION_UNIT_RAD
    tie = np.abs(np.abs(scaled - np.floor(scaled)) - 0.5) < 1e-6 * np.maximum(1.0, np.abs(scaled))
    free = np.zeros(baps.shape, dtype=bool)
    np.logical_or.at(free, (slice(None), columns), tie | wrap | locked[..., None])
    assert np.array_equal(baps[~free], reference[~free])
    differ = np.any(baps != reference, axis=1)
    if differ.any():
        a = baps_to_motion(baps[differ], 25.0).rotations
        b = baps_to_motion(reference[differ], 25.0).rotations
        assert np.max(rotations.angle_between(a, b)) <= 3 * bap_table.ROTATION_UNIT_RAD


@pytest.mark.parametrize("letter", ["A", "H", "J", "Z"])
def test_letters(letter):
    _check(_letter(letter))


def _posed(anatomical: np.ndarray) -> Motion:
    """A motion of every mapped bone whose anatomical rotations F^-1 (N^-1 q) F are `anatomical` (T, B, 4)."""
    bap_map = avatar_bap_map()
    frames, neutrals, _, _ = bap_map.arrays
    conj = np.array([1.0, -1.0, -1.0, -1.0])
    q = rotations.multiply(neutrals, rotations.multiply(frames, rotations.multiply(anatomical, frames * conj)))
    return Motion(25.0, bap_map.bone_names, q, np.zeros((len(q), 3)))


def _edge_anatomical(n_bones: int) -> np.ndarray:
    """(T, B, 4) anatomical rotations at the Euler split's edges, from its own from_euler."""
    rng = np.random.default_rng(7)
    pi, half = np.pi, np.pi / 2
    rows = []
    for f in (pi, -pi, pi - 1e-9, -pi + 1e-9, 0.0, 3.14159, -3.14159, 1.0):
        for a in (half, -half, half - 1e-8, -half + 1e-8, half - 1e-6, 0.0, 0.3):
            for t in (pi, -pi, pi - 1e-9, 0.0, -2.5):
                rows.append((f, a, t))
    angles = np.array(rows)
    n = -(-len(angles) // n_bones) * n_bones
    angles = np.concatenate([angles, rng.uniform(-pi, pi, (n - len(angles), 3)) * [1, 0.5, 1]])
    q = rotations.from_euler(angles.reshape(-1, n_bones, 3), EULER_ORDER)
    q[::3] *= -1.0                                   # both signs of each quaternion
    return q * rng.uniform(0.999, 1.001, q.shape[:-1] + (1,))     # not quite unit: the normalisation counts


def test_edges():
    _check(_posed(_edge_anatomical(len(avatar_bap_map().bones))))


def test_edges_reach_gimbal_lock_and_pi():
    """The edge poses do exercise the special branches (else the test above proves little)."""
    angles = scipy_angles(_posed(_edge_anatomical(len(avatar_bap_map().bones))))
    assert np.any(angles[..., 2] == 0.0) and np.any(np.abs(np.abs(angles[..., 1]) - np.pi / 2) < 1e-6)
    assert np.any(np.abs(np.abs(angles[..., 0]) - np.pi) < 1e-6)


def test_missing_bones_at_rest():
    """Bones a motion lacks are at the rig's rest (identity) in both paths."""
    full = _letter("A")
    keep = [k for k, name in enumerate(full.bone_names) if not name.startswith(("finger", "wrist"))]
    motion = Motion(full.fps, tuple(full.bone_names[k] for k in keep), full.rotations[:, keep],
                    full.root_translation)
    _check(motion)


# ------------------------------------------------------------------ held poses (the kernels skip repeated frames)

def _with_held_frames(motion: Motion) -> Motion:
    """The motion with runs of repeated frames and exact zeros of both signs."""
    q = motion.rotations[np.repeat(np.arange(motion.n_frames), 3)].copy()
    q[1::6, :5, 1:] = 0.0
    q[2::6, :5, 1:] = -0.0
    q[4::6, :5, 1:] = -0.0
    t = np.repeat(motion.root_translation, 3, axis=0)
    return Motion(motion.fps, motion.bone_names, q, t)


@pytest.mark.parametrize("letter", ["B", "J"])
def test_held_frames(letter):
    _check(_with_held_frames(_letter(letter)))


def test_bap_value_rotations():
    """BAPs -> rotations with repeated frames skipped: the per-frame kernel on the angles, and scipy's from_euler
    with NumPy's products, within 1e-12 per component."""
    bap_map = avatar_bap_map()
    frames, neutrals, columns, signs = bap_map.arrays
    values = np.concatenate([motion_to_baps(_letter(letter)) for letter in "AHJ"])
    values = values[np.repeat(np.arange(len(values)), 2)]
    values[::5, columns[:4]] = 0
    angles = values[:, columns].astype(np.float64) * bap_table.ROTATION_UNIT_RAD * signs
    expected = bap_loops.bap_rotations(np.ascontiguousarray(angles), frames, neutrals)
    got = bap_loops.bap_value_rotations(values, columns, signs, bap_table.ROTATION_UNIT_RAD, frames, neutrals)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)
    conj = np.array([1.0, -1.0, -1.0, -1.0])
    e = rotations.from_euler(angles, EULER_ORDER)
    numpy = rotations.canonical(rotations.normalize(rotations.multiply(
        neutrals, rotations.multiply(rotations.multiply(frames, e), frames * conj))))
    np.testing.assert_allclose(got, numpy, rtol=0, atol=1e-12)
    np.testing.assert_allclose(baps_to_motion(values, 25.0).rotations, expected, rtol=0, atol=1e-12)


# ------------------------------------------------------------------ sparse P-frame models

def _skewed_levels(n_frames: int, sizes: np.ndarray, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """(levels (F, P), low (P,)): geometric-ish residuals in alphabets of these sizes, centred on 0."""
    rng = np.random.default_rng(seed)
    low = -(sizes // 2)
    draws = np.minimum(rng.geometric(0.4, (n_frames, len(sizes))) - 1, sizes - 1)
    signs = np.where(rng.random((n_frames, len(sizes))) < 0.5, -1, 1)
    levels = np.clip(draws * signs, low, low + sizes - 1)
    return levels.astype(np.int64), low.astype(np.int64)


@pytest.mark.parametrize("n_frames, seed", [(31, 1), (400, 2), (70_000, 3)])
def test_sparse_models_code_the_dense_banks_bits(n_frames, seed):
    """write_sparse_frames writes the bits of write_level_frames (Fenwick banks) with the same models, also
    past the models' halving (70,000 symbols of a 5-symbol model exceed MAX_TOTAL); read_sparse_planes
    reads them back, also when a model outgrows its keys and decoding continues on the dense bank."""
    sizes = np.array([1, 5, 200, 15241, 3], dtype=np.int64)
    levels, low = _skewed_levels(n_frames, sizes, seed)
    starts = np.array([0, 2, 5], dtype=np.int64)
    header, header_bits = 0b0100, 4                      # a predicted plane of BAPs
    dense = pc.LevelFrames(low, low + sizes - 1, starts)
    dense_writer = BitWriter()
    dense.write(dense_writer, levels, header, header_bits)
    sparse_writer = BitWriter()
    sparse_writer.reserve(dense_writer.n_bits + 64)
    pf.write_sparse_frames(sparse_writer.buffer, sparse_writer.state, header, header_bits, levels, low, starts,
                           sizes, *pf.new_sparse(sizes, n_frames), MAX_TOTAL)
    data = sparse_writer.getvalue()
    assert data == dense_writer.getvalue()

    columns = np.arange(len(sizes), dtype=np.int64)
    steps = np.ones(len(sizes), dtype=np.int64)
    expected = np.cumsum(levels, axis=0)
    for capacity in (8, 256):
        reader = BitReader(data)
        models = pf.new_sparse(sizes, capacity)
        held = np.zeros(len(sizes), dtype=np.int64)
        out = np.zeros((n_frames, len(sizes)), dtype=np.int64)
        status, n = pf.read_sparse_planes(reader.array, reader.end_bit, reader.registers, 2, low, starts, sizes,
                                          *models, MAX_TOTAL, columns, steps, held, out)
        if capacity == 8:                             # the 200- and 15241-symbol models outgrow 8 keys
            assert status == pf.SPARSE_FULL and 8 <= n < n_frames
            bank = pc.LevelFrames(low, low + sizes - 1, starts)
            _, offsets, counts, tree, scalars, _ = bank.bank_arrays()
            pf.sparse_to_dense(sizes, *models, offsets, counts, tree, scalars)
            status, m = pf.read_predicted_planes(reader.array, reader.end_bit, reader.registers, 2, low, starts,
                                                 *bank.bank_arrays(), columns, steps, held, out[n:])
            n += m
        assert status == 0 and n == n_frames
        assert np.array_equal(out, expected)


def _long_period_stream(q: int) -> tuple[np.ndarray, bytes]:
    values = np.concatenate([motion_to_baps(_letter(letter)) for letter in "AHJ"])
    return values, encode_fba(values, 25.0, q, "pred", intra_period=len(values))


@pytest.mark.parametrize("q", [1, 31])
def test_decoder_leaves_sparse_models_for_long_periods(q, monkeypatch):
    """An intra period of more P planes than SPARSE_KEYS decodes the same through the sparse models, the
    switch to the dense bank, and the dense bank alone, within half a step of the input."""
    values, data = _long_period_stream(q)
    decoded = {}
    for keys in (0, 4, fba_codec.SPARSE_KEYS, 1000):
        monkeypatch.setattr(fba_codec, "SPARSE_KEYS", keys)
        decoded[keys] = decode_fba(data).baps
    for keys, baps in decoded.items():
        assert np.array_equal(baps, decoded[0]), keys
    assert np.all(np.abs(decoded[0] - values) <= bap_table.steps() * q // 2)


def test_encoder_p_planes_match_level_frames(monkeypatch):
    """_write_p_planes (sparse models) writes what pc.LevelFrames.write wrote, on real letters with the face."""
    def dense(writer, alphabets, levels, header, header_bits):
        starts = np.cumsum([0] + [len(low) for low, _ in alphabets])
        frames = pc.LevelFrames(np.concatenate([low for low, _ in alphabets]),
                                np.concatenate([high for _, high in alphabets]), starts)
        frames.write(writer, np.concatenate(levels, axis=1), header, header_bits)

    for letter in "AHJ":
        motion = _letter(letter)
        for q in (1, 8, 31):
            for period in (32, motion.n_frames):
                got = encode_fba(motion_to_baps(motion), 25.0, q, "pred", faps=motion.faps, intra_period=period)
                with monkeypatch.context() as patch:
                    patch.setattr(fba_codec, "_write_p_planes", dense)
                    want = encode_fba(motion_to_baps(motion), 25.0, q, "pred", faps=motion.faps, intra_period=period)
                assert got == want


# ------------------------------------------------------------------ DCT levels around NumPy's products

@pytest.mark.parametrize("q", [1, 8, 31])
def test_dct_kernels_bitwise(q):
    """The DCT levels and reconstructions of the kernels are param_coding's, bit for bit, on real segments
    of every length 1..16."""
    values = np.concatenate([motion_to_baps(_letter(letter)) for letter in "AHJ"])
    order = np.flatnonzero(np.any(values != 0, axis=0))
    dc_step, ac_step = pc.dct_steps(bap_table.steps()[order], q)
    for n in range(1, 17):
        for start in (0, 7, len(values) - n):
            segment = values[start:start + n, order]
            dc, ac = pc.dct_levels(segment, dc_step, ac_step)
            got_dc, got_ac = fba_codec._dct_levels(segment, dc_step, ac_step)
            assert np.array_equal(got_dc, dc) and np.array_equal(got_ac, ac)
            assert np.array_equal(fba_codec._dct_reconstruct(dc, ac, dc_step, ac_step),
                                  pc.dct_reconstruct(dc, ac, dc_step, ac_step))

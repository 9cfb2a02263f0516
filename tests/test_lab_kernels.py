"""The compiled and batched paths of the seed-002 coders and the Motion <-> BAP conversion against the plain
NumPy/scipy computations they stand for, to rounding (the streams themselves are pinned by
tests/test_lab_conformance.py)."""
import struct
import zlib

import numpy as np
import pytest
from motion_samples import smooth_motion
from scipy.signal import savgol_filter

from comparisons.params import bap_table
from comparisons.lab import streams as coded_streams
from comparisons.lab.streams import StreamReader, StreamWriter
from comparisons.params.fba_mapping import (
    EULER_ORDER,
    avatar_bap_map,
    baps_to_motion,
    motion_to_baps,
)
from comparisons.lab.model import (
    GestureMatcher,
    PostureMatcher,
    gesture_distance,
    gesture_weights,
    group_speed,
    group_speeds,
    hermite_fill,
    savgol_slope,
    warp,
    warp_segments,
)
from comparisons.lab.vq import nearest
from media import rotations
from media.errors import SigncastError


def _reference_baps_to_motion_rotations(values: np.ndarray) -> np.ndarray:
    """baps_to_motion's rotations as computed before comparisons/lab/rotations.py: scipy from_euler, NumPy products."""
    frames, neutrals, columns, signs = avatar_bap_map().arrays
    angles = values[:, columns].astype(np.float64) * bap_table.ROTATION_UNIT_RAD * signs
    anatomical = rotations.from_euler(angles, EULER_ORDER)
    relative = rotations.multiply(rotations.multiply(frames, anatomical), rotations.conjugate(frames))
    return rotations.canonical(rotations.normalize(rotations.multiply(neutrals, relative)))


def test_baps_to_motion_rotations_stay_within_1e_12_of_the_scipy_euler_path():
    rng = np.random.default_rng(3)
    cases = [motion_to_baps(smooth_motion(n_frames=30, seed=1)),
             rng.integers(-314159, 314160, (20, bap_table.N_BAPS)), np.zeros((2, bap_table.N_BAPS), np.int64)]
    for values in cases:
        got = baps_to_motion(values, 25.0).rotations
        assert np.abs(got - _reference_baps_to_motion_rotations(values)).max() <= 1e-12
        assert np.all(got[..., 0] >= 0.0)


def test_motion_to_baps_is_the_numpy_product_chain_to_a_unit():
    motion = smooth_motion(n_frames=40, seed=2)
    frames, neutrals, columns, signs = avatar_bap_map().arrays
    names = {n: k for k, n in enumerate(motion.bone_names)}
    q = np.zeros((motion.n_frames, len(avatar_bap_map().bones), 4))
    q[..., 0] = 1.0
    for k, bone in enumerate(avatar_bap_map().bones):
        if bone.bone in names:
            q[:, k] = motion.rotations[:, names[bone.bone]]
    relative = rotations.multiply(rotations.conjugate(neutrals), q)
    anatomical = rotations.multiply(rotations.multiply(rotations.conjugate(frames), relative), frames)
    angles = rotations.to_euler(anatomical, EULER_ORDER) * signs
    expected = np.round(angles / bap_table.ROTATION_UNIT_RAD).astype(np.int64)
    got = motion_to_baps(motion)[:, columns]
    assert np.abs(got - expected).max() <= 1          # a value on a rounding boundary may go either way
    assert np.mean(got == expected) > 0.99


def test_compiled_sections_use_the_entropy_coders_model_limits():
    from comparisons.params import entropy
    assert coded_streams._MODEL_LIMIT == entropy.MAX_TOTAL and coded_streams._MAX_OVERRUN == entropy.PRECISION


def _writer() -> StreamWriter:
    return StreamWriter(1, 0, 10, 3, 25.0)


@pytest.mark.parametrize("alphabet", [1, 2, 41, 255, 4096])
def test_symbol_rows_write_the_bytes_of_one_section_per_row(alphabet):
    rows = np.random.default_rng(alphabet).integers(0, alphabet, (7, 33))
    rows[2] = 0
    batched, single = _writer(), _writer()
    batched.symbol_rows(rows, alphabet)
    for row in rows:
        single.parts += [b"S", coded_streams._varint(alphabet), coded_streams._varint(len(row))]
        data = single.stage.encode(row, alphabet)           # the entropy stage itself, no compiled section
        single.parts += [coded_streams._varint(len(data)), data]
    assert batched.finish() == single.finish()
    reader = StreamReader(batched.finish(), 1, "test")
    assert np.array_equal(reader.symbol_rows(alphabet, 7, 33), rows)
    reader.finish()


def test_damaged_sections_still_raise_the_checking_readers_errors():
    rows = np.random.default_rng(0).integers(0, 16, (4, 20))
    writer = _writer()
    writer.symbol_rows(rows, 16)
    writer.signed(np.arange(-30, 30))
    data = bytearray(writer.finish())
    body = bytes(data[:-4])
    header = coded_streams._HEADER.size
    for position in range(header, len(body)):
        for flip in (0x01, 0x80):
            damaged = bytearray(body)
            damaged[position] ^= flip
            stream = bytes(damaged) + struct.pack("<I", zlib.crc32(bytes(damaged)))
            reader = StreamReader(stream, 1, "test")
            try:
                got = reader.symbol_rows(16, 4, 20)
                values = reader.signed(60)
                reader.finish()
            except SigncastError:
                continue
            assert got.shape == (4, 20) and values.shape == (60,)     # undetected damage decodes to something


def test_signed_sections_match_magnitude_classes_and_pack_bits():
    values = np.random.default_rng(1).integers(-(1 << 39), 1 << 39, 200)
    values[:5] = [0, 1, -1, (1 << 40) - 1, -((1 << 40) - 1)]
    fast, slow = _writer(), _writer()
    fast.signed(values)
    classes, mantissa, widths = coded_streams.magnitude_classes(values)
    slow.symbols(classes, 41)
    slow.raw(mantissa, widths)
    assert fast.finish() == slow.finish()
    reader = StreamReader(fast.finish(), 1, "test")
    assert np.array_equal(reader.signed(200), values)
    with pytest.raises(ValueError):
        _writer().signed(np.array([1 << 40]))


def test_savgol_slope_is_scipys_savgol_filter():
    rng = np.random.default_rng(4)
    for shape in [(7,), (8, 1), (9, 5), (31, 57), (100,), (12, 3, 2)]:
        x = rng.standard_normal(shape)
        np.testing.assert_allclose(savgol_slope(x), savgol_filter(x, 7, 3, deriv=1, axis=0), rtol=0, atol=1e-13)
    with pytest.raises(SigncastError):
        savgol_slope(np.zeros((6, 2)))


def test_group_speeds_of_all_groups_at_once_equal_each_groups_own():
    dofs = smooth_motion(n_frames=40, seed=5).rotations.reshape(40, -1)[:, :60]
    groups = [np.arange(0, 21), np.arange(21, 27), np.arange(27, 60)]
    for (omega, alpha), group in zip(group_speeds(dofs, groups), groups):
        velocity = savgol_filter(dofs[:, group], 7, 3, deriv=1, axis=0)
        expected_omega = np.linalg.norm(velocity, axis=1)
        np.testing.assert_allclose(omega, expected_omega, rtol=0, atol=1e-13)
        np.testing.assert_allclose(alpha, savgol_filter(expected_omega, 7, 3, deriv=1), rtol=0, atol=1e-13)
        assert np.array_equal(group_speed(dofs[:, group])[0], omega)


def test_warp_is_np_interp_per_column():
    rng = np.random.default_rng(6)
    for n, length in [(2, 16), (5, 16), (16, 16), (40, 17), (3, 2)]:
        segment = rng.standard_normal((n, 4))
        source, target = np.linspace(0.0, 1.0, n), np.linspace(0.0, 1.0, length)
        expected = np.stack([np.interp(target, source, segment[:, k]) for k in range(4)], axis=1)
        np.testing.assert_allclose(warp(segment, length), expected, rtol=0, atol=1e-14)


def test_hermite_fill_equals_the_per_interval_formula():
    keys = np.array([0, 3, 4, 9, 15])
    values = np.random.default_rng(7).standard_normal((5, 3))
    got = hermite_fill(keys, values, 16)
    lags = np.diff(keys).astype(np.float64)
    secants = np.diff(values, axis=0) / lags[:, None]
    slopes = np.zeros_like(values)
    s = lags[1:] / (lags[:-1] + lags[1:])
    slopes[1:-1] = s[:, None] * secants[:-1] + (1.0 - s)[:, None] * secants[1:]
    expected = np.empty((16, 3))
    for m in range(len(keys) - 1):
        a, b = keys[m], keys[m + 1]
        t = (np.arange(a, b + 1) - a) / (b - a)
        cube = t ** 3
        h00, h10 = 2 * cube - 3 * t ** 2 + 1, cube - 2 * t ** 2 + t
        h01, h11 = -2 * cube + 3 * t ** 2, cube - t ** 2
        expected[a:b + 1] = (h00[:, None] * values[m] + h10[:, None] * (b - a) * slopes[m]
                             + h01[:, None] * values[m + 1] + h11[:, None] * (b - a) * slopes[m + 1])
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-13)


def test_warp_segments_are_each_segments_warp():
    rng = np.random.default_rng(11)
    source = rng.standard_normal((60, 5))
    starts, counts, lengths = np.array([0, 3, 10, 30, 58]), np.array([4, 2, 21, 29, 2]), np.array([16, 7, 1, 16, 40])
    expected = np.concatenate([warp(source[a:a + n], m) for a, n, m in zip(starts, counts, lengths)])
    np.testing.assert_allclose(warp_segments(source, starts, counts, lengths), expected, rtol=0, atol=1e-14)
    assert np.array_equal(warp_segments(source, [5], [1], [4]), warp(source[5:6], 4))


def test_gesture_matcher_is_gesture_distance_and_argmin_even_on_ties():
    rng = np.random.default_rng(12)
    weights = gesture_weights()
    for k in (1, 3, 9, 21):
        table = rng.standard_normal((k, 40, 16)).transpose(1, 2, 0)  # the shipped tables' layout
        table[7] = table[3]  # an exact tie: argmin keeps the first
        warped = table[[3, 0, 12, 39]] + rng.normal(0, 1e-3, (4, 16, k))
        warped[0] = table[3]
        warped = np.concatenate([warped, rng.standard_normal((3, 16, k))])
        best, distance = GestureMatcher(table, weights).match(warped)
        for s, segment in enumerate(warped):
            expected = gesture_distance(segment, table, weights)
            assert best[s] == expected.argmin() and distance[s] == expected[best[s]]
        assert best[0] == 3


def test_posture_matcher_is_nearest_of_each_row_even_on_near_ties():
    rng = np.random.default_rng(13)
    codebook = rng.standard_normal((18, 256)).T  # the shipped tables' layout
    codebook[100] = codebook[50] * (1 + 1e-15)
    rows = np.concatenate([codebook[[50, 100, 7]] + 1e-12, rng.standard_normal((20, 18))])
    expected = np.array([nearest(row[None], codebook)[0] for row in rows])
    assert np.array_equal(PostureMatcher(codebook).nearest(rows), expected)

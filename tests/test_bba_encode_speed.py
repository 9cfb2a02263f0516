"""The BBA encoder's compiled paths against their references: the Euler split (media.rotations.euler_split against
scipy's as_euler, every rotation order, gimbal lock included: within 1e-9 rad, the same rotation within 1e-12 where
gimbal lock leaves the split free) and the key-frame
search (comparisons/params/bba_keyframes.py against keyframes._key_frames_numpy, on real clips, with the kernel's
undecided candidates handed back to NumPy)."""
from __future__ import annotations

import numpy as np
import pytest

from comparisons.params import bba as bba_codec
from comparisons.params import keyframes as kf
from comparisons.params import coding as pc
from comparisons.params import bba_writer as writer_kernel
from media import rotations
from media.face_rig import with_face_bones
from media.fingerspelling import letter_motion


def _quaternions() -> np.ndarray:
    """(N, 4) random quaternions (not unit), rotations about one axis (gimbal lock of some orders), Euler
    angles at the +-pi/2 locks, the axes and their negatives, and rows repeated (the kernel's skip)."""
    rng = np.random.default_rng(7)
    single = [rotations.from_axis_angle(np.eye(3)[axis], angle) for axis in range(3) for angle in np.linspace(-np.pi, np.pi, 41)]
    locked = rotations.from_euler(rng.uniform(-3, 3, (500, 3)) * [1.0, 0.0, 1.0], "XYZs")
    at_pi_2 = rotations.from_euler(np.array([[0.3, np.pi / 2, 0.2], [0.1, -np.pi / 2, 0.5], [0.0, np.pi / 2 + 1e-9, 1.0]]),
                                   "ZXYr")
    q = np.concatenate([rng.normal(size=(3000, 4)), np.array(single), locked, at_pi_2, np.eye(4), -np.eye(4)])
    q = q[len(q) % 40:]                     # whole frames of 40 bones; the single-axis and locked rows kept
    return np.concatenate([q, q[:40], q[:40]])


@pytest.mark.parametrize("order", bba_codec.ORDER_NAMES)
def test_euler_split_is_scipys(order):
    q = _quaternions()
    expected = rotations.to_euler(q, order)
    unit = rotations.normalize(q)
    for shaped in (q, q.reshape(-1, 40, 4)):              # flat, and as (T, B, 4) frames (held bones skipped)
        got = bba_codec._to_euler(shaped, order).reshape(-1, 3)
        same = np.abs(1.0 - np.abs(np.sum(rotations.from_euler(got, order) * unit, axis=-1)))
        assert np.max(same) < 1e-12
        # the angles themselves, away from gimbal lock (where only their sum or difference is defined) and from
        # the +-pi wrap of the outer angles
        middle = expected[:, 1] if order[0] == order[2] else expected[:, 1] + np.pi / 2
        clear = (np.minimum(np.abs(middle), np.abs(middle - np.pi)) > 1e-6) & np.all(np.abs(np.abs(expected) - np.pi) > 1e-6,
                                                                                       axis=1)
        np.testing.assert_allclose(got[clear], expected[clear], rtol=0, atol=1e-9)


@pytest.fixture(scope="module")
def clips():
    """Face-played ASL and DGS letters (the motions bba-key codes)."""
    return [with_face_bones(letter_motion(language, letter, 25.0)).without_face()
            for language, letters in (("ase", "ABCDEFGHIJKLMNO"), ("gsg", "ABC")) for letter in letters]


@pytest.mark.parametrize("threshold", [1e-3, 0.01, kf.default_threshold_rad(1), kf.default_threshold_rad(31), 0.3])
def test_key_frames_are_the_numpy_searchs(clips, threshold):
    for motion in clips:
        expected = kf._key_frames_numpy(motion, threshold)
        assert np.array_equal(kf.key_frames(motion, threshold), expected)
        assert np.array_equal(kf.key_frames(motion, threshold, 0.0005), kf._key_frames_numpy(motion, threshold, 0.0005))


def test_undecided_candidates_are_decided_by_numpy(clips, monkeypatch):
    # Margins wider than any value: the kernel decides nothing, every candidate goes back to _within_each.
    monkeypatch.setattr(kf, "_MARGIN_RAD", 10.0)
    monkeypatch.setattr(kf, "_MARGIN_M", 10.0)
    asked = []
    numpy_test = kf._within_each
    monkeypatch.setattr(kf, "_within_each", lambda *args: asked.append(args[2:4]) or numpy_test(*args))
    for motion in clips[:6]:
        expected = kf._key_frames_numpy(motion, 0.05)
        del asked[:]
        assert np.array_equal(kf.key_frames(motion, 0.05), expected)
        # one candidate at a time, every one of them: the first candidate of each key, 2 frames on, among them
        assert all(len(first) == 1 for first, _ in asked)
        firsts = {int(k) for k in expected if k + 2 <= motion.n_frames - 1}
        assert firsts and firsts <= {int(first[0]) for first, last in asked if last[0] == first[0] + 2}


def test_key_frames_edge_cases(clips):
    motion = clips[0]
    for n in (1, 2, 3, 4):
        part = motion.frames(0, n)
        assert np.array_equal(kf.key_frames(part, 0.05), kf._key_frames_numpy(part, 0.05))
    # below the compiled path's thresholds: the NumPy search itself
    assert np.array_equal(kf.key_frames(motion, 1e-4), kf._key_frames_numpy(motion, 1e-4))


def _shifted(motion, offset_m: float):
    """The motion with its root moved by offset_m (metres) on every axis: translations at half-millimetre
    ties (np.round's half to even) and beyond the coded range."""
    return type(motion)(motion.fps, motion.bone_names, motion.rotations, motion.root_translation + offset_m)


@pytest.mark.parametrize("coding, keyframes", [("pred", False), ("dct", False), ("pred", True)])
def test_compiled_values_and_mask_are_the_numpy_analysis(clips, coding, keyframes):
    """_motion_arrays (comparisons/params/bba_values.py motion_values) against _motion_arrays_numpy: the same header,
    the same mask dict (its order included), KeyFrameIndex and values, at several Q and rotation orders."""
    skeleton = bba_codec.load_avatar().skeleton
    motions = clips[::2] + [_shifted(clips[1], 0.0005), _shifted(clips[3], -0.0025), _shifted(clips[5], 40.0),
                            clips[0].frames(0, 1)]
    for k, motion in enumerate(motions):
        for q in (1, 8, 31):
            order = (0, 5, 13)[k % 3]
            args = (motion, q, coding, keyframes, None, None, order, 0, "clip", skeleton)
            header, mask, kfi, values = bba_codec._motion_arrays(*args)
            header_ref, mask_ref, kfi_ref, values_ref = bba_codec._motion_arrays_numpy(*args)
            assert header == header_ref
            assert list(mask.items()) == list(mask_ref.items())
            assert np.array_equal(kfi, kfi_ref) and kfi.dtype == kfi_ref.dtype
            assert np.array_equal(values, values_ref) and values.dtype == values_ref.dtype


def test_a_motion_without_moving_values_sends_nothing(clips):
    skeleton = bba_codec.load_avatar().skeleton
    still = clips[0].frames(0, 3)
    still = type(still)(still.fps, still.bone_names, np.broadcast_to([1.0, 0.0, 0.0, 0.0], still.rotations.shape),
                        still.root_translation * 0.0)
    _, mask, _, values = bba_codec._motion_arrays(still, 8, "pred", False, None, None, 0, 0, "s", skeleton)
    assert mask == {} and values.shape == (3, 0)
    assert list(bba_codec._motion_arrays_numpy(still, 8, "pred", False, None, None, 0, 0, "s", skeleton)[1]) == []


def test_dense_range_choice_is_the_masked_one():
    """_range_choice of units that carry every key (carried None: compiled fields, counted units) against the
    masked form with an all-true mask: the same fields and choice, also where the default alphabets win."""
    rng = np.random.default_rng(3)
    choices = set()
    for n, k, scale in ((1, 5, 3), (24, 217, 40), (30, 12, 2000), (7, 3, 0), (40, 60, 1)):
        levels = np.round(rng.laplace(size=(n, k)) * scale).astype(np.int64)
        for period in (1, 5, 60):
            intra = np.arange(n) % period == 0
            for q in (1, 8, 31):
                fields, tight = bba_codec._range_choice(levels, None, intra, q)
                fields_ref, tight_ref = bba_codec._range_choice(levels, np.ones(levels.shape, dtype=bool), intra, q)
                assert tight == tight_ref and np.array_equal(fields, fields_ref) and fields.dtype == fields_ref.dtype
                choices.add(tight)
    assert choices == {True, False}


def test_compiled_range_cost_choice_is_numpys(monkeypatch):
    """kernels/bba_writer.range_cost_gap's choice against NumPy's estimated bits on 3,000 random field sets
    (near-tie gaps included), and its undecided answer (-1) handed to NumPy's sums."""
    rng = np.random.default_rng(11)
    bonus = 4 * pc.RANGE_BITS
    decided = set()
    for _ in range(3000):
        k = int(rng.integers(1, 300))
        fields = rng.integers(0, pc.DEFAULT_RANGE_FIELD + 1, size=(4, k)).astype(np.int64)
        fields[:, rng.random(k) < 0.5] = pc.DEFAULT_RANGE_FIELD       # many keys at the default: near ties
        n_intra, n_predicted, q = int(rng.integers(0, 5)), int(rng.integers(0, 60)), int(rng.integers(1, 32))
        counts = np.array([[n_intra] * k, [n_predicted] * k], dtype=np.int64)
        default = np.full_like(fields, pc.DEFAULT_RANGE_FIELD)
        expected = bba_codec._estimated_bits(default, counts, q) < bba_codec._estimated_bits(fields, counts, q) + bonus * k
        choice = writer_kernel.range_cost_gap(fields, n_intra, n_predicted, q, pc.RANGE_DELTA,
                                                   pc.DEFAULT_RANGE_FIELD, pc.RANGE_BITS)
        assert choice == -1 or bool(choice) == expected
        decided.add(choice)
    assert {0, 1} <= decided
    levels = np.round(rng.laplace(size=(24, 40)) * 3).astype(np.int64)
    intra = np.arange(24) % 5 == 0
    expected = [bba_codec._range_choice(levels, None, intra, q) for q in (1, 8, 31)]
    monkeypatch.setattr(bba_codec.writer_kernel, "range_cost_gap", lambda *args: -1)
    for q, (fields, tight) in zip((1, 8, 31), expected):
        fields_numpy, tight_numpy = bba_codec._range_choice(levels, None, intra, q)
        assert tight_numpy == tight and np.array_equal(fields_numpy, fields)

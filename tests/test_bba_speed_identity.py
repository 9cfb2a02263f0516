"""The compiled face-rig solve (kernels/bba_face_rig.py) against its NumPy reference (media.face_rig._carry_numpy),
and the BBA coder's batched paths against the stream they must reproduce."""
from __future__ import annotations

import numpy as np
import pytest

from comparisons import bba_codec
from comparisons.fap_rates import synthetic_faps
from media import face_rig
from media.errors import SigncastError
from media.face_rig import avatar_fapu, face_bone_rotations
from media.fingerspelling import letter_motion
from media.motion import Motion


@pytest.mark.parametrize("seed", [0, 1])
def test_compiled_face_rig_solve_matches_the_numpy_reference_on_synthetic_faps(avatar, monkeypatch, seed):
    faps = synthetic_faps(60, 25.0, seed=seed)
    fapu = avatar_fapu(avatar)
    compiled = face_bone_rotations(faps, avatar.skeleton, fapu)
    monkeypatch.setattr(face_rig, "_carry", face_rig._carry_numpy)
    reference = face_bone_rotations(faps, avatar.skeleton, fapu)
    assert list(compiled) == list(reference)
    moved = 0
    for name, rotation in reference.items():
        angle = 2 * np.arcsin(np.minimum(np.linalg.norm(
            (compiled[name] - rotation) / 2, axis=-1), 1.0))     # chord -> angle, exact for small angles
        assert angle.max() <= 1e-12, name
        moved += int(np.any(np.abs(rotation[:, 0]) < 1 - 1e-9))
    assert moved >= 10                          # the FAPs turn the carried bones, not only the identity


def test_bba_stream_with_changing_masks_round_trips_its_held_values(avatar):
    """Frames whose bone masks differ (a bone dropping out and coming back) decode to the values sent,
    the held ones where a frame does not carry a bone."""
    skeleton = avatar.skeleton
    root = int(np.flatnonzero(skeleton.parents < 0)[0])
    other = skeleton.index("jaw")
    rot = 1 << bba_codec.ROTATION_BITS[0]
    frames = [bba_codec.BBAFrame(0, {root: rot, other: rot}, {root: [4096], other: [8192]}),
              bba_codec.BBAFrame(0, {root: rot}, {root: [12288]}),
              bba_codec.BBAFrame(0, {root: rot, other: rot}, {root: [16384], other: [20480]})]
    stream = bba_codec.BBAStream(bba_codec.BBAHeader("t", 25.0, "pred", 1), frames)
    decoded, lost = bba_codec.read_stream(bba_codec.write_stream(stream, skeleton))
    assert lost == []
    assert [f.values for f in decoded.frames] == [f.values for f in frames]
    motion = bba_codec.stream_to_motion(decoded, skeleton)
    jaw = motion.bone_names.index("jaw")
    # the jaw holds frame 0's angle in frame 1
    assert np.array_equal(motion.rotations[1, jaw], motion.rotations[0, jaw])
    assert not np.array_equal(motion.rotations[2, jaw], motion.rotations[0, jaw])


def _translated(motion: Motion, metres: np.ndarray) -> Motion:
    return Motion(motion.fps, motion.bone_names, motion.rotations, motion.root_translation + metres[:, None])


@pytest.mark.parametrize("q", [1, 8, 31])
def test_compiled_predictive_levels_match_the_unit_by_unit_loop(avatar, q):
    """kernels/bba_levels.py (streams with one mask) against _levels_by_unit, on a real letter and on the
    same letter jumping 16 m back and forth (P levels beyond the range fields: those units go intra)."""
    motion = letter_motion("ase", "J", 25.0)
    jumps = np.where(np.arange(motion.n_frames) % 2 == 1, 8.0, -8.0)
    for jumping in (False, True):
        s = bba_codec.motion_to_stream(_translated(motion, jumps) if jumping else motion, q)
        units = bba_codec._units(s)
        masks = sorted(s.frames[0].bones.items())
        key_index = {key: j for j, key in enumerate((b, bit) for b, mask in masks for bit in bba_codec._bits(mask))}
        exponents = bba_codec._exponent_items(avatar.skeleton)
        flags_a = bba_codec._intra_flags(s, units)
        flags_b = list(flags_a)
        compiled = bba_codec._uniform_levels(s, flags_a, exponents, key_index)
        loop = bba_codec._levels_by_unit(s, units, flags_b, exponents, key_index)
        assert flags_a == flags_b
        for (keys_a, _, level_a, columns_a), (keys_b, _, level_b, columns_b) in zip(compiled, loop, strict=True):
            assert keys_a == keys_b
            assert np.array_equal(level_a, level_b) and np.array_equal(columns_a, columns_b)
        assert (sum(flags_a) == len(flags_a)) == jumping


def test_compiled_predictive_levels_raise_the_loop_error_on_an_intra_level_out_of_range(avatar):
    motion = letter_motion("ase", "A", 25.0)
    far = _translated(motion, np.where(np.arange(motion.n_frames) == 3, 20.0, 0.0))   # beyond 15.24 m
    with pytest.raises(SigncastError, match="TranslationOnX = 20000 cannot be sent at Q=31"):
        bba_codec.write_stream(bba_codec.motion_to_stream(far, 31), avatar.skeleton)

"""The face rig's compiled paths against their NumPy references: the frame-vectorised solve
(media/face_rig_solve.carry) against face_rig._carry_numpy within CARRY_TOLERANCE, the compiled conversions
against scipy / NumPy (media/rotations.py), held frames solved once."""
from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from comparisons.params.fap_rates import synthetic_faps
from media import face_rig, rotation_loops, rotations
from media import face_rig_solve as face_kernel
from media.face_rig import avatar_fapu, face_bone_rotations
from media.fingerspelling import letter_motion
from media.motion import Motion


def _bits(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64).view(np.int64)


def _wild_faps() -> np.ndarray:
    """(40, 68) FAPs beyond the rig's reach, with all-zero frames and frames held from the one before."""
    wild = np.random.default_rng(7).integers(-3000, 3000, size=(40, 68))
    wild[::5] = 0
    wild[1::7] = wild[0::7][: len(wild[1::7])]
    return wild


# The compiled solve against the dense NumPy reference (face_rig._carry_numpy): the same Gauss-Newton steps in
# another summation order, so the rotations agree to rounding. Stated bound: 1e-9 per quaternion component
# (measured ~1e-14; a wrong step or iteration count differs by > 1e-4).
CARRY_TOLERANCE = 1e-9


@pytest.mark.parametrize("anchor, names", [
    ("head", ("levator05.L", "risorius03.L", "oculi01.L", "levator06.L", "levator05.R", "risorius03.R",
              "oculi01.R", "levator06.R", "oris05", "oris03.L", "oris03.R")),
    ("jaw", ("oris01", "oris07.L", "oris07.R")),
])
def test_compiled_solve_is_the_numpy_solve_within_the_stated_tolerance(avatar, anchor, names):
    rng = np.random.default_rng(len(names))
    for scale, n_frames in itertools.product((0.0, 1e-4, 3e-3, 0.05), (37, face_kernel.FEW_FRAMES + 5)):
        heads = rng.normal(size=(n_frames, len(names), 3)) * scale   # rest, small, typical, far beyond reach
        tails = heads + rng.normal(size=heads.shape) * scale * 0.5
        heads[5] = tails[5] = 0.0
        targets = {name: (heads[:, k], tails[:, k]) for k, name in enumerate(names)}
        for settings in ({}, face_rig.FULL_SOLVE):      # frames stopping on the tolerance; all running 10 iterations
            got = face_rig._carry(avatar.skeleton, anchor, targets, **settings)
            expected = face_rig._carry_numpy(avatar.skeleton, anchor, targets, **settings)
            assert got.keys() == expected.keys()
            for name in got:
                # q and -q are one rotation
                sign = np.sign(np.sum(got[name] * expected[name], axis=-1, keepdims=True))
                assert np.abs(got[name] - sign * expected[name]).max() <= CARRY_TOLERANCE, name
                assert np.allclose(got[name][5], [1.0, 0.0, 0.0, 0.0])     # no target: no turn
        if scale > 0:
            assert not np.allclose(np.stack(list(got.values())), [1.0, 0.0, 0.0, 0.0])


# The compiled conversions after the solve against scipy / NumPy (media/rotations.py): stated bound 1e-12 per
# quaternion or matrix component (measured ~1e-16).
CONVERSION_TOLERANCE = 1e-12


def test_compiled_from_matrix_is_scipys_within_rounding():
    rng = np.random.default_rng(0)
    matrices = [Rotation.random(20000, random_state=1).as_matrix()]
    for scale in (1e-9, 1e-4, 0.3):
        matrices.append(Rotation.from_rotvec(rng.normal(size=(5000, 3)) * scale).as_matrix())
    axes = rng.normal(size=(5000, 3))
    matrices.append(Rotation.from_rotvec(axes / np.linalg.norm(axes, axis=1)[:, None] * np.pi).as_matrix())
    for axis in np.eye(3):           # half and quarter turns: ties between the trace and the diagonal
        for angle in (0.0, np.pi / 2, -np.pi / 2, np.pi):
            matrices.append(Rotation.from_rotvec(axis * angle).as_matrix()[None])
    m = np.ascontiguousarray(np.concatenate(matrices))
    products = np.einsum("nij,njk->nik", m[:10000], m[10000:20000])     # a few ulp off orthogonal, as posed
    for batch in (m, products):
        got = face_kernel.from_matrix(batch)
        expected = rotations.from_matrix(batch)
        assert np.all(got[:, 0] >= 0)
        # the same rotation (w = 0: q and -q both canonical candidates)
        assert np.max(np.abs(1.0 - np.abs(np.sum(got * expected, axis=1)))) < CONVERSION_TOLERANCE
        np.testing.assert_allclose(rotations.to_matrix(got), batch, rtol=0, atol=CONVERSION_TOLERANCE)


def test_compiled_bone_turns_are_between_then_to_matrix():
    rng = np.random.default_rng(1)
    arms = rng.normal(size=(5, 3)) * 0.01
    for scale in (1e-6, 1e-3, 0.05):
        head = rng.normal(size=(400, 5, 3)) * scale
        tail = head + rng.normal(size=(400, 5, 3)) * scale * (rng.random((400, 5, 1)) < 0.5)
        tail[1::13] = head[1::13] - 2 * arms                  # the bone turned right round
        full = np.broadcast_to(arms, tail.shape)
        expected = rotations.to_matrix(rotations.between(full, full + tail - head))
        np.testing.assert_allclose(face_kernel.bone_turns(arms, head, tail), expected, rtol=0, atol=CONVERSION_TOLERANCE)


def test_held_frames_are_solved_once_and_give_each_frame_its_own_solution(avatar):
    order = [0, 0, 0, 1, 2, 2, 3, 4, 5, 5, 5, 5, 6, 7, 8, 9, 10, 11, 11]
    wanted = np.random.default_rng(4).normal(size=(12, 11, 3))
    wanted[7] = 0.0
    wanted[8] = -0.0                      # equal to frame 7 as numbers, not bit for bit: solved again
    run, first = face_kernel.held_runs(wanted[order])
    assert run.tolist() == [0, 0, 0, 1, 2, 2, 3, 4, 5, 5, 5, 5, 6, 7, 8, 9, 10, 11, 11]
    assert first.tolist() == [0, 3, 4, 6, 7, 8, 12, 13, 14, 15, 16, 17]
    assert face_kernel.held_runs(np.zeros((0, 3, 3)))[1].tolist() == []
    fapu = avatar_fapu(avatar)
    faps = synthetic_faps(12, 25.0, seed=4)
    once = face_bone_rotations(faps, avatar.skeleton, fapu)
    with_holds = face_bone_rotations(faps[order], avatar.skeleton, fapu)
    for name, rotation in once.items():
        assert np.array_equal(_bits(with_holds[name]), _bits(rotation[order])), name


def _carry_by_steps(plan, head_moved, tail_moved):
    """The carry as separate steps (how face_rig._carry_arrays did it before the one-call kernel): distinct
    frames by a NumPy comparison, the frame-vectorised solve (`carry`), bone_turns, parent^T turned,
    from_matrix. (T, C + S, 4)."""
    rows = np.ascontiguousarray(head_moved).reshape(len(head_moved), -1).view(np.int64)
    changed = np.ones(len(rows), dtype=bool)
    changed[1:] = np.any(rows[1:] != rows[:-1], axis=1)
    local, parent = face_kernel.carry(np.ascontiguousarray(head_moved[changed]), plan.carrier_heads,
                                      plan.carrier_parents, plan.skinned_heads, plan.skinned_parents, plan.on_chain,
                                      plan.group_members, plan.group_start, face_rig.CARRY_ITERATIONS,
                                      face_rig.CARRY_DAMPING, face_rig.CARRY_MAX_TURN, face_rig.CARRY_TOLERANCE)
    run = np.cumsum(changed) - 1
    local, parent = local[run], parent[run]
    turned = face_kernel.bone_turns(plan.arms, head_moved, tail_moved)
    matrices = np.concatenate([local, face_kernel.transposed_products(parent, turned)], axis=1)
    return face_kernel.from_matrix(matrices.reshape(-1, 3, 3)).reshape(matrices.shape[:2] + (4,))


@pytest.mark.parametrize("anchor, names", [("head", face_rig._HEAD_CARRIED), ("jaw", face_rig._JAW_CARRIED)])
def test_one_call_carry_into_is_the_carry_as_steps(avatar, anchor, names):
    """face_rig._carry_into (kernels/bba_face_rig.carry_into: held frames, solve, quaternions and bone turns in
    one call) against the same carry as separate steps, on random targets from rest to far beyond reach, with
    held frames."""
    plan = face_rig._carry_plan(avatar.skeleton, anchor, names)
    rng = np.random.default_rng(len(names) + 3)
    for scale in (0.0, 1e-4, 3e-3, 0.05):
        head = rng.normal(size=(30, len(names), 3)) * scale
        head[4:7] = head[3]
        head[9] = 0.0
        tail = head + rng.normal(size=head.shape) * scale * (rng.random((30, len(names), 1)) < 0.5)
        reference = _carry_by_steps(plan, head, tail)
        out = np.full((30, len(plan.names) + 2, 4), np.nan)
        face_rig._carry_into(plan, head, tail, out, 1)
        assert np.isnan(out[:, [0, -1]]).all()
        for k, name in enumerate(plan.names):
            np.testing.assert_allclose(out[:, 1 + k], reference[:, k], rtol=0, atol=CONVERSION_TOLERANCE,
                                       err_msg=f"{scale} {name}")


@pytest.mark.parametrize("n_frames", [0, 1])
def test_face_rig_takes_empty_and_single_frame_tracks(avatar, n_frames):
    faps = np.zeros((n_frames, 68), dtype=np.int64)
    result = face_bone_rotations(faps, avatar.skeleton, avatar_fapu(avatar))
    for rotation in result.values():
        assert rotation.shape == (n_frames, 4)
        assert np.array_equal(rotation, np.broadcast_to([1.0, 0.0, 0.0, 0.0], rotation.shape))


def test_compiled_from_rotvec_is_scipys():
    """media/rotation_loops.from_rotvec (the face rig's turns) against scipy's from_rotvec within 1e-15 per
    component, across its small-angle series (below 1e-4 rad)."""
    rng = np.random.default_rng(11)
    for scale in (0.0, 1e-7, 1e-5, 1e-4, 5e-4, 1e-3, 0.1, 1.0, 3.0, 7.0):
        rotvec = rng.normal(size=(500, 3)) * scale
        expected = Rotation.from_rotvec(rotvec).as_quat()[:, [3, 0, 1, 2]]
        np.testing.assert_allclose(rotation_loops.from_rotvec(rotvec), expected, rtol=0, atol=1e-15)


def test_both_sides_at_once_are_side_by_side(avatar):
    """face_rig._carried_bones (both sides' targets as (T, 2) arrays) against _carried_bones_by_side."""
    fapu = avatar_fapu(avatar)
    cases = [letter_motion("ase", letter, 25.0).faps for letter in "ABC"]
    cases += [synthetic_faps(60, 25.0, seed=5), _wild_faps(), -_wild_faps()]
    for faps in cases:
        face = face_rig._Displacements(np.asarray(faps), fapu)
        fast, reference = face_rig._carried_bones(face, avatar.skeleton), face_rig._carried_bones_by_side(face, avatar.skeleton)
        assert list(fast) == list(reference)
        for name in reference:
            np.testing.assert_allclose(fast[name], reference[name], rtol=0, atol=1e-15, err_msg=name)


@pytest.fixture(scope="module")
def real_faps():
    """FAPs of real fingerspelled letters in several sign languages (the motions the BBA encoder plays)."""
    return [letter_motion(language, letter, 25.0).faps
            for language, letters in (("ase", "KLMNO"), ("gsg", "ABCD"), ("fsl", "EFG"), ("ssp", "HI")) for letter in letters]


def test_compiled_displacements_and_eyes_are_the_numpy_rig(avatar, real_faps):
    """face_bone_rotations (media/face_bones.py face_targets, turn_*, eye_rotations; arctan2 / arccos and the
    arm products still NumPy's) against _face_bone_rotations_numpy (the displacements and eyes in NumPy), on
    real FAPs of many clips and languages, synthetic tracks and FAPs far beyond the rig's reach."""
    fapu = avatar_fapu(avatar)
    cases = real_faps + [synthetic_faps(80, 25.0, seed=seed) for seed in range(4)] + [_wild_faps(), -_wild_faps()]
    for faps in cases:
        fast = face_bone_rotations(faps, avatar.skeleton, fapu)
        reference = face_rig._face_bone_rotations_numpy(faps, avatar.skeleton, fapu)
        assert list(fast) == list(reference)
        for name in reference:
            np.testing.assert_allclose(fast[name], reference[name], rtol=0, atol=CONVERSION_TOLERANCE, err_msg=name)


def test_with_face_bones_places_the_face_after_the_body_and_replaces_face_bones_it_has(avatar):
    motion = letter_motion("ase", "B", 25.0)
    face = face_bone_rotations(motion.faps, avatar.skeleton, avatar_fapu(avatar))
    played = face_rig.with_face_bones(motion, avatar)
    assert played.bone_names == motion.bone_names + tuple(name for name in face if name not in motion.bone_names)
    assert np.array_equal(played.rotations[:, :len(motion.bone_names)][:, [n not in face for n in motion.bone_names]],
                          motion.rotations[:, [n not in face for n in motion.bone_names]])
    for name, rotation in face.items():
        assert np.array_equal(_bits(played.rotations[:, played.bone_names.index(name)]), _bits(rotation))
    # a motion that already carries some face bones keeps their places, with the face's rotations
    rest_face = played.rotations.copy()
    rest_face[:, len(motion.bone_names):] = [1.0, 0.0, 0.0, 0.0]
    again = face_rig.with_face_bones(Motion(played.fps, played.bone_names, rest_face, played.root_translation, played.faps),
                                     avatar)
    assert again.bone_names == played.bone_names
    assert np.array_equal(_bits(again.rotations), _bits(played.rotations))


def test_series_sine_and_versine_are_the_librarys_within_rounding():
    """face_rig_solve._sine_versine (Taylor series below SERIES_LIMIT, the solve's turns) against np.sin and
    1 - np.cos: within 5e-16 absolute (a few ulp of 1), on the whole range the solve uses and beyond
    it (np.sin / np.cos)."""
    rng = np.random.default_rng(3)
    for angles in (np.linspace(0.0, face_kernel.SERIES_LIMIT * 0.999, 100001), np.array([0.0, 1e-300, 1e-8, 0.3]),
                   rng.uniform(0.0, 3.0, 1000)):
        sine, versine = angles.copy(), np.empty_like(angles)
        face_kernel._sine_versine(sine, versine)
        np.testing.assert_allclose(sine, np.sin(angles), rtol=0, atol=5e-16)
        np.testing.assert_allclose(versine, 2 * np.sin(angles / 2) ** 2, rtol=0, atol=5e-16)

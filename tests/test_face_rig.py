import numpy as np
import pytest

from comparisons.params import fap_table
from kernels.skinning import skin
from media import rotations
from media.errors import SigncastError
from media.face_rig import (
    FAP_IDS,
    HEAD_ROTATION_FAP_IDS,
    avatar_fapu,
    face_bone_rotations,
    face_landmarks,
    with_face_bones,
)
from media.kinematics import bone_matrices, world_rotations
from media.motion import N_FAPS, Motion
from media.render import AvatarRenderer, RenderSettings


def faps_of(n_frames: int = 1, **values: int) -> np.ndarray:
    faps = np.zeros((n_frames, N_FAPS), dtype=np.int64)
    for name, value in values.items():
        faps[:, FAP_IDS[name] - 1] = value
    return faps


def face_motion(avatar, **values: int) -> Motion:
    rest = Motion.rest(avatar.skeleton.names, 1)
    return Motion(rest.fps, rest.bone_names, rest.rotations, rest.root_translation, faps_of(**values))


def displacement(avatar, **values: int) -> np.ndarray:
    """(V, 3) metres each skin vertex moves when the rest pose plays these FAPs (NumPy skinning)."""
    matrices = bone_matrices(avatar.skeleton, with_face_bones(face_motion(avatar, **values), avatar))[0]
    posed = skin(avatar.vertices, avatar.weights, matrices.astype(np.float32), backend="numpy")
    return posed.astype(np.float64) - avatar.vertices


def dominated_by(avatar, bone: str) -> np.ndarray:
    return avatar.weights.dominant_bone() == avatar.skeleton.index(bone)


def test_rig_fap_ids_match_the_mpeg4_table():
    for name, fap_id in (FAP_IDS | HEAD_ROTATION_FAP_IDS).items():
        assert fap_table.fap(fap_id).name == name
    assert set(HEAD_ROTATION_FAP_IDS.values()) == set(fap_table.HEAD_ROTATION)
    assert not set(FAP_IDS.values()) & set(fap_table.HEAD_ROTATION)


def test_avatar_fapu_has_adult_face_proportions_and_a_symmetric_face(avatar):
    fapu = avatar_fapu(avatar)
    metres = {name: value * 1024 for name, value in fapu.__dict__.items()}
    assert 0.055 < metres["es"] < 0.07           # pupils ~6 cm apart
    assert 0.007 < metres["irisd"] < 0.013       # open eye ~1 cm from lid to lid
    assert 0.03 < metres["ens"] < 0.05
    assert 0.02 < metres["mns"] < 0.04
    assert 0.04 < metres["mw"] < 0.06
    points = face_landmarks(avatar)
    for name in ("pupil", "upper_lid", "lower_lid", "mouth_corner"):
        np.testing.assert_allclose(points[f"{name}.L"], points[f"{name}.R"] * [-1, 1, 1], atol=1e-4)
        assert points[f"{name}.L"][0] > 0                    # the avatar's left is +X
    assert points["upper_lid.L"][1] > points["pupil.L"][1] > points["lower_lid.L"][1]
    assert points["pupil.L"][1] > points["nose_tip"][1] > points["mouth_middle"][1]


def test_zero_faps_give_identity_rotations(avatar):
    result = face_bone_rotations(faps_of(3), avatar.skeleton, avatar_fapu(avatar))
    assert {"jaw", "oris05", "oris01", "levator05.L", "oculi01.R", "orbicularis03.L", "eye.R"} <= set(result)
    for q in result.values():
        assert q.shape == (3, 4)
        np.testing.assert_allclose(np.abs(q[:, 0]), 1.0, atol=1e-12)


def test_open_jaw_drops_the_chin_by_the_requested_displacement(avatar):
    fapu, sk, v = avatar_fapu(avatar), avatar.skeleton, avatar.vertices
    moved = displacement(avatar, open_jaw=400)
    wanted = 400 * fapu.mns
    chin_bottom = dominated_by(avatar, "jaw") & (np.abs(v[:, 0]) < 1e-4) & (v[:, 1] < sk.tails[sk.index("jaw"), 1] + 0.003)
    assert chin_bottom.sum() >= 3
    assert 0.7 * wanted < -moved[chin_bottom, 1].mean() < 1.3 * wanted
    nose_tip = np.argmin(np.linalg.norm(v - face_landmarks(avatar)["nose_tip"], axis=1))
    assert np.linalg.norm(moved[nose_tip]) < 1e-6


def test_closing_the_left_upper_lid_lowers_it_by_irisd_and_leaves_the_right_eye(avatar):
    fapu, v = avatar_fapu(avatar), avatar.vertices
    moved = displacement(avatar, close_t_l_eyelid=1024)
    margin = face_landmarks(avatar)["upper_lid.L"]
    lid_margin = dominated_by(avatar, "orbicularis03.L") & (np.linalg.norm(v - margin, axis=1) < 0.003)
    assert lid_margin.sum() >= 3
    wanted = 1024 * fapu.irisd
    assert 0.7 * wanted < -moved[lid_margin, 1].mean() < 1.3 * wanted
    assert np.abs(moved[v[:, 0] < 0]).max() < 1e-6


def test_raising_the_left_brow_moves_its_vertices_up_and_not_the_right_brow(avatar):
    fapu = avatar_fapu(avatar)
    moved = displacement(avatar, raise_l_i_eyebrow=300, raise_l_m_eyebrow=300)
    left_brow, right_brow = dominated_by(avatar, "oculi01.L"), dominated_by(avatar, "oculi01.R")
    assert left_brow.sum() >= 10
    assert moved[left_brow, 1].min() > 0 and moved[left_brow, 1].max() > 0.4 * 300 * fapu.ens
    assert np.abs(moved[right_brow]).max() < 1e-6


def test_lip_faps_move_the_lips_their_way(avatar):
    fapu, v = avatar_fapu(avatar), avatar.vertices
    corner = np.argmin(np.linalg.norm(v - face_landmarks(avatar)["mouth_corner.L"], axis=1))
    rounded = displacement(avatar, stretch_l_cornerlip=-200, stretch_l_cornerlip_o=-200)
    assert rounded[corner, 0] < -0.3 * 200 * fapu.mw                     # the left corner moves in
    pushed = displacement(avatar, push_t_lip=150, push_b_lip=150)
    for bone in ("oris05", "oris01"):
        assert pushed[dominated_by(avatar, bone), 2].mean() > 0.5 * 150 * fapu.mns
    lowered = displacement(avatar, lower_t_midlip=150, lower_t_midlip_o=150)
    assert lowered[dominated_by(avatar, "oris05"), 1].mean() < -0.5 * 150 * fapu.mns


def test_eyeball_faps_turn_the_eyes_by_their_angles(avatar):
    sk = avatar.skeleton
    motion = with_face_bones(face_motion(avatar, yaw_l_eyeball=20000, pitch_r_eyeball=-10000), avatar)
    world = world_rotations(sk, motion)[0]
    left, right = world[sk.index("eye.L")], world[sk.index("eye.R")]
    np.testing.assert_allclose(rotations.angle_between(rotations.IDENTITY, left), 0.2, atol=1e-9)
    np.testing.assert_allclose(rotations.rotate(left, np.array([0.0, 0.0, 1.0])), [np.sin(0.2), 0, np.cos(0.2)], atol=1e-9)
    np.testing.assert_allclose(rotations.rotate(right, np.array([0.0, 0.0, 1.0])), [0, np.sin(0.1), np.cos(0.1)], atol=1e-9)


def test_with_face_bones_is_idempotent_and_leaves_faceless_motions_alone(avatar):
    faceless = Motion.rest(avatar.skeleton.names[:5], 2)
    assert with_face_bones(faceless, avatar) is faceless
    rest = Motion.rest(("root", "head"), 2)
    motion = Motion(rest.fps, rest.bone_names, rest.rotations, rest.root_translation,
                    faps_of(2, open_jaw=300, close_t_r_eyelid=500, raise_r_m_eyebrow=200))
    once = with_face_bones(motion, avatar)
    twice = with_face_bones(once, avatar)
    assert once.bone_names[:2] == ("root", "head") and "jaw" in once.bone_names
    assert twice.bone_names == once.bone_names
    np.testing.assert_array_equal(twice.rotations, once.rotations)
    np.testing.assert_array_equal(once.faps, motion.faps)
    assert not np.allclose(once.rotations[:, once.bone("jaw")], rotations.IDENTITY)
    bones_only = with_face_bones(motion, avatar, keep_faps=False)
    assert bones_only.faps is None and bones_only.bone_names == once.bone_names
    np.testing.assert_array_equal(bones_only.rotations, once.rotations)


def test_face_bone_rotations_refuse_faps_of_the_wrong_shape(avatar):
    with pytest.raises(SigncastError, match="FAPs must be"):
        face_bone_rotations(np.zeros((2, 10), np.int64), avatar.skeleton, avatar_fapu(avatar))


def test_rendering_a_motion_with_faps_moves_the_face(avatar):
    renderer = AvatarRenderer(avatar, RenderSettings(width=352, height=288, backend="numpy"))
    neutral, neutral_labels = next(renderer.frames(face_motion(avatar)))
    open_mouth, _ = next(renderer.frames(face_motion(avatar, open_jaw=500)))
    changed = np.abs(neutral.astype(int) - open_mouth).max(axis=-1) > 16
    assert changed.sum() > 20
    assert np.all(np.isin(neutral_labels[changed], [0, 2]))     # the head, and the background the chin left


def _posed_skinned_bones(avatar, anchor: str, names: tuple, head_moved, tail_moved, settings: dict):
    """The carry (face_rig._carry with `settings`) as the skin sees it: each skinned bone's posed head (T, S, 3)
    and posed rotation (T, S, 3, 3) relative to the anchor (the carriers are unskinned), and the local turns
    (bone name -> (T, 4))."""
    from media import face_rig
    skeleton = avatar.skeleton
    targets = {name: (head_moved[:, k], tail_moved[:, k]) for k, name in enumerate(names)}
    solved = face_rig._carry(skeleton, anchor, targets, **settings)
    plan = face_rig._carry_plan(skeleton, anchor, names)
    local = np.stack([rotations.to_matrix(solved[skeleton.names[bone]]) for bone in plan.carriers], axis=1)
    world = face_rig._carrier_poses(skeleton, anchor, plan.carriers, local)
    heads, turns = [], []
    for name in names:
        bone = skeleton.index(name)
        pose = world[int(skeleton.parents[bone])]
        heads.append(face_rig._transform(pose, skeleton.heads[bone]))
        turns.append(pose[0] @ rotations.to_matrix(solved[name]))
    return np.stack(heads, axis=1), np.stack(turns, axis=1), solved


def test_the_face_is_the_full_solves_within_the_stated_error(avatar):
    """The carry stops each frame on CARRY_TOLERANCE: every face bone's turn within FACE_TURN_ERROR_RAD of the full
    solve (all 10 iterations for every frame), the skinned bones' posed heads, which the skin follows, within
    FACE_HEAD_ERROR_M and their posed rotations equal to rounding, on real letters with faces in four sign
    languages, synthetic tracks and FAPs beyond the rig's reach."""
    from comparisons.params.fap_rates import synthetic_faps
    from media import face_bones, face_rig
    from media.fingerspelling import letter_motion
    fapu = avatar_fapu(avatar)
    rig = face_rig._face_rig(avatar.skeleton, fapu)
    cases = [letter_motion(language, letter, 25.0).faps
             for language, letters in (("ase", "ABJ"), ("bzs", "AB"), ("gsg", "C"), ("fsl", "E")) for letter in letters]
    wild = np.random.default_rng(7).integers(-3000, 3000, size=(30, N_FAPS))
    wild[::5] = 0
    cases += [synthetic_faps(60, 25.0, seed=seed) for seed in (0, 1)] + [wild]
    assert all(faps is not None for faps in cases)
    worst = turn_error = 0.0
    for faps in cases:
        _, _, head, tail, jaw = face_bones.face_targets(np.ascontiguousarray(faps, dtype=np.float64),
                                                        face_rig._TARGET_COLUMNS, rig.units, rig.shares,
                                                        face_rig.ANGLE_UNIT_RAD)
        for anchor, names, head_moved, tail_moved in (("head", face_rig._HEAD_CARRIED, head, tail),
                                                      ("jaw", face_rig._JAW_CARRIED, jaw, jaw)):
            heads, turns, solved = _posed_skinned_bones(avatar, anchor, names, head_moved, tail_moved, {})
            full_heads, full_turns, full_solved = _posed_skinned_bones(avatar, anchor, names, head_moved, tail_moved,
                                                                       face_rig.FULL_SOLVE)
            for name, full in full_solved.items():
                chord = np.linalg.norm(solved[name] - np.sign(np.sum(solved[name] * full, axis=-1))[:, None] * full,
                                       axis=-1)
                turn_error = max(turn_error, (2 * np.arcsin(np.minimum(chord / 2, 1.0))).max())
            worst = max(worst, np.abs(heads - full_heads).max())
            np.testing.assert_allclose(turns, full_turns, rtol=0, atol=1e-12)
    assert worst <= face_rig.FACE_HEAD_ERROR_M         # measured 2.5e-7 m
    assert turn_error <= face_rig.FACE_TURN_ERROR_RAD  # measured 4e-5 rad

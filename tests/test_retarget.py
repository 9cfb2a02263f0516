"""Retargeting real lexicon keypoints to the avatar: lifting, CCD IK, handshapes, accuracy."""
import numpy as np
import pytest

from media import fingerspelling, ik, lexicon, lifting, retarget, rotations
from media.avatar import load_avatar
from media.kinematics import joint_positions, world_rotations


@pytest.fixture(scope="module")
def skeleton():
    return load_avatar().skeleton


@pytest.fixture(scope="module")
def asl(skeleton):
    return {letter: retarget.retarget(lexicon.read_clip(lexicon.lookup("ase", letter)), skeleton) for letter in "ABGLV"}


def _fingertip_to_palm(skeleton, motion, side="R"):
    heads = joint_positions(skeleton, motion)
    tails = joint_positions(skeleton, motion, tails=True)
    tips = tails[:, [skeleton.index(f"finger{f}-3.{side}") for f in range(2, 6)]]
    palm = heads[:, [skeleton.index(f"finger{f}-1.{side}") for f in range(2, 6)] + [skeleton.index(f"wrist.{side}")]].mean(axis=1)
    return np.median(np.linalg.norm(tips - palm[:, None], axis=-1).mean(axis=1))


def test_out_of_plane_component_from_known_length():
    assert lifting.out_of_plane(np.array([0.03, 0.04]), 0.13) == pytest.approx(0.12)
    assert lifting.out_of_plane(np.array([0.3, 0.4]), 0.1) == 0.0   # longer image than bone: in the plane
    towards, away = lifting.lift_directions(np.array([[0.0, 0.05]]), 0.1)
    assert towards[0, 2] > 0 > away[0, 2]
    np.testing.assert_allclose(np.linalg.norm(towards, axis=-1), 1.0)


def test_triangle_fit_recovers_rotation_and_scale_up_to_depth_mirror():
    template = np.array([[0.0, 0.0, 0.0], [0.02, 0.09, 0.01], [-0.04, 0.08, 0.0]])
    truth = rotations.to_matrix(rotations.from_axis_angle(np.array([[0.3, -0.5, 0.8]]), np.array([0.9])))
    posed = np.einsum("tij,nj->tni", truth, template) * 1500.0       # pixels per metre
    rotation_a, rotation_b, scale = lifting.fit_triangle(posed[..., :2], template)
    assert scale[0] == pytest.approx(1500.0, rel=1e-6)
    errors = [np.abs(r[0] - truth[0]).max() for r in (rotation_a, rotation_b)]
    assert min(errors) < 1e-6
    mirror = np.diag([1.0, 1.0, -1.0])
    np.testing.assert_allclose(np.einsum("ij,nj->ni", rotation_a[0], template)[:, :2],
                               np.einsum("ij,nj->ni", rotation_b[0], template)[:, :2], atol=1e-9)
    np.testing.assert_allclose(mirror @ rotation_a[0] @ template.T, rotation_b[0] @ template.T, atol=1e-9)


def test_ccd_reaches_a_reachable_target_and_respects_limits():
    chain = [
        ik.ChainJoint("shoulder", np.zeros(3), np.eye(3), np.full(3, -np.pi), np.full(3, np.pi)),
        ik.ChainJoint("elbow", np.array([0.0, -0.3, 0.0]), np.array([[1.0, 0.0, 0.0]]), np.array([-2.5]), np.array([0.0])),
    ]
    base = np.tile(np.eye(4), (2, 1, 1))
    hand_rest = np.array([0.0, -0.6, 0.0])
    goal = np.array([[0.2, -0.3, 0.25], [0.0, -0.6, 0.0]])           # reachable (|goal| < 0.6)
    targets = ik.IKTargets(points=[(1, hand_rest, goal, 1.0)])
    angles = ik.solve_ccd(chain, base, targets, max_passes=100)
    reached = ik.chain_transforms(chain, angles, base)[1]
    hand = np.einsum("tij,j->ti", reached[:, :3, :3], hand_rest) + reached[:, :3, 3]
    np.testing.assert_allclose(hand, goal, atol=1e-3)
    # an elbow that may only bend one way cannot reach a goal needing the other: clamped, best effort
    limited = ik.solve_ccd(chain, base, ik.IKTargets(points=[(1, hand_rest, np.array([[0.0, -0.3, 0.3]] * 2), 1.0)]))
    assert np.all(limited[1] <= 0.0) and np.all(limited[1] >= -2.5)


def test_fist_a_and_flat_hand_b_differ_in_fingertip_to_palm_distance(skeleton, asl):
    fist = _fingertip_to_palm(skeleton, asl["A"].motion)
    flat = _fingertip_to_palm(skeleton, asl["B"].motion)
    assert flat > 0.075 and fist < 0.045                               # metres
    assert flat > 2.0 * fist


def test_retargeted_letters_have_no_nan_and_unit_quaternions(asl):
    for result in asl.values():
        q = result.motion.rotations
        assert np.all(np.isfinite(q))
        np.testing.assert_allclose(np.linalg.norm(q, axis=-1), 1.0, atol=1e-9)


def test_absent_left_hand_rests_in_the_neutral_posture(skeleton, asl):
    motion = asl["B"].motion
    assert asl["B"].hands == ("right",)
    rest = retarget.natural_rest(skeleton, "L")
    for bone in ("upperarm01.L", "lowerarm01.L", "lowerarm02.L", "wrist.L", "finger2-2.L", "finger1-2.L"):
        np.testing.assert_allclose(motion.rotations[:, motion.bone(bone)], np.tile(rest[bone], (motion.n_frames, 1)))
    hanging = joint_positions(skeleton, motion)[:, [skeleton.index("upperarm01.L"), skeleton.index("lowerarm01.L")]]
    upper = hanging[:, 1] - hanging[:, 0]
    assert np.all(np.degrees(np.arccos(-upper[:, 1] / np.linalg.norm(upper, axis=-1))) < 15.0)   # not the A-pose


def test_signing_hand_is_in_front_of_the_body_at_chest_to_head_height(skeleton, asl):
    for result in asl.values():
        heads = joint_positions(skeleton, result.motion)
        wrist = heads[:, skeleton.index("wrist.R")]
        shoulder = heads[:, skeleton.index("upperarm01.R")]
        chest = heads[:, skeleton.index("spine02")]
        assert np.all(wrist[:, 2] > shoulder[:, 2] + 0.03)            # in front
        assert np.all(wrist[:, 1] > chest[:, 1])                       # above the lower chest
        assert np.all(wrist[:, 1] < heads[:, skeleton.index("head"), 1] + 0.1)


def test_palm_of_b_faces_the_viewer(skeleton, asl):
    motion = asl["B"].motion
    world = world_rotations(skeleton, motion)[:, skeleton.index("wrist.R")]
    palmar = rotations.rotate(world, np.broadcast_to(retarget._palmar_normal(skeleton, "R"), (motion.n_frames, 3)))
    assert np.median(palmar[:, 2]) > 0.6


def test_handshapes_follow_keypoints_l_has_index_up_and_thumb_out(skeleton, asl):
    motion = asl["L"].motion
    heads = joint_positions(skeleton, motion)
    tails = joint_positions(skeleton, motion, tails=True)
    t = motion.n_frames * 2 // 3
    index_dir = tails[t, skeleton.index("finger2-3.R")] - heads[t, skeleton.index("finger2-1.R")]
    middle_tip = np.linalg.norm(tails[t, skeleton.index("finger3-3.R")] - heads[t, skeleton.index("wrist.R")])
    index_tip = np.linalg.norm(tails[t, skeleton.index("finger2-3.R")] - heads[t, skeleton.index("wrist.R")])
    assert index_dir[1] > 0.8 * np.linalg.norm(index_dir)             # the index points up
    assert index_tip > middle_tip + 0.03                               # the middle finger is folded


def test_left_handed_language_moves_the_left_arm_only(skeleton):
    result = retarget.retarget(lexicon.read_clip(lexicon.lookup("ise", "B")), skeleton)
    assert result.hands == ("left",)
    motion = result.motion
    assert rotations.angle_between(motion.rotations[:, motion.bone("lowerarm01.L")], np.array([1.0, 0, 0, 0])).max() > 0.2
    resting = retarget.natural_rest(skeleton, "R")["upperarm01.R"]
    np.testing.assert_allclose(motion.rotations[:, motion.bone("upperarm01.R")], np.tile(resting, (motion.n_frames, 1)))
    wrist = joint_positions(skeleton, motion)[:, skeleton.index("wrist.L")]
    assert np.all(wrist[:, 0] > 0.1)                                   # on the avatar's left (+X)


def test_bone_directions_follow_keypoints_within_a_few_degrees(skeleton, asl):
    for kind in ("2d", "3d"):
        pooled = {group: [] for group in retarget.BONE_GROUPS}
        for result in asl.values():
            for group, angles in retarget.direction_errors(result, skeleton)[kind].items():
                pooled[group].extend(angles)
        assert np.mean(pooled["arm"]) < 5.0, kind
        assert np.mean(pooled["fingers"]) < 15.0, kind
        assert np.mean(pooled["thumb"]) < 15.0, kind


def test_missing_hand_frames_take_the_nearest_seen_frame(skeleton):
    clip = lexicon.read_clip(lexicon.lookup("ase", "B"))
    clip.confidence["RIGHT_HAND_LANDMARKS"][5:9] = 0.0                 # hand lost for 4 frames
    clip.points["RIGHT_HAND_LANDMARKS"][5:9] = 0.0
    motion = retarget.retarget(clip, skeleton).motion
    assert np.all(np.isfinite(motion.rotations))
    finger = motion.bone("finger3-2.R")
    assert rotations.angle_between(motion.rotations[6, finger], motion.rotations[4, finger]) < 0.3


def test_open_hinge_brings_a_folded_forearm_forward():
    upper = np.array([[0.0, -1.0, 0.0]])                               # upper arm hangs down
    forearm_image = np.array([[0.02, 0.22]])                           # forearm image points straight up, full length
    direction = lifting.open_hinge(forearm_image, np.zeros(1), -upper, np.radians(35.0))
    interior = np.degrees(np.arccos(direction[0] @ -upper[0]))
    assert 35.0 <= interior < 40.0 and direction[0, 2] > 0               # just as far forward as the elbow needs
    same = lifting.open_hinge(np.array([[0.2, 0.0]]), np.array([0.1]), -upper, np.radians(35.0))
    np.testing.assert_allclose(same[0], np.array([0.2, 0.0, 0.1]) / np.linalg.norm([0.2, 0.0, 0.1]))


def test_smooth_choice_keeps_a_depth_mirror_unless_the_evidence_is_strong():
    flicker = np.array([[0.0, 0.1], [0.1, 0.0], [0.0, 0.1], [0.1, 0.0]])
    jump = np.tile(np.array([[0.0, 3.0], [3.0, 0.0]]), (3, 1, 1))
    assert retarget.smooth_choice(flicker, jump).tolist() == [0, 0, 0, 0]
    strong = np.array([[0.0, 5.0], [5.0, 0.0], [5.0, 0.0], [5.0, 0.0]])
    assert retarget.smooth_choice(strong, jump).tolist() == [0, 1, 1, 1]


def test_compiled_axis_matrices_are_the_numpy_broadcast():
    """media/ik.py's Rodrigues matrices compiled (media/rotation_loops.axis_matrices) against the NumPy form
    within 1e-15: random and axis-aligned axes, angles over eight decades, +-0."""
    rng = np.random.default_rng(2)
    for trial in range(300):
        n_axes, n_frames = int(rng.integers(1, 4)), int(rng.integers(1, 60))
        axes = rng.normal(size=(n_axes, 3))
        axes /= np.linalg.norm(axes, axis=1, keepdims=True)
        if trial % 4 == 0:
            axes = np.eye(3)[:n_axes] * rng.choice([-1.0, 1.0], (n_axes, 1))
        angles = rng.uniform(-4, 4, (n_frames, n_axes)) * 10.0 ** rng.uniform(-8, 0, (n_frames, n_axes))
        angles[:, 0] = 0.0 if trial % 5 == 0 else angles[:, 0]
        angles[:, -1] = -0.0 if trial % 7 == 0 else angles[:, -1]
        expected = ik._axis_matrices_numpy(axes, angles)
        np.testing.assert_allclose(ik._axis_matrices(axes, angles), expected, rtol=0, atol=1e-15)


def test_compiled_smooth_choice_is_the_numpy_loop():
    """media/viterbi.py against the NumPy loop: random costs with 2-4 options, exact ties (small integers)
    and NaNs (np.argmin takes the first NaN), one frame and two."""
    rng = np.random.default_rng(4)
    for trial in range(600):
        n_frames, n_options = int(rng.integers(1, 40)), int(rng.integers(2, 5))
        unary = rng.normal(size=(n_frames, n_options))
        pairwise = rng.normal(size=(max(n_frames - 1, 0), n_options, n_options))
        if trial % 3 == 1:                                   # ties
            unary, pairwise = np.round(unary), np.round(pairwise)
        if trial % 5 == 2:
            unary[rng.random(unary.shape) < 0.1] = np.nan
            pairwise[rng.random(pairwise.shape) < 0.1] = np.nan
        expected = retarget._smooth_choice_numpy(unary, pairwise)
        assert retarget.smooth_choice(unary, pairwise).tolist() == expected.tolist()


def test_palm_does_not_flip_while_the_hand_holds_still(skeleton):
    for letter in "AI":
        clip = lexicon.read_clip(lexicon.lookup("ase", letter))
        world = world_rotations(skeleton, retarget.retarget(clip, skeleton).motion)[:, skeleton.index("wrist.R")]
        keypoints = clip.points["RIGHT_HAND_LANDMARKS"][..., :2]
        still = np.linalg.norm(np.diff(keypoints, axis=0), axis=-1).max(axis=1) < 4.0   # pixels between frames
        steps = np.degrees(rotations.angle_between(world[1:], world[:-1]))
        assert still.sum() >= 8 and steps[still].max() < 15.0, letter


def _held_handshape(skeleton, letter):
    """(mean knuckle flexion of finger2..5-1 in degrees, mean fingertip-to-palm-centre distance in
    metres) per frame of an ASL letter's held span (no rise, no drop), right hand."""
    motion = fingerspelling.letter_motion("ase", letter, 25.0, keep_rise=False, keep_drop=False)
    knuckles = np.mean([np.degrees(rotations.to_axis_angle(motion.rotations[:, motion.bone(f"finger{f}-1.R")])[1])
                        for f in range(2, 6)], axis=0)
    heads = joint_positions(skeleton, motion)
    tails = joint_positions(skeleton, motion, tails=True)
    tips = tails[:, [skeleton.index(f"finger{f}-3.R") for f in range(2, 6)]]
    centre = heads[:, [skeleton.index(f"finger{f}-1.R") for f in range(2, 6)] + [skeleton.index("wrist.R")]].mean(axis=1)
    return knuckles, np.linalg.norm(tips - centre[:, None], axis=-1).mean(axis=1)


@pytest.mark.parametrize("letter", ["A", "S"])
def test_closed_handshapes_are_fists_with_flexed_knuckles(skeleton, letter):
    knuckles, tips = _held_handshape(skeleton, letter)
    assert np.median(knuckles) > 50.0, letter                          # degrees, all four knuckles together
    assert np.median(tips) < 0.04, letter                              # metres from the palm centre


def test_flat_hand_b_keeps_its_knuckles_straight(skeleton):
    knuckles, tips = _held_handshape(skeleton, "B")
    assert np.median(knuckles) < 25.0
    assert np.median(tips) > 0.07


def test_fist_knuckle_landmarks_are_moved_out_only_for_closed_hands(asl):
    closed = asl["A"].overridden["finger3-1.R"]
    assert closed.mean() > 0.5                                         # the held fist
    assert asl["B"].overridden["finger3-1.R"].mean() == 0.0            # an open hand keeps its landmarks
    assert all(not mask.any() for bone, mask in asl["B"].overridden.items())


def test_signer_lengths_come_from_the_whole_lexicon(skeleton):
    lengths = retarget.signer_lengths("ase", "right", skeleton)
    assert set(lengths) == {bone for chain in retarget.FINGER_CHAINS.values() for bone, _, _ in chain}
    avatar = np.linalg.norm(retarget._bone_vector(skeleton, "finger3-1.R"))
    assert 1.2 * avatar < lengths["finger3-1"] < 2.0 * avatar           # a real proximal phalanx is longer
    assert all(0.005 < value < 0.08 for value in lengths.values())      # metres

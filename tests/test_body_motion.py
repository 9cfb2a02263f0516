"""A body that signs like a person: shoulders shrug with the signer, the torso's roll stays small, and the
arm stays up between the letters of a word (real lexicon keypoints and words)."""
import dataclasses

import numpy as np
import pytest

from media import fingerspelling, lexicon, retarget, rotations
from media.avatar import load_avatar
from media.kinematics import joint_positions, world_rotations

POINT = {name: i for i, name in enumerate(lexicon.POSE_POINTS)}
WORDS = (("ase", "HELLO"), ("ase", "WORLD"), ("gsg", "WELT"), ("gsg", "WASSER"))


@pytest.fixture(scope="module")
def skeleton():
    return load_avatar().skeleton


@pytest.fixture(scope="module")
def palm(skeleton):
    """The avatar's palm length (wrist to middle knuckle), metres."""
    return float(np.linalg.norm(skeleton.heads[skeleton.index("finger3-1.R")] - skeleton.heads[skeleton.index("wrist.R")]))


@pytest.fixture(scope="module")
def words():
    return {key: (fingerspelling.fingerspell(*key), fingerspelling.letter_spans(*key)) for key in WORDS}


def _pose(clip):
    pose, valid = retarget._component(clip, lexicon.POSE_COMPONENT)
    return pose[:, :len(lexicon.POSE_POINTS)], valid[:, :len(lexicon.POSE_POINTS)]


def _still(clip, frame, n_frames=12):
    """The clip's keypoints of one frame, held for n_frames (a signer who does not move)."""
    points = {name: np.repeat(p[frame:frame + 1], n_frames, axis=0) for name, p in clip.points.items()}
    confidence = {name: np.repeat(c[frame:frame + 1], n_frames, axis=0) for name, c in clip.confidence.items()}
    return dataclasses.replace(clip, points=points, confidence=confidence)


def _angle_degrees(q):
    return np.degrees(rotations.to_axis_angle(q)[1])


def test_clavicles_and_spine_stay_within_their_clamps_on_real_clips(skeleton):
    for language, unit in (("ase", "J"), ("gsg", "W"), ("cse", "A"), ("ise", "B"), ("tsm", "M")):
        pose, valid = _pose(lexicon.read_clip(lexicon.lookup(language, unit)))
        elevations = np.degrees(retarget.clavicle_elevations(pose, valid, skeleton))
        assert np.all(np.abs(elevations) <= retarget.CLAVICLE_ELEVATION_MAX + 1e-9)
        assert np.abs(elevations).max() > 0.5                      # real signers do move their shoulders
        torso = retarget._torso_rotations(pose, valid, skeleton)
        roll = sum(_angle_degrees(torso[bone]) for bone in ("spine01", "spine02", "spine03"))
        assert np.all(roll <= retarget.SHOULDER_ROLL_MAX + 1e-6)


def test_a_still_signer_keeps_clavicles_at_rest_and_the_torso_still(skeleton):
    clip = _still(lexicon.read_clip(lexicon.lookup("ase", "B")), frame=12)
    pose, valid = _pose(clip)
    np.testing.assert_allclose(retarget.clavicle_elevations(pose, valid, skeleton), 0.0, atol=1e-12)
    motion = retarget.retarget_clip(clip, skeleton)
    for bone in ("clavicle.L", "clavicle.R", "shoulder01.L", "shoulder01.R"):
        assert _angle_degrees(motion.rotations[:, motion.bone(bone)]).max() < 1e-6
    for bone in retarget.TORSO_BONES:
        q = motion.rotations[:, motion.bone(bone)]
        assert rotations.angle_between(q, q[:1]).max() < 1e-9


def test_raising_one_shoulder_landmark_shrugs_that_clavicle_and_lifts_the_arm(skeleton):
    still = _still(lexicon.read_clip(lexicon.lookup("ase", "B")), frame=12, n_frames=16)
    raised = dataclasses.replace(still, points={name: p.copy() for name, p in still.points.items()})
    width = np.linalg.norm(still.points["POSE_LANDMARKS"][0, POINT["LEFT_SHOULDER"], :2]
                           - still.points["POSE_LANDMARKS"][0, POINT["RIGHT_SHOULDER"], :2])
    shrug = slice(0, 5)                        # (the [1, 2, 1] filter spreads it to frame 5) the median stays still
    raised.points["POSE_LANDMARKS"][shrug, POINT["LEFT_SHOULDER"], 1] -= 0.03 * width    # image y is down
    pose, valid = _pose(raised)
    elevations = np.degrees(retarget.clavicle_elevations(pose, valid, skeleton))
    assert np.all(elevations[1:4, 0] > 2.0) and np.all(elevations[1:4, 0] <= retarget.CLAVICLE_ELEVATION_MAX)
    np.testing.assert_allclose(elevations[:, 1], 0.0, atol=1e-9)           # the other shoulder stays
    assert np.abs(elevations[8:, 0]).max() < 1e-9
    before, after = (retarget.retarget_clip(clip, skeleton) for clip in (still, raised))
    joint = skeleton.index("upperarm01.L")                                  # the avatar's left shoulder joint
    lift = joint_positions(skeleton, after)[2, joint] - joint_positions(skeleton, before)[2, joint]
    avatar_width = np.linalg.norm(skeleton.heads[joint] - skeleton.heads[skeleton.index("upperarm01.R")])
    assert 0.9 * 0.03 * avatar_width < lift[1] < 1.1 * 0.03 * avatar_width    # the shoulder rises as the landmark did
    assert abs(lift[0]) < 0.5 * lift[1] and abs(lift[2]) < 1e-3              # along the clavicle tip's arc
    # the unseen left arm (ASL signs right-handed) hangs the same way, only higher: it does not swing
    arm = skeleton.index("lowerarm01.L")
    turned = rotations.angle_between(world_rotations(skeleton, after)[2, arm], world_rotations(skeleton, before)[2, arm])
    assert turned < 0.02                                                     # radians
    # the shrug is not read as a sideways lean: the spine's roll barely moves
    spine = after.bone("spine01")
    assert np.degrees(rotations.angle_between(after.rotations[2, spine], before.rotations[2, spine])) < 0.2


def test_mediapipe_depth_does_not_turn_the_torso(skeleton):
    """z is not driven (docs/retargeting.md): pushing one shoulder's z leaves the motion as it was."""
    clip = lexicon.read_clip(lexicon.lookup("ase", "B"))
    pushed = dataclasses.replace(clip, points={name: p.copy() for name, p in clip.points.items()})
    pushed.points["POSE_LANDMARKS"][:, POINT["LEFT_SHOULDER"], 2] += 50.0
    np.testing.assert_allclose(retarget.retarget_clip(pushed, skeleton).rotations,
                               retarget.retarget_clip(clip, skeleton).rotations)


def test_arm_stays_up_between_letters_of_real_words(words, palm):
    for (language, word), (motion, spans) in words.items():
        drops = fingerspelling.interletter_drops(motion, spans)
        assert len(drops) == len(spans) - 1
        assert drops.max() < 0.3 * palm, f"{language} {word}: drop {drops.max() / palm:.2f} palm lengths"


def test_interletter_drop_sees_an_arm_dropped_between_letters(words, skeleton, palm):
    motion, spans = words[("gsg", "WELT")]
    dropped = motion.copy()
    (_, _, end_w), (_, start_e, _) = spans[0], spans[1]
    # the last of W's frames and the first of E's replaced by the arm hanging at rest (the clip's first frame)
    first = fingerspelling.letter_motion("gsg", "W")
    arm = [dropped.bone_names.index(f"{bone}.R") for bone in ("upperarm01", "lowerarm01", "lowerarm02", "wrist")]
    dropped.rotations[end_w - 1:start_e + 1, arm] = first.rotations[0, arm]
    assert fingerspelling.interletter_drop(dropped, spans, skeleton) > 0.3 * palm
    assert fingerspelling.interletter_drop(motion, spans[:1], skeleton) == 0.0


def test_first_letter_still_rises_and_last_still_drops(words, skeleton, palm):
    wrist = skeleton.index("wrist.R")
    for (language, word), (motion, spans) in words.items():
        height = joint_positions(skeleton, motion)[:, wrist, 1]
        first_hold = np.median(height[spans[0][1]:spans[0][2]])
        last_hold = np.median(height[spans[-1][1]:spans[-1][2]])
        assert height[0] < first_hold - 0.3 * palm, f"{language} {word}: no rise"
        assert height[-1] < last_hold - 0.3 * palm, f"{language} {word}: no drop"


def test_held_span_cuts_a_slow_ending_drop_and_keeps_a_letters_own_movement():
    # DGS W: a jittery frame in its drop stopped the former per-frame rule, which kept the drop
    clip = lexicon.read_clip(lexicon.lookup("gsg", "W"))
    start, stop = fingerspelling.held_span(clip)
    height = -clip.points["RIGHT_HAND_LANDMARKS"][:, 0, 1]
    palm_px = np.median(np.linalg.norm(clip.points["RIGHT_HAND_LANDMARKS"][:, 9, :2] - clip.points["RIGHT_HAND_LANDMARKS"][:, 0, :2], axis=-1))
    hold = np.median(height[start:stop])
    assert height[stop - 1] > hold - 0.3 * palm_px and height[start] > hold - 0.3 * palm_px
    assert stop <= clip.n_frames - 6
    # LSE H moves down and holds there before the drop: the low hold is kept
    clip = lexicon.read_clip(lexicon.lookup("ssp", "H"))
    start, stop = fingerspelling.held_span(clip)
    height = -clip.points["RIGHT_HAND_LANDMARKS"][:, 0, 1]
    assert height[start:stop].max() - height[stop - 1] > 100                 # pixels: the movement is inside
    assert stop < clip.n_frames

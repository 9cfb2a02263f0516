"""Retargeting any .pose (signcast motion/render --pose): the lexicon's retargeting on a copied lexicon file, the
natural rest of an unseen arm, one-line errors for bad files, and the One-Euro jitter filter."""
import shutil

import numpy as np
import pytest

from media import jitter_filter, lexicon, retarget, rotations
from media.avatar import load_avatar
from media.bvh import read_bvh
from media.errors import SigncastError
from media.kinematics import joint_positions
from media.pose_file import read_pose
from pipeline.cli import main


@pytest.fixture(scope="module")
def skeleton():
    return load_avatar().skeleton


@pytest.fixture
def asl_b(tmp_path):
    """A copy of the ASL letter B's lexicon .pose (right hand only), outside the lexicon."""
    path = tmp_path / "b.pose"
    shutil.copy(lexicon.lookup("ase", "B").path, path)
    return path


# --------------------------------------------------------------------------- One-Euro filter

def test_one_euro_keeps_a_constant_signal_constant():
    points = np.full((50, 3, 2), 123.5)
    filtered = jitter_filter.one_euro(points, np.ones((50, 3), bool), 25.0)
    np.testing.assert_allclose(filtered, points, atol=1e-12)


def test_one_euro_follows_a_step():
    points = np.zeros((60, 1, 1))
    points[20:] = 100.0
    filtered = jitter_filter.one_euro(points, np.ones((60, 1), bool), 25.0, jitter_filter.OneEuro(1.0, 2.0, 1.0))
    assert filtered[20, 0, 0] > 5.0                          # reacts in the step's frame (speed raises the cutoff)
    assert np.all(np.diff(filtered[:, 0, 0]) >= -1e-9)       # no overshoot back
    assert abs(filtered[-1, 0, 0] - 100.0) < 1.0              # and settles on it


def test_one_euro_leaves_missing_points_missing_and_restarts_after_a_long_gap():
    points = np.zeros((40, 1, 1))
    points[25:] = 50.0
    points[10:25] = -7.0                                      # garbage under the missing samples
    valid = np.ones((40, 1), bool)
    valid[10:25] = False
    filtered = jitter_filter.one_euro(points, valid, 25.0)
    np.testing.assert_array_equal(filtered[10:25], points[10:25])   # not read, not written
    assert np.all(filtered[:10] == 0.0)
    assert filtered[25, 0, 0] > 30.0                          # 0.6 s gap: the old value barely drags


def test_one_euro_lowers_jitter_on_a_noisy_still_point():
    rng = np.random.default_rng(3)
    # MediaPipe-like jitter, 1.5 px for 150 px between the shoulders, in shoulder widths as media.retarget filters
    points = (200.0 + rng.normal(0.0, 1.5, size=(200, 5, 2))) / 150.0
    filtered = jitter_filter.one_euro(points, np.ones((200, 5), bool), 25.0, retarget.ONE_EURO)
    raw_steps = np.abs(np.diff(points, axis=0)).mean()
    filtered_steps = np.abs(np.diff(filtered, axis=0)).mean()
    assert filtered_steps < 0.4 * raw_steps


def test_unknown_filter_and_bad_settings_are_refused():
    with pytest.raises(SigncastError, match="unknown jitter filter"):
        jitter_filter.check_filter("kalman")
    with pytest.raises(SigncastError, match="min_cutoff"):
        jitter_filter.OneEuro(min_cutoff=0.0)


# --------------------------------------------------------------------------- retargeting a .pose

def test_pose_copy_of_a_lexicon_clip_retargets_like_the_lexicon(skeleton, asl_b):
    entry = lexicon.lookup("ase", "B")
    lexicon_result = retarget.retarget(lexicon.read_clip(entry), skeleton)
    pose_result = retarget.retarget(read_pose(asl_b), skeleton, jitter_filter="binomial")
    assert pose_result.hands == lexicon_result.hands == ("right",)
    assert pose_result.motion.fps == lexicon_result.motion.fps
    lexicon_motion, pose_motion = lexicon_result.motion, pose_result.motion
    angle = lambda bone: np.degrees(rotations.angle_between(lexicon_motion.rotations[:, lexicon_motion.bone(bone)],
                                                            pose_motion.rotations[:, pose_motion.bone(bone)]))
    # the same torso and arm; the hand differs only by the phalanx lengths (the clip's own, not the signer's
    # over all ASL letters), which move the palm's depth choice a little
    for bone in retarget.TORSO_BONES + ("upperarm01.R", "lowerarm01.R"):
        assert angle(bone).max() < 2.0, bone
    for bone in ("lowerarm02.R", "wrist.R", "finger2-1.R", "finger3-2.R"):
        assert np.median(angle(bone)) < 10.0, bone


def test_unseen_arm_rests_beside_the_body_not_in_the_a_pose(skeleton, asl_b):
    motion = retarget.retarget(read_pose(asl_b), skeleton).motion          # a .pose: natural rest by default
    a_pose = retarget.retarget(read_pose(asl_b), skeleton, unseen_arm="a-pose").motion
    heads, tails = joint_positions(skeleton, motion), joint_positions(skeleton, motion, tails=True)
    wrist, shoulder, elbow = (heads[:, skeleton.index(name)] for name in ("wrist.L", "upperarm01.L", "lowerarm01.L"))
    fingertip = tails[:, skeleton.index("finger3-3.L")]
    hip = heads[:, skeleton.index("upperleg01.L")]
    assert np.all(fingertip[:, 1] < hip[:, 1])                          # the hand hangs below the hip joint
    upper = (elbow - shoulder) / np.linalg.norm(elbow - shoulder, axis=-1, keepdims=True)
    assert np.all(np.degrees(np.arccos(-upper[:, 1])) < 15.0)           # the upper arm nearly vertical
    a_pose_wrist = joint_positions(skeleton, a_pose)[:, skeleton.index("wrist.L")]
    assert np.all(a_pose_wrist[:, 0] > wrist[:, 0] + 0.1)               # the A-pose holds it far out
    assert np.all(wrist[:, 0] > 0.15)                                   # beside the body, on its left (+X)
    for bone in ("upperarm01.L", "lowerarm01.L", "finger2-2.L"):        # and still: the same every frame
        column = motion.rotations[:, motion.bone(bone)]
        np.testing.assert_allclose(column, np.broadcast_to(column[0], column.shape))


def test_natural_rest_is_mirrored_for_the_right_arm(skeleton):
    left, right = retarget.natural_rest(skeleton, "L"), retarget.natural_rest(skeleton, "R")
    assert set(name[:-2] for name in left) == set(name[:-2] for name in right)
    for name, q in left.items():
        mirrored = right[name[:-2] + ".R"]
        # mirroring X: (w, x, y, z) -> (w, x, -y, -z)
        np.testing.assert_allclose(rotations.canonical(mirrored), rotations.canonical(q * [1, 1, -1, -1]), atol=0.02)


def test_head_pitch_follows_the_nose_height(skeleton, asl_b):
    clip = read_pose(asl_b)
    nose = lexicon.POSE_POINTS.index("NOSE")
    level = retarget.retarget(clip, skeleton).motion
    clip.points["POSE_LANDMARKS"][:, nose, 1] += 10.0                   # the nose 10 px lower: a nod down
    nodding = retarget.retarget(clip, skeleton).motion
    head = level.bone("head")
    top = np.array([0.0, 1.0, 0.0])
    before = rotations.rotate(level.rotations[:, head], np.broadcast_to(top, (level.n_frames, 3)))
    after = rotations.rotate(nodding.rotations[:, head], np.broadcast_to(top, (level.n_frames, 3)))
    assert np.all(after[:, 2] > before[:, 2])                           # the head's top tips towards the viewer
    pitch = np.degrees(rotations.angle_between(level.rotations[:, head], nodding.rotations[:, head]))
    assert np.all(pitch < retarget.HEAD_PITCH_MAX / 4 + 0.1)           # small: a quarter of the clamp per bone


# --------------------------------------------------------------------------- the commands

def test_motion_command_writes_the_pose_files_motion_at_its_own_rate(tmp_path, capsys, skeleton, asl_b):
    output = tmp_path / "b.bvh"
    assert main(["motion", "--pose", str(asl_b), "-o", str(output)]) == 0
    out = capsys.readouterr().out
    assert "b.pose (hands: right)" in out
    motion, hierarchy = read_bvh(output)
    expected = retarget.retarget(read_pose(asl_b), skeleton).motion
    assert motion.n_frames == expected.n_frames and motion.fps == pytest.approx(expected.fps)
    for bone in ("finger2-2.R", "upperarm01.L", "head"):
        dots = np.abs(np.sum(motion.rotations[:, motion.bone_names.index(bone)]
                             * expected.rotations[:, expected.bone(bone)], axis=-1))
        assert dots.min() > 1 - 1e-9, bone


def test_motion_command_resamples_a_pose_to_fps_and_takes_a_jitter_filter(tmp_path, capsys, asl_b):
    output = tmp_path / "b.bvh"
    assert main(["motion", "--pose", str(asl_b), "-o", str(output), "--fps", "10", "--jitter-filter", "off"]) == 0
    capsys.readouterr()
    motion, _ = read_bvh(output)
    clip = read_pose(asl_b)
    assert motion.fps == pytest.approx(10.0)
    assert motion.n_frames == int(np.floor((clip.n_frames - 1) / clip.fps * 10 + 1e-9)) + 1


def test_a_two_handed_pose_drives_both_arms(tmp_path, capsys):
    path = tmp_path / "two.pose"
    entry = next(e for e in lexicon.entries("cse") if lexicon.read_clip(e).hand_visibility("left") > 0.5
                 and lexicon.read_clip(e).hand_visibility("right") > 0.5)
    shutil.copy(entry.path, path)
    assert main(["motion", "--pose", str(path), "-o", str(tmp_path / "two.bvh")]) == 0
    assert "(hands: left, right)" in capsys.readouterr().out


def test_a_pose_showing_no_hand_still_works_with_a_notice(tmp_path, capsys, skeleton, asl_b):
    from media.pose_file import write_pose
    clip = read_pose(asl_b)
    for name in lexicon.HAND_COMPONENTS.values():
        clip.confidence[name][:] = 0.0
        clip.points[name][:] = 0.0
    path = tmp_path / "nohands.pose"
    write_pose(path, clip, 500, 500)
    output = tmp_path / "nohands.bvh"
    assert main(["motion", "--pose", str(path), "-o", str(output)]) == 0
    captured = capsys.readouterr()
    notices = captured.err.strip().splitlines()
    assert len(notices) == 1 and "shows no hand" in notices[0] and "both arms rest" in notices[0]
    assert read_bvh(output)[0].n_frames == clip.n_frames
    heads = joint_positions(skeleton, retarget.retarget(read_pose(path), skeleton).motion)
    for side in "LR":
        assert np.all(heads[:, skeleton.index(f"wrist.{side}"), 1] < heads[:, skeleton.index("spine03"), 1])


@pytest.mark.parametrize("command", ["motion", "render"])
def test_corrupt_and_foreign_pose_files_are_one_line_errors(tmp_path, capsys, asl_b, command):
    from pose_format import Pose
    corrupt = tmp_path / "corrupt.pose"
    corrupt.write_bytes(asl_b.read_bytes()[:-100])
    foreign = tmp_path / "foreign.pose"
    pose = Pose.read(asl_b.read_bytes()).get_components(["POSE_LANDMARKS", "RIGHT_HAND_LANDMARKS"])
    with foreign.open("wb") as handle:
        pose.write(handle)
    output = tmp_path / ("x.bvh" if command == "motion" else "x.mkv")
    for path, message in ((corrupt, "damaged pose file"), (foreign, "not in the MediaPipe Holistic layout"),
                          (tmp_path / "missing.pose", "cannot read pose file")):
        assert main([command, "--pose", str(path), "-o", str(output)]) == 2
        err = capsys.readouterr().err.strip()
        assert message in err and len(err.splitlines()) == 1, err
        assert not output.exists()


@pytest.mark.parametrize("argv, message", [
    (["motion", "ase", "AB", "--pose", "x.pose"], "not both"),
    (["motion", "ase"], "give LANGUAGE WORD"),
    (["motion"], "give LANGUAGE WORD"),
    (["motion", "ase", "AB", "--jitter-filter", "off"], "--jitter-filter applies to --pose"),
    (["render", "ase", "AB", "--pose", "x.pose"], "not both"),
    (["motion", "--pose", "x.pose", "--jitter-filter", "kalman"], "invalid choice"),
])
def test_exactly_one_source_is_an_argparse_error(tmp_path, capsys, argv, message):
    with pytest.raises(SystemExit) as stop:
        main(argv + ["-o", str(tmp_path / "x.out")])
    assert stop.value.code == 2
    assert message in capsys.readouterr().err


def test_render_command_renders_a_pose_file_with_both_arms_posed(tmp_path, capsys, asl_b):
    video, preview = tmp_path / "b.mkv", tmp_path / "b.png"
    code = main(["render", "--pose", str(asl_b), "-o", str(video), "--size", "176x144", "--preview", str(preview),
                 "--no-progress", "--backend", "numpy", "--fps", "10"])
    assert code == 0
    out = capsys.readouterr().out
    assert "b.pose (hands: right)" in out and "at 10 fps" in out
    assert video.stat().st_size > 0 and preview.stat().st_size > 0


# --------------------------------------------------------------------------- relaxed rest hand, upright torso

def _rest_points(skeleton, side="L"):
    from media.motion import Motion
    pose = retarget.natural_rest(skeleton, side)
    names = tuple(pose)
    motion = Motion(25.0, names, np.stack([pose[n] for n in names])[None], np.zeros((1, 3)))
    return joint_positions(skeleton, motion)[0], joint_positions(skeleton, motion, tails=True)[0]


def test_the_resting_hand_is_relaxed_not_splayed(skeleton):
    """Fingers slightly curled at every joint and nearly together, the thumb's tip by the index finger (the
    neutral's straight fingers keep the rig's 11-16 deg spread and the thumb 6 cm from the index knuckle)."""
    heads, tails = _rest_points(skeleton)
    bone = lambda name: tails[skeleton.index(name)] - heads[skeleton.index(name)]
    unit = lambda v: v / np.linalg.norm(v)
    angle = lambda a, b: np.degrees(np.arccos(np.clip(unit(a) @ unit(b), -1.0, 1.0)))
    for finger in (2, 4, 5):                                  # proximal phalanges nearly parallel to the middle's
        assert angle(bone(f"finger{finger}-1.L"), bone("finger3-1.L")) < 7.0
    for finger in (2, 3, 4, 5):                               # each joint bent a little, none a fist
        chain = [bone(f"finger{finger}-{k}.L") for k in (1, 2, 3)]
        assert 20.0 < angle(chain[0], chain[1]) < 45.0 and 5.0 < angle(chain[1], chain[2]) < 30.0
    thumb_tip = tails[skeleton.index("finger1-3.L")]
    index_middle = tails[skeleton.index("finger2-2.L")]
    assert np.linalg.norm(thumb_tip - index_middle) < 0.045


def test_the_relaxed_rest_costs_its_stated_baps(skeleton, asl_b):
    """The idle left arm of a one-handed clip: exactly REST_ARM's non-zero values, each one constant BAP."""
    from comparisons.params.fba_mapping import avatar_bap_map, motion_to_baps
    values = motion_to_baps(retarget.retarget(read_pose(asl_b), skeleton).motion)
    bap_map = avatar_bap_map(skeleton)
    left_arm = [i for b in bap_map.bones if b.bone.endswith(".L") and b.bone.startswith(
        ("upperarm", "lowerarm", "wrist", "finger", "metacarpal")) for i in b.baps]
    moving = [i for i in left_arm if values[:, i - 1].any()]
    rest = retarget.REST_ARM
    nonzero = lambda values: int(np.count_nonzero(values))
    stated = (nonzero([rest[k] for k in ("flexion", "abduction", "elbow", "twist", "thumb_spread")])
              + 4 * nonzero(rest["finger_curl"]) + nonzero(rest["finger_spread"]) + nonzero(rest["thumb_curl"]))
    assert len(moving) == stated == 20
    assert np.all(values[:, [i - 1 for i in moving]] == values[:1, [i - 1 for i in moving]])


@pytest.fixture(scope="module")
def carphone_pose(tmp_path_factory):
    """carphone's first 30 frames as a .pose: a head-and-shoulders clip shot at a slant (shoulders and eyes
    15 deg off level), no hand seen."""
    path = tmp_path_factory.mktemp("carphone") / "c.pose"
    assert main(["pose", "carphone", "-o", str(path), "--frames", "30", "--no-progress"]) == 0
    return path


def test_an_undriven_torso_stays_upright_and_unseen_arms_rest(skeleton, carphone_pose):
    result = retarget.retarget(read_pose(carphone_pose), skeleton)
    motion = result.motion
    assert result.hands == ()
    for bone in ("spine01", "spine02", "spine03"):
        _, angle = rotations.to_axis_angle(motion.rotations[:, motion.bone(bone)])
        assert np.all(np.degrees(angle) < 2.0), bone               # formerly 5.9, 5.9 and 3.0 deg
    heads = joint_positions(skeleton, motion)
    rest = np.radians(retarget.NEUTRAL_ARM_ABDUCTION)
    for side, outwards in (("L", 1.0), ("R", -1.0)):
        upper = heads[:, skeleton.index(f"lowerarm01.{side}")] - heads[:, skeleton.index(f"upperarm01.{side}")]
        out = np.degrees(np.arctan2(outwards * upper[:, 0], -upper[:, 1]))   # out of the vertical, in the frontal plane
        assert np.all(np.abs(out - np.degrees(rest)) < 4.0), (side, out.min(), out.max())   # formerly 28-29 and 0
    neck = heads[:, skeleton.index("neck01")] - heads[:, skeleton.index("spine01")]
    assert np.all(np.degrees(np.arctan2(np.abs(neck[:, 0]), neck[:, 1])) < 3.0)            # upright

"""BVH export and import: exact round trip and an independent parser."""
import numpy as np
import pytest

from media import rotations
from media.avatar import load_avatar
from media.bvh import read_bvh, write_bvh
from media.errors import SigncastError
from media.kinematics import joint_positions
from media.motion import Motion


@pytest.fixture(scope="module")
def skeleton():
    return load_avatar().skeleton


@pytest.fixture(scope="module")
def random_motion(skeleton):
    rng = np.random.default_rng(1)
    motion = Motion.rest(skeleton.names, 6, fps=25.0)
    motion.rotations = rotations.canonical(rotations.from_axis_angle(rng.normal(size=(6, len(skeleton), 3)), rng.uniform(0, 2.5, (6, len(skeleton)))))
    motion.root_translation = rng.normal(size=(6, 3)) * 0.1
    return motion


def test_bvh_round_trip_is_exact_to_1e6(tmp_path, skeleton, random_motion):
    path = tmp_path / "m.bvh"
    write_bvh(path, random_motion, skeleton)
    back, hierarchy = read_bvh(path)
    order = [back.bone_names.index(name) for name in skeleton.names]
    dot = np.abs(np.sum(random_motion.rotations * back.rotations[:, order], axis=-1))
    assert np.all(1 - dot < 1e-12)
    assert np.abs(back.root_translation - random_motion.root_translation).max() < 1e-6
    assert back.fps == pytest.approx(25.0)
    rebuilt = hierarchy.to_skeleton()
    assert np.abs(rebuilt.heads[order] - skeleton.heads).max() < 1e-6
    assert np.abs(joint_positions(rebuilt, back)[:, order] - joint_positions(skeleton, random_motion)).max() < 1e-6


def test_bvh_opens_in_an_independent_parser(tmp_path, skeleton, random_motion):
    bvh = pytest.importorskip("bvh", reason="the independent parser `bvh` (pip install bvh) is a test extra")
    path = tmp_path / "m.bvh"
    write_bvh(path, random_motion, skeleton)
    parsed = bvh.Bvh(path.read_text())
    assert parsed.nframes == 6 and parsed.frame_time == pytest.approx(0.04)
    assert sorted(parsed.get_joints_names()) == sorted(skeleton.names)
    wrist = skeleton.index("wrist.R")
    z, x, y = np.radians(parsed.frame_joint_channels(3, "wrist.R", ["Zrotation", "Xrotation", "Yrotation"]))
    q = rotations.multiply(rotations.multiply(rotations.from_axis_angle([0, 0, 1], z), rotations.from_axis_angle([1, 0, 0], x)),
                           rotations.from_axis_angle([0, 1, 0], y))
    assert rotations.angle_between(q, random_motion.rotations[3, wrist]) < 1e-6
    offset = np.array(parsed.joint_offset("wrist.R")) / 100.0
    assert np.allclose(offset, skeleton.offsets()[wrist], atol=1e-6)


def test_bvh_rejects_truncated_file(tmp_path, skeleton, random_motion):
    path = tmp_path / "m.bvh"
    write_bvh(path, random_motion, skeleton)
    path.write_text(path.read_text()[:-200])
    with pytest.raises(SigncastError, match="not a valid BVH"):
        read_bvh(path)
    with pytest.raises(SigncastError, match="not found"):
        read_bvh(tmp_path / "missing.bvh")


_TWO_JOINTS = """HIERARCHY
ROOT hips
{{
  OFFSET 0 90 0
  CHANNELS {root_channels}
  JOINT spine
  {{
    OFFSET 0 10 0
    CHANNELS {spine_channels}
    End Site
    {{
      OFFSET 0 20 0
    }}
  }}
}}
MOTION
Frames: 1
Frame Time: 0.04
{values}
"""


def test_bvh_reader_rejects_position_channels_on_a_non_root_joint(tmp_path):
    path = tmp_path / "m.bvh"
    path.write_text(_TWO_JOINTS.format(root_channels="3 Zrotation Xrotation Yrotation",
                                       spine_channels="6 Xposition Yposition Zposition Zrotation Xrotation Yrotation",
                                       values="0 0 0 30 40 50 0 0 0"))
    with pytest.raises(SigncastError, match="spine.*non-root translations are not supported"):
        read_bvh(path)


def test_bvh_root_without_position_channels_stays_at_its_offset(tmp_path):
    path = tmp_path / "m.bvh"
    path.write_text(_TWO_JOINTS.format(root_channels="3 Zrotation Xrotation Yrotation",
                                       spine_channels="3 Zrotation Xrotation Yrotation", values="0 0 0 0 0 90"))
    motion, hierarchy = read_bvh(path)
    assert np.allclose(motion.root_translation, 0.0)
    assert np.allclose(hierarchy.offsets[0], [0.0, 0.9, 0.0])
    assert rotations.angle_between(motion.rotations[0, 1], rotations.from_axis_angle([0, 1, 0], np.pi / 2)) < 1e-9


def test_bvh_root_position_channels_give_the_translation_from_the_offset(tmp_path):
    path = tmp_path / "m.bvh"
    path.write_text(_TWO_JOINTS.format(root_channels="4 Yposition Zrotation Xrotation Yrotation",
                                       spine_channels="3 Zrotation Xrotation Yrotation", values="100 0 0 0 0 0 0"))
    motion, _ = read_bvh(path)
    assert np.allclose(motion.root_translation, [[0.0, 0.1, 0.0]])    # Y 100 cm against the 90 cm offset


def test_bvh_of_a_motion_with_faps_moves_the_face_joints_as_the_face_rig_does(tmp_path, skeleton):
    """`signcast motion` of a word with mouthing: the FAPs are played on the face bones (media.face_rig), and the
    file carries those rotations; read back by our reader and by the independent `bvh` parser, within 1e-6 rad."""
    from media.face_rig import face_bone_names, with_face_bones
    from media.motion import N_FAPS
    frames = 5
    faps = np.zeros((frames, N_FAPS), np.int64)
    ramp = np.linspace(0, 1, frames)
    for fap_id, amplitude in ((3, 400), (4, -150), (5, -150), (6, 120), (7, 120), (12, 100), (13, 100),
                              (19, 300), (20, 300), (31, 150), (32, 150), (33, 180), (34, 180), (53, 100), (54, 100)):
        faps[:, fap_id - 1] = np.round(amplitude * ramp)
    motion = Motion.rest(skeleton.names, frames, fps=25.0)
    motion.faps = faps
    path = tmp_path / "face.bvh"
    write_bvh(path, motion, skeleton)
    expected = with_face_bones(motion)
    face = [name for name in face_bone_names() if name in skeleton.names]
    back, _ = read_bvh(path)
    want = expected.rotations[:, [expected.bone_names.index(n) for n in face]]
    got = back.rotations[:, [back.bone_names.index(n) for n in face]]
    assert rotations.angle_between(got, want).max() < 1e-6
    moved = rotations.angle_between(got, rotations.IDENTITY).max(axis=0) > np.radians(0.5)
    assert moved.sum() >= 10, f"only {moved.sum()} face joints move"
    assert np.all(rotations.angle_between(got[0], rotations.IDENTITY) < 1e-9)     # FAPs 0: the face at rest
    bvh = pytest.importorskip("bvh", reason="the independent parser `bvh` (pip install bvh) is a test extra")
    parsed = bvh.Bvh(path.read_text())
    for k, name in enumerate(face):
        z, x, y = np.radians(parsed.frame_joint_channels(frames - 1, name, ["Zrotation", "Xrotation", "Yrotation"]))
        q = rotations.multiply(rotations.multiply(rotations.from_axis_angle([0, 0, 1], z),
                                                  rotations.from_axis_angle([1, 0, 0], x)),
                               rotations.from_axis_angle([0, 1, 0], y))
        assert rotations.angle_between(q, want[-1, k]) < 1e-6, name

"""Motion, forward kinematics, resampling and key-frame interpolation."""
import numpy as np
import pytest

from media import rotations
from media.avatar import load_avatar
from media.errors import SigncastError
from media.interpolation import interpolate_keys
from media.kinematics import bone_matrices, joint_positions
from media.motion import Motion, concatenate, resample


@pytest.fixture(scope="module")
def skeleton():
    return load_avatar().skeleton


def test_rest_motion_puts_joints_at_rest_heads(skeleton):
    positions = joint_positions(skeleton, Motion.rest(skeleton.names, 2))
    assert np.allclose(positions, skeleton.heads[None], atol=1e-12)
    assert np.allclose(bone_matrices(skeleton, Motion.rest(skeleton.names, 1)), np.eye(4), atol=1e-12)


def test_elbow_flexion_moves_the_wrist_on_a_circle(skeleton):
    motion = Motion.rest(skeleton.names, 1)
    elbow, wrist = skeleton.index("lowerarm01.L"), skeleton.index("wrist.L")
    motion.rotations[0, elbow] = rotations.from_axis_angle([1, 0, 0], -np.pi / 2)
    positions = joint_positions(skeleton, motion)[0]
    rest = skeleton.heads
    assert np.linalg.norm(positions[wrist] - positions[elbow]) == pytest.approx(np.linalg.norm(rest[wrist] - rest[elbow]))
    assert np.allclose(positions[: elbow + 1][skeleton.subtree(elbow)[: elbow + 1] == 0], rest[: elbow + 1][skeleton.subtree(elbow)[: elbow + 1] == 0])
    expected = rest[elbow] + rotations.rotate(rotations.from_axis_angle([1, 0, 0], -np.pi / 2), rest[wrist] - rest[elbow])
    assert np.allclose(positions[wrist], expected)


def test_root_translation_moves_everything(skeleton):
    motion = Motion.rest(skeleton.names, 1)
    motion.root_translation[0] = [0.1, -0.2, 0.3]
    assert np.allclose(joint_positions(skeleton, motion)[0], skeleton.heads + [0.1, -0.2, 0.3])


def test_resample_keeps_duration_and_interpolates(skeleton):
    motion = Motion.rest(skeleton.names, 26, fps=25.0)
    angles = np.linspace(0, 1.0, 26)
    motion.rotations[:, 5] = rotations.from_axis_angle(np.tile([0, 1, 0], (26, 1)), angles)
    for fps in (10, 15, 20, 25):
        out = resample(motion, fps)
        assert out.fps == fps
        assert out.n_frames == int(np.floor(1.0 * fps + 1e-9)) + 1
        _, angle = rotations.to_axis_angle(out.rotations[:, 5])
        assert np.allclose(angle, np.arange(out.n_frames) / fps, atol=1e-9)
    with pytest.raises(SigncastError, match="frame rate"):
        resample(motion, 0)


def test_two_keys_slerp_and_three_keys_cubic_spline(skeleton):
    keys = Motion.rest(skeleton.names, 3)
    keys.rotations[:, 7] = rotations.from_axis_angle(np.tile([1, 0, 0], (3, 1)), np.array([0.0, 1.0, 0.0]))
    keys.root_translation[:, 0] = [0.0, 1.0, 0.0]
    two = interpolate_keys(np.array([0.0, 1.0]), keys.frames(0, 2), np.linspace(0, 1, 5))
    _, angle = rotations.to_axis_angle(two.rotations[:, 7])
    assert np.allclose(angle, np.linspace(0, 1, 5))                       # constant angular speed
    three = interpolate_keys(np.array([0.0, 1.0, 2.0]), keys, np.linspace(0, 2, 9))
    assert np.allclose(np.linalg.norm(three.rotations, axis=-1), 1.0)
    assert np.allclose(three.root_translation[[0, 4, 8], 0], [0, 1, 0])  # passes through the keys
    assert three.root_translation[2, 0] > 0.5 * 1.0                       # smooth, above the linear chord
    _, angle3 = rotations.to_axis_angle(three.rotations[:, 7])
    assert angle3[4] == pytest.approx(1.0) and angle3[2] > 0.5


def test_motion_rejects_nan_and_bad_shapes(skeleton):
    q = np.zeros((2, len(skeleton), 4))
    q[..., 0] = 1
    q[1, 3, 0] = np.nan
    with pytest.raises(SigncastError, match="NaN"):
        Motion(25.0, skeleton.names, q, np.zeros((2, 3)))
    with pytest.raises(SigncastError, match="frame rate"):
        Motion(-1.0, skeleton.names, np.nan_to_num(q, nan=1.0), np.zeros((2, 3)))
    with pytest.raises(SigncastError, match="share"):
        concatenate([Motion.rest(skeleton.names, 1, 25), Motion.rest(skeleton.names, 1, 10)])


def test_euler_orders_round_trip():
    rng = np.random.default_rng(3)
    for order in ("XYZs", "ZXYr", "YZXs", "XZYr", "ZYZs", "XYXr"):
        angles = rng.uniform(-1, 1, (50, 3)) * [3.0, 1.4, 3.0]
        if order[0] == order[2]:
            angles[:, 1] = np.abs(angles[:, 1]) + 0.05
        back = rotations.to_euler(rotations.from_euler(angles, order), order)
        assert np.allclose(back, angles, atol=1e-12)

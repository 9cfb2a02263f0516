"""The constrained fit of arm and hand joint angles (media/hand_fit.py): forward kinematics equal to the avatar's,
an analytic Jacobian, exact recovery from exact targets (3D, and 2D where the limits choose the depth), and
anatomical limits that hold against targets that ask for more (no finger bends backwards or crosses another)."""
import numpy as np
import pytest

from media import hand_fit, rotations
from media.avatar import load_avatar
from media.kinematics import bone_matrices, joint_positions
from media.motion import Motion


@pytest.fixture(scope="module")
def setup():
    skeleton = load_avatar().skeleton
    model = hand_fit.ArmHandModel(skeleton, "R")
    rest = Motion(25.0, ["wrist.R"], np.array([[[1.0, 0.0, 0.0, 0.0]]]), np.zeros((1, 3)))
    base = bone_matrices(skeleton, rest)[0, skeleton.index("shoulder01.R")]
    return skeleton, model, base[:3, :3], base[:3, 3]


def _pose(model, rng):
    while True:
        theta = rng.uniform(0.7 * model.lower, 0.7 * model.upper)
        if not model.crossing(theta).any():
            return theta


def _targets(model, theta, rotation, translation):
    points = model.forward(theta, rotation, translation)[0]
    vectors = np.stack([points[b] - points[a] for a, b in hand_fit.SEGMENTS])
    units = vectors / np.linalg.norm(vectors, axis=-1, keepdims=True)
    return units[None], units[None, :, :2].copy()


def test_forward_kinematics_is_the_avatars(setup):
    skeleton, model, rotation, translation = setup
    theta = _pose(model, np.random.default_rng(0))
    local = model.local_quaternions(theta[None])
    motion = Motion(25.0, list(local), np.stack(list(local.values()), axis=1), np.zeros((1, 3)))
    heads = joint_positions(skeleton, motion)[0]
    points = model.forward(theta, rotation, translation)[0]
    assert np.allclose(points[hand_fit.ELBOW], heads[skeleton.index("lowerarm01.R")], atol=1e-12)
    assert np.allclose(points[hand_fit.HAND0 + 6], heads[skeleton.index("finger2-2.R")], atol=1e-12)


def test_jacobian_matches_finite_differences(setup):
    _, model, rotation, translation = setup
    theta = _pose(model, np.random.default_rng(1))
    points, axes, pivots = model.forward(theta, rotation, translation)
    analytic = model.point_jacobian(points, axes, pivots)
    step = 1e-6
    numeric = np.stack([(model.forward(theta + step * np.eye(model.n_dofs)[d], rotation, translation)[0] - points)
                        / step for d in range(model.n_dofs)], axis=-1)
    assert np.abs(analytic - numeric).max() < 1e-5


@pytest.mark.parametrize("depth", ["3d", "2d"])
def test_exact_targets_are_recovered(setup, depth):
    """From exact directions the angles come back; from their 2D projection too: the limits pick the depth."""
    _, model, rotation, translation = setup
    rng = np.random.default_rng(5)
    for _ in range(3):
        theta = _pose(model, rng)
        world, image = _targets(model, theta, rotation, translation)
        if depth == "2d":
            world = np.full_like(world, np.nan)
        angles, _ = hand_fit.fit_clip(model, rotation[None], translation[None], hand_fit.Targets(world, image))
        fitted, truth = model.local_quaternions(angles[0]), model.local_quaternions(theta)
        finger_error = np.mean([np.degrees(rotations.angle_between(truth[n], fitted[n]))
                                for n in truth if n.startswith("finger")])
        assert finger_error < (1.0 if depth == "3d" else 10.0)


def test_limits_hold_no_finger_bends_backwards_or_crosses_another(setup):
    """Targets asking every finger to bend backwards by 60 deg and the index to lie across the middle finger: the
    fit stays in the anatomical limits (PIP/DIP hinges never extend past -5/-10 deg) and the spreads do not cross."""
    _, model, rotation, translation = setup
    theta = model.rest.copy()
    wanted = theta.copy()
    for finger, joints in model.finger_joints.items():
        for joint in joints:
            wanted[model.dof_start[joint]] = -np.radians(60.0)                 # bent backwards
    index_spread = model._crossing[0][0]
    wanted[index_spread] = -model._crossing[0][2] * np.radians(40.0)          # index across the middle finger
    points = model.forward(np.clip(wanted, -np.pi, np.pi), rotation, translation)[0]
    vectors = np.stack([points[b] - points[a] for a, b in hand_fit.SEGMENTS])
    world = (vectors / np.linalg.norm(vectors, axis=-1, keepdims=True))[None]
    angles, _ = hand_fit.fit_clip(model, rotation[None], translation[None],
                                  hand_fit.Targets(world, world[..., :2].copy()))
    fitted = angles[0]
    assert np.all(fitted >= model.lower - 1e-9) and np.all(fitted <= model.upper + 1e-9)
    for finger, joints in model.finger_joints.items():
        for level, joint in enumerate(joints, start=1):
            flexion = np.degrees(fitted[model.dof_start[joint]])
            floor = {"thumb": (-50.0, -20.0, -20.0)}.get(finger, (-20.0, -5.0, -10.0))[level - 1]
            assert flexion >= floor - 1e-6
    assert np.all(model.crossing(fitted) < np.radians(3.0))

import numpy as np
import pytest

from media import rotations
from media.errors import SigncastError
from media.kinematics import bone_matrices, joint_positions
from media.motion import Motion
from media.muscles import activations
from media.domain import parse_size
from media.render import AvatarRenderer, RenderSettings, render_motion


def bent_elbow(avatar, degrees: float, side: str = "R") -> Motion:
    """Rest pose with one elbow bent `degrees` further (about the axis normal to upper arm and forearm)."""
    sk = avatar.skeleton
    shoulder, elbow, wrist = (sk.heads[sk.index(f"{n}.{side}")] for n in ("upperarm01", "lowerarm01", "wrist"))
    axis = np.cross(elbow - shoulder, wrist - elbow)
    motion = Motion.rest(sk.names, 1)
    motion.rotations[0, sk.index(f"lowerarm01.{side}")] = rotations.from_axis_angle(axis / np.linalg.norm(axis),
                                                                                      np.radians(degrees))
    return motion


def test_sizes_parse_and_bad_sizes_fail_with_one_line():
    assert parse_size("352x288") == (352, 288) and parse_size("400x340") == (400, 340) and parse_size("qcif") == (176, 144)
    for bad in ("352", "axb", "10x10", "352x288x3"):
        with pytest.raises(SigncastError, match=rf"^bad size '{bad}' for --size: "):
            parse_size(bad)


def test_elbow_flexion_contracts_only_that_arms_muscles(avatar):
    assert [m.name for m in avatar.muscles] == ["biceps.L", "forearm.L", "biceps.R", "forearm.R"]
    rest = activations(avatar.skeleton, avatar.muscles, joint_positions(avatar.skeleton, Motion.rest(avatar.skeleton.names, 1)))
    np.testing.assert_allclose(rest, 0.0, atol=1e-9)
    bent = activations(avatar.skeleton, avatar.muscles, joint_positions(avatar.skeleton, bent_elbow(avatar, 50)))[0]
    assert bent[0] == bent[1] == 0.0 and 0.4 < bent[2] == bent[3] < 0.7


def test_contracted_biceps_pushes_the_upper_arm_skin_out(avatar):
    renderer = AvatarRenderer(avatar, RenderSettings(backend="numpy"))
    motion = bent_elbow(avatar, 80)
    matrices = bone_matrices(avatar.skeleton, motion)[0]
    contraction = activations(avatar.skeleton, avatar.muscles, joint_positions(avatar.skeleton, motion))[0]
    with_muscles = renderer.pose_vertices(matrices, contraction)
    without = renderer.pose_vertices(matrices, np.zeros_like(contraction))
    moved = np.linalg.norm(with_muscles - without, axis=1)
    upper_arm = avatar.skeleton.index("upperarm02.R")
    dominant = avatar.weights.dominant_bone()
    assert moved.max() > 0.006
    assert np.all(np.isin(dominant[moved > 1e-4], [avatar.skeleton.index(n) for n in
                                                   ("upperarm01.R", "upperarm02.R", "lowerarm01.R", "lowerarm02.R")]))
    assert moved[dominant == upper_arm].max() > 0.005


def test_signing_space_frames_the_head_and_both_hands_while_fingerspelling(avatar, fingerspelling_ab):
    motion = fingerspelling_ab
    frames, labels = render_motion(avatar, motion,
                                   RenderSettings(width=176, height=144, backend="warp"))
    assert frames.shape == (motion.n_frames, 144, 176, 3) and labels.shape == (motion.n_frames, 144, 176)
    for label in labels[::8]:
        assert {0, 1, 2, 3, 4} <= set(np.unique(label))
        assert not np.any(label[0] == 2)                  # the head is not cut at the top
        assert not np.any(np.isin(label[:, [0, -1]], (3, 4)))   # nor the hands at the sides


def raised_arms(avatar) -> Motion:
    """Right arm raised with the elbow bent, left elbow bent, head turned: joints where segments split."""
    sk = avatar.skeleton
    motion = Motion.rest(sk.names, 1)
    for name, axis, degrees in [("upperarm01.R", (0, 0, 1), -50), ("lowerarm01.R", (1, 0, 0), -70),
                                ("wrist.R", (1, 0, 0), 40), ("head", (0, 1, 0), 35),
                                ("upperarm01.L", (0, 0, 1), 30), ("lowerarm01.L", (0, 1, 0), -60)]:
        motion.rotations[0, sk.index(name)] = rotations.from_axis_angle(np.array(axis, float), np.radians(degrees))
    return motion


def test_segmented_body_shows_seams_where_the_seamless_skin_stays_closed(avatar):
    motion = raised_arms(avatar)
    _, seamless = render_motion(avatar, motion, RenderSettings(width=352, height=288, backend="warp"))
    _, segmented = render_motion(avatar, motion, RenderSettings(width=352, height=288, segmented=True, backend="warp"))
    holes = (seamless[0] > 0) & (segmented[0] == 0)     # background seen through the opened seams
    assert np.count_nonzero(holes) > 30
    assert np.mean(seamless == segmented) > 0.99


def test_flat_look_frames_read_back_as_labels(avatar):
    from kernels.raster import FLAT_PALETTE
    frames, labels = render_motion(avatar, bent_elbow(avatar, 30), RenderSettings(176, 144, look="flat", backend="warp"))
    assert np.array_equal(frames, FLAT_PALETTE[labels])


def test_bad_look_or_backend_is_a_signcast_error(avatar):
    with pytest.raises(SigncastError, match=r"^unknown look 'toon': choose shaded or flat$"):
        AvatarRenderer(avatar, RenderSettings(look="toon"))
    with pytest.raises(SigncastError, match=r"^unknown backend 'cuda': choose one of warp, opencl, numpy, auto$"):
        AvatarRenderer(avatar, RenderSettings(backend="cuda"))


def test_kernel_errors_are_signcast_errors_so_the_command_line_catches_one_type():
    from kernels.errors import KernelError
    from kernels.raster import rasterize
    assert issubclass(KernelError, SigncastError)
    with pytest.raises(SigncastError, match=r"^image size must be whole pixels in \[1, 8192\], got 0x0$"):
        rasterize(np.zeros((3, 3), np.float32), np.array([[0, 1, 2]]), np.array([1], np.uint8),
                  np.eye(4, dtype=np.float32), 0, 0, backend="numpy")


@pytest.mark.parametrize("segmented", [False, True])
def test_render_pose_draws_what_draw_of_pose_vertices_draws_with_contracted_muscles(avatar, any_backend, segmented):
    renderer = AvatarRenderer(avatar, RenderSettings(width=176, height=144, backend=any_backend, segmented=segmented))
    motion = bent_elbow(avatar, 80)
    matrices = bone_matrices(avatar.skeleton, motion)[0]
    contraction = activations(avatar.skeleton, avatar.muscles, joint_positions(avatar.skeleton, motion))[0]
    assert contraction.max() > 0.4
    for activation in (contraction, np.zeros_like(contraction)):
        expected = renderer.draw(renderer.pose_vertices(matrices, activation))
        result = renderer.render_pose(matrices, activation)
        assert all(np.array_equal(r, e) for r, e in zip(result, expected))

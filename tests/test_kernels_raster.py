import numpy as np
import pytest

from kernels import backends
from kernels.camera import view_projection
from kernels.errors import KernelError
from kernels.raster import FLAT_PALETTE, rasterize
from media.avatar import load_avatar
from media.fingerspelling import fingerspell
from media.kinematics import bone_matrices
from media.render import signing_space_camera
from kernels.skinning import skin

OPENCL_SKIP_REASON = ("no OpenCL device can build kernels (install Debian's pocl-opencl-icd; the PoCL bundled "
                      "with pyopencl uses LLVM 14, which cannot target some newer CPUs)")
ACCELERATED = ["warp", pytest.param("opencl", marks=pytest.mark.skipif(not backends.opencl_available(),
                                                                     reason=OPENCL_SKIP_REASON))]

IDENTITY_CAMERA = np.eye(4, dtype=np.float32)   # positions are already clip coordinates with w = 1


@pytest.fixture(scope="module")
def signing_poses():
    """The avatar's skin in three frames of real fingerspelling (ASL 'AB')."""
    avatar = load_avatar()
    motion = fingerspell("ase", "AB", 25.0)
    matrices = bone_matrices(avatar.skeleton, motion).astype(np.float32)
    frames = np.linspace(0, motion.n_frames - 1, 3).astype(int)
    return avatar, [skin(avatar.vertices, avatar.weights, matrices[t], backend="numpy") for t in frames]


@pytest.mark.parametrize("backend", ACCELERATED)
@pytest.mark.parametrize("size", [(176, 144), (352, 288)])
def test_backends_agree_with_numpy_oracle_on_labels_and_triangles(signing_poses, backend, size):
    avatar, poses = signing_poses
    width, height = size
    camera = signing_space_camera(avatar, width, height)
    for positions in poses[:2] if size == (352, 288) else poses:
        reference = rasterize(positions, avatar.triangles, avatar.triangle_part, camera, width, height, backend="numpy")
        result = rasterize(positions, avatar.triangles, avatar.triangle_part, camera, width, height, backend=backend)
        assert [r.shape for r in result] == [(height, width, 3), (height, width), (height, width), (height, width)]
        assert np.mean(result[1] == reference[1]) >= 0.999
        assert np.mean(result[2] == reference[2]) >= 0.999
        assert np.mean(np.abs(result[0].astype(int) - reference[0]) <= 1) >= 0.999
        assert set(np.unique(reference[1])) == {0, 1, 2, 3, 4}


def test_labels_are_the_parts_of_the_visible_triangles(signing_poses):
    avatar, poses = signing_poses
    rgb, labels, triangle_id, depth = rasterize(poses[1], avatar.triangles, avatar.triangle_part,
                                                signing_space_camera(avatar, 176, 144), 176, 144, backend="numpy")
    covered = triangle_id >= 0
    assert np.array_equal(labels[covered], avatar.triangle_part[triangle_id[covered]])
    assert np.all(labels[~covered] == 0) and np.all(np.isinf(depth[~covered]))
    assert np.all((depth[covered] > 0) & (depth[covered] < 1))


@pytest.mark.parametrize("backend", ["numpy", *ACCELERATED])
def test_flat_look_paints_one_colour_per_part_so_masks_read_back_by_colour(signing_poses, backend):
    avatar, poses = signing_poses
    rgb, labels, _, _ = rasterize(poses[2], avatar.triangles, avatar.triangle_part,
                                  signing_space_camera(avatar, 176, 144), 176, 144, look="flat", backend=backend)
    assert np.array_equal(rgb, FLAT_PALETTE[labels])
    decoded = np.argmax(np.all(rgb[:, :, None, :] == FLAT_PALETTE[None, None], axis=-1), axis=-1)
    assert np.array_equal(decoded, labels)


def square(z=0.0, half=0.5):
    """Two counter-clockwise triangles covering [-half, half]^2 at clip depth z (a shared diagonal)."""
    positions = np.array([[-half, -half, z], [half, -half, z], [half, half, z], [-half, half, z]], np.float32)
    return positions, np.array([[0, 1, 2], [0, 2, 3]], np.int32)


@pytest.mark.parametrize("backend", ["numpy", *ACCELERATED])
def test_triangles_sharing_an_edge_cover_each_pixel_exactly_once(backend):
    positions, triangles = square()
    _, labels, triangle_id, _ = rasterize(positions, triangles, np.array([1, 2], np.uint8), IDENTITY_CAMERA, 64, 64,
                                          look="flat", backend=backend)
    # the square spans pixels 16..47 in both directions; its diagonal passes through 32 pixel centres
    assert np.count_nonzero(triangle_id >= 0) == 32 * 32
    assert np.all(triangle_id[16:48, 16:48] >= 0)
    assert {int(np.count_nonzero(triangle_id == 0)), int(np.count_nonzero(triangle_id == 1))} == {512 - 16, 512 + 16}


@pytest.mark.parametrize("backend", ["numpy", *ACCELERATED])
def test_nearest_surface_wins_whatever_the_triangle_order(backend):
    near, triangles = square(z=-0.5, half=0.25)
    far, _ = square(z=0.5, half=0.5)
    for order in (0, 1):
        layers = [near, far] if order == 0 else [far, near]
        parts = np.array([2, 2, 1, 1] if order == 0 else [1, 1, 2, 2], np.uint8)
        positions = np.concatenate(layers)
        both = np.concatenate([triangles, triangles + 4])
        _, labels, _, depth = rasterize(positions, both, parts, IDENTITY_CAMERA, 32, 32, look="flat", backend=backend)
        assert np.all(labels[12:20, 12:20] == 2) and np.count_nonzero(labels == 2) == 8 * 8
        assert np.all(labels[8:24, 8:24] > 0) and np.count_nonzero(labels == 1) == 16 * 16 - 8 * 8
        np.testing.assert_allclose(depth[16, 16], 0.25, atol=1e-6)   # window depth = clip z / 2 + 1 / 2


@pytest.mark.parametrize("backend", ["numpy", *ACCELERATED])
def test_back_faces_are_culled_unless_asked_for(backend):
    positions, triangles = square()
    clockwise = triangles[:, ::-1].copy()
    _, labels, _, _ = rasterize(positions, clockwise, np.array([1, 1], np.uint8), IDENTITY_CAMERA, 32, 32, backend=backend)
    assert not labels.any()
    _, labels, _, _ = rasterize(positions, clockwise, np.array([1, 1], np.uint8), IDENTITY_CAMERA, 32, 32,
                                cull_back_faces=False, backend=backend)
    assert np.count_nonzero(labels) == 16 * 16


def test_shaded_look_lights_faces_towards_the_key_light_brighter():
    positions, triangles = square()
    facing = rasterize(positions, triangles, np.array([2, 2], np.uint8), IDENTITY_CAMERA, 16, 16, backend="numpy")[0]
    camera = view_projection((0, 0, 3), (0, 0, 0), 30, 1.0, 1, 5)
    tilted = positions.copy()
    tilted[:, 2] = tilted[:, 0] * 0.9     # turned away from the light, which comes from +x
    turned = rasterize(tilted, triangles, np.array([2, 2], np.uint8), camera, 16, 16, backend="numpy")
    assert facing[8, 8].sum() > turned[0][8, 8].sum() > 0
    background = turned[0][0, 0]
    assert not np.array_equal(background, [0, 0, 0])


def test_any_resolution_renders_the_signer(signing_poses):
    avatar, poses = signing_poses
    for width, height in [(400, 340), (97, 61)]:
        rgb, labels, _, _ = rasterize(poses[0], avatar.triangles, avatar.triangle_part,
                                      signing_space_camera(avatar, width, height), width, height, backend="warp")
        assert rgb.shape == (height, width, 3) and {1, 2} <= set(np.unique(labels))


def test_rasterize_rejects_bad_arguments():
    positions, triangles = square()
    parts = np.array([1, 1], np.uint8)
    with pytest.raises(KernelError, match="look"):
        rasterize(positions, triangles, parts, IDENTITY_CAMERA, 8, 8, look="toon")
    with pytest.raises(KernelError, match="size"):
        rasterize(positions, triangles, parts, IDENTITY_CAMERA, 0, 8)
    with pytest.raises(KernelError, match="indices"):
        rasterize(positions, triangles + 10, parts, IDENTITY_CAMERA, 8, 8)
    with pytest.raises(KernelError, match="NaN"):
        rasterize(positions * np.nan, triangles, parts, IDENTITY_CAMERA, 8, 8)
    with pytest.raises(KernelError, match="shape"):
        rasterize(positions, triangles, parts, np.eye(3), 8, 8)

import numpy as np
import pytest

from kernels import backends, raster
from kernels.camera import view_projection
from kernels.errors import KernelError, SigncastError
from kernels.raster import FLAT_PALETTE, rasterize
from media.render import signing_space_camera

IDENTITY_CAMERA = np.eye(4, dtype=np.float32)   # positions are already clip coordinates with w = 1


@pytest.mark.parametrize("size", [(176, 144), (352, 288)])
def test_backends_agree_with_numpy_oracle_on_labels_and_triangles(avatar, signing_poses, accelerated_backend, size,
                                                                  shared_edge_pixels):
    width, height = size
    camera = signing_space_camera(avatar, width, height)
    for positions in signing_poses[:2] if size == (352, 288) else signing_poses:
        reference = rasterize(positions, avatar.triangles, avatar.triangle_part, camera, width, height, backend="numpy")
        result = rasterize(positions, avatar.triangles, avatar.triangle_part, camera, width, height,
                           backend=accelerated_backend)
        assert [r.shape for r in result] == [(height, width, 3), (height, width), (height, width), (height, width)]
        assert set(np.unique(reference[1])) == {0, 1, 2, 3, 4}
        # identical coverage (exact integer edge functions); another triangle only where triangles meet
        assert np.array_equal(result[2] >= 0, reference[2] >= 0)
        same = result[2] == reference[2]
        assert np.all(shared_edge_pixels(reference[2])[~same])
        assert np.mean(same) >= 0.999 and np.mean(result[1] == reference[1]) >= 0.999
        assert np.abs(result[0].astype(int) - reference[0])[same].max() <= 1       # same face, same colour
        np.testing.assert_allclose(result[3][same], reference[3][same], rtol=0, atol=1e-6)


def test_labels_are_the_parts_of_the_visible_triangles(avatar, signing_poses):
    _, labels, triangle_id, depth = rasterize(signing_poses[1], avatar.triangles, avatar.triangle_part,
                                              signing_space_camera(avatar, 176, 144), 176, 144, backend="numpy")
    covered = triangle_id >= 0
    assert np.array_equal(labels[covered], avatar.triangle_part[triangle_id[covered]])
    assert np.all(labels[~covered] == 0) and np.all(np.isinf(depth[~covered]))
    assert np.all((depth[covered] > 0) & (depth[covered] < 1))


def test_flat_look_paints_one_colour_per_part_so_masks_read_back_by_colour(avatar, signing_poses, any_backend):
    rgb, labels, _, _ = rasterize(signing_poses[2], avatar.triangles, avatar.triangle_part,
                                  signing_space_camera(avatar, 176, 144), 176, 144, look="flat", backend=any_backend)
    assert np.array_equal(rgb, FLAT_PALETTE[labels])
    decoded = np.argmax(np.all(rgb[:, :, None, :] == FLAT_PALETTE[None, None], axis=-1), axis=-1)
    assert np.array_equal(decoded, labels)


def square(z=0.0, half=0.5):
    """Two counter-clockwise triangles covering [-half, half]^2 at clip depth z (a shared diagonal)."""
    positions = np.array([[-half, -half, z], [half, -half, z], [half, half, z], [-half, half, z]], np.float32)
    return positions, np.array([[0, 1, 2], [0, 2, 3]], np.int32)


def test_triangles_sharing_an_edge_cover_each_pixel_exactly_once(any_backend):
    positions, triangles = square()
    _, _, triangle_id, _ = rasterize(positions, triangles, np.array([1, 2], np.uint8), IDENTITY_CAMERA, 64, 64,
                                     look="flat", backend=any_backend)
    # the square spans pixels 16..47 in both directions; its diagonal passes through 32 pixel centres
    assert np.count_nonzero(triangle_id >= 0) == 32 * 32
    assert np.all(triangle_id[16:48, 16:48] >= 0)
    assert {int(np.count_nonzero(triangle_id == 0)), int(np.count_nonzero(triangle_id == 1))} == {512 - 16, 512 + 16}


def test_nearest_surface_wins_whatever_the_triangle_order(any_backend):
    near, triangles = square(z=-0.5, half=0.25)
    far, _ = square(z=0.5, half=0.5)
    for order in (0, 1):
        layers = [near, far] if order == 0 else [far, near]
        parts = np.array([2, 2, 1, 1] if order == 0 else [1, 1, 2, 2], np.uint8)
        positions = np.concatenate(layers)
        both = np.concatenate([triangles, triangles + 4])
        _, labels, _, depth = rasterize(positions, both, parts, IDENTITY_CAMERA, 32, 32, look="flat", backend=any_backend)
        assert np.all(labels[12:20, 12:20] == 2) and np.count_nonzero(labels == 2) == 8 * 8
        assert np.all(labels[8:24, 8:24] > 0) and np.count_nonzero(labels == 1) == 16 * 16 - 8 * 8
        np.testing.assert_allclose(depth[16, 16], 0.25, atol=1e-6)   # window depth = clip z / 2 + 1 / 2


def test_back_faces_are_culled_unless_asked_for(any_backend):
    positions, triangles = square()
    clockwise = triangles[:, ::-1].copy()
    _, labels, _, _ = rasterize(positions, clockwise, np.array([1, 1], np.uint8), IDENTITY_CAMERA, 32, 32, backend=any_backend)
    assert not labels.any()
    _, labels, _, _ = rasterize(positions, clockwise, np.array([1, 1], np.uint8), IDENTITY_CAMERA, 32, 32,
                                cull_back_faces=False, backend=any_backend)
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


def test_any_resolution_renders_the_signer(avatar, signing_poses):
    for width, height in [(400, 340), (97, 61)]:
        rgb, labels, _, _ = rasterize(signing_poses[0], avatar.triangles, avatar.triangle_part,
                                      signing_space_camera(avatar, width, height), width, height, backend="warp")
        assert rgb.shape == (height, width, 3) and {1, 2} <= set(np.unique(labels))


def test_rasterize_rejects_bad_arguments_with_a_signcast_error_naming_the_fault():
    positions, triangles = square()
    parts = np.array([1, 1], np.uint8)
    with pytest.raises(KernelError, match=r"^unknown look 'toon': choose shaded or flat$"):
        rasterize(positions, triangles, parts, IDENTITY_CAMERA, 8, 8, look="toon")
    with pytest.raises(KernelError, match=r"^image size must be whole pixels in \[1, 8192\], got 0x8$"):
        rasterize(positions, triangles, parts, IDENTITY_CAMERA, 0, 8)
    with pytest.raises(KernelError, match=r"^triangles: indices must lie in \[0, 4\), got \[10, 13\]$"):
        rasterize(positions, triangles + 10, parts, IDENTITY_CAMERA, 8, 8)
    with pytest.raises(KernelError, match=r"^positions hold NaN or infinite values$"):
        rasterize(positions * np.nan, triangles, parts, IDENTITY_CAMERA, 8, 8)
    with pytest.raises(KernelError, match=r"^camera: expected shape \(4, 4\), got \(3, 3\)$"):
        rasterize(positions, triangles, parts, np.eye(3), 8, 8)
    with pytest.raises(SigncastError, match=r"^unknown backend 'cuda': choose one of warp, opencl, numpy, auto$"):
        rasterize(positions, triangles, parts, IDENTITY_CAMERA, 8, 8, backend="cuda")


def test_opencl_source_receives_the_python_constants_as_defines():
    defines = dict(line.split()[1:] for line in raster._OPENCL_SOURCE.splitlines() if line.startswith("#define"))
    assert defines == {"SUBPIXEL": "256L", "HALF_SUBPIXEL": "128L", "MIN_CLIP_W": f"{float(np.float32(1e-6))!r}f",
                       "GUARD_PIXELS": "32768.0f", "DEPTH_SCALE": "2147483648.0f", "ID_SCALE": "4294967296L",
                       "EMPTY_KEY": "9223372036854775807L"}
    body = raster._OPENCL_SOURCE.split("#pragma", 1)[1]
    assert not [literal for literal in ("256", "128", "1e-6", "32768", "2147483648", "4294967296") if literal in body]
    with pytest.raises(KernelError, match="expected a number"):
        backends.opencl_defines({"LOOK": "flat"})


def test_triangles_between_pixel_centres_or_off_the_image_cover_nothing_like_the_oracle(any_backend):
    # pixel centres of a 16x16 image lie at clip x, y = (k + 0.5) / 8 - 1: a sliver between two of them is skipped,
    # a triangle whose corner sits exactly on a centre covers it by the top-left rule, as in the oracle
    positions = np.array([[0.01, 0.01, 0], [0.05, 0.01, 0], [0.05, 0.05, 0],           # between centres
                          [1.5, 1.5, 0], [1.9, 1.5, 0], [1.9, 1.9, 0],                 # off the image
                          [-0.1875, -0.1875, 0], [0.1875, -0.1875, 0], [-0.1875, 0.1875, 0]], np.float32)
    triangles = np.arange(9, dtype=np.int32).reshape(3, 3)
    parts = np.array([1, 2, 3], np.uint8)
    reference = rasterize(positions, triangles, parts, IDENTITY_CAMERA, 16, 16, backend="numpy")
    result = rasterize(positions, triangles, parts, IDENTITY_CAMERA, 16, 16, backend=any_backend)
    assert set(np.unique(reference[2])) == {-1, 2}
    for ours, oracle in zip(result, reference):
        assert np.array_equal(ours, oracle)


def test_consecutive_frames_each_start_from_an_empty_image(avatar, signing_poses, accelerated_backend):
    camera = signing_space_camera(avatar, 176, 144)
    rasterize(signing_poses[0], avatar.triangles, avatar.triangle_part, camera, 176, 144, backend=accelerated_backend)
    away = signing_poses[1] + np.float32([0, 0, -50])    # beyond the far plane: nothing is drawn
    _, labels, triangle_id, depth = rasterize(away, avatar.triangles, avatar.triangle_part, camera, 176, 144,
                                              backend=accelerated_backend)
    assert not labels.any() and np.all(triangle_id == -1) and np.all(np.isinf(depth))
    after = rasterize(signing_poses[2], avatar.triangles, avatar.triangle_part, camera, 176, 144,
                      backend=accelerated_backend)
    reference = rasterize(signing_poses[2], avatar.triangles, avatar.triangle_part, camera, 176, 144, backend="numpy")
    assert np.array_equal(after[2], reference[2]) and np.array_equal(after[1], reference[1])


def test_two_avatars_in_one_frame_and_a_changed_mesh_match_the_oracle(avatar, signing_poses, accelerated_backend):
    width, height = 240, 144
    camera = signing_space_camera(avatar, width, height)
    two = np.concatenate([signing_poses[0] - np.float32([0.4, 0, 0]), signing_poses[2] + np.float32([0.4, 0, 0])])
    triangles = np.concatenate([avatar.triangles, avatar.triangles + len(avatar.vertices)]).astype(np.int32)
    parts = np.tile(avatar.triangle_part, 2)
    for look in ("shaded", "flat"):
        reference = rasterize(two, triangles, parts, camera, width, height, look=look, backend="numpy")
        result = rasterize(two, triangles, parts, camera, width, height, look=look, backend=accelerated_backend)
        assert np.array_equal(result[2], reference[2]) and np.array_equal(result[1], reference[1])
        assert np.array_equal(result[0], reference[0])
        assert {int(t) // len(avatar.triangles) for t in np.unique(reference[2][reference[2] >= 0])} == {0, 1}
    # the same array changed in place (second copy turned inside out: its inner faces are now the front ones)
    triangles[len(avatar.triangles):] = triangles[len(avatar.triangles):, ::-1]
    inside_out = rasterize(two, triangles, parts, camera, width, height, backend="numpy")
    result = rasterize(two, triangles, parts, camera, width, height, backend=accelerated_backend)
    assert np.array_equal(result[2], inside_out[2])
    assert not np.array_equal(inside_out[2], reference[2])


def test_frames_that_change_pose_look_and_background_each_match_the_oracle_and_stay_as_returned(
        avatar, signing_poses, accelerated_backend):
    # The Warp body keeps its outputs between frames and rewrites only what changed (kernels/raster.py):
    # every frame must still equal the oracle's, and frames already returned must not change afterwards.
    width, height = 176, 144
    camera = signing_space_camera(avatar, width, height)
    away = signing_poses[1] + np.float32([0, 0, -50])    # beyond the far plane: nothing is drawn
    steps = [(signing_poses[0], "shaded", None), (signing_poses[2], "shaded", None), (away, "shaded", None),
             (signing_poses[1], "flat", None), (signing_poses[1], "shaded", np.uint8([10, 200, 30])),
             (signing_poses[0], "shaded", np.uint8([10, 200, 30])), (signing_poses[2], "flat", None)]
    kept = []
    for positions, look, background in steps:
        arguments = (positions, avatar.triangles, avatar.triangle_part, camera, width, height)
        reference = rasterize(*arguments, look=look, background=background, backend="numpy")
        result = rasterize(*arguments, look=look, background=background, backend=accelerated_backend)
        assert np.array_equal(result[2], reference[2]) and np.array_equal(result[1], reference[1])
        assert np.array_equal(result[0], reference[0]) and np.array_equal(result[3], reference[3])
        kept.append(([r.copy() for r in result], result))
    for copies, result in kept:
        assert all(np.array_equal(c, r) for c, r in zip(copies, result))


def test_static_inputs_changed_in_place_are_checked_and_drawn_again(any_backend):
    # Index checks of the mesh run once per array object and content (kernels/_arrays.py), and the
    # Warp-CPU body reads the caller's arrays in place: a change in place must be seen by both.
    positions, triangles = square()
    parts = np.array([1, 2], np.uint8)
    first = rasterize(positions, triangles, parts, IDENTITY_CAMERA, 16, 16, look="flat", backend=any_backend)
    assert set(np.unique(first[1])) == {0, 1, 2}
    parts[:] = 3
    second = rasterize(positions, triangles, parts, IDENTITY_CAMERA, 16, 16, look="flat", backend=any_backend)
    assert set(np.unique(second[1])) == {0, 3} and np.array_equal(second[2], first[2])
    assert set(np.unique(first[1])) == {0, 1, 2}                       # the earlier frame stays as returned
    triangles[1] = [0, 2, 9]
    with pytest.raises(KernelError, match=r"^triangles: indices must lie in \[0, 4\), got \[0, 9\]$"):
        rasterize(positions, triangles, parts, IDENTITY_CAMERA, 16, 16, backend=any_backend)
    triangles[1] = [0, 2, 3]
    parts[0] = 7
    with pytest.raises(KernelError, match=r"^triangle_part: indices must lie in \[0, 5\), got \[3, 7\]$"):
        rasterize(positions, triangles, parts, IDENTITY_CAMERA, 16, 16, look="flat", backend=any_backend)


def test_small_triangles_on_the_pixel_grid_match_the_oracle_frame_after_frame(accelerated_backend):
    # Tiny triangles of both orientations with vertices on a quarter-pixel grid, so that edges run through
    # pixel centres (top-left rule), many cover no centre at all and some lie partly off the image; the
    # frames reuse the buffers, so a lit colour left from a triangle's earlier frame would show in the RGB.
    rng = np.random.default_rng(22)
    width, height, count = 40, 32, 600
    triangles = np.arange(3 * count, dtype=np.int32).reshape(count, 3)
    parts = rng.integers(1, 5, count).astype(np.uint8)
    colours = rng.integers(0, 256, (count, 3)).astype(np.uint8)
    for frame in range(4):
        corner = rng.integers(-8, 4 * np.array([width, height]) + 8, (count, 1, 2))
        window = (corner + rng.integers(-12, 13, (count, 3, 2))).reshape(-1, 2) / 4.0
        positions = np.empty((3 * count, 3), np.float32)
        positions[:, 0] = window[:, 0] / width * 2 - 1
        positions[:, 1] = 1 - window[:, 1] / height * 2
        positions[:, 2] = rng.uniform(-1.2, 1.2, 3 * count)   # some vertices beyond the depth range
        for cull in (True, False):
            kwargs = {"triangle_colour": colours, "cull_back_faces": cull}
            reference = rasterize(positions, triangles, parts, IDENTITY_CAMERA, width, height, backend="numpy",
                                  **kwargs)
            result = rasterize(positions, triangles, parts, IDENTITY_CAMERA, width, height,
                               backend=accelerated_backend, **kwargs)
            assert np.count_nonzero(reference[2] >= 0) > 200, frame
            for expected, actual in zip(reference, result, strict=True):
                np.testing.assert_array_equal(actual, expected)

"""skin_and_rasterize: skinning and rasterization in one call (on OpenCL the posed positions stay on the
device) gives what rasterize(skin(...)) gives on the same backend, bit for bit, with the same checks."""
import numpy as np
import pytest

from kernels.errors import KernelError
from kernels.raster import rasterize
from kernels.skinned_raster import skin_and_rasterize
from kernels.skinning import skin
from media.render import signing_space_camera, triangle_colours


def _two_calls(avatar, matrices, camera, size, backend, **options):
    posed = skin(avatar.vertices, avatar.weights, matrices, backend=backend)
    return rasterize(posed, avatar.triangles, avatar.triangle_part, camera, *size, backend=backend, **options)


def _one_call(avatar, matrices, camera, size, backend, **options):
    return skin_and_rasterize(avatar.vertices, avatar.weights, matrices, avatar.triangles, avatar.triangle_part,
                              camera, *size, backend=backend, **options)


@pytest.mark.parametrize("look", ["shaded", "flat"])
def test_one_call_draws_what_the_two_calls_draw_frame_after_frame(avatar, signing_matrices, any_backend, look):
    size = (176, 144)
    camera = signing_space_camera(avatar, *size)
    colours = triangle_colours(avatar)
    for matrices in [*signing_matrices, signing_matrices[0]]:
        expected = _two_calls(avatar, matrices, camera, size, any_backend, look=look, triangle_colour=colours)
        result = _one_call(avatar, matrices, camera, size, any_backend, look=look, triangle_colour=colours)
        assert all(np.array_equal(r, e) for r, e in zip(result, expected))
        assert set(np.unique(result[1])) == {0, 1, 2, 3, 4}


def test_the_one_call_agrees_with_the_numpy_oracle_on_coverage(avatar, signing_matrices, accelerated_backend):
    size = (176, 144)
    camera = signing_space_camera(avatar, *size)
    reference = _one_call(avatar, signing_matrices[1], camera, size, "numpy")
    result = _one_call(avatar, signing_matrices[1], camera, size, accelerated_backend)
    assert np.array_equal(result[2] >= 0, reference[2] >= 0)
    assert np.mean(result[1] == reference[1]) >= 0.999


@pytest.mark.filterwarnings("ignore:overflow encountered:RuntimeWarning")   # the NumPy oracle casts to float32
def test_posed_positions_that_are_not_finite_are_rejected_and_the_next_frame_is_right(avatar, signing_matrices,
                                                                                      any_backend):
    size = (176, 144)
    camera = signing_space_camera(avatar, *size)
    _one_call(avatar, signing_matrices[0], camera, size, any_backend)
    overflowing = signing_matrices[1].copy()
    overflowing[:, 1, 1] = overflowing[:, 1, 3] = 3e38     # finite, but posed heights above 0.14 m overflow float32
    for bad in (overflowing, np.where(np.arange(4) == 3, np.nan, signing_matrices[1]).astype(np.float32)):
        with pytest.raises(KernelError, match="positions hold NaN or infinite values"):
            _one_call(avatar, bad, camera, size, any_backend)
    after = _one_call(avatar, signing_matrices[2], camera, size, any_backend)
    expected = _two_calls(avatar, signing_matrices[2], camera, size, any_backend)
    assert all(np.array_equal(r, e) for r, e in zip(after, expected))


def test_bad_arguments_get_the_same_errors_as_the_two_calls(avatar, signing_matrices, any_backend):
    camera = signing_space_camera(avatar, 176, 144)
    with pytest.raises(KernelError, match="unknown look"):
        _one_call(avatar, signing_matrices[0], camera, (176, 144), any_backend, look="glossy")
    with pytest.raises(KernelError, match="image size"):
        _one_call(avatar, signing_matrices[0], camera, (0, 144), any_backend)
    with pytest.raises(KernelError, match="bone_matrices"):
        _one_call(avatar, signing_matrices[0][:, :3], camera, (176, 144), any_backend)
    with pytest.raises(KernelError, match="weights.bones"):       # fewer bones than the weights name
        _one_call(avatar, signing_matrices[0][:10], camera, (176, 144), any_backend)

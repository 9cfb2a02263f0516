import numpy as np
import pytest

from kernels import backends
from kernels.errors import KernelError
from kernels.skinning import SparseWeights, skin, skin_rigid
from media.avatar import load_avatar
from media.fingerspelling import fingerspell
from media.kinematics import bone_matrices

OPENCL_SKIP_REASON = ("no OpenCL device can build kernels (install Debian's pocl-opencl-icd; the PoCL bundled "
                      "with pyopencl uses LLVM 14, which cannot target some newer CPUs)")
ACCELERATED = ["warp", pytest.param("opencl", marks=pytest.mark.skipif(not backends.opencl_available(),
                                                                     reason=OPENCL_SKIP_REASON))]


@pytest.fixture(scope="module")
def avatar():
    return load_avatar()


@pytest.fixture(scope="module")
def signing_matrices(avatar):
    """Bone matrices of three frames of real fingerspelling (ASL 'AB')."""
    motion = fingerspell("ase", "AB", 25.0)
    frames = np.linspace(0, motion.n_frames - 1, 3).astype(int)
    return bone_matrices(avatar.skeleton, motion)[frames].astype(np.float32)


def relative_error(result, reference):
    return np.abs(result - reference).max() / np.abs(reference).max()


@pytest.mark.parametrize("backend", ACCELERATED)
def test_linear_blend_skinning_matches_numpy_oracle_on_fingerspelling(avatar, signing_matrices, backend):
    for matrices in signing_matrices:
        reference = skin(avatar.vertices, avatar.weights, matrices, backend="numpy")
        result = skin(avatar.vertices, avatar.weights, matrices, backend=backend)
        assert result.shape == (len(avatar.vertices), 3) and result.dtype == np.float32
        assert relative_error(result, reference) < 1e-4


@pytest.mark.parametrize("backend", ACCELERATED)
def test_rigid_skinning_matches_numpy_oracle(avatar, signing_matrices, backend):
    dominant = avatar.weights.dominant_bone()
    reference = skin_rigid(avatar.vertices, dominant, signing_matrices[1], backend="numpy")
    result = skin_rigid(avatar.vertices, dominant, signing_matrices[1], backend=backend)
    assert relative_error(result, reference) < 1e-4


def test_skinning_oracle_is_weighted_sum_of_bone_transforms():
    rest = np.array([[1.0, 0.0, 0.0], [0.0, 2.0, 0.0]], np.float32)
    weights = SparseWeights(np.array([0, 2, 3]), np.array([0, 1, 1]), np.array([0.25, 0.75, 1.0], np.float32))
    translate = np.eye(4, dtype=np.float32)
    translate[:3, 3] = (0.0, 0.0, 4.0)
    quarter_turn_z = np.array([[0, -1, 0, 0], [1, 0, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], np.float32)
    posed = skin(rest, weights, np.stack([translate, quarter_turn_z]), backend="numpy")
    np.testing.assert_allclose(posed[0], 0.25 * np.array([1, 0, 4]) + 0.75 * np.array([0, 1, 0]), atol=1e-6)
    np.testing.assert_allclose(posed[1], [-2, 0, 0], atol=1e-6)


def test_identity_bones_leave_the_rest_pose_unchanged(avatar):
    identity = np.tile(np.eye(4, dtype=np.float32), (len(avatar.skeleton), 1, 1))
    for backend in ("numpy", "warp"):
        np.testing.assert_allclose(skin(avatar.vertices, avatar.weights, identity, backend=backend),
                                   avatar.vertices, atol=2e-6)


def test_segmented_body_parts_separate_where_the_seamless_skin_blends(avatar, signing_matrices):
    seamless = skin(avatar.vertices, avatar.weights, signing_matrices[1], backend="numpy")
    rigid = skin_rigid(avatar.vertices, avatar.weights.dominant_bone(), signing_matrices[1], backend="numpy")
    single = np.diff(avatar.weights.indptr) == 1
    gap = np.linalg.norm(seamless - rigid, axis=1)
    assert gap[single].max() < 1e-5           # one-bone vertices move the same way
    assert gap[~single].max() > 0.005         # blended vertices split apart: the seams


def test_skinning_rejects_bad_arguments(avatar):
    matrices = np.tile(np.eye(4, dtype=np.float32), (len(avatar.skeleton), 1, 1))
    with pytest.raises(KernelError, match="backend"):
        skin(avatar.vertices, avatar.weights, matrices, backend="cuda")
    with pytest.raises(KernelError, match="shape"):
        skin(avatar.vertices[:, :2], avatar.weights, matrices)
    with pytest.raises(KernelError, match="indices"):
        skin_rigid(avatar.vertices, np.full(len(avatar.vertices), 999), matrices)
    with pytest.raises(KernelError, match="CSR"):
        skin(avatar.vertices, object(), matrices)

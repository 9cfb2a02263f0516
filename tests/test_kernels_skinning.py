import numpy as np
import pytest

from kernels.errors import KernelError
from kernels.skinning import SkinWeights, skin, skin_rigid


def relative_error(result, reference):
    return np.abs(result - reference).max() / np.abs(reference).max()


def test_linear_blend_skinning_matches_numpy_oracle_on_fingerspelling(avatar, signing_matrices, accelerated_backend):
    for matrices in signing_matrices:
        reference = skin(avatar.vertices, avatar.weights, matrices, backend="numpy")
        result = skin(avatar.vertices, avatar.weights, matrices, backend=accelerated_backend)
        assert result.shape == (len(avatar.vertices), 3) and result.dtype == np.float32
        assert relative_error(result, reference) < 1e-4


def test_rigid_skinning_matches_numpy_oracle(avatar, signing_matrices, accelerated_backend):
    dominant = avatar.weights.dominant_bone()
    reference = skin_rigid(avatar.vertices, dominant, signing_matrices[1], backend="numpy")
    result = skin_rigid(avatar.vertices, dominant, signing_matrices[1], backend=accelerated_backend)
    assert relative_error(result, reference) < 1e-4


def test_skinning_oracle_is_weighted_sum_of_bone_transforms():
    rest = np.array([[1.0, 0.0, 0.0], [0.0, 2.0, 0.0]], np.float32)
    weights = SkinWeights(np.array([0, 2, 3]), np.array([0, 1, 1]), np.array([0.25, 0.75, 1.0], np.float32))
    translate = np.eye(4, dtype=np.float32)
    translate[:3, 3] = (0.0, 0.0, 4.0)
    quarter_turn_z = np.array([[0, -1, 0, 0], [1, 0, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], np.float32)
    posed = skin(rest, weights, np.stack([translate, quarter_turn_z]), backend="numpy")
    np.testing.assert_allclose(posed[0], 0.25 * np.array([1, 0, 4]) + 0.75 * np.array([0, 1, 0]), atol=1e-6)
    np.testing.assert_allclose(posed[1], [-2, 0, 0], atol=1e-6)


def test_identity_bones_leave_the_rest_pose_unchanged(avatar, any_backend):
    identity = np.tile(np.eye(4, dtype=np.float32), (len(avatar.skeleton), 1, 1))
    np.testing.assert_allclose(skin(avatar.vertices, avatar.weights, identity, backend=any_backend),
                               avatar.vertices, atol=2e-6)


def test_segmented_body_parts_separate_where_the_seamless_skin_blends(avatar, signing_matrices):
    seamless = skin(avatar.vertices, avatar.weights, signing_matrices[1], backend="numpy")
    rigid = skin_rigid(avatar.vertices, avatar.weights.dominant_bone(), signing_matrices[1], backend="numpy")
    single = np.diff(avatar.weights.indptr) == 1
    gap = np.linalg.norm(seamless - rigid, axis=1)
    assert gap[single].max() < 1e-5           # one-bone vertices move the same way
    assert gap[~single].max() > 0.005         # blended vertices split apart: the seams


def test_skinning_rejects_bad_arguments_naming_the_fault(avatar):
    matrices = np.tile(np.eye(4, dtype=np.float32), (len(avatar.skeleton), 1, 1))
    with pytest.raises(KernelError, match=r"^unknown backend 'cuda': choose one of warp, opencl, numpy, auto$"):
        skin(avatar.vertices, avatar.weights, matrices, backend="cuda")
    with pytest.raises(KernelError, match=r"^rest: expected shape \(N, 3\), got \(14537, 2\)$"):
        skin(avatar.vertices[:, :2], avatar.weights, matrices)
    with pytest.raises(KernelError, match=r"^dominant_bone: indices must lie in \[0, 163\), got \[999, 999\]$"):
        skin_rigid(avatar.vertices, np.full(len(avatar.vertices), 999), matrices)
    with pytest.raises(KernelError, match=r"^weights: expected CSR weights with indptr, bones and values$"):
        skin(avatar.vertices, object(), matrices)
    with pytest.raises(KernelError, match=r"^weights.indptr: must rise from 0 to the number of entries$"):
        skin(avatar.vertices, SkinWeights(avatar.weights.indptr[::-1].copy(), avatar.weights.bones,
                                          avatar.weights.values), matrices)


def test_dense_weights_round_trip_and_rows_are_renormalised():
    matrix = np.array([[0.5, 0.5, 0.0], [0.0, 2.0, 2e-7], [0.2, 0.2, 0.6]])
    weights = SkinWeights.from_dense(matrix)
    assert weights.n_vertices == 3 and weights.indptr.tolist() == [0, 2, 3, 6]
    np.testing.assert_allclose(weights.dense(3), [[0.5, 0.5, 0.0], [0.0, 1.0, 0.0], [0.2, 0.2, 0.6]], atol=1e-7)
    assert weights.dominant_bone().tolist() == [0, 1, 2]
    with pytest.raises(KernelError, match=r"^1 vertices have no bone weight$"):
        SkinWeights.from_dense(np.array([[1.0, 0.0], [0.0, 0.0]]))


def test_returned_poses_stay_as_returned_when_meshes_and_kernels_alternate(avatar, signing_matrices,
                                                                            accelerated_backend):
    # the kept device buffers and kernels (one set per kernel and mesh size) must not leak between calls
    dominant = avatar.weights.dominant_bone()
    half = len(avatar.vertices) // 2
    part = SkinWeights.from_dense(avatar.weights.dense(len(avatar.skeleton))[:half])
    results, references = [], []
    for matrices in signing_matrices[:2]:
        for function, rest, weights in ((skin, avatar.vertices, avatar.weights), (skin_rigid, avatar.vertices, dominant),
                                        (skin, avatar.vertices[:half], part)):
            results.append(function(rest, weights, matrices, backend=accelerated_backend))
            references.append(function(rest, weights, matrices, backend="numpy"))
    for result, reference in zip(results, references):
        assert result.shape == reference.shape and relative_error(result, reference) < 1e-4


def test_weights_changed_in_place_are_checked_and_used_again(avatar, signing_matrices, any_backend):
    # The weights' checks run once per array object and content (kernels/_arrays.py), and the Warp-CPU
    # body reads the caller's arrays in place: a change in place must be seen by both.
    weights = SkinWeights(avatar.weights.indptr.copy(), avatar.weights.bones.copy(), avatar.weights.values.copy())
    matrices = signing_matrices[1]
    before = skin(avatar.vertices, weights, matrices, backend=any_backend)
    weights.bones[:] = weights.bones[::-1]
    after = skin(avatar.vertices, weights, matrices, backend=any_backend)
    reference = skin(avatar.vertices, weights, matrices, backend="numpy")
    assert relative_error(after, reference) < 1e-4 and not np.allclose(after, before)
    weights.bones[0] = 999
    with pytest.raises(KernelError, match=r"^weights.bones: indices must lie in \[0, 163\), got \[\d+, 999\]$"):
        skin(avatar.vertices, weights, matrices, backend=any_backend)
    weights.bones[0] = 0
    weights.indptr[1] = weights.indptr[2] + 1
    with pytest.raises(KernelError, match=r"^weights.indptr: must rise from 0 to the number of entries$"):
        skin(avatar.vertices, weights, matrices, backend=any_backend)

"""Error measures: eq. 2.6 and the seed-002 chapter 6 family."""
import numpy as np
import pytest

from comparisons.judging import metrics
from media import rotations
from media.avatar import load_avatar
from media.errors import SigncastError
from media.motion import Motion


def test_distortion_is_the_mean_squared_norm_of_the_vector_error():
    original = np.array([[0.0, 0.0], [1.0, 1.0], [2.0, 0.0]])
    decoded = np.array([[0.0, 1.0], [1.0, 1.0], [0.0, 0.0]])
    assert metrics.distortion(original, decoded) == pytest.approx((1 + 0 + 4) / 3)
    with pytest.raises(SigncastError):
        metrics.distortion(original, decoded[:2])


def test_scalar_measures_match_their_definitions():
    original = np.array([[0.0], [2.0], [4.0], [2.0]])
    decoded = original + np.array([[1.0], [-1.0], [1.0], [-1.0]])
    assert metrics.mse(original, decoded)[0] == 1.0
    assert metrics.rmse(original, decoded)[0] == 1.0
    assert metrics.nmse(original, decoded)[0] == pytest.approx(4 / 24)
    assert metrics.pmse(original, decoded)[0] == pytest.approx(1 / 16)
    assert metrics.psnr(original, decoded)[0] == pytest.approx(10 * np.log10(16))
    assert metrics.nsnr(original, decoded)[0] == pytest.approx(10 * np.log10(6))
    assert np.isnan(metrics.psnr(np.ones((4, 1)), np.zeros((4, 1)))[0])     # constant original: no range


def test_weighted_vector_error_and_its_maximum_form():
    original = np.zeros((2, 3))
    decoded = np.array([[1.0, 2.0, 0.0], [0.0, 0.0, 3.0]])
    a, b = np.array([1.0, 0.5, 1.0]), np.array([2.0, 2.0, 3.0])
    assert metrics.weighted_vector_error(original, decoded, a, b).tolist() == pytest.approx([(0.25 + 0.5) / 3, 1 / 3])
    assert metrics.max_weighted_error(original, decoded, a, b).tolist() == pytest.approx([0.5, 1.0])


def test_vmse_with_unit_weights_equals_mse():
    rng = np.random.default_rng(0)
    original = np.cumsum(rng.normal(size=(90, 3)), axis=0)
    decoded = original + rng.normal(scale=0.3, size=original.shape)
    assert metrics.vmse(original, decoded, 30, weights=(1, 1, 1, 1)) == pytest.approx(metrics.mse(original, decoded))


def test_vpsnr_forgives_time_shifts_and_punishes_jitter():
    t = np.arange(300) / 30.0
    original = np.sin(2 * np.pi * 0.4 * t)[:, None]
    shifted = np.sin(2 * np.pi * 0.4 * (t - 0.1))[:, None]
    jitter = original + np.random.default_rng(1).normal(scale=0.05, size=original.shape)
    assert metrics.vpsnr(original, shifted, 30)[0] > metrics.psnr(original, shifted)[0] + 6
    assert metrics.vpsnr(original, jitter, 30)[0] < metrics.psnr(original, jitter)[0] - 3


def test_joint_position_error_is_zero_for_equal_motions_and_grows_with_rotation():
    skeleton = load_avatar().skeleton
    rest = Motion.rest(("upperarm01.R",), 2, 10)
    moved = rest.copy()
    moved.rotations[1, 0] = rotations.from_axis_angle(np.array([1.0, 0, 0]), 0.2)
    assert metrics.joint_position_error_mm(skeleton, rest, rest).max() == 0
    error = metrics.joint_position_error_mm(skeleton, rest, moved)
    assert error[0].max() == 0 and 30 < error[1].max() < 200           # the hand moves by centimetres


def test_bap_group_errors_cover_only_groups_that_move():
    original = np.zeros((4, 296))
    original[:, 37] = [0, 100, 200, 300]             # BAP 38, l_elbow_flexion, group "left arm 1"
    decoded = original.copy()
    decoded[1, 37] += 30
    groups = metrics.bap_group_errors(original, decoded)
    assert list(groups) == ["left arm 1"]
    mean_w, max_m = groups["left arm 1"]
    assert mean_w == pytest.approx((0.1 ** 2) / 4) and max_m == pytest.approx(0.1)

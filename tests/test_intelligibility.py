"""Landmark intelligibility: hand error in hand sizes, PCK, hands found, face error in interocular distances."""
import copy

import numpy as np
import pytest

from comparisons.judging.intelligibility import Intelligibility, hand_sizes, interocular_distances, measure
from comparisons.reports.records import INTELLIGIBILITY_FIELDS
from media import lexicon
from media.errors import SigncastError

RIGHT, FACE = "RIGHT_HAND_LANDMARKS", "FACE_LANDMARKS"


@pytest.fixture(scope="module")
def clip():
    """ASL B of the lexicon: right hand and face (with irises) in all 24 frames, no left hand."""
    return lexicon.read_clip(lexicon.lookup("ase", "B"))


def _copy(clip):
    return copy.deepcopy(clip)


def test_a_clip_against_itself_is_perfect(clip):
    result = measure(clip, clip)
    assert result.hand_error == 0 and result.hand_error_p90 == 0
    assert result.hand_pck_10 == 100 and result.hand_pck_20 == 100
    assert result.right_hand_found == 100 and result.left_hand_found is None   # ASL never shows the left hand
    assert result.face_error == 0 and result.face_found == 100
    assert set(result.fields()) <= set(INTELLIGIBILITY_FIELDS)
    assert "left_hand_found" not in result.fields() and result.fields()["hand_pck_20"] == 100


def test_hands_shifted_by_0_15_hand_sizes(clip):
    observed = _copy(clip)
    sizes = hand_sizes(clip.points[RIGHT])
    observed.points[RIGHT] = clip.points[RIGHT] + np.stack([0.15 * sizes, 0 * sizes, 0 * sizes], -1)[:, None, :]
    result = measure(clip, observed)
    assert result.hand_error == pytest.approx(0.15) and result.hand_error_p90 == pytest.approx(0.15)
    assert result.hand_pck_10 == 0 and result.hand_pck_20 == 100


def test_hand_size_is_the_palm_not_the_fingers(clip):
    points = clip.points[RIGHT][:1].copy()
    fist = points.copy()
    fist[:, 10:13] = points[:, 9:10]                  # middle finger folded onto its MCP
    assert hand_sizes(fist) == pytest.approx(hand_sizes(points))
    assert hand_sizes(2 * points) == pytest.approx(2 * hand_sizes(points))


def test_a_hand_lost_in_half_the_frames(clip):
    observed = _copy(clip)
    lost = np.arange(clip.n_frames) % 2 == 0
    observed.points[RIGHT][lost] = 0
    observed.confidence[RIGHT][lost] = 0
    result = measure(clip, observed)
    assert result.right_hand_found == 50
    assert result.hand_error == 0                      # the frames it keeps are exact
    assert result.hand_pck_10 == 50                    # a lost hand is 21 keypoints wrong


def test_face_error_is_the_shift_over_the_interocular_distance(clip):
    observed = _copy(clip)
    interocular = interocular_distances(clip.points[FACE], clip.confidence[FACE])
    pupils = np.linalg.norm(clip.points[FACE][:, 468, :2] - clip.points[FACE][:, 473, :2], axis=-1)
    np.testing.assert_allclose(interocular, pupils)
    observed.points[FACE] = clip.points[FACE] + np.array([0.0, 3.0, 0.0])        # 3 px down
    result = measure(clip, observed)
    assert result.face_error == pytest.approx(np.mean(3.0 / interocular))
    no_irises = _copy(clip)
    no_irises.confidence[FACE][:, 468:] = 0
    corners = np.linalg.norm(clip.points[FACE][:, 33, :2] - clip.points[FACE][:, 263, :2], axis=-1)
    np.testing.assert_allclose(interocular_distances(no_irises.points[FACE], no_irises.confidence[FACE]), corners)


def test_undefined_values_are_none():
    empty = Intelligibility()
    assert empty.fields() == {}


def test_frame_counts_must_match(clip):
    shorter = _copy(clip)
    shorter.points = {name: points[:-1] for name, points in clip.points.items()}
    shorter.confidence = {name: confidence[:-1] for name, confidence in clip.confidence.items()}
    with pytest.raises(SigncastError, match="frames"):
        measure(clip, shorter)


def test_mouth_and_eyes_errors_see_expression_not_displacement(clip):
    from comparisons.judging.intelligibility import EYES_POINTS, MOUTH_POINTS
    interocular = interocular_distances(clip.points[FACE], clip.confidence[FACE])
    shifted = _copy(clip)
    shifted.points[FACE] = clip.points[FACE] + np.array([5.0, -2.0, 0.0])
    result = measure(clip, shifted)
    assert result.face_error > 0.05
    assert result.mouth_error == pytest.approx(0.0, abs=1e-9) and result.eyes_error == pytest.approx(0.0, abs=1e-9)
    opened = _copy(clip)
    lower_lip = [i for i in MOUTH_POINTS if i in (84, 17, 314, 405, 321, 181, 91, 87, 14, 317, 402, 178)]
    opened.points[FACE][:, lower_lip, 1] += 4.0              # the lower lip 4 px down: a mouth opening
    result = measure(clip, opened)
    # the offset removed is the mean over all 468 mesh points, so nearly all of the 4 px stays
    expected = np.mean(len(lower_lip) * 4.0 / len(MOUTH_POINTS) / interocular)
    assert result.mouth_error == pytest.approx(expected, rel=0.05)
    assert result.eyes_error < 0.1 * result.mouth_error
    assert set(EYES_POINTS).isdisjoint(MOUTH_POINTS)


def test_a_hand_resting_below_the_waist_is_not_scored(clip):
    from comparisons.judging.intelligibility import waist_heights
    waist = waist_heights(clip)
    assert np.all(np.isfinite(waist))
    lowered = _copy(clip)
    drop = waist - clip.points[RIGHT][:, 0, 1] + 5.0                # the wrist 5 px below the waist
    lowered.points[RIGHT] = clip.points[RIGHT] + np.stack([np.zeros_like(drop), drop, np.zeros_like(drop)], axis=1)[:, None]
    lost = _copy(lowered)
    lost.confidence[RIGHT][:] = 0
    result = measure(lowered, lost)
    assert result.right_hand_found is None and result.hand_pck_20 is None
    signing = measure(clip, _copy(clip))
    assert signing.right_hand_found == 100

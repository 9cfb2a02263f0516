"""Message fidelity (comparisons/judging/fidelity.py) on hand-made cases: framing-invariant where it must be (a
scaled and shifted clip), sensitive where it must be (a hand turned in the image, a mirrored hand)."""
import numpy as np
import pytest

from comparisons.judging import fidelity
from media.lexicon import SignClip


def _hand() -> np.ndarray:
    """(21, 2) pixels of an open right hand, fingers up, palm 40 px long, the thumb out to one side."""
    points = np.zeros((21, 2))
    points[0] = (100.0, 200.0)
    points[1:5] = [(115, 190), (128, 178), (138, 168), (146, 160)]            # thumb out to the right
    for k, x in enumerate((110.0, 100.0, 90.0, 80.0)):                         # index .. little knuckles
        base = 5 + 4 * k
        points[base:base + 4] = [(x, 160.0), (x - 1.0 * k, 140.0), (x - 2.0 * k, 128.0), (x - 3.0 * k, 118.0)]
    return points


def _turn(points: np.ndarray, degrees: float, about: np.ndarray) -> np.ndarray:
    a = np.radians(degrees)
    rotation = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    return (points - about) @ rotation.T + about


def test_identical_hands_score_perfectly():
    hand = np.repeat(_hand()[None], 5, axis=0)
    shown = np.ones(5, bool)
    result = fidelity.handshape(hand, hand, shown, shown)
    assert result["found"] == 100.0 and result["pck"] == 100.0 and result["shape_pck"] == 100.0
    assert result["error"] == pytest.approx(0.0) and result["shape_error"] == pytest.approx(0.0)


def test_a_rotated_hand_loses_orientation_but_not_shape():
    reference = _hand()[None]
    turned = _turn(_hand(), 60.0, _hand()[0])[None]
    shown = np.ones(1, bool)
    result = fidelity.handshape(reference, turned, shown, shown)
    assert result["error"] > 0.5 and result["pck"] < 30.0                    # another orientation, another message
    assert result["shape_error"] == pytest.approx(0.0, abs=1e-9) and result["shape_pck"] == 100.0


def test_a_mirrored_hand_is_another_hand_even_after_the_best_rotation():
    reference = _hand()[None]
    mirrored = _hand().copy()
    mirrored[:, 0] = 2 * mirrored[0, 0] - mirrored[:, 0]                      # left-right mirror about the wrist
    result = fidelity.handshape(reference, mirrored[None], np.ones(1, bool), np.ones(1, bool))
    assert result["shape_error"] > 0.2 and result["shape_pck"] < 80.0


def test_a_lost_hand_counts_as_every_point_wrong():
    hand = np.repeat(_hand()[None], 4, axis=0)
    result = fidelity.handshape(hand, hand, np.ones(4, bool), np.array([True, True, False, False]))
    assert result["found"] == 50.0 and result["pck"] == 50.0 and result["error"] == pytest.approx(0.0)


def _clip(scale: float = 1.0, shift=(0.0, 0.0), turn: float = 0.0, frames: int = 6) -> SignClip:
    """A person: pose anchors, a right hand moving right by 5 px a frame, a face; mapped by a similarity."""
    rng = np.random.default_rng(3)
    pose = np.zeros((frames, 33, 3))
    pose[:, :, :2] = rng.uniform(60, 140, (33, 2))
    pose[:, 11, :2], pose[:, 12, :2] = (160.0, 250.0), (40.0, 250.0)           # shoulders 120 px apart
    hand = np.repeat(_hand()[None], frames, axis=0)
    hand[..., 0] += 5.0 * np.arange(frames)[:, None]
    face = np.zeros((frames, 478, 3))
    face[:, :, :2] = rng.uniform(70, 130, (478, 2))
    centre = np.array([100.0, 150.0])

    def mapped(points):
        out = points.copy()
        out[..., :2] = _turn(points[..., :2], turn, centre) * scale + np.asarray(shift)
        return out

    points = {"POSE_LANDMARKS": mapped(pose), "FACE_LANDMARKS": mapped(face),
              "RIGHT_HAND_LANDMARKS": mapped(np.concatenate([hand, np.zeros((frames, 21, 1))], axis=-1)),
              "LEFT_HAND_LANDMARKS": np.zeros((frames, 21, 3))}
    confidence = {"POSE_LANDMARKS": np.ones((frames, 33)), "FACE_LANDMARKS": np.ones((frames, 478)),
                  "RIGHT_HAND_LANDMARKS": np.ones((frames, 21)), "LEFT_HAND_LANDMARKS": np.zeros((frames, 21))}
    return SignClip(25.0, points, confidence)


def test_a_scaled_shifted_and_turned_clip_keeps_the_whole_message():
    """Another framing (half the size, moved, turned 10 deg) is the same message: every figure perfect."""
    result = fidelity.message_fidelity(_clip(), _clip(scale=0.5, shift=(30.0, -20.0), turn=10.0))
    assert result["right_location"] == pytest.approx(0.0, abs=1e-9)
    assert result["right_movement"] == pytest.approx(0.0, abs=1e-9)
    assert result["right_shape_pck"] == 100.0 and result["right_shape_error"] == pytest.approx(0.0, abs=1e-9)
    assert result["mouth_error"] == pytest.approx(0.0, abs=1e-9) and result["eyes_error"] == pytest.approx(0.0, abs=1e-9)
    assert result["left_found"] is None and result["left_location"] is None


def test_a_hand_in_the_wrong_place_costs_location_in_shoulder_widths():
    reference, observed = _clip(), _clip(scale=2.0, shift=(10.0, 5.0))
    observed.points["RIGHT_HAND_LANDMARKS"][..., 0] += 2.0 * 60.0               # half a shoulder width, at scale 2
    result = fidelity.message_fidelity(reference, observed)
    assert result["right_location"] == pytest.approx(0.5, rel=1e-6)
    assert result["right_movement"] == pytest.approx(0.0, abs=1e-9)           # the same movement, elsewhere
    assert result["right_pck"] == 100.0


def test_similarity_recovers_a_known_transform_and_never_reflects():
    rng = np.random.default_rng(0)
    source = rng.normal(size=(10, 2))
    target = _turn(source, 30.0, np.zeros(2)) * 3.0 + np.array([5.0, -2.0])
    scale, rotation, translation = fidelity.fit_similarity(source, target)
    assert scale == pytest.approx(3.0) and np.allclose(translation, [5.0, -2.0])
    assert np.allclose(fidelity.apply_similarity((scale, rotation, translation), source), target)
    mirrored = source * np.array([-1.0, 1.0])
    assert np.linalg.det(fidelity.fit_similarity(source, mirrored)[1]) == pytest.approx(1.0)

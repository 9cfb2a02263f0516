"""Rests scored for the face only (issue 36): the extractor looks for a hand only in the frames where some measure
reads it (a reference shows it signing, or a letter span needs the signing hand); elsewhere no hand model runs."""
from types import SimpleNamespace

import numpy as np
import pytest

from comparisons.judging.intelligibility import signing_hands
from comparisons.judging.judge import Judge
from media.lexicon import SignClip
from pipeline.studies.compare import held_hands

T = 6


def _clip(left_y: list[float | None], right_y: list[float | None]) -> SignClip:
    """A hand-made clip: shoulders at y 100, hips at y 300 (waist y 200); each hand's wrist at the given y (None:
    the hand not found in that frame)."""
    pose = np.zeros((T, 33, 3))
    pose[:, [11, 12], 1], pose[:, [23, 24], 1] = 100.0, 300.0
    points, confidence = {"POSE_LANDMARKS": pose}, {"POSE_LANDMARKS": np.ones((T, 33))}
    for component, ys in (("LEFT_HAND_LANDMARKS", left_y), ("RIGHT_HAND_LANDMARKS", right_y)):
        hand = np.zeros((T, 21, 3))
        hand[:, :, 1] = [[0.0 if y is None else y] for y in ys]
        points[component] = hand
        confidence[component] = np.array([[0.0 if y is None else 0.9] * 21 for y in ys])
    return SignClip(25.0, points, confidence)


def test_a_hand_signs_where_it_is_found_above_the_waist():
    clip = _clip([250, 250, None, 150, 150, 250], [150, None, 150, 199, 201, 150])
    wanted = signing_hands(clip)
    assert wanted.shape == (T, 2)
    assert wanted[:, 0].tolist() == [False, False, False, True, True, False]
    assert wanted[:, 1].tolist() == [True, False, True, True, False, True]


def test_the_hands_to_look_for_join_the_references_and_the_signing_hand_in_letter_spans():
    source = _clip([250] * T, [150, 150, 250, 250, 250, 250])           # the right hand rests from frame 2
    render = _clip([150, 250, 250, 250, 250, 250], [250] * T)           # the render's left hand signs in frame 0
    signing = SimpleNamespace(kind="word", name="x", fps=25.0, frames=np.zeros((T, 8, 8, 3), np.uint8),
                              labels=np.zeros((T, 8, 8), np.uint8), landmarks=source, render=None,
                              render_labels=np.zeros((T, 8, 8), np.uint8), render_landmarks=render, spans=None,
                              language="ase", n_frames=T)
    judge = Judge(signing)
    assert judge.hands_for("NSV").tolist() == [[False, True], [False, True]] + [[False, False]] * 4
    assert judge.hands_for("FBA").tolist() == [[True, True], [False, True]] + [[False, False]] * 4
    # a fingerspelled word: ASL's signing hand (the right) is read by the letters across each letter's span
    signing.spans = [("A", 3, 5)]
    judge = Judge(signing, recogniser=object())
    assert judge.hands_for("NSV")[:, 1].tolist() == [True, True, False, True, True, False]
    assert not judge.hands_for("NSV")[:, 0].any()


def test_a_picture_held_over_measured_frames_is_looked_at_for_every_hand_read_in_them():
    hands = np.array([[False, True], [True, False], [False, False], [False, False]])
    on_screen = np.array([0, 0, 1, 2])           # picture 0 held over the first two measured frames
    assert held_hands(hands, on_screen, 3).tolist() == [[True, True], [False, False], [False, False]]


@pytest.fixture(scope="module")
def signer():
    """The avatar fingerspelling ASL 'AB' at 352x288, its first 8 frames (T, H, W, 3) uint8."""
    from media.avatar import load_avatar
    from media.fingerspelling import fingerspell
    from media.render import RenderSettings, render_motion
    frames, _ = render_motion(load_avatar(), fingerspell("ase", "AB", 25.0), RenderSettings(width=352, height=288))
    return frames[:8]


def test_a_hand_not_looked_for_runs_no_hand_model_and_the_other_hand_is_found_as_before(signer, monkeypatch):
    from media.landmarks import hands as hand_stage
    from media.landmarks.holistic import extract_landmarks
    calls = {"hand_landmark": 0, "palm_detection": 0}
    real_hand, real_palms = hand_stage.hand_in_roi, hand_stage.palm_rois

    def counted_hand(*args):
        calls["hand_landmark"] += 1
        return real_hand(*args)

    def counted_palms(*args):
        calls["palm_detection"] += 1
        return real_palms(*args)
    monkeypatch.setattr(hand_stage, "hand_in_roi", counted_hand)
    monkeypatch.setattr(hand_stage, "palm_rois", counted_palms)
    every = extract_landmarks(signer, 25.0)
    assert calls["hand_landmark"] > 0
    right = np.all(every.confidence["RIGHT_HAND_LANDMARKS"] > 0, axis=1)
    assert right.sum() >= 6                       # the signing hand is found in (almost) every frame
    calls.update(hand_landmark=0, palm_detection=0)
    none = extract_landmarks(signer, 25.0, hands=np.zeros((len(signer), 2), bool))
    assert calls == {"hand_landmark": 0, "palm_detection": 0}
    assert not none.confidence["LEFT_HAND_LANDMARKS"].any() and not none.confidence["RIGHT_HAND_LANDMARKS"].any()
    np.testing.assert_array_equal(none.points["FACE_LANDMARKS"], every.points["FACE_LANDMARKS"])
    np.testing.assert_array_equal(none.points["POSE_LANDMARKS"], every.points["POSE_LANDMARKS"])
    # the right hand only: found exactly as with both looked for (the resting left hand never competed for it)
    wanted = np.zeros((len(signer), 2), bool)
    wanted[:, 1] = True
    right_only = extract_landmarks(signer, 25.0, hands=wanted)
    assert not right_only.confidence["LEFT_HAND_LANDMARKS"].any()
    np.testing.assert_array_equal(right_only.points["RIGHT_HAND_LANDMARKS"], every.points["RIGHT_HAND_LANDMARKS"])
    # not looked for in the third frame: the next frame finds it afresh from the pose, not tracked, so its points
    # move by a fraction of a pixel (the hand is about 30 pixels)
    wanted[2, 1] = False
    some = extract_landmarks(signer, 25.0, hands=wanted)
    assert not some.confidence["RIGHT_HAND_LANDMARKS"][2].any()
    kept = right & wanted[:, 1]
    np.testing.assert_allclose(some.points["RIGHT_HAND_LANDMARKS"][kept, :, :2],
                               every.points["RIGHT_HAND_LANDMARKS"][kept, :, :2], atol=1.0)

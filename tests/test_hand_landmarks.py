"""The hand stage (media/landmarks/hands.py) on real images: the rendered avatar fingerspelling ASL 'AB', whose label
buffer says where each hand truly is (3 = left hand, 4 = right hand, the person's own sides), and the bundled
carphone clip, which shows no hands."""
import cv2
import numpy as np
import pytest

from media.errors import SigncastError

LEFT_LABEL, RIGHT_LABEL = 3, 4
WIDTH, HEIGHT = 352, 288
VISIBLE_PIXELS = 100        # a hand with at least this many labelled pixels is in view


@pytest.fixture(scope="module")
def signer():
    """The avatar fingerspelling ASL 'AB': frames (T, H, W, 3) uint8, labels (T, H, W) uint8."""
    from media.avatar import load_avatar
    from media.fingerspelling import fingerspell
    from media.render import RenderSettings, render_motion
    return render_motion(load_avatar(), fingerspell("ase", "AB", 25.0),
                         RenderSettings(width=WIDTH, height=HEIGHT, look="shaded", backend="auto"))


@pytest.fixture(scope="module")
def poses(signer):
    """The pose stage's result (PoseResult or None) for every frame of the signer."""
    from media.landmarks.pose import PoseTracker
    tracker = PoseTracker()
    return [tracker.process(frame) for frame in signer[0]]


def _track(frames, poses=None):
    from media.landmarks.hands import HandTracker
    tracker = HandTracker()
    results = []
    for t, frame in enumerate(frames):
        pose = None if poses is None else poses[t]
        results.append(tracker.process(frame, None if pose is None else pose.points,
                                       None if pose is None else pose.visibility))
    return results


@pytest.fixture(scope="module")
def hands_with_pose(signer, poses):
    return _track(signer[0], poses)


@pytest.fixture(scope="module")
def hands_without_pose(signer):
    return _track(signer[0])


def _distance_to_label(labels: np.ndarray, label: int) -> np.ndarray:
    """(H, W) pixels from each pixel to the nearest pixel of label (0 on it)."""
    return cv2.distanceTransform(np.where(labels == label, 0, 255).astype(np.uint8), cv2.DIST_L2, 5)


def _check_on_labelled_hands(results, labels):
    """Every found hand lies on its own side's labelled pixels; the right hand is found whenever it is in view."""
    in_view = found_in_view = 0
    for t, result in enumerate(results):
        for side, label in (("left", LEFT_LABEL), ("right", RIGHT_LABEL)):
            points, confidence = result[side]
            assert points.shape == (21, 3) and confidence.shape == (21,)
            assert points.dtype == np.float64 and confidence.dtype == np.float64
            visible = np.count_nonzero(labels[t] == label) >= VISIBLE_PIXELS
            if side == "right":
                in_view += visible
                found_in_view += visible and confidence[0] > 0
            if confidence[0] == 0:
                assert not points.any()
                continue
            assert np.all((confidence >= 0.5) & (confidence <= 1))
            distance = _distance_to_label(labels[t], label)
            x, y = np.clip(np.round(points[:, :2]).astype(int), 0, [WIDTH - 1, HEIGHT - 1]).T
            on_hand = distance[y, x]
            assert np.median(on_hand) <= 2.0, (t, side, on_hand)
            assert on_hand[0] <= 4.0, (t, side, "wrist", on_hand[0])
            other = _distance_to_label(labels[t], RIGHT_LABEL + LEFT_LABEL - label)[y, x]
            assert np.median(on_hand) < np.median(other), (t, side, "on the other hand")
    assert in_view >= len(results) // 2
    assert found_in_view >= 0.95 * in_view, (found_in_view, in_view)


def test_hands_from_the_pose_lie_on_the_labelled_hands(signer, hands_with_pose):
    _check_on_labelled_hands(hands_with_pose, signer[1])


def test_without_a_pose_palm_detection_finds_the_hands(signer, hands_without_pose):
    _check_on_labelled_hands(hands_without_pose, signer[1])


def test_palm_detection_alone_finds_both_hands_frame_by_frame(signer):
    """A fresh tracker per frame and no pose: every hand comes from palm detection and handedness."""
    from media.landmarks.hands import HandTracker
    frames, labels = signer
    on_own_side = found = 0
    for t in range(0, len(frames), 6):
        result = HandTracker().process(frames[t])
        for side, label in (("left", LEFT_LABEL), ("right", RIGHT_LABEL)):
            points, confidence = result[side]
            if confidence[0] == 0:
                continue
            x, y = np.clip(np.round(points[:, :2]).astype(int), 0, [WIDTH - 1, HEIGHT - 1]).T
            own = np.median(_distance_to_label(labels[t], label)[y, x])
            other = np.median(_distance_to_label(labels[t], LEFT_LABEL + RIGHT_LABEL - label)[y, x])
            assert min(own, other) <= 2.0, (t, side)
            found += 1
            on_own_side += own < other
        assert result["right"][1][0] > 0 or np.count_nonzero(labels[t] == RIGHT_LABEL) < VISIBLE_PIXELS, t
    assert on_own_side >= 0.8 * found


def test_both_sides_never_hold_the_same_hand(hands_with_pose, hands_without_pose):
    from media.landmarks.hands import landmark_overlap
    for result in hands_with_pose + hands_without_pose:
        (left, left_found), (right, right_found) = result["left"], result["right"]
        if left_found[0] > 0 and right_found[0] > 0:
            assert landmark_overlap(left, right) <= 0.5


def test_handedness_output_is_the_camera_view_side(signer, poses):
    """hand_landmark_full's handedness is P(person's right hand) in an unmirrored image (MediaPipe calls it 'Left')."""
    from media.landmarks.hands import POSE_WRIST_PINKY_INDEX, hand_in_roi, recrop_roi, roi_from_pose
    frames = signer[0]
    scores = {"left": [], "right": []}
    for t in range(0, len(frames), 4):
        for side, (wrist, pinky, index) in POSE_WRIST_PINKY_INDEX.items():
            points = poses[t].points
            hand = hand_in_roi(frames[t], recrop_roi(frames[t], roi_from_pose(points[wrist, :2], points[pinky, :2],
                                                                               points[index, :2])))
            if hand is not None:
                scores[side].append(hand.right_handedness)
    assert len(scores["right"]) >= 5 and len(scores["left"]) >= 5
    assert np.median(scores["right"]) > 0.5 > np.median(scores["left"])


def test_tracking_roi_encloses_the_hand_and_points_it_up(hands_with_pose):
    from media.landmarks.hands import roi_from_landmarks, tracking_holds
    checked = 0
    for result in hands_with_pose:
        for points, confidence in result.values():
            if confidence[0] == 0:
                continue
            roi = roi_from_landmarks(points)
            assert roi.width == pytest.approx(roi.height)
            in_crop = roi.to_crop(points[:, :2])
            assert np.all((in_crop > 0) & (in_crop < 1))
            assert in_crop[0, 1] > in_crop[9, 1]                     # wrist below the middle knuckle
            assert tracking_holds(roi, points, roi)
            turned = type(roi)(roi.cx, roi.cy, roi.width, roi.height, roi.angle + np.pi / 2)
            assert not tracking_holds(roi, points, turned)
            checked += 1
    assert checked > 0


def test_a_grey_frame_has_no_hands(poses):
    from media.landmarks.hands import HandTracker
    grey = np.full((HEIGHT, WIDTH, 3), 128, np.uint8)
    tracker = HandTracker()
    for pose, visibility in ((None, None), (poses[0].points, poses[0].visibility), (poses[0].points, None)):
        result = tracker.process(grey, pose, visibility)
        for points, confidence in result.values():
            assert not points.any() and not confidence.any()


def test_carphone_shows_few_hands():
    from media.landmarks.hands import HandTracker
    from media.landmarks.pose import PoseTracker
    from media.video_io import bundled_clip_path, read_video
    frames, _ = read_video(bundled_clip_path("carphone"), max_frames=40)
    pose_tracker, hand_tracker = PoseTracker(), HandTracker()
    with_hands = 0
    for frame in frames:
        pose = pose_tracker.process(frame)
        result = hand_tracker.process(frame, None if pose is None else pose.points,
                                      None if pose is None else pose.visibility)
        with_hands += any(confidence[0] > 0 for _, confidence in result.values())
    assert with_hands <= 0.05 * len(frames)


def test_tracker_reset_forgets_the_last_hands(signer, poses):
    from media.landmarks.hands import HandTracker
    frames = signer[0]
    tracker = HandTracker()
    tracker.process(frames[0], poses[0].points, poses[0].visibility)
    tracker.reset()
    fresh = HandTracker().process(frames[-1])
    after_reset = tracker.process(frames[-1])
    for side in ("left", "right"):
        np.testing.assert_array_equal(fresh[side][0], after_reset[side][0])


def test_bad_inputs_raise_signcast_errors():
    from media.landmarks.hands import HandTracker
    tracker = HandTracker()
    frame = np.zeros((HEIGHT, WIDTH, 3), np.uint8)
    with pytest.raises(SigncastError):
        tracker.process(frame.astype(np.float32))
    with pytest.raises(SigncastError):
        tracker.process(frame[..., 0])
    with pytest.raises(SigncastError):
        tracker.process(frame, np.zeros((21, 3)))
    with pytest.raises(SigncastError):
        tracker.process(frame, np.zeros((33, 3)), np.zeros(21))

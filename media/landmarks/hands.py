"""Both hands' 21 landmarks per frame: MediaPipe Holistic's hand branch, rebuilt on the vendored models.

Per side (the person's own left/right, as MediaPipe's pose names LEFT_WRIST = 15, RIGHT_WRIST = 16):
  1. ROI from the pose: centre on the estimated middle knuckle (2 index + pinky) / 3, side twice its distance
     to the wrist, rotated so the wrist -> middle vector points up; enlarged 2.7x, shifted 0.1 side towards
     the fingers, and refined by the hand_recrop model (its two points: centre and scale, side twice
     their distance, rotated -90 deg; shifted 0.1 side towards the fingers). Needs the pose wrist's
     visibility >= 0.1.
  2. Tracking: last frame's landmarks give a ROI (wrist, thumb CMC..IP, and the MCP and PIP of the other
     fingers; rotated so wrist -> MCPs points up; enlarged 2x, shifted 0.1 towards the fingers). Holistic keeps
     it while the recrop ROI agrees (rotation within 40 deg, centre within 0.2, size within 0.4 of the
     recrop ROI's side, last landmarks inside the recrop ROI shrunk by 10 %); without a recrop ROI (no pose, or
     the pose wrist not visible) it is kept as is, which Holistic itself would not do.
  3. hand_landmark_full on the chosen ROI (input RGB [0, 1], 224 x 224); a presence score (a probability)
     under 0.5 means no hand there. If the chosen ROI finds none, the other one is tried.
  4. Fallback for a side still without a hand: palm detection (on the first frame, then on every 5th frame
     while a side stays without a hand) over the whole (letterboxed) frame; each palm
     gives a ROI (palm box, rotated wrist -> middle knuckle up, enlarged 2.6x, shifted 0.5 towards the
     fingers) whose hand goes to the side of the nearest pose wrist, or, without a pose, to the side
     hand_landmark's handedness output says.
Two sides never keep the same hand: if their landmarks overlap, the side whose pose wrist is nearer (or,
without a pose, whose handedness agrees) keeps it.

Handedness convention, checked on the rendered (unmirrored) avatar: hand_landmark_full's handedness output
is the probability that the hand is the person's own right hand as a camera (not a selfie mirror) sees it;
MediaPipe, which assumes mirrored selfie images, labels that same hand "Left".

Frames are (H, W, 3) uint8 RGB; points are frame pixels (x right, y down); z is hand_landmark's depth
relative to the wrist, scaled to pixels like x (smaller = nearer the camera). World points are the model's 21
world landmarks, metres, origin the hand's geometric centre, turned by the ROI's rotation into the image's axes
(x right, y down, z away from the camera), as MediaPipe's WorldLandmarkProjectionCalculator does: real depth,
which the retargeting fits to (media/hand_fit.py).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from media.errors import SigncastError
from media.landmarks.detection import PALM_DETECTION, detect_in_frame
from media.landmarks.models import load
from media.landmarks.roi import Roi, crop, rotation_to

SIDES = ("left", "right")
POSE_WRIST_PINKY_INDEX = {"left": (15, 17, 19), "right": (16, 18, 20)}   # MediaPipe pose landmark indices
N_HAND_POINTS = 21

HAND_PRESENCE_THRESHOLD = 0.5      # hand_landmark_cpu.pbtxt ThresholdingCalculator
WRIST_VISIBILITY_THRESHOLD = 0.1   # hand_visibility_from_hand_landmarks_from_pose.pbtxt
HAND_Z_NORMALISATION = 0.4         # hand_landmark_cpu.pbtxt TensorsToLandmarks normalize_z
# hand_landmarks_to_roi.pbtxt: the landmarks that give the tracking ROI, and its rotation keypoints
TRACKING_POINTS = np.array([0, 1, 2, 3, 5, 6, 9, 10, 13, 14, 17, 18])
WRIST, INDEX_MCP, MIDDLE_MCP, RING_MCP = 0, 5, 9, 13
# hand_tracking.pbtxt RoiTrackingCalculator options
TRACKING_MAX_ROTATION = np.radians(40.0)
TRACKING_MAX_TRANSLATION = 0.2
TRACKING_MAX_SCALE = 0.4
TRACKING_RECROP_MARGIN = -0.1
MIN_ROI_SIDE = 2.0                 # pixels: smaller (degenerate) ROIs are not cropped
SAME_HAND_IOU = 0.5                # two sides' landmark boxes overlapping this much hold the same hand

# While a side stays without a hand, palm detection (the dearest model of the hand stage) runs on every
# PALM_FALLBACK_PERIOD-th frame only: a hand that comes back is found within 0.2 s at 25 fps.
PALM_FALLBACK_PERIOD = 5
PALM_MAX_HANDS = 2                 # hand_landmark_tracking_cpu.pbtxt num_hands default
PALM_WRIST, PALM_MIDDLE_MCP = 0, 2  # palm keypoints giving the ROI's rotation


@dataclass(frozen=True)
class Hand:
    """One found hand. points: (21, 3) frame pixels (x, y, z); presence: hand_landmark's presence
    probability; right_handedness: probability that it is the person's right hand; roi: the crop it came from;
    world: (21, 3) world landmarks, metres (image axes, origin the hand's centre), or None."""
    points: np.ndarray
    presence: float
    right_handedness: float
    roi: Roi
    world: np.ndarray | None = None


def hand_in_roi(frame: np.ndarray, roi: Roi) -> Hand | None:
    """hand_landmark_full on the ROI of frame (H, W, 3) uint8; None when its presence is under 0.5 (or the ROI
    is degenerate)."""
    if not _usable(roi):
        return None
    model = load("hand_landmark_full")
    size = model.input_size[0]
    image = crop(frame, roi, model.input_size).astype(np.float32) / 255.0
    landmarks, presence, handedness, world = model.run(image)
    presence = float(presence.reshape(-1)[0])
    if not presence >= HAND_PRESENCE_THRESHOLD:   # also rejects NaN
        return None
    raw = landmarks.reshape(N_HAND_POINTS, 3).astype(np.float64)
    points = np.empty((N_HAND_POINTS, 3))
    points[:, :2] = roi.to_frame(raw[:, :2] / size)
    points[:, 2] = raw[:, 2] / size / HAND_Z_NORMALISATION * roi.width
    return Hand(points, presence, float(handedness.reshape(-1)[0]), roi, _world_points(world, roi.angle))


def _world_points(world: np.ndarray, angle: float) -> np.ndarray:
    """The model's world landmarks (63,) -> (21, 3) metres in the image's axes (turned by the ROI's angle)."""
    points = np.asarray(world, dtype=np.float64).reshape(N_HAND_POINTS, 3)
    c, s = np.cos(angle), np.sin(angle)
    turned = points.copy()
    turned[:, 0] = c * points[:, 0] - s * points[:, 1]
    turned[:, 1] = s * points[:, 0] + c * points[:, 1]
    return turned


def roi_from_pose(wrist: np.ndarray, pinky: np.ndarray, index: np.ndarray) -> Roi:
    """The search region for hand_recrop from the pose's wrist, pinky and index points (2,) pixels
    (hand_detections_from_pose_to_rects_calculator.cc + hand_landmarks_from_pose_to_recrop_roi.pbtxt)."""
    middle = (2.0 * index + pinky) / 3.0
    side = 2.0 * float(np.hypot(*(middle - wrist)))
    angle = rotation_to(wrist, middle, np.pi / 2)
    return Roi(float(middle[0]), float(middle[1]), side, side, angle).scaled(2.7, shift_y=-0.1).squared()


def recrop_roi(frame: np.ndarray, search: Roi) -> Roi | None:
    """hand_recrop's refined hand ROI inside the search ROI (hand_recrop_by_roi_cpu.pbtxt); None when either
    ROI is degenerate."""
    if not _usable(search):
        return None
    model = load("hand_recrop")
    image = crop(frame, search, model.input_size).astype(np.float32) / 255.0
    centre, scale = search.to_frame(model.run(image)[0].reshape(2, 2).astype(np.float64) / model.input_size[0])
    side = 2.0 * float(np.hypot(*(scale - centre)))
    angle = rotation_to(centre, scale, -np.pi / 2)
    refined = Roi(float(centre[0]), float(centre[1]), side, side, angle).scaled(1.0, shift_y=-0.1).squared()
    return refined if _usable(refined) else None


def _usable(roi: Roi) -> bool:
    """Whether the ROI is finite and at least MIN_ROI_SIDE pixels on each side."""
    values = np.array([roi.cx, roi.cy, roi.width, roi.height, roi.angle], dtype=np.float64)
    return bool(np.isfinite(values).all() and min(roi.width, roi.height) >= MIN_ROI_SIDE)


def roi_from_landmarks(points: np.ndarray) -> Roi:
    """Next frame's ROI from this frame's hand points (21, 2+) pixels (hand_landmarks_to_roi.pbtxt,
    hand_landmarks_to_rect_calculator.cc): the box around the stable points in the hand's own frame."""
    xy = np.asarray(points, dtype=np.float64)[:, :2]
    knuckles = 0.5 * (0.5 * (xy[INDEX_MCP] + xy[RING_MCP]) + xy[MIDDLE_MCP])
    angle = rotation_to(xy[WRIST], knuckles, np.pi / 2)
    stable = xy[TRACKING_POINTS]
    x_axis, y_axis = Roi(0, 0, 1, 1, angle).axes()
    along_x, along_y = stable @ x_axis, stable @ y_axis
    mid_x, mid_y = 0.5 * (along_x.max() + along_x.min()), 0.5 * (along_y.max() + along_y.min())
    centre = mid_x * x_axis + mid_y * y_axis
    box = Roi(float(centre[0]), float(centre[1]), float(np.ptp(along_x)), float(np.ptp(along_y)), angle)
    return box.scaled(2.0, shift_y=-0.1).squared()


def tracking_holds(previous_roi: Roi, previous_points: np.ndarray, recrop: Roi) -> bool:
    """Whether last frame's landmark ROI may stay in use, judged against this frame's recrop ROI
    (roi_tracking_calculator.cc with hand_tracking.pbtxt's options)."""
    turn = (previous_roi.angle - recrop.angle + np.pi) % (2.0 * np.pi) - np.pi
    if abs(turn) > TRACKING_MAX_ROTATION:
        return False
    offset = recrop.to_crop(np.array([previous_roi.cx, previous_roi.cy])) - 0.5   # in recrop sides
    if np.any(np.abs(offset) > TRACKING_MAX_TRANSLATION):
        return False
    if (abs(previous_roi.width - recrop.width) > TRACKING_MAX_SCALE * recrop.width
            or abs(previous_roi.height - recrop.height) > TRACKING_MAX_SCALE * recrop.height):
        return False
    inside = np.abs(recrop.to_crop(previous_points[:, :2]) - 0.5) < 0.5 * (1.0 + TRACKING_RECROP_MARGIN)
    return bool(inside.all())


def palm_rois(frame: np.ndarray) -> list[Roi]:
    """Hand ROIs from palm detection over the whole letterboxed frame (H, W, 3) uint8, best first, at most 2
    (palm_detection_cpu.pbtxt via detection.PALM_DETECTION; palm_detection_detection_to_roi.pbtxt)."""
    rois = []
    for palm in detect_in_frame(frame, PALM_DETECTION)[:PALM_MAX_HANDS]:
        x0, y0, x1, y1 = palm.box
        angle = rotation_to(palm.keypoints[PALM_WRIST], palm.keypoints[PALM_MIDDLE_MCP], np.pi / 2)
        box = Roi(0.5 * (x0 + x1), 0.5 * (y0 + y1), float(x1 - x0), float(y1 - y0), angle)
        rois.append(box.scaled(2.6, shift_y=-0.5).squared())
    return rois


def _iou(a: np.ndarray, b: np.ndarray) -> float:
    """Intersection over union of boxes a, b (4,) as (xmin, ymin, xmax, ymax)."""
    width = max(0.0, min(a[2], b[2]) - max(a[0], b[0]))
    height = max(0.0, min(a[3], b[3]) - max(a[1], b[1]))
    inter = width * height
    union = (a[2] - a[0]) * (a[3] - a[1]) + (b[2] - b[0]) * (b[3] - b[1]) - inter
    return inter / union if union > 0 else 0.0


def _box(points: np.ndarray) -> np.ndarray:
    """(xmin, ymin, xmax, ymax) of points (N, 2+)."""
    return np.concatenate([points[:, :2].min(axis=0), points[:, :2].max(axis=0)])


def landmark_overlap(points_a: np.ndarray, points_b: np.ndarray) -> float:
    """Intersection over union of the axis-aligned boxes around two hands' points (21, 2+) pixels."""
    return _iou(_box(points_a), _box(points_b))


def same_hand(a: Hand, b: Hand) -> bool:
    """Whether two found hands lie on the same image region (their landmark boxes overlap by IoU > 0.5)."""
    return landmark_overlap(a.points, b.points) > SAME_HAND_IOU


class HandTracker:
    """Left and right hand landmarks over the frames of one video, tracked from frame to frame.
    Feed the frames in order; `reset` before another video."""

    def __init__(self):
        self._previous: dict[str, Hand | None] = {}
        self._frames_without_palm_search = 0
        # side -> the last processed frame's world landmarks (21, 3) metres, None where no hand was found
        self.world: dict[str, np.ndarray | None] = {}
        self.reset()

    def reset(self) -> None:
        """Forget last frame's hands (start of a new video)."""
        self._previous = {side: None for side in SIDES}
        self.world = {side: None for side in SIDES}
        self._frames_without_palm_search = PALM_FALLBACK_PERIOD   # the first frame searches

    def process(self, frame: np.ndarray, pose: np.ndarray | None = None,
                pose_visibility: np.ndarray | None = None,
                sides: tuple[str, ...] = SIDES) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """Hands of one frame (H, W, 3) uint8 RGB, given the pose landmarks (33, 3) in frame pixels and their
        visibility (33,) in [0, 1] (None: no pose; no visibility: all visible). Returns {'left', 'right'}
        (the person's own sides) -> (points (21, 3) float64 frame pixels x, y, z; confidence (21,) float64:
        the hand's presence probability, all 0 with points 0 when that hand was not found). The same hands'
        world landmarks are then in `self.world` (side -> (21, 3) metres, or None).

        sides: the sides looked for in this frame; the others run no model (not tracked, not searched by palm
        detection) and are returned as not found, so the next frame looks for them afresh."""
        frame = _checked_frame(frame)
        pose, pose_visibility = _checked_pose(pose, pose_visibility)
        hands = {side: self._track(frame, side, pose, pose_visibility) if side in sides else None for side in SIDES}
        if hands["left"] is not None and hands["right"] is not None and same_hand(hands["left"], hands["right"]):
            loser = _weaker_claim(hands["left"], hands["right"], pose)
            hands[loser] = None
        if any(hands[side] is None for side in sides):
            if self._frames_without_palm_search + 1 >= PALM_FALLBACK_PERIOD:
                self._palm_fallback(frame, hands, pose, sides)
                self._frames_without_palm_search = 0
            else:
                self._frames_without_palm_search += 1
        self._previous = hands
        self.world = {side: None if hands[side] is None or hands[side].world is None else hands[side].world.copy()
                      for side in SIDES}
        return {side: _as_output(hands[side]) for side in SIDES}

    def _track(self, frame: np.ndarray, side: str, pose: np.ndarray | None,
               pose_visibility: np.ndarray | None) -> Hand | None:
        """This side's hand from last frame's landmarks and/or the pose, or None."""
        previous = self._previous[side]
        tracked = None if previous is None else roi_from_landmarks(previous.points)
        from_pose = None
        wrist, pinky, index = POSE_WRIST_PINKY_INDEX[side]
        if pose is not None and (pose_visibility is None or pose_visibility[wrist] >= WRIST_VISIBILITY_THRESHOLD):
            from_pose = recrop_roi(frame, roi_from_pose(pose[wrist, :2], pose[pinky, :2], pose[index, :2]))
        if tracked is not None and from_pose is not None and not tracking_holds(tracked, previous.points, from_pose):
            tracked = None
        for roi in (tracked, from_pose):
            if roi is not None:
                hand = hand_in_roi(frame, roi)
                if hand is not None:
                    return hand
        return None

    def _palm_fallback(self, frame: np.ndarray, hands: dict[str, Hand | None], pose: np.ndarray | None,
                       sides: tuple[str, ...] = SIDES) -> None:
        """Fills sides of `sides` still without a hand from palm detection (hands overlapping one already found are
        dropped; a side not in `sides` counts as taken). With a pose a palm's hand goes to the side of the nearest
        pose wrist, and is dropped if that side is taken; two new hands take the pairing with the smaller total
        wrist distance. Without a pose, two new hands split by handedness (the more right-handed one is right); a
        single one goes to its handedness's side, or to the free side when that one is taken (one signer has one
        hand per side)."""
        found: list[Hand] = []
        for roi in palm_rois(frame):
            hand = hand_in_roi(frame, roi)
            if hand is not None and not any(same_hand(hand, other) for other in found + list(hands.values())
                                            if other is not None):
                found.append(hand)
        free = [side for side in SIDES if hands[side] is None and side in sides]
        if len(found) == 2 and len(free) == 2:
            if pose is None:
                right_first = found[0].right_handedness >= found[1].right_handedness
            else:
                straight = _wrist_distance(found[0], pose, "right") + _wrist_distance(found[1], pose, "left")
                crossed = _wrist_distance(found[0], pose, "left") + _wrist_distance(found[1], pose, "right")
                right_first = straight <= crossed
            hands["right"], hands["left"] = found if right_first else found[::-1]
            return
        for hand in found:
            if pose is None:
                side = "right" if hand.right_handedness >= 0.5 else "left"
                if side not in free:
                    side = "left" if side == "right" else "right"
            else:
                side = min(SIDES, key=lambda s: _wrist_distance(hand, pose, s))
            if side in free:
                free.remove(side)
                hands[side] = hand


def _wrist_distance(hand: Hand, pose: np.ndarray, side: str) -> float:
    """Pixels between the hand's wrist and the pose's wrist of side."""
    return float(np.hypot(*(hand.points[WRIST, :2] - pose[POSE_WRIST_PINKY_INDEX[side][0], :2])))


def _weaker_claim(left: Hand, right: Hand, pose: np.ndarray | None) -> str:
    """The side that gives up a hand both sides found: the one whose pose wrist is farther from its found
    wrist; without a pose, the one whose handedness agrees less with its side."""
    if pose is None:
        return "left" if left.right_handedness > 1.0 - right.right_handedness else "right"
    return "left" if _wrist_distance(left, pose, "left") > _wrist_distance(right, pose, "right") else "right"


def _as_output(hand: Hand | None) -> tuple[np.ndarray, np.ndarray]:
    """(points (21, 3), confidence (21,)) float64; zeros for no hand."""
    if hand is None:
        return np.zeros((N_HAND_POINTS, 3)), np.zeros(N_HAND_POINTS)
    return hand.points.copy(), np.full(N_HAND_POINTS, hand.presence)


def _checked_frame(frame: np.ndarray) -> np.ndarray:
    frame = np.asarray(frame)
    if frame.ndim != 3 or frame.shape[2] != 3 or frame.dtype != np.uint8 or min(frame.shape[:2]) < 1:
        raise SigncastError(f"a frame must be (H, W, 3) uint8 RGB, got {frame.shape} {frame.dtype}")
    return frame


def _checked_pose(pose: np.ndarray | None, visibility: np.ndarray | None):
    """(pose (33, 3) float64 or None, visibility (33,) float64 or None); SigncastError for other shapes."""
    if pose is None:
        return None, None
    pose = np.asarray(pose, dtype=np.float64)
    if pose.ndim != 2 or pose.shape[0] != 33 or pose.shape[1] < 2:
        raise SigncastError(f"pose landmarks must be (33, 3) frame pixels, got shape {pose.shape}")
    if visibility is not None:
        visibility = np.asarray(visibility, dtype=np.float64).reshape(-1)
        if visibility.shape != (33,):
            raise SigncastError(f"pose visibility must be (33,), got shape {visibility.shape}")
    if not np.isfinite(pose[:, :2]).all():
        return None, None
    return pose, visibility

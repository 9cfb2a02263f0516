"""signcast's MediaPipe Holistic: pose, then both hands, then the face, per frame, tracked through a video.

`HolisticTracker.process(frame)` gives one frame's landmarks in the lexicon's five components followed by the
two hands' world landmarks (media.pose_file.WORLD_LAYOUT); `extract_landmarks(frames, fps)` runs it over a video into a SignClip, and
`found_shares(clip)` says in what share of frames each part was found. Coordinates are frame pixels (x right,
y down; z MediaPipe's relative depth scaled to pixels like x), world landmarks metres. Confidence: the pose's
visibility for pose and world points, the landmark model's score for hand and face points, 0 where a part was
not found (its coordinates are then 0: nothing is invented).
"""
from __future__ import annotations

from typing import Callable, Iterable

import numpy as np

from media.landmarks.face import FaceTracker
from media.landmarks.pose import PoseTracker
from media.lexicon import SignClip
from media.pose_file import HAND_WORLD_COMPONENTS, HOLISTIC_LAYOUT, WORLD_LAYOUT

POSE, FACE, LEFT_HAND, RIGHT_HAND, WORLD = (name for name, _ in HOLISTIC_LAYOUT)
LEFT_HAND_WORLD, RIGHT_HAND_WORLD = HAND_WORLD_COMPONENTS
SIZES = {name: len(points) for name, points in WORLD_LAYOUT}
# the parts a user is told about, and the component that says whether each was found
PARTS = {"pose": POSE, "face": FACE, "left hand": LEFT_HAND, "right hand": RIGHT_HAND}
HAND_SIDES = ("left", "right")     # the person's own sides, in the order of extract_landmarks' `hands` columns

Landmarks = dict[str, tuple[np.ndarray, np.ndarray]]   # component -> ((N, 3) points, (N,) confidence)


def empty_landmarks() -> Landmarks:
    """Every component missing: zero points, zero confidence."""
    return {name: (np.zeros((size, 3)), np.zeros(size)) for name, size in SIZES.items()}


class HolisticTracker:
    """Pose -> hands -> face on consecutive frames of one video, each stage tracking its own ROI."""

    def __init__(self) -> None:
        from media.landmarks.hands import HandTracker   # written alongside; imported when a tracker is made

        self.pose = PoseTracker()
        self.hands = HandTracker()
        self.face = FaceTracker()

    def reset(self) -> None:
        """Forget all tracking (the next frame starts from detection)."""
        self.pose.reset()
        self.hands.reset()
        self.face.reset()

    def process(self, frame: np.ndarray, hands: tuple[str, ...] = HAND_SIDES) -> Landmarks:
        """One frame (H, W, 3) uint8 RGB -> its landmarks by component (missing parts: zeros). hands: the sides
        ('left', 'right') whose hand models run in this frame (the others are reported missing)."""
        frame = np.ascontiguousarray(frame)
        result = empty_landmarks()
        pose = self.pose.process(frame)
        if pose is not None:
            result[POSE] = (pose.points, pose.visibility)
            result[WORLD] = (pose.world, pose.visibility.copy())
        found = self.hands.process(frame, None if pose is None else pose.points,
                                   None if pose is None else pose.visibility, sides=tuple(hands))
        for side, name, world_name in (("left", LEFT_HAND, LEFT_HAND_WORLD), ("right", RIGHT_HAND, RIGHT_HAND_WORLD)):
            if side in found:
                points, confidence = found[side]
                result[name] = (np.asarray(points, np.float64), np.asarray(confidence, np.float64))
                world = getattr(self.hands, "world", {}).get(side)
                if world is not None:
                    result[world_name] = (np.asarray(world, np.float64), np.asarray(confidence, np.float64).copy())
        face = self.face.process(frame, None if pose is None else pose.points)
        if face is not None:
            confidence = np.full(SIZES[FACE], face.score)
            confidence[468:473] *= face.iris_found[0]
            confidence[473:478] *= face.iris_found[1]
            result[FACE] = (face.points, confidence)
        return result


def extract_landmarks(frames: Iterable[np.ndarray], fps: float, n_frames: int | None = None,
                      progress: Callable[[int], object] | None = None, hands: np.ndarray | None = None) -> SignClip:
    """Landmarks of every frame (H, W, 3) uint8 RGB of one video shown at fps frames per second, as a SignClip in
    the lexicon's layout plus the hands' world landmarks (WORLD_LAYOUT; metres): points component -> (T, N, 3) float64, confidence component -> (T, N) in [0, 1], 0 (and
    coordinates 0) where missing. n_frames: stop after this many frames (None: all). progress: called with 1 after
    each frame. hands: (T, 2) bool, whether the left and the right hand's models run in each frame (None: both in
    every frame); a hand not looked for is missing in that frame."""
    tracker = HolisticTracker()
    points = {name: [] for name in SIZES}
    confidence = {name: [] for name in SIZES}
    for index, frame in enumerate(frames):
        if n_frames is not None and index >= n_frames:
            break
        sides = HAND_SIDES if hands is None else tuple(side for side, on in zip(HAND_SIDES, hands[index]) if on)
        for name, (values, scores) in tracker.process(frame, sides).items():
            scores = np.clip(np.nan_to_num(np.asarray(scores, np.float64)), 0.0, 1.0)
            values = np.asarray(values, np.float64)
            seen = (scores > 0) & np.all(np.isfinite(values), axis=-1)
            points[name].append(np.where(seen[:, None], values, 0.0))
            confidence[name].append(np.where(seen, scores, 0.0))
        if progress is not None:
            progress(1)
    stacked_points = {name: np.stack(values) if values else np.zeros((0, SIZES[name], 3))
                      for name, values in points.items()}
    stacked_confidence = {name: np.stack(values) if values else np.zeros((0, SIZES[name]))
                          for name, values in confidence.items()}
    return SignClip(float(fps), stacked_points, stacked_confidence)


def found_shares(clip: SignClip) -> dict[str, float]:
    """Share of frames in [0, 1] in which each part ('pose', 'face', 'left hand', 'right hand') was found."""
    return {part: float(np.mean(np.any(clip.confidence[name] > 0, axis=1))) if clip.n_frames else 0.0
            for part, name in PARTS.items()}


def frames_missing(clip: SignClip, part: str) -> int:
    """How many frames lack `part` ('pose', 'face', 'left hand', 'right hand')."""
    return int(np.sum(~np.any(clip.confidence[PARTS[part]] > 0, axis=1)))

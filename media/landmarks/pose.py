"""The pose stage of MediaPipe Holistic on one video: 33 body landmarks per frame, tracked from frame to frame.

Graph (mediapipe/modules/pose_landmark/pose_landmark_cpu.pbtxt and its subgraphs, model complexity 1 = "full"):
- without a tracked ROI (the first frame, or after the pose was lost): the pose detector on the whole frame; its
  best detection gives a rotated square ROI: centre the mid-hip keypoint, side twice the distance to the full-body
  scale keypoint, rotated so that this vector points up (target angle 90 degrees), enlarged 1.25 times;
- pose_landmark_full in that ROI (256x256, RGB in [0, 1]): 39 points (x, y, z in crop pixels, visibility and
  presence logits), a pose presence score (already a probability), a 64x64x39 heatmap that refines x and y
  (MediaPipe's RefineLandmarksFromHeatmapCalculator, 7x7 kernel) and 39 world points (metres, hips' centre origin);
- presence below 0.5: no pose in this frame, and the next frame is detected again; otherwise the auxiliary points
  33 (centre) and 34 (scale and rotation) give the next frame's ROI by the same rule as the detection.
No smoothing: the landmarks are the model's, frame by frame.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from media.landmarks import models
from media.landmarks.detection import POSE_DETECTION, Detection, detect_in_frame
from media.landmarks.roi import Roi, crop, rotation_to

LANDMARK_MODEL = "pose_landmark_full"
PRESENCE_THRESHOLD = 0.5          # pose_landmark_by_roi: ThresholdingCalculator on the pose flag
ROI_SCALE = 1.25                  # pose_detection_to_roi / pose_landmarks_to_roi (full-body models)
HEATMAP_KERNEL = 7
HEATMAP_MIN_CONFIDENCE = 0.5
N_POINTS = 33
N_MODEL_POINTS = 39               # 33 landmarks, 2 auxiliary (ROI) points, 4 unused


def _sigmoid(x: np.ndarray) -> np.ndarray:
    return 1.0 / (1.0 + np.exp(-np.asarray(x, np.float64)))


@dataclass
class PoseResult:
    """One frame's pose. points (33, 3) frame pixels (x right, y down, z relative depth in pixels of the same
    scale as x, smaller is nearer the camera); visibility and presence (33,) in [0, 1]; world (33, 3) metres
    (x right, y down, z away from the camera, origin between the hips); score: the pose presence probability;
    roi: the region the landmark model saw."""
    points: np.ndarray
    visibility: np.ndarray
    presence: np.ndarray
    world: np.ndarray
    score: float
    roi: Roi


def alignment_roi(centre: np.ndarray, scale_point: np.ndarray, scale: float = ROI_SCALE) -> Roi:
    """MediaPipe's AlignmentPointsRectsCalculator + RectTransformationCalculator: a square of side
    2 |scale_point - centre| x scale pixels around centre, rotated so that centre -> scale_point points up."""
    side = 2.0 * float(np.hypot(*(np.asarray(scale_point, np.float64) - centre)))
    angle = rotation_to(centre, scale_point, np.pi / 2)
    return Roi(float(centre[0]), float(centre[1]), side * scale, side * scale, angle)


def roi_from_detection(detection: Detection) -> Roi:
    """The landmark ROI of a pose detection (keypoint 0 mid-hip centre, 1 full-body scale point)."""
    return alignment_roi(detection.keypoints[0], detection.keypoints[1])


def refine_with_heatmap(xy: np.ndarray, heatmap: np.ndarray) -> np.ndarray:
    """MediaPipe's RefineLandmarksFromHeatmapCalculator: xy (K, 2) normalised to the crop; heatmap (h, w, K)
    logits. Each point within the heatmap moves to the sigmoid-weighted mean of the 7x7 cells around it when the
    best of them is at least 0.5 confident. Returns (K, 2) normalised."""
    height, width, _ = heatmap.shape
    refined = np.array(xy, np.float64)
    offset = (HEATMAP_KERNEL - 1) // 2
    for k, (x, y) in enumerate(xy):
        col, row = int(x * width), int(y * height)     # C++ float -> int truncation
        if not (0 <= col < width and 0 <= row < height):
            continue
        rows = slice(max(0, row - offset), min(height, row + offset + 1))
        cols = slice(max(0, col - offset), min(width, col + offset + 1))
        confidence = _sigmoid(heatmap[rows, cols, k])
        total = confidence.sum()
        if confidence.max() >= HEATMAP_MIN_CONFIDENCE and total > 0:
            grid_rows, grid_cols = np.mgrid[rows, cols]
            refined[k] = ((grid_cols * confidence).sum() / width / total, (grid_rows * confidence).sum() / height / total)
    return refined


def landmarks_in_roi(frame: np.ndarray, roi: Roi) -> tuple[PoseResult | None, Roi | None]:
    """pose_landmark_full on roi of frame (H, W, 3) uint8 RGB: (the pose, the next frame's ROI), or (None, None)
    when the model finds no pose there."""
    model = models.load(LANDMARK_MODEL)
    size = model.input_size
    image = crop(frame, roi, size).astype(np.float32) / np.float32(255.0)
    raw, flag, _segmentation, heatmap, world = model.run(image)
    score = float(np.asarray(flag).reshape(-1)[0])
    if not score >= PRESENCE_THRESHOLD:
        return None, None
    raw = raw.reshape(N_MODEL_POINTS, 5).astype(np.float64)
    normalised = raw[:, :2] / np.array([size[1], size[0]], np.float64)
    normalised = refine_with_heatmap(normalised, heatmap)
    xy = roi.to_frame(normalised)
    z = raw[:, 2] / size[1] * roi.width
    points = np.concatenate([xy, z[:, None]], axis=1)
    world_points = world.reshape(N_MODEL_POINTS, 3).astype(np.float64)[:N_POINTS]
    world_points = _rotate_world(world_points, roi.angle)
    result = PoseResult(points[:N_POINTS], _sigmoid(raw[:N_POINTS, 3]), _sigmoid(raw[:N_POINTS, 4]), world_points,
                        score, roi)
    return result, alignment_roi(xy[33], xy[34])


def _rotate_world(points: np.ndarray, angle: float) -> np.ndarray:
    """MediaPipe's WorldLandmarkProjectionCalculator: world points turned in the image plane by the ROI's rotation."""
    c, s = np.cos(angle), np.sin(angle)
    rotated = points.copy()
    rotated[:, 0] = c * points[:, 0] - s * points[:, 1]
    rotated[:, 1] = s * points[:, 0] + c * points[:, 1]
    return rotated


class PoseTracker:
    """The pose stage over consecutive frames of one video (keeps the tracked ROI between calls)."""

    def __init__(self) -> None:
        self._roi: Roi | None = None
        self.detections = 0       # how many frames needed the detector

    def reset(self) -> None:
        """Forget the tracked ROI (the next frame is detected again)."""
        self._roi = None

    def process(self, frame: np.ndarray) -> PoseResult | None:
        """The pose in frame (H, W, 3) uint8 RGB, or None when there is none."""
        roi = self._roi
        if roi is None:
            self.detections += 1
            found = detect_in_frame(frame, POSE_DETECTION)
            if not found:
                return None
            roi = roi_from_detection(found[0])
        result, self._roi = landmarks_in_roi(frame, roi)
        return result

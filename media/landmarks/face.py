"""The face stage of MediaPipe Holistic: 478 face points per frame (the 468-point mesh and 2 x 5 iris points).

Graph (mediapipe/modules/holistic_landmark/face_landmarks_from_pose_cpu.pbtxt and its subgraphs):
- re-crop ROI from the pose's 11 face points (0-10): their bounding box, rotated by the pose's right eye (5) ->
  left eye (2) vector (target angle 0), enlarged 3 times, squared;
- the short-range face detector in that ROI; its best detection gives the face ROI: the bounding box of its 6
  keypoints, rotated by right eye -> left eye, enlarged 2 times, moved up by 0.1 of its height, squared;
  no face detected: no face in this frame;
- tracking (FaceTracking, RoiTrackingCalculator): the previous frame's mesh ROI (bounding box of the 468 points,
  rotated by points 33 -> 263, enlarged 1.5 times, squared) is used instead when it differs from the face ROI by
  at most 15 degrees, 0.1 of its size in position, 0.3 in size, and every previous point lies inside the face ROI
  shrunk by 20 %;
- face_landmark (192x192, RGB in [0, 1]): 468 points (x, y, z crop pixels) and a face score (logit; below 0.5
  after the sigmoid: no face);
- irises (iris_landmark_left_and_right_from_face_landmarks_cpu.pbtxt, iris_landmark_cpu.pbtxt): for each eye, the
  ROI of its two corners (33, 133 and 362, 263; rotated by the first -> second, enlarged 2.3 times, squared) goes
  to iris_landmark (64x64, RGB in [0, 1]; the 362/263 eye mirrored, as the model only knows one eye); its 5 iris
  points become points 468-472 (the 33/133 eye) and 473-477 (the 362/263 eye), in the order of MediaPipe's
  478-point mesh (LandmarksRefinementCalculator of face_landmark_with_attention: centre, right, top, left, bottom
  edge, as the image shows them for both eyes, which the lexicon's clips confirm), with z the mean z of the eye's
  16 contour points as there.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from media.landmarks import models
from media.landmarks.detection import FACE_DETECTION, detect_in_roi
from media.landmarks.roi import Roi, crop, rotation_to

MESH_MODEL = "face_landmark"
IRIS_MODEL = "iris_landmark"
SCORE_THRESHOLD = 0.5
N_MESH = 468
N_POINTS = 478
# the eye corners that place each iris crop, and whether the crop is mirrored, in 478-layout order
EYES = (((33, 133), False, slice(468, 473)), ((362, 263), True, slice(473, 478)))
EYE_CONTOURS = ((33, 7, 163, 144, 145, 153, 154, 155, 133, 246, 161, 160, 159, 158, 157, 173),
                (263, 249, 390, 373, 374, 380, 381, 382, 362, 466, 388, 387, 386, 385, 384, 398))
TRACKING_ROTATION_DEG = 15.0
TRACKING_TRANSLATION = 0.1
TRACKING_SCALE = 0.3
TRACKING_MARGIN = -0.2


@dataclass
class FaceResult:
    """One frame's face. points (478, 3) frame pixels (x right, y down, z relative depth in pixels like x);
    score: the face model's presence probability (also the irises' confidence); roi: the region the mesh model
    saw; iris_found: (2,) bool, whether each iris (468-472, 473-477) was measured."""
    points: np.ndarray
    score: float
    roi: Roi
    iris_found: np.ndarray


def box_roi(points: np.ndarray, angle: float, scale: float, shift_y: float = 0.0) -> Roi:
    """MediaPipe's DetectionsToRects (bounding box of points (N, 2) pixels, given rotation) followed by
    RectTransformation (shift along the rotated y axis by shift_y x height, square on the long side, scale)."""
    low, high = points.min(axis=0), points.max(axis=0)
    centre = 0.5 * (low + high)
    box = Roi(float(centre[0]), float(centre[1]), float(high[0] - low[0]), float(high[1] - low[1]), angle)
    return box.scaled(scale, scale, shift_y).squared()


def roi_from_pose(pose_points: np.ndarray) -> Roi:
    """The face re-crop ROI from the pose's points 0-10 (33, 2+) frame pixels."""
    face = np.asarray(pose_points, np.float64)[:11, :2]
    return box_roi(face, rotation_to(face[5], face[2], 0.0), 3.0)


def roi_from_mesh(mesh: np.ndarray) -> Roi:
    """The tracking ROI of a face mesh (468+, 2+) frame pixels."""
    mesh = np.asarray(mesh, np.float64)[:N_MESH, :2]
    return box_roi(mesh, rotation_to(mesh[33], mesh[263], 0.0), 1.5)


def _keeps_tracking(previous: Roi, recrop: Roi, previous_mesh: np.ndarray) -> bool:
    """RoiTrackingCalculator's rect and landmark requirements (in the re-crop ROI's axes)."""
    x_axis, y_axis = recrop.axes()
    shift = np.array([previous.cx - recrop.cx, previous.cy - recrop.cy])
    turn = np.degrees(previous.angle - recrop.angle)
    turn = abs((turn + 180.0) % 360.0 - 180.0)
    if (turn > TRACKING_ROTATION_DEG or abs(shift @ x_axis) > recrop.width * TRACKING_TRANSLATION
            or abs(shift @ y_axis) > recrop.height * TRACKING_TRANSLATION
            or abs(previous.width - recrop.width) > recrop.width * TRACKING_SCALE
            or abs(previous.height - recrop.height) > recrop.height * TRACKING_SCALE):
        return False
    inner = recrop.to_crop(previous_mesh[:, :2])
    half_x = 0.5 * (1.0 + TRACKING_MARGIN)
    return bool(np.all(np.abs(inner - 0.5) < half_x))


def mesh_in_roi(frame: np.ndarray, roi: Roi) -> tuple[np.ndarray, float]:
    """face_landmark on roi of frame (H, W, 3) uint8 RGB: ((468, 3) frame pixels, presence probability)."""
    model = models.load(MESH_MODEL)
    size = model.input_size
    image = crop(frame, roi, size).astype(np.float32) / np.float32(255.0)
    raw, logit = model.run(image)
    score = float(1.0 / (1.0 + np.exp(-float(np.asarray(logit).reshape(-1)[0]))))
    raw = raw.reshape(N_MESH, 3).astype(np.float64)
    xy = roi.to_frame(raw[:, :2] / np.array([size[1], size[0]], np.float64))
    return np.concatenate([xy, (raw[:, 2] / size[1] * roi.width)[:, None]], axis=1), score


def eye_roi(mesh: np.ndarray, corners: tuple[int, int]) -> Roi:
    """The iris crop of one eye from its two corner points of the mesh (468+, 2+) frame pixels."""
    first, second = np.asarray(mesh, np.float64)[list(corners), :2]
    return box_roi(np.stack([first, second]), rotation_to(first, second, 0.0), 2.3)


def iris_in_roi(frame: np.ndarray, roi: Roi, mirrored: bool) -> np.ndarray:
    """iris_landmark on roi of frame: the 5 iris points (5, 2) frame pixels: centre, then the right, top, left and
    bottom edges as the image shows them."""
    model = models.load(IRIS_MODEL)
    size = model.input_size
    image = crop(frame, roi, size)
    if mirrored:
        image = image[:, ::-1]
    _contour, iris = model.run(image.astype(np.float32) / np.float32(255.0))
    iris = iris.reshape(5, 3)[:, :2].astype(np.float64) / np.array([size[1], size[0]], np.float64)
    if mirrored:
        # back from the mirror image; MediaPipe's 478-point layout lists both irises as centre, image-right,
        # top, image-left, bottom edge (checked on the lexicon's clips), so the mirrored eye's edges swap
        iris[:, 0] = 1.0 - iris[:, 0]
        iris = iris[[0, 3, 2, 1, 4]]
    return roi.to_frame(iris)


def add_irises(frame: np.ndarray, mesh: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The 478-point face: mesh (468, 3) frame pixels plus both irises; (points (478, 3), iris_found (2,) bool).
    An eye whose corners coincide (no crop to take) stays at 0 with iris_found False."""
    points = np.zeros((N_POINTS, 3), np.float64)
    points[:N_MESH] = mesh
    found = np.zeros(2, bool)
    for index, ((corners, mirrored, where), contour) in enumerate(zip(EYES, EYE_CONTOURS)):
        roi = eye_roi(mesh, corners)
        if not roi.width > 1e-6:
            continue
        points[where, :2] = iris_in_roi(frame, roi, mirrored)
        points[where, 2] = mesh[list(contour), 2].mean()
        found[index] = True
    return points, found


class FaceTracker:
    """The face stage over consecutive frames of one video (keeps the previous mesh for tracking)."""

    def __init__(self, with_irises: bool = True) -> None:
        self.with_irises = with_irises
        self._previous_mesh: np.ndarray | None = None

    def reset(self) -> None:
        self._previous_mesh = None

    def find_roi(self, frame: np.ndarray, pose_points: np.ndarray) -> Roi | None:
        """The ROI the mesh model should see in this frame, or None when the face detector finds no face near the
        pose's face."""
        found = detect_in_roi(frame, roi_from_pose(pose_points), FACE_DETECTION)
        if not found:
            return None
        keypoints = found[0].keypoints
        recrop = box_roi(keypoints, rotation_to(keypoints[0], keypoints[1], 0.0), 2.0, shift_y=-0.1)
        if self._previous_mesh is not None:
            previous = roi_from_mesh(self._previous_mesh)
            if _keeps_tracking(previous, recrop, self._previous_mesh):
                return previous
        return recrop

    def process(self, frame: np.ndarray, pose_points: np.ndarray | None) -> FaceResult | None:
        """The face in frame (H, W, 3) uint8 RGB given this frame's pose points (33, 2+) frame pixels, or None."""
        if pose_points is None:
            self._previous_mesh = None
            return None
        roi = self.find_roi(frame, pose_points)
        mesh, score = (None, 0.0) if roi is None else mesh_in_roi(frame, roi)
        if mesh is None or not score >= SCORE_THRESHOLD:
            self._previous_mesh = None
            return None
        self._previous_mesh = mesh
        if self.with_irises:
            points, iris_found = add_irises(frame, mesh)
        else:
            points, iris_found = np.concatenate([mesh, np.zeros((N_POINTS - N_MESH, 3))]), np.zeros(2, bool)
        return FaceResult(points, score, roi, iris_found)

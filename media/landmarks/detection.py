"""MediaPipe's SSD detectors (pose, face, palm): anchors, decoding, weighted non-max suppression, letterboxing.

Each detector is described by one `SsdOptions` (POSE_DETECTION, FACE_DETECTION, PALM_DETECTION below), whose
numbers are those of MediaPipe's public graph definitions (SsdAnchorsCalculator, TensorsToDetectionsCalculator and
NonMaxSuppressionCalculator options in mediapipe/modules/{pose,face,palm}_detection/*.pbtxt). `anchors(options)`
generates the anchors as MediaPipe's SsdAnchorsCalculator does; `decode` turns a model's raw outputs into
`Detection`s in the model's input pixels, sigmoid scores thresholded, after MediaPipe's weighted non-max
suppression. `detect_in_frame` runs a detector on a whole frame (letterboxed to the model's square input, as
MediaPipe's ImageToTensorCalculator with keep_aspect_ratio) and `detect_in_roi` on a rotated square region; both
return detections in frame pixels.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass

import cv2
import numpy as np

from media.landmarks import models
from media.landmarks.roi import Roi, crop


@dataclass(frozen=True)
class SsdOptions:
    """One SSD detector: its model, input, anchors and decoding (MediaPipe's option names)."""
    model: str                          # file name under media/assets/mediapipe, without .tflite
    input_size: int                     # square input, pixels
    input_range: tuple[float, float]    # what pixel values 0 and 255 become
    strides: tuple[int, ...]            # one per anchor layer
    num_keypoints: int
    min_score: float                    # sigmoid score threshold
    min_scale: float = 0.1484375
    max_scale: float = 0.75
    anchor_offset: float = 0.5
    aspect_ratios: tuple[float, ...] = (1.0,)
    interpolated_scale_aspect_ratio: float = 1.0
    fixed_anchor_size: bool = True
    score_clipping: float = 100.0
    min_suppression_iou: float = 0.3


# mediapipe/modules/pose_detection/pose_detection_cpu.pbtxt: keypoints 0 mid-hip centre, 1 full-body size and
# rotation point, 2 mid-shoulder centre, 3 upper-body size and rotation point
POSE_DETECTION = SsdOptions(model="pose_detection", input_size=224, input_range=(-1.0, 1.0),
                            strides=(8, 16, 32, 32, 32), num_keypoints=4, min_score=0.5)
# mediapipe/modules/face_detection/face_detection_short_range.pbtxt: keypoints 0 right eye, 1 left eye, 2 nose
# tip, 3 mouth centre, 4 right ear tragion, 5 left ear tragion (the person's own sides)
FACE_DETECTION = SsdOptions(model="face_detection_short_range", input_size=128, input_range=(-1.0, 1.0),
                            strides=(8, 16, 16, 16), num_keypoints=6, min_score=0.5)
# mediapipe/modules/palm_detection/palm_detection_cpu.pbtxt: keypoints 0 wrist centre, 1 index finger MCP,
# 2 middle finger MCP, 3 ring finger MCP, 4 pinky MCP, 5 thumb CMC, 6 thumb MCP
PALM_DETECTION = SsdOptions(model="palm_detection_full", input_size=192, input_range=(0.0, 1.0),
                            strides=(8, 16, 16, 16), num_keypoints=7, min_score=0.5)


@dataclass(frozen=True)
class Detection:
    """score in [0, 1]; box (x0, y0, x1, y1) pixels; keypoints (K, 2) pixels (x right, y down)."""
    score: float
    box: np.ndarray
    keypoints: np.ndarray


def _scale(options: SsdOptions, layer: int) -> float:
    count = len(options.strides)
    if count == 1:
        return 0.5 * (options.min_scale + options.max_scale)
    return options.min_scale + (options.max_scale - options.min_scale) * layer / (count - 1)


@functools.lru_cache(maxsize=None)
def anchors(options: SsdOptions) -> np.ndarray:
    """(N, 4) float64 anchors (x_centre, y_centre, width, height), normalised to the input, in the order of the
    model's outputs (MediaPipe's SsdAnchorsCalculator; reduce_boxes_in_lowest_layer is off in every detector here)."""
    rows = []
    strides = options.strides
    layer = 0
    while layer < len(strides):
        sizes = []
        last = layer
        while last < len(strides) and strides[last] == strides[layer]:   # layers of one stride share a grid
            scale = _scale(options, last)
            for ratio in options.aspect_ratios:
                sizes.append((scale * np.sqrt(ratio), scale / np.sqrt(ratio)))
            if options.interpolated_scale_aspect_ratio > 0:
                following = 1.0 if last == len(strides) - 1 else _scale(options, last + 1)
                ratio = options.interpolated_scale_aspect_ratio
                middle = np.sqrt(scale * following)
                sizes.append((middle * np.sqrt(ratio), middle / np.sqrt(ratio)))
            last += 1
        grid = int(np.ceil(options.input_size / strides[layer]))
        for y in range(grid):
            for x in range(grid):
                for width, height in sizes:
                    if options.fixed_anchor_size:
                        width = height = 1.0
                    rows.append(((x + options.anchor_offset) / grid, (y + options.anchor_offset) / grid, width, height))
        layer = last
    return np.array(rows, dtype=np.float64)


def decode(raw_boxes: np.ndarray, raw_scores: np.ndarray, options: SsdOptions) -> list[Detection]:
    """Detections from one image's raw outputs: raw_boxes (N, 4 + 2K) (x, y, w, h offsets then keypoints, in input
    pixels relative to each anchor), raw_scores (N, 1) logits. Returns detections in the model's input pixels, best
    first, after the score threshold and MediaPipe's weighted non-max suppression."""
    anchor = anchors(options)
    size = float(options.input_size)
    logits = np.clip(np.asarray(raw_scores, np.float64).reshape(-1), -options.score_clipping, options.score_clipping)
    scores = 1.0 / (1.0 + np.exp(-logits))
    kept = np.flatnonzero(scores >= options.min_score)
    if not len(kept):
        return []
    raw = np.asarray(raw_boxes, np.float64)[kept]
    anchor = anchor[kept]
    centre = raw[:, 0:2] / size * anchor[:, 2:4] + anchor[:, 0:2]
    half = 0.5 * raw[:, 2:4] / size * anchor[:, 2:4]
    boxes = np.concatenate([centre - half, centre + half], axis=1) * size
    points = raw[:, 4:4 + 2 * options.num_keypoints].reshape(len(kept), options.num_keypoints, 2)
    points = (points / size * anchor[:, None, 2:4] + anchor[:, None, 0:2]) * size
    return _weighted_nms(scores[kept], boxes, points, options.min_suppression_iou)


def _iou(box: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    x0 = np.maximum(box[0], boxes[:, 0])
    y0 = np.maximum(box[1], boxes[:, 1])
    x1 = np.minimum(box[2], boxes[:, 2])
    y1 = np.minimum(box[3], boxes[:, 3])
    inter = np.clip(x1 - x0, 0, None) * np.clip(y1 - y0, 0, None)
    area = (box[2] - box[0]) * (box[3] - box[1])
    areas = (boxes[:, 2] - boxes[:, 0]) * (boxes[:, 3] - boxes[:, 1])
    union = area + areas - inter
    return np.where(union > 0, inter / np.where(union > 0, union, 1.0), 0.0)


def _weighted_nms(scores: np.ndarray, boxes: np.ndarray, points: np.ndarray, threshold: float) -> list[Detection]:
    """MediaPipe's WEIGHTED non-max suppression: the best remaining detection absorbs every one overlapping it by
    more than threshold IoU (itself included); box and keypoints become their score-weighted mean, the score stays
    the best one's."""
    order = np.argsort(-scores, kind="stable")
    remaining = order
    result = []
    while len(remaining):
        best = remaining[0]
        overlap = _iou(boxes[best], boxes[remaining]) > threshold
        overlap[0] = True
        group = remaining[overlap]
        weights = scores[group] / scores[group].sum()
        result.append(Detection(float(scores[best]), weights @ boxes[group],
                                np.tensordot(weights, points[group], axes=1)))
        remaining = remaining[~overlap]
    return result


def _input(image: np.ndarray, options: SsdOptions) -> np.ndarray:
    low, high = options.input_range
    return image.astype(np.float32) * np.float32((high - low) / 255.0) + np.float32(low)


def _run(image: np.ndarray, options: SsdOptions) -> list[Detection]:
    outputs = models.load(options.model).run(_input(image, options))
    boxes, scores = sorted(outputs, key=lambda output: -output.shape[-1])   # (N, 4 + 2K) then (N, 1)
    return decode(boxes, scores, options)


@dataclass(frozen=True)
class Letterbox:
    """A frame scaled by `scale` (aspect kept) and placed at offset (x, y) pixels in a square model input."""
    scale: float
    offset: tuple[float, float]

    @classmethod
    def fit(cls, width: int, height: int, size: int) -> "Letterbox":
        scale = min(size / width, size / height)
        return cls(scale, (0.5 * (size - width * scale), 0.5 * (size - height * scale)))

    def to_frame(self, points: np.ndarray) -> np.ndarray:
        """Model input pixels (..., 2) -> frame pixels (..., 2)."""
        return (np.asarray(points, np.float64) - np.array(self.offset)) / self.scale

    def apply(self, frame: np.ndarray, size: int) -> np.ndarray:
        """frame (H, W, 3) uint8 -> (size, size, 3) uint8, zero (black) borders."""
        matrix = np.array([[self.scale, 0, self.offset[0]], [0, self.scale, self.offset[1]]], dtype=np.float64)
        return cv2.warpAffine(frame, matrix, (size, size), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT,
                              borderValue=0)


def detect_in_frame(frame: np.ndarray, options: SsdOptions) -> list[Detection]:
    """Detections in a whole frame (H, W, 3) uint8 RGB, letterboxed to the model's input; frame pixels, best first."""
    height, width = frame.shape[:2]
    letterbox = Letterbox.fit(width, height, options.input_size)
    found = _run(letterbox.apply(frame, options.input_size), options)
    return [Detection(d.score, letterbox.to_frame(d.box.reshape(2, 2)).reshape(4), letterbox.to_frame(d.keypoints))
            for d in found]


def detect_in_roi(frame: np.ndarray, roi: Roi, options: SsdOptions) -> list[Detection]:
    """Detections inside a square rotated ROI of frame (H, W, 3) uint8 RGB; frame pixels, best first. Each box
    becomes the axis-aligned bounds of its projected corners."""
    size = options.input_size
    found = _run(crop(frame, roi, (size, size)), options)
    result = []
    for d in found:
        x0, y0, x1, y1 = d.box / size
        corners = roi.to_frame(np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]]))
        result.append(Detection(d.score, np.concatenate([corners.min(axis=0), corners.max(axis=0)]),
                                roi.to_frame(d.keypoints / size)))
    return result

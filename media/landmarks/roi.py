"""Rotated regions of interest: what a landmark model sees, and how its outputs map back to the frame.

A `Roi` is a rotated rectangle in frame pixels: centre (cx, cy), size (width, height) and rotation
(radians; MediaPipe's convention: a positive angle turns the ROI clockwise as the image shows it,
since y points down). `crop` resamples the ROI to a model's input size with
one affine warp (border replicated, as MediaPipe's ImageToTensor does), and `to_frame` maps points in
the model's normalised crop coordinates ([0, 1] x [0, 1], x right, y down) back to frame pixels.
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np


@dataclass(frozen=True)
class Roi:
    """cx, cy: centre (pixels); width, height: size (pixels); angle: rotation (radians). The ROI's
    own x axis points along (cos angle, sin angle) and its y axis along (-sin angle, cos angle) in the
    frame (x right, y down), as in MediaPipe's NormalizedRect."""
    cx: float
    cy: float
    width: float
    height: float
    angle: float = 0.0

    def axes(self) -> tuple[np.ndarray, np.ndarray]:
        """Unit vectors (2,) of the ROI's x (right) and y (down) axes in frame pixels."""
        c, s = np.cos(self.angle), np.sin(self.angle)
        return np.array([c, s]), np.array([-s, c])

    def corners(self) -> np.ndarray:
        """(4, 2) pixels: top-left, top-right, bottom-right, bottom-left of the ROI as the model sees it."""
        x_axis, y_axis = self.axes()
        centre = np.array([self.cx, self.cy])
        half_w, half_h = 0.5 * self.width * x_axis, 0.5 * self.height * y_axis
        return np.stack([centre - half_w - half_h, centre + half_w - half_h,
                         centre + half_w + half_h, centre - half_w + half_h])

    def to_frame(self, normalised: np.ndarray) -> np.ndarray:
        """Points (..., 2) in crop coordinates ([0, 1], x right, y down) -> frame pixels (..., 2)."""
        x_axis, y_axis = self.axes()
        u = (np.asarray(normalised[..., 0:1]) - 0.5) * self.width
        v = (np.asarray(normalised[..., 1:2]) - 0.5) * self.height
        return np.array([self.cx, self.cy]) + u * x_axis + v * y_axis

    def to_crop(self, pixels: np.ndarray) -> np.ndarray:
        """Frame pixels (..., 2) -> crop coordinates (..., 2), the inverse of `to_frame`."""
        x_axis, y_axis = self.axes()
        d = np.asarray(pixels, dtype=np.float64) - np.array([self.cx, self.cy])
        return np.stack([d @ x_axis / self.width + 0.5, d @ y_axis / self.height + 0.5], axis=-1)

    def scaled(self, factor_x: float, factor_y: float | None = None, shift_y: float = 0.0) -> "Roi":
        """The ROI enlarged by factors, its centre moved by shift_y x height along its own y axis."""
        _, y_axis = self.axes()
        centre = np.array([self.cx, self.cy]) + shift_y * self.height * y_axis
        return Roi(float(centre[0]), float(centre[1]), self.width * factor_x,
                   self.height * (factor_x if factor_y is None else factor_y), self.angle)

    def squared(self) -> "Roi":
        """The ROI made square on its longer side."""
        side = max(self.width, self.height)
        return Roi(self.cx, self.cy, side, side, self.angle)


def crop(frame: np.ndarray, roi: Roi, size: tuple[int, int]) -> np.ndarray:
    """The ROI of frame (H, W, 3) uint8 resampled to size (height, width): (height, width, 3) uint8,
    bilinear, borders replicated."""
    height, width = size
    source = roi.corners()[[0, 1, 3]].astype(np.float32)
    target = np.array([[0, 0], [width, 0], [0, height]], dtype=np.float32)
    matrix = cv2.getAffineTransform(source, target)
    return cv2.warpAffine(frame, matrix, (width, height), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)


def rotation_to(points_from: np.ndarray, points_to: np.ndarray, target_angle: float) -> float:
    """MediaPipe's ROI rotation: target_angle (radians) minus the angle of the vector from
    points_from (2,) to points_to (2,) pixels, measured with y up; normalised to [-pi, pi)."""
    dx, dy = points_to[0] - points_from[0], points_to[1] - points_from[1]
    angle = target_angle - np.arctan2(-dy, dx)
    return float(angle - 2.0 * np.pi * np.floor((angle + np.pi) / (2.0 * np.pi)))

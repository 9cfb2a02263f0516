"""Where the person is: MediaPipe's selfie segmentation model (general, 256x256) run on whole frames.

As MediaPipe's SelfieSegmentationCpu graph does: the frame is stretched to the model's square input (aspect
not kept), bilinear, RGB scaled to [0, 1]; the model's one output is already a person probability per input
pixel (no activation is applied to it), and it is resized back to the frame's size, bilinear.
"""
from __future__ import annotations

from typing import Callable, Iterable

import cv2
import numpy as np

from media.errors import SigncastError
from media.landmarks import models

MODEL = "selfie_segmentation"
PERSON_THRESHOLD = 0.5          # probability at which a pixel counts as the person's


def person_probability(frame: np.ndarray) -> np.ndarray:
    """Person probability (H, W) float32 in [0, 1] of one frame (H, W, 3) uint8 RGB."""
    frame = np.asarray(frame)
    if frame.ndim != 3 or frame.shape[-1] != 3 or frame.dtype != np.uint8:
        raise SigncastError(f"a frame must be (H, W, 3) uint8 RGB, got {frame.shape} {frame.dtype}")
    height, width = frame.shape[:2]
    model = models.load(MODEL)
    model_height, model_width = model.input_size
    tensor = cv2.resize(frame, (model_width, model_height), interpolation=cv2.INTER_LINEAR).astype(np.float32) / 255.0
    probability = model.run(tensor)[0][..., 0]
    probability = cv2.resize(probability, (width, height), interpolation=cv2.INTER_LINEAR)
    return np.clip(probability, 0.0, 1.0).astype(np.float32)


def person_masks(frames: Iterable[np.ndarray], threshold: float = PERSON_THRESHOLD,
                 progress: Callable[[int], object] | None = None) -> np.ndarray:
    """Person masks (T, H, W) bool of frames (T, H, W, 3) uint8 RGB: probability >= threshold.

    progress: called with 1 after each frame."""
    masks = []
    for frame in frames:
        masks.append(person_probability(frame) >= threshold)
        if progress:
            progress(1)
    if not masks:
        raise SigncastError("no frames to find the person in")
    return np.stack(masks)

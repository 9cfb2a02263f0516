"""What a viewer can read: landmarks of what the viewer sees against the landmarks of the reference.

`measure(reference, observed)` compares two SignClips of the same frames (MediaPipe Holistic layout,
media.pose_file.HOLISTIC_LAYOUT): the reference's landmarks (of the source video, or of the lossless
render) and the landmarks extracted from what the viewer sees (the decoded video, or the terminal's
re-render of the decoded parameters). Only the image plane counts: x and y in pixels; z is not
comparable between extractions of different renders.

Definitions (per frame, then the mean and the 90th percentile over frames):
- a hand is shown in a frame when all 21 of its points have confidence > 0; the face when all 468
  mesh points do;
- a hand signs in a frame when the reference shows it in the signing space: its wrist (point 0) above the waist,
  the midpoint between the reference's shoulders' and hips' centres (pose points 11, 12, 23, 24; image y down).
  A hand hanging at rest by the hip carries no message, and at the sizes a resting hand has in a frame framed for
  signing (a 176x144 render: a 6 px hand) its landmarks jitter by a large share of its size, so counting it would
  score the extractor's noise, not the signing; where the reference has no hips or shoulders every shown hand
  signs;
- hand size (`hand_sizes`), per frame and hand, from the REFERENCE: the larger of the palm's length
  (wrist -> middle-finger MCP, points 0 -> 9) and PALM_LENGTH_PER_WIDTH times its width (index MCP ->
  pinky MCP, 5 -> 17). It does not depend on the fingers, so it does not shrink for a fist (a landmark
  box does), and it survives the palm turning edge-on (one of the two stays unforeshortened). With
  1.3 the size varies least inside a lexicon clip's frames: coefficient of variation 9 % against 16 %
  for the palm length alone and 13 % for the longer side of the landmark box. An adult's palm length is
  about 10 cm, so 0.1 hand sizes is about a centimetre;
- hand error of a frame and hand: the mean over the 21 keypoints of |observed - reference| / hand size,
  over the (frame, hand) pairs where both clips show the hand; hand_error / hand_error_p90 pool both
  hands' pairs;
- hand PCK at 0.1 / 0.2: the share (percent) of keypoints within 0.1 / 0.2 hand sizes, over every
  (frame, hand) pair where the REFERENCE shows the hand; a hand the observed clip does not show counts as
  21 keypoints wrong, so losing a hand never scores better than keeping it badly;
- left_hand_found / right_hand_found: the share (percent) of the frames showing that hand in the
  reference in which the observed clip shows it too;
- face error of a frame: the mean over the 468 mesh points of the distance / interocular distance; the
  interocular distance is the reference's pupil centres (points 468 and 473) where both irises were
  found, else its eyes' outer corners (33 and 263); over frames where both clips show the face. Frames
  where the observed clip loses the face are not in face_error; `face_found` counts them (not a record
  field).
- mouth error and eyes error (the non-manual features that carry grammar: mouthing, brows, eyelids,
  gaze) of a frame: the mean distance / interocular distance over the lip points (MOUTH_POINTS, the 40
  inner and outer lip contour points of the mesh) or the eye, brow and iris points (EYES_POINTS), after
  removing the frame's mean offset of the whole mesh between the two clips, so a face that is only
  displaced counts in face_error but not here; same frames as face_error.
A value is None where it is undefined (e.g. the reference never shows the left hand).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from media.errors import SigncastError
from media.lexicon import HAND_COMPONENTS, SignClip

FACE_COMPONENT = "FACE_LANDMARKS"
POSE_COMPONENT = "POSE_LANDMARKS"
SHOULDERS, HIPS = (11, 12), (23, 24)
MESH_POINTS = 468
PUPILS = (468, 473)
EYE_OUTER_CORNERS = (33, 263)
# MediaPipe face-mesh contours (FACEMESH_LIPS, _LEFT/RIGHT_EYE, _LEFT/RIGHT_EYEBROW; irises 468..477)
MOUTH_POINTS = (61, 146, 91, 181, 84, 17, 314, 405, 321, 375, 291, 409, 270, 269, 267, 0, 37, 39, 40, 185,
                78, 95, 88, 178, 87, 14, 317, 402, 318, 324, 308, 415, 310, 311, 312, 13, 82, 81, 80, 191)
EYES_POINTS = (33, 7, 163, 144, 145, 153, 154, 155, 133, 173, 157, 158, 159, 160, 161, 246,
               263, 249, 390, 373, 374, 380, 381, 382, 362, 398, 384, 385, 386, 387, 388, 466,
               46, 53, 52, 65, 55, 70, 63, 105, 66, 107, 276, 283, 282, 295, 285, 300, 293, 334, 296, 336)
IRIS_POINTS = tuple(range(468, 478))
PALM_LENGTH_PER_WIDTH = 1.3
PCK_THRESHOLDS = (0.1, 0.2)      # hand sizes
RECORD_FIELDS = ("hand_error", "hand_error_p90", "hand_pck_10", "hand_pck_20", "left_hand_found",
                 "right_hand_found", "face_error", "face_error_p90", "mouth_error", "eyes_error")


@dataclass(frozen=True)
class Intelligibility:
    """Landmark agreement of one observed clip with its reference (see the module docstring).

    hand_error, hand_error_p90: hand sizes; hand_pck_10, hand_pck_20, left_hand_found, right_hand_found,
    face_found: percent; face_error, face_error_p90: interocular distances. None where undefined.
    """
    hand_error: float | None = None
    hand_error_p90: float | None = None
    hand_pck_10: float | None = None
    hand_pck_20: float | None = None
    left_hand_found: float | None = None
    right_hand_found: float | None = None
    face_error: float | None = None
    face_error_p90: float | None = None
    face_found: float | None = None
    mouth_error: float | None = None
    eyes_error: float | None = None

    def fields(self) -> dict[str, float]:
        """The record fields (comparisons.reports.records names) that have a value."""
        return {name: getattr(self, name) for name in RECORD_FIELDS if getattr(self, name) is not None}


def hand_sizes(points: np.ndarray) -> np.ndarray:
    """Hand size in pixels of hand landmarks (..., 21, >=2): max(|p0 - p9|, 1.3 |p5 - p17|) in x, y."""
    points = np.asarray(points, np.float64)[..., :2]
    length = np.linalg.norm(points[..., 9, :] - points[..., 0, :], axis=-1)
    width = np.linalg.norm(points[..., 17, :] - points[..., 5, :], axis=-1)
    return np.maximum(length, PALM_LENGTH_PER_WIDTH * width)


def shown(clip: SignClip, component: str, n_points: int | None = None) -> np.ndarray:
    """(T,) bool: frames in which the first n_points (all: None) of a component all have confidence > 0."""
    confidence = clip.confidence.get(component)
    if confidence is None or confidence.size == 0:
        return np.zeros(clip.n_frames, bool)
    return np.all(confidence[:, :n_points] > 0, axis=1)


def interocular_distances(face: np.ndarray, confidence: np.ndarray) -> np.ndarray:
    """(T,) pixels: pupil to pupil where both irises were found, else outer eye corner to corner."""
    pupils = np.linalg.norm(face[:, PUPILS[0], :2] - face[:, PUPILS[1], :2], axis=-1)
    corners = np.linalg.norm(face[:, EYE_OUTER_CORNERS[0], :2] - face[:, EYE_OUTER_CORNERS[1], :2], axis=-1)
    if confidence.shape[1] > max(PUPILS):
        has_pupils = np.all(confidence[:, list(PUPILS)] > 0, axis=1)
    else:
        has_pupils = np.zeros(len(face), bool)
    return np.where(has_pupils & (pupils > 0), pupils, corners)


def waist_heights(clip: SignClip) -> np.ndarray:
    """(T,) image y (pixels, down) of the waist: halfway between the shoulders' and the hips' centres (pose points
    11, 12 and 23, 24) where all four are seen, else +inf (every hand counts as signing)."""
    points, confidence = clip.points.get(POSE_COMPONENT), clip.confidence.get(POSE_COMPONENT)
    if points is None or confidence is None or points.shape[1] <= max(HIPS):
        return np.full(clip.n_frames, np.inf)
    seen = np.all(confidence[:, list(SHOULDERS + HIPS)] > 0, axis=1)
    waist = 0.5 * (points[:, list(SHOULDERS), 1].mean(axis=1) + points[:, list(HIPS), 1].mean(axis=1))
    return np.where(seen, waist, np.inf)


def signing_hands(reference: SignClip) -> np.ndarray:
    """(T, 2) bool: in each frame, whether the reference shows its left / right hand (HAND_COMPONENTS' order)
    signing: all 21 points found and the wrist above the waist (`waist_heights`). The hands `measure` and
    comparisons.judging.message count; an observed hand in any other frame enters no measure."""
    waist = waist_heights(reference)
    return np.stack([shown(reference, component) & (reference.points[component][:, 0, 1] < waist)
                     for component in HAND_COMPONENTS.values()], axis=1)


def _percent(share: float) -> float:
    return 100.0 * float(share)


def _mean_and_p90(values: list[np.ndarray]) -> tuple[float | None, float | None]:
    pooled = np.concatenate(values) if values else np.zeros(0)
    if not pooled.size:
        return None, None
    return float(np.mean(pooled)), float(np.percentile(pooled, 90))


def measure(reference: SignClip, observed: SignClip) -> Intelligibility:
    """Hand and face landmark agreement of `observed` with `reference` (same frames; see the module docstring).

    Raises SigncastError when the clips have different frame counts.
    """
    if reference.n_frames != observed.n_frames:
        raise SigncastError(f"cannot compare landmarks: the reference has {reference.n_frames} frames, "
                            f"the observed clip {observed.n_frames}")
    hand_errors, pck_hits, pck_counts, found = [], np.zeros(len(PCK_THRESHOLDS)), 0, {}
    waist = waist_heights(reference)
    for hand, component in HAND_COMPONENTS.items():
        in_reference = shown(reference, component) & (reference.points[component][:, 0, 1] < waist)
        if not in_reference.any():
            found[hand] = None
            continue
        in_observed = shown(observed, component) & in_reference
        found[hand] = _percent(in_observed.sum() / in_reference.sum())
        both = np.flatnonzero(in_observed)
        truth = reference.points[component][both, :, :2]
        size = hand_sizes(truth)[:, None]
        distances = np.linalg.norm(observed.points[component][both, :, :2] - truth, axis=-1) / np.maximum(size, 1e-9)
        hand_errors.append(distances.mean(axis=1))
        pck_hits += [np.sum(distances <= threshold) for threshold in PCK_THRESHOLDS]
        pck_counts += 21 * int(in_reference.sum())          # lost hands: 21 keypoints wrong each
    hand_error, hand_error_p90 = _mean_and_p90(hand_errors)
    pck = [None if not pck_counts else _percent(hits / pck_counts) for hits in pck_hits]

    face_error = face_error_p90 = face_found = mouth_error = eyes_error = None
    in_reference = shown(reference, FACE_COMPONENT, MESH_POINTS)
    if in_reference.any():
        in_observed = shown(observed, FACE_COMPONENT, MESH_POINTS) & in_reference
        face_found = _percent(in_observed.sum() / in_reference.sum())
        both = np.flatnonzero(in_observed)
        truth = reference.points[FACE_COMPONENT][both]
        interocular = interocular_distances(truth, reference.confidence[FACE_COMPONENT][both])
        distances = np.linalg.norm(observed.points[FACE_COMPONENT][both, :MESH_POINTS, :2]
                                   - truth[:, :MESH_POINTS, :2], axis=-1)
        face_error, face_error_p90 = _mean_and_p90([distances.mean(axis=1) / np.maximum(interocular, 1e-9)])
        if len(both):
            mouth_error = _feature_error(observed.points[FACE_COMPONENT][both], truth, interocular, MOUTH_POINTS)
            has_irises = min(observed.points[FACE_COMPONENT].shape[1], truth.shape[1]) > max(IRIS_POINTS)
            eyes_error = _feature_error(observed.points[FACE_COMPONENT][both], truth, interocular,
                                        EYES_POINTS + (IRIS_POINTS if has_irises else ()))
    return Intelligibility(hand_error=hand_error, hand_error_p90=hand_error_p90, hand_pck_10=pck[0],
                           hand_pck_20=pck[1], left_hand_found=found["left"], right_hand_found=found["right"],
                           face_error=face_error, face_error_p90=face_error_p90, face_found=face_found,
                           mouth_error=mouth_error, eyes_error=eyes_error)


def _feature_error(observed: np.ndarray, truth: np.ndarray, interocular: np.ndarray, indices: tuple[int, ...]) -> float:
    """Mean over frames and `indices` of |observed - truth| / interocular after removing each frame's mean
    mesh offset. observed, truth: (N, >=478 or 468, >=2) pixels; interocular: (N,) pixels."""
    offset = np.mean(observed[:, :MESH_POINTS, :2] - truth[:, :MESH_POINTS, :2], axis=1, keepdims=True)
    index = list(indices)
    distances = np.linalg.norm(observed[:, index, :2] - offset - truth[:, index, :2], axis=-1)
    return float(np.mean(distances.mean(axis=1) / np.maximum(interocular, 1e-9)))


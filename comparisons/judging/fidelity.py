"""Message fidelity, framing-invariant: what of a person's signing another clip (the avatar's render, a decoded
video) keeps, measured so that the two clips may be framed differently (another size, position, zoom).

Pure functions on landmark arrays (MediaPipe Holistic layout, image pixels x right, y down; only x and y are used:
the two clips' depths are not comparable). The reference is the person's clip; "observed" the other one.

- handshape (`handshape`), per hand and frame: the 20 points other than the wrist, minus the wrist, over the hand
  size (each clip's own: comparisons.judging.intelligibility.hand_sizes), so framing cancels. The error is the mean
  distance (hand sizes) and PCK@0.2 the share of points within 0.2 hand sizes, with the orientation kept (a hand
  turned in the image is another message); the shape-only error and PCK after the best in-plane rotation of the
  observed hand onto the reference's (rotation only, never a reflection: a mirrored hand is another hand).
- location (`location`): one similarity per clip (scale, rotation, translation; `fit_similarity`) maps the
  observed clip's torso and face points (ANCHOR_POINTS of the pose, over all frames both show them) onto the
  reference's; each frame's wrist distance after it, in the reference's shoulder widths.
- movement (`movement`): the wrist's frame-to-frame velocity, the observed one turned and scaled by the same
  similarity, the difference in shoulder widths per frame.
- face (`face`): per frame, a similarity on the face mesh's stable points (FACE_ANCHORS) maps the observed face onto
  the reference's; then the mean distance of the mouth points and of the eye, brow and iris points, over the
  reference's interocular distance.
"""
from __future__ import annotations

import numpy as np

from comparisons.judging.intelligibility import EYES_POINTS, IRIS_POINTS, MOUTH_POINTS, hand_sizes
from media.framing import ANCHOR_POINTS, apply_similarity, fit_similarity   # shared with the avatar's framing

PCK_THRESHOLD = 0.2                 # hand sizes
LEFT_SHOULDER, RIGHT_SHOULDER = 11, 12
POSE_WRIST = {"left": 15, "right": 16}
HAND_COMPONENT = {"left": "LEFT_HAND_LANDMARKS", "right": "RIGHT_HAND_LANDMARKS"}
# face mesh points that move little with expression: forehead, nose bridge and tip, cheekbones, jaw corners,
# the eyes' outer and inner corners
FACE_ANCHORS = (10, 151, 9, 8, 168, 6, 197, 195, 5, 4, 1, 234, 454, 127, 356, 93, 323, 132, 361, 33, 263, 133, 362)


def _rotation_only(source: np.ndarray, target: np.ndarray) -> np.ndarray:
    """(2, 2) rotation (no reflection) turning source (N, 2) onto target (N, 2) best, both about the origin."""
    covariance = target.T @ source
    angle = np.arctan2(covariance[1, 0] - covariance[0, 1], covariance[0, 0] + covariance[1, 1])
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s], [s, c]])


def normalised_hand(points: np.ndarray) -> np.ndarray:
    """Hand landmarks (..., 21, >=2) pixels -> (..., 20, 2): points 1..20 minus the wrist, over the hand size."""
    points = np.asarray(points, np.float64)[..., :2]
    size = np.maximum(hand_sizes(points), 1e-9)
    return (points[..., 1:, :] - points[..., :1, :]) / size[..., None, None]


def handshape(reference: np.ndarray, observed: np.ndarray, reference_shown: np.ndarray,
              observed_shown: np.ndarray) -> dict[str, float | None]:
    """Handshape fidelity of one hand over a clip.

    reference, observed: (T, 21, >=2) pixels; *_shown: (T,) bool, the hand found in that frame. Over the frames the
    reference shows the hand: found (percent of them in which observed shows it too); over the frames both show it:
    error (mean distance, hand sizes) and pck (percent of points within PCK_THRESHOLD) with the orientation kept,
    shape_error and shape_pck after the best in-plane rotation. A frame where only the reference shows the hand
    counts as every point wrong in pck and shape_pck. None where the reference never shows the hand (or they never
    both do, for the errors)."""
    reference_shown = np.asarray(reference_shown, bool)
    both = reference_shown & np.asarray(observed_shown, bool)
    n_reference = int(reference_shown.sum())
    if not n_reference:
        return {"found": None, "error": None, "pck": None, "shape_error": None, "shape_pck": None}
    a = normalised_hand(reference[both])
    b = normalised_hand(observed[both])
    oriented = np.linalg.norm(a - b, axis=-1)                                   # (F, 20)
    shaped = np.stack([np.linalg.norm(a[f] - b[f] @ _rotation_only(b[f], a[f]).T, axis=-1) for f in range(len(a))]) \
        if len(a) else np.zeros((0, 20))
    points = n_reference * a.shape[-2] if len(a) else n_reference * 20
    pck = lambda distances: 100.0 * float(np.sum(distances <= PCK_THRESHOLD)) / points
    return {"found": 100.0 * float(both.sum()) / n_reference,
            "error": float(oriented.mean()) if len(a) else None,
            "pck": pck(oriented),
            "shape_error": float(shaped.mean()) if len(a) else None,
            "shape_pck": pck(shaped)}


def shoulder_width(pose: np.ndarray, shown: np.ndarray) -> float:
    """Median distance (pixels) between the shoulders (pose (T, 33, >=2)) over the frames shown (T,) bool."""
    pose = np.asarray(pose, np.float64)[np.asarray(shown, bool)]
    if not len(pose):
        return float("nan")
    return float(np.median(np.linalg.norm(pose[:, LEFT_SHOULDER, :2] - pose[:, RIGHT_SHOULDER, :2], axis=-1)))


def clip_similarity(reference_pose: np.ndarray, observed_pose: np.ndarray,
                    both_shown: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """The one similarity of a clip mapping the observed pose's ANCHOR_POINTS onto the reference's, fitted over
    all frames where both show the pose (both_shown (T,) bool); pose arrays (T, 33, >=2) pixels."""
    both_shown = np.asarray(both_shown, bool)
    source = np.asarray(observed_pose, np.float64)[both_shown][:, ANCHOR_POINTS, :2].reshape(-1, 2)
    target = np.asarray(reference_pose, np.float64)[both_shown][:, ANCHOR_POINTS, :2].reshape(-1, 2)
    return fit_similarity(source, target)


def location(reference_wrist: np.ndarray, observed_wrist: np.ndarray, transform, width: float,
             both_shown: np.ndarray) -> np.ndarray:
    """Per frame where both show the wrist (both_shown (T,) bool): |reference - mapped observed| in shoulder widths
    (width: the reference's, pixels); wrists (T, >=2) pixels; transform from clip_similarity."""
    both_shown = np.asarray(both_shown, bool)
    mapped = apply_similarity(transform, np.asarray(observed_wrist, np.float64)[both_shown])
    return np.linalg.norm(np.asarray(reference_wrist, np.float64)[both_shown, :2] - mapped, axis=-1) / width


def movement(reference_wrist: np.ndarray, observed_wrist: np.ndarray, transform, width: float,
             both_shown: np.ndarray) -> np.ndarray:
    """Per pair of consecutive frames both showing the wrist: |reference velocity - observed velocity turned and
    scaled by the similarity| in shoulder widths per frame."""
    both_shown = np.asarray(both_shown, bool)
    pairs = both_shown[1:] & both_shown[:-1]
    scale, rotation, _ = transform
    reference_velocity = np.diff(np.asarray(reference_wrist, np.float64)[:, :2], axis=0)[pairs]
    observed_velocity = scale * np.diff(np.asarray(observed_wrist, np.float64)[:, :2], axis=0)[pairs] @ rotation.T
    return np.linalg.norm(reference_velocity - observed_velocity, axis=-1) / width


def face(reference_face: np.ndarray, observed_face: np.ndarray, both_shown: np.ndarray) -> dict[str, float | None]:
    """Mouth and eyes (eyes, brows, irises) error after aligning each frame's observed face onto the reference's
    by a similarity on FACE_ANCHORS; faces (T, 478, >=2) pixels, both_shown (T,) bool. Means over frames of the
    mean point distance over the reference's interocular distance (pupil centres 468, 473)."""
    mouth, eyes = [], []
    for t in np.flatnonzero(np.asarray(both_shown, bool)):
        ref = np.asarray(reference_face[t], np.float64)[:, :2]
        obs = np.asarray(observed_face[t], np.float64)[:, :2]
        mapped = apply_similarity(fit_similarity(obs[list(FACE_ANCHORS)], ref[list(FACE_ANCHORS)]), obs)
        interocular = max(float(np.linalg.norm(ref[468] - ref[473])), 1e-9)
        mouth.append(np.mean(np.linalg.norm(mapped[list(MOUTH_POINTS)] - ref[list(MOUTH_POINTS)], axis=-1)) / interocular)
        points = list(EYES_POINTS) + list(IRIS_POINTS)
        eyes.append(np.mean(np.linalg.norm(mapped[points] - ref[points], axis=-1)) / interocular)
    return {"mouth_error": float(np.mean(mouth)) if mouth else None,
            "eyes_error": float(np.mean(eyes)) if eyes else None}


def _shown(confidence: np.ndarray) -> np.ndarray:
    return np.all(np.asarray(confidence) > 0, axis=1)


def message_fidelity(reference, observed) -> dict[str, float | None]:
    """All of the above between two SignClips of the same frames (reference: the person's): per hand
    ('left_'/'right_' + found, error, pck, shape_error, shape_pck, location, location_p90, movement), face
    (mouth_error, eyes_error). Units: percent, hand sizes, shoulder widths (per frame for movement), interocular
    distances. None where a part is never shown in both."""
    result: dict[str, float | None] = {}
    ref_pose, obs_pose = reference.points["POSE_LANDMARKS"], observed.points["POSE_LANDMARKS"]
    ref_pose_shown = np.all(reference.confidence["POSE_LANDMARKS"][:, ANCHOR_POINTS] > 0, axis=1)
    obs_pose_shown = np.all(observed.confidence["POSE_LANDMARKS"][:, ANCHOR_POINTS] > 0, axis=1)
    pose_both = ref_pose_shown & obs_pose_shown
    transform = clip_similarity(ref_pose, obs_pose, pose_both) if pose_both.any() else None
    width = shoulder_width(ref_pose, ref_pose_shown)
    for side, component in HAND_COMPONENT.items():
        ref_shown = _shown(reference.confidence[component])
        obs_shown = _shown(observed.confidence[component])
        for key, value in handshape(reference.points[component], observed.points[component], ref_shown,
                                    obs_shown).items():
            result[f"{side}_{key}"] = value
        both = ref_shown & obs_shown
        if transform is not None and both.any() and np.isfinite(width) and width > 0:
            ref_wrist = reference.points[component][:, 0]
            obs_wrist = observed.points[component][:, 0]
            distances = location(ref_wrist, obs_wrist, transform, width, both)
            velocities = movement(ref_wrist, obs_wrist, transform, width, both)
            result[f"{side}_location"] = float(np.mean(distances))
            result[f"{side}_location_p90"] = float(np.percentile(distances, 90))
            result[f"{side}_movement"] = float(np.mean(velocities)) if len(velocities) else None
        else:
            result[f"{side}_location"] = result[f"{side}_location_p90"] = result[f"{side}_movement"] = None
    face_both = _shown(reference.confidence["FACE_LANDMARKS"]) & _shown(observed.confidence["FACE_LANDMARKS"])
    result.update(face(reference.points["FACE_LANDMARKS"], observed.points["FACE_LANDMARKS"], face_both))
    return result

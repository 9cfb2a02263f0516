"""The person's message as one set of record fields: comparisons.judging.fidelity's framing-invariant measures,
summarised over the hands that sign, so that the avatar solutions and the video solutions are matched on the
same axis against the source video (issue 35, item 1).

`message_fields(reference, observed)` -> (all may be None where undefined):
- message_pck: handshape PCK@0.2 with the orientation kept (the 20 points minus the wrist over each clip's own
  hand size), percent, pooled over the hands the reference shows signing (wrist above the waist, as
  comparisons.judging.intelligibility counts a hand), a lost hand counting as all its points wrong;
- message_shape_pck: the same after the best in-plane rotation of each observed hand;
- message_location: the signing wrists' mean distance after one clip-wide similarity on torso and face (shoulder
  widths of the reference), the mean over the hands;
- message_movement: the wrists' velocity difference after that similarity (shoulder widths per frame);
- message_mouth, message_eyes: mouth and eyes/brows/irises error after a per-frame similarity on the face's stable
  points (interocular distances); message_face: their mean (the face criterion's field).
"""
from __future__ import annotations

import numpy as np

from comparisons.judging import fidelity
from comparisons.judging.intelligibility import waist_heights
from media.lexicon import HAND_COMPONENTS, SignClip

MESSAGE_FIELDS = ("message_pck", "message_shape_pck", "message_location", "message_movement", "message_mouth",
                  "message_eyes", "message_face")


def signing_only(reference: SignClip) -> SignClip:
    """A copy of reference whose hands are unshown (confidence 0) in the frames where they rest below the waist."""
    waist = waist_heights(reference)
    confidence = dict(reference.confidence)
    for component in HAND_COMPONENTS.values():
        if component not in reference.points:
            continue
        resting = reference.points[component][:, 0, 1] >= waist
        kept = confidence[component].copy()
        kept[resting] = 0
        confidence[component] = kept
    return SignClip(reference.fps, reference.points, confidence)


def _mean(values) -> float | None:
    present = [float(v) for v in values if v is not None and np.isfinite(v)]
    return float(np.mean(present)) if present else None


def message_fields(reference: SignClip, observed: SignClip) -> dict[str, float | None]:
    """The summary fields (see the module's description) of observed against the person's reference."""
    if reference.n_frames != observed.n_frames:
        raise ValueError(f"message fidelity needs the same frames: {reference.n_frames} and {observed.n_frames}")
    found = fidelity.message_fidelity(signing_only(reference), observed)
    weights = {side: int(np.sum(np.all(signing_only(reference).confidence[component] > 0, axis=1)))
               for side, component in fidelity.HAND_COMPONENT.items()}

    def pooled(key: str) -> float | None:
        """The hands' percentages weighted by the frames each signs (points per frame are equal)."""
        pairs = [(found.get(f"{side}_{key}"), weights[side]) for side in weights]
        pairs = [(value, weight) for value, weight in pairs if value is not None and weight > 0]
        total = sum(weight for _, weight in pairs)
        return sum(value * weight for value, weight in pairs) / total if total else None

    mouth, eyes = found.get("mouth_error"), found.get("eyes_error")
    return {"message_pck": pooled("pck"), "message_shape_pck": pooled("shape_pck"),
            "message_location": _mean(found.get(f"{side}_location") for side in weights),
            "message_movement": _mean(found.get(f"{side}_movement") for side in weights),
            "message_mouth": mouth, "message_eyes": eyes, "message_face": _mean((mouth, eyes))}

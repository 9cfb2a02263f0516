"""`signcast pose VIDEO -o clip.pose`: a real signer's video in, MediaPipe Holistic landmarks out.

The video is read at its own rate (scaled down to fit max_size, as the video command does), every frame goes
through signcast's Holistic graph (media.landmarks.holistic), and the landmarks are written as a `.pose` file in
the lexicon's layout (media.pose_file.write_pose), optionally with a preview video of the landmarks drawn on the
frames. A video with no person in it is refused (SigncastError); a hand missing from some frames (outside the
picture or hidden) is only noted: those frames are masked in the file.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from media.errors import SigncastError
from media.lexicon import SignClip
from media.video_io import resolve_video, video_info
from pipeline.studies.shared import DEFAULT_MAX_SIZE, draw_landmarks, extract_landmarks, read_natural_clip

POSE_SUFFIXES = (".pose",)
PREVIEW_SUFFIXES = (".mkv", ".avi", ".nut", ".mp4")   # lossless FFV1, but H.264 in .mp4 (what MP4 players play)


@dataclass(frozen=True)
class PoseSettings:
    """video: a path or a bundled clip name; output: the .pose file; preview: a video of the landmarks drawn on
    the frames, or None; max_size: (width, height) larger videos are scaled down to fit, None keeps the size;
    frames: only the first N frames (None: all)."""
    video: str
    output: Path
    preview: Path | None = None
    max_size: tuple[int, int] | None = DEFAULT_MAX_SIZE
    frames: int | None = None


@dataclass
class PoseResult:
    clip: SignClip
    width: int
    height: int
    shares: dict[str, float]         # part -> share of frames in which it was found
    frames_per_second: float         # extraction speed
    notes: list[str]


def check(settings: PoseSettings) -> Path:
    """Refuse a missing or unreadable video before any work; the video's path."""
    path = resolve_video(settings.video)
    video_info(path)
    if settings.frames is not None and settings.frames < 1:
        raise SigncastError(f"--frames must be at least 1, got {settings.frames}")
    return path


def run(settings: PoseSettings, *, progress: bool = True) -> PoseResult:
    """Read, extract, check and write (see the module's docstring)."""
    from media.landmarks.holistic import found_shares
    from media.pose_file import write_pose
    from media.video_io import write_video

    path = check(settings)
    video, notes = read_natural_clip(str(path), settings.frames, settings.max_size, progress=progress)
    frames = video.frames
    height, width = frames.shape[1:3]
    started = time.perf_counter()
    clip = extract_landmarks(frames, video.fps, "landmarks", progress, leave=True)
    speed = len(frames) / max(time.perf_counter() - started, 1e-9)
    shares = found_shares(clip)
    if shares["pose"] == 0.0:
        raise SigncastError(f"no person found in {path}: no body pose in any of its {len(frames)} frames")
    notes += missing_part_notes(clip, width, height)
    write_pose(settings.output, clip, width, height)
    if settings.preview is not None:
        drawn = draw_landmarks(frames, clip)
        if settings.preview.suffix.lower() == ".mp4":
            from media.video_io import crop_even
            write_video(settings.preview, crop_even(drawn), video.fps, codec="libx264", options={"crf": 18})
        else:
            write_video(settings.preview, drawn, video.fps)
    return PoseResult(clip, width, height, shares, speed, notes)


def missing_part_notes(clip: SignClip, width: int, height: int) -> list[str]:
    """One line per part missing from some frames; for a hand, how many of those frames have the pose's wrist
    outside the picture (width x height pixels): the hand left the frame, rather than being hidden."""
    from media.landmarks.holistic import PARTS, frames_missing
    from media.landmarks.hands import POSE_WRIST_PINKY_INDEX

    notes = []
    pose_points, pose_seen = clip.points["POSE_LANDMARKS"], clip.confidence["POSE_LANDMARKS"] > 0
    for part, component in PARTS.items():
        missing = frames_missing(clip, part)
        if not missing:
            continue
        if part == "pose":
            notes.append(f"note: no person is found in {missing} of {clip.n_frames} frames; those frames are "
                         "masked in the .pose")
            continue
        where = ""
        if part.endswith("hand"):
            wrist = POSE_WRIST_PINKY_INDEX[part.split()[0]][0]
            absent = ~np.any(clip.confidence[component] > 0, axis=1)
            x, y = pose_points[:, wrist, 0], pose_points[:, wrist, 1]
            outside = pose_seen[:, wrist] & ((x < 0) | (x >= width) | (y < 0) | (y >= height))
            left_frame = int(np.sum(absent & outside))
            where = f" (its wrist is outside the picture in {left_frame} of them)" if left_frame else ""
        notes.append(f"note: the {part} is not found in {missing} of {clip.n_frames} frames{where}; those "
                     "frames are masked in the .pose")
    return notes


def summary(settings: PoseSettings, result: PoseResult) -> str:
    """The one line the command prints."""
    shares = ", ".join(f"{part} {100 * share:.0f}%" for part, share in result.shares.items())
    return (f"{settings.output}: {result.clip.n_frames} frames at {result.clip.fps:.4g} fps, "
            f"{result.width}x{result.height}; found in frames: {shares}; "
            f"extracted at {result.frames_per_second:.1f} frames/s")

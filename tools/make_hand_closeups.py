"""Close-ups of the avatar's right hand holding ASL letters, one captioned strip (docs/).

Renders the held middle frame of each letter (the clip without the hand rising and dropping)
at 1408x1152, crops a square around the right hand's pixels (label 4) with a margin, and writes
the tiles side by side, each captioned with its letter.

    python tools/make_hand_closeups.py [--letters ABCOS] [--out docs/hands-ase-A-B-C-O-S.png]
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

RIGHT_HAND_LABEL = 4
TILE = 480          # pixels per tile side
MARGIN = 0.2        # share of the hand's extent added on each side


def hand_tile(frame: np.ndarray, label: np.ndarray, letter: str) -> np.ndarray:
    """A TILE x TILE crop (RGB) around the right hand's pixels, captioned with `letter`."""
    rows, cols = np.nonzero(label == RIGHT_HAND_LABEL)
    if not len(rows):
        raise SystemExit(f"letter {letter}: the right hand is not in the frame")
    centre = np.array([(rows.min() + rows.max()) / 2, (cols.min() + cols.max()) / 2])
    half = int(max(rows.max() - rows.min(), cols.max() - cols.min()) * (0.5 + MARGIN))
    padded = np.pad(frame, ((half, half), (half, half), (0, 0)), mode="edge")
    top, left = (centre + half).astype(int) - half
    crop = np.ascontiguousarray(padded[top:top + 2 * half, left:left + 2 * half])
    tile = cv2.resize(crop, (TILE, TILE), interpolation=cv2.INTER_AREA)
    cv2.putText(tile, letter, (12, 44), cv2.FONT_HERSHEY_SIMPLEX, 1.4, (0, 0, 0), 5, cv2.LINE_AA)
    cv2.putText(tile, letter, (12, 44), cv2.FONT_HERSHEY_SIMPLEX, 1.4, (255, 255, 255), 2, cv2.LINE_AA)
    return tile


def main() -> int:
    from media.avatar import load_avatar
    from media.fingerspelling import letter_motion
    from media.render import RenderSettings, render_motion

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--language", default="ase")
    parser.add_argument("--letters", default="ABCOS")
    parser.add_argument("--out", default=None, help="PNG path (default docs/hands-<language>-<letters>.png)")
    args = parser.parse_args()
    out = Path(args.out or ROOT / "docs" / f"hands-{args.language}-{'-'.join(args.letters)}.png")
    avatar = load_avatar()
    tiles = []
    for letter in args.letters:
        motion = letter_motion(args.language, letter, 25.0, keep_rise=False, keep_drop=False)
        middle = motion.n_frames // 2
        frames, labels = render_motion(avatar, motion.frames(middle, middle + 1), RenderSettings(width=1408, height=1152))
        tiles.append(hand_tile(frames[0], labels[0], letter))
    strip = np.concatenate(tiles, axis=1)
    out.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(out), cv2.cvtColor(strip, cv2.COLOR_RGB2BGR))
    print(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())

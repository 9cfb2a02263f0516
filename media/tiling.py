"""Tile several videos into one, each tile captioned (for side-by-side viewing)."""
from __future__ import annotations

import cv2
import numpy as np

CAPTION_HEIGHT = 18


def tile_videos(videos: list[tuple[np.ndarray, str]], tile_size: tuple[int, int] = (352, 288), columns: int = 4,
                n_frames: int | None = None) -> np.ndarray:
    """videos: list of (frames (T_i, H_i, W_i, 3) uint8 RGB, caption); tile_size: (width, height) of each tile's picture.

    Each video is scaled to fit its tile (aspect kept, letterboxed), a caption bar is drawn under it, and
    shorter videos loop. Returns (T, rows * (h + caption), columns * w, 3) uint8 with T = n_frames or the longest.
    """
    if not videos:
        raise ValueError("no videos to tile")
    width, height = tile_size
    columns = min(columns, len(videos))
    rows = -(-len(videos) // columns)
    T = n_frames or max(len(frames) for frames, _ in videos)
    cell_h = height + CAPTION_HEIGHT
    canvas = np.full((T, rows * cell_h, columns * width, 3), 24, dtype=np.uint8)
    for k, (frames, caption) in enumerate(videos):
        r, c = divmod(k, columns)
        y0, x0 = r * cell_h, c * width
        scale = min(width / frames.shape[2], height / frames.shape[1])
        w, h = max(1, round(frames.shape[2] * scale)), max(1, round(frames.shape[1] * scale))
        oy, ox = y0 + (height - h) // 2, x0 + (width - w) // 2
        resized = [cv2.resize(f, (w, h), interpolation=cv2.INTER_AREA if scale < 1 else cv2.INTER_LINEAR) for f in frames]
        for t in range(T):
            canvas[t, oy:oy + h, ox:ox + w] = resized[t % len(resized)]
        bar = np.full((CAPTION_HEIGHT, width, 3), 24, dtype=np.uint8)
        cv2.putText(bar, caption, (4, CAPTION_HEIGHT - 5), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (235, 235, 235), 1, cv2.LINE_AA)
        canvas[:, y0 + height:y0 + cell_h, x0:x0 + width] = bar
    return canvas

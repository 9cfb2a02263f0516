"""What would per-VOP boxes save over the clip-wide box (issue 39 §2)?

MPEG-4 Visual codes each VOP's texture in that VOP's own box (aligned to 16, padded). FFmpeg's MPEG-4 Part 2
encoder keeps one frame size per stream, so comparisons/video/objects.py codes an object in the union of its
boxes over the clip, on the frame's 16x16 grid, and fills every macroblock that holds no opaque pixel (which
includes every macroblock outside that VOP's own box) so that the encoder codes it almost for free: flat in
intra frames, skipped in predicted ones. Per-VOP boxes would save what those outside macroblocks still cost.

Per object (at MPEG-4 Q = 12, GOP 12) this prints: the union box in macroblocks, the mean macroblocks of each
VOP's own box (16-aligned on the same grid) and the share outside it, the object's texture bytes as coded today,
the bytes of the same box and frames with every macroblock transparent, and from those, less the bytes of an
all-transparent 32x32 stream of the same frames (the per-frame headers, which per-VOP boxes keep), the price of
one transparent macroblock a frame; then the saving per-VOP boxes could bring: that price times the
macroblocks outside each VOP's box, over the texture bytes; last, the mean transparent macroblocks a frame in the
union box (those outside the VOP's box and those inside it) and what they cost at that price, over the texture
bytes: what MPEG-4 Core, which sends no texture for them, would not pay.

    python benchmarks/object_boxes.py [--frames 36] [--clip carphone]
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np

from benchmarks.shape_coding import BIT_OBJECTS, avatar_labels, clip_labels

MB = 16


def vop_box_macroblocks(mask: np.ndarray) -> int:
    """Macroblocks of one VOP's own box (mask (H, W) bool), aligned to the frame's 16x16 grid; 0 if empty."""
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    if not len(rows):
        return 0
    return (rows[-1] // MB - rows[0] // MB + 1) * (cols[-1] // MB - cols[0] // MB + 1)


def empty_stream(frames: np.ndarray, fps: float) -> bytes:
    """MPEG-4 Q 12 stream of frames (T, h, w, 3) with every macroblock transparent (objects.pad_object)."""
    from comparisons.video import codecs as video_codecs
    from comparisons.video import objects as video_objects

    masks = np.zeros(frames.shape[:3], bool)
    return video_codecs.code_video(video_objects.pad_object(frames, masks), fps, "mpeg4", 12).data


def report(source: str, frames: np.ndarray, labels: np.ndarray, fps: float) -> None:
    from comparisons.video import objects as video_objects

    print(f"\n{source}: {labels.shape[2]}x{labels.shape[1]}, {len(labels)} frames, {fps:g} fps, Q 12")
    print(f"{'object':11} {'union MB':>8} {'VOP MB':>7} {'outside':>7} {'texture B':>9} {'empty B':>8}"
          f" {'bits/MB':>7} {'saving':>7} {'transp MB':>9} {'cost':>6}")
    for name, parts in BIT_OBJECTS.items():
        masks = np.isin(labels, parts)
        box = video_objects.bounding_box(masks, labels.shape[1:])
        if box is None:
            print(f"{name:11} never appears")
            continue
        y0, y1, x0, x1 = box
        union = (-(-(y1 - y0) // MB)) * (-(-(x1 - x0) // MB))
        own = np.mean([vop_box_macroblocks(m) for m in masks])
        coded = video_objects.code_object(name, frames, masks, fps, "mpeg4", 12)
        empty = len(empty_stream(frames[:, y0:y1, x0:x1], fps))
        per_mb = 8.0 * (empty - len(empty_stream(frames[:, :32, :32], fps))) / ((union - 4) * len(frames))
        saving = per_mb * (union - own) * len(frames) / 8.0
        transparent = np.mean([video_objects.transparent_macroblocks(m[y0:y1, x0:x1]).sum() for m in masks])
        transparent_cost = per_mb * transparent * len(frames) / 8.0
        print(f"{name:11} {union:8d} {own:7.1f} {100 * (1 - own / union):6.1f}% {coded.texture_bytes:9d}"
              f" {empty:8d} {per_mb:7.2f} {100 * saving / coded.texture_bytes:6.1f}%"
              f" {transparent:9.1f} {100 * transparent_cost / coded.texture_bytes:5.1f}%", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--frames", type=int, default=36)
    parser.add_argument("--clip", default=None, help="also a natural clip (e.g. carphone), landmark segmentation")
    args = parser.parse_args()
    from media.avatar import load_avatar
    from media.fingerspelling import fingerspell
    from media.render import AvatarRenderer, RenderSettings

    renderer = AvatarRenderer(load_avatar(), RenderSettings(width=320, height=240, backend="numpy"))
    pictures = []
    for picture, _ in renderer.frames(fingerspell("ase", "AB")):
        pictures.append(picture)
        if len(pictures) == args.frames:
            break
    report('avatar ASL "AB" (label buffer)', np.stack(pictures), avatar_labels(320, 240, args.frames), 25.0)
    if args.clip:
        from pipeline.studies.shared import read_natural_clip

        clip, _ = read_natural_clip(args.clip, max_frames=args.frames, progress=False)
        report(f"{args.clip} (landmark segmentation)", clip.frames, clip_labels(args.clip, args.frames), clip.fps)


if __name__ == "__main__":
    main()

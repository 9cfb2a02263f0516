"""Real video codecs through PyAV: encode frames to an elementary stream, decode it back.

- "mpeg4": MPEG-4 Part 2 at a truly fixed quantiser Q (qmin = qmax = Q; the `qscale` option is ignored by
  FFmpeg's encoder), GOP of 12 with 2 B-frames: I B B P B B P B B P B B. Raw `m4v` elementary stream.
- "libx264": H.264 at constant QP (0..51), GOP 12, 2 B-frames. Annex-B `h264` elementary stream.
- "libsvtav1": AV1 (SVT-AV1) at constant QP (1..63), preset 8, GOP 12. Low-overhead `obu` stream.

The measured size is len() of the stream that was decoded back. Frames are (T, H, W, 3) uint8 RGB with even
H and W (4:2:0); SVT-AV1 needs at least 64x64, so smaller frames are edge-padded for it and cropped back.
Also: frame-rate reduction by dropping frames at constant duration, and half resolution.
"""
from __future__ import annotations

import io
import os
from dataclasses import dataclass, field
from fractions import Fraction

import av
import cv2
import numpy as np

from media.errors import SigncastError
from media.video_io import frame_indices_at_rate

CODECS = {
    # name: (elementary stream format, quantiser range)
    "mpeg4": ("m4v", (1, 31)),
    "libx264": ("h264", (0, 51)),
    "libsvtav1": ("obu", (1, 63)),
}
GOP = 12
B_FRAMES = 2
_AV1_MIN_SIZE = 64
_PICTURE_TYPES = {1: "I", 2: "P", 3: "B", 4: "S", 5: "SI", 6: "SP", 7: "BI"}  # FFmpeg's AVPictureType

os.environ.setdefault("SVT_LOG", "1")  # SVT-AV1 prints its configuration to stderr unless told otherwise


def padded_packet(data: bytes) -> av.Packet:
    """An av.Packet holding a copy of `data` in FFmpeg's own allocation, which ends in the zeroed padding that
    FFmpeg's bitstream readers may read past the end (AV_INPUT_BUFFER_PADDING_SIZE). av.Packet(bytes) wraps the
    Python bytes without that padding: the MPEG-4 decoder then reads whatever memory follows, and decoded the
    same VOP differently from run to run (flagged corrupt, drifting until the next keyframe)."""
    packet = av.Packet(len(data))
    memoryview(packet)[:] = data
    return packet


@dataclass
class CodedVideo:
    """One encoded and decoded sequence."""

    codec: str
    q: int
    fps: float
    data: bytes
    decoded: np.ndarray                      # (T, H, W, 3) uint8 RGB
    picture_types: list[str] = field(default_factory=list)

    @property
    def bits(self) -> int:
        return 8 * len(self.data)


def _check(frames: np.ndarray, codec: str, q: int, fps: float) -> np.ndarray:
    frames = np.asarray(frames)
    if codec not in CODECS:
        raise SigncastError(f"unknown codec {codec!r}; choose from {', '.join(CODECS)}")
    low, high = CODECS[codec][1]
    if not low <= q <= high:
        raise SigncastError(f"{codec} quantiser must be {low}..{high}, got {q}")
    if frames.ndim != 4 or frames.shape[-1] != 3 or frames.dtype != np.uint8 or len(frames) == 0:
        raise SigncastError(f"frames must be (T, H, W, 3) uint8 with T >= 1, got {frames.shape} {frames.dtype}")
    if frames.shape[1] % 2 or frames.shape[2] % 2:
        raise SigncastError(f"frame size {frames.shape[2]}x{frames.shape[1]} must be even for 4:2:0 coding")
    if fps <= 0:
        raise SigncastError(f"frame rate must be positive, got {fps}")
    return frames


def encode_video(frames: np.ndarray, fps: float, codec: str = "mpeg4", q: int = 12) -> bytes:
    """Encode frames (T, H, W, 3) uint8 RGB at a fixed quantiser; returns the elementary stream."""
    frames = _check(frames, codec, q, fps)
    fmt = CODECS[codec][0]
    buffer = io.BytesIO()
    rate = Fraction(fps).limit_denominator(1001)
    with av.open(buffer, mode="w", format=fmt) as container:
        stream = container.add_stream(codec, rate=rate)
        stream.width, stream.height = frames.shape[2], frames.shape[1]
        stream.pix_fmt = "yuv420p"
        context = stream.codec_context
        context.gop_size = GOP
        if codec == "mpeg4":
            context.qmin = context.qmax = q
            context.max_b_frames = B_FRAMES
        elif codec == "libx264":
            stream.options = {"qp": str(q), "bf": str(B_FRAMES), "keyint_min": str(GOP), "sc_threshold": "0"}
        else:
            stream.options = {"qp": str(q), "preset": "8"}
        for index, image in enumerate(frames):
            frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(image), format="rgb24")
            frame.pts = index
            for packet in stream.encode(frame):
                container.mux(packet)
        for packet in stream.encode():
            container.mux(packet)
    return buffer.getvalue()


def decode_video(data: bytes, codec: str) -> tuple[np.ndarray, list[str]]:
    """Decode an elementary stream from encode_video: (frames (T, H, W, 3) uint8 RGB, picture types 'I'/'P'/'B')."""
    if codec not in CODECS:
        raise SigncastError(f"unknown codec {codec!r}; choose from {', '.join(CODECS)}")
    frames, types = [], []
    try:
        with av.open(io.BytesIO(data), format=CODECS[codec][0]) as container:
            for frame in container.decode(video=0):
                frames.append(frame.to_ndarray(format="rgb24"))
                types.append(_PICTURE_TYPES.get(int(frame.pict_type), "?"))
    except av.error.FFmpegError as error:
        raise SigncastError(f"cannot decode {codec} stream: {error}") from None
    if not frames:
        raise SigncastError(f"{codec} stream decodes to no frames")
    return np.stack(frames), types


def _pad_to(frames: np.ndarray, height: int, width: int) -> np.ndarray:
    pad_y, pad_x = max(0, height - frames.shape[1]), max(0, width - frames.shape[2])
    if not pad_y and not pad_x:
        return frames
    return np.pad(frames, ((0, 0), (0, pad_y), (0, pad_x), (0, 0)), mode="edge")


def code_video(frames: np.ndarray, fps: float, codec: str = "mpeg4", q: int = 12) -> CodedVideo:
    """Encode and decode; the decoded frames (T, H, W, 3) match the input's shape."""
    frames = _check(frames, codec, q, fps)
    height, width = frames.shape[1:3]
    source = _pad_to(frames, _AV1_MIN_SIZE, _AV1_MIN_SIZE) if codec == "libsvtav1" else frames
    data = encode_video(source, fps, codec, q)
    decoded, types = decode_video(data, codec)
    if len(decoded) != len(frames):
        raise SigncastError(f"{codec} decoded {len(decoded)} frames from {len(frames)}")
    return CodedVideo(codec, q, fps, data, np.ascontiguousarray(decoded[:, :height, :width]), types)


def kept_frame_indices(n_frames: int, source_fps: float, target_fps: float) -> np.ndarray:
    """Indices of the frames kept when a clip at source_fps is sent at target_fps with the same duration."""
    if not 0 < target_fps <= source_fps:
        raise SigncastError(f"target frame rate must be in (0, {source_fps:g}], got {target_fps:g}")
    return frame_indices_at_rate(np.arange(n_frames) / source_fps, n_frames / source_fps, target_fps)


def half_resolution(frames: np.ndarray, labels: np.ndarray | None = None):
    """Halve width and height (rounded down to even): frames by area averaging, labels by nearest neighbour.

    Returns frames (T, H/2, W/2, 3), or (frames, labels) when labels (T, H, W) are given.
    """
    frames = np.asarray(frames)
    width = (frames.shape[2] // 2) & ~1
    height = (frames.shape[1] // 2) & ~1
    small = np.stack([cv2.resize(f, (width, height), interpolation=cv2.INTER_AREA) for f in frames])
    if labels is None:
        return small
    small_labels = np.stack([cv2.resize(l, (width, height), interpolation=cv2.INTER_NEAREST) for l in labels])
    return small, small_labels


def match_quality(encode_at, q_range: tuple[int, int], target: float) -> tuple[int, object, float]:
    """The cheapest quantiser whose quality reaches target, by bisection (quality falls as q grows).

    encode_at(q) -> (result, quality). Returns (q, result, quality); when even the finest q misses the
    target, the finest q is returned.
    """
    low, high = q_range
    best = None
    while low <= high:
        middle = (low + high) // 2
        result, quality = encode_at(middle)
        if quality >= target:
            best = (middle, result, quality)
            low = middle + 1
        else:
            high = middle - 1
    if best is None:
        result, quality = encode_at(q_range[0])
        best = (q_range[0], result, quality)
    return best

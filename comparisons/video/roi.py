"""NSV-ROI: region-of-interest coding, today's counterpart of the object solutions (issue 39 §3).

One H.264 stream (libx264, CRF mode) whose quantiser is lower on the signer's face and hands and higher
elsewhere. No shape is sent: the regions only steer the encoder, and any H.264 decoder plays the stream.

How the regions reach x264 through PyAV: PyAV does not expose x264's per-macroblock quantiser offsets
(x264_picture_t.prop.quant_offsets), but libavcodec's libx264 wrapper reads a frame's
AV_FRAME_DATA_REGIONS_OF_INTEREST side data into them, and FFmpeg's `addroi` filter adds that side data. So
each frame is pushed through a small filter graph (buffer -> addroi (face) -> addroi (hand) ... -> addroi (whole
frame, the positive offset for the rest) -> buffersink) and the frame that the sink gives back, side data and
all, goes straight to the encoder (a frame that PyAV must reformat first would lose it: the frames are made
yuv420p before the graph). A filter instance holds one fixed rectangle, so a graph is built per distinct set of
boxes: per frame (boxes="frame", the default: the boxes follow the face and hands every frame; building a graph
costs well under a millisecond) or per GOP (boxes="gop": the union box of each part over the GOP).

The wrapper's rules (libavcodec/libx264.c): ROI is ignored at constant QP and without adaptive quantisation, so
this codes in CRF mode with x264's default AQ; the first region in the side data wins where regions overlap
(the wrapper writes them last to first), hence the face and hands come before the whole-frame region; a
region's qoffset in -1..1 is scaled by x264's QP range (52 for 8-bit video) into a QP offset per macroblock.
`addroi` takes x, y, w, h (pixels, expressions allowed) and qoffset in -1..1; the boxes here are aligned to
the 16x16 macroblocks.

SVT-AV1 (libsvtav1) through PyAV: see `svtav1_roi_reaches_encoder` below and docs/comparison.md ("NSV-ROI").

Pure: frames and labels in, bytes and decoded frames out; nothing is written to files.
"""
from __future__ import annotations

import io
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from media.domain import HEAD, LEFT_HAND, RIGHT_HAND
from media.errors import SigncastError

__all__ = ["ROI_CODECS", "ROI_PARTS", "RoiCoded", "RoiSettings", "decode", "encode_plain", "encode_roi",
           "region_psnr", "roi_boxes"]

ROI_CODECS = ("libx264",)
ROI_PARTS = (HEAD, LEFT_HAND, RIGHT_HAND)      # media.segmentation_landmarks labels 2, 3, 4
MB = 16                                        # H.264 macroblock side, pixels
CRF_RANGE = (0, 51)


@dataclass(frozen=True)
class RoiSettings:
    """crf: x264's constant rate factor (the quality of the frame outside any region); skin_offset and rest_offset:
    `addroi` qoffsets (-1..1, x 52 = QP offset) of the face / hand boxes and of the rest of the frame; margin:
    pixels added around each part's box before it is aligned outward to the macroblocks; boxes: "frame" (a
    graph per frame) or "gop" (the union box per GOP); gop: keyframe interval, frames; preset: x264's."""

    crf: int = 28
    skin_offset: float = -0.12
    rest_offset: float = 0.12
    margin: int = 4
    boxes: str = "frame"
    gop: int = 12
    preset: str = "medium"

    def __post_init__(self):
        if not CRF_RANGE[0] <= self.crf <= CRF_RANGE[1]:
            raise SigncastError(f"CRF {self.crf} outside {CRF_RANGE[0]}..{CRF_RANGE[1]}")
        for name in ("skin_offset", "rest_offset"):
            if not -1.0 <= getattr(self, name) <= 1.0:
                raise SigncastError(f"{name} {getattr(self, name)} outside -1..1 (addroi's qoffset)")
        if self.boxes not in ("frame", "gop"):
            raise SigncastError(f"ROI boxes must be 'frame' or 'gop', not {self.boxes!r}")
        if self.gop < 1 or self.margin < 0:
            raise SigncastError(f"ROI GOP {self.gop} must be >= 1 and margin {self.margin} >= 0")


@dataclass(frozen=True)
class RoiCoded:
    """One coded stream: Annex-B H.264 bytes, its decoded frames (T, H, W, 3) uint8 RGB, the boxes it was coded
    with (per frame, (x, y, w, h) each; empty for a plain stream) and the number of filter graphs built."""

    data: bytes
    picture: np.ndarray
    boxes: tuple[tuple[tuple[int, int, int, int], ...], ...]
    graphs: int

    @property
    def bits(self) -> int:
        return 8 * len(self.data)


def _aligned_box(mask: np.ndarray, margin: int, height: int, width: int) -> tuple[int, int, int, int] | None:
    """(x, y, w, h) of the mask's pixels grown by margin, aligned outward to macroblocks; None when empty."""
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    if rows.size == 0:
        return None
    y0 = max(0, (int(rows[0]) - margin) // MB * MB)
    x0 = max(0, (int(cols[0]) - margin) // MB * MB)
    y1 = min(height, -(-(int(rows[-1]) + 1 + margin) // MB) * MB)
    x1 = min(width, -(-(int(cols[-1]) + 1 + margin) // MB) * MB)
    return x0, y0, x1 - x0, y1 - y0


def roi_boxes(labels: np.ndarray, settings: RoiSettings = RoiSettings()) -> tuple[tuple[tuple[int, int, int, int], ...], ...]:
    """Per frame, the boxes (x, y, w, h) of the face and each hand present (labels (T, H, W) uint8 as
    media.segmentation_landmarks: 2 head, 3 left hand, 4 right hand), per frame or as each part's union over
    its GOP (settings.boxes)."""
    labels = np.asarray(labels)
    if labels.ndim != 3:
        raise SigncastError(f"ROI labels must be (T, H, W), got {labels.shape}")
    frames, height, width = labels.shape
    out = []
    for t in range(frames):
        if settings.boxes == "gop":
            start = t // settings.gop * settings.gop
            window = labels[start:start + settings.gop]
        else:
            window = labels[t:t + 1]
        boxes = []
        for part in ROI_PARTS:
            box = _aligned_box((window == part).any(axis=0), settings.margin, height, width)
            if box is not None:
                boxes.append(box)
        out.append(tuple(boxes))
    return tuple(out)


def _time_base(fps: float) -> Fraction:
    if not fps > 0:
        raise SigncastError(f"frame rate must be positive, got {fps}")
    return 1 / Fraction(fps).limit_denominator(1001)


def _graph(width: int, height: int, time_base: Fraction, boxes, settings: RoiSettings):
    """buffer -> addroi per box (skin_offset) -> addroi whole frame (rest_offset) -> buffersink, configured."""
    import av

    graph = av.filter.Graph()
    node = graph.add_buffer(width=width, height=height, format="yuv420p", time_base=time_base)
    regions = [(box, settings.skin_offset) for box in boxes]
    if settings.rest_offset:
        regions.append(((0, 0, width, height), settings.rest_offset))
    for (x, y, w, h), offset in regions:
        roi = graph.add("addroi", f"x={x}:y={y}:w={w}:h={h}:qoffset={offset:.6f}:clear=0")
        node.link_to(roi)
        node = roi
    sink = graph.add("buffersink")
    node.link_to(sink)
    graph.configure()
    return graph


def _check_frames(frames: np.ndarray) -> np.ndarray:
    frames = np.asarray(frames)
    if frames.ndim != 4 or frames.shape[-1] != 3 or frames.dtype != np.uint8 or len(frames) < 1:
        raise SigncastError(f"ROI frames must be (T, H, W, 3) uint8, got {frames.shape} {frames.dtype}")
    if frames.shape[1] % 2 or frames.shape[2] % 2:
        raise SigncastError(f"H.264 4:2:0 needs even frame sides, got {frames.shape[2]}x{frames.shape[1]}")
    return frames


def _encode(frames: np.ndarray, fps: float, settings: RoiSettings, boxes, codec: str = "libx264") -> RoiCoded:
    import av

    if codec not in ROI_CODECS:
        raise SigncastError(f"ROI coding is reached through {', '.join(ROI_CODECS)}, not {codec!r}")
    frames = _check_frames(frames)
    _, height, width, _ = frames.shape
    time_base = _time_base(fps)
    buffer = io.BytesIO()
    container = av.open(buffer, "w", format="h264")
    stream = container.add_stream(codec, rate=Fraction(fps).limit_denominator(1001))
    stream.width, stream.height, stream.pix_fmt = width, height, "yuv420p"
    stream.codec_context.time_base = time_base
    stream.options = {"crf": str(settings.crf), "preset": settings.preset, "g": str(settings.gop),
                      "keyint_min": str(settings.gop), "sc_threshold": "0", "threads": "1"}
    graph, graph_boxes, graphs = None, None, 0
    for t, rgb in enumerate(frames):
        frame = av.VideoFrame.from_ndarray(rgb, format="rgb24").reformat(format="yuv420p")
        frame.pts, frame.time_base = t, time_base
        if boxes is not None:
            if graph is None or boxes[t] != graph_boxes:
                graph, graph_boxes = _graph(width, height, time_base, boxes[t], settings), boxes[t]
                graphs += 1
            graph.push(frame)
            frame = graph.pull()       # the same picture, now with REGIONS_OF_INTEREST side data
        for packet in stream.encode(frame):
            container.mux(packet)
    for packet in stream.encode():
        container.mux(packet)
    container.close()
    data = buffer.getvalue()
    return RoiCoded(data, decode(data, len(frames)), tuple(boxes) if boxes is not None else (), graphs)


def encode_roi(frames: np.ndarray, labels: np.ndarray, fps: float, settings: RoiSettings = RoiSettings(),
               codec: str = "libx264") -> RoiCoded:
    """frames (T, H, W, 3) uint8 RGB and their part labels (T, H, W) -> one ROI-coded H.264 stream."""
    frames = _check_frames(frames)
    labels = np.asarray(labels)
    if labels.shape != frames.shape[:3]:
        raise SigncastError(f"labels {labels.shape} do not match frames {frames.shape[:3]}")
    return _encode(frames, fps, settings, roi_boxes(labels, settings), codec)


def encode_plain(frames: np.ndarray, fps: float, crf: int = RoiSettings.crf, gop: int = RoiSettings.gop,
                 preset: str = RoiSettings.preset, codec: str = "libx264") -> RoiCoded:
    """The same encoder and settings without regions: plain x264 at this CRF (the ROI stream's baseline)."""
    return _encode(frames, fps, RoiSettings(crf=crf, gop=gop, preset=preset), None, codec)


def decode(data: bytes, frames: int | None = None) -> np.ndarray:
    """An Annex-B H.264 stream -> (T, H, W, 3) uint8 RGB by plain PyAV (av.open on the bytes)."""
    import av

    try:
        with av.open(io.BytesIO(bytes(data)), format="h264") as container:
            pictures = [f.to_ndarray(format="rgb24") for f in container.decode(video=0)]
    except av.FFmpegError as exc:
        raise SigncastError(f"cannot decode the ROI stream: {exc}") from None
    if not pictures or (frames is not None and len(pictures) != frames):
        raise SigncastError(f"the ROI stream decodes to {len(pictures)} frames, expected {frames}")
    return np.stack(pictures)


def region_psnr(reference: np.ndarray, picture: np.ndarray, mask: np.ndarray) -> float:
    """PSNR (dB) of the luma inside mask (T, H, W) bool."""
    from comparisons.video.quality import psnr

    return psnr(reference, picture, mask)


def svtav1_roi_reaches_encoder(frames: np.ndarray, labels: np.ndarray, fps: float, crf: int = 40) -> dict:
    """Whether libsvtav1 through PyAV acts on addroi's side data: bytes and skin PSNR with and without the
    regions at the same CRF (equal bytes and pictures: it ignores them)."""
    import av

    frames = _check_frames(frames)
    _, height, width, _ = frames.shape
    time_base = _time_base(fps)
    boxes = roi_boxes(labels, RoiSettings())
    settings = RoiSettings(skin_offset=-0.5, rest_offset=0.5)
    out = {}
    for use_roi in (False, True):
        buffer = io.BytesIO()
        container = av.open(buffer, "w", format="ivf")
        stream = container.add_stream("libsvtav1", rate=Fraction(fps).limit_denominator(1001))
        stream.width, stream.height, stream.pix_fmt = width, height, "yuv420p"
        stream.options = {"crf": str(crf), "preset": "10"}
        for t, rgb in enumerate(frames):
            frame = av.VideoFrame.from_ndarray(rgb, format="rgb24").reformat(format="yuv420p")
            frame.pts, frame.time_base = t, time_base
            if use_roi:
                graph = _graph(width, height, time_base, boxes[t], settings)
                graph.push(frame)
                frame = graph.pull()
            for packet in stream.encode(frame):
                container.mux(packet)
        for packet in stream.encode():
            container.mux(packet)
        container.close()
        with av.open(io.BytesIO(buffer.getvalue())) as reader:
            picture = np.stack([f.to_ndarray(format="rgb24") for f in reader.decode(video=0)])
        skin = np.isin(labels, ROI_PARTS)
        out["roi" if use_roi else "plain"] = {"bytes": len(buffer.getvalue()),
                                              "skin_psnr": region_psnr(frames, picture, skin)}
    out["reaches_encoder"] = out["roi"]["bytes"] != out["plain"]["bytes"]
    return out

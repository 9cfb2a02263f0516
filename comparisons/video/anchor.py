"""The human anchor: a clip coded at a viewer-judged operating point, to set the threshold people set.

Tran et al. (ASSETS 2013; TACCESS 2015) found ASL video at 320x240, 10 fps and 60 kbit/s (H.264) intelligible to
signers; EN 301 549 §6.5 calls QCIF at 12 fps usable with restrictions. `code_at_rate` codes frames as a viewer at
such a point would receive them: scaled to fit the size (aspect kept, even), the frames on screen at the frame
rate kept (held until the next), H.264 at a target bit rate (one-pass ABR with a VBV of two seconds' bits), decoded
and scaled back to the frames' own size (the display shows it at the size of the other solutions, so that the same
extractor reads it on the same pixel grid as the reference).
"""
from __future__ import annotations

import io
from dataclasses import dataclass
from fractions import Fraction

import av
import cv2
import numpy as np

from media.errors import SigncastError


@dataclass
class AnchorCoding:
    """decoded: (K, H, W, 3) uint8 at the frames' own size (the K sent frames); bits: the stream's size; size: (width,
    height) coded; kept: (K,) indices of the sent frames."""
    decoded: np.ndarray
    bits: int
    size: tuple[int, int]
    kept: np.ndarray


def fit_even(width: int, height: int, box: tuple[int, int]) -> tuple[int, int]:
    """(width, height) scaled to fit box (aspect kept, never enlarged), each rounded down to even."""
    scale = min(1.0, box[0] / width, box[1] / height)
    return max(2, int(width * scale) // 2 * 2), max(2, int(height * scale) // 2 * 2)


def code_at_rate(frames: np.ndarray, kept: np.ndarray, fps: float, kbps: float, box: tuple[int, int],
                 codec: str = "libx264") -> AnchorCoding:
    """Code frames[kept] ((T, H, W, 3) uint8; kept (K,) indices, sent at fps) scaled to fit box, at a target of kbps
    kbit/s; decode and scale back to (W, H)."""
    frames = np.asarray(frames)
    height, width = frames.shape[1:3]
    coded_w, coded_h = fit_even(width, height, box)
    sent = [cv2.resize(frames[i], (coded_w, coded_h), interpolation=cv2.INTER_AREA) for i in kept]
    buffer = io.BytesIO()
    bits_per_s = int(round(kbps * 1000))
    with av.open(buffer, mode="w", format="h264") as container:
        stream = container.add_stream(codec, rate=Fraction(fps).limit_denominator(1001))
        stream.width, stream.height, stream.pix_fmt = coded_w, coded_h, "yuv420p"
        stream.bit_rate = bits_per_s
        stream.codec_context.gop_size = max(1, int(round(fps)))
        # reproducible bytes: on several threads x264's rate control (ABR with a VBV) codes the same frames to a
        # different size from one call to the next (14.6-15.0 kB on 22 carphone frames), which moved the human anchor's
        # threshold between runs; the VBV is set through FFmpeg's own maxrate/bufsize (given only in x264-params,
        # FFmpeg's wrapper finds them differ from its own and reconfigures x264 as it goes, with the same effect)
        stream.options = {"preset": "medium", "bf": "2", "threads": "1",
                          "maxrate": str(bits_per_s), "bufsize": str(2 * bits_per_s)}
        for index, image in enumerate(sent):
            # converted here, not inside encode: PyAV's implicit conversion there made the sizes vary between calls
            frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(image), format="rgb24").reformat(format="yuv420p")
            frame.pts = index
            for packet in stream.encode(frame):
                container.mux(packet)
        for packet in stream.encode():
            container.mux(packet)
    data = buffer.getvalue()
    decoded = []
    with av.open(io.BytesIO(data), format="h264") as container:
        for frame in container.decode(video=0):
            decoded.append(cv2.resize(frame.to_ndarray(format="rgb24"), (width, height),
                                      interpolation=cv2.INTER_LINEAR))
    if len(decoded) != len(kept):
        raise SigncastError(f"the anchor's {codec} stream decoded {len(decoded)} frames from {len(kept)}")
    return AnchorCoding(np.stack(decoded), 8 * len(data), (coded_w, coded_h), np.asarray(kept))

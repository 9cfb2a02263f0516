"""Live video: encode one frame at a time as it is captured, decode packet by packet with losses concealed.

Encoder (LiveEncoder) — a PyAV `CodecContext` opened without a container, configured like
comparisons/video/codecs.py for the same codec and Q (replicated here, not shared: a fixed quantiser
qmin = qmax = Q for "mpeg4", constant QP for "libx264", GOP `gop`), with live choices (chosen here):
- no B-frames by default (b_frames=0), so a packet leaves for every frame that comes in;
- libx264 `tune=zerolatency` (no lookahead, no frame threads: sliced threads instead);
- no global header (FFmpeg's AV_CODEC_FLAG_GLOBAL_HEADER stays off), so the configuration travels in-band:
  FFmpeg's MPEG-4 Part 2 encoder writes the visual object sequence and VOL headers (ISO/IEC 14496-2 §6.2.2,
  start codes 0x000001B0 / 0x00000120) before every I-VOP, and libx264 sets `b_repeat_headers` and writes
  SPS and PPS (ITU-T H.264 §7.3.2.1-2) before every IDR picture in Annex B byte-stream form. Every keyframe
  packet therefore starts a decodable stream on its own (tested).
Options that FFmpeg did not consume are left in `CodecContext.options` after open; both ends check that it
is empty, so a misspelled option fails loudly instead of being ignored.

Measured encoder delay (frames in minus packets out, 64x48, PyAV 18.1 / FFmpeg 8 / x264): mpeg4 b_frames=0: 0;
mpeg4 b_frames=2: 2 (two B-frames wait for the P-frame after them); libx264 zerolatency b_frames=0: 0,
b_frames=2: 2; libx264 without zerolatency, b_frames=0: 1, b_frames=2: 3.

Decoder (LiveDecoder) — FFmpeg's error resilience is turned on through codec options that FFmpeg 8
accepts (checked: a bad value fails avcodec_open2, an unknown name is left over): `ec=guess_mvs+deblock+
favor_inter` (motion-vector guessing and deblocking of concealed macroblocks), `err_detect=ignore_err`
(keep decoding past errors), `flags=+output_corrupt` (return pictures that needed concealment) and
`max_pixels` (bounds what damaged headers can make FFmpeg allocate). One thread, slice threading only, so
no frame is held back by threads. Concealment policy (chosen here), per frame index:
- "ok": decoded cleanly from an intact reference chain;
- "damaged": FFmpeg flagged the picture corrupt, or it is predicted from a reference chain broken by a lost,
  damaged or undecodable packet since the last clean keyframe (drift): returned, but counted (conservative:
  the receiver cannot tell whether a lost packet was a reference, so a lost B-frame counts too);
- "concealed": no picture came out for the index (packet lost, or FFmpeg could not decode it, or the H.264
  decoder withholds pictures until it recovers): the last shown picture is held; before any picture was
  shown, mid-grey.
A packet whose decoding raises any av error counts as a decode error; the decoder never raises on bytes.
FFmpeg cannot see all damage: flipped bytes inside an H.264 CABAC slice usually decode "cleanly" to garbage
(8 bytes XORed mid-packet in a 64x48 P-frame: no error, no corrupt flag, 17 dB instead of 27 dB; MPEG-4
Part 2 flags the same damage). A transport that knows a payload failed its checksum but delivers it anyway
says so with `decode(..., damaged=True)`, and the picture and its successors count as damaged.
Pictures are converted to RGB at the negotiated size (width, height), whatever a damaged header says.
"""
from __future__ import annotations

import bisect
from dataclasses import dataclass
from fractions import Fraction
from typing import NamedTuple

import av
import numpy as np

from comparisons.video.codecs import CODECS, padded_packet
from media.errors import SigncastError

LIVE_CODECS = ("mpeg4", "libx264")
_DECODERS = {"mpeg4": "mpeg4", "libx264": "h264"}
_MAX_REORDER = 16           # frames; bounds the decoder's reorder window whatever a damaged stream claims
_GREY = 128


class EncodedPacket(NamedTuple):
    """One access unit: the frame index it shows (its pts), its bytes, and whether it is a keyframe."""

    index: int
    data: bytes
    keyframe: bool


def _rate(fps: float) -> Fraction:
    if not fps > 0:
        raise SigncastError(f"frame rate must be positive, got {fps}")
    return Fraction(fps).limit_denominator(1001)


def _check_open(context: av.CodecContext, what: str) -> None:
    """Open the context; SigncastError if FFmpeg rejects or leaves over an option."""
    try:
        context.open()
    except av.error.FFmpegError as error:
        raise SigncastError(f"cannot open {what}: {error}") from None
    if context.options:
        raise SigncastError(f"{what} ignored options {sorted(context.options)}")


class LiveEncoder:
    """Encodes RGB frames (H, W, 3) uint8 one at a time; returns the packets the encoder emits now.

    codec: "mpeg4" (fixed quantiser q in 1..31) or "libx264" (constant QP q in 0..51); width, height: even
    pixels; fps: capture rate; gop: frames between keyframes; b_frames: B-frames between references (0 for
    live: each B-frame delays the stream); low_delay: libx264 tune=zerolatency.
    """

    def __init__(self, codec: str, width: int, height: int, fps: float, q: int, gop: int = 12, b_frames: int = 0,
                 low_delay: bool = True):
        if codec not in LIVE_CODECS:
            raise SigncastError(f"unknown live codec {codec!r}; choose from {', '.join(LIVE_CODECS)}")
        low, high = CODECS[codec][1]
        if not low <= q <= high:
            raise SigncastError(f"{codec} quantiser must be {low}..{high}, got {q}")
        if width < 2 or height < 2 or width % 2 or height % 2:
            raise SigncastError(f"frame size {width}x{height} must be even and at least 2x2 for 4:2:0 coding")
        if not 1 <= gop <= 600:
            raise SigncastError(f"GOP must be 1..600 frames, got {gop}")
        if not 0 <= b_frames <= 4:
            raise SigncastError(f"B-frames must be 0..4, got {b_frames}")
        rate = _rate(fps)
        self.codec, self.width, self.height = codec, width, height
        context = av.CodecContext.create(codec, "w")
        context.width, context.height, context.pix_fmt = width, height, "yuv420p"
        context.time_base, context.framerate = 1 / rate, rate
        context.gop_size = gop
        if codec == "mpeg4":
            context.qmin = context.qmax = q
            context.max_b_frames = b_frames
        else:
            options = {"qp": str(q), "bf": str(b_frames), "keyint_min": str(gop), "sc_threshold": "0"}
            if low_delay:
                options["tune"] = "zerolatency"
            context.options = options
        _check_open(context, f"{codec} encoder")
        self._context = context
        self._last_index = -1
        self.frames_in = self.packets_out = 0
        self.max_delay = 0          # most frames in that had no packet out yet, after any encode call

    def _packets(self, packets) -> list[EncodedPacket]:
        out = [EncodedPacket(int(p.pts), bytes(p), bool(p.is_keyframe)) for p in packets]
        self.packets_out += len(out)
        return out

    def encode(self, frame_rgb: np.ndarray, index: int) -> list[EncodedPacket]:
        """Encode frame (H, W, 3) uint8 RGB shown at frame index `index` (strictly increasing)."""
        frame_rgb = np.asarray(frame_rgb)
        if frame_rgb.shape != (self.height, self.width, 3) or frame_rgb.dtype != np.uint8:
            raise SigncastError(f"live frame must be ({self.height}, {self.width}, 3) uint8, "
                                f"got {frame_rgb.shape} {frame_rgb.dtype}")
        if index <= self._last_index:
            raise SigncastError(f"frame index {index} does not follow {self._last_index}")
        self._last_index = index
        frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(frame_rgb), format="rgb24").reformat(format="yuv420p")
        frame.pts = index
        out = self._packets(self._context.encode(frame))
        self.frames_in += 1
        self.max_delay = max(self.max_delay, self.frames_in - self.packets_out)
        return out

    def flush(self) -> list[EncodedPacket]:
        """The packets still held by the encoder (end of stream)."""
        return self._packets(self._context.encode(None))


@dataclass
class LiveDecoderStats:
    """Counts over all frame indices the decoder has returned."""

    decoded: int = 0        # pictures that came out of FFmpeg and were shown ("ok" or "damaged")
    damaged: int = 0        # of those, flagged corrupt or drifting from a broken reference chain
    concealed: int = 0      # indices with no picture: the last shown one was held
    errors: int = 0         # packets on which FFmpeg raised an error
    lost: int = 0           # indices announced lost (packet None)
    late: int = 0           # packets for an index already shown or concealed: dropped


class LiveDecoder:
    """Decodes a live elementary stream packet by packet, concealing what is lost or damaged.

    codec: "mpeg4" or "libx264" (the encoder's name); width, height: the negotiated picture size in pixels
    (every returned picture is (height, width, 3) uint8 RGB, also those held before any picture arrived).
    """

    def __init__(self, codec: str, width: int, height: int):
        if codec not in _DECODERS:
            raise SigncastError(f"unknown live codec {codec!r}; choose from {', '.join(LIVE_CODECS)}")
        if not (2 <= width <= 8192 and 2 <= height <= 8192):
            raise SigncastError(f"picture size {width}x{height} outside 2..8192 pixels a side")
        self.codec, self.width, self.height = codec, width, height
        self.stats = LiveDecoderStats()
        self.last_status: list[str] = []      # "ok" / "damaged" / "concealed" per frame of the last return
        self._pending: list[int] = []         # indices fed to FFmpeg, not yet shown (sorted)
        self._shown = -1                      # the last index returned
        self._held = np.full((height, width, 3), _GREY, np.uint8)
        self._drift = False                   # a reference was lost or damaged since the last clean keyframe
        self._suspect = -1                    # the last index whose packet the transport flagged as damaged
        self._context = self._open()

    def _open(self) -> av.CodecContext:
        context = av.CodecContext.create(_DECODERS[self.codec], "r")
        context.thread_type, context.thread_count = "SLICE", 1
        context.options = {"ec": "guess_mvs+deblock+favor_inter", "err_detect": "ignore_err",
                           "flags": "+output_corrupt",
                           "max_pixels": str(max(4 * self.width * self.height, 1 << 16))}
        _check_open(context, f"{self.codec} decoder")
        return context

    def _reorder_depth(self) -> int:
        try:
            depth = int(self._context.reorder_depth)     # FFmpeg's has_b_frames (PyAV's has_b_frames is a bool)
        except (av.error.FFmpegError, ValueError, TypeError):
            depth = 0
        return min(max(depth, 0), _MAX_REORDER)

    def _emit(self, out: list, index: int, image: np.ndarray | None, damaged: bool) -> None:
        if image is None:
            status = "concealed"
            self.stats.concealed += 1
        else:
            status = "damaged" if damaged else "ok"
            self.stats.decoded += 1
            self.stats.damaged += damaged
            self._held = image
        out.append((index, self._held))
        self.last_status.append(status)
        self._shown = index

    def _take(self, frames, out: list) -> None:
        """Show decoded pictures in display order, holding the last picture over the indices they skip."""
        for frame in frames:
            try:
                image = frame.to_ndarray(width=self.width, height=self.height, format="rgb24")
                corrupt = bool(frame.is_corrupt) or (frame.width, frame.height) != (self.width, self.height)
                keyframe = bool(frame.key_frame)
            except (av.error.FFmpegError, ValueError, TypeError):
                self._drift = True
                continue
            index = frame.pts if frame.pts is not None else (self._pending[0] if self._pending else None)
            if index is None or index not in self._pending:
                continue                      # a picture for an index already concealed: too late to show
            while self._pending and self._pending[0] < index:
                self._emit(out, self._pending.pop(0), None, False)
            self._pending.remove(index)
            corrupt = corrupt or index == self._suspect
            if keyframe and not corrupt:
                self._drift = False
            elif corrupt:
                self._drift = True
            self._emit(out, index, np.ascontiguousarray(image), self._drift or corrupt)

    def _conceal_beyond(self, depth: int, out: list) -> None:
        while len(self._pending) > depth:
            self._emit(out, self._pending.pop(0), None, False)

    def decode(self, packet: bytes | None, index: int, damaged: bool = False) -> list[tuple[int, np.ndarray]]:
        """Feed the access unit of frame `index` (None: it was lost; damaged: the transport knows its bytes are
        damaged); returns the (index, (H, W, 3) uint8 RGB) pictures now due, in display order. Never raises on
        any bytes."""
        self.last_status = []
        out: list[tuple[int, np.ndarray]] = []
        index = int(index)
        if index <= self._shown or index in self._pending:
            self.stats.late += 1
            return out
        bisect.insort(self._pending, index)
        if packet is not None and len(packet) == 0:
            packet = None                     # an empty packet would tell FFmpeg to drain: treat it as lost
        if packet is None:
            self.stats.lost += 1
            self._drift = True
        else:
            if damaged:
                self._suspect = index
            av_packet = padded_packet(packet)
            av_packet.pts = av_packet.dts = index
            try:
                frames = self._context.decode(av_packet)
            except av.error.FFmpegError:
                self.stats.errors += 1
                self._drift = True
                frames = []
            self._take(frames, out)
        self._conceal_beyond(self._reorder_depth(), out)
        return out

    def flush(self) -> list[tuple[int, np.ndarray]]:
        """End of stream: the pictures FFmpeg still holds, then the held picture for any index still due.
        The decoder is ready for a new stream afterwards."""
        self.last_status = []
        out: list[tuple[int, np.ndarray]] = []
        try:
            frames = self._context.decode(None)
        except av.error.FFmpegError:
            self.stats.errors += 1
            frames = []
        self._take(frames, out)
        self._conceal_beyond(0, out)
        self._context = self._open()
        return out

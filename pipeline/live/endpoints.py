"""What each solution's sender and receiver do with frames, per capture instant (pipeline/live/session.py calls
them).

Senders ("sources"): capture(i) is called at frame i's capture time and returns the AccessUnits ready then;
finish() returns what is left after the last frame.
- NSV (VideoSource): the frame is encoded at once by a live PyAV encoder (comparisons.transport.video.LiveEncoder,
  no B-frames: each would delay every frame by one frame interval) and its packet sent as one access unit.
- FBA / BBA (ParameterSource): frames are gathered into refresh periods; when a period's last frame is captured,
  the period is coded by the parameter codec as one self-contained stream (intra first) and sent as one unit
  (comparisons.transport.fba_units: start code, frame numbers, CRC-8, the stream with its own checks). A unit decodes alone,
  so a lost one costs exactly its frames; the price is look-ahead: a period's first frame waits refresh - 1
  frame intervals before it can be sent.

Receivers ("sinks"): receive(frame, depacketized) is called as the jitter buffer releases each capture instant's
data and returns the indices of the frames now ready to show; finish() returns (shown (T, H, W, 3) uint8,
received (T,) bool), every frame that never arrived concealed by holding the last shown one (the first shown,
before any arrived).
- NSV: a live PyAV decoder with FFmpeg's error concealment (comparisons.transport.video.LiveDecoder); access units
  lost entirely are announced to it, partial ones are decoded as they are.
- FBA / BBA: units are found by a resynchronising scanner, decoded, and rendered by the terminal's renderer.
The video-object solutions (NSV2O, NSV3O, NSV3O+C, SSV) have their own source and sink: pipeline/live/objects.py,
which this module imports (objects imports only pipeline.live.session, so the two do not import each other).
"""
from __future__ import annotations

import numpy as np

from comparisons.params import bba as bba_codec
from comparisons.transport import fba_units
from comparisons.params import codecs as param_codecs
from comparisons.params.bits import START_CODE_PREFIX
from comparisons.transport.video import LiveDecoder, LiveEncoder
from media.errors import SigncastError
from media.motion import Motion
from media.domain import Solution
from pipeline.live import objects
from pipeline.live.session import LIVE_GOP, VIDEO_CODECS, AccessUnit, SessionDescription

__all__ = ["VIDEO_CODECS", "LIVE_GOP", "VideoSource", "ParameterSource", "VideoSink", "ParameterSink", "source_for",
           "sink_for", "warm_up", "payload_prefix"]


class VideoSource:
    """NSV: frames (T, H, W, 3) uint8 RGB coded one by one at quantiser q."""

    def __init__(self, codec: str, frames: np.ndarray, fps: float, q: int, gop: int = LIVE_GOP):
        self.frames = frames
        self.encoder = LiveEncoder(codec, frames.shape[2], frames.shape[1], fps, q, gop=gop, b_frames=0)

    def capture(self, index: int) -> list[AccessUnit]:
        return [AccessUnit(p.index, p.data) for p in self.encoder.encode(self.frames[index], index)]

    def finish(self) -> list[AccessUnit]:
        return [AccessUnit(p.index, p.data) for p in self.encoder.flush()]


class ParameterSource:
    """FBA / BBA: `motion` coded by the parameter codec `codec` at q, one unit per `refresh` frames."""

    def __init__(self, codec: str, motion: Motion, q: int, refresh: int):
        if not 1 <= refresh <= fba_units.MAX_UNIT_FRAMES:
            raise SigncastError(f"the refresh period must be 1..{fba_units.MAX_UNIT_FRAMES} frames, got {refresh}")
        self.codec = param_codecs.get_codec(codec)
        self.motion, self.q, self.refresh = motion, q, refresh
        self.start = 0

    def capture(self, index: int) -> list[AccessUnit]:
        if index + 1 - self.start < self.refresh and index + 1 < self.motion.n_frames:
            return []
        first, self.start = self.start, index + 1
        payload = self.codec.encode(self.motion.frames(first, index + 1), self.q)
        return [AccessUnit(first, [fba_units.wrap_unit(first, index + 1 - first, payload)])]

    def finish(self) -> list[AccessUnit]:
        return []


def payload_prefix(codec: str) -> bytes:
    """The first bytes of every unit payload of a parameter codec: next_start_code() stuffing and the stream's
    start code (a scanner rejects a false unit header on them without waiting for its payload)."""
    if codec.startswith("fba"):
        return fba_units.FBA_PAYLOAD_PREFIX
    return b"\x7f" + START_CODE_PREFIX + bytes([bba_codec.BBA_START_CODE])


class _Screen:
    """The receiver's frames: shown (T, H, W, 3) and received (T,), with hold concealment at the end."""

    def __init__(self, n_frames: int, height: int, width: int):
        self.shown = np.zeros((n_frames, height, width, 3), np.uint8)
        self.received = np.zeros(n_frames, bool)

    def put(self, index: int, frame: np.ndarray) -> bool:
        if 0 <= index < len(self.shown) and not self.received[index]:
            self.shown[index] = frame
            self.received[index] = True
            return True
        return False

    def finish(self) -> tuple[np.ndarray, np.ndarray]:
        got = np.flatnonzero(self.received)
        if len(got):
            source = got[np.clip(np.searchsorted(got, np.arange(len(self.shown)), side="right") - 1, 0, None)]
            self.shown[:] = self.shown[source]
        return self.shown, self.received


class VideoSink:
    """NSV receiver."""

    def __init__(self, description: SessionDescription):
        self.screen = _Screen(description.n_frames, description.height, description.width)
        self.decoder = LiveDecoder(description.codec, description.width, description.height)
        self.next_index = 0

    def _show(self, pictures) -> list[int]:
        ready = []
        for (index, picture), status in zip(pictures, self.decoder.last_status):
            if status != "concealed" and self.screen.put(index, picture):
                ready.append(index)
        return ready

    def receive(self, frame: int, depacketized, stream: int = 0) -> list[int]:
        ready = []
        for missing in range(self.next_index, frame):
            ready += self._show(self.decoder.decode(None, missing))
        for unit in depacketized.units or [None]:
            ready += self._show(self.decoder.decode(None if unit is None else unit.data, frame))
        self.next_index = max(self.next_index, frame + 1)
        return ready

    def finish(self) -> tuple[np.ndarray, np.ndarray]:
        self._show(self.decoder.flush())
        return self.screen.finish()

    @property
    def stats(self) -> dict:
        return vars(self.decoder.stats)


class ParameterSink:
    """FBA / BBA receiver: finds units, decodes them and renders their frames with `renderer`."""

    def __init__(self, description: SessionDescription, renderer):
        self.screen = _Screen(description.n_frames, description.height, description.width)
        self.codec = param_codecs.get_codec(description.codec)
        self.renderer = renderer
        self.scanner = fba_units.UnitScanner(self._decode_payload, payload_prefix(description.codec))
        self.units = 0

    def _decode_payload(self, payload: bytes, n_frames: int) -> Motion:
        motion = self.codec.decode(payload)
        if motion.n_frames != n_frames:
            raise SigncastError(f"a unit announces {n_frames} frames and holds {motion.n_frames}")
        return motion

    def receive(self, frame: int, depacketized, stream: int = 0):
        """Yields each frame's index as soon as it is rendered (a generator: the session time-stamps each)."""
        for unit in depacketized.units:
            for decoded in self.scanner.feed(unit.data):
                self.units += 1
                for k, (rgb, _) in enumerate(self.renderer.frames(decoded.decoded)):
                    if self.screen.put(decoded.first_frame + k, rgb):
                        yield decoded.first_frame + k

    def finish(self) -> tuple[np.ndarray, np.ndarray]:
        return self.screen.finish()

    @property
    def stats(self) -> dict:
        return {"units": self.units, "skipped_bytes": self.scanner.skipped}


def warm_up(codec: str, renderer=None, motion: Motion | None = None) -> None:
    """Run what a session will run once, on a little data, so that one-time costs (loading compiled kernels: the
    entropy coder's, the shape coder's, the padding's; the renderer's first frame) do not land on a session's
    first frames: a terminal is ready before a call starts."""
    if codec in VIDEO_CODECS:
        from comparisons.transport import shape_units
        from comparisons.video import objects as video_objects
        mask = np.zeros((1, 32, 32), bool)
        mask[0, 8:20, 10:24] = True
        units = shape_units.encode_shape_units(mask, gop=1)
        shape_units.find_shape_units(b"".join(unit.data for unit in units))
        video_objects.repetitive_padding(np.zeros((32, 32, 3), np.uint8), mask[0])
        return
    if motion is None:
        return
    parameter_codec = param_codecs.get_codec(codec)
    decoded = parameter_codec.decode(parameter_codec.encode(motion.frames(0, min(4, motion.n_frames)), 4))
    if renderer is not None:
        for _ in renderer.frames(decoded.frames(0, 1)):
            pass


def source_for(solution: str, codec: str, q: int, *, frames: np.ndarray | None = None, motion: Motion | None = None,
               labels: np.ndarray | None = None, fps: float, refresh: int, shape_gop: int = 1):
    """(payload format, the sender's source) of one solution: NSV codes frames (T, H, W, 3) uint8; the object
    solutions (NSV2O, NSV3O, NSV3O+C, SSV: pipeline/live/objects.py) code frames cut by part labels (T, H, W)
    uint8, with shape units of shape_gop frames; FBA and BBA code the motion in units of refresh frames."""
    if solution in objects.OBJECT_SOLUTIONS:
        return "objects", objects.ObjectSource(solution, frames, labels, fps, codec, q, shape_gop=shape_gop)
    if solution == "NSV":
        if codec not in VIDEO_CODECS:
            raise SigncastError(f"NSV is sent live with {' or '.join(VIDEO_CODECS)}, not {codec!r}")
        return VIDEO_CODECS[codec], VideoSource(codec, frames, fps, q)
    if solution in (Solution.FBA, Solution.BBA):
        return "units", ParameterSource(codec, motion, q, refresh)
    raise SigncastError(f"unknown solution {solution!r}: choose NSV, {', '.join(objects.OBJECT_SOLUTIONS)}, FBA or BBA")


def sink_for(description: SessionDescription, renderer_for):
    """The receiver's sink for a session; renderer_for(width, height) gives the terminal's renderer."""
    if description.solution in objects.OBJECT_SOLUTIONS:
        return objects.ObjectSink(description)
    if description.solution == "NSV":
        return VideoSink(description)
    return ParameterSink(description, renderer_for(description.width, description.height))

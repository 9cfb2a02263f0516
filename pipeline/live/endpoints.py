"""What each solution's sender and receiver do with frames, per capture instant (pipeline/live/session.py calls
them).

Senders ("sources"): capture(i) is called at frame i's capture time and returns the AccessUnits ready then;
finish() returns what is left after the last frame.
- NSV (VideoSource): the frame is encoded at once by a live PyAV encoder (comparisons.transport.video.LiveEncoder,
  no B-frames: each would delay every frame by one frame interval) and its packet sent as one access unit.
- FBA / BBA (ParameterSource), low delay (units "frame", the default of `live` and `send`): every frame is a
  unit sent as it is captured: the codec's own one-frame stream at least every refresh frames, a delta unit
  predicted from that intra frame between (comparisons.transport.fba_units.encode_delta). With units "period",
  frames are gathered into refresh periods; when a period's last frame is captured, the period is coded by the
  parameter codec as one self-contained stream (intra first) and sent as one unit (comparisons.transport.fba_units:
  start code, frame numbers, CRC-8, the stream with its own checks). A unit decodes alone, so a lost one costs
  exactly its frames; the price is look-ahead: a period's first frame waits refresh - 1 frame intervals.

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
    """FBA / BBA: `motion` coded by the parameter codec `codec` at q.

    units "frame" (low delay, the default of `signcast live` and `send`): every frame is a unit sent as soon as
    it is captured: an intra unit (the codec's own stream of that frame) at least every `refresh` frames, a
    delta unit (comparisons.transport.fba_units.encode_delta: the frame predicted from the last intra frame as
    the receiver rebuilds it) in between, unless the intra unit is smaller (it is then sent instead, and later
    frames are predicted from it). units "period": one unit per `refresh` frames, the codec's stream of the period, sent when its last
    frame is captured (the period's first frame waits refresh - 1 frame intervals)."""

    def __init__(self, codec: str, motion: Motion, q: int, refresh: int, units: str = "period"):
        if not 1 <= refresh <= fba_units.MAX_UNIT_FRAMES:
            raise SigncastError(f"the refresh period must be 1..{fba_units.MAX_UNIT_FRAMES} frames, got {refresh}")
        if units not in UNIT_MODES:
            raise SigncastError(f"unknown unit mode {units!r}: choose {' or '.join(UNIT_MODES)}")
        self.codec = param_codecs.get_codec(codec)
        self.motion, self.q, self.refresh, self.units = motion, q, refresh, units
        self.start = 0
        self.state: fba_units.FrameState | None = None       # the last intra frame, as the receiver rebuilds it
        self.bones: tuple[str, ...] = ()                      # its bones
        self.intra_frame = 0

    def capture(self, index: int) -> list[AccessUnit]:
        if self.units == "frame":
            return [AccessUnit(index, [fba_units.wrap_unit(index, 1, self._frame_payload(index))])]
        if index + 1 - self.start < self.refresh and index + 1 < self.motion.n_frames:
            return []
        first, self.start = self.start, index + 1
        payload = self.codec.encode(self.motion.frames(first, index + 1), self.q)
        return [AccessUnit(first, [fba_units.wrap_unit(first, index + 1 - first, payload)])]

    def _frame_payload(self, index: int) -> bytes:
        intra = self.codec.encode(self.motion.frames(index, index + 1), self.q)
        decoded = self.codec.decode(intra)                          # what an intra unit of this frame shows
        shown = fba_units.FrameState.last_of(decoded)
        if index % self.refresh and self.state is not None and (shown.faps is None) == (self.state.faps is None):
            # predicted from the period's intra frame; a BBA stream leaves out bones at rest: they are at rest
            # (identity) here, and bones the intra frame lacks are named in the delta unit and added at rest
            new = tuple(name for name in decoded.bone_names if name not in set(self.bones))
            bones = (*self.bones, *new)
            where = {name: k for k, name in enumerate(decoded.bone_names)}
            rotations = np.tile([1.0, 0.0, 0.0, 0.0], (len(bones), 1))
            for k, name in enumerate(bones):
                if name in where:
                    rotations[k] = shown.rotations[where[name]]
            payload, _ = fba_units.encode_delta(self.state, fba_units.FrameState(rotations, shown.root, shown.faps),
                                                self.q, new, self.intra_frame)
            if len(payload) < len(intra):                       # else the intra unit is cheaper: it goes instead
                return payload
        self.state, self.bones, self.intra_frame = shown, decoded.bone_names, index
        return intra

    def finish(self) -> list[AccessUnit]:
        return []


UNIT_MODES = ("frame", "period")


def payload_prefix(codec: str) -> bytes:
    """The first bytes of every unit payload of a parameter codec: next_start_code() stuffing and the stream's
    start code (a scanner rejects a false unit header on them without waiting for its payload)."""
    if codec.startswith("fba"):
        return fba_units.FBA_PAYLOAD_PREFIX
    return b"\x7f" + START_CODE_PREFIX + bytes([bba_codec.BBA_START_CODE])


def payload_prefixes(codec: str) -> tuple[bytes, bytes]:
    """What may follow a unit header in a live parameter stream: the codec's stream, or a delta unit."""
    return payload_prefix(codec), fba_units.DELTA_PREFIX


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
    """FBA / BBA receiver: finds units, decodes them (the codec's streams, and delta units applied to the frame
    on their intra frame) and renders their frames with `renderer`. A delta unit whose intra frame did not
    arrive cannot be applied: it is counted in `broken` and its frame concealed."""

    def __init__(self, description: SessionDescription, renderer):
        self.screen = _Screen(description.n_frames, description.height, description.width)
        self.codec = param_codecs.get_codec(description.codec)
        self.fps = description.fps
        self.renderer = renderer
        self.scanner = fba_units.UnitScanner(self._decode_payload, payload_prefixes(description.codec))
        self.units = self.broken = 0
        self.state: tuple[int, fba_units.FrameState, Motion] | None = None     # the last intra frame

    def _decode_payload(self, payload: bytes, n_frames: int):
        if payload.startswith(fba_units.DELTA_PREFIX):
            if n_frames != 1:
                raise SigncastError(f"a delta unit announces {n_frames} frames")
            return fba_units.read_delta(payload)
        motion = self.codec.decode(payload)
        if motion.n_frames != n_frames:
            raise SigncastError(f"a unit announces {n_frames} frames and holds {motion.n_frames}")
        return motion

    def _motion(self, first: int, decoded) -> Motion | None:
        if isinstance(decoded, fba_units.DeltaPayload):
            if self.state is None or self.state[0] != decoded.reference:
                self.broken += 1
                return None
            _, reference, template = self.state
            try:
                frame = fba_units.apply_delta(decoded, reference)
            except SigncastError:
                self.broken += 1
                return None
            return Motion(template.fps, (*template.bone_names, *decoded.new_bones), frame.rotations[None],
                          frame.root[None], None if frame.faps is None else frame.faps[None])
        if decoded.n_frames == 1:
            self.state = (first, fba_units.FrameState.last_of(decoded), decoded)
        return decoded

    def receive(self, frame: int, depacketized, stream: int = 0):
        """Yields each frame's index as soon as it is rendered (a generator: the session time-stamps each)."""
        for unit in depacketized.units:
            for decoded in self.scanner.feed(unit.data):
                self.units += 1
                motion = self._motion(decoded.first_frame, decoded.decoded)
                if motion is None:
                    continue
                for k, (rgb, _) in enumerate(self.renderer.frames(motion)):
                    if self.screen.put(decoded.first_frame + k, rgb):
                        yield decoded.first_frame + k

    def finish(self) -> tuple[np.ndarray, np.ndarray]:
        return self.screen.finish()

    @property
    def stats(self) -> dict:
        return {"units": self.units, "skipped_bytes": self.scanner.skipped, "broken_chain": self.broken}


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


def warm_up_sink(sink) -> None:
    """A receiver's one-time costs paid before the session starts (the sender waits for READY): a parameter
    sink's codec (compiled loops) and renderer's first frame, on a rest pose of the avatar's bones."""
    if not isinstance(sink, ParameterSink):
        return
    renderer = sink.renderer
    skeleton = getattr(getattr(renderer, "avatar", None), "skeleton", None)
    names = tuple(getattr(skeleton, "names", ()) or ())
    if not names:
        return
    rest = Motion(sink.fps, names, np.tile([1.0, 0.0, 0.0, 0.0], (2, len(names), 1)), np.zeros((2, 3)))
    try:
        decoded = sink.codec.decode(sink.codec.encode(rest, 4))
        for _ in renderer.frames(decoded.frames(0, 1)):
            pass
    except SigncastError:
        pass


def source_for(solution: str, codec: str, q: int, *, frames: np.ndarray | None = None, motion: Motion | None = None,
               labels: np.ndarray | None = None, fps: float, refresh: int, shape_gop: int = 1,
               units: str = "period"):
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
        return "units", ParameterSource(codec, motion, q, refresh, units)
    raise SigncastError(f"unknown solution {solution!r}: choose NSV, {', '.join(objects.OBJECT_SOLUTIONS)}, FBA or BBA")


def sink_for(description: SessionDescription, renderer_for):
    """The receiver's sink for a session; renderer_for(width, height) gives the terminal's renderer."""
    if description.solution in objects.OBJECT_SOLUTIONS:
        return objects.ObjectSink(description)
    if description.solution == "NSV":
        return VideoSink(description)
    return ParameterSink(description, renderer_for(description.width, description.height))

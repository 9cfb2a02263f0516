"""Live delivery of the video-object solutions (NSV2O, NSV3O, NSV3O+C, SSV): the sender's ObjectSource and the
receiver's ObjectSink (pipeline/live/session.py calls them, as it calls the endpoints of pipeline/live/endpoints.py).

Streams: every object of the solution (comparisons.video.objects.SOLUTION_OBJECTS, in that order) is sent as two
RTP streams, `<object>/texture` (payload "mp4v" for mpeg4, "h264" for libx264: one access unit per frame) and
`<object>/shape` (payload "units": comparisons.transport.shape_units units, each an independent lossless shape stream).

Texture over the whole frame (chosen here): the offline coder (comparisons.video.objects.code_object) crops each
object to the bounding box of its masks over the whole clip, which a live sender cannot know before the clip
ends. The live texture covers the whole frame instead, padded causally frame by frame as pad_object pads
(MPEG-4 repetitive padding; in predicted frames the pixels outside the shape in this and the previous frame
repeat the previous padded frame; fully transparent 16x16 macroblocks get their own mean colour in intra frames
and repeat the previous padded frame in the others), so the encoder spends a skip flag per macroblock outside
the shape. Intra frames are those at index % TEXTURE_GOP == 0, the LiveEncoder's keyframes. An object absent
from a frame is fully transparent there (grey texture, empty mask); it is sent anyway: a live sender cannot know
that it will never appear. The clothes object of NSV3O+C is coded at CLOTHES_Q with mpeg4, as offline.

Shape: the masks of `shape_gop` frames make one unit (shape_units.encode_shape_unit, intra first), sent when the
unit's last frame is captured (shape_gop - 1 frames of look-ahead; 1: no delay, every frame intra). The unit's
RTP timestamp is that of its first frame. The shape is lossless, so the receiver's mask is the one the sender
padded with.

Receiver: per object a LiveDecoder (texture, FFmpeg's concealment) and a shape unit scanner
(shape_units.find_shape_units on each received unit). A frame is composed as video_objects.compose does (black
where no object; each object's texture inside its mask, later objects over earlier) once every object has a
decoded (not concealed) texture picture and its mask for that frame; its index is yielded then. At finish() the
frames never completed are composed from what exists (chosen here, as shape_units.assemble_shape conceals): a
missing mask holds the object's last received mask before that frame (fully transparent before any), a missing
texture is the decoder's held picture; such frames are not "received". The sink keeps only the pieces of frames
not yet composed (and the one mask per object that a later missing mask may need to hold), besides the screen.
"""
from __future__ import annotations

import numpy as np

from comparisons.transport import shape_units
from comparisons.video import objects as video_objects
from comparisons.transport.video import LiveDecoder, LiveEncoder
from comparisons.video.objects import flatten_macroblocks, transparent_macroblocks
from media.errors import SigncastError
from pipeline.live.session import LIVE_GOP, VIDEO_CODECS, AccessUnit, SessionDescription

TEXTURE_PAYLOADS = VIDEO_CODECS                             # live texture codec -> RTP payload format
TEXTURE_GOP = LIVE_GOP                                      # frames between texture keyframes
OBJECT_SOLUTIONS = tuple(name for name in video_objects.SOLUTION_OBJECTS if name != "NSV")


def object_streams(solution: str, codec: str) -> list[tuple[str, str]]:
    """[(stream name, payload format)] of a solution's objects: texture then shape of each object, in order."""
    if solution not in OBJECT_SOLUTIONS:
        raise SigncastError(f"{solution!r} is not a video-object solution; choose from {', '.join(OBJECT_SOLUTIONS)}")
    if codec not in TEXTURE_PAYLOADS:
        raise SigncastError(f"video objects are sent live with {' or '.join(TEXTURE_PAYLOADS)}, not {codec!r}")
    streams = []
    for name in video_objects.SOLUTION_OBJECTS[solution]:
        streams += [(f"{name}/texture", TEXTURE_PAYLOADS[codec]), (f"{name}/shape", "units")]
    return streams


def macroblock_box(mask: np.ndarray) -> tuple[int, int, int, int] | None:
    """(y0, y1, x0, x1): the 16x16-aligned box of the macroblocks holding an opaque pixel of mask (H, W) bool,
    clipped to the frame; None for an empty mask."""
    rows, columns = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    if not len(rows):
        return None
    mb = video_objects.MB
    return (rows[0] // mb * mb, min(mask.shape[0], (rows[-1] // mb + 1) * mb),
            columns[0] // mb * mb, min(mask.shape[1], (columns[-1] // mb + 1) * mb))


class CausalPadder:
    """pad_object one frame at a time over the whole frame: needs only the previous frame's padded texture and
    mask. `pad(frame (H, W, 3) uint8, mask (H, W) bool, intra)` returns the padded texture (H, W, 3) uint8.

    In a predicted frame every pixel outside the macroblocks that hold the object repeats the previous padded
    frame, so only the object's macroblock box is padded (the same values as padding the whole frame: the box
    holds every row and column with an opaque pixel); an intra frame pads the whole frame, whose transparent
    macroblocks take their own mean."""

    def __init__(self):
        self.previous: np.ndarray | None = None
        self.previous_mask: np.ndarray | None = None

    def pad(self, frame: np.ndarray, mask: np.ndarray, intra: bool) -> np.ndarray:
        transparent = video_objects.transparent_pixels(mask)
        if not intra and self.previous is not None:
            padded = self.previous.copy()
            box = macroblock_box(mask)
            if box is not None:
                y0, y1, x0, x1 = box
                inside = video_objects.repetitive_padding(frame[y0:y1, x0:x1], mask[y0:y1, x0:x1])
                fresh = ~((~mask[y0:y1, x0:x1] & ~self.previous_mask[y0:y1, x0:x1]) | transparent[y0:y1, x0:x1])
                padded[y0:y1, x0:x1][fresh] = inside[fresh]
        else:
            padded = video_objects.repetitive_padding(frame, mask)
            if transparent.any():
                padded = flatten_macroblocks(padded, transparent_macroblocks(mask))
        self.previous, self.previous_mask = padded, mask
        return padded


class ObjectSource:
    """Sender of a video-object solution: frames (T, H, W, 3) uint8 RGB, part labels (T, H, W) uint8 (media's
    segmentation labels), fps, texture codec "mpeg4" or "libx264" at quantiser q, shape units of shape_gop frames
    (1..255). `streams` lists (name, payload) of every RTP stream; AccessUnit.stream indexes it."""

    def __init__(self, solution: str, frames: np.ndarray, labels: np.ndarray, fps: float, codec: str, q: int,
                 shape_gop: int = 1):
        self.streams = object_streams(solution, codec)
        frames, labels = np.asarray(frames), np.asarray(labels)
        if frames.ndim != 4 or frames.shape[3] != 3 or frames.dtype != np.uint8 or not len(frames):
            raise SigncastError(f"frames must be (T, H, W, 3) uint8 with T >= 1, got {frames.shape} {frames.dtype}")
        if labels.shape != frames.shape[:3]:
            raise SigncastError(f"labels {labels.shape} do not match frames {frames.shape[:3]}")
        if not 1 <= shape_gop <= 255:
            raise SigncastError(f"shape units must hold 1..255 frames, got {shape_gop}")
        self.frames, self.shape_gop = frames, shape_gop
        self.masks = video_objects.object_masks_for(solution, labels)        # name -> (T, H, W) bool, per frame
        height, width = frames.shape[1:3]
        self.encoders, self.padders = {}, {}
        for name in self.masks:
            object_q = video_objects.CLOTHES_Q if name == "clothes" and codec == "mpeg4" else q
            self.encoders[name] = LiveEncoder(codec, width, height, fps, object_q, gop=TEXTURE_GOP, b_frames=0)
            self.padders[name] = CausalPadder()
        self.shape_start = 0            # first frame of the shape unit being gathered

    def _texture_stream(self, k: int) -> int:
        return 2 * k

    def _shape_units(self, stop: int) -> list[AccessUnit]:
        """The shape units of frames [shape_start, stop), one per object."""
        first, self.shape_start = self.shape_start, stop
        return [AccessUnit(first, [shape_units.encode_shape_unit(masks[first:stop], first, self.shape_gop).data],
                           2 * k + 1)
                for k, masks in enumerate(self.masks.values())]

    def capture(self, index: int) -> list[AccessUnit]:
        """The access units ready when frame `index` (0..T-1, in order) is captured."""
        if not 0 <= index < len(self.frames):
            raise SigncastError(f"frame {index} outside the clip's 0..{len(self.frames) - 1}")
        out = []
        for k, (name, masks) in enumerate(self.masks.items()):
            texture = self.padders[name].pad(self.frames[index], masks[index], index % TEXTURE_GOP == 0)
            out += [AccessUnit(p.index, p.data, self._texture_stream(k))
                    for p in self.encoders[name].encode(texture, index)]
        if index + 1 - self.shape_start >= self.shape_gop or index + 1 == len(self.frames):
            out += self._shape_units(index + 1)
        return out

    def finish(self) -> list[AccessUnit]:
        """What is left after the last capture: packets the encoders still hold."""
        out = []
        for k, name in enumerate(self.masks):
            out += [AccessUnit(p.index, p.data, self._texture_stream(k)) for p in self.encoders[name].flush()]
        return out


class _ObjectState:
    """One object at the receiver: its texture decoder and the pieces of frames not yet composed."""

    def __init__(self, codec: str, width: int, height: int):
        self.decoder = LiveDecoder(codec, width, height)
        self.next_index = 0                          # the next texture index the decoder expects
        self.textures: dict[int, np.ndarray] = {}   # frame -> decoded picture (H, W, 3) uint8
        self.concealed: dict[int, np.ndarray] = {}  # frame -> the decoder's held picture (no picture decoded)
        self.masks: dict[int, np.ndarray] = {}      # frame -> received mask (H, W) bool
        self.shape_units = self.bad_shape_units = self.skipped_shape_bytes = self.held_shape_frames = 0


class ObjectSink:
    """Receiver of a video-object solution described by `description` (streams named as ObjectSource names
    them, in its order)."""

    def __init__(self, description: SessionDescription):
        self.n_frames, self.height, self.width = description.n_frames, description.height, description.width
        streams = [(stream.get("name"), stream.get("payload")) if isinstance(stream, dict) else None
                   for stream in description.streams]
        try:
            expected = object_streams(description.solution, description.codec)
        except SigncastError as error:
            raise SigncastError(f"bad session description from the sender: {error}") from None
        if streams != expected:
            raise SigncastError(f"bad session description from the sender: streams {streams}, expected {expected}")
        if self.n_frames < 1:
            raise SigncastError("bad session description from the sender: no frame")
        self.objects = {name.split("/")[0]: _ObjectState(description.codec, self.width, self.height)
                        for name, _ in expected[::2]}
        self.states = list(self.objects.values())
        self.shown = np.zeros((self.n_frames, self.height, self.width, 3), np.uint8)
        self.received = np.zeros(self.n_frames, bool)
        self.composed = np.zeros(self.n_frames, bool)
        self.unknown_streams = 0

    # ------------------------------------------------------------------------------------------ receiving

    def receive(self, frame: int, depacketized, stream: int = 0) -> list[int]:
        """Feed one capture instant's data of stream `stream`; returns the frames now composed (ready to show)."""
        if not 0 <= stream < 2 * len(self.states):
            self.unknown_streams += 1
            return []
        state = self.states[stream // 2]
        touched = self._texture(state, frame, depacketized) if stream % 2 == 0 else self._shape(state, depacketized)
        return [index for index in sorted(set(touched)) if self._try_compose(index)]

    def _texture(self, state: _ObjectState, frame: int, depacketized) -> list[int]:
        if not 0 <= frame < self.n_frames:
            return []
        touched = []
        for missing in range(state.next_index, frame):
            touched += self._keep(state, state.decoder.decode(None, missing))
        for unit in depacketized.units or [None]:
            data = None if unit is None else unit.data
            touched += self._keep(state, state.decoder.decode(data, frame, bool(unit is not None and unit.damaged)))
        state.next_index = max(state.next_index, frame + 1)
        return touched

    def _keep(self, state: _ObjectState, pictures) -> list[int]:
        kept = []
        for (index, picture), status in zip(pictures, state.decoder.last_status):
            if self.composed[index]:
                continue
            (state.concealed if status == "concealed" else state.textures)[index] = picture
            kept.append(index)
        return kept

    def _shape(self, state: _ObjectState, depacketized) -> list[int]:
        touched = []
        for unit in depacketized.units:
            found, skipped = shape_units.find_shape_units(unit.data)
            state.skipped_shape_bytes += skipped
            for first, masks in found:
                if masks.shape[1:] != (self.height, self.width) or not 0 <= first < self.n_frames:
                    state.bad_shape_units += 1
                    continue
                state.shape_units += 1
                for index in range(first, min(first + len(masks), self.n_frames)):
                    if not self.composed[index]:
                        state.masks[index] = masks[index - first]
                        touched.append(index)
        self._prune_masks(state)
        return touched

    def _prune_masks(self, state: _ObjectState) -> None:
        """Drop the masks of composed frames that no later missing mask can need (the next frame has its own)."""
        for index in [i for i in state.masks if self.composed[i]
                      and (i + 1 >= self.n_frames or i + 1 in state.masks or self.composed[i + 1])]:
            del state.masks[index]

    # ------------------------------------------------------------------------------------------ composing

    def _compose(self, index: int, masks: list[np.ndarray | None], textures: list[np.ndarray]) -> None:
        picture = self.shown[index]
        picture[:] = 0
        for mask, texture in zip(masks, textures):
            if mask is not None:
                picture[mask] = texture[mask]
        self.composed[index] = True
        for state in self.states:
            state.textures.pop(index, None)
            state.concealed.pop(index, None)
            self._prune_masks(state)

    def _try_compose(self, index: int) -> bool:
        if self.composed[index] or not all(index in s.textures and index in s.masks for s in self.states):
            return False
        self._compose(index, [s.masks[index] for s in self.states], [s.textures[index] for s in self.states])
        self.received[index] = True
        return True

    def _held_mask(self, state: _ObjectState, index: int) -> np.ndarray | None:
        earlier = [i for i in state.masks if i < index]
        return state.masks[max(earlier)] if earlier else None

    def finish(self) -> tuple[np.ndarray, np.ndarray]:
        """(shown (T, H, W, 3) uint8, received (T,) bool): the frames never completed composed with held masks and
        the decoders' held pictures."""
        for state in self.states:
            for missing in range(state.next_index, self.n_frames):
                self._keep(state, state.decoder.decode(None, missing))
            state.next_index = self.n_frames
            self._keep(state, state.decoder.flush())
        grey = np.full((self.height, self.width, 3), 128, np.uint8)     # unreachable: the decoders returned all
        for index in np.flatnonzero(~self.composed):
            index = int(index)
            masks, textures = [], []
            for state in self.states:
                if index in state.masks:
                    masks.append(state.masks[index])
                else:
                    masks.append(self._held_mask(state, index))
                    state.held_shape_frames += 1
                    if masks[-1] is not None:
                        state.masks[index] = masks[-1]      # the frame after may hold it in turn
                texture = state.textures.get(index, state.concealed.get(index))
                textures.append(texture if texture is not None else grey)
            self._compose(index, masks, textures)
        return self.shown, self.received

    @property
    def stats(self) -> dict:
        """Per object: its texture decoder's counts, shape units received (and rejected), frames with a held shape."""
        return {name: {"texture": vars(state.decoder.stats), "shape_units": state.shape_units,
                       "bad_shape_units": state.bad_shape_units, "skipped_shape_bytes": state.skipped_shape_bytes,
                       "held_shape_frames": state.held_shape_frames}
                for name, state in self.objects.items()} | {"unknown_streams": self.unknown_streams}

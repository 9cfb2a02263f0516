"""Object-based video coding in the manner of MPEG-4 Core profile, with today's encoders doing the texture.

Each video object is coded as its own texture stream over its bounding box (the union of its masks over the
sequence, aligned to the 16x16 macroblock grid), with the pixels outside its shape padded, plus its binary
shape coded by `comparisons.video.shape` (losslessly, or within a stated shape error: ShapeCache.shape_error).
The object's cost is texture bytes + shape bytes. The receiving side decodes both and composes the objects onto a black frame for quality measurement.

Padding (the texture encoder has no shape tool, so padding must keep the outside cheap): MPEG-4 repetitive
padding in each frame (transparent runs in a row take the value of the opaque pixel at their border, or the
rounded mean of both borders; rows with no opaque pixel then take the nearest padded rows above / below),
and in predicted frames the pixels outside the shape in this and the previous frame repeat the previous padded
frame, so that the encoder finds nothing to code there.

Transparent macroblocks (MPEG-4 Core sends no texture for a 16x16 macroblock of the box that holds no opaque
pixel): the texture encoder has no such mode, so such macroblocks are filled with what it codes almost for
free: in intra frames a flat grey (RGB 128, MPEG-4's padding value where no opaque pixel is near), a block of
DC only whose DC equals its neighbours'; in predicted frames the co-located block of the previous padded frame,
which the encoder skips (no motion, no residual). They still cost the encoder's few bits per macroblock (the
not-coded flag, the intra DC): the reported texture bytes are len() of the real, decodable stream, nothing is
subtracted from it. The box is aligned to the 16x16 grid, so these macroblocks are the encoder's own.

Solutions (seed 000, §4.2.1-4.2.2): NSV the whole frame; NSV2O the signer (labels > 0) — the segmentation
makes two objects, signer and background, but only the signer's texture and shape are coded, "ignoring the
rest of the image" (§4.2.1), so the background is not sent; NSV3O and SSV the skin objects head, left hand,
right hand; NSV3O+C adds the clothes object at Q = 31.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from comparisons.video import quality as image_quality
from comparisons.video import shape as shape_coding
from comparisons.video import codecs as video_codecs
from comparisons.video import padding as padding_kernel
from media import segmentation
from media.domain import Solution
from media.errors import SigncastError

MB = 16
CLOTHES_Q = 31
SOLUTION_OBJECTS = {     # the video objects each video solution sends, in stream order
    Solution.NSV: ("frame",),
    Solution.NSV2O: ("signer",),
    Solution.NSV3O: ("head", "left_hand", "right_hand"),
    Solution.NSV3O_C: ("head", "left_hand", "right_hand", "clothes"),
    Solution.SSV: ("head", "left_hand", "right_hand"),
}


def bounding_box(masks: np.ndarray, frame_shape: tuple[int, int]) -> tuple[int, int, int, int] | None:
    """Union box (y0, y1, x0, x1) of masks (T, H, W) over all frames, widened to the 16x16 grid and
    clipped to the frame (even sizes); None when the object never appears."""
    rows = np.flatnonzero(masks.any(axis=(0, 2)))
    cols = np.flatnonzero(masks.any(axis=(0, 1)))
    if not len(rows):
        return None
    height, width = frame_shape
    y0, x0 = (rows[0] // MB) * MB, (cols[0] // MB) * MB
    y1 = min(height, -(-(rows[-1] + 1) // MB) * MB) & ~1
    x1 = min(width, -(-(cols[-1] + 1) // MB) * MB) & ~1
    if y1 - y0 < 2 or x1 - x0 < 2:
        y1, x1 = min(height & ~1, y0 + 2), min(width & ~1, x0 + 2)
    return int(y0), int(y1), int(x0), int(x1)


def _fill_runs(values: np.ndarray, opaque: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Repetitive padding along the last-but-one axis of values (..., N, C) where opaque (..., N) is False.

    Returns the filled values (float) and whether each line (...) had an opaque pixel.
    """
    n = opaque.shape[-1]
    positions = np.arange(n)
    left = np.where(opaque, positions, -1)
    np.maximum.accumulate(left, axis=-1, out=left)
    right = np.where(opaque, positions, n)
    right = np.flip(np.minimum.accumulate(np.flip(right, -1), axis=-1), -1)
    has_left, has_right = left >= 0, right < n
    take_left = np.take_along_axis(values, np.clip(left, 0, n - 1)[..., None], axis=-2).astype(np.float32)
    take_right = np.take_along_axis(values, np.clip(right, 0, n - 1)[..., None], axis=-2).astype(np.float32)
    both = (has_left & has_right)[..., None]
    filled = np.where(both, np.floor((take_left + take_right + 1) / 2),
                      np.where(has_left[..., None], take_left, take_right))
    filled = np.where(opaque[..., None], values.astype(np.float32), filled)
    return filled, opaque.any(axis=-1)


def repetitive_padding(image: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """MPEG-4 repetitive padding of one image (H, W, 3) uint8 outside mask (H, W) bool; grey 128 if empty
    (the compiled kernel; repetitive_padding_numpy is its oracle)."""
    return padding_kernel.repetitive_padding(image, mask)


def repetitive_padding_numpy(image: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """MPEG-4 repetitive padding of one image (H, W, 3) uint8 outside mask (H, W) bool; grey 128 if empty."""
    if not mask.any():
        return np.full_like(image, 128)
    rows, row_has = _fill_runs(image, mask)                      # horizontal pass
    columns = np.swapaxes(rows, 0, 1)                            # (W, H, 3)
    line_mask = np.broadcast_to(row_has[None, :], columns.shape[:2])
    filled, _ = _fill_runs(columns, line_mask)                   # vertical pass over empty rows
    return np.swapaxes(filled, 0, 1).astype(np.uint8)


def pad_object(frames: np.ndarray, masks: np.ndarray, gop: int = video_codecs.GOP,
               skip_transparent: bool = True) -> np.ndarray:
    """Padded texture (T, h, w, 3) uint8 of an object cropped to its box: frames (T, h, w, 3), masks (T, h, w).

    Intra frames (every gop frames) get repetitive padding only; in the other frames a pixel outside the
    shape that was outside in the previous frame too keeps its previous padded value, so the encoder finds
    no change to code there, and only newly uncovered pixels take the repetitive padding.
    skip_transparent: fully transparent 16x16 macroblocks are flat grey in intra frames and repeat the previous
    padded frame whole in the others (the module's docstring says why).
    """
    padded = np.empty_like(frames)
    for t in range(len(frames)):
        padded[t] = repetitive_padding(frames[t], masks[t])
        transparent = transparent_pixels(masks[t]) if skip_transparent else np.zeros(masks.shape[1:], bool)
        if t % gop:
            held = (~masks[t] & ~masks[t - 1]) | transparent
            padded[t][held] = padded[t - 1][held]
        elif transparent.any():
            padded[t] = flatten_macroblocks(padded[t], transparent_macroblocks(masks[t]))
    return padded


def flatten_macroblocks(image: np.ndarray, blocks: np.ndarray) -> np.ndarray:
    """image (H, W, 3) uint8 with each macroblock marked in blocks (ceil(H/16), ceil(W/16)) bool set to its own
    rounded mean colour."""
    height, width = image.shape[:2]
    flat = image.copy()
    for by, bx in zip(*np.nonzero(blocks)):
        view = flat[by * MB:min(height, (by + 1) * MB), bx * MB:min(width, (bx + 1) * MB)]
        view[:] = np.round(view.reshape(-1, 3).mean(axis=0)).astype(np.uint8)
    return flat


def transparent_macroblocks(mask: np.ndarray) -> np.ndarray:
    """(ceil(H/16), ceil(W/16)) bool: the 16x16 macroblocks of mask (H, W) bool with no opaque pixel."""
    height, width = mask.shape
    grid = np.zeros((-(-height // MB) * MB, -(-width // MB) * MB), bool)
    grid[:height, :width] = mask
    return ~grid.reshape(grid.shape[0] // MB, MB, grid.shape[1] // MB, MB).any(axis=(1, 3))


def transparent_pixels(mask: np.ndarray) -> np.ndarray:
    """(H, W) bool: the pixels of mask (H, W) bool that lie in a fully transparent 16x16 macroblock."""
    height, width = mask.shape
    blocks = transparent_macroblocks(mask)
    return np.repeat(np.repeat(blocks, MB, axis=0), MB, axis=1)[:height, :width]


@dataclass
class CodedObject:
    """One video object after coding and decoding."""

    name: str
    q: int
    box: tuple[int, int, int, int]           # (y0, y1, x0, x1) in the frame
    texture_bytes: int
    shape_bytes: int
    decoded_texture: np.ndarray              # (T, y1-y0, x1-x0, 3) uint8
    decoded_masks: np.ndarray                # (T, H, W) bool, the whole frame
    area_percent: float
    shape_errors: tuple[int, int] = (0, 0)   # (wrong pixels, object pixels) of the decoded shape, all frames

    @property
    def bits(self) -> int:
        return 8 * (self.texture_bytes + self.shape_bytes)


@dataclass
class ShapeCache:
    """Coded shapes by (object name, frame-set key): the shape is independent of the texture quantiser.

    shape_error: percent of each object's pixels its decoded shape may get wrong (0: lossless; see
    comparisons.video.shape.encode_shape). streams maps a key to (shape bytes, decoded masks, wrong pixels,
    object pixels)."""

    streams: dict = field(default_factory=dict)
    shape_error: float = 0.0

    def get(self, key, masks: np.ndarray) -> tuple[int, np.ndarray]:
        """(shape bytes, decoded masks) for masks (T, H, W), coding and decoding once per key."""
        if key not in self.streams:
            stream, stats = shape_coding.encode_shape(masks, gop=video_codecs.GOP, shape_error=self.shape_error)
            decoded = shape_coding.decode_shape(stream)
            expected = masks if stats.reconstruction is None else stats.reconstruction
            if not np.array_equal(decoded, expected):
                raise SigncastError(f"shape decoder did not reproduce the encoder's masks of {key}")
            self.streams[key] = (len(stream), decoded, stats.error_pixels, stats.object_pixels)
        return self.streams[key][:2]

    def errors(self, key) -> tuple[int, int]:
        """(wrong pixels, object pixels) of a coded key."""
        return self.streams[key][2:]


def code_object(name: str, frames: np.ndarray, masks: np.ndarray | None, fps: float, codec: str, q: int,
                shapes: ShapeCache | None = None, shape_key=None, skip_transparent: bool = True) -> CodedObject | None:
    """Code one object: frames (T, H, W, 3) uint8 RGB, masks (T, H, W) bool (None: the whole frame, no shape).

    skip_transparent: fill fully transparent macroblocks so that they cost (almost) no texture bits (pad_object).
    Returns None for an object that never appears.
    """
    frames = np.asarray(frames)
    height, width = frames.shape[1:3]
    if masks is None:
        coded = video_codecs.code_video(frames, fps, codec, q)
        full = np.ones(frames.shape[:3], bool)
        return CodedObject(name, q, (0, height, 0, width), len(coded.data), 0, coded.decoded, full, 100.0)
    masks = np.asarray(masks, bool)
    if masks.shape != frames.shape[:3]:
        raise SigncastError(f"object {name}: masks {masks.shape} do not match frames {frames.shape[:3]}")
    box = bounding_box(masks, (height, width))
    if box is None:
        return None
    shapes = shapes if shapes is not None else ShapeCache()
    key = shape_key or (name, masks.shape, id(masks))
    shape_bytes, decoded_masks = shapes.get(key, masks)
    y0, y1, x0, x1 = box
    texture = pad_object(frames[:, y0:y1, x0:x1], decoded_masks[:, y0:y1, x0:x1], skip_transparent=skip_transparent)
    coded = video_codecs.code_video(texture, fps, codec, q)
    return CodedObject(name, q, box, len(coded.data), shape_bytes, coded.decoded, decoded_masks,
                       100.0 * float(masks.mean()), shapes.errors(key))


def compose(objects: list[CodedObject], frame_shape: tuple[int, int, int]) -> tuple[np.ndarray, np.ndarray]:
    """Received picture (T, H, W, 3) uint8 (black where nothing was sent) and the sent region (T, H, W) bool."""
    count, height, width = frame_shape
    picture = np.zeros((count, height, width, 3), np.uint8)
    region = np.zeros((count, height, width), bool)
    for obj in objects:
        y0, y1, x0, x1 = obj.box
        inside = obj.decoded_masks[:, y0:y1, x0:x1, None]
        np.copyto(picture[:, y0:y1, x0:x1], obj.decoded_texture, where=inside)     # 3-4x faster than mask indexing
        region |= obj.decoded_masks
    return picture, region


def object_masks_for(solution: str, labels: np.ndarray | None) -> dict[str, np.ndarray | None]:
    """The masks (T, H, W) bool of a solution's objects from part labels (T, H, W) uint8."""
    if solution not in SOLUTION_OBJECTS:
        raise SigncastError(f"unknown video solution {solution!r}; choose from {', '.join(SOLUTION_OBJECTS)}")
    if solution == "NSV":
        return {"frame": None}
    if labels is None:
        raise SigncastError(f"{solution} needs part labels")
    named = segmentation.object_masks(labels)
    return {name: named[name] for name in SOLUTION_OBJECTS[solution]}


@dataclass
class CodedSolution:
    solution: str
    objects: list[CodedObject]
    picture: np.ndarray                      # (T, H, W, 3) uint8 received picture
    region: np.ndarray                       # (T, H, W) bool sent region

    @property
    def bits(self) -> int:
        return sum(obj.bits for obj in self.objects)

    @property
    def shape_bits(self) -> int:
        return sum(8 * obj.shape_bytes for obj in self.objects)

    @property
    def shape_error(self) -> float:
        """Percent: decoded shape pixels unlike the masks over the objects' pixels (0 for lossless shape)."""
        wrong = sum(obj.shape_errors[0] for obj in self.objects)
        return 100.0 * wrong / max(1, sum(obj.shape_errors[1] for obj in self.objects))


def code_solution(solution: str, frames: np.ndarray, labels: np.ndarray | None, fps: float, codec: str, q: int,
                  shapes: ShapeCache | None = None, shape_key=None,
                  object_q: dict[str, int] | None = None) -> CodedSolution:
    """Code every object of a solution at quantiser q; object_q overrides q per object name.

    With mpeg4 the clothes object of NSV3O+C is coded at Q = 31 unless object_q says otherwise.
    """
    shapes = shapes or ShapeCache()
    object_q = dict(object_q or {})
    if codec == "mpeg4":
        object_q.setdefault("clothes", CLOTHES_Q)
    coded = []
    for name, masks in object_masks_for(solution, labels).items():
        key = (name, shape_key) if shape_key is not None else None
        obj = code_object(name, frames, masks, fps, codec, object_q.get(name, q), shapes, key)
        if obj is not None:
            coded.append(obj)
    if not coded:
        raise SigncastError(f"{solution}: no object appears in any frame")
    picture, region = compose(coded, frames.shape[:3])
    return CodedSolution(solution, coded, picture, region)


def code_roi(frames: np.ndarray, labels: np.ndarray, fps: float, crf: int, codec: str = "libx264",
             offsets: tuple[float, float] | None = None) -> CodedSolution:
    """NSV-ROI at x264's CRF crf (comparisons/video/roi.py): frames (T, H, W, 3) uint8 RGB and their part labels
    (T, H, W) as one stream with the face and hands at a lower quantiser, as one whole-frame object (no shape is
    sent). offsets: addroi's (face and hands, rest) qoffsets in -1..1 (None: RoiSettings' defaults; (0, 0) codes
    plain CRF, the control)."""
    from comparisons.video import roi as video_roi

    settings = video_roi.RoiSettings(crf=int(crf))
    if offsets is not None:
        settings = video_roi.RoiSettings(crf=int(crf), skin_offset=float(offsets[0]), rest_offset=float(offsets[1]))
    coded = video_roi.encode_roi(frames, labels, fps, settings, codec)
    height, width = frames.shape[1:3]
    whole = np.ones(frames.shape[:3], bool)
    frame = CodedObject("frame", int(crf), (0, height, 0, width), len(coded.data), 0, coded.picture, whole, 100.0)
    return CodedSolution(Solution.NSV_ROI, [frame], coded.picture, whole)


def object_psnr(obj: CodedObject, frames: np.ndarray) -> float:
    """Luma PSNR (dB) of a decoded object inside its own shape, against the source frames (T, H, W, 3)."""
    y0, y1, x0, x1 = obj.box
    inside = obj.decoded_masks[:, y0:y1, x0:x1]
    return image_quality.psnr(frames[:, y0:y1, x0:x1], obj.decoded_texture, inside)


def code_solution_matched(reference: CodedSolution, frames: np.ndarray, labels: np.ndarray | None, fps: float,
                          codec: str, shapes: ShapeCache | None = None, shape_key=None) -> CodedSolution:
    """Code a solution with another codec, each object at the cheapest quantiser whose PSNR inside the
    object's shape reaches that of the same object in reference (matched quality)."""
    low, high = video_codecs.CODECS[codec][1]
    chosen = {}
    for obj in reference.objects:
        target = object_psnr(obj, frames)
        masks = object_masks_for(reference.solution, labels)[obj.name]
        key = (obj.name, shape_key) if shape_key is not None else None

        def encode_at(q: int, name=obj.name, masks=masks, key=key):
            candidate = code_object(name, frames, masks, fps, codec, q, shapes, key)
            return candidate, object_psnr(candidate, frames)
        chosen[obj.name] = video_codecs.match_quality(encode_at, (low, high), target)[0]
    return code_solution(reference.solution, frames, labels, fps, codec, min(chosen.values()), shapes, shape_key,
                         object_q=chosen)

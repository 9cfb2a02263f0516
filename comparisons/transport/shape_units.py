"""Shape units: a video object's binary shape cut into independently decodable units for live delivery.

`comparisons.video.shape` codes a whole mask sequence as one stream: one lost byte loses every frame. For live
delivery the masks are coded in units of `gop` frames, each unit an independent `encode_shape` stream that
starts with an intra frame, behind a small unit header (format chosen here):

    start code      32 bits  0x000001C5 (signcast's: a value ISO/IEC 14496-2 Table 6-3 leaves reserved)
    first_frame     u32      index of the unit's first frame in the clip
    n_frames        u16      frames in the unit (1..65535)
    length          u24      bytes of the shape stream that follows
    crc8            u8       CRC-8 (x^8 + x^2 + x + 1, comparisons.params.bits.crc8_bits) of the 9 bytes before it
    shape stream    `length` bytes: an encode_shape stream (version 4; 2 and 3 are read too), whose own header carries
                    a CRC-32 of its header and payload, so no further checksum is added here

Multi-byte fields are big-endian. A receiver (`find_shape_units`) scans for the start code, checks the header
CRC-8 (it detects every error burst of up to 8 bits, so any single damaged header byte), that `length` bytes
follow, and that the shape stream decodes (its CRC-32) to `n_frames` masks; anything else is skipped and the
scan resumes one byte after the start code, so damage costs exactly the unit it hits. A start code emulated
inside a payload is rejected by the CRC-8 and then the CRC-32. Allocation is bounded by what shape_coding
accepts (at most MAX_PIXELS mask pixels a unit); `length` only ever slices the received bytes.

Concealment (`assemble_shape`, chosen here): a frame whose unit was lost shows the last received mask; before
the first received unit the object has no mask at all and is fully transparent: the object is not shown.

What a lost shape packet costs (measured: the first 25 frames of ASL "AB" fingerspelled at 25 fps
(media.fingerspelling), rendered at 176x144 by media.render with the NumPy kernels, masks from
media.segmentation.object_masks; bytes per unit include the 14-byte unit header and shape_coding's 22-byte
header; IoU of the held masks against the true ones, pooled over the frames of the lost unit, mean and worst
over every unit that has a predecessor):

    object      gop  units  bytes/unit  bits/frame  IoU one unit lost (mean / worst)
    right_hand    1     25        56.8         454  0.852 / 0.516
    right_hand    4      7        91.7         205  0.859 / 0.578
    right_hand   12      3       146.7         141  0.800 / 0.656
    skin          1     25       107.3         859  0.963 / 0.888
    skin          4      7       172.9         387  0.959 / 0.860
    skin         12      3       270.0         259  0.937 / 0.884
    signer        1     25       173.5        1388  0.991 / 0.971
    signer       12      3       420.7         404  0.985 / 0.973

The fingerspelling hand is what a lost unit hurts: its held mask misses up to half of the moving hand, while
the head and body barely move. Short units cost bits (36 bytes of headers a unit) and lose less per loss.
"""
from __future__ import annotations

import struct
from collections.abc import Iterable
from typing import NamedTuple

import numpy as np

from comparisons.params.bits import crc8_bits
from comparisons.video.shape import decode_shape, encode_shape
from media.errors import SigncastError

START_CODE = b"\x00\x00\x01\xc5"
DEFAULT_GOP = 12
_FIELDS = struct.Struct(">IH")                  # first_frame, n_frames; then length u24 and CRC-8
HEADER_SIZE = len(START_CODE) + _FIELDS.size + 3 + 1
MAX_FIRST_FRAME = (1 << 32) - 1
MAX_UNIT_FRAMES = (1 << 16) - 1
MAX_LENGTH = (1 << 24) - 1


class ShapeUnit(NamedTuple):
    """One coded unit: the clip index of its first frame, its number of frames, and its bytes (header included)."""

    first_frame: int
    n_frames: int
    data: bytes


def _header(first_frame: int, n_frames: int, length: int) -> bytes:
    fields = START_CODE + _FIELDS.pack(first_frame, n_frames) + length.to_bytes(3, "big")
    return fields + bytes([crc8_bits(fields, 8 * len(START_CODE), 8 * len(fields))])


def encode_shape_unit(masks: np.ndarray, first_frame: int, gop: int = DEFAULT_GOP) -> ShapeUnit:
    """One unit from masks (n, H, W) bool whose first frame is clip frame `first_frame` (the live sender's call)."""
    masks = np.asarray(masks)
    if not 0 <= first_frame <= MAX_FIRST_FRAME:
        raise SigncastError(f"shape unit first frame must be 0..{MAX_FIRST_FRAME}, got {first_frame}")
    if masks.ndim != 3 or not 1 <= masks.shape[0] <= MAX_UNIT_FRAMES:
        raise SigncastError(f"a shape unit holds (n, H, W) masks with 1 <= n <= {MAX_UNIT_FRAMES}, got {masks.shape}")
    stream, _ = encode_shape(masks, gop=min(gop, 255))
    if len(stream) > MAX_LENGTH:
        raise SigncastError(f"shape unit of {len(stream)} bytes exceeds {MAX_LENGTH}: use a shorter gop")
    return ShapeUnit(first_frame, masks.shape[0], _header(first_frame, masks.shape[0], len(stream)) + stream)


def encode_shape_units(masks: np.ndarray, gop: int = DEFAULT_GOP) -> list[ShapeUnit]:
    """Code masks (T, H, W) bool as units of `gop` frames (1..255), each independently decodable."""
    masks = np.asarray(masks)
    if masks.ndim != 3 or masks.shape[0] < 1:
        raise SigncastError(f"shape masks must be (T, H, W) with T >= 1, got {masks.shape}")
    if not 1 <= gop <= 255:
        raise SigncastError(f"shape unit GOP must be 1..255 frames, got {gop}")
    return [encode_shape_unit(masks[start:start + gop], start, gop) for start in range(0, masks.shape[0], gop)]


def _parse_unit(data: bytes, at: int) -> tuple[int, np.ndarray, int] | None:
    """(first_frame, masks (n, H, W) bool, end offset) of the unit whose start code is at `at`, or None."""
    if at + HEADER_SIZE > len(data):
        return None
    header = data[at:at + HEADER_SIZE]
    if crc8_bits(header, 8 * len(START_CODE), 8 * (HEADER_SIZE - 1)) != header[-1]:
        return None
    first_frame, n_frames = _FIELDS.unpack_from(header, len(START_CODE))
    length = int.from_bytes(header[len(START_CODE) + _FIELDS.size:HEADER_SIZE - 1], "big")
    end = at + HEADER_SIZE + length
    if n_frames == 0 or end > len(data):
        return None
    try:
        masks = decode_shape(data[at + HEADER_SIZE:end])
    except SigncastError:
        return None
    if masks.shape[0] != n_frames:
        return None
    return first_frame, masks, end


def find_shape_units(data: bytes) -> tuple[list[tuple[int, np.ndarray]], int]:
    """Every intact unit in a received byte stream, resynchronising at the next start code after damage.

    Returns ([(first_frame, masks (n, H, W) bool), ...] in stream order, skipped bytes: those not in an intact
    unit). Never raises on any bytes.
    """
    data = bytes(data)
    units: list[tuple[int, np.ndarray]] = []
    used, position = 0, 0
    while True:
        at = data.find(START_CODE, position)
        if at < 0:
            break
        parsed = _parse_unit(data, at)
        if parsed is None:
            position = at + 1
            continue
        first_frame, masks, end = parsed
        units.append((first_frame, masks))
        used += end - at
        position = end
    return units, len(data) - used


def assemble_shape(units: Iterable[tuple[int, np.ndarray]], n_frames: int, height: int,
                   width: int) -> tuple[np.ndarray, np.ndarray, int]:
    """Place received units on the clip's frames and conceal the rest.

    units: (first_frame, masks (n, H, W) bool) as find_shape_units returns them; units of another size are
    ignored (treated as lost), frames past n_frames dropped. Returns masks (n_frames, height, width) bool,
    received (n_frames,) bool, and the number of concealed frames: a frame not received holds the last
    received mask; before the first received frame the object is fully transparent (not shown).
    """
    if n_frames < 0 or height < 1 or width < 1:
        raise SigncastError(f"cannot assemble {n_frames} frames of {width}x{height} shape masks")
    masks = np.zeros((n_frames, height, width), bool)
    received = np.zeros(n_frames, bool)
    for first_frame, unit_masks in units:
        unit_masks = np.asarray(unit_masks)
        if unit_masks.ndim != 3 or unit_masks.shape[1:] != (height, width) or not 0 <= first_frame < n_frames:
            continue
        count = min(unit_masks.shape[0], n_frames - first_frame)
        masks[first_frame:first_frame + count] = unit_masks[:count]
        received[first_frame:first_frame + count] = True
    for t in range(1, n_frames):
        if not received[t]:
            masks[t] = masks[t - 1]
    return masks, received, int(n_frames - received.sum())

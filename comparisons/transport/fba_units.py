"""Live FBA: a stream cut into independently decodable units that a receiver resynchronises on.

The unit layer is not tied to FBA: `wrap_unit` puts any self-contained stream of a group of frames behind the
same header, and a `UnitScanner` takes the payload's decoder and first bytes. `signcast live` sends BBA so too,
one BBA stream (header, intra unit, predicted units) per unit: the BBA header's ranges come from the frames it
covers, so a live sender can only write it once those frames are captured.

One FBA stream (comparisons/params/fba.py) has one CRC-32 at its end and no resynchronisation, so
one damaged byte loses the whole clip. A live FBA stream is instead a sequence of units, each
covering `refresh` consecutive frames (the intra refresh period, chosen by the caller):

    unit_start_code   0x000001C4   (4 bytes; a start code value that ISO/IEC 14496-2 Table 6-3
                                    lists as reserved: signcast's own, not MPEG-4's)
    first_frame       u32          index of the unit's first frame in the clip
    n_frames          u16          frames in the unit, 1..65535
    payload_length    u24          bytes of the payload
    header_crc        u8           CRC-8 (polynomial 0x07, initial 0) of the 10 bytes before it,
                                   from the start code's last byte 0xC4 on (as the BBA stream's CRCs)
    payload                        one complete FBA stream of those frames (encode_fba with one
                                   intra period covering the unit: it starts with an intra plane
                                   and ends with its own CRC-32), so the unit decodes alone

A receiver scans for the start code, checks the header's CRC-8, that the payload starts with
fba_object_start_code, decodes the payload (its CRC-32 catches damage) and checks that it holds
n_frames frames; anything that fails is damage, and the scan resumes at the next 0x000001C4
after the failed candidate's first byte. The header fields and the payload's CRC-32 are raw bytes,
so they can emulate the start code (first_frame 452 is 00 00 01 C4): such a false candidate is
rejected by the CRC-8 (all single-byte errors, 255/256 of random headers) and by the payload checks,
and a scan that decoded a unit continues after it, never inside it. A header's CRC-8 detects every
single-byte error, a payload's CRC-32 likewise, so one damaged byte loses exactly one unit.

Overhead per unit (UNIT_OVERHEAD_BYTES): 14 bytes of unit header, plus what every embedded stream
repeats: next_start_code() stuffing and fba_object_start_code (5), stuffing (0-1) and the end code
(4), and the CRC-32 (4): 27-28 bytes, plus the rate cost of an intra plane at every unit.

Memory: n_frames is at most 65535 and decode_fba is given it as max_frames, so a unit never decodes
to more; a scanner buffers at most one unit (14 + payload_length < 2^24 + 14 bytes) beyond the
chunk being fed. A live scanner waits for a unit's payload_length bytes: when bytes inside a unit
were lost, the units after it are found once those bytes have come (decoding then fails and the scan
resumes after the damaged unit's start code), so loss delays them but does not lose them.

Rate against refresh period (DEFAULT_REFRESH chosen here): ASL "HELLO" fingerspelled (80 frames,
BAPs and FAPs), 25 fps, Q = 4, kbit/s of the concatenated units; one FBA stream (intra period 32 /
4 DCT segments) for contrast:

    refresh (frames)    4      8      12     16     25     32    one stream
    pred             23.52  19.04  15.24  13.73  12.53  11.69    11.50
    dct              14.39  12.42  12.21  12.15  11.76  11.83    11.58

A predictive unit pays range fields and absolute levels at its intra plane, so its rate falls up to
16 frames and slowly after; a DCT unit's intra segment costs little, so DCT is nearly flat. 16 frames
(640 ms of look-ahead at 25 fps, one DCT segment) costs +19 % (pred) / +5 % (dct) over one stream;
8 frames would cost +66 % for pred, and 32 frames doubles the latency and the frames one damaged
byte takes with it to save 2 kbit/s.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from comparisons.params import fba as fba_codec
from comparisons.params import coding as pc
from comparisons.params.bits import START_CODE_PREFIX, crc8_bits
from comparisons.params.fba import DecodedFba, decode_fba, encode_fba
from media.errors import SigncastError

UNIT_START_CODE = 0xC4
UNIT_PREFIX = START_CODE_PREFIX + bytes([UNIT_START_CODE])
HEADER_BYTES = 14                   # start code 4, first_frame 4, n_frames 2, payload_length 3, CRC-8 1
MAX_UNIT_FRAMES = 0xFFFF            # n_frames u16
MAX_PAYLOAD_BYTES = 0xFFFFFF        # payload_length u24
MAX_FIRST_FRAME = 0xFFFFFFFF        # first_frame u32
DEFAULT_REFRESH = 16                # frames; see the table in the module docstring
UNIT_OVERHEAD_BYTES = (27, 28)      # header + embedded stuffing, start and end codes, CRC-32 (min, max)
# an FBA stream's first bytes: next_start_code() stuffing (aligned: 0111 1111), fba_object_start_code
FBA_PAYLOAD_PREFIX = b"\x7f" + START_CODE_PREFIX + bytes([fba_codec.OBJECT_START_CODE])


@dataclass(frozen=True)
class FbaUnit:
    """One coded unit: frames first_frame .. first_frame + n_frames - 1 of the clip; data: its bytes
    (header and payload)."""
    first_frame: int
    n_frames: int
    data: bytes


@dataclass(frozen=True, eq=False)
class DecodedUnit:
    """A unit that arrived intact: its frames first_frame .. first_frame + n_frames - 1, decoded (a DecodedFba,
    or what the scanner's payload decoder returns)."""
    first_frame: int
    n_frames: int
    decoded: DecodedFba


@dataclass(frozen=True, eq=False)
class ReceivedFba:
    """What a receiver rebuilds of a clip of T frames from the units that arrived.

    baps: (T, 296) int64 BAP units, None for a face-only stream; faps: (T, 68) int64 FAP units, None
    when no unit carried the face; face_frames: (T,) bool (None with faps); fps: frames per second
    (of the first unit kept); received: (T,) bool, the frames decoded from a unit (the others are
    concealed); lost_units: runs (first_frame, n_frames) of the frames not received; concealed: their
    count."""
    baps: np.ndarray | None
    faps: np.ndarray | None
    face_frames: np.ndarray | None
    fps: float
    received: np.ndarray
    lost_units: list[tuple[int, int]] = field(default_factory=list)
    concealed: int = 0


def _header(first_frame: int, n_frames: int, payload_length: int) -> bytes:
    head = (UNIT_PREFIX + first_frame.to_bytes(4, "big") + n_frames.to_bytes(2, "big")
            + payload_length.to_bytes(3, "big"))
    return head + bytes([crc8_bits(head, 24, 8 * len(head))])


def encode_fba_units(values: np.ndarray | None, fps: float, q: int, coding: str = "pred", *,
                     faps: np.ndarray | None = None, fap_quant: int | None = None,
                     face_frames: np.ndarray | None = None, refresh: int = DEFAULT_REFRESH) -> list[FbaUnit]:
    """A live FBA stream of BAP values (T, 296) and/or FAP values (T, 68) at `fps`: one unit per
    `refresh` frames (1..65535), each a complete FBA stream (the arguments are encode_fba's, with
    the same errors). The stream is b"".join(unit.data for unit in units)."""
    if isinstance(refresh, bool) or not isinstance(refresh, (int, np.integer)) or not 1 <= refresh <= MAX_UNIT_FRAMES:
        raise SigncastError(f"the refresh period must be 1..{MAX_UNIT_FRAMES} frames, got {refresh!r}")
    refresh = int(refresh)
    q = pc.check_q(q)
    checked_fap_quant = q if fap_quant is None else pc.check_q(fap_quant, "fap_quant")
    face, body, face_frames = fba_codec._checked_tracks(values, faps, face_frames, q, checked_fap_quant)
    if coding not in ("pred", "dct"):
        raise SigncastError(f"unknown FBA coding {coding!r}: choose 'pred' or 'dct'")
    units = []
    for start in range(0, len(face_frames), refresh):
        stop = min(start + refresh, len(face_frames))
        n = stop - start
        payload = encode_fba(None if body is None else body.values[start:stop], fps, q, coding,
                             faps=None if face is None else face.values[start:stop], fap_quant=fap_quant,
                             face_frames=None if face is None else face_frames[start:stop],
                             intra_period=n, intra_segments=-(-n // pc.SEGMENT))
        units.append(FbaUnit(start, n, wrap_unit(start, n, payload)))
    return units


def wrap_unit(first_frame: int, n_frames: int, payload: bytes) -> bytes:
    """One unit's bytes: the header for frames first_frame .. first_frame + n_frames - 1, then `payload`, a
    self-contained stream of those frames (an FBA stream here; `signcast live` also carries BBA streams so)."""
    if not 0 <= first_frame <= MAX_FIRST_FRAME or not 1 <= n_frames <= MAX_UNIT_FRAMES:
        raise SigncastError(f"a unit covers frames 0..{MAX_FIRST_FRAME}, 1..{MAX_UNIT_FRAMES} at a time; got "
                            f"{n_frames} from {first_frame}")
    if len(payload) > MAX_PAYLOAD_BYTES:
        raise SigncastError(f"a unit of {n_frames} frames takes {len(payload)} bytes, above the unit's "
                            f"{MAX_PAYLOAD_BYTES}: use a shorter refresh period")
    return _header(first_frame, n_frames, len(payload)) + bytes(payload)


def decode_fba_payload(payload: bytes, n_frames: int) -> DecodedFba:
    """The FBA stream of a unit of n_frames frames; SigncastError when it is damaged or holds another count."""
    fba = decode_fba(payload, max_frames=n_frames)
    if fba.n_frames != n_frames:
        raise SigncastError(f"an FBA unit announces {n_frames} frames and holds {fba.n_frames}")
    return fba


def _decode_at(buffer: bytes | bytearray, position: int, final: bool, decode_payload: Callable,
               prefix: bytes) -> tuple[str, DecodedUnit | None, int]:
    """Try the candidate unit whose start code is at `position` of `buffer`: ("ok", unit, end),
    ("wait", None, 0) when its bytes are not all there yet (never when final), or ("bad", None, 0)."""
    if len(buffer) - position < HEADER_BYTES:
        return ("bad" if final else "wait"), None, 0
    head = bytes(buffer[position:position + HEADER_BYTES])
    if crc8_bits(head, 24, 8 * (HEADER_BYTES - 1)) != head[-1]:
        return "bad", None, 0
    first_frame = int.from_bytes(head[4:8], "big")
    n_frames = int.from_bytes(head[8:10], "big")
    length = int.from_bytes(head[10:13], "big")
    prefixes = prefix if isinstance(prefix, tuple) else (prefix,)
    if n_frames == 0 or length < max(min(map(len, prefixes)), 1):
        return "bad", None, 0
    payload_start = position + HEADER_BYTES
    seen = bytes(buffer[payload_start:payload_start + max(map(len, prefixes))])
    if not any(seen[:len(p)] == p[:len(seen)] for p in prefixes):
        return "bad", None, 0
    end = payload_start + length
    if end > len(buffer):
        return ("bad" if final else "wait"), None, 0
    try:
        decoded = decode_payload(bytes(buffer[payload_start:end]), n_frames)
    except SigncastError:
        return "bad", None, 0
    return "ok", DecodedUnit(first_frame, n_frames, decoded), end


class UnitScanner:
    """Incremental unit finder for a live receiver that gets the stream's bytes packet by packet; payload_prefix
    is the first bytes of every payload, or a tuple of the kinds of payload that may follow a unit header.

    feed(chunk) returns the units completed by the chunk; bytes that belong to no intact unit are
    dropped and counted in `skipped`. The buffer holds at most one unit being received (and the
    3 bytes that could start a start code) beyond the chunk fed. finish() ends the stream: a unit
    still incomplete is damage, and what follows it is scanned."""

    def __init__(self, decode_payload: Callable = decode_fba_payload, payload_prefix: bytes = FBA_PAYLOAD_PREFIX) -> None:
        self.buffer = bytearray()
        self.skipped = 0
        self.decode_payload, self.payload_prefix = decode_payload, payload_prefix

    def feed(self, chunk: bytes) -> list[DecodedUnit]:
        self.buffer += chunk
        return self._scan(final=False)

    def finish(self) -> list[DecodedUnit]:
        units = self._scan(final=True)
        self.skipped += len(self.buffer)
        self.buffer.clear()
        return units

    def _scan(self, final: bool) -> list[DecodedUnit]:
        units = []
        buffer = self.buffer
        position = 0
        while True:
            candidate = buffer.find(UNIT_PREFIX, position)
            if candidate < 0:
                keep = len(buffer) if final else max(position, len(buffer) - len(UNIT_PREFIX) + 1)
                self.skipped += keep - position
                position = keep
                break
            self.skipped += candidate - position
            status, unit, end = _decode_at(buffer, candidate, final, self.decode_payload, self.payload_prefix)
            if status == "wait":
                position = candidate
                break
            if status == "ok":
                units.append(unit)
                position = end
            else:
                self.skipped += 1
                position = candidate + 1
        del buffer[:position]
        return units


def find_units(data: bytes) -> tuple[list[DecodedUnit], int]:
    """(the intact units of a live FBA stream's bytes, in stream order; the number of bytes that
    belong to none). The bytes may be damaged, cut or missing anywhere: the scan resynchronises at
    the next unit start code. Never raises on any input."""
    scanner = UnitScanner()
    units = scanner.feed(bytes(data))
    units += scanner.finish()
    return units, scanner.skipped


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(first index, length) of each run of True in the 1-D bool `mask`."""
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    return [(int(a), int(b - a)) for a, b in zip(starts, stops)]


def assemble(units: list[DecodedUnit], n_frames: int, conceal: str = "hold") -> ReceivedFba:
    """The clip of n_frames frames rebuilt from `units` (find_units' output, any order).

    A frame of no unit is concealed: "hold" repeats the last received frame (the first received one
    before any); "interpolate" is linear between the received frames around the gap, rounded to
    integers, holding at the clip's ends. Where units overlap, the first in the list is kept; a
    unit whose BAP presence or fps differs from the first kept one is ignored (damage), as are frames
    at or beyond n_frames. SigncastError when no unit arrived."""
    if conceal not in ("hold", "interpolate"):
        raise SigncastError(f"unknown concealment {conceal!r}: choose 'hold' or 'interpolate'")
    if isinstance(n_frames, bool) or not isinstance(n_frames, (int, np.integer)) or not 1 <= n_frames <= fba_codec.MAX_FRAMES:
        raise SigncastError(f"the clip length must be 1..{fba_codec.MAX_FRAMES} frames, got {n_frames!r}")
    n_frames = int(n_frames)
    kept = []
    taken = np.zeros(n_frames, dtype=bool)
    for unit in units:
        start, stop = unit.first_frame, min(unit.first_frame + unit.n_frames, n_frames)
        if start >= n_frames or (kept and ((unit.decoded.baps is None) != (kept[0][2].baps is None)
                                           or unit.decoded.fps != kept[0][2].fps)):
            continue
        fresh = ~taken[start:stop]
        if fresh.any():
            kept.append((start, stop, unit.decoded, fresh))
            taken[start:stop] = True
    if not kept:
        raise SigncastError("no unit of the stream arrived")
    reference = kept[0][2]
    has_face = any(fba.faps is not None for _, _, fba, _ in kept)
    baps = None if reference.baps is None else np.zeros((n_frames, fba_codec.BAPS.count), dtype=np.int64)
    faps = np.zeros((n_frames, fba_codec.FAPS.count), dtype=np.int64) if has_face else None
    face_frames = np.zeros(n_frames, dtype=bool) if has_face else None
    for start, stop, fba, fresh in kept:
        frames = start + np.flatnonzero(fresh)
        rows = frames - start
        if baps is not None:
            baps[frames] = fba.baps[rows]
        if has_face and fba.faps is not None:
            faps[frames] = fba.faps[rows]
            face_frames[frames] = fba.face_frames[rows]
    received = taken
    lost = _runs(~received)
    got = np.flatnonzero(received)
    missing = np.flatnonzero(~received)
    if len(missing):
        index = np.searchsorted(got, missing)                  # received frames before each missing one
        before = got[np.where(index > 0, index - 1, index)]     # the last received before (none: first after)
        after = got[np.where(index < len(got), index, index - 1)]   # the first received after (none: last before)
        for array in (baps, faps):
            if array is None:
                continue
            if conceal == "hold":
                array[missing] = array[before]
            else:
                span = np.maximum(after - before, 1)
                weight = ((missing - before) / span)[:, None]
                mixed = array[before] + weight * (array[after] - array[before])
                array[missing] = np.round(mixed).astype(np.int64)
        if face_frames is not None:
            face_frames[missing] = face_frames[before]
    return ReceivedFba(baps, faps, face_frames, reference.fps, received.copy(), lost, len(missing))


# ------------------------------------------------------------------------------------------------------------
# Low-delay units: one frame each, predicted from the frame before (issue 37)
#
# A unit of `refresh` frames can only leave once its last frame is captured, so its first frame waits
# refresh - 1 frame intervals (8 frames at 25 fps: 280 ms before any network). In low-delay mode every frame
# is its own unit, sent as soon as it is captured:
# - an intra frame every `refresh` frames: a unit whose payload is the parameter codec's own stream of that one
#   frame (FBA or BBA, decodable alone, exactly as above);
# - every other frame a predicted ("delta") unit, behind the same unit header (first_frame = the frame,
#   n_frames = 1), predicted from the period's intra frame (not from the frame before: a lost delta unit costs
#   its own frame only, and a lost intra unit its period), whose payload is signcast's own:
#
#     prefix            7F 00 00 01 C6   (stuffing as the codec streams, and a start code value ISO/IEC 14496-2
#                                         lists as reserved, like 0xC4 and 0xC5)
#     reference         u32   the intra frame it is predicted from
#     q                 u8    1..31
#     n_bones           u16   bones of the motion, 1..MAX_DELTA_BONES
#     has_faps          u8    0 or 1
#     n_new             u8    bones the frame before did not have (a BBA stream leaves out bones at rest), added
#                             at rest (identity) after its bones before the levels; each: length u8, UTF-8 name
#     levels            bits: per bone a flag (1: moved) and, when it moved, three signed Exp-Golomb levels of
#                       the rotation vector from the previous frame's rotation to this one, in steps of
#                       ROTATION_STEP x q rad; a flag and three levels for the root translation (steps of
#                       TRANSLATION_STEP x q m); with FAPs, a flag and 68 signed levels (FAP units, exact);
#                       zero bits to the byte
#     crc32             u32   zlib CRC-32 of everything before it
#
#   The levels are closed-loop: the sender predicts from the intra frame as the receiver rebuilt it, so errors
#   do not add up; each rotation is within half a step per component (of the rotation vector) of the codec's
#   own decode of that frame (what an intra unit of it would show). A delta unit needs its intra frame: the
#   receiver applies it only when it holds that frame, and otherwise conceals it.

import zlib as _zlib

DELTA_START_CODE = 0xC6
DELTA_PREFIX = b"\x7f" + START_CODE_PREFIX + bytes([DELTA_START_CODE])
ROTATION_STEP = 2e-4            # rad per unit of q: q 4 -> 8e-4 rad (0.046 degrees)
TRANSLATION_STEP = 2.5e-4       # m per unit of q: q 4 -> 1 mm
MAX_DELTA_BONES = 1024
MAX_GOLOMB_BITS = 40            # levels up to 2^40: far beyond any real step, and bounded work per value
N_FAP_VALUES = 68


@dataclass(frozen=True, eq=False)
class FrameState:
    """One rebuilt frame: rotations (B, 4) unit quaternions, root (3,) metres, faps (68,) int64 or None."""
    rotations: np.ndarray
    root: np.ndarray
    faps: np.ndarray | None = None

    @classmethod
    def last_of(cls, motion) -> "FrameState":
        return cls(np.array(motion.rotations[-1], dtype=np.float64), np.array(motion.root_translation[-1], np.float64),
                   None if motion.faps is None else np.array(motion.faps[-1], dtype=np.int64))


@dataclass(frozen=True, eq=False)
class DeltaPayload:
    """A delta unit's payload, checked (prefix, sizes, CRC-32) but not yet applied: q, n_bones, has_faps and the
    level bits."""
    q: int
    n_bones: int
    has_faps: bool
    bits: bytes
    new_bones: tuple[str, ...] = ()
    reference: int = 0


def _rotation_vectors(q: np.ndarray) -> np.ndarray:
    """(..., 3) rotation vectors of unit quaternions (w, x, y, z), the shorter way round."""
    q = np.where(q[..., :1] < 0, -q, q)
    vector = q[..., 1:]
    sine = np.linalg.norm(vector, axis=-1, keepdims=True)
    angle = 2.0 * np.arctan2(sine, np.clip(q[..., :1], -1.0, 1.0))
    scale = np.where(sine > 1e-12, angle / np.maximum(sine, 1e-300), 2.0)
    return vector * scale


def _quaternions(vectors: np.ndarray) -> np.ndarray:
    angle = np.linalg.norm(vectors, axis=-1, keepdims=True)
    half = angle / 2.0
    scale = np.where(angle > 1e-12, np.sin(half) / np.maximum(angle, 1e-300), 0.5)
    return np.concatenate([np.cos(half), vectors * scale], axis=-1)


def _multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    aw, ax, ay, az = np.moveaxis(a, -1, 0)
    bw, bx, by, bz = np.moveaxis(b, -1, 0)
    return np.stack([aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw], axis=-1)


def _conjugate(q: np.ndarray) -> np.ndarray:
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def _golomb(bits: list[str], value: int) -> None:
    code = 2 * value - 1 if value > 0 else -2 * value          # signed -> unsigned, as H.264's se(v)
    text = bin(code + 1)[2:]
    bits.append("0" * (len(text) - 1) + text)


class _Bits:
    def __init__(self, data: bytes):
        self.text = "".join(f"{byte:08b}" for byte in data)
        self.pos = 0

    def bit(self) -> int:
        if self.pos >= len(self.text):
            raise SigncastError("a delta unit ends inside its levels")
        self.pos += 1
        return self.text[self.pos - 1] == "1"

    def golomb(self) -> int:
        zeros = 0
        while not self.bit():
            zeros += 1
            if zeros > MAX_GOLOMB_BITS:
                raise SigncastError("a delta unit holds a level beyond its range")
        end = self.pos + zeros
        if end > len(self.text):
            raise SigncastError("a delta unit ends inside its levels")
        code = (1 << zeros) - 1 + (int(self.text[self.pos:end], 2) if zeros else 0)
        self.pos = end
        return (code + 1) // 2 if code % 2 else -(code // 2)


def _levels(bits: list[str], levels: np.ndarray) -> None:
    for row in levels:
        if row.any():
            bits.append("1")
            for value in row:
                _golomb(bits, int(value))
        else:
            bits.append("0")


def with_new_bones(reference: FrameState, n_new: int) -> FrameState:
    """`reference` with n_new bones at rest (identity) after its own."""
    if not n_new:
        return reference
    rest = np.tile([1.0, 0.0, 0.0, 0.0], (n_new, 1))
    return FrameState(np.concatenate([reference.rotations, rest]), reference.root, reference.faps)


def encode_delta(reference: FrameState, target: FrameState, q: int,
                 new_bones: tuple[str, ...] = (), reference_frame: int = 0) -> tuple[bytes, FrameState]:
    """(a delta unit's payload taking `reference` (frame reference_frame) to `target`, the frame the receiver
    will rebuild from it). new_bones: names of bones `target` has after those of `reference` (their rows last)."""
    q = pc.check_q(q)
    if not 0 <= reference_frame <= MAX_FIRST_FRAME:
        raise SigncastError(f"a delta unit's reference frame must be 0..{MAX_FIRST_FRAME}")
    names = [name.encode() for name in new_bones]
    if len(names) > 255 or any(not 1 <= len(name) <= 255 for name in names):
        raise SigncastError("a delta unit adds at most 255 bones, each named in 1..255 bytes")
    reference = with_new_bones(reference, len(names))
    n_bones = len(reference.rotations)
    if not 1 <= n_bones <= MAX_DELTA_BONES or target.rotations.shape != reference.rotations.shape:
        raise SigncastError(f"a delta unit carries 1..{MAX_DELTA_BONES} bones, the same in both frames")
    if (reference.faps is None) != (target.faps is None):
        raise SigncastError("a delta unit cannot start or stop the face: that takes an intra unit")
    step, move = ROTATION_STEP * q, TRANSLATION_STEP * q
    turn = _rotation_vectors(_multiply(_conjugate(reference.rotations), target.rotations))
    rotation_levels = np.round(turn / step).astype(np.int64)
    rotations = _multiply(reference.rotations, _quaternions(rotation_levels * step))
    rotations /= np.linalg.norm(rotations, axis=-1, keepdims=True)
    root_levels = np.round((target.root - reference.root) / move).astype(np.int64)
    root = reference.root + root_levels * move
    bits: list[str] = []
    _levels(bits, rotation_levels)
    _levels(bits, root_levels[None])
    faps = None
    if target.faps is not None:
        fap_levels = (np.asarray(target.faps, np.int64) - reference.faps)
        _levels(bits, fap_levels[None])
        faps = reference.faps + fap_levels
    text = "".join(bits)
    text += "0" * (-len(text) % 8)
    body = int(text, 2).to_bytes(len(text) // 8, "big") if text else b""
    head = (DELTA_PREFIX + int(reference_frame).to_bytes(4, "big") + bytes([q]) + n_bones.to_bytes(2, "big") + bytes([target.faps is not None])
            + bytes([len(names)]) + b"".join(bytes([len(name)]) + name for name in names))
    payload = head + body
    return payload + _zlib.crc32(payload).to_bytes(4, "big"), FrameState(rotations, root, faps)


def read_delta(payload: bytes) -> DeltaPayload:
    """A delta unit's payload checked (prefix, fields, CRC-32); SigncastError when damaged."""
    payload = bytes(payload)
    head = len(DELTA_PREFIX) + 9
    if len(payload) < head + 4 or not payload.startswith(DELTA_PREFIX):
        raise SigncastError("not a delta unit")
    if _zlib.crc32(payload[:-4]).to_bytes(4, "big") != payload[-4:]:
        raise SigncastError("a delta unit fails its CRC-32")
    reference = int.from_bytes(payload[5:9], "big")
    q, n_bones, has_faps, n_new = payload[9], int.from_bytes(payload[10:12], "big"), payload[12], payload[13]
    if not 1 <= q <= 31 or not 1 <= n_bones <= MAX_DELTA_BONES or has_faps > 1 or n_new > n_bones:
        raise SigncastError("a delta unit with a bad q, bone count, face flag or new bones")
    names = []
    for _ in range(n_new):
        size = payload[head] if head < len(payload) - 4 else 0
        name = payload[head + 1:head + 1 + size]
        if not size or len(name) < size or head + 1 + size > len(payload) - 4:
            raise SigncastError("a delta unit ends inside its new bones' names")
        try:
            names.append(name.decode())
        except UnicodeDecodeError:
            raise SigncastError("a delta unit names a bone in bytes that are not UTF-8") from None
        head += 1 + size
    if len(set(names)) != len(names):
        raise SigncastError("a delta unit adds the same bone twice")
    return DeltaPayload(q, n_bones, bool(has_faps), payload[head:-4], tuple(names), reference)


def apply_delta(delta: DeltaPayload, reference: FrameState) -> FrameState:
    """The frame a delta unit rebuilds from `reference` (the frame before it; the unit's new bones are added to
    it at rest); SigncastError when they do not match (bones, face) or the levels are damaged."""
    reference = with_new_bones(reference, len(delta.new_bones))
    if delta.n_bones != len(reference.rotations) or delta.has_faps != (reference.faps is not None):
        raise SigncastError("a delta unit does not fit the frame before it (bones or face)")
    bits = _Bits(delta.bits)

    def rows(n_rows: int, width: int) -> np.ndarray:
        out = np.zeros((n_rows, width), np.int64)
        for k in range(n_rows):
            if bits.bit():
                out[k] = [bits.golomb() for _ in range(width)]
        return out

    rotation_levels = rows(delta.n_bones, 3)
    root_levels = rows(1, 3)[0]
    fap_levels = rows(1, N_FAP_VALUES)[0] if delta.has_faps else None
    if bits.text[bits.pos:].strip("0") or len(bits.text) - bits.pos >= 8:
        raise SigncastError("a delta unit holds bytes after its levels")
    step, move = ROTATION_STEP * delta.q, TRANSLATION_STEP * delta.q
    turn = rotation_levels * step
    if not np.all(np.isfinite(turn)) or np.abs(root_levels).max(initial=0) * move > 1e3:
        raise SigncastError("a delta unit moves beyond any body")
    rotations = _multiply(reference.rotations, _quaternions(turn))
    rotations /= np.linalg.norm(rotations, axis=-1, keepdims=True)
    faps = None if fap_levels is None else reference.faps + fap_levels
    return FrameState(rotations, reference.root + root_levels * move, faps)

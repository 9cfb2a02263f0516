"""Fuzz targets: one function per decoder or reader of signcast, `target(data: bytes) -> None`.

A target decodes `data` with the real decoder. Two outcomes pass: SigncastError (a clean rejection;
the target lets it propagate and `run` turns it into "rejected"), or a decode that passes the
target's oracle ("decoded"). Anything else propagates: another exception type from the decoder, or
DecodeMismatch from the oracle, is a finding. Hangs (> 1 s) and memory (> 1 GB) are watched by the
fuzzer (benchmarks/fuzz.py), not here.

Oracles, where a decode succeeds: the result has the announced shape and finite values, decoding
is deterministic (the same bytes decode to the same values twice), and, where the format has an
encoder, the decoded values survive the encoder: lossless formats (shape, .bap, BBA-XML, records,
BVH) give them back exactly (BVH to 1e-6), and quantising coders (FBA, BBA predictive) give them
back once they lie on the encoder's grid. A binary BBA stream must also be a valid BBA-XML stream.

Checksums are repaired before decoding (FBA, shape, motion coders: CRC-32 in a fixed place), so
mutations reach the parser behind them instead of stopping at the checksum test; a corpus file,
already valid, is unchanged by the repair. BBA's CRC-8 per unit is left as is (the fuzzer's
comparison tracing learns one byte). Readers that take a path get the bytes through a temporary file.
"""
from __future__ import annotations

import atexit
import functools
import shutil
import struct
import tempfile
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from media.errors import SigncastError

ROUND_TRIP_LIMIT = 64            # frames (or 64 k shape pixels): larger decodes skip the encoder oracle,
SHAPE_ROUND_TRIP_PIXELS = 1 << 16  # so that the oracle alone never approaches the 1 s budget per input
# The encoders of FBA, BBA, shape and BVH cost 5-10 decodes: the fuzzer (benchmarks/fuzz.py) runs their
# oracle on one input in ENCODER_ORACLE_EVERY, chosen by the input's CRC so that a finding reproduces.
ENCODER_ORACLE_EVERY = 1


class DecodeMismatch(AssertionError):
    """A decode that succeeded but is not correct: a finding, like an unexpected exception."""


def _unchanged(data: bytes) -> bytes:
    return data


@dataclass(frozen=True)
class Target:
    """name: the corpus folder under tests/fuzz/corpus/; decode: the target; what: the decoder, in words;
    seal: repairs the input's checksums before decode (identity where none is repaired)."""
    name: str
    decode: Callable[[bytes], None]
    what: str
    seal: Callable[[bytes], bytes] = _unchanged


def _expect(condition: bool, message: str) -> None:
    if not condition:
        raise DecodeMismatch(message)


def _check_fps(fps: float) -> None:
    _expect(isinstance(fps, float) and np.isfinite(fps) and fps > 0,
            f"decoded frame rate {fps!r} is not a positive number")


def _check_array(values: np.ndarray, shape: tuple, dtype=None) -> None:
    """shape: expected sizes, None where any size >= 1 goes."""
    _expect(isinstance(values, np.ndarray) and values.ndim == len(shape)
            and all(s is None and n >= 1 or n == s for n, s in zip(values.shape, shape)),
            f"decoded array of shape {getattr(values, 'shape', None)}, expected {shape}")
    if dtype is not None:
        _expect(values.dtype == dtype, f"decoded array of dtype {values.dtype}, expected {dtype}")
    _expect(values.dtype == bool or bool(np.all(np.isfinite(values))), "decoded array holds NaN or infinite values")


def _same(first, second, what: str) -> None:
    if isinstance(first, np.ndarray):
        _expect(isinstance(second, np.ndarray) and first.shape == second.shape and np.array_equal(first, second),
                f"{what} differ")
    else:
        _expect(first == second, f"{what} differ")


@functools.lru_cache(maxsize=1)
def _scratch() -> Path:
    folder = Path(tempfile.mkdtemp(prefix="signcast-fuzz-"))
    atexit.register(shutil.rmtree, folder, True)
    return folder


def _as_file(data: bytes, suffix: str) -> Path:
    path = _scratch() / f"input{suffix}"
    path.write_bytes(data)
    return path


def _scratch_path(suffix: str) -> Path:
    return _scratch() / f"oracle{suffix}"


def _encoder_oracle_due(data: bytes) -> bool:
    return zlib.crc32(data) % ENCODER_ORACLE_EVERY == 0


# ------------------------------------------------------------------------------------------ FBA

def seal_fba(data: bytes) -> bytes:
    """The stream with its trailing CRC-32 (big-endian, over all bytes before it) recomputed."""
    if len(data) < 4:
        return data
    return data[:-4] + zlib.crc32(data[:-4]).to_bytes(4, "big")


def fba(data: bytes) -> None:
    from comparisons.params import bap_table
    from comparisons.params import fap_table
    from comparisons.params.fba import decode_fba, encode_fba

    decoded = decode_fba(data)
    _expect(decoded.baps is not None or decoded.faps is not None, "FBA stream decoded to neither BAPs nor FAPs")
    n_frames = decoded.n_frames
    if decoded.baps is not None:
        _check_array(decoded.baps, (n_frames, bap_table.N_BAPS), np.int64)
    if decoded.faps is not None:
        _check_array(decoded.faps, (n_frames, fap_table.N_FAPS), np.int64)
        _check_array(decoded.face_frames, (n_frames,), bool)
        _expect(not decoded.faps[~decoded.face_frames].any(), "FBA frames without the face hold FAPs other than 0")
    _check_fps(decoded.fps)
    again = decode_fba(data)
    for name in ("baps", "faps", "face_frames"):
        first, second = getattr(decoded, name), getattr(again, name)
        _expect((first is None) == (second is None), f"two decodes of the same FBA stream differ in {name}")
        if first is not None:
            _same(first, second, f"{name} of two decodes of the same FBA stream")
    _expect(again.fps == decoded.fps, "two decodes of the same FBA stream differ in frame rate")
    # Values on the Q = 1 grid (every predictive stream's are) come back exactly from the predictive coder.
    on_grid = ((decoded.baps is None or np.all(decoded.baps % bap_table.steps() == 0))
               and (decoded.faps is None or np.all(decoded.faps % fap_table.steps() == 0)))
    if n_frames <= ROUND_TRIP_LIMIT and on_grid and _encoder_oracle_due(data):
        try:
            stream = encode_fba(decoded.baps, decoded.fps, 1, "pred", faps=decoded.faps,
                                face_frames=decoded.face_frames)
        except SigncastError:
            return  # values the encoder cannot represent: not the decoder's business
        coded = decode_fba(stream)
        for name in ("baps", "faps"):
            if getattr(decoded, name) is not None:
                _same(getattr(coded, name), getattr(decoded, name), f"FBA {name} re-encoded at Q=1 and decoded again")


# ------------------------------------------------------------------------------------------ BBA

def _bba_values(stream) -> list:
    return [(f.kfi, f.bones, f.values) for f in stream.frames]


def _check_bba(stream) -> None:
    """A decoded BBA stream must also be a valid BBA-XML stream (its schema bounds values and IDs)."""
    from comparisons.params.bba_xml import from_xml, to_xml

    _check_fps(float(stream.header.fps))
    _expect(len(stream.frames) >= 1, "decoded BBA stream without frames")
    try:
        back = from_xml(to_xml(stream))
    except SigncastError as error:
        raise DecodeMismatch(f"decoded BBA stream is not a valid BBA stream: {error}") from None
    _same(_bba_values(back), _bba_values(stream), "BBA frames and their XML form")


def bba(data: bytes) -> None:
    from comparisons.params.bba import read_stream, write_stream

    stream, lost = read_stream(data)
    _expect(lost == [], f"strict BBA decode reports lost units {lost}")
    _check_bba(stream)
    _same(_bba_values(read_stream(data)[0]), _bba_values(stream), "two decodes of the same BBA stream")
    if stream.header.coding == "pred" and len(stream.frames) <= ROUND_TRIP_LIMIT and _encoder_oracle_due(data):
        # once re-encoded, values lie on the encoder's grid: a second round trip must not move them
        try:
            once = read_stream(write_stream(stream))[0]
            twice = read_stream(write_stream(once))[0]
        except SigncastError:
            return
        _same(_bba_values(twice), _bba_values(once), "BBA frames re-encoded a second time")


def bba_resilient(data: bytes) -> None:
    from comparisons.params.bba import read_stream

    stream, lost = read_stream(data, resilient=True)
    _check_bba(stream)
    _expect(lost == sorted(set(lost)) and all(i >= 0 for i in lost), f"lost units {lost} are not increasing indices")
    again, lost_again = read_stream(data, resilient=True)
    _same((_bba_values(again), lost_again), (_bba_values(stream), lost), "two resilient decodes of the same BBA stream")


def bba_xml(data: bytes) -> None:
    from comparisons.params.bba_xml import from_xml, to_xml

    stream = from_xml(data.decode("utf-8", errors="replace"))
    _check_fps(float(stream.header.fps))
    back = from_xml(to_xml(stream))
    _same(back, stream, "BBA-XML stream written and read again")


# ---------------------------------------------------------------------------------------- .bap

def bap(data: bytes) -> None:
    from comparisons.params import bap_table
    from comparisons.params.bap_file import format_bap, parse_bap, read_bap

    values, fps, name = read_bap(_as_file(data, ".bap"))
    _check_array(values, (len(values), bap_table.N_BAPS), np.int64)  # a .bap may hold 0 frames
    _check_fps(fps)
    back, fps_back, name_back = parse_bap(format_bap(values, fps, name))
    _same(back, values, ".bap values written and read again")
    _same(name_back, name, ".bap names written and read again")
    _expect(abs(fps_back - fps) <= 1e-5 * fps, f".bap frame rate {fps} comes back as {fps_back}")


def fap(data: bytes) -> None:
    from comparisons.params import fap_table
    from comparisons.params.fap_file import format_fap, parse_fap, read_fap

    faps, fps, name = read_fap(_as_file(data, ".fap"))
    _check_array(faps, (len(faps), fap_table.N_FAPS), np.int64)      # a .fap may hold 0 frames
    _check_fps(fps)
    back, fps_back, name_back = parse_fap(format_fap(faps, fps, name))
    _same(back, faps, ".fap values written and read again")
    _same(name_back, name, ".fap names written and read again")
    _expect(abs(fps_back - fps) <= 1e-5 * fps, f".fap frame rate {fps} comes back as {fps_back}")


# --------------------------------------------------------------------------------------- shape

def seal_shape(data: bytes) -> bytes:
    """The stream with the header's payload length set to the payload's, and its CRC-32 (the header's
    last field, over the header before it and the payload) recomputed."""
    from comparisons.video.shape import _HEADER

    if len(data) < _HEADER.size:
        return data
    fields = list(_HEADER.unpack_from(data))
    payload = data[_HEADER.size:]
    fields[-2] = len(payload)
    head = _HEADER.pack(*fields)[:-4]
    return head + zlib.crc32(payload, zlib.crc32(head)).to_bytes(4, "big") + payload


def shape(data: bytes) -> None:
    from comparisons.video.shape import _HEADER, decode_shape, encode_shape

    masks = decode_shape(data)
    _, _, width, height, frames, gop = _HEADER.unpack_from(data)[:6]
    _check_array(masks, (frames, height, width), bool)
    _same(decode_shape(data), masks, "two decodes of the same shape stream")
    # lossless: the masks re-encoded decode to themselves
    if masks.size <= SHAPE_ROUND_TRIP_PIXELS and _encoder_oracle_due(data):
        _same(decode_shape(encode_shape(masks, gop)[0]), masks, "shape masks re-encoded and decoded again")


# ------------------------------------------------------------------------------- motion coders

def seal_motion(data: bytes) -> bytes:
    """A motion-coder clip with its CRC-32s repaired: the compact layout's one (coded_streams.write_compact), or the
    inner stream's and the clip's (lab_codecs layout)."""
    from comparisons.lab.streams import COMPACT_MAGIC
    from comparisons.lab.codecs import dof_layout

    if data.startswith(COMPACT_MAGIC):              # its CRC starts from wavelet-cx's model tag
        from comparisons.lab.waveform import context_priors
        return data[:-4] + struct.pack("<I", zlib.crc32(data[:-4], context_priors().tag)) if len(data) > 4 else data
    head = 5 + -(-dof_layout().n_dofs // 8)       # magic, coder id, active-DOF mask
    if len(data) < head + 8:
        return data
    inner = data[head:-4]
    inner = inner[:-4] + struct.pack("<I", zlib.crc32(inner[:-4]))
    body = data[:head] + inner
    return body + struct.pack("<I", zlib.crc32(body))


def _motion_target(name: str) -> Callable[[bytes], None]:
    def decode(data: bytes) -> None:
        from comparisons.lab.codecs import LabCodec, dof_layout

        codec = LabCodec(name)
        dofs, fps = codec.decode_dofs(data)
        _check_array(dofs, (None, dof_layout().n_dofs), np.float64)
        _check_fps(float(fps))
        again, _ = codec.decode_dofs(data)
        _same(again, dofs, f"two decodes of the same {name} stream")
    decode.__name__ = f"motion_{name}"
    return decode


# ----------------------------------------------------------------------------------------- BVH

def bvh(data: bytes) -> None:
    from media import rotations
    from media.bvh import read_bvh, write_bvh

    motion, hierarchy = read_bvh(_as_file(data, ".bvh"))
    bones = len(hierarchy.names)
    _check_array(motion.rotations, (None, bones, 4), np.float64)
    _check_array(hierarchy.offsets, (bones, 3), np.float64)
    _check_fps(float(motion.fps))
    if motion.n_frames * bones > ROUND_TRIP_LIMIT * 32 or not _encoder_oracle_due(data):
        return
    try:
        copy = _scratch_path(".bvh")
        write_bvh(copy, motion, hierarchy.to_skeleton())
    except SigncastError:
        return  # a hierarchy the writer cannot express (e.g. two roots): not the reader's business
    back, _ = read_bvh(copy)
    _same(back.bone_names, motion.bone_names, "BVH bones written and read again")
    dots = np.abs(np.sum(rotations.canonical(back.rotations) * rotations.canonical(motion.rotations), axis=-1))
    _expect(bool(np.all(dots > 1 - 1e-9)), "BVH rotations written and read again differ")
    _expect(np.allclose(back.root_translation, motion.root_translation, atol=1e-8, rtol=1e-9),
            "BVH root translations written and read again differ")


# --------------------------------------------------------------------------------------- .pose

def pose(data: bytes) -> None:
    from media.pose_file import HOLISTIC_LAYOUT, read_pose

    clip = read_pose(data)
    _check_fps(float(clip.fps))
    _expect(tuple(clip.points) == tuple(name for name, _ in HOLISTIC_LAYOUT),
            "decoded components differ from the layout")
    for name, points in HOLISTIC_LAYOUT:
        _check_array(clip.points[name], (clip.n_frames, len(points), 3), np.float64)
        _check_array(clip.confidence[name], (clip.n_frames, len(points)), np.float64)
        _expect(bool(np.all((clip.confidence[name] >= 0) & (clip.confidence[name] <= 1))), "confidence outside [0, 1]")
    again = read_pose(data)
    for name, _ in HOLISTIC_LAYOUT:
        _same(again.points[name], clip.points[name], "two decodes of the same .pose")


# ------------------------------------------------------------------------------------- records

def records(data: bytes) -> None:
    from comparisons.reports.records import read_records
    from pipeline.outputs import write_records

    found = read_records(_as_file(data, ".jsonl"))
    _expect(isinstance(found, list) and all(isinstance(r, dict) for r in found), "records are not a list of objects")
    # write_records turns NaN into null, so compare from the first rewrite on
    once = read_records(write_records(_scratch_path(".jsonl"), found))
    twice = read_records(write_records(_scratch_path(".jsonl"), once))
    _same(twice, once, "records written and read again")


# ------------------------------------------------------------------------------- live delivery (issue 37)
# The live receiver's parsers: what arrives from the network. Inputs that carry several datagrams frame each as
# [u16 length][bytes] (big-endian); a length past the end takes what is left.

def _frames(data: bytes, head: int = 0) -> list[tuple[bytes, bytes]]:
    """(head bytes, body) of each length-prefixed record of `data` (head: bytes before the length)."""
    out, at = [], 0
    while at + head + 2 <= len(data):
        prefix = data[at:at + head]
        size = int.from_bytes(data[at + head:at + head + 2], "big")
        body = data[at + head + 2:at + head + 2 + size]
        out.append((prefix, body))
        at += head + 2 + size
    return out


def _seal_unit_at(data: bytearray, at: int) -> int:
    """Repair the CRC-8 of the unit header at `at` and its payload's trailing CRC-32; the unit's end."""
    from comparisons.params.bits import crc8_bits
    from comparisons.transport.fba_units import HEADER_BYTES
    head = data[at:at + HEADER_BYTES]
    if len(head) < HEADER_BYTES:
        return len(data)
    data[at + HEADER_BYTES - 1] = crc8_bits(bytes(head), 24, 8 * (HEADER_BYTES - 1))
    length = int.from_bytes(head[10:13], "big")
    end = min(len(data), at + HEADER_BYTES + length)
    payload = bytes(data[at + HEADER_BYTES:end])
    if len(payload) > 4:
        data[end - 4:end] = zlib.crc32(payload[:-4]).to_bytes(4, "big")
    return max(end, at + 1)


def seal_live_units(data: bytes) -> bytes:
    """A live parameter stream with every unit's header CRC-8 and payload CRC-32 repaired (units found where
    the start code is)."""
    from comparisons.transport.fba_units import UNIT_PREFIX
    out = bytearray(data)
    at = out.find(UNIT_PREFIX)
    while at >= 0:
        at = out.find(UNIT_PREFIX, _seal_unit_at(out, at))
    return bytes(out)


def _decode_live_payload(payload: bytes, n_frames: int):
    from comparisons.transport import fba_units
    if payload.startswith(fba_units.DELTA_PREFIX):
        if n_frames != 1:
            raise SigncastError("a delta unit covers one frame")
        return fba_units.read_delta(payload)
    return fba_units.decode_fba_payload(payload, n_frames)


def _rest_reference(delta):
    from comparisons.transport.fba_units import FrameState
    rotations = np.tile([1.0, 0.0, 0.0, 0.0], (delta.n_bones - len(delta.new_bones), 1))
    return FrameState(rotations, np.zeros(3), np.zeros(68, np.int64) if delta.has_faps else None)


def _check_delta(delta) -> None:
    from comparisons.transport.fba_units import apply_delta
    if delta.n_bones - len(delta.new_bones) < 0:
        return
    try:
        frame = apply_delta(delta, _rest_reference(delta))
    except SigncastError:
        return
    _check_array(frame.rotations, (delta.n_bones, 4), np.float64)
    _expect(bool(np.allclose(np.linalg.norm(frame.rotations, axis=1), 1.0)), "delta unit rotations not unit length")
    _check_array(frame.root, (3,), np.float64)


def live_units(data: bytes) -> None:
    """A receiver's live FBA stream (FBA units and delta units), fed in two chunks (the first byte picks the
    cut): the units it finds decode to their announced frames, the same whole or cut, and never overlap in
    the bytes."""
    from comparisons.transport import fba_units
    cut = data[0] % (len(data) + 1) if data else 0

    def scan(chunks):
        scanner = fba_units.UnitScanner(_decode_live_payload, (fba_units.FBA_PAYLOAD_PREFIX, fba_units.DELTA_PREFIX))
        units = []
        for chunk in chunks:
            units += scanner.feed(chunk)
        units += scanner.finish()
        return units, scanner.skipped

    units, skipped = scan([data[:cut], data[cut:]])
    whole, skipped_whole = scan([data])
    _expect([(u.first_frame, u.n_frames) for u in units] == [(u.first_frame, u.n_frames) for u in whole],
            "a live stream scanned in two chunks gives other units than scanned whole")
    _expect(0 <= skipped == skipped_whole <= len(data), f"skipped bytes {skipped} / {skipped_whole} of {len(data)}")
    used = sum(fba_units.HEADER_BYTES for _ in units)
    _expect(used + skipped <= len(data), "units and skipped bytes add up to more than the input")
    for unit in units:
        if isinstance(unit.decoded, fba_units.DeltaPayload):
            _expect(unit.n_frames == 1, "a delta unit of several frames")
            _check_delta(unit.decoded)
        else:
            _expect(unit.decoded.n_frames == unit.n_frames, "a unit decodes to another frame count than announced")


def seal_delta(data: bytes) -> bytes:
    return data[:-4] + zlib.crc32(data[:-4]).to_bytes(4, "big") if len(data) > 4 else data


def delta_unit(data: bytes) -> None:
    """A delta unit's payload (CRC-32 repaired), applied to a rest frame of its size: unit rotations, and the
    same frame twice."""
    from comparisons.transport.fba_units import apply_delta, read_delta
    delta = read_delta(data)
    _expect(1 <= delta.n_bones <= 1024 and 1 <= delta.q <= 31, "delta unit fields outside their ranges")
    _check_delta(delta)
    if delta.n_bones >= len(delta.new_bones):
        try:
            first = apply_delta(delta, _rest_reference(delta))
        except SigncastError:
            return
        again = apply_delta(read_delta(data), _rest_reference(delta))
        _same(first.rotations, again.rotations, "two applications of the same delta unit")


def seal_shape_units(data: bytes) -> bytes:
    """Shape units with their header CRC-8 and embedded shape streams' length and CRC-32 repaired."""
    from comparisons.params.bits import crc8_bits
    from comparisons.transport.shape_units import HEADER_SIZE, START_CODE
    out = bytearray(data)
    at = out.find(START_CODE)
    while at >= 0 and at + HEADER_SIZE <= len(out):
        length = int.from_bytes(out[at + HEADER_SIZE - 4:at + HEADER_SIZE - 1], "big")
        end = min(len(out), at + HEADER_SIZE + length)
        out[at + HEADER_SIZE:end] = seal_shape(bytes(out[at + HEADER_SIZE:end]))
        out[at + HEADER_SIZE - 1] = crc8_bits(bytes(out[at:at + HEADER_SIZE]), 8 * len(START_CODE), 8 * (HEADER_SIZE - 1))
        at = out.find(START_CODE, max(end, at + 1))
    return bytes(out)


def shape_units(data: bytes) -> None:
    from comparisons.transport.shape_units import find_shape_units
    units, skipped = find_shape_units(data)
    _expect(0 <= skipped <= len(data), f"skipped {skipped} of {len(data)} bytes")
    for first, masks in units:
        _expect(first >= 0 and masks.ndim == 3 and masks.shape[0] >= 1 and masks.dtype == bool,
                f"a shape unit decoded to {masks.shape} {masks.dtype}")
    again, skipped_again = find_shape_units(data)
    _expect(skipped_again == skipped and len(again) == len(units), "two scans of the same shape units differ")


RTP_PAYLOADS = ("units", "h264", "mp4v")


def rtp_depacketizers(data: bytes) -> None:
    """Datagrams ([u16 length][bytes] each) parsed as RTP and given to a depacketiser: the first byte picks
    the payload format (mod 3) and whether the first sequence number is known (bit 2, from the next 2 bytes).
    Any packets are rebuilt without an exception other than SigncastError, the same way twice, and what is
    returned holds bytes that arrived."""
    from comparisons.transport import rtp
    if len(data) < 3:
        raise SigncastError("too short")
    payload = RTP_PAYLOADS[data[0] % 3]
    first = int.from_bytes(data[1:3], "big") if data[0] & 4 else None
    packets = []
    for _, datagram in _frames(data[3:]):
        try:
            packets.append(rtp.RtpPacket.parse(datagram))
        except SigncastError:
            continue
    depacketize = {"units": rtp.depacketize_parameters, "h264": rtp.depacketize_h264,
                   "mp4v": lambda p, f: rtp.depacketize_mp4v(p, f, partial=True)}[payload]
    result = depacketize(packets, first)
    again = depacketize(list(packets), first)
    _same([(u.timestamp, u.data, u.damaged) for u in result.units],
          [(u.timestamp, u.data, u.damaged) for u in again.units], "two depacketisations of the same packets")
    _expect(all(a < b for a, b in result.lost_sequence_ranges), "an empty or inverted lost range")
    arrived = sum(len(p.payload) for p in packets)
    _expect(sum(len(u.data) for u in result.units) <= 4 * arrived + 64 * len(result.units),
            "depacketised units hold more bytes than arrived")


def jitter_buffer(data: bytes) -> None:
    """Datagrams ([u8 tenths of a frame interval to wait][u16 length][bytes] each) pushed into a jitter
    buffer of a 50-frame clip at 25 fps whose first sequence number is the input's first two bytes (RTP
    version bits set and the SSRC forced where a datagram is long enough, so most are RTP): every frame is
    released at most once, in increasing order, within the clip, and every datagram is counted once."""
    from pipeline.live.jitter_buffer import JitterBuffer
    if len(data) < 2:
        raise SigncastError("too short")
    buffer = JitterBuffer("units", 25.0, hold_s=0.04, first_sequence=int.from_bytes(data[:2], "big"), n_frames=50)
    released, now, pushed = [], 0.0, 0
    for head, datagram in _frames(data[2:], head=1):
        now += head[0] / 250.0
        if len(datagram) >= 12:
            datagram = bytes([0x80 | (datagram[0] & 0x3F)]) + datagram[1:8] + (0x5EED).to_bytes(4, "big") + datagram[12:]
        buffer.push(datagram, now)
        pushed += 1
        released += [frame for frame, _ in buffer.release(now)]
    released += [frame for frame, _ in buffer.release(float("inf"))]
    _expect(released == sorted(set(released)), f"frames released out of order or twice: {released[:20]}")
    _expect(all(0 <= f < 50 for f in released), "a frame outside the clip was released")
    counted = (buffer.accepted_packets + buffer.late_packets + buffer.discarded_packets + buffer.malformed_packets
               + (buffer.probation is not None))
    _expect(counted <= pushed, f"{counted} datagrams counted of {pushed} pushed")


def ts_demux(data: bytes) -> None:
    """An MPEG-2 TS through PyAV's demuxer and signcast's overhead parser: streams with packets, KLV units
    unwrapped, overhead figures finite and within the stream's size."""
    from comparisons.transport import ts
    demuxed = ts.demux_transport_stream(data)
    _expect(len(demuxed.streams) >= 1, "a demuxed TS without streams")
    for stream in demuxed.streams:
        _expect(all(isinstance(unit, bytes) for _, unit in stream.units), "a KLV unit that is not bytes")
    cost = ts.stream_overheads(ts.ts_overhead(data, 1.0), demuxed)
    figures = (cost["total_kbps"], cost["psi_kbps"], cost["pcr_kbps"], cost["null_kbps"])
    _expect(all(np.isfinite(v) and v >= 0 for v in figures), f"TS overhead figures {figures}")
    _expect(max(figures) <= 8 * len(data) / 1000 + 1e-6, "a TS overhead figure above the stream's size")


def session_description(data: bytes) -> None:
    """A session description line as a receiver reads it: valid ones are within the receiver's limits and
    survive being written and read again."""
    from pipeline.live.session import MAX_SHOWN_BYTES, SessionDescription
    description = SessionDescription.from_line(data)
    _expect(description.n_frames * description.width * description.height * 3 <= MAX_SHOWN_BYTES,
            "a description whose frames exceed the receiver's memory passed")
    _expect(1.0 <= description.fps <= 240.0, f"frame rate {description.fps} passed")
    again = SessionDescription.from_line(description.to_line())
    _same(again.to_line(), description.to_line(), "a session description written and read again")


def live_report(data: bytes) -> None:
    """Records (JSON lines) that pass validation, made into the live report: table rows, the terminal summary,
    the HTML page; the chart on one input in ENCODER_ORACLE_EVERY (matplotlib is slow)."""
    from comparisons.reports import live as report
    from comparisons.reports.records import read_typed_records, report_rows
    typed = read_typed_records(_as_file(data, ".jsonl"))
    found = report_rows(typed)
    points = report.aggregate(report.loss_points(found))
    rows = report.table_rows(points)
    _expect(len(rows) == len(points) + 1, "live table rows do not match the points")
    _expect(isinstance(report.summary_text(typed), str), "summary is not text")
    if _encoder_oracle_due(data):
        outputs = report.report_outputs(typed)
        _expect(outputs["live_loss.png"][:4] == b"\x89PNG", "the live chart is not a PNG")
    else:
        _expect("<html" in report.report_html(found, b"\x89PNG\r\n\x1a\n").lower(), "the live report is not HTML")


# ------------------------------------------------------------------------------------ registry

MOTION_CODERS = ("quant", "nuquant", "dpcm", "adpcm", "deadreck", "dct", "wavelet", "wavelet-cx", "svq", "tvq",
                 "posture", "gesture", "hybrid")   # = lab_codecs.LAB_CODEC_NAMES (tested), without importing it

LIVE_TARGETS = [
    Target("live-units", live_units, "comparisons.transport.fba_units.UnitScanner (FBA and delta units; CRCs "
           "repaired)", seal_live_units),
    Target("delta-unit", delta_unit, "comparisons.transport.fba_units.read_delta / apply_delta (CRC-32 repaired)",
           seal_delta),
    Target("shape-units", shape_units, "comparisons.transport.shape_units.find_shape_units (CRCs repaired)",
           seal_shape_units),
    Target("rtp", rtp_depacketizers, "comparisons.transport.rtp: RtpPacket.parse and the three depacketisers"),
    Target("jitter-buffer", jitter_buffer, "pipeline.live.jitter_buffer.JitterBuffer"),
    Target("ts-demux", ts_demux, "comparisons.transport.ts.demux_transport_stream and ts_overhead"),
    Target("session-description", session_description, "pipeline.live.session.SessionDescription.from_line"),
    Target("live-report", live_report, "comparisons.reports.live on records that pass read_records"),
]
LIVE_TARGET_NAMES = tuple(target.name for target in LIVE_TARGETS)   # benchmarks/fuzz.py --targets live

TARGETS: dict[str, Target] = {t.name: t for t in [
    Target("fba", fba, "comparisons.params.fba.decode_fba (CRC-32 repaired)", seal_fba),
    Target("bba", bba, "comparisons.params.bba.read_stream"),
    Target("bba-resilient", bba_resilient, "comparisons.params.bba.read_stream(resilient=True)"),
    Target("bba-xml", bba_xml, "comparisons.params.bba_xml.from_xml"),
    Target("bap", bap, "comparisons.params.bap_file.read_bap"),
    Target("fap", fap, "comparisons.params.fap_file.read_fap"),
    Target("shape", shape, "comparisons.video.shape.decode_shape (length and CRC-32 repaired)", seal_shape),
    *[Target(f"motion-{name}", _motion_target(name), f"comparisons.lab.codecs.LabCodec({name!r}).decode_dofs "
             "(CRC-32s repaired)", seal_motion) for name in MOTION_CODERS],
    Target("bvh", bvh, "media.bvh.read_bvh"),
    Target("pose", pose, "media.pose_file.read_pose"),
    Target("records", records, "comparisons.reports.records.read_records"),
    *LIVE_TARGETS,
]}

CORPUS_DIR = Path(__file__).resolve().parent / "corpus"


def run(name: str, data: bytes) -> str:
    """'decoded' or 'rejected' (SigncastError) for the input with its checksums repaired; any other
    exception, or DecodeMismatch, propagates."""
    target = TARGETS[name]
    try:
        target.decode(target.seal(data))
    except SigncastError:
        return "rejected"
    return "decoded"


def corpus_files(name: str) -> list[Path]:
    """The seed files of a target, sorted."""
    folder = CORPUS_DIR / name
    return sorted(p for p in folder.iterdir() if p.is_file()) if folder.is_dir() else []

"""MPEG-2 transport stream (ISO/IEC 13818-1) carrying the signer beside a programme video, as in the
ViSiCAST broadcast trials (seed 000 §4.2.5): mux through PyAV/FFmpeg, demux back, and measure the TS overhead.

Mux (FFmpeg's mpegts muxer, default settings, variable rate so no null packets):
- The programme video is the first stream, so it gets PID 0x100 and carries the PCR (FFmpeg's choice).
  Its packets are H.264 (Annex B) from `encode_programme` (libx264 at a constant QP) or any caller's packets.
- Each signer video object (`ElementaryVideo`: NSV2O/NSV3O texture streams, or a whole NSV video) is an
  extra video stream, remuxed from already-encoded packets (MPEG-4 Part 2: stream_type 0x10; H.264: 0x1B).
- A parameter track (FBA or BBA units) is a data stream with FFmpeg's "klv" codec. Chosen here over the
  other two cases tried with PyAV 18.1 / FFmpeg 8: "smpte_klv" is not a data codec name PyAV accepts, and the
  synchronous KLV profile (stream_type 0x15, metadata AU cells) is picked by FFmpeg only from the codec
  profile, which PyAV's DataStream does not let us set; a data stream without a codec becomes private data
  that demuxes back with no name. "klv" is written as stream_type 0x06 (PES private data, stream_id 0xBD)
  with a 'KLVA' registration descriptor (13818-1 §2.6.8) in the PMT, and demuxes back as codec "klv" with its
  PES payload unchanged. Each unit is one KLV triplet (SMPTE ST 336): a 16-byte key, a BER length, the unit.
  The keys are signcast's own (chosen here, not registered with SMPTE): the SMPTE UL prefix 06 0E 2B 34,
  the private-use item designator 0E, then "SC" and the kind ("FBA" / "BBA").
- All streams share the 90 kHz system clock. Media time t (frame index / fps) is written as
  PTS = CLOCK_ORIGIN_S + t, leaving room for B-frame DTS before the first PTS; `demux_transport_stream`
  returns the PTS as it is in the stream (seconds), so signcast's media time is pts_s - CLOCK_ORIGIN_S.

Overhead (`ts_overhead`): our own parse of the 188-byte packets (13818-1 §2.4.3.2 header, §2.4.3.4 adaptation
field, §2.4.3.6 PES header, §2.4.4 PAT/PMT) counts per PID the TS headers, the adaptation fields (with
stuffing; of those the 6-byte PCR fields), the PES headers and the payload (the elementary stream bytes);
PSI PIDs (PAT 0x0000, the PMTs named by the PAT, SDT 0x0011) count their payload as table bytes.
"""
from __future__ import annotations

import io
from dataclasses import dataclass, field
from fractions import Fraction

import av
import numpy as np

from media.domain import kbps
from comparisons.video.codecs import padded_packet
from media.errors import SigncastError

TS_PACKET = 188
SYNC_BYTE = 0x47
CLOCK_HZ = 90_000
CLOCK_ORIGIN_S = 1.0                      # chosen here: media time 0 is PTS 90000
PAT_PID, SDT_PID, NULL_PID = 0x0000, 0x0011, 0x1FFF
PCR_FIELD_BYTES = 6                       # program_clock_reference_base (33) + reserved (6) + extension (9)

VIDEO_CODECS = {"mpeg4": "mpeg4", "libx264": "h264"}          # signcast's encoder name -> decoder/stream name
PARAMETER_KINDS = ("fba", "bba", "shape")       # shape: a video object's shape units (comparisons.transport.shape_units)
_KLV_PREFIX = bytes.fromhex("060E2B34 01010101 0E") + b"SC"   # SMPTE UL prefix, private-use designator, "SC"
KLV_KEYS = {kind: (_KLV_PREFIX + kind.upper().encode()).ljust(16, b"\0") for kind in PARAMETER_KINDS}
_KIND_OF_KEY = {key: kind for kind, key in KLV_KEYS.items()}
MAX_UNIT_BYTES = 1 << 24                  # a parameter unit larger than 16 MiB is not one of ours

# stream_ids whose PES packets have no optional header (13818-1 Table 2-21 and §2.4.3.7)
_NO_OPTIONAL_HEADER = {0xBC, 0xBE, 0xBF, 0xF0, 0xF1, 0xF2, 0xF8, 0xFF}


@dataclass
class ElementaryVideo:
    """An already-encoded video stream: one packet per frame, in decode order.

    codec: "mpeg4" (MPEG-4 Part 2 elementary stream) or "libx264" (H.264 Annex B).
    pts: each packet's presentation index (display frame number, int), so its media time is pts / fps.
    keyframes: per packet, True for an intra (random access) picture; empty means "only the first".
    """

    name: str
    codec: str
    fps: float
    width: int
    height: int
    packets: list[bytes]
    pts: list[int]
    keyframes: list[bool] = field(default_factory=list)


class ProgrammeVideo(ElementaryVideo):
    """The programme's video: the first stream of the TS and the PID that carries the PCR."""


@dataclass
class ParameterTrack:
    """A data stream (kind "fba", "bba" or "shape") at fps; units: (frame index, unit bytes), in time order."""

    kind: str
    fps: float
    units: list[tuple[int, bytes]]


@dataclass
class DemuxedStream:
    """One stream as the demuxer gives it back.

    kind: "video" or "data"; codec: "h264", "mpeg4", "klv", ... (None when FFmpeg names none);
    packets: (pts seconds on the TS clock, packet bytes) in stream order;
    units: for a "klv" stream of signcast's, (pts seconds, unit bytes) with the KLV wrapping removed.
    """

    index: int
    pid: int
    kind: str
    codec: str | None
    packets: list[tuple[float, bytes]]
    parameter_kind: str | None = None
    units: list[tuple[float, bytes]] = field(default_factory=list)

    @property
    def payload_bytes(self) -> int:
        return sum(len(data) for _, data in self.packets)


@dataclass
class Demuxed:
    """All streams of a demuxed TS, in stream order."""

    streams: list[DemuxedStream]

    def by_kind(self, kind: str) -> list[DemuxedStream]:
        return [stream for stream in self.streams if stream.kind == kind]


def _timestamps(video: ElementaryVideo) -> tuple[list[int], list[int]]:
    """(pts, dts) in 90 kHz ticks: pts = origin + index / fps; dts walks the sorted pts, delayed just enough
    (the reorder depth) that no packet is decoded after it is shown."""
    ticks = [round((CLOCK_ORIGIN_S + index / video.fps) * CLOCK_HZ) for index in video.pts]
    ordered = sorted(ticks)
    delay = max(0, max(o - t for o, t in zip(ordered, ticks)))
    if delay > CLOCK_ORIGIN_S * CLOCK_HZ:
        raise SigncastError(f"video {video.name!r} reorders more than {CLOCK_ORIGIN_S} s of frames")
    return ticks, [o - delay for o in ordered]


def _check_video(video: ElementaryVideo) -> None:
    if video.codec not in VIDEO_CODECS:
        raise SigncastError(f"video {video.name!r}: codec must be one of {', '.join(VIDEO_CODECS)}, got {video.codec!r}")
    if not video.fps > 0 or video.width <= 0 or video.height <= 0:
        raise SigncastError(f"video {video.name!r}: fps, width and height must be positive")
    if not video.packets or len(video.packets) != len(video.pts):
        raise SigncastError(f"video {video.name!r}: needs one pts per packet and at least one packet")
    if video.keyframes and len(video.keyframes) != len(video.packets):
        raise SigncastError(f"video {video.name!r}: keyframes must be empty or one per packet")


def klv_wrap(kind: str, unit: bytes) -> bytes:
    """One KLV triplet: signcast's 16-byte key for `kind`, BER length (short form below 128), the unit."""
    if kind not in KLV_KEYS:
        raise SigncastError(f"parameter kind must be one of {', '.join(PARAMETER_KINDS)}, got {kind!r}")
    if len(unit) > MAX_UNIT_BYTES:
        raise SigncastError(f"parameter unit of {len(unit)} bytes exceeds {MAX_UNIT_BYTES}")
    size = len(unit)
    if size < 0x80:
        length = bytes([size])
    else:
        body = size.to_bytes((size.bit_length() + 7) // 8, "big")
        length = bytes([0x80 | len(body)]) + body
    return KLV_KEYS[kind] + length + bytes(unit)


def klv_unwrap(data: bytes) -> list[tuple[str, bytes]]:
    """The (kind, unit) of each KLV triplet in data; SigncastError for a foreign key or a truncated triplet."""
    units, offset = [], 0
    while offset < len(data):
        key = bytes(data[offset:offset + 16])
        if key not in _KIND_OF_KEY:
            raise SigncastError(f"KLV key {key.hex()} is not a signcast parameter key")
        offset += 16
        if offset >= len(data):
            raise SigncastError("KLV triplet truncated before its length")
        first = data[offset]
        offset += 1
        if first & 0x80:
            n_bytes = first & 0x7F
            if not 1 <= n_bytes <= 4 or offset + n_bytes > len(data):
                raise SigncastError("KLV BER length is malformed or truncated")
            size = int.from_bytes(data[offset:offset + n_bytes], "big")
            offset += n_bytes
        else:
            size = first
        if size > len(data) - offset:
            raise SigncastError(f"KLV value of {size} bytes overruns the packet ({len(data) - offset} left)")
        units.append((_KIND_OF_KEY[key], bytes(data[offset:offset + size])))
        offset += size
    return units


def mux_transport_stream(programme: ProgrammeVideo, signer_video: list[ElementaryVideo] = (),
                         signer_data: ParameterTrack | list[ParameterTrack] | None = None) -> bytes:
    """An MPEG-2 TS (bytes, a whole number of 188-byte packets) holding the programme video (PCR PID),
    each signer video object as a further video stream, and each parameter track (one, or a list: e.g. the
    shape units of each video object) as a KLV data stream of its own."""
    videos = [programme, *signer_video]
    for video in videos:
        _check_video(video)
    tracks = [] if signer_data is None else [signer_data] if isinstance(signer_data, ParameterTrack) else list(
        signer_data)
    for signer_data in tracks:
        if signer_data.kind not in PARAMETER_KINDS:
            raise SigncastError(f"parameter kind must be one of {', '.join(PARAMETER_KINDS)}, got {signer_data.kind!r}")
        if not signer_data.fps > 0:
            raise SigncastError(f"parameter track fps must be positive, got {signer_data.fps}")
        frames = [index for index, _ in signer_data.units]
        if any(index < 0 for index in frames) or frames != sorted(frames):
            raise SigncastError("parameter units need non-negative frame indices in time order")
    time_base = Fraction(1, CLOCK_HZ)
    buffer = io.BytesIO()
    packets = []                              # (dts, order, av.Packet), interleaved by dts below
    try:
        with av.open(buffer, "w", format="mpegts") as output:
            for order, video in enumerate(videos):
                stream = output.add_stream(VIDEO_CODECS[video.codec])
                stream.width, stream.height = video.width, video.height
                stream.pix_fmt = "yuv420p"
                stream.time_base = time_base
                stream.codec_context.time_base = Fraction(video.fps).limit_denominator(1001) ** -1
                keyframes = video.keyframes or [index == 0 for index in range(len(video.packets))]
                for data, pts, dts, key in zip(video.packets, *_timestamps(video), keyframes):
                    packet = av.Packet(bytes(data))
                    packet.pts, packet.dts, packet.time_base, packet.stream = pts, dts, time_base, stream
                    packet.is_keyframe = bool(key)
                    packets.append((dts, order, packet))
            for order, signer_data in enumerate(tracks, start=len(videos)):
                stream = output.add_data_stream("klv")
                stream.time_base = time_base
                for index, unit in signer_data.units:
                    packet = av.Packet(klv_wrap(signer_data.kind, unit))
                    packet.pts = packet.dts = round((CLOCK_ORIGIN_S + index / signer_data.fps) * CLOCK_HZ)
                    packet.time_base, packet.stream = time_base, stream
                    packets.append((packet.dts, order, packet))
            for _, _, packet in sorted(packets, key=lambda item: item[:2]):
                output.mux(packet)
    except av.error.FFmpegError as error:
        raise SigncastError(f"mpegts muxer refused the streams: {error}") from None
    return buffer.getvalue()


def _check_ts(data: bytes) -> None:
    if len(data) == 0 or len(data) % TS_PACKET:
        raise SigncastError(f"not an MPEG-2 TS: {len(data)} bytes is not a positive multiple of {TS_PACKET}")
    sync = np.frombuffer(data, dtype=np.uint8)[::TS_PACKET]
    if not np.all(sync == SYNC_BYTE):
        bad = int(np.flatnonzero(sync != SYNC_BYTE)[0])
        raise SigncastError(f"not an MPEG-2 TS: packet {bad} lacks the 0x47 sync byte")


def demux_transport_stream(data: bytes) -> Demuxed:
    """Every stream of the TS through PyAV's demuxer: PID (stream.id), kind, codec, packets (pts s, bytes);
    signcast's KLV parameter units unwrapped. SigncastError for input that is not a whole TS."""
    _check_ts(data)
    found: dict[int, DemuxedStream] = {}

    def described(stream) -> DemuxedStream:
        if stream.index not in found:       # FFmpeg may add a stream while demuxing (a PMT that changes)
            context = stream.codec_context
            codec = context.name if context is not None else getattr(stream, "name", None)
            found[stream.index] = DemuxedStream(stream.index, int(stream.id), stream.type, codec, [])
        return found[stream.index]

    try:
        with av.open(io.BytesIO(data), "r", format="mpegts") as container:
            for stream in container.streams:
                described(stream)
            packets = container.demux()
            while True:
                try:
                    packet = next(packets)
                except StopIteration:
                    break
                except IndexError:          # PyAV's stream list is fixed at open: FFmpeg found a stream later
                    raise SigncastError("the transport stream adds an elementary stream after its start, which "
                                        "PyAV's demuxer cannot follow") from None
                if packet.size == 0 or packet.pts is None:
                    continue
                described(packet.stream).packets.append((float(packet.pts * packet.time_base), bytes(packet)))
    except av.error.FFmpegError as error:
        raise SigncastError(f"cannot demux the transport stream: {error}") from None
    streams = [found[index] for index in sorted(found)]
    if not streams:
        raise SigncastError("the transport stream carries no elementary stream")
    for stream in streams:
        if stream.codec == "klv":
            for pts_s, payload in stream.packets:
                for kind, unit in klv_unwrap(payload):
                    if stream.parameter_kind not in (None, kind):
                        raise SigncastError(f"PID {stream.pid:#x} mixes {stream.parameter_kind} and {kind} units")
                    stream.parameter_kind = kind
                    stream.units.append((pts_s, unit))
    return Demuxed(streams)


def decode_demuxed_video(stream: DemuxedStream) -> np.ndarray:
    """Decode a demuxed video stream with PyAV: (T, H, W, 3) uint8 RGB in display order."""
    if stream.kind != "video" or stream.codec not in VIDEO_CODECS.values():
        raise SigncastError(f"stream {stream.index} ({stream.kind} {stream.codec}) is not a video signcast decodes")
    decoder = av.CodecContext.create(stream.codec, "r")
    frames = []
    try:
        for pts_s, data in stream.packets:
            packet = padded_packet(data)
            packet.pts, packet.time_base = round(pts_s * CLOCK_HZ), Fraction(1, CLOCK_HZ)
            frames.extend(decoder.decode(packet))
        frames.extend(decoder.decode(None))
    except av.error.FFmpegError as error:
        raise SigncastError(f"cannot decode {stream.codec} stream {stream.index}: {error}") from None
    if not frames:
        raise SigncastError(f"{stream.codec} stream {stream.index} decodes to no frames")
    return np.stack([frame.to_ndarray(format="rgb24") for frame in frames])


def encode_programme(frames: np.ndarray, fps: float, qp: int = 26) -> ProgrammeVideo:
    """Encode programme frames (T, H, W, 3) uint8 RGB, even H and W, with libx264 at constant QP (0..51),
    GOP 25, 2 B-frames, into per-frame Annex B packets in decode order."""
    frames = np.asarray(frames)
    if frames.ndim != 4 or frames.shape[-1] != 3 or frames.dtype != np.uint8 or len(frames) == 0:
        raise SigncastError(f"frames must be (T, H, W, 3) uint8 with T >= 1, got {frames.shape} {frames.dtype}")
    if frames.shape[1] % 2 or frames.shape[2] % 2 or not 0 <= qp <= 51 or not fps > 0:
        raise SigncastError("programme needs even frame sizes, qp in 0..51 and a positive fps")
    encoder = av.CodecContext.create("libx264", "w")
    encoder.width, encoder.height, encoder.pix_fmt = frames.shape[2], frames.shape[1], "yuv420p"
    rate = Fraction(fps).limit_denominator(1001)
    encoder.time_base, encoder.framerate = 1 / rate, rate
    encoder.options = {"qp": str(qp), "bf": "2", "g": "25", "keyint_min": "25", "sc_threshold": "0"}
    packets = []
    for index, image in enumerate(frames):
        frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(image), format="rgb24")
        frame.pts = index
        packets.extend(encoder.encode(frame))
    packets.extend(encoder.encode(None))
    return ProgrammeVideo("programme", "libx264", fps, frames.shape[2], frames.shape[1],
                          [bytes(packet) for packet in packets], [int(packet.pts) for packet in packets],
                          [bool(packet.is_keyframe) for packet in packets])


def split_elementary_stream(name: str, data: bytes, codec: str, fps: float) -> ElementaryVideo:
    """Cut an elementary stream (e.g. `video_codecs.encode_video` output) into per-frame packets with PyAV's
    parser, and find each packet's display index and intra flag by decoding: the decoder hands back each
    frame with the pts of the packet that carried it, in display order."""
    if codec not in VIDEO_CODECS:
        raise SigncastError(f"codec must be one of {', '.join(VIDEO_CODECS)}, got {codec!r}")
    try:
        parser = av.CodecContext.create(VIDEO_CODECS[codec], "r")
        packets = [bytes(packet) for packet in parser.parse(bytes(data)) + parser.parse(None)]
        decoder = av.CodecContext.create(VIDEO_CODECS[codec], "r")
        shown = []
        for index, chunk in enumerate(packets):
            packet = padded_packet(chunk)
            packet.pts = packet.dts = index
            shown.extend(decoder.decode(packet))
        shown.extend(decoder.decode(None))
    except av.error.FFmpegError as error:
        raise SigncastError(f"cannot parse {codec} stream {name!r}: {error}") from None
    if not shown or len(shown) != len(packets) or sorted(frame.pts for frame in shown) != list(range(len(packets))):
        raise SigncastError(f"{codec} stream {name!r}: {len(packets)} packets decode to {len(shown)} frames")
    pts, keyframes = [0] * len(packets), [False] * len(packets)
    for display, frame in enumerate(shown):
        pts[frame.pts], keyframes[frame.pts] = display, bool(frame.key_frame)
    return ElementaryVideo(name, codec, fps, shown[0].width, shown[0].height, packets, pts, keyframes)


def _psi_sections(payload: bytes, unit_start: bool) -> bytes:
    """The section that starts in this payload (after the pointer field), or b'' when none starts here."""
    if not unit_start or not payload:
        return b""
    pointer = payload[0]
    return payload[1 + pointer:]


def _parse_pat(section: bytes) -> list[int]:
    """PMT PIDs named by a PAT section (13818-1 §2.4.4.3); program 0 (the network PID) is skipped."""
    if len(section) < 8 or section[0] != 0x00:
        return []
    length = ((section[1] & 0x0F) << 8) | section[2]
    body = section[8:min(len(section), 3 + length - 4)]
    pids = []
    for offset in range(0, len(body) - 3, 4):
        program = (body[offset] << 8) | body[offset + 1]
        if program:
            pids.append(((body[offset + 2] & 0x1F) << 8) | body[offset + 3])
    return pids


def _parse_pmt(section: bytes) -> tuple[int | None, dict[int, int]]:
    """(PCR PID, {elementary PID: stream_type}) of a PMT section (13818-1 §2.4.4.8)."""
    if len(section) < 12 or section[0] != 0x02:
        return None, {}
    length = ((section[1] & 0x0F) << 8) | section[2]
    end = min(len(section), 3 + length - 4)
    pcr_pid = ((section[8] & 0x1F) << 8) | section[9]
    offset = 12 + (((section[10] & 0x0F) << 8) | section[11])
    streams = {}
    while offset + 5 <= end:
        stream_type = section[offset]
        pid = ((section[offset + 1] & 0x1F) << 8) | section[offset + 2]
        streams[pid] = stream_type
        offset += 5 + (((section[offset + 3] & 0x0F) << 8) | section[offset + 4])
    return pcr_pid, streams


_PARTS = ("ts_header_bytes", "adaptation_bytes", "pcr_bytes", "pes_header_bytes", "payload_bytes", "table_bytes")


def ts_overhead(data: bytes, duration_s: float) -> dict:
    """Per-PID byte counts of a TS and their rates over duration_s.

    Returns {"duration_s", "packets", "total_bytes", "pcr_pid", "pids": {pid: row}, "totals": row}; a row has
    kind ("psi" | "pes" | "null" | "other"), stream_type (from the PMT, or None), packets, and bytes and kbps of
    each part: ts_header (4 per packet), adaptation (whole fields with their length byte and stuffing),
    pcr (the 6-byte PCR fields, already inside adaptation), pes_header (from 00 00 01 to the end of
    PES_header_data_length's bytes), payload (elementary stream bytes) and table (PSI payload incl. pointer
    field and 0xFF fill). The parts other than pcr add up to 188 per packet."""
    _check_ts(data)
    if not duration_s > 0:
        raise SigncastError(f"duration must be positive, got {duration_s}")
    pmt_pids: set[int] = set()
    stream_types: dict[int, int] = {}
    pcr_pid = None
    rows: dict[int, dict] = {}
    pending_header: dict[int, int] = {}       # PES header bytes still to come in the PID's next packet
    for start in range(0, len(data), TS_PACKET):
        packet = data[start:start + TS_PACKET]
        unit_start = bool(packet[1] & 0x40)
        pid = ((packet[1] & 0x1F) << 8) | packet[2]
        control = (packet[3] >> 4) & 0x3
        row = rows.setdefault(pid, dict.fromkeys(("packets",) + _PARTS, 0))
        row["packets"] += 1
        row["ts_header_bytes"] += 4
        offset = 4
        if control & 0x2:
            length = packet[4]
            if length > TS_PACKET - 5 or (control == 0x3 and length > TS_PACKET - 6):
                raise SigncastError(f"TS packet {start // TS_PACKET}: adaptation field length {length} overruns it")
            if length and packet[5] & 0x10:
                if length < 1 + PCR_FIELD_BYTES:
                    raise SigncastError(f"TS packet {start // TS_PACKET}: PCR flag set in a {length}-byte field")
                row["pcr_bytes"] += PCR_FIELD_BYTES
            row["adaptation_bytes"] += 1 + length
            offset += 1 + length
        payload = packet[offset:] if control & 0x1 else b""
        if control == 0:
            row["adaptation_bytes"] += TS_PACKET - 4  # reserved value: nothing in it is payload
            continue
        if pid == PAT_PID or pid == SDT_PID or pid in pmt_pids:
            row["table_bytes"] += len(payload)
            section = _psi_sections(payload, unit_start)
            if pid == PAT_PID:
                pmt_pids.update(_parse_pat(section))
            elif pid in pmt_pids and section:
                pcr, streams = _parse_pmt(section)
                if pcr is not None:
                    pcr_pid = pcr
                    stream_types.update(streams)
            continue
        if pid == NULL_PID:
            row["payload_bytes"] += len(payload)
            continue
        header = 0
        if unit_start and payload[:3] == b"\x00\x00\x01" and len(payload) >= 6:
            header = 6 if payload[3] in _NO_OPTIONAL_HEADER else 9 + (payload[8] if len(payload) >= 9 else 0)
        elif pid in pending_header:
            header = pending_header.pop(pid)
        if header > len(payload):
            pending_header[pid] = header - len(payload)
            header = len(payload)
        row["pes_header_bytes"] += header
        row["payload_bytes"] += len(payload) - header
    to_kbps = kbps(8, duration_s)          # kbit/s per byte over the duration

    def finish(row: dict) -> dict:
        for part in _PARTS:
            row[part.replace("_bytes", "_kbps")] = row[part] * to_kbps
        return row

    for pid, row in rows.items():
        kind = "psi" if pid in (PAT_PID, SDT_PID) or pid in pmt_pids else "null" if pid == NULL_PID else \
            "pes" if pid in stream_types else "other"
        row.update(pid=pid, kind=kind, stream_type=stream_types.get(pid))
        finish(row)
    totals = finish({part: sum(row[part] for row in rows.values()) for part in ("packets",) + _PARTS})
    return {"duration_s": duration_s, "packets": len(data) // TS_PACKET, "total_bytes": len(data),
            "pcr_pid": pcr_pid, "pids": rows, "totals": totals}


def stream_overheads(overhead: dict, demuxed: Demuxed) -> dict:
    """Map a `ts_overhead` result onto the carried streams.

    Returns {"streams": [...], "psi_kbps", "pcr_kbps", "null_kbps", "total_kbps"}: per stream its PID, kind,
    codec, payload_kbps and overhead_kbps = its PID's TS headers + adaptation fields + PES headers, less the
    PCR fields, which belong to the programme as a whole and are stated once as pcr_kbps; psi_kbps is every
    byte of the PSI PIDs (PAT, PMT, SDT), TS headers included."""
    to_kbps = kbps(8, overhead["duration_s"])
    rows = overhead["pids"]
    streams = []
    for stream in demuxed.streams:
        row = rows.get(stream.pid)
        if row is None:
            continue
        share = row["ts_header_bytes"] + row["adaptation_bytes"] - row["pcr_bytes"] + row["pes_header_bytes"]
        streams.append({"pid": stream.pid, "kind": stream.kind, "codec": stream.codec,
                        "parameter_kind": stream.parameter_kind, "packets": row["packets"],
                        "payload_kbps": row["payload_bytes"] * to_kbps, "overhead_kbps": share * to_kbps,
                        "overhead_ratio": share / row["payload_bytes"] if row["payload_bytes"] else float("inf")})
    psi = sum(TS_PACKET * row["packets"] for row in rows.values() if row["kind"] == "psi")
    null = sum(TS_PACKET * row["packets"] for row in rows.values() if row["kind"] == "null")
    return {"streams": streams, "psi_kbps": psi * to_kbps, "pcr_kbps": overhead["totals"]["pcr_bytes"] * to_kbps,
            "null_kbps": null * to_kbps, "total_kbps": overhead["total_bytes"] * to_kbps}

"""RTP packetisation (RFC 3550) of signcast's streams: pure functions on bytes, no sockets.

Three payload formats, each a packetiser (sender) and a depacketiser (receiver):

- H.264, RFC 6184 non-interleaved mode (`H264Packetizer`, `depacketize_h264`): an Annex B access unit is split
  into NAL units; consecutive NAL units that fit together go in one STAP-A packet (§5.7.1), a NAL unit that fits
  alone goes in a single NAL unit packet (§5.6), a larger one is cut into FU-A fragments (§5.8). The receiver
  rebuilds Annex B access units with the start codes of H.264 B.1.2 as libx264 writes them (`annexb`).
- MPEG-4 Part 2, RFC 6416 §5 (`Mp4vPacketizer`, `depacketize_mp4v`): an access unit is one VOP with any
  VOS/VO/VOL headers before it; no payload header; cut at MTU boundaries (allowed by §5.2; cutting at resync
  markers is not done here).
- signcast parameter units (`ParameterPacketizer`, `depacketize_parameters`): FBA / BBA units, format chosen
  here and described below.

In every format the marker bit is set on the last packet of an access unit (or of the units of one capture
instant), RFC 3550 §5.1, and all payloads use a 90 kHz clock (`CLOCK_RATE`).

signcast parameter payload format (chosen here, in the manner of an RTP payload format RFC). Each RTP payload
starts with a 4-byte payload header, in network byte order (2 bytes of flags and count, and 2 more for a unit
number so that a receiver can name the units it lost)::

    0                   1                   2                   3
    0 1 2 3 4 5 6 7 8 9 0 1 2 3 4 5 6 7 8 9 0 1 2 3 4 5 6 7 8 9 0 1
   +-+-+-----------+---------------+-------------------------------+
   |S|E|  reserved |     COUNT     |          UNIT NUMBER          |
   +-+-+-----------+---------------+-------------------------------+

- S: the payload starts with the first byte of a unit. E: the payload ends with the last byte of a unit.
  Reserved bits are sent as zero and ignored.
- UNIT NUMBER: the number of the (first) unit in the payload, counted from 0 per stream, modulo 2^16; it lets a
  receiver name the units it lost, the way RTP sequence numbers name lost packets.
- S=1, E=1: aggregation packet of COUNT >= 1 whole units (numbers UNIT NUMBER, +1, ...), each prefixed by its
  16-bit length (non-zero); the lengths must use up the payload exactly.
- S=1, E=0 / S=0, E=0 / S=0, E=1: first / middle / last fragment of one unit (COUNT = 1) too large for one
  packet; the rest of the payload is the fragment (non-empty). A unit is whole only if all its fragments arrive
  (consecutive sequence numbers, same unit number).

A sender greedily aggregates the units of one capture instant (one `packetize_units` call, one timestamp) while
they fit in `mtu` bytes and fragments a unit that does not fit alone. The receiver hands on the bytes of every
whole unit in order; the stream decoder resynchronises at the next unit, so a lost unit is just missing bytes.

Receiver rules shared by the three depacketisers: packets are ordered by extended sequence number
(`unwrap_sequences`, RFC 3550 A.1 style), duplicates are dropped, and the missing sequence numbers between the
first and last received packet are reported lost. Packets are grouped into access units by timestamp and marker
bit. An access unit counts as whole only if its packets are consecutive, its last packet carries the marker bit
and the packet just before its first one arrived and ended the previous access unit (or, for the first access
unit, its first packet is `first_sequence` when the caller knows it, e.g. from RTSP RTP-Info, RFC 2326 §12.33;
when `first_sequence` is None the first received packet is taken to start the stream). An access unit lost
entirely cannot be named by timestamp; its packets are in `lost_sequences`. Depacketisers never raise on loss,
reordering or duplication; a packet whose payload is malformed is dropped and counted.

Use (sender and receiver around UDP sockets)::

    packetizer = H264Packetizer(mtu=1200, seed=1)                   # or Mp4vPacketizer / ParameterPacketizer
    for index, unit in enumerate(access_units(stream, "libx264")):  # decode order
        for packet in packetizer.packetize(unit, timestamp_of(index, fps)):
            sock.sendto(packet.to_bytes(), address)                 # parameters: packetize_units(units, ts)
    received = [RtpPacket.parse(datagram) for datagram in datagrams]  # SigncastError: count it, skip it
    result = depacketize_h264(received, first_sequence=packetizer.first_sequence)
    result.units, result.lost_packets, result.damaged_timestamps, wire_bits(sent_packets)
"""
from __future__ import annotations

import struct
from collections.abc import Iterable
from dataclasses import dataclass, field

import av
import numpy as np

from media.errors import SigncastError

RTP_VERSION = 2
RTP_HEADER_BYTES = 12
HEADER_OVERHEAD = 20 + 8 + RTP_HEADER_BYTES   # IPv4 + UDP + RTP fixed header, bytes per packet
_IP_UDP_BYTES = 20 + 8
CLOCK_RATE = 90_000                            # Hz, for every payload format here
DEFAULT_MTU = 1200                             # maximum RTP payload bytes
MIN_MTU = 16
MAX_MTU = 65_535 - _IP_UDP_BYTES - RTP_HEADER_BYTES

PAYLOAD_TYPE_H264 = 96                         # dynamic payload types (RFC 3551 §6), chosen here
PAYLOAD_TYPE_MP4V = 97
PAYLOAD_TYPE_PARAMETERS = 98

_SEQ_MOD = 1 << 16
_TS_MOD = 1 << 32
_STAP_A, _FU_A = 24, 28
_PARAM_HEADER = struct.Struct("!BBH")
_MAX_AGGREGATED = 255


@dataclass(frozen=True)
class RtpPacket:
    """One RTP packet: fixed header fields (RFC 3550 §5.1) and the payload bytes."""

    payload_type: int      # 0..127
    sequence: int          # 0..65535
    timestamp: int         # 0..2^32-1, 90 kHz clock units
    ssrc: int              # 0..2^32-1
    marker: bool
    payload: bytes

    def to_bytes(self) -> bytes:
        """The packet on the wire: version 2, no padding, no extension, no CSRC."""
        if not 0 <= self.payload_type < 128:
            raise SigncastError(f"RTP payload type must be 0..127, got {self.payload_type}")
        if not 0 <= self.sequence < _SEQ_MOD:
            raise SigncastError(f"RTP sequence number must be 0..65535, got {self.sequence}")
        if not 0 <= self.timestamp < _TS_MOD or not 0 <= self.ssrc < _TS_MOD:
            raise SigncastError(f"RTP timestamp and SSRC must be 0..2^32-1, got {self.timestamp}, {self.ssrc}")
        first = RTP_VERSION << 6
        second = (int(bool(self.marker)) << 7) | self.payload_type
        return struct.pack("!BBHII", first, second, self.sequence, self.timestamp, self.ssrc) + bytes(self.payload)

    @classmethod
    def parse(cls, data: bytes) -> RtpPacket:
        """Parse one packet from the wire; CSRC list, header extension and padding are skipped (RFC 3550 §5.1,
        §5.3.1). Raises SigncastError on anything malformed."""
        data = bytes(data)
        if len(data) < RTP_HEADER_BYTES:
            raise SigncastError(f"RTP packet too short: {len(data)} bytes, the fixed header is 12")
        first, second, sequence, timestamp, ssrc = struct.unpack_from("!BBHII", data)
        if first >> 6 != RTP_VERSION:
            raise SigncastError(f"RTP version must be 2, got {first >> 6}")
        start = RTP_HEADER_BYTES + 4 * (first & 0x0F)
        end = len(data)
        if start > end:
            raise SigncastError(f"RTP CSRC count {first & 0x0F} runs past the {len(data)}-byte packet")
        if first & 0x10:
            if start + 4 > end:
                raise SigncastError("RTP header extension runs past the packet")
            (words,) = struct.unpack_from("!H", data, start + 2)
            start += 4 + 4 * words
            if start > end:
                raise SigncastError(f"RTP header extension of {words} words runs past the packet")
        if first & 0x20:
            padding = data[-1]
            if padding == 0 or end - padding < start:
                raise SigncastError(f"RTP padding count {padding} is invalid for a {len(data)}-byte packet")
            end -= padding
        return cls(second & 0x7F, sequence, timestamp, ssrc, bool(second & 0x80), data[start:end])


def wire_bits(packets: Iterable[RtpPacket | bytes]) -> int:
    """Bits on the wire including IPv4 and UDP headers: sum of (RTP packet bytes + 28) * 8."""
    total = 0
    for packet in packets:
        size = len(packet.payload) + RTP_HEADER_BYTES if isinstance(packet, RtpPacket) else len(packet)
        total += (size + _IP_UDP_BYTES) * 8
    return total


def timestamp_of(frame_index: int, fps: float, first_timestamp: int = 0) -> int:
    """RTP timestamp (90 kHz units, mod 2^32) of frame `frame_index` at `fps` frames per second."""
    if fps <= 0:
        raise SigncastError(f"frame rate must be positive, got {fps}")
    return (int(first_timestamp) + round(float(frame_index) * CLOCK_RATE / float(fps))) % _TS_MOD


def _nearest(reference: int, number: int) -> int:
    """The integer congruent to 16-bit `number` mod 2^16 nearest to `reference` (an extended number)."""
    return reference + (number - reference + _SEQ_MOD // 2) % _SEQ_MOD - _SEQ_MOD // 2


def unwrap_sequences(seqs: Iterable[int]) -> list[int]:
    """Extended sequence numbers, in the given (arrival) order, from 16-bit ones (RFC 3550 A.1 style).

    Each number is placed within +-32768 of the highest extended number seen so far, so wrap-around, reordering
    and duplicates are handled. The first number keeps its value; one reordered before it across a wrap comes
    out negative."""
    extended: list[int] = []
    highest: int | None = None
    for seq in seqs:
        seq = int(seq) % _SEQ_MOD
        if highest is None:
            value = seq
        else:
            value = _nearest(highest, seq)
        highest = value if highest is None else max(highest, value)
        extended.append(value)
    return extended


# ---------------------------------------------------------------------------------------------------- results


@dataclass(frozen=True)
class Unit:
    """One access unit (video) or one parameter unit rebuilt by a depacketiser."""

    timestamp: int                 # RTP timestamp, 90 kHz units
    data: bytes
    damaged: bool = False          # some of its bytes were lost (the decoder conceals)
    number: int | None = None      # parameter units: extended unit number


@dataclass
class Depacketized:
    """What a depacketiser rebuilt from the packets it was given."""

    units: list[Unit] = field(default_factory=list)        # in sequence order
    # extended sequence numbers never received, as half-open ranges [first, stop) (memory stays proportional
    # to the packets received, whatever numbers they carry)
    lost_sequence_ranges: list[tuple[int, int]] = field(default_factory=list)
    damaged_timestamps: list[int] = field(default_factory=list)  # returned, but incomplete
    dropped_timestamps: list[int] = field(default_factory=list)  # packets arrived, nothing returned
    dropped_fragments: int = 0     # NAL / parameter units dropped because a fragment was missing
    lost_unit_ranges: list[tuple[int, int]] = field(default_factory=list)  # parameter units not returned
    malformed_packets: int = 0
    duplicate_packets: int = 0

    @property
    def lost_packets(self) -> int:
        """How many sequence numbers were never received."""
        return sum(stop - first for first, stop in self.lost_sequence_ranges)

    @property
    def lost_sequences(self) -> list[int]:
        """The extended sequence numbers never received, listed."""
        return [n for first, stop in self.lost_sequence_ranges for n in range(first, stop)]

    @property
    def lost_units(self) -> list[int]:
        """Parameter units: extended unit numbers not returned, listed."""
        return [n for first, stop in self.lost_unit_ranges for n in range(first, stop)]

    @property
    def stream(self) -> bytes:
        """The returned units' bytes, concatenated in order (what a resynchronising decoder reads)."""
        return b"".join(unit.data for unit in self.units)


@dataclass
class _Group:
    """The received packets of one access unit, with sequence numbers extended."""

    timestamp: int
    packets: list[tuple[int, RtpPacket]]
    whole: bool


def _gaps(first: int, stop: int, present: list[int]) -> list[tuple[int, int]]:
    """Half-open ranges of the numbers in [first, stop) missing from sorted `present`."""
    gaps, expected = [], first
    for number in [*present, stop]:
        if number > expected:
            gaps.append((expected, number))
        expected = max(expected, number + 1)
    return gaps


def _groups(packets: Iterable[RtpPacket], first_sequence: int | None, result: Depacketized) -> list[_Group]:
    """Sort by extended sequence number, drop duplicates, record lost numbers, group into access units."""
    packets = list(packets)
    extended = unwrap_sequences(packet.sequence for packet in packets)
    unique: dict[int, RtpPacket] = {}
    for number, packet in zip(extended, packets):
        if number in unique:
            result.duplicate_packets += 1
        else:
            unique[number] = packet
    if not unique:
        return []
    ordered = sorted(unique.items())
    lowest, highest = ordered[0][0], ordered[-1][0]
    start = lowest
    if first_sequence is not None:
        start = min(_nearest(lowest, first_sequence), lowest)
    result.lost_sequence_ranges = _gaps(start, highest + 1, [number for number, _ in ordered])

    groups: list[_Group] = []
    for number, packet in ordered:
        previous = groups[-1].packets[-1] if groups else None
        if previous is None or previous[1].marker or previous[1].timestamp != packet.timestamp:
            if previous is None:
                starts_clean = first_sequence is None or number == start
            else:
                starts_clean = previous[0] == number - 1 and previous[1].marker
            groups.append(_Group(packet.timestamp, [], starts_clean))
        group = groups[-1]
        if group.packets and group.packets[-1][0] != number - 1:
            group.whole = False
        group.packets.append((number, packet))
    for group in groups:
        if not group.packets[-1][1].marker:
            group.whole = False
    return groups


class _Packetizer:
    """Running sequence number and a fixed SSRC, both drawn from `seed`; `mtu` is the largest RTP payload."""

    payload_type: int

    def __init__(self, mtu: int = DEFAULT_MTU, seed: int = 0, payload_type: int | None = None) -> None:
        if not MIN_MTU <= mtu <= MAX_MTU:
            raise SigncastError(f"RTP payload size (mtu) must be {MIN_MTU}..{MAX_MTU} bytes, got {mtu}")
        rng = np.random.default_rng(seed)
        self.mtu = int(mtu)
        self.ssrc = int(rng.integers(0, _TS_MOD))
        self.first_sequence = int(rng.integers(0, _SEQ_MOD))   # random initial value, RFC 3550 §5.1
        self.sequence = self.first_sequence
        if payload_type is not None:
            self.payload_type = payload_type

    def _packet(self, payload: bytes, timestamp: int, marker: bool) -> RtpPacket:
        packet = RtpPacket(self.payload_type, self.sequence, int(timestamp) % _TS_MOD, self.ssrc, marker, payload)
        self.sequence = (self.sequence + 1) % _SEQ_MOD
        return packet

    def _packets(self, payloads: list[bytes], timestamp: int) -> list[RtpPacket]:
        return [self._packet(p, timestamp, i == len(payloads) - 1) for i, p in enumerate(payloads)]


# ---------------------------------------------------------------------------------------------------- H.264


def h264_nal_units(access_unit: bytes) -> list[bytes]:
    """The NAL units (without start codes) of Annex B bytes; trailing zero bytes of each are dropped."""
    data = bytes(access_unit)
    starts = []
    position = data.find(b"\x00\x00\x01")
    if position < 0 or data[:position].strip(b"\x00"):
        raise SigncastError("H.264 access unit must start with an Annex B start code (00 00 01)")
    while position >= 0:
        starts.append(position + 3)
        position = data.find(b"\x00\x00\x01", position + 3)
    nal_units = []
    for index, begin in enumerate(starts):
        end = starts[index + 1] - 3 if index + 1 < len(starts) else len(data)
        nal = data[begin:end].rstrip(b"\x00")
        if nal:
            nal_units.append(nal)
    return nal_units


def annexb(nal_units: list[bytes]) -> bytes:
    """An Annex B access unit: a 4-byte start code before the first NAL unit and before SPS and PPS, a 3-byte one
    before the others (the zero_byte rule of H.264 B.1.2, which libx264 follows)."""
    return b"".join((b"\x00\x00\x00\x01" if i == 0 or nal[0] & 0x1F in (7, 8) else b"\x00\x00\x01") + nal
                    for i, nal in enumerate(nal_units))


class H264Packetizer(_Packetizer):
    """RFC 6184 non-interleaved packetiser: STAP-A, single NAL unit and FU-A packets."""

    payload_type = PAYLOAD_TYPE_H264

    def packetize(self, access_unit: bytes, timestamp: int) -> list[RtpPacket]:
        """Packets (marker on the last) of one Annex B access unit at RTP `timestamp` (90 kHz)."""
        payloads: list[bytes] = []
        pending: list[bytes] = []

        def flush() -> None:
            if len(pending) == 1:
                payloads.append(pending[0])
            elif pending:
                f_bit = max(nal[0] & 0x80 for nal in pending)
                nri = max(nal[0] & 0x60 for nal in pending)
                payloads.append(bytes([f_bit | nri | _STAP_A]) + b"".join(struct.pack("!H", len(n)) + n
                                                                            for n in pending))
            pending.clear()

        for nal in h264_nal_units(access_unit):
            aggregated = 1 + sum(2 + len(n) for n in pending) + 2 + len(nal)
            if pending and aggregated <= self.mtu:
                pending.append(nal)
                continue
            flush()
            if len(nal) <= self.mtu:
                pending.append(nal)
                continue
            indicator = bytes([(nal[0] & 0xE0) | _FU_A])
            body, step = nal[1:], self.mtu - 2
            for offset in range(0, len(body), step):
                header = nal[0] & 0x1F
                header |= 0x80 if offset == 0 else 0
                header |= 0x40 if offset + step >= len(body) else 0
                payloads.append(indicator + bytes([header]) + body[offset:offset + step])
        flush()
        if not payloads:
            raise SigncastError("H.264 access unit holds no NAL units")
        return self._packets(payloads, timestamp)


def _h264_group(group: _Group, result: Depacketized) -> tuple[list[bytes], bool]:
    """Whole NAL units of one access unit, and whether any was dropped."""
    nal_units: list[bytes] = []
    dropped = False
    pieces: list[bytes] = []          # the FU-A NAL unit being rebuilt
    state = None                      # None, "building" (start seen, no gap) or "broken" (counted, skipping)
    last_number = None
    for number, packet in group.packets:
        payload = packet.payload
        kind = payload[0] & 0x1F if payload else 0
        contiguous = last_number is not None and number == last_number + 1
        last_number = number
        if kind != _FU_A:
            if state == "building":
                result.dropped_fragments += 1
                dropped = True
            state = None
        if 1 <= kind <= 23:
            nal_units.append(payload)
        elif kind == _STAP_A:
            items, offset = [], 1
            while offset + 2 <= len(payload):
                (size,) = struct.unpack_from("!H", payload, offset)
                if size == 0 or offset + 2 + size > len(payload):
                    break
                items.append(payload[offset + 2:offset + 2 + size])
                offset += 2 + size
            if offset != len(payload) or not items:
                result.malformed_packets += 1
                dropped = True
            else:
                nal_units.extend(items)
        elif kind == _FU_A:
            header = payload[1] if len(payload) > 2 else None
            if header is None or (header & 0xC0) == 0xC0 or not 1 <= header & 0x1F <= 23:
                result.malformed_packets += 1
                dropped = True
                if state == "building":
                    result.dropped_fragments += 1
                    state = "broken"
                continue
            if header & 0x80:
                if state == "building":
                    result.dropped_fragments += 1
                    dropped = True
                state, pieces = "building", [bytes([(payload[0] & 0xE0) | (header & 0x1F)]), payload[2:]]
            elif state == "building" and contiguous:
                pieces.append(payload[2:])
            elif not (state == "broken" and contiguous):
                # a gap: the NAL unit being built, or a new one whose start was lost, is dropped (counted once)
                result.dropped_fragments += 1
                state, dropped = "broken", True
            if header & 0x40:
                if state == "building":
                    nal_units.append(b"".join(pieces))
                state = None
        else:
            result.malformed_packets += 1
            dropped = True
    if state == "building":
        result.dropped_fragments += 1
        dropped = True
    return nal_units, dropped


def depacketize_h264(packets: Iterable[RtpPacket], first_sequence: int | None = None) -> Depacketized:
    """Annex B access units (start codes as `annexb`) rebuilt from H.264 packets in any order.

    A NAL unit with a missing FU-A fragment is dropped (`dropped_fragments`); an access unit with NAL units
    dropped or packets missing is still returned, flagged damaged; one left with no NAL unit is dropped."""
    result = Depacketized()
    for group in _groups(packets, first_sequence, result):
        nal_units, dropped = _h264_group(group, result)
        if not nal_units:
            result.dropped_timestamps.append(group.timestamp)
            continue
        damaged = dropped or not group.whole
        result.units.append(Unit(group.timestamp, annexb(nal_units), damaged))
        if damaged:
            result.damaged_timestamps.append(group.timestamp)
    return result


# ---------------------------------------------------------------------------------------------------- MP4V-ES


class Mp4vPacketizer(_Packetizer):
    """RFC 6416 §5 MP4V-ES packetiser: the access unit cut at MTU boundaries, no payload header."""

    payload_type = PAYLOAD_TYPE_MP4V

    def packetize(self, access_unit: bytes, timestamp: int) -> list[RtpPacket]:
        """Packets (marker on the last) of one VOP, with any configuration headers before it."""
        data = bytes(access_unit)
        if not data:
            raise SigncastError("MPEG-4 access unit is empty")
        return self._packets([data[i:i + self.mtu] for i in range(0, len(data), self.mtu)], timestamp)


def depacketize_mp4v(packets: Iterable[RtpPacket], first_sequence: int | None = None, *,
                     partial: bool = True) -> Depacketized:
    """VOPs rebuilt from MP4V-ES packets in any order. A VOP with a missing fragment is returned as the
    fragments that arrived, concatenated in order and flagged damaged (`partial=True`), or dropped."""
    result = Depacketized()
    for group in _groups(packets, first_sequence, result):
        fragments = [packet.payload for _, packet in group.packets if packet.payload]
        result.malformed_packets += len(group.packets) - len(fragments)
        whole = group.whole and len(fragments) == len(group.packets)
        if whole:
            result.units.append(Unit(group.timestamp, b"".join(fragments)))
        elif partial and fragments:
            result.units.append(Unit(group.timestamp, b"".join(fragments), damaged=True))
            result.damaged_timestamps.append(group.timestamp)
        else:
            result.dropped_timestamps.append(group.timestamp)
    return result


# ---------------------------------------------------------------------------------------------------- parameters


class ParameterPacketizer(_Packetizer):
    """signcast parameter units (FBA / BBA) in the payload format of the module docstring."""

    payload_type = PAYLOAD_TYPE_PARAMETERS

    def __init__(self, mtu: int = DEFAULT_MTU, seed: int = 0, payload_type: int | None = None) -> None:
        super().__init__(mtu, seed, payload_type)
        self.unit_number = 0      # next unit's number, mod 2^16

    def packetize_units(self, units: list[bytes], timestamp: int) -> list[RtpPacket]:
        """Packets (marker on the last) of the units of one capture instant, all at RTP `timestamp`."""
        units = [bytes(unit) for unit in units]
        if not units or any(not unit for unit in units):
            raise SigncastError("parameter packetiser needs at least one unit and no empty unit")
        room = self.mtu - _PARAM_HEADER.size
        payloads: list[bytes] = []
        pending: list[bytes] = []
        pending_first = self.unit_number

        def flush() -> None:
            if pending:
                body = b"".join(struct.pack("!H", len(u)) + u for u in pending)
                payloads.append(_PARAM_HEADER.pack(0xC0, len(pending), pending_first) + body)
                pending.clear()

        for unit in units:
            number = self.unit_number
            self.unit_number = (self.unit_number + 1) % _SEQ_MOD
            if pending and len(pending) < _MAX_AGGREGATED and sum(2 + len(u) for u in pending) + 2 + len(unit) <= room:
                pending.append(unit)
                continue
            flush()
            if 2 + len(unit) <= room:
                pending.append(unit)
                pending_first = number
                continue
            step = min(room, len(unit) - 1)     # at least two fragments: one would read as an aggregate
            for offset in range(0, len(unit), step):
                flags = (0x80 if offset == 0 else 0) | (0x40 if offset + step >= len(unit) else 0)
                payloads.append(_PARAM_HEADER.pack(flags, 1, number) + unit[offset:offset + step])
        flush()
        return self._packets(payloads, timestamp)

    def packetize(self, access_unit: bytes, timestamp: int) -> list[RtpPacket]:
        """One unit: `packetize_units([access_unit], timestamp)`."""
        return self.packetize_units([access_unit], timestamp)


def _parse_parameter_payload(payload: bytes) -> tuple[int, int, int, list[bytes]] | None:
    """(flags S/E as 2 bits, count, unit number, units or [fragment]) or None when malformed."""
    if len(payload) <= _PARAM_HEADER.size:
        return None
    flags, count, number = _PARAM_HEADER.unpack_from(payload)
    flags >>= 6
    body = payload[_PARAM_HEADER.size:]
    if flags != 0b11:
        return (flags, count, number, [body]) if count == 1 else None
    items, offset = [], 0
    while offset + 2 <= len(body) and len(items) < count:
        (size,) = struct.unpack_from("!H", body, offset)
        if size == 0 or offset + 2 + size > len(body):
            return None
        items.append(body[offset + 2:offset + 2 + size])
        offset += 2 + size
    if count == 0 or len(items) != count or offset != len(body):
        return None
    return flags, count, number, items


def depacketize_parameters(packets: Iterable[RtpPacket], first_sequence: int | None = None) -> Depacketized:
    """Whole parameter units, in order, rebuilt from packets in any order.

    A unit with a missing fragment is dropped (`dropped_fragments`). `lost_units` names every unit number
    between the lowest and highest number seen that was not returned; `damaged_timestamps` are the capture
    instants that lost packets (units of those instants that arrived whole are still returned)."""
    result = Depacketized()
    groups = _groups(packets, first_sequence, result)
    returned: set[int] = set()
    seen: list[int] = []              # lowest and highest unit number the received packets carry
    fragmented: set[int] = set()      # units seen in fragment packets
    highest: int | None = None

    def extend(number: int) -> int:
        nonlocal highest
        value = number if highest is None else _nearest(highest, number)
        highest = value if highest is None else max(highest, value)
        return value

    for group in groups:
        damaged = not group.whole
        fragment: tuple[int, int, list[bytes]] | None = None   # (unit number, last sequence, pieces)
        for sequence, packet in group.packets:
            parsed = _parse_parameter_payload(packet.payload)
            if parsed is None:
                result.malformed_packets += 1
                damaged = True
                continue
            flags, count, number, items = parsed
            number = extend(number)
            seen[:] = [min([*seen, number]), max([*seen, number + count - 1])]
            if flags == 0b11:
                result.units.extend(Unit(group.timestamp, item, number=number + i) for i, item in enumerate(items))
                returned.update(range(number, number + count))
                fragment = None
                continue
            fragmented.add(number)
            if flags == 0b10:
                fragment = (number, sequence, [items[0]])
            elif fragment is not None and fragment[0] == number and fragment[1] == sequence - 1:
                fragment[2].append(items[0])
                fragment = (number, sequence, fragment[2])
                if flags == 0b01:
                    result.units.append(Unit(group.timestamp, b"".join(fragment[2]), number=number))
                    returned.add(number)
                    fragment = None
            else:
                fragment, damaged = None, True
        if fragment is not None or any(n not in returned for n in fragmented):
            damaged = True
        if damaged:
            result.damaged_timestamps.append(group.timestamp)
    result.dropped_fragments = len(fragmented - returned)
    if seen:
        result.lost_unit_ranges = _gaps(seen[0], seen[1] + 1, sorted(returned))
    return result


# ---------------------------------------------------------------------------------------------------- helpers


_PARSERS = {"libx264": "h264", "h264": "h264", "mpeg4": "mpeg4"}


def access_units(stream: bytes, codec: str) -> list[bytes]:
    """Split an elementary stream (Annex B H.264 for "libx264", m4v for "mpeg4") into access units, in decode
    order, with FFmpeg's parser through PyAV."""
    if codec not in _PARSERS:
        raise SigncastError(f"cannot split {codec!r} into access units; choose from {', '.join(_PARSERS)}")
    try:
        context = av.CodecContext.create(_PARSERS[codec], "r")
        packets = context.parse(bytes(stream)) + context.parse(None)
    except av.error.FFmpegError as error:
        raise SigncastError(f"cannot parse {codec} stream: {error}") from None
    return [bytes(packet) for packet in packets]


# codec name (as in video_codecs) or "parameters" -> (packetiser class, depacketiser, RTP payload type)
PAYLOAD_FORMATS = {
    "libx264": (H264Packetizer, depacketize_h264, PAYLOAD_TYPE_H264),
    "mpeg4": (Mp4vPacketizer, depacketize_mp4v, PAYLOAD_TYPE_MP4V),
    "parameters": (ParameterPacketizer, depacketize_parameters, PAYLOAD_TYPE_PARAMETERS),
}

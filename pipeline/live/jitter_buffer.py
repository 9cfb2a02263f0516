"""The receiver's jitter buffer: RTP datagrams grouped by timestamp (one capture instant), released in
timestamp order as soon as a group is complete, or once it has waited `hold_s` for packets that may be lost or
reordered (the head-of-line wait is bounded by hold_s).

A group is complete when its marker packet arrived and no sequence number is missing between the end of the
previous group and the marker. Datagrams that are not RTP, or whose timestamp belongs to a group already
released, are counted (malformed_packets, late_packets) and dropped, as a real receiver must."""
from __future__ import annotations

from dataclasses import dataclass, field

from comparisons.transport import rtp
from media.errors import SigncastError

SEQUENCE_MODULUS = 1 << 16
TIMESTAMP_MODULUS = 1 << 32
DEPACKETIZERS = {"units": rtp.depacketize_parameters, "h264": rtp.depacketize_h264,
                 "mp4v": lambda packets, first: rtp.depacketize_mp4v(packets, first, partial=True)}
MAX_GROUPS = 4096            # groups held at once: a receiver bounded in memory whatever arrives


def _unwrap(value: int, reference: int | None, modulus: int) -> int:
    """The extended value nearest `reference` congruent to value modulo `modulus` (RFC 3550 A.1's idea)."""
    if reference is None:
        return value
    base = reference - reference % modulus + value
    candidates = (base - modulus, base, base + modulus)
    return min(candidates, key=lambda c: abs(c - reference))


@dataclass
class _Group:
    first_arrival: float
    packets: dict = field(default_factory=dict)     # extended sequence -> RtpPacket
    marker_sequence: int | None = None


class JitterBuffer:
    """Groups packets by timestamp; `depacketize(packets)` turns a released group's packets (sorted, with any
    sequence gap meaning loss) into its data: comparisons.transport.rtp's depacketiser of the session's payload format."""

    def __init__(self, payload: str, fps: float, hold_s: float, first_sequence: int | None = None):
        self.payload, self.fps, self.hold_s = payload, fps, hold_s
        self.first_sequence = first_sequence          # the sender's first sequence number (RTP-Info's job)
        self.groups: dict[int, _Group] = {}
        self.last_sequence: int | None = None
        self.last_timestamp: int | None = None
        self.expected_sequence: int | None = None
        self.released_through: int | None = None
        self.late_packets = self.malformed_packets = self.lost_packets = 0

    def push(self, datagram: bytes, now: float) -> None:
        try:
            packet = rtp.RtpPacket.parse(datagram)
        except SigncastError:
            self.malformed_packets += 1
            return
        sequence = _unwrap(packet.sequence, self.last_sequence, SEQUENCE_MODULUS)
        if self.expected_sequence is None and self.first_sequence is not None:
            self.expected_sequence = _unwrap(self.first_sequence, sequence, SEQUENCE_MODULUS)
        timestamp = _unwrap(packet.timestamp, self.last_timestamp, TIMESTAMP_MODULUS)
        self.last_sequence = max(sequence, self.last_sequence or sequence)
        self.last_timestamp = max(timestamp, self.last_timestamp or timestamp)
        if self.released_through is not None and timestamp <= self.released_through:
            self.late_packets += 1
            return
        group = self.groups.get(timestamp)
        if group is None:
            if len(self.groups) >= MAX_GROUPS:
                self.late_packets += 1
                return
            group = self.groups[timestamp] = _Group(now)
        group.packets.setdefault(sequence, packet)
        if packet.marker:
            group.marker_sequence = sequence

    def _complete(self, group: _Group) -> bool:
        if group.marker_sequence is None:
            return False
        first = self.expected_sequence if self.expected_sequence is not None else min(group.packets)
        return all(s in group.packets for s in range(first, group.marker_sequence + 1))

    def release(self, now: float) -> list[tuple[int, object]]:
        """[(frame index, data)] of the groups ready now, in timestamp order (now=inf releases all)."""
        out = []
        while self.groups:
            timestamp = min(self.groups)
            group = self.groups[timestamp]
            if not (self._complete(group) or now - group.first_arrival >= self.hold_s):
                break
            del self.groups[timestamp]
            sequences = sorted(group.packets)
            if self.expected_sequence is not None and sequences[0] > self.expected_sequence:
                self.lost_packets += sequences[0] - self.expected_sequence
            self.lost_packets += sequences[-1] - sequences[0] + 1 - len(sequences)
            self.released_through = timestamp
            first = self.expected_sequence
            self.expected_sequence = sequences[-1] + 1
            frame = int(round(timestamp * self.fps / rtp.CLOCK_RATE))
            packets = [group.packets[s] for s in sequences]
            out.append((frame, DEPACKETIZERS[self.payload](packets, None if first is None else first % SEQUENCE_MODULUS)))
        return out

"""The receiver's jitter buffer: RTP datagrams grouped by capture instant (the frame their timestamp names),
released in frame order as soon as a group is complete, or once it has waited `hold_s` for packets that may be
lost or reordered (the head-of-line wait is bounded by hold_s).

A group is complete when its marker packet arrived and no sequence number is missing between the end of the
previous group and the marker.

No datagram can stop the stream (issue 37). Each is checked before it may touch the buffer:
- not RTP: counted in `malformed_packets`;
- outside the window around the stream (RFC 3550 §6.2.1 and A.1, source validation): its extended sequence
  number more than MAX_MISORDER behind or MAX_DROPOUT ahead of the highest accepted one, its frame more than
  MAX_AHEAD_S ahead of the highest accepted frame or behind the first, or outside the described clip
  (0 .. n_frames - 1): counted in `discarded_packets` and dropped. A real jump (a sender that restarted, a long
  outage) is followed as RFC 3550 A.1 follows one: the packet is held on probation, and accepted (with the
  window moved to it) only when the next packet in sequence agrees with it; a lone spoofed or damaged datagram
  never gets a follower and never moves the buffer.
- its frame already released: counted in `late_packets` (it came after its frame was shown). Groups are keyed
  by frame, not by raw timestamp, so a damaged timestamp that rounds to a released frame cannot release that
  frame a second time: every frame is released at most once, in increasing order.

The hold follows the measured jitter: the interarrival jitter J of RFC 3550 §6.4.1 (transit = arrival time minus
the RTP timestamp in seconds; J += (|D| - J) / 16), and hold_s = clip(JITTER_FACTOR * J, min_hold_s, max_hold_s).
The minimum is the caller's hold_s (a frame interval or two): on a quiet loopback the buffer waits that long
for a lost packet, and it waits longer only when packets really arrive spread out.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from comparisons.transport import rtp
from media.errors import SigncastError

SEQUENCE_MODULUS = 1 << 16
TIMESTAMP_MODULUS = 1 << 32
DEPACKETIZERS = {"units": rtp.depacketize_parameters, "h264": rtp.depacketize_h264,
                 "mp4v": lambda packets, first: rtp.depacketize_mp4v(packets, first, partial=True)}
MAX_GROUPS = 4096            # groups held at once: a receiver bounded in memory whatever arrives
MAX_DROPOUT = 3000           # RFC 3550 A.1: sequence numbers ahead of the highest accepted
MAX_MISORDER = 100           # and behind it
MAX_AHEAD_S = 2.0            # capture time ahead of the highest accepted frame
JITTER_FACTOR = 4.0          # hold = this many times the measured interarrival jitter ...
MAX_HOLD_S = 0.25            # ... at most (a lost packet then costs its frame, not the conversation)


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
    last_arrival: float = 0.0


@dataclass
class _Probation:
    """A packet outside the window, waiting for the next packet in sequence to agree with it."""
    sequence: int              # extended against the old reference
    frame: int
    packet: rtp.RtpPacket
    arrival: float


class JitterBuffer:
    """Groups packets by frame; `release(now)` gives [(frame, depacketised data)] of the groups ready: the
    depacketiser of the session's payload format (comparisons.transport.rtp) applied to each released group.

    payload: "units", "h264" or "mp4v"; fps: the stream's frame rate (timestamps are frame / fps on the 90 kHz
    clock, frame 0 at timestamp 0); hold_s: the least time an incomplete group waits; first_sequence: the
    sender's first sequence number (RTSP's RTP-Info), the window's start; n_frames: the clip's length (frames
    outside it are discarded); max_hold_s: the most it waits, however large the jitter."""

    def __init__(self, payload: str, fps: float, hold_s: float, first_sequence: int | None = None,
                 n_frames: int | None = None, max_hold_s: float = MAX_HOLD_S):
        if payload not in DEPACKETIZERS:
            raise SigncastError(f"unknown payload format {payload!r}")
        self.payload, self.fps, self.n_frames = payload, float(fps), n_frames
        self.min_hold_s = float(hold_s)
        self.max_hold_s = max(float(max_hold_s), self.min_hold_s)
        self.first_sequence = first_sequence
        self.groups: dict[int, _Group] = {}
        self.highest_sequence: int | None = first_sequence - 1 if first_sequence is not None else None
        self.highest_frame: int | None = None
        self.expected_sequence: int | None = first_sequence
        self.released_through: int | None = None          # the last frame released
        self.probation: _Probation | None = None
        self.jitter_s = 0.0
        self._last_transit: float | None = None
        self.late_packets = self.malformed_packets = self.lost_packets = self.discarded_packets = 0
        self.accepted_packets = 0
        self.arrivals: dict[int, int] = {}      # frame -> its last packet's arrival (ns), for released frames

    @property
    def hold_s(self) -> float:
        return min(self.max_hold_s, max(self.min_hold_s, JITTER_FACTOR * self.jitter_s))

    @property
    def delay_s(self) -> float:
        """The longest a packet may still be waited for: what the receiver drains after the sender's BYE."""
        return self.max_hold_s

    def _frame(self, timestamp: int) -> int:
        """The frame a timestamp names, unwrapped near the highest accepted frame (frame 0 before any)."""
        reference = 0 if self.highest_frame is None else round(self.highest_frame * rtp.CLOCK_RATE / self.fps)
        return int(round(_unwrap(timestamp, reference, TIMESTAMP_MODULUS) * self.fps / rtp.CLOCK_RATE))

    def _in_clip(self, frame: int) -> bool:
        return frame >= 0 and (self.n_frames is None or frame < self.n_frames)

    def _in_window(self, sequence: int, frame: int) -> bool:
        if self.highest_sequence is not None and not (
                self.highest_sequence - MAX_MISORDER <= sequence <= self.highest_sequence + MAX_DROPOUT):
            return False
        if self.highest_frame is not None and frame > self.highest_frame + MAX_AHEAD_S * self.fps:
            return False
        return True

    def push(self, datagram: bytes, now: float) -> None:
        try:
            packet = rtp.RtpPacket.parse(datagram)
        except SigncastError:
            self.malformed_packets += 1
            return
        sequence = _unwrap(packet.sequence, self.highest_sequence, SEQUENCE_MODULUS)
        frame = self._frame(packet.timestamp)
        if not self._in_clip(frame):
            self.discarded_packets += 1
            return
        if not self._in_window(sequence, frame):
            waiting = self.probation
            if (waiting is not None and sequence == waiting.sequence + 1
                    and 0 <= frame - waiting.frame <= MAX_AHEAD_S * self.fps):
                self.probation = None                       # two in a row agree: follow the jump
                self._rebase(waiting.sequence, waiting.frame)
                self._accept(waiting.packet, waiting.sequence, waiting.frame, waiting.arrival)
                self._accept(packet, sequence, frame, now)
                return
            if waiting is not None:
                self.discarded_packets += 1                 # the held one never got a follower
            self.probation = _Probation(sequence, frame, packet, now)
            return
        if self.probation is not None:
            self.discarded_packets += 1
            self.probation = None
        self._accept(packet, sequence, frame, now)

    def _rebase(self, sequence: int, frame: int) -> None:
        """The stream really jumped: groups before it are released as they are, and the window moves."""
        self.highest_sequence = sequence - 1
        self.expected_sequence = None if not self.groups else self.expected_sequence
        self.highest_frame = None

    def _accept(self, packet: rtp.RtpPacket, sequence: int, frame: int, now: float) -> None:
        if self.released_through is not None and frame <= self.released_through:
            self.late_packets += 1
            return
        group = self.groups.get(frame)
        if group is None:
            if len(self.groups) >= MAX_GROUPS:
                self.late_packets += 1
                return
            group = self.groups[frame] = _Group(now)
        if sequence in group.packets:
            return                                          # a duplicate: the first copy is kept
        self.accepted_packets += 1
        group.packets[sequence] = packet
        group.last_arrival = max(group.last_arrival, now)
        if packet.marker:
            group.marker_sequence = sequence
        self.highest_sequence = max(sequence, self.highest_sequence if self.highest_sequence is not None else sequence)
        self.highest_frame = max(frame, self.highest_frame if self.highest_frame is not None else frame)
        transit = now - packet.timestamp / rtp.CLOCK_RATE           # RFC 3550 §6.4.1
        if self._last_transit is not None:
            self.jitter_s += (abs(transit - self._last_transit) - self.jitter_s) / 16.0
        self._last_transit = transit

    def _complete(self, group: _Group) -> bool:
        if group.marker_sequence is None:
            return False
        first = self.expected_sequence if self.expected_sequence is not None else min(group.packets)
        if group.marker_sequence - first > MAX_DROPOUT:
            return False
        return all(s in group.packets for s in range(first, group.marker_sequence + 1))

    def release(self, now: float) -> list[tuple[int, object]]:
        """[(frame index, data)] of the groups ready now, in frame order (now=inf releases all)."""
        out = []
        hold = self.hold_s
        while self.groups:
            frame = min(self.groups)
            group = self.groups[frame]
            if not (self._complete(group) or now - group.first_arrival >= hold):
                break
            del self.groups[frame]
            sequences = sorted(group.packets)
            if self.expected_sequence is not None and sequences[0] > self.expected_sequence:
                self.lost_packets += min(sequences[0] - self.expected_sequence, MAX_DROPOUT)
            self.lost_packets += sequences[-1] - sequences[0] + 1 - len(sequences)
            self.released_through = frame
            self.arrivals[frame] = int(group.last_arrival * 1e9)
            first = self.expected_sequence
            if first is not None and not 0 <= sequences[0] - first <= MAX_DROPOUT:
                first = None
            self.expected_sequence = sequences[-1] + 1
            packets = [group.packets[s] for s in sequences]
            out.append((frame, DEPACKETIZERS[self.payload](packets, None if first is None else first % SEQUENCE_MODULUS)))
        return out

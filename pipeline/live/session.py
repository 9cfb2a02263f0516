"""One live session: a sender paced at the capture rate, RTP over UDP to a receiver, and a control connection.

Control (chosen here, after RTSP's split of control and media): the receiver listens on TCP and UDP at the same
port number. The sender connects over TCP and sends the session description (one JSON line: what is sent, its
payload format, frame rate, frame count, the capture clock's start), streams RTP datagrams over UDP, and ends
with a "BYE" line. Loss applies to the media datagrams only, as it would to RTP with its description delivered by
SDP over a reliable channel.

Timing: frame i is captured at t0 + i / fps on CLOCK_MONOTONIC (time.monotonic_ns), which every process on one
machine shares, so the receiver can subtract a frame's capture time from the moment the frame is ready to show:
capture -> encode -> network -> decode -> render, per frame. Frames that never arrive are concealed (the last
shown frame held) and are left out of the latency figures; their count is reported.
"""
from __future__ import annotations

import json
import select
import socket
import time
from dataclasses import asdict, dataclass, field

import numpy as np

from comparisons.transport import rtp
from media.errors import SigncastError
from pipeline.live.jitter_buffer import JitterBuffer
from pipeline.live.network import LOOPBACK, MAX_DATAGRAM, udp_socket

START_LEAD_S = 0.1          # the capture clock starts this long after the receiver said it is ready
CONNECT_TIMEOUT_S = 30.0
READY_TIMEOUT_S = 120.0     # how long a sender waits for the receiver to build its decoder (a cold start)
CONTROL_TIMEOUT_S = 5.0     # every read of the control connection has this deadline
SESSION_GRACE_S = 10.0      # a sender that never says BYE: the session ends this long after its last capture
MAX_PENDING = 8             # control connections waiting to describe a session at once
HOLD_FRAMES = 1.0           # the jitter buffer waits at least this many frame intervals for a missing packet
MAX_DESCRIPTION = 1 << 16   # bytes of the control line
MIN_FPS = 1.0               # frame rates a session may declare: MIN_FPS .. media.domain.MAX_FPS
MAX_STREAMS = 16            # RTP streams of one session (NSV3O+C has 8)
MAX_SHOWN_BYTES = 4 << 30   # what the receiver may hold of shown frames, n_frames x height x width x 3
MAX_FRAMES = 216_000        # = comparisons.params.fba.MAX_FRAMES, the parameter coders' limit (tested equal;
                            # not imported: the receiver checks a description before it loads the coders)


def _bad(what: str) -> SigncastError:
    return SigncastError(f"bad session description from the sender: {what}")


@dataclass
class SessionDescription:
    """What the receiver needs before the first packet (an SDP's job): solution and codec, payload format
    ("units", "h264" or "mp4v"; "objects" for several streams), q, fps, n_frames, the picture's width and height,
    the capture clock's start t0_ns (CLOCK_MONOTONIC), the clip's name, free-form details (e.g. the refresh
    period) and, filled in by the sender, its RTP streams: name, payload format, SSRC and first sequence number
    (RTSP's RTP-Info) of each."""
    solution: str
    codec: str
    payload: str
    q: int
    fps: float
    n_frames: int
    width: int
    height: int
    clip: str = ""
    t0_ns: int = 0
    details: dict = field(default_factory=dict)
    streams: list = field(default_factory=list)

    def to_line(self) -> bytes:
        return (json.dumps(asdict(self)) + "\n").encode()

    @classmethod
    def from_line(cls, line: bytes) -> "SessionDescription":
        """The description a sender sent, validated (validate()); SigncastError on anything else."""
        try:
            data = json.loads(line)
            description = cls(**data)
        except (ValueError, TypeError, RecursionError) as error:
            raise _bad(str(error)[:200]) from None
        description.validate()
        return description

    def validate(self) -> None:
        """Checks the description against the limits the coders and the receiver hold to: a known solution and
        a codec it is sent with, Q in the codec's range, fps in MIN_FPS..MAX_FPS, 1..MAX_FRAMES frames (the
        parameter coders' limit), an even picture size in MIN_SIDE..MAX_SIDE whose frames fit MAX_SHOWN_BYTES,
        1..MAX_STREAMS streams with distinct SSRCs; SigncastError naming the first field that fails."""
        from media.domain import MAX_FPS, MAX_SIDE, MIN_SIDE, Solution, solution_of
        integer = lambda value: isinstance(value, int) and not isinstance(value, bool)
        for name in ("solution", "codec", "payload", "clip"):
            if not isinstance(getattr(self, name), str) or len(getattr(self, name)) > 200:
                raise _bad(f"{name} must be a short string")
        try:
            solution = Solution(self.solution)
        except ValueError:
            solution = None
        if solution is None or solution == Solution.MOTION_CODER:
            raise _bad(f"unknown solution {self.solution[:40]!r}")
        if self.payload not in PAYLOADS:
            raise _bad(f"payload format {self.payload[:40]!r}")
        if solution.kind == "parameters":
            # fba-* / bba-* by name here (light: the receiver validates before it loads any codec); an unknown
            # codec of the right family is refused when the sink is built (comparisons.params.codecs.get_codec)
            try:
                family = solution_of(self.codec)
            except SigncastError:
                family = None
            if family != solution or self.payload != "units":
                raise _bad(f"{solution} is not sent with codec {self.codec[:40]!r} in payload {self.payload!r}")
            low, high = 1, 31
        else:
            if self.codec not in VIDEO_CODECS:
                raise _bad(f"{solution} is sent live with {' or '.join(VIDEO_CODECS)}, not {self.codec[:40]!r}")
            wanted = VIDEO_CODECS[self.codec] if solution == Solution.NSV else "objects"
            if self.payload != wanted:
                raise _bad(f"{solution} with {self.codec} travels in payload {wanted!r}, not {self.payload!r}")
            low, high = (1, 31) if self.codec == "mpeg4" else (0, 51)
        if not integer(self.q) or not low <= self.q <= high:
            raise _bad(f"Q {self.q!r} outside {low}..{high}")
        if isinstance(self.fps, bool) or not isinstance(self.fps, (int, float)) or not MIN_FPS <= self.fps <= MAX_FPS:
            raise _bad(f"fps {self.fps!r} outside {MIN_FPS:g}..{MAX_FPS:g}")
        if not integer(self.n_frames) or not 1 <= self.n_frames <= MAX_FRAMES:
            raise _bad(f"frame count {self.n_frames!r} outside 1..{MAX_FRAMES}")
        for name in ("width", "height"):
            value = getattr(self, name)
            if not integer(value) or not MIN_SIDE <= value <= MAX_SIDE or value % 2:
                raise _bad(f"{name} {value!r}: an even number of pixels in {MIN_SIDE}..{MAX_SIDE}")
        if self.n_frames * self.width * self.height * 3 > MAX_SHOWN_BYTES:
            raise _bad(f"{self.n_frames} frames of {self.width}x{self.height} exceed the receiver's "
                       f"{MAX_SHOWN_BYTES >> 30} GiB of shown frames")
        if not integer(self.t0_ns) or not isinstance(self.details, dict) or not isinstance(self.streams, list):
            raise _bad("t0_ns, details or streams of the wrong type")
        if not 1 <= len(self.streams) <= MAX_STREAMS:
            raise _bad(f"{len(self.streams)} RTP streams (1..{MAX_STREAMS})")
        ssrcs = set()
        for stream in self.streams:
            if not isinstance(stream, dict):
                raise _bad("a stream that is not an object")
            ssrc, first, payload = stream.get("ssrc"), stream.get("first_sequence"), stream.get("payload")
            if not (integer(ssrc) and 0 <= ssrc < 1 << 32 and integer(first) and 0 <= first < 1 << 16
                    and payload in STREAM_PAYLOADS and isinstance(stream.get("name", ""), str)):
                raise _bad("a stream without a valid ssrc, first sequence or payload format")
            ssrcs.add(ssrc)
        if len(ssrcs) != len(self.streams):
            raise _bad("two streams share an SSRC")

    def capture_time_ns(self, index: int | np.ndarray) -> int | np.ndarray:
        return self.t0_ns + np.round(np.asarray(index) * 1e9 / self.fps).astype(np.int64)


VIDEO_CODECS = {"mpeg4": "mp4v", "libx264": "h264"}     # live video codec -> RTP payload format
LIVE_GOP = 12               # frames per intra period of the live video encoders
PAYLOADS = ("units", "h264", "mp4v", "objects")
STREAM_PAYLOADS = ("units", "h264", "mp4v")


def packetizer_for(payload: str, seed: int = 0):
    """The RTP packetiser of a payload format (comparisons.transport.rtp)."""
    if payload == "units":
        return rtp.ParameterPacketizer(seed=seed)
    if payload == "h264":
        return rtp.H264Packetizer(seed=seed)
    if payload == "mp4v":
        return rtp.Mp4vPacketizer(seed=seed)
    raise SigncastError(f"unknown payload format {payload!r}")


@dataclass
class AccessUnit:
    """What a source emits at one capture instant: the frame index its timestamp names, its bytes (for a
    "units" stream a list of units, else one access unit), and the index of its stream in source.streams."""
    frame: int
    data: bytes | list[bytes]
    stream: int = 0


@dataclass
class SendReport:
    """The sender's side: packets and bytes sent (RTP payloads, RTP packets, and the stream's own bytes), the
    time spent encoding, the frames whose capture came more than a frame late, the access units sent, and what
    the relay (when there is one) dropped."""
    packets: int = 0
    payload_bytes: int = 0
    rtp_bytes: int = 0
    media_bytes: int = 0
    encode_s: float = 0.0
    late_frames: int = 0
    access_units: list = field(default_factory=list)
    relay_dropped: int | None = None


class _LineReader:
    """Lines of a control connection, read without ever blocking: feed() once select() says the socket is
    readable, then take the complete lines; SigncastError when a line outgrows MAX_DESCRIPTION."""

    def __init__(self, link: socket.socket):
        self.link, self.buffer, self.closed = link, bytearray(), False
        link.setblocking(False)

    def feed(self) -> list[bytes]:
        try:
            chunk = self.link.recv(65536)
        except (BlockingIOError, InterruptedError):
            chunk = None
        except OSError:
            chunk = b""
        if chunk == b"":
            self.closed = True
        elif chunk:
            self.buffer.extend(chunk)
        lines = []
        while b"\n" in self.buffer:
            line, _, rest = bytes(self.buffer).partition(b"\n")
            self.buffer[:] = rest
            lines.append(line)
        if len(self.buffer) > MAX_DESCRIPTION:
            raise SigncastError("a control line is too long")
        return lines

    def line(self, deadline: float) -> bytes | None:
        """The next line, waiting at most until `deadline` (time.monotonic()); None when the peer closed or the
        deadline passed."""
        pending: list[bytes] = []
        while not pending:
            if self.closed:
                return None
            wait = deadline - time.monotonic()
            if wait <= 0:
                return None
            if select.select([self.link], [], [], wait)[0]:
                pending = self.feed()
        if pending[1:]:
            self.buffer[:0] = b"".join(line + b"\n" for line in pending[1:])
        return pending[0]


def _send_line(link: socket.socket, text: str) -> None:
    link.setblocking(True)
    link.settimeout(CONTROL_TIMEOUT_S)
    link.sendall(text.encode() + b"\n")


def send(description: SessionDescription, source, destination: tuple[str, int],
         control: tuple[str, int] | None = None, *, relay=None,
         relay_address: tuple[str, int] | None = None) -> SendReport:
    """Sends one session: the description over TCP to control (default: destination's host and port); once the
    receiver answers READY (it has built its decoder and renderer), the capture clock starts (t0, sent as PLAY):
    `source.capture(i)` at each frame's capture time, `source.finish()` after the last, each AccessUnit
    packetised and sent over UDP to the relay (a LossyRelay, or relay_address) or destination, with one timing
    line per access unit (when it was encoded and when its last datagram left) on the control connection. After
    the last datagram the relay is drained and closed, then BYE carries the count of datagrams sent and of those
    the relay dropped. Returns what was sent; SigncastError when the receiver refuses the description."""
    control = control or destination
    report = SendReport()
    try:
        link = socket.create_connection(control, timeout=CONNECT_TIMEOUT_S)
    except OSError as error:
        raise SigncastError(f"cannot reach the receiver at {control[0]}:{control[1]} (TCP): "
                            f"{error.strerror or error}") from None
    out = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    target = relay.address if relay is not None else relay_address or destination
    streams = getattr(source, "streams", None) or [(description.solution, description.payload)]
    if any(payload not in STREAM_PAYLOADS for _, payload in streams):
        raise SigncastError(f"unknown payload format among {[payload for _, payload in streams]}")
    packetizers = [packetizer_for(payload, seed=k) for k, (_, payload) in enumerate(streams)]
    try:
        description.t0_ns = 0
        description.streams = [{"name": name, "payload": payload, "ssrc": packetizer.ssrc,
                                "first_sequence": packetizer.first_sequence}
                               for (name, payload), packetizer in zip(streams, packetizers)]
        link.sendall(description.to_line())
        reader = _LineReader(link)
        answer = reader.line(time.monotonic() + READY_TIMEOUT_S)
        if answer is None or not answer.startswith(b"READY"):
            reason = "no answer" if answer is None else answer.decode("utf-8", "replace")[:300]
            raise SigncastError(f"the receiver did not accept the session: {reason}")
        description.t0_ns = time.monotonic_ns() + int(START_LEAD_S * 1e9)
        _send_line(link, f"PLAY {description.t0_ns}")

        def emit(units: list[AccessUnit], encoded_ns: int) -> None:
            for unit in units:
                timestamp = rtp.timestamp_of(unit.frame, description.fps)
                packetizer = packetizers[unit.stream]
                packets = (packetizer.packetize_units(unit.data, timestamp) if streams[unit.stream][1] == "units"
                           else packetizer.packetize(unit.data, timestamp))
                for packet in packets:
                    datagram = packet.to_bytes()
                    out.sendto(datagram, target)
                    report.packets += 1
                    report.payload_bytes += len(packet.payload)
                    report.rtp_bytes += len(datagram)
                link.sendall(f"T {unit.frame} {unit.stream} {encoded_ns} {time.monotonic_ns()}\n".encode())
                report.media_bytes += sum(map(len, unit.data)) if isinstance(unit.data, list) else len(unit.data)
                report.access_units.append(unit)

        for index in range(description.n_frames):
            wait_ns = int(description.capture_time_ns(index)) - time.monotonic_ns()
            if wait_ns > 0:
                time.sleep(wait_ns / 1e9)
            elif wait_ns < -1e9 / description.fps:
                report.late_frames += 1
            started = time.perf_counter()
            units = source.capture(index)
            report.encode_s += time.perf_counter() - started
            emit(units, time.monotonic_ns())
        started = time.perf_counter()
        units = source.finish()
        report.encode_s += time.perf_counter() - started
        emit(units, time.monotonic_ns())
        if relay is not None:
            relay.close(drain_s=1.0)
            report.relay_dropped = relay.counts.dropped
        bye = {"packets": report.packets, "relay_dropped": report.relay_dropped}
        link.sendall(b"BYE " + json.dumps(bye).encode() + b"\n")
    except OSError as error:
        raise SigncastError(f"the connection to the receiver broke: {error.strerror or error}") from None
    finally:
        out.close()
        link.close()
    return report


STAGES = ("encode", "packetise", "network", "buffer", "decode+render")


@dataclass
class ControlCounts:
    """What the receiver's control port saw: connections accepted, those dropped for stalling past
    CONTROL_TIMEOUT_S or closing before a description, descriptions rejected (invalid), and connections refused
    while a session ran."""
    connections: int = 0
    stalled: int = 0
    rejected: int = 0
    refused: int = 0
    reasons: list = field(default_factory=list)


@dataclass
class ReceiveReport:
    """The receiver's side. shown: (T, H, W, 3) uint8, the frame on screen at each capture instant;
    received: (T,) bool, frames decoded from data that arrived; ready_ns: (T,) int64 when each frame was ready to
    show (0 for concealed frames); latency_ms: (T,) float, ready minus capture time (nan where concealed);
    stages_ms: STAGES -> (T,) float, the latency split at the sender's encode and last datagram, the last
    datagram's arrival and the jitter buffer's release (nan where unknown); packets: datagrams read;
    late_packets: those read after their frame was released or after the session; discarded_packets: those
    outside the stream's window (spoofed or damaged); malformed_packets: not RTP; unknown_packets: an SSRC the
    session does not have; drained_packets: datagrams still queued when the session ended (read then, and
    counted late); packets_sent, relay_dropped: what the sender's BYE said (None without a BYE); control: the
    control port's counts; hold_ms: the jitter buffers' hold at the end (from the measured jitter)."""
    description: SessionDescription
    shown: np.ndarray
    received: np.ndarray
    ready_ns: np.ndarray
    latency_ms: np.ndarray
    packets: int = 0
    late_packets: int = 0
    rtp_bytes: int = 0
    sink_stats: dict = field(default_factory=dict)
    unknown_packets: int = 0
    discarded_packets: int = 0
    malformed_packets: int = 0
    drained_packets: int = 0
    packets_sent: int | None = None
    relay_dropped: int | None = None
    control: ControlCounts = field(default_factory=ControlCounts)
    stages_ms: dict = field(default_factory=dict)
    hold_ms: float | None = None
    jitter_ms: float | None = None

    @property
    def concealed(self) -> int:
        return int((~self.received).sum())

    def latency_summary(self) -> tuple[float | None, float | None]:
        """(median, 95th percentile) latency in ms over the frames received; None when none were."""
        return _summary(self.latency_ms)

    def stage_summary(self) -> dict[str, tuple[float | None, float | None]]:
        """stage -> (median, 95th percentile) in ms over the frames received."""
        return {stage: _summary(np.where(self.received, values, np.nan)) for stage, values in self.stages_ms.items()}

    def unaccounted_packets(self) -> int | None:
        """Datagrams sent that neither the relay dropped nor the receiver read: lost inside the host (a full
        socket buffer) or on a real network; None without the sender's counts."""
        if self.packets_sent is None:
            return None
        return max(0, self.packets_sent - (self.relay_dropped or 0) - self.packets)


def _summary(values: np.ndarray) -> tuple[float | None, float | None]:
    values = values[np.isfinite(values)]
    if not len(values):
        return None, None
    return float(np.median(values)), float(np.percentile(values, 95))


class Listener:
    """The receiver's sockets: UDP for RTP and TCP for control, on one port number (0: any free port)."""

    def __init__(self, host: str = LOOPBACK, port: int = 0):
        self.udp = udp_socket(host, port)
        self.port = self.udp.getsockname()[1]
        self.tcp = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self.tcp.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            self.tcp.bind((host, self.port))
        except OSError as error:
            self.udp.close()
            self.tcp.close()
            raise SigncastError(f"cannot listen on TCP {host}:{self.port}: {error.strerror or error}") from None
        self.tcp.listen(MAX_PENDING)
        self.address = (host, self.port)

    def close(self) -> None:
        self.udp.close()
        self.tcp.close()


def _close(link: socket.socket, answer: str | None = None) -> None:
    if answer is not None:
        try:
            link.setblocking(False)
            link.send(answer.encode()[:400] + b"\n")
        except OSError:
            pass
    try:
        link.close()
    except OSError:
        pass


def _open_session(listener: Listener, sink_for, timeout_s: float, control_timeout_s: float,
                  counts: ControlCounts):
    """(reader, description, sink) of the first connection that describes a valid session within timeout_s.
    Several connections may be pending; each must send its description within control_timeout_s of connecting
    or is dropped (counts.stalled); an invalid description, or one the sink cannot be built for, is answered
    REJECT and counted (counts.rejected). Then READY is sent and PLAY awaited (control_timeout_s)."""
    deadline = time.monotonic() + timeout_s
    pending: dict[socket.socket, tuple[_LineReader, float]] = {}
    try:
        while True:
            now = time.monotonic()
            for link, (_, expiry) in list(pending.items()):
                if now >= expiry:
                    counts.stalled += 1
                    _close(link, "REJECT no session description in time")
                    del pending[link]
            if now >= deadline:
                raise SigncastError(f"no sender connected within {timeout_s:g} s")
            wait = min([deadline] + [expiry for _, expiry in pending.values()]) - now
            readable, _, _ = select.select([listener.tcp, *pending], [], [], max(0.0, min(wait, 0.5)))
            for link in readable:
                if link is listener.tcp:
                    try:
                        link, _ = listener.tcp.accept()
                    except OSError:
                        continue
                    counts.connections += 1
                    if len(pending) >= MAX_PENDING:
                        oldest = min(pending, key=lambda k: pending[k][1])
                        counts.stalled += 1
                        _close(oldest, "REJECT too many pending connections")
                        del pending[oldest]
                    pending[link] = (_LineReader(link), time.monotonic() + control_timeout_s)
                    continue
                reader, _ = pending[link]
                try:
                    lines = reader.feed()
                    if not lines:
                        if reader.closed:
                            counts.stalled += 1
                            _close(link)
                            del pending[link]
                        continue
                    description = SessionDescription.from_line(lines[0])
                    sink = sink_for(description)
                except SigncastError as error:
                    counts.rejected += 1
                    counts.reasons.append(str(error)[:200])
                    _close(link, f"REJECT {error}")
                    del pending[link]
                    continue
                del pending[link]
                try:
                    _send_line(link, "READY")
                    reader = _LineReader(link)
                    play = reader.line(time.monotonic() + control_timeout_s)
                    t0 = int(play.split()[1]) if play is not None and play.startswith(b"PLAY ") else None
                except (OSError, ValueError, IndexError):
                    t0 = None
                if t0 is None:
                    counts.stalled += 1
                    _close(link)
                    continue
                description.t0_ns = t0
                return reader, description, sink
    finally:
        for link in pending:
            counts.refused += 1
            _close(link, "REJECT another session started")


def _read_datagrams(udp: socket.socket, limit: int = 256):
    """Up to `limit` datagrams queued on the (non-blocking) socket, with the time each was read."""
    got = []
    for _ in range(limit):
        try:
            datagram = udp.recv(MAX_DATAGRAM)
        except (BlockingIOError, InterruptedError):
            break
        got.append((datagram, time.monotonic_ns()))
    return got


def receive(listener: Listener, sink_for, *, timeout_s: float = 60.0,
            control_timeout_s: float = CONTROL_TIMEOUT_S) -> ReceiveReport:
    """Receives one session on `listener`: waits (at most timeout_s) for a sender's valid description (others
    are dropped and counted: _open_session), makes the sink with sink_for(description), answers READY, then
    feeds the sink every access unit as the jitter buffer releases it, until the sender's BYE plus the jitter
    buffers' delay; datagrams still queued then are read too (counted late). Returns what was shown, when, and
    what every datagram and connection came to."""
    counts = ControlCounts()
    reader, description, sink = _open_session(listener, sink_for, timeout_s, control_timeout_s, counts)
    link = reader.link
    n = description.n_frames
    ready_ns = np.zeros(n, np.int64)
    buffers = _jitter_buffers(description)
    k_streams = len(description.streams)
    sent_at = np.zeros((2, k_streams, n), np.int64)          # encoded, last datagram sent (sender's clock)
    seen_at = np.zeros((2, k_streams, n), np.int64)          # last datagram read, released by the buffer
    packets = rtp_bytes = unknown = drained = 0
    packets_sent = relay_dropped = None
    listener.udp.setblocking(False)

    def show(now_ns: int) -> None:
        for ssrc, (stream, jitter_buffer) in buffers.items():
            for frame, data in jitter_buffer.release(now_ns / 1e9):
                seen_at[0, stream, frame] = jitter_buffer.arrivals.pop(frame, 0)
                seen_at[1, stream, frame] = time.monotonic_ns()
                for index in sink.receive(frame, data, stream):
                    if 0 <= index < n and not ready_ns[index]:
                        ready_ns[index] = time.monotonic_ns()

    def take(datagrams) -> None:
        nonlocal packets, rtp_bytes, unknown
        for datagram, at_ns in datagrams:
            packets += 1
            rtp_bytes += len(datagram)
            target = buffers.get(int.from_bytes(datagram[8:12], "big")) if len(datagram) >= 12 else None
            if target is None:
                unknown += 1
            else:
                target[1].push(datagram, at_ns / 1e9)

    def control(lines) -> bool:
        nonlocal packets_sent, relay_dropped
        for line in lines:
            parts = line.split()
            if len(parts) == 5 and parts[0] == b"T":
                try:
                    frame, stream, encoded, sent = (int(p) for p in parts[1:])
                except ValueError:
                    continue
                if 0 <= frame < n and 0 <= stream < k_streams:
                    sent_at[:, stream, frame] = encoded, sent
            elif parts[:1] == [b"BYE"]:
                try:
                    said = json.loads(line[3:]) if len(line) > 3 else {}
                    packets_sent = int(said["packets"]) if said.get("packets") is not None else None
                    relay_dropped = int(said["relay_dropped"]) if said.get("relay_dropped") is not None else None
                except (ValueError, TypeError, AttributeError, KeyError):
                    pass
                return True
        return False

    end_by = time.monotonic() + START_LEAD_S + n / description.fps + SESSION_GRACE_S
    drain_s = max(jitter_buffer.delay_s for _, jitter_buffer in buffers.values())
    try:
        stop_at = None
        while True:
            now = time.monotonic()
            if stop_at is not None and now >= stop_at or stop_at is None and now >= end_by:
                break
            waiting = [listener.udp, listener.tcp] + ([link] if stop_at is None else [])
            readable, _, _ = select.select(waiting, [], [], 0.005)
            if listener.tcp in readable:
                try:
                    other, _ = listener.tcp.accept()
                    counts.connections += 1
                    counts.refused += 1
                    _close(other, "REJECT a session is running")
                except OSError:
                    pass
            if link in readable:
                try:
                    said_bye = control(reader.feed())
                except SigncastError:
                    said_bye = True
                if said_bye or reader.closed:
                    stop_at = time.monotonic() + drain_s
            if listener.udp in readable:
                take(_read_datagrams(listener.udp))
            show(time.monotonic_ns())
        while True:                                    # what is still queued: read, counted as late
            left = _read_datagrams(listener.udp)
            if not left:
                break
            drained += len(left)
            take(left)
        show(time.monotonic_ns())
        show(1 << 62)
        shown, received = sink.finish()
    finally:
        _close(link)
        listener.udp.setblocking(True)
    received = received & (ready_ns > 0)
    capture = description.capture_time_ns(np.arange(n))
    latency = np.where(received, (ready_ns - capture) / 1e6, np.nan)
    stages = _stages(capture, sent_at, seen_at, ready_ns, received)
    values = [jitter_buffer for _, jitter_buffer in buffers.values()]
    late = sum(b.late_packets for b in values)
    return ReceiveReport(description, shown, received, ready_ns, latency, packets, late + drained, rtp_bytes,
                         dict(getattr(sink, "stats", {}) or {}), unknown,
                         discarded_packets=sum(b.discarded_packets for b in values),
                         malformed_packets=sum(b.malformed_packets for b in values), drained_packets=drained,
                         packets_sent=packets_sent, relay_dropped=relay_dropped, control=counts,
                         stages_ms=stages, hold_ms=1e3 * max(b.hold_s for b in values),
                         jitter_ms=1e3 * max(b.jitter_s for b in values))


def _filled(times: np.ndarray) -> np.ndarray:
    """(streams, T) stamps with each frame given its access unit's: the latest stamped frame at or before it
    (a unit of several frames is stamped at its first); 0 where none is."""
    out = np.zeros_like(times)
    for k, row in enumerate(times):
        index = np.where(row > 0, np.arange(len(row)), -1)
        index = np.maximum.accumulate(index)
        out[k] = np.where(index >= 0, row[np.clip(index, 0, None)], 0)
    return out


def _stages(capture: np.ndarray, sent_at: np.ndarray, seen_at: np.ndarray, ready_ns: np.ndarray,
            received: np.ndarray) -> dict[str, np.ndarray]:
    """STAGES -> (T,) ms: capture -> encoded -> last datagram sent -> last datagram read -> released -> ready,
    each frame taking the latest of its streams (a frame needs them all)."""
    encoded, sent = (_filled(a).max(axis=0) for a in sent_at)
    arrived, released = (_filled(a).max(axis=0) for a in seen_at)
    marks = [capture, encoded, sent, arrived, released, ready_ns]
    known = received & np.all([m > 0 for m in marks[1:]], axis=0)
    return {stage: np.where(known, (b - a) / 1e6, np.nan) for stage, a, b in zip(STAGES, marks[:-1], marks[1:])}


def _jitter_buffers(description: SessionDescription) -> dict[int, tuple[int, JitterBuffer]]:
    """SSRC -> (stream index, its jitter buffer), from the description's streams."""
    if not description.streams:
        raise SigncastError("bad session description from the sender: no RTP stream")
    buffers = {}
    for k, stream in enumerate(description.streams):
        try:
            ssrc, payload, first = int(stream["ssrc"]), stream["payload"], int(stream["first_sequence"])
        except (KeyError, TypeError, ValueError):
            raise SigncastError("bad session description from the sender: a stream without ssrc, payload or "
                                "first sequence") from None
        if payload not in STREAM_PAYLOADS:
            raise SigncastError(f"bad session description from the sender: payload format {payload!r}")
        buffers[ssrc] = (k, JitterBuffer(payload, description.fps, hold_s=HOLD_FRAMES / description.fps,
                                         first_sequence=first, n_frames=description.n_frames))
    return buffers

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

START_LEAD_S = 0.3          # the capture clock starts this long after the description is sent
DRAIN_S = 0.5               # after BYE the receiver keeps listening this long for late datagrams
CONNECT_TIMEOUT_S = 30.0
HOLD_FRAMES = 2.0           # the jitter buffer waits at most this many frame intervals for a missing packet
MAX_DESCRIPTION = 1 << 20   # bytes of the control line


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
        try:
            data = json.loads(line)
            description = cls(**data)
        except (ValueError, TypeError) as error:
            raise SigncastError(f"bad session description from the sender: {error}") from None
        if description.payload not in PAYLOADS or not description.fps > 0 or description.n_frames < 1:
            raise SigncastError("bad session description from the sender: payload, fps or frame count")
        return description

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
    time spent encoding, the frames whose capture came more than a frame late, and the access units sent."""
    packets: int = 0
    payload_bytes: int = 0
    rtp_bytes: int = 0
    media_bytes: int = 0
    encode_s: float = 0.0
    late_frames: int = 0
    access_units: list = field(default_factory=list)


def send(description: SessionDescription, source, destination: tuple[str, int],
         control: tuple[str, int] | None = None, *, relay_address: tuple[str, int] | None = None) -> SendReport:
    """Sends one session: `source.capture(i)` at each frame's capture time, `source.finish()` after the last,
    each AccessUnit packetised and sent over UDP to relay_address (or destination), the description and BYE over
    TCP to control (default: destination's host and port). Returns what was sent."""
    control = control or destination
    report = SendReport()
    try:
        link = socket.create_connection(control, timeout=CONNECT_TIMEOUT_S)
    except OSError as error:
        raise SigncastError(f"cannot reach the receiver at {control[0]}:{control[1]} (TCP): "
                            f"{error.strerror or error}") from None
    out = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    target = relay_address or destination
    streams = getattr(source, "streams", None) or [(description.solution, description.payload)]
    if any(payload not in STREAM_PAYLOADS for _, payload in streams):
        raise SigncastError(f"unknown payload format among {[payload for _, payload in streams]}")
    packetizers = [packetizer_for(payload, seed=k) for k, (_, payload) in enumerate(streams)]
    try:
        description.t0_ns = time.monotonic_ns() + int(START_LEAD_S * 1e9)
        description.streams = [{"name": name, "payload": payload, "ssrc": packetizer.ssrc,
                                "first_sequence": packetizer.first_sequence}
                               for (name, payload), packetizer in zip(streams, packetizers)]
        link.sendall(description.to_line())

        def emit(units: list[AccessUnit]) -> None:
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
            emit(units)
        started = time.perf_counter()
        units = source.finish()
        report.encode_s += time.perf_counter() - started
        emit(units)
        link.sendall(b"BYE\n")
    except OSError as error:
        raise SigncastError(f"the connection to the receiver broke: {error.strerror or error}") from None
    finally:
        out.close()
        link.close()
    return report


@dataclass
class ReceiveReport:
    """The receiver's side. shown: (T, H, W, 3) uint8, the frame on screen at each capture instant;
    received: (T,) bool, frames decoded from data that arrived; ready_ns: (T,) int64 when each frame was ready to
    show (0 for concealed frames); latency_ms: (T,) float, ready minus capture time (nan where concealed);
    packets, late_packets: datagrams received, and those that came after their access unit was used."""
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

    @property
    def concealed(self) -> int:
        return int((~self.received).sum())

    def latency_summary(self) -> tuple[float | None, float | None]:
        """(median, 95th percentile) latency in ms over the frames received; None when none were."""
        values = self.latency_ms[np.isfinite(self.latency_ms)]
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
        self.tcp.listen(1)
        self.address = (host, self.port)

    def close(self) -> None:
        self.udp.close()
        self.tcp.close()


def _read_line(link: socket.socket, buffer: bytearray) -> bytes | None:
    """One line from the control connection (None when it closed); SigncastError beyond MAX_DESCRIPTION."""
    while b"\n" not in buffer:
        chunk = link.recv(65536)
        if not chunk:
            return None
        buffer.extend(chunk)
        if len(buffer) > MAX_DESCRIPTION:
            raise SigncastError("the sender's control line is too long")
    line, _, rest = bytes(buffer).partition(b"\n")
    buffer[:] = rest
    return line


def receive(listener: Listener, sink_for, *, timeout_s: float = 60.0) -> ReceiveReport:
    """Receives one session on `listener`: waits (at most timeout_s) for a sender's description, makes the sink
    with sink_for(description), then feeds it every access unit as the jitter buffer releases it until BYE (and
    DRAIN_S more), and returns what was shown and when."""
    ready, _, _ = select.select([listener.tcp], [], [], timeout_s)
    if not ready:
        raise SigncastError(f"no sender connected within {timeout_s:g} s")
    link, _ = listener.tcp.accept()
    buffer = bytearray()
    try:
        line = _read_line(link, buffer)
        if line is None:
            raise SigncastError("the sender closed the connection before describing the session")
        description = SessionDescription.from_line(line)
        sink = sink_for(description)
        n = description.n_frames
        ready_ns = np.zeros(n, np.int64)
        buffers = _jitter_buffers(description)
        packets = rtp_bytes = unknown = 0

        def show(now: float) -> None:
            for ssrc, (stream, jitter_buffer) in buffers.items():
                for frame, data in jitter_buffer.release(now):
                    for index in sink.receive(frame, data, stream):
                        if 0 <= index < n and not ready_ns[index]:
                            ready_ns[index] = time.monotonic_ns()

        bye_at = None
        while True:
            now = time.monotonic()
            if bye_at is not None and now - bye_at > DRAIN_S:
                break
            waiting = [listener.udp] + ([link] if bye_at is None else [])
            readable, _, _ = select.select(waiting, [], [], 0.005)
            if link in readable:
                if _read_line(link, buffer) in (None, b"BYE"):
                    bye_at = time.monotonic()
            if listener.udp in readable:
                datagram = listener.udp.recv(MAX_DATAGRAM)
                packets += 1
                rtp_bytes += len(datagram)
                target = buffers.get(int.from_bytes(datagram[8:12], "big")) if len(datagram) >= 12 else None
                if target is None:
                    unknown += 1
                else:
                    target[1].push(datagram, time.monotonic())
            show(time.monotonic())
        show(float("inf"))
        shown, received = sink.finish()
    finally:
        link.close()
    received = received & (ready_ns > 0)
    latency = np.where(received, (ready_ns - description.capture_time_ns(np.arange(n))) / 1e6, np.nan)
    late = sum(jitter_buffer.late_packets for _, jitter_buffer in buffers.values())
    return ReceiveReport(description, shown, received, ready_ns, latency, packets, late, rtp_bytes,
                         dict(getattr(sink, "stats", {}) or {}), unknown)


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
                                         first_sequence=first))
    return buffers

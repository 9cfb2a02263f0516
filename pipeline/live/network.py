"""UDP on the loopback interface: sockets, and a relay that drops, delays and reorders datagrams as a seeded
network model decides (comparisons.transport.loss.NetworkModel).

The relay runs in its own thread between a sender and a receiver: it receives every datagram on its own port,
asks the model whether to drop it and how long to hold it, and forwards it to the receiver when its delay is
over (a heap ordered by release time, so a packet held longer than its successor arrives after it: that is
reordering). Decisions depend only on the seed and the datagram's arrival order, so a run is repeatable."""
from __future__ import annotations

import heapq
import itertools
import select
import socket
import threading
import time
from dataclasses import dataclass

from media.errors import SigncastError

LOOPBACK = "127.0.0.1"
MAX_DATAGRAM = 65_535
RECEIVE_BUFFER = 4 << 20        # bytes: a 2-core machine can fall a few hundred ms behind without kernel drops


def udp_socket(host: str = LOOPBACK, port: int = 0) -> socket.socket:
    """A UDP socket bound to (host, port) (port 0: any free port) with a large receive buffer."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, RECEIVE_BUFFER)
    try:
        sock.bind((host, port))
    except OSError as error:
        sock.close()
        raise SigncastError(f"cannot listen on UDP {host}:{port}: {error.strerror or error}") from None
    return sock


def parse_address(text: str, default_host: str = LOOPBACK) -> tuple[str, int]:
    """'HOST:PORT' or 'PORT' -> (host, port); SigncastError on anything else."""
    host, _, port_text = str(text).rpartition(":")
    try:
        port = int(port_text)
    except ValueError:
        port = -1
    if not 0 < port < 65536:
        raise SigncastError(f"bad address {text!r}: give PORT or HOST:PORT with a port in 1..65535")
    return host or default_host, port


@dataclass
class RelayCounts:
    """Datagrams the relay received, dropped and forwarded."""
    received: int = 0
    dropped: int = 0
    forwarded: int = 0


class LossyRelay:
    """Forwards datagrams arriving on its port to `destination`, through `model` (None: forward at once).

    Use as a context manager; `address` is where senders send."""

    def __init__(self, destination: tuple[str, int], model=None, host: str = LOOPBACK):
        self.destination, self.model = destination, model
        self.sock = udp_socket(host, 0)
        self.address = self.sock.getsockname()
        self.counts = RelayCounts()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="lossy-relay", daemon=True)

    def __enter__(self) -> "LossyRelay":
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self, drain_s: float = 0.0) -> None:
        """Forwards what is still held (waiting at most drain_s past its release), then stops; once."""
        if self._stop.is_set():
            return
        self._drain_s = drain_s
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join()
        self.sock.close()

    def _run(self) -> None:
        held: list[tuple[float, int, bytes]] = []
        order = itertools.count()
        out = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            while True:
                now = time.monotonic()
                while held and held[0][0] <= now:
                    out.sendto(heapq.heappop(held)[2], self.destination)
                    self.counts.forwarded += 1
                if self._stop.is_set():
                    self.sock.setblocking(False)            # what the sender sent before close() is still
                    while True:                             # queued on our socket: it goes through the model too
                        try:
                            data = self.sock.recv(MAX_DATAGRAM)
                        except (BlockingIOError, InterruptedError):
                            break
                        self._take(data, held, order)
                    deadline = now + getattr(self, "_drain_s", 0.0)
                    for release, _, data in sorted(held):
                        if release > deadline:               # held past the drain: the network lost it
                            self.counts.dropped += 1
                            continue
                        time.sleep(max(0.0, release - time.monotonic()))
                        out.sendto(data, self.destination)
                        self.counts.forwarded += 1
                    return
                wait = 0.02 if not held else max(0.0, min(0.02, held[0][0] - now))
                ready, _, _ = select.select([self.sock], [], [], wait)
                if not ready:
                    continue
                self._take(self.sock.recv(MAX_DATAGRAM), held, order)
        finally:
            out.close()

    def _take(self, data: bytes, held: list, order) -> None:
        """One datagram through the model: counted, dropped or held until its release time."""
        self.counts.received += 1
        dropped, delay_s = self.model.next() if self.model is not None else (False, 0.0)
        if dropped:
            self.counts.dropped += 1
            return
        heapq.heappush(held, (time.monotonic() + float(delay_s), next(order), data))

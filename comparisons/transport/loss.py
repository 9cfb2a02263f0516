"""Seeded network models for live delivery: which packets are lost and how late the others arrive.

- `Bernoulli(rate, seed)`: every packet is lost independently with probability `rate`.
- `GilbertElliott(p_good_to_bad, p_bad_to_good, loss_in_good, loss_in_bad, seed)`: a two-state Markov chain
  (Gilbert 1960, Elliott 1963) stepped once per packet; a packet in state G is lost with probability
  `loss_in_good`, in state B with `loss_in_bad`. With p = p_good_to_bad and r = p_bad_to_good the stationary
  probability of B is pi_B = p / (p + r), so the mean loss rate is

      loss = (1 - pi_B) * loss_in_good + pi_B * loss_in_bad = (r * loss_in_good + p * loss_in_bad) / (p + r).

  A stay in B lasts 1 / r packets on average (geometric), which is the mean loss-burst length when
  loss_in_good = 0 and loss_in_bad = 1 (the simple Gilbert model). `GilbertElliott.from_rate(rate, burst)` builds
  that model: r = 1 / burst, p = rate * r / (1 - rate). The chain starts in a state drawn from the stationary
  distribution.
- `NetworkModel(loss, jitter_ms, base_delay_ms, reorder_rate, reorder_delay_ms, seed)`: loss plus one-way delay.
  delay = base_delay_ms + |N(0, jitter_ms)| (jitter_ms is the standard deviation of a half-normal extra delay,
  chosen here so that no packet arrives before base_delay_ms); a share `reorder_rate` of packets is held back by
  a further `reorder_delay_ms`, so it arrives after the packets sent within that time after it.

Every model draws from `numpy.random.default_rng(seed)` (a separate stream per purpose, spawned from the seed),
so the same seed gives the same decisions, and deciding n packets at once or one by one gives the same result.
`parse_loss_spec("none" | "bernoulli:RATE" | "ge:RATE:BURST")` builds a loss model from a command-line string.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from media.errors import SigncastError


def _check_probability(name: str, value: float) -> float:
    value = float(value)
    if not 0.0 <= value <= 1.0:       # also rejects NaN
        raise SigncastError(f"{name} must be in [0, 1], got {value}")
    return value


def _check_count(n_packets: int) -> int:
    if int(n_packets) != n_packets or n_packets < 0:
        raise SigncastError(f"number of packets must be a non-negative integer, got {n_packets}")
    return int(n_packets)


class Bernoulli:
    """Independent losses at `rate` (0..1)."""

    def __init__(self, rate: float, seed: int = 0) -> None:
        self.rate = _check_probability("loss rate", rate)
        self.seed = seed
        self._rng = np.random.default_rng(seed)

    @property
    def mean_loss_rate(self) -> float:
        return self.rate

    def decide(self, n_packets: int) -> np.ndarray:
        """(n_packets,) bool: True where the packet is lost."""
        return self._rng.random(_check_count(n_packets)) < self.rate

    def next(self) -> bool:
        """Whether the next packet is lost."""
        return bool(self.decide(1)[0])

    def __repr__(self) -> str:
        return f"Bernoulli(rate={self.rate}, seed={self.seed})"


class GilbertElliott:
    """Two-state Markov loss model; the module docstring gives the stationary loss rate."""

    def __init__(self, p_good_to_bad: float, p_bad_to_good: float, loss_in_good: float = 0.0,
                 loss_in_bad: float = 1.0, seed: int = 0) -> None:
        self.p_good_to_bad = _check_probability("Gilbert-Elliott P(good -> bad)", p_good_to_bad)
        self.p_bad_to_good = _check_probability("Gilbert-Elliott P(bad -> good)", p_bad_to_good)
        self.loss_in_good = _check_probability("loss probability in the good state", loss_in_good)
        self.loss_in_bad = _check_probability("loss probability in the bad state", loss_in_bad)
        self.seed = seed
        state_seed, loss_seed = np.random.SeedSequence(seed).spawn(2)
        self._state_rng = np.random.default_rng(state_seed)
        self._loss_rng = np.random.default_rng(loss_seed)
        self._bad = bool(self._state_rng.random() < self.stationary_bad)
        self._left = self._draw_stay()      # packets left in the current state (inf: stays forever)

    @classmethod
    def from_rate(cls, mean_loss_rate: float, mean_burst_length: float, seed: int = 0) -> GilbertElliott:
        """Simple Gilbert model (loss 0 in G, 1 in B) with the given mean loss rate and mean burst length
        (packets, >= 1)."""
        rate = _check_probability("mean loss rate", mean_loss_rate)
        burst = float(mean_burst_length)
        if not burst >= 1.0:
            raise SigncastError(f"mean burst length must be >= 1 packet, got {mean_burst_length}")
        if rate >= 1.0:
            raise SigncastError("a Gilbert-Elliott loss rate must be below 1 (use bernoulli:1 to lose everything)")
        p_bad_to_good = 1.0 / burst
        p_good_to_bad = rate * p_bad_to_good / (1.0 - rate)
        if p_good_to_bad > 1.0:
            raise SigncastError(f"loss rate {rate} with mean burst {burst} packets needs P(good -> bad) > 1; "
                                "use a longer burst")
        return cls(p_good_to_bad, p_bad_to_good, 0.0, 1.0, seed)

    @property
    def stationary_bad(self) -> float:
        """Stationary probability of the bad state, p / (p + r) (0 when the chain never moves)."""
        total = self.p_good_to_bad + self.p_bad_to_good
        return self.p_good_to_bad / total if total > 0 else 0.0

    @property
    def mean_loss_rate(self) -> float:
        bad = self.stationary_bad
        return (1.0 - bad) * self.loss_in_good + bad * self.loss_in_bad

    @property
    def mean_burst_length(self) -> float:
        """Mean stay in the bad state, packets (the loss-burst length of the simple Gilbert model)."""
        return 1.0 / self.p_bad_to_good if self.p_bad_to_good > 0 else float("inf")

    def _draw_stay(self) -> float:
        leave = self.p_bad_to_good if self._bad else self.p_good_to_bad
        return float(self._state_rng.geometric(leave)) if leave > 0 else float("inf")

    def decide(self, n_packets: int) -> np.ndarray:
        """(n_packets,) bool: True where the packet is lost."""
        n_packets = _check_count(n_packets)
        bad = np.empty(n_packets, dtype=bool)
        filled = 0
        while filled < n_packets:
            take = int(min(self._left, n_packets - filled))
            bad[filled:filled + take] = self._bad
            filled += take
            self._left -= take
            if self._left == 0:
                self._bad = not self._bad
                self._left = self._draw_stay()
        chance = np.where(bad, self.loss_in_bad, self.loss_in_good)
        return self._loss_rng.random(n_packets) < chance

    def next(self) -> bool:
        """Whether the next packet is lost."""
        return bool(self.decide(1)[0])

    def __repr__(self) -> str:
        return (f"GilbertElliott(p_good_to_bad={self.p_good_to_bad:.6g}, p_bad_to_good={self.p_bad_to_good:.6g}, "
                f"loss_in_good={self.loss_in_good}, loss_in_bad={self.loss_in_bad}, seed={self.seed})")


LossModel = Bernoulli | GilbertElliott


@dataclass(frozen=True)
class Decisions:
    """The network's decisions for n packets, in sending order."""

    dropped: np.ndarray     # (n,) bool
    delay_s: np.ndarray     # (n,) float64, one-way delay in seconds (meaningless where dropped)


class NetworkModel:
    """Loss model plus delay: base delay, half-normal jitter (std `jitter_ms`) and occasional hold-backs."""

    def __init__(self, loss: LossModel | None = None, jitter_ms: float = 0.0, base_delay_ms: float = 0.0,
                 reorder_rate: float = 0.0, reorder_delay_ms: float = 30.0, seed: int = 0) -> None:
        for name, value in (("jitter", jitter_ms), ("base delay", base_delay_ms), ("reorder delay", reorder_delay_ms)):
            if not float(value) >= 0.0 or not np.isfinite(value):
                raise SigncastError(f"{name} must be a finite number of ms >= 0, got {value}")
        self.loss = loss if loss is not None else Bernoulli(0.0, seed)
        self.jitter_ms = float(jitter_ms)
        self.base_delay_ms = float(base_delay_ms)
        self.reorder_rate = _check_probability("reorder rate", reorder_rate)
        self.reorder_delay_ms = float(reorder_delay_ms)
        jitter_seed, reorder_seed = np.random.SeedSequence(seed).spawn(2)
        self._jitter_rng = np.random.default_rng(jitter_seed)
        self._reorder_rng = np.random.default_rng(reorder_seed)

    def decide(self, n_packets: int) -> Decisions:
        """Decisions for the next n_packets packets."""
        n_packets = _check_count(n_packets)
        dropped = self.loss.decide(n_packets)
        delay_ms = self.base_delay_ms + np.abs(self._jitter_rng.standard_normal(n_packets)) * self.jitter_ms
        held = self._reorder_rng.random(n_packets) < self.reorder_rate
        delay_ms = delay_ms + held * self.reorder_delay_ms
        return Decisions(dropped, delay_ms / 1000.0)

    def next(self) -> tuple[bool, float]:
        """(lost, delay_s) for the next packet."""
        decisions = self.decide(1)
        return bool(decisions.dropped[0]), float(decisions.delay_s[0])


def parse_loss_spec(text: str, seed: int = 0) -> LossModel:
    """A loss model from "none", "bernoulli:RATE" or "ge:RATE:MEAN_BURST" (rates in [0, 1], burst in packets)."""
    parts = str(text).strip().lower().split(":")
    try:
        numbers = [float(part) for part in parts[1:]]
    except ValueError:
        numbers = None
    if parts == ["none"]:
        return Bernoulli(0.0, seed)
    if numbers is not None and parts[0] == "bernoulli" and len(numbers) == 1:
        return Bernoulli(numbers[0], seed)
    if numbers is not None and parts[0] == "ge" and len(numbers) == 2:
        return GilbertElliott.from_rate(numbers[0], numbers[1], seed)
    raise SigncastError(f"loss model {text!r} not understood; use none, bernoulli:RATE or ge:RATE:MEAN_BURST")

"""Seeded loss and delay models: measured rates and bursts match the configuration, same seed same decisions."""
from __future__ import annotations

import numpy as np
import pytest

from comparisons.transport.loss import (
    Bernoulli,
    GilbertElliott,
    NetworkModel,
    parse_loss_spec,
)
from media.errors import SigncastError

N = 200_000


def burst_lengths(lost: np.ndarray) -> np.ndarray:
    """Lengths of the runs of consecutive True values."""
    edges = np.diff(np.concatenate([[0], lost.astype(np.int8), [0]]))
    return np.flatnonzero(edges == -1) - np.flatnonzero(edges == 1)


@pytest.mark.parametrize("rate", [0.0, 0.01, 0.05, 0.3])
def test_bernoulli_measured_rate_matches(rate):
    lost = Bernoulli(rate, seed=1).decide(N)
    assert lost.shape == (N,) and lost.dtype == bool
    assert abs(lost.mean() - rate) <= 4 * np.sqrt(rate * (1 - rate) / N) + 1e-12


@pytest.mark.parametrize("rate, burst", [(0.02, 4.0), (0.1, 2.5), (0.05, 1.0)])
def test_gilbert_elliott_rate_and_burst_length_match(rate, burst):
    model = GilbertElliott.from_rate(rate, burst, seed=2)
    assert model.mean_loss_rate == pytest.approx(rate) and model.mean_burst_length == pytest.approx(burst)
    lost = model.decide(N)
    bursts = burst_lengths(lost)
    assert abs(lost.mean() - rate) < 0.15 * rate
    assert abs(bursts.mean() - burst) < 0.1 * burst
    assert lost.sum() == bursts.sum()


def test_gilbert_elliott_losses_in_both_states_follow_the_stationary_formula():
    model = GilbertElliott(0.05, 0.2, loss_in_good=0.01, loss_in_bad=0.6, seed=3)
    expected = (0.2 * 0.01 + 0.05 * 0.6) / 0.25
    assert model.mean_loss_rate == pytest.approx(expected)
    assert abs(model.decide(N).mean() - expected) < 0.1 * expected


def test_gilbert_elliott_losses_are_bursty_not_independent():
    lost = GilbertElliott.from_rate(0.05, 5.0, seed=4).decide(N)
    after_loss = lost[1:][lost[:-1]].mean()
    assert after_loss > 0.7          # P(loss | previous lost) = 1 - 1/5; Bernoulli would give 0.05


def as_list(decisions) -> list:
    """Loss decisions, or (dropped, delay_s) pairs for a NetworkModel, as a plain list."""
    if hasattr(decisions, "delay_s"):
        return list(zip(decisions.dropped.tolist(), decisions.delay_s.tolist()))
    return decisions.tolist()


@pytest.mark.parametrize("make", [lambda s: Bernoulli(0.1, s), lambda s: GilbertElliott.from_rate(0.1, 3.0, s),
                                  lambda s: NetworkModel(GilbertElliott.from_rate(0.1, 3.0, s), 5.0, 20.0, 0.1,
                                                         seed=s)])
def test_same_seed_same_decisions_in_one_batch_or_many(make):
    whole = as_list(make(7).decide(5000))
    model = make(7)
    pieces = [d for n in (1, 999, 0, 2500, 1500) for d in as_list(model.decide(n))]
    one_by_one = make(7)
    singles = [one_by_one.next() for _ in range(50)]
    assert whole == pieces
    assert singles == whole[:50]
    assert whole != as_list(make(8).decide(5000))


def test_network_model_delays_jitter_and_reordering():
    network = NetworkModel(Bernoulli(0.0, 1), jitter_ms=4.0, base_delay_ms=30.0, reorder_rate=0.05,
                           reorder_delay_ms=50.0, seed=5)
    decisions = network.decide(N)
    assert not decisions.dropped.any() and decisions.delay_s.shape == (N,)
    delay_ms = decisions.delay_s * 1000
    assert delay_ms.min() >= 30.0
    held = delay_ms > 30.0 + 4.0 * 5.5      # no half-normal draw reaches 5.5 sigma in 200k
    assert abs(held.mean() - 0.05) < 0.005
    assert np.mean(delay_ms[~held] - 30.0) == pytest.approx(4.0 * np.sqrt(2 / np.pi), rel=0.02)
    send_s = np.arange(N) * 0.002           # a packet every 2 ms: a held one lands behind its successors
    arrival = send_s + decisions.delay_s
    overtaken = arrival[:-1] > arrival[1:]
    assert overtaken[held[:-1]].mean() > 0.95


def test_network_model_without_loss_or_delay_passes_everything_at_once():
    decisions = NetworkModel(seed=0).decide(100)
    assert not decisions.dropped.any() and not decisions.delay_s.any()


@pytest.mark.parametrize("build", [
    lambda: Bernoulli(1.5), lambda: Bernoulli(-0.1), lambda: Bernoulli(float("nan")),
    lambda: GilbertElliott(0.1, 1.2), lambda: GilbertElliott(0.1, 0.5, loss_in_bad=2.0),
    lambda: GilbertElliott.from_rate(0.1, 0.5), lambda: GilbertElliott.from_rate(1.0, 3.0),
    lambda: GilbertElliott.from_rate(0.8, 1.0),
    lambda: NetworkModel(jitter_ms=-1.0), lambda: NetworkModel(base_delay_ms=float("inf")),
    lambda: NetworkModel(reorder_rate=1.1), lambda: Bernoulli(0.1).decide(-1),
])
def test_invalid_parameters_raise_signcast_error(build):
    with pytest.raises(SigncastError):
        build()


def test_parse_loss_spec():
    assert parse_loss_spec("none").decide(1000).sum() == 0
    bernoulli = parse_loss_spec("bernoulli:0.02", seed=3)
    assert isinstance(bernoulli, Bernoulli) and bernoulli.rate == 0.02
    ge = parse_loss_spec(" GE:0.05:4 ")
    assert isinstance(ge, GilbertElliott)
    assert (ge.mean_loss_rate, ge.mean_burst_length) == (pytest.approx(0.05), pytest.approx(4.0))
    for text in ["", "bernoulli", "bernoulli:x", "bernoulli:0.1:2", "ge:0.05", "gilbert:0.1:2", "none:1"]:
        with pytest.raises(SigncastError, match="not understood"):
            parse_loss_spec(text)
    for text in ["bernoulli:2", "ge:0.05:0.5", "ge:nan:3"]:
        with pytest.raises(SigncastError):
            parse_loss_spec(text)

"""Fair matching of solutions on intelligibility: the cheapest rate whose intelligibility reaches a threshold, and
the lowest frame rate at which it still holds.

Points are measured records (dicts) with "kbps" and the fields the criteria read. A point meets the threshold when
it meets every criterion; a missing (None) or non-finite value never does.

Chosen here:
- the matched rate is the cheapest rate above which every swept point meets the threshold (a cheap point that
  meets it by chance, below a dearer one that misses it, does not count): the cheapest point of that run of
  points is the "upper" bracket, the next cheaper swept point (which misses) the "lower" one;
- between the two, each criterion's value is taken as linear in log-rate, and the matched rate is where the last
  criterion reaches its threshold; the record fields at that rate are interpolated the same way;
- when even the dearest point misses, the match is not reached and its rate is that of the best point (the one
  that misses the criteria by the smallest margin, in units of each criterion's threshold distance);
- when the cheapest swept point already meets the threshold, the rate is its own (no cheaper bracket).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from media.errors import SigncastError


@dataclass(frozen=True)
class Criterion:
    """field >= threshold (higher_is_better) or field <= threshold."""

    field: str
    threshold: float
    higher_is_better: bool = True
    label: str = ""

    def value(self, point: dict) -> float | None:
        value = point.get(self.field)
        if value is None or not isinstance(value, (int, float)) or not math.isfinite(value):
            return None
        return float(value)

    def met(self, point: dict) -> bool:
        value = self.value(point)
        if value is None:
            return False
        return value >= self.threshold - 1e-9 if self.higher_is_better else value <= self.threshold + 1e-9

    def shortfall(self, point: dict) -> float:
        """How far the point is from the threshold (0 when met), in the field's units; inf when missing."""
        value = self.value(point)
        if value is None:
            return math.inf
        gap = self.threshold - value if self.higher_is_better else value - self.threshold
        return max(gap, 0.0)

    def text(self) -> str:
        return f"{self.label or self.field} {'>=' if self.higher_is_better else '<='} {self.threshold:.4g}"


def threshold_text(criteria: list[Criterion]) -> str:
    """'hand PCK@0.2 >= 98 and letter top-1 >= 100' (units as the labels give them)."""
    return " and ".join(c.text() for c in criteria)


def meets(point: dict, criteria: list[Criterion]) -> bool:
    return all(c.met(point) for c in criteria)


@dataclass(frozen=True)
class Match:
    """kbps: the matched rate; upper: the cheapest point of the run that meets the threshold (or the best point
    when not reached); lower: the next cheaper swept point (it misses), or None; fraction: where kbps lies between
    them in log-rate (0 at lower, 1 at upper); reached: whether any run of points meets the threshold."""

    kbps: float
    upper: dict
    lower: dict | None
    fraction: float
    reached: bool


def cheapest_rate(points: list[dict], criteria: list[Criterion]) -> Match:
    """The cheapest rate (kbps) meeting every criterion (see the module's description); points: >= 1 records."""
    if not points:
        raise SigncastError("no swept point to match")
    if not criteria:
        raise SigncastError("matching needs at least one criterion")
    ordered = sorted(points, key=lambda p: p["kbps"])
    k = len(ordered)
    while k > 0 and meets(ordered[k - 1], criteria):
        k -= 1
    if k == len(ordered):            # even the dearest point misses
        best = min(ordered, key=lambda p: (_miss(p, criteria), -p["kbps"]))
        return Match(float(best["kbps"]), best, None, 1.0, False)
    upper = ordered[k]
    if k == 0:
        return Match(float(upper["kbps"]), upper, None, 1.0, True)
    lower = ordered[k - 1]
    fraction = max(_crossing(lower, upper, c) for c in criteria)
    return Match(_log_between(lower["kbps"], upper["kbps"], fraction), upper, lower, fraction, True)


def _miss(point: dict, criteria: list[Criterion]) -> float:
    """Sum over criteria of the shortfall relative to the threshold's size (inf when a value is missing)."""
    return sum(c.shortfall(point) / max(abs(c.threshold), 1e-6) for c in criteria)


def _crossing(lower: dict, upper: dict, criterion: Criterion) -> float:
    """Where, in [0, 1] from lower to upper, the criterion's value (linear in log-rate) reaches its threshold."""
    if criterion.met(lower):
        return 0.0
    low, high = criterion.value(lower), criterion.value(upper)
    if low is None or high is None or high == low:
        return 1.0
    return min(max((criterion.threshold - low) / (high - low), 0.0), 1.0)


def _log_between(low: float, high: float, fraction: float) -> float:
    if low <= 0 or high <= 0:
        return low + fraction * (high - low)
    return math.exp(math.log(low) + fraction * (math.log(high) - math.log(low)))


def fields_at(match: Match, names: tuple[str, ...]) -> dict:
    """The named numeric fields at the matched rate: linear in log-rate between the bracketing points (the upper
    point's where there is no lower one, or where either value is missing)."""
    out = {}
    for name in names:
        high = match.upper.get(name)
        low = match.lower.get(name) if match.lower is not None else None
        if _finite(high) and _finite(low):
            out[name] = float(low + match.fraction * (high - low))
        elif high is not None:
            out[name] = high
    return out


def _finite(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def lowest_fps_holding(points: list[dict], criteria: list[Criterion]) -> float | None:
    """The lowest frame rate (the points' "fps") down to which every swept rate, from the highest, meets every
    criterion; None when the highest rate already misses. points: one per frame rate, at one Q."""
    holding = None
    for point in sorted(points, key=lambda p: -p["fps"]):
        if not meets(point, criteria):
            break
        holding = float(point["fps"])
    return holding

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

With monotone=True the criteria are judged on each criterion's monotone fit over the swept points instead of the
values as measured: intelligibility does not fall when bits (or frames) are added, so a measured fall is the
landmark extractor's noise, and the least-squares fit that never falls (isotonic regression, pooling adjacent
violators, every point weighted alike: `monotone_fit`) pools the points that disagree. The matched rate,
bracket and crossing follow from the fitted values; Match.fitted holds them at the matched rate, while
`fields_at` still interpolates the measured fields.
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
    fitted: dict | None = None       # monotone=True: each criterion's fitted value at the matched rate


def cheapest_rate(points: list[dict], criteria: list[Criterion], *, monotone: bool = False) -> Match:
    """The cheapest rate (kbps) meeting every criterion (see the module's description); points: >= 1 records;
    monotone: judge each criterion on its monotone fit over the points (non-decreasing in rate where higher is
    better) rather than on the values as measured."""
    if not points:
        raise SigncastError("no swept point to match")
    if not criteria:
        raise SigncastError("matching needs at least one criterion")
    ordered = sorted(points, key=lambda p: p["kbps"])
    judged = _fitted(ordered, criteria) if monotone else ordered
    k = len(ordered)
    while k > 0 and meets(judged[k - 1], criteria):
        k -= 1
    if k == len(ordered):            # even the dearest point misses
        best = min(range(k), key=lambda i: (_miss(judged[i], criteria), -ordered[i]["kbps"]))
        return Match(float(ordered[best]["kbps"]), ordered[best], None, 1.0, False,
                     _fields(judged[best], criteria) if monotone else None)
    if k == 0:
        return Match(float(ordered[0]["kbps"]), ordered[0], None, 1.0, True,
                     _fields(judged[0], criteria) if monotone else None)
    fraction = max(_crossing(judged[k - 1], judged[k], c) for c in criteria)
    fitted = _fields(judged[k - 1], criteria, judged[k], fraction) if monotone else None
    return Match(_log_between(ordered[k - 1]["kbps"], ordered[k]["kbps"], fraction), ordered[k], ordered[k - 1],
                 fraction, True, fitted)


def monotone_fit(values: list[float | None], increasing: bool = True) -> list[float | None]:
    """The least-squares fit of values (in the order given) that never decreases (increasing) or never increases,
    every value weighted alike: pool adjacent violators, each pooled run taking its mean. None (a missing value)
    is left out of the fit and stays None."""
    present = [i for i, v in enumerate(values) if v is not None]
    sign = 1.0 if increasing else -1.0
    blocks: list[list[float]] = []              # [sum, count] of each pooled run, means non-decreasing
    for i in present:
        blocks.append([sign * values[i], 1.0])
        while len(blocks) > 1 and blocks[-2][0] / blocks[-2][1] > blocks[-1][0] / blocks[-1][1]:
            total, count = blocks.pop()
            blocks[-1][0] += total
            blocks[-1][1] += count
    fitted: list[float | None] = [None] * len(values)
    position = iter(present)
    for total, count in blocks:
        for _ in range(int(count)):
            fitted[next(position)] = sign * total / count
    return fitted


def _fitted(ordered: list[dict], criteria: list[Criterion]) -> list[dict]:
    """Copies of the points (ordered along the swept axis) with each criterion's field replaced by its monotone fit:
    non-decreasing along the axis where higher is better, non-increasing where lower is."""
    judged = [dict(point) for point in ordered]
    for criterion in criteria:
        fit = monotone_fit([criterion.value(point) for point in ordered], criterion.higher_is_better)
        for point, value in zip(judged, fit):
            point[criterion.field] = value
    return judged


def _fields(point: dict, criteria: list[Criterion], upper: dict | None = None, fraction: float = 0.0) -> dict:
    """Each criterion's value at point, or fraction of the way from point to upper (linear; upper's value where
    either is missing)."""
    values = {}
    for c in criteria:
        low = c.value(point)
        high = c.value(upper) if upper is not None else low
        values[c.field] = high if low is None or high is None else low + fraction * (high - low)
    return values


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


def lowest_fps_holding(points: list[dict], criteria: list[Criterion], *, monotone: bool = False) -> float | None:
    """The lowest frame rate (the points' "fps") down to which every swept rate, from the highest, meets every
    criterion; None when the highest rate already misses. points: one per frame rate, at one Q; monotone: judge
    each criterion on its monotone fit over the frame rates (as cheapest_rate does over the rates)."""
    ordered = sorted(points, key=lambda p: p["fps"])
    judged = _fitted(ordered, criteria) if monotone else ordered
    holding = None
    for point in reversed(judged):
        if not meets(point, criteria):
            break
        holding = float(point["fps"])
    return holding


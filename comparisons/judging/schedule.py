"""What to measure next, so that only what decides a match is measured (issue 36). Pure functions on point records
(dicts with "q", "kbps", "fps" and the criteria's fields, their draws under "draw_values").

- The Q sweep runs coarse to fine as a search over the swept Q (`next_swept_q`): the first point is the middle of
  the swept Q; then, on the monotone fit of the points measured so far (comparisons.judging.matching), the middle
  of the swept Q still unmeasured between the bracket's two points (finer than the dearest point where it misses,
  coarser than the cheapest where it meets), asked for by the fit of the means or by any extraction's own fit. A
  series stops when no swept Q is left between any of those fits' crossing points: every fit has crossed the
  threshold between two neighbours of the sweep. The Q sweep alone would measure
  every swept Q; a point outside the bracket moves the fit only where it reads against the trend (the extractor's
  noise), which the later extractions check.
- Extractions are added where the answer is unclear (`extractions_agree`): each extraction is matched on its own
  (its draw of every point and of the threshold's record: comparisons.judging.operating.extraction_matches); where
  those matches disagree on the verdict or the bracket, the series' points get more (the ceilings and the anchor
  have them all from the start, so every point's draw k pairs with the threshold's draw k).
- The frame rates at the matched Q run from the highest down (`next_frame_rate`), and stop at the first rate whose
  monotone fit misses: no lower rate can hold once a higher one does not.
"""
from __future__ import annotations

from comparisons.judging import matching


def _middle(candidates: list[int]) -> int:
    """The middle of candidates ordered coarse to fine (high Q first); of two, the coarser."""
    ordered = sorted(candidates, reverse=True)
    return ordered[(len(ordered) - 1) // 2]


def _candidates(found: matching.Match, measured: set[int], unmeasured: list[int]) -> set[int]:
    """The unmeasured swept Q where a match asks for its next point: finer than the finest measured where it is not
    reached, coarser than its point where the cheapest meets, else strictly between its bracket's two Q."""
    if not found.reached:
        finest = min(measured)
        return {q for q in unmeasured if q < finest}
    if found.lower is None:
        coarsest = int(found.upper["q"])
        return {q for q in unmeasured if q > coarsest}
    upper, lower = int(found.upper["q"]), int(found.lower["q"])
    return {q for q in unmeasured if min(upper, lower) < q < max(upper, lower)}


def next_swept_q(swept: tuple[int, ...] | list[int], points: list[dict], criteria: list[matching.Criterion],
                 extractions: list[tuple[list[dict], list[matching.Criterion]]] = ()) -> int | None:
    """The next swept Q to measure for one series, or None where its search is over (see the module's
    description). points: the series' Q-sweep points measured so far (refined points included: they bound the
    search like any other); extractions: each extraction's (points, criteria) as it alone read them
    (operating.pick), whose matches ask for points too: the search stops only where the fit of the means and every
    extraction's fit have crossed the threshold between neighbours of the sweep (clearly crossed)."""
    measured = {int(p["q"]) for p in points}
    unmeasured = [int(q) for q in swept if int(q) not in measured]
    if not unmeasured:
        return None
    if not points:
        return _middle(unmeasured)
    wanted = _candidates(matching.cheapest_rate(points, criteria, monotone=True), measured, unmeasured)
    for points_k, criteria_k in extractions:
        wanted |= _candidates(matching.cheapest_rate(points_k, criteria_k, monotone=True), measured, unmeasured)
    return _middle(sorted(wanted)) if wanted else None


def _bracket(found: matching.Match) -> tuple:
    return (found.reached, int(found.upper["q"]), None if found.lower is None else int(found.lower["q"]))


def extractions_agree(matches: list[matching.Match]) -> bool:
    """Whether the per-extraction matches give one verdict within one bracket (the same upper and lower point)."""
    return len({_bracket(found) for found in matches}) <= 1


def bracket_points(points: list[dict], found: matching.Match) -> list[dict]:
    """The points a match rests on: its upper and lower bracket points (the best point where not reached)."""
    keys = {id(found.upper)} | ({id(found.lower)} if found.lower is not None else set())
    return [p for p in points if id(p) in keys]


def next_frame_rate(rates: list[float], points: list[dict], criteria: list[matching.Criterion]) -> float | None:
    """The next frame rate (from rates, all below the full rate) to measure at a series' matched Q, or None where
    the sweep is over: from the highest rate down, stopping once the monotone fit over the rates measured (points:
    the full-rate point at that Q and the lower rates measured so far) misses at one of them."""
    measured = {float(p["fps"]) for p in points}
    holding = matching.lowest_fps_holding(points, criteria, monotone=True)
    lowest = min(measured)
    if holding is None or holding > lowest:        # a measured rate misses: no lower one can hold
        return None
    lower = [r for r in sorted(rates, reverse=True) if r not in measured and r < lowest]
    return lower[0] if lower else None

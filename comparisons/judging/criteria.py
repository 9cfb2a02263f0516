"""The six-criteria scores of seed 000 §4.2.4 (Tables 4.1-4.5 and 4.17); scores 1..6, 6 = best.

Tables 4.1-4.5 are judgements about production, terminals and interaction that a bitrate run cannot
re-measure: they are carried over from the source, each with the one-line reason it gives. The
bandwidth row (Table 4.17) is recomputed from measured kbps: the solution with the lowest rate at
its operating point scores 6, the next 5, and so on (ties share the better score). Where the operating point is
the rate at matched intelligibility, a solution that never reaches the threshold (its rate is that of its best
point, below the threshold) ranks after every solution that does, whatever its rate.
"""
from __future__ import annotations

from media.domain import Solution

# The source tables' six columns, in its order: media.domain.Solution without NSV3O+C, NSV-ROI (today's counterpart,
# not in the source) and the seed-002 motion coders, which have no column of their own here.
SOLUTIONS = tuple(s for s in Solution if s not in (Solution.NSV3O_C, Solution.NSV_ROI, Solution.MOTION_CODER))

CARRIED_OVER = {
    "4.1 Equipment at the producer's side": (
        (6, 5, 4, 2, 3, 3),
        "NSV needs only a camera; objects add segmentation software; SSV, FBA and BBA need good models and motion capture "
        "(FBA also segmentation and deformation tables)."),
    "4.2 Real-time production": (
        (6, 6, 5, 4, 4, 4),
        "Capture and colour keying run in real time; robust 3-object segmentation needs tracking; motion capture is real-time "
        "but calibration is slow."),
    "4.3 Reusability of the content": (
        (1, 1, 1, 5, 6, 6),
        "Video cannot be recomposed into new signs; synthetic motion can be retargeted and collected into libraries."),
    "4.4 Terminal capabilities": (
        (6, 6, 6, 6, 5, 4),
        "Video needs only a decoder; FBA needs rigid transforms (ran on a set-top box without 3D hardware); BBA needs skinning."),
    "4.5 User interaction": (
        (2, 2, 2, 2, 6, 6),
        "Video allows play, pause and seek; FBA/BBA in a 3D scene allow viewpoint changes, zooming on hands or face, another avatar."),
}
SOURCE_BANDWIDTH_SCORES = (1, 2, 3, 4, 5, 6)   # Table 4.17 of the source


def bandwidth_scores(kbps_by_solution: dict[str, float], below_threshold: frozenset | set = frozenset()) -> dict[str, int]:
    """Score 6 for the lowest measured kbps, 5 for the next, ...; solutions without a measure are left out; those in
    below_threshold (not reached at any swept point) rank after all the others (by their rate among themselves)."""
    measured = sorted((name in below_threshold, kbps, name) for name, kbps in kbps_by_solution.items()
                      if kbps is not None)
    measured = [(kbps if not below else kbps + 1e12, name) for below, kbps, name in measured]
    scores, rank = {}, 0
    previous = None
    for position, (kbps, name) in enumerate(measured):
        if previous is None or kbps > previous * 1.0001:
            rank = position
        scores[name] = 6 - rank
        previous = kbps
    return scores


def criteria_table(kbps_by_solution: dict[str, float], below_threshold: frozenset | set = frozenset(),
                   basis: str = "kbps at each solution's operating point") -> list[dict]:
    """Rows {criterion, NSV..BBA scores, reason} with the measured bandwidth row and a sum row; below_threshold:
    the solutions whose rate is below the threshold (ranked last, `bandwidth_scores`); basis: what the rates are."""
    rows = [{"criterion": name, **dict(zip(SOLUTIONS, scores)), "reason": reason}
            for name, (scores, reason) in CARRIED_OVER.items()]
    measured = bandwidth_scores(kbps_by_solution, below_threshold)
    below = [s for s in SOLUTIONS if s in below_threshold]
    rows.append({"criterion": "4.17 Required bandwidth (measured here)",
                 **{s: measured.get(s) for s in SOLUTIONS},
                 "reason": f"Ranked by this run's {basis}"
                           + (f"; below the threshold at every swept point, ranked last: {', '.join(below)}" if below else "")
                           + " (source: "
                           + ", ".join(f"{s} {v}" for s, v in zip(SOLUTIONS, SOURCE_BANDWIDTH_SCORES)) + ")."})
    rows.append({"criterion": "Sum", **{s: sum(r[s] for r in rows if r[s] is not None) for s in SOLUTIONS}, "reason": ""})
    return rows

"""Each solution's operating point: the threshold tied to the uncoded reference, the next Q to measure, the matched
record with how clear its verdict is and its rate's jackknife error. Pure functions on records (dicts with a
"kind": "point", "uncoded", "matched"), on top of comparisons.judging.matching.

- The threshold (`criteria_for`): hand PCK@0.2 within PCK_MARGIN points of the ceiling (the uncoded reference,
  resampled by sub-pixel shifts and re-extracted) where the reference shows a hand in at least MIN_HAND_SHARE of
  its frames, else face error within FACE_MARGIN interocular distances of it; on fingerspelling also letter top-1
  no more than LETTER_MARGIN letters of the word below the ceiling's (none where the ceiling reads no letter).
- Refinement (`q_to_refine`): the next Q inside the matched bracket, or beyond the swept Q where none or all of
  them meet the threshold.
- Verdicts are taken on each criterion's monotone fit over the swept Q (JUDGED_ON). A matched record carries
  kbps_se (`rate_spread`: the jackknife standard error of a reached rate over the extractions, kbit/s) and
  verdict_margin_se (`verdict_margin`: standard errors between the fit at the dearest point and the threshold),
  with verdict_clear when that is at least CLEAR_VERDICT_SE.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from comparisons.judging import matching
from comparisons.judging.judge import LOSSLESS, SOURCE, UNCODED_SUBJECTS
from comparisons.judging.landmark_draws import draw_values, leave_out
from comparisons.reports.records import INTELLIGIBILITY_FIELDS
from media.domain import MAX_Q, MIN_Q, Solution

PCK_MARGIN = 2.0             # hand PCK@0.2 points below the uncoded reference's (re-extracted after resampling)
# letter top-1 below the uncoded reference's, in letters of the word: with several extractions, a letter the ceiling
# reads may be missed in fewer than half of them (one extraction: no letter may be lost)
LETTER_MARGIN = 0.5
FACE_MARGIN = 0.02           # face error, interocular distances above the uncoded reference's
MIN_HAND_SHARE = 0.1         # a reference showing a hand in fewer frames is matched on the face
JUDGED_ON = ("each criterion's monotone fit over the swept Q (and frame rates) of the means over the extractions "
             "(comparisons.judging.matching, monotone=True)")
# a verdict (reached or not) this many standard errors from its threshold is clear; nearer, too close to call for the
# extractions made (comparisons.judging.matching.verdict_margin)
CLEAR_VERDICT_SE = 2.0
QUALITY_FIELDS = ("image_psnr", "ssim", "skin_psnr", "skin_ssim")


@dataclass(frozen=True)
class Series:
    """One solution with one codec, swept over Q."""
    solution: str
    codec: str

    @property
    def avatar(self) -> bool:
        return Solution(self.solution).avatar

    @property
    def reference(self) -> str:
        """The reference the series is matched against: the lossless render for an avatar solution, else the
        source video."""
        return LOSSLESS if self.avatar else SOURCE

    def points(self, records: list[dict], sweep: str = "q") -> list[dict]:
        """The series' point records of one sweep ("q" or "fps") against its own reference."""
        return [r for r in records if r.get("kind") == "point" and r["solution"] == self.solution
                and r["codec"] == self.codec and r.get("sweep") == sweep and r.get("reference") == self.reference]


def ceiling(records: list[dict], reference: str) -> dict:
    """The ceiling record of a reference: its uncoded frames, resampled and re-extracted."""
    return next(r for r in records if r.get("kind") == "uncoded" and r["reference"] == reference
                and r["subject"] == UNCODED_SUBJECTS[reference])


def criteria_for(ceiling: dict, hand_share: float, n_letters: int) -> list[matching.Criterion]:
    """The threshold tied to a ceiling record (the uncoded reference re-extracted): hand PCK@0.2 within PCK_MARGIN
    points of it where the reference shows a hand in at least MIN_HAND_SHARE of its frames (hand_share, 0-1), else
    face error within FACE_MARGIN; and letter top-1 within LETTER_MARGIN letters of a word of n_letters, where the
    ceiling reads any letter (a ceiling that reads none leaves letters nothing to hold)."""
    if hand_share >= MIN_HAND_SHARE and ceiling.get("hand_pck_20") is not None:
        found = [matching.Criterion("hand_pck_20", ceiling["hand_pck_20"] - PCK_MARGIN, label="hand PCK@0.2 %")]
    else:
        found = [matching.Criterion("face_error", (ceiling.get("face_error") or 0.0) + FACE_MARGIN,
                                    higher_is_better=False, label="face error (interocular)")]
    if ceiling.get("letter_top1"):
        margin = 100.0 * LETTER_MARGIN / max(n_letters, 1)
        found.append(matching.Criterion("letter_top1", ceiling["letter_top1"] - margin, label="letter top-1 %"))
    return found


def q_to_refine(found: matching.Match, measured: set[int]) -> int | None:
    """The Q to measure next for a match, one step of its refinement; None when there is none to measure:
    - reached between two swept Q: the rounded geometric middle of the two, moved off them (None where the two are
      adjacent);
    - not reached (even the dearest point misses): the geometric middle of MIN_Q and the finest swept Q, moved off
      it (None where that is MIN_Q): the match is looked for beyond the sweep, at finer Q;
    - reached at the cheapest swept point (no lower bracket): the geometric middle of its Q and MAX_Q, moved off it
      (None where that is MAX_Q), for a bracket below it.
    None also where that Q is measured already. measured: the series' swept Q."""
    if not found.reached:
        finest = min(measured)
        q = _geometric_middle(MIN_Q, finest, MIN_Q, finest - 1) if finest > MIN_Q else None
    elif found.lower is None:
        coarsest = int(found.upper["q"])
        q = _geometric_middle(coarsest, MAX_Q, coarsest + 1, MAX_Q) if coarsest < MAX_Q else None
    else:
        low, high = sorted((int(found.lower["q"]), int(found.upper["q"])))
        q = _geometric_middle(low, high, low + 1, high - 1) if high - low >= 2 else None
    return None if q in measured else q


def _geometric_middle(low: int, high: int, least: int, most: int) -> int:
    """round(sqrt(low * high)), held within least..most."""
    return min(max(round((low * high) ** 0.5), least), most)


def mark_operating(points: list[dict], kbps: float, criteria: list[matching.Criterion]) -> None:
    """Sets operating_point (and operating_rule) on the swept point nearest the matched rate kbps (log-rate)."""
    nearest = min(points, key=lambda r: abs(np.log(max(r["kbps"], 1e-9)) - np.log(max(kbps, 1e-9))))
    nearest["operating_point"] = True
    nearest["operating_rule"] = f"nearest the matched rate: {matching.threshold_text(criteria)}"


def _shifted_draws(values: list[float | None] | None, offset: float) -> list[float | None] | None:
    """A ceiling's values in each extraction moved by its threshold's offset from its mean: the threshold draw by
    draw."""
    return None if values is None else [None if v is None else v + offset for v in values]


def verdict_margin(points: list[dict], criteria: list[matching.Criterion], ceiling: dict) -> float | None:
    """A series' verdict margin in standard errors (comparisons.judging.matching.verdict_margin), each point against
    the threshold draw by draw: the ceiling's extractions moved by the threshold's offset from their mean."""
    threshold_draws = {c.field: _shifted_draws(draw_values(ceiling, c.field),
                                               c.threshold - (ceiling.get(c.field) or 0.0)) for c in criteria}
    return matching.verdict_margin(points, criteria, draw_values, threshold_draws)


def rate_spread(points: list[dict], ceiling: dict, criteria_of, found: matching.Match, count: int) -> float | None:
    """The jackknife standard error (kbit/s) of a reached match's rate over count landmark extractions: replicate k
    leaves extraction k out of every point and of the ceiling (landmark_draws.leave_out: the same draw everywhere,
    as the draws are paired) and matches again with criteria_of(ceiling replicate); SE = sqrt((K - 1) / K *
    sum (rate_k - mean)^2). None for a match not reached (its rate is the best point's, not a crossing) or with one
    extraction."""
    if count < 2 or not found.reached:
        return None
    rates = np.array([matching.cheapest_rate([leave_out(point, k) for point in points],
                                             criteria_of(leave_out(ceiling, k)), monotone=True).kbps
                      for k in range(count)])
    return float(np.sqrt((count - 1) / count * np.sum((rates - rates.mean()) ** 2)))


def matched_record(series: Series, found: matching.Match, criteria: list[matching.Criterion], *, clip: str,
                   fps_holds: float | None, kbps_se: float | None, margin: float | None) -> dict:
    """The series at its matched rate ("matched" record): the criteria's fields are their monotone fits there (what
    the match was judged on; the measured values, interpolated, under "measured"), every other field interpolated
    in log-rate between the bracketing points (the point's own without a lower bracket). fps_holds: the lowest
    frame rate down to which the threshold holds; kbps_se: `rate_spread`; margin: `verdict_margin`."""
    lower = found.lower
    qs = [found.upper["q"]] + ([lower["q"]] if lower is not None else [])
    fields_at = "interpolated in log-rate between the bracketing points" if lower is not None else "the point's own"
    fields = matching.fields_at(found, (*INTELLIGIBILITY_FIELDS, *QUALITY_FIELDS, "joint_error_mm_mean"))
    measured = {name: fields.get(name) for name in found.fitted}
    return {"kind": "matched", "solution": series.solution, "codec": series.codec, "clip": clip,
            "reference": series.reference, "kbps": found.kbps, "kbps_se": kbps_se,
            "q_low": min(qs), "q_high": max(qs),
            "bracket_kbps": [lower["kbps"] if lower is not None else found.upper["kbps"], found.upper["kbps"]],
            "q_shown": found.upper["q"], "threshold": matching.threshold_text(criteria),
            "reached": found.reached, "verdict_margin_se": margin if margin is not None and np.isfinite(margin) else None,
            "verdict_clear": None if margin is None else bool(abs(margin) >= CLEAR_VERDICT_SE),
            "fps_holds": fps_holds, "fields_at": fields_at, "judged_on": JUDGED_ON,
            **fields, **found.fitted, "measured": measured}

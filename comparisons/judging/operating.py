"""Each solution's operating point: the threshold tied to the uncoded reference, the next Q to measure, the matched
record with how clear its verdict is. Pure functions on records (dicts with a "kind": "point", "uncoded",
"matched"), on top of comparisons.judging.matching.

- The threshold (`criteria_for`): hand PCK@0.2 within PCK_MARGIN points of the ceiling (the uncoded reference,
  resampled by sub-pixel shifts and re-extracted) where the reference shows a hand in at least MIN_HAND_SHARE of
  its frames, and then also the face: the aligned mouth and eyes/brows error (message_face) within FACE_MARGIN
  interocular distances of the ceiling's (a solution reaches only where hands AND face meet their thresholds);
  where the reference shows hands in fewer frames, the face alone; on fingerspelling also letter top-1 no more
  than LETTER_MARGIN letters of the word below the ceiling's (none where the ceiling reads no letter). The
  human-anchored threshold (`anchored_criteria`) holds the same criteria at the anchor's own values.
- Refinement (`q_to_refine`): the next Q inside the matched bracket, or beyond the swept Q where none or all of
  them meet the threshold.
- Verdicts are taken on each criterion's monotone fit over the swept Q (JUDGED_ON), each extraction matched on its
  own (`extraction_matches`): the rate is the median of the K rates, with their range, and the verdict is clear
  when all K agree (`extraction_summary`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from comparisons.judging import matching
from comparisons.judging.judge import LOSSLESS, SOURCE, UNCODED_SUBJECTS
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
QUALITY_FIELDS = ("image_psnr", "ssim", "skin_psnr", "skin_ssim")
# the sensitivity table: the ceiling-tied threshold's hand margin, points under the ceiling
SENSITIVITY_MARGINS = (1.0, 2.0, 3.0, 4.0)
LOCATION_MARGIN = 0.02       # message fidelity: wrist location, shoulder widths above the ceiling's
# the human-anchored threshold: the source itself coded at a viewer-judged operating point, Tran et al. (ASSETS 2013;
# TACCESS 2015): 320x240 (the clip's size scaled to fit it), 10 fps, 60 kbit/s H.264, found intelligible by signers
ANCHOR_CODEC = "libx264"
ANCHOR_SIZE = (320, 240)
ANCHOR_FPS = 10.0
ANCHOR_KBPS = 60.0
ANCHOR_SUBJECT = "source coded at Tran et al.'s point (H.264, 320x240, 10 fps, 60 kbit/s)"
HUMAN_ANCHORED = "human-anchored"
CEILING_TIED = "ceiling-tied"
# message fidelity (the video scenario): the fields every solution is matched on against the person's video
MESSAGE_HAND, MESSAGE_LOCATION, MESSAGE_FACE = "message_pck", "message_location", "message_face"


@dataclass(frozen=True)
class Series:
    """One solution with one codec, swept over Q."""
    solution: str
    codec: str
    message: bool = False     # matched on message fidelity against the source video (the video scenario)

    @property
    def avatar(self) -> bool:
        return Solution(self.solution).avatar

    @property
    def reference(self) -> str:
        """The reference the series is matched against: the source video for a video solution, and for every
        solution matched on message fidelity (the person's message: the video scenario); else (the avatar
        scenarios, where the source is the render) the lossless render for an avatar solution."""
        return SOURCE if self.message or not self.avatar else LOSSLESS

    def codec_loss(self) -> "Series":
        """The same solution and codec judged against the lossless render (an avatar's codec loss)."""
        return Series(self.solution, self.codec, False)

    def points(self, records: list[dict], sweep: str = "q") -> list[dict]:
        """The series' point records of one sweep ("q" or "fps") against its own reference."""
        return [r for r in records if r.get("kind") == "point" and r["solution"] == self.solution
                and r["codec"] == self.codec and r.get("sweep") == sweep and r.get("reference") == self.reference]


def ceiling(records: list[dict], reference: str) -> dict:
    """The ceiling record of a reference: its uncoded frames, resampled and re-extracted."""
    return next(r for r in records if r.get("kind") == "uncoded" and r["reference"] == reference
                and r["subject"] == UNCODED_SUBJECTS[reference])


def criteria_for(ceiling: dict, hand_share: float, n_letters: int, *, pck_margin: float = PCK_MARGIN,
                 message: bool = False) -> list[matching.Criterion]:
    """The ceiling-tied threshold (the uncoded reference re-extracted: ceiling): hand PCK@0.2 within pck_margin points
    of it where the reference shows a hand in at least MIN_HAND_SHARE of its frames (hand_share, 0-1), else face
    error within FACE_MARGIN; and letter top-1 within LETTER_MARGIN letters of a word of n_letters, where the
    ceiling reads any letter (a ceiling that reads none leaves letters nothing to hold). message: match on the
    person's message instead (comparisons.judging.message): handshape PCK@0.2 (message_pck) within pck_margin and
    the wrists' location within LOCATION_MARGIN shoulder widths of the ceiling's; face: aligned mouth and eyes."""
    hand = MESSAGE_HAND if message else "hand_pck_20"
    if hand_share >= MIN_HAND_SHARE and ceiling.get(hand) is not None:
        found = [matching.Criterion(hand, ceiling[hand] - pck_margin,
                                    label="handshape PCK@0.2 %" if message else "hand PCK@0.2 %")]
        if message and ceiling.get(MESSAGE_LOCATION) is not None:
            found.append(matching.Criterion(MESSAGE_LOCATION, ceiling[MESSAGE_LOCATION] + LOCATION_MARGIN,
                                            higher_is_better=False, label="wrist location (shoulder widths)"))
        face = face_criterion(ceiling, margin=FACE_MARGIN)
        found += [face] if face is not None else []
    else:
        field = MESSAGE_FACE if message else "face_error"
        found = [matching.Criterion(field, (ceiling.get(field) or 0.0) + FACE_MARGIN, higher_is_better=False,
                                    label="aligned face error (interocular)" if message else "face error (interocular)")]
    if ceiling.get("letter_top1"):
        margin = 100.0 * LETTER_MARGIN / max(n_letters, 1)
        found.append(matching.Criterion("letter_top1", ceiling["letter_top1"] - margin, label="letter top-1 %"))
    return found


def anchored_criteria(anchor: dict, hand_share: float, *, message: bool = False) -> list[matching.Criterion]:
    """The human-anchored threshold: what the anchor record (the source coded at Tran et al.'s point, read by the same
    extractor) keeps, each criterion at the anchor's own value: hand PCK@0.2 (message: handshape PCK@0.2 and wrist
    location) where the reference shows hands in at least MIN_HAND_SHARE of its frames, else the face; letter top-1
    where the anchor reads any letter. A solution reaches it where it keeps at least as much as video at a point
    signers judged intelligible."""
    hand = MESSAGE_HAND if message else "hand_pck_20"
    if hand_share >= MIN_HAND_SHARE and anchor.get(hand) is not None:
        found = [matching.Criterion(hand, anchor[hand], label="handshape PCK@0.2 %" if message else "hand PCK@0.2 %")]
        if message and anchor.get(MESSAGE_LOCATION) is not None:
            found.append(matching.Criterion(MESSAGE_LOCATION, anchor[MESSAGE_LOCATION], higher_is_better=False,
                                            label="wrist location (shoulder widths)"))
        face = face_criterion(anchor, margin=0.0)
        found += [face] if face is not None else []
    else:
        field = MESSAGE_FACE if message else "face_error"
        found = [matching.Criterion(field, anchor.get(field) or 0.0, higher_is_better=False,
                                    label="aligned face error (interocular)" if message else "face error (interocular)")]
    if anchor.get("letter_top1"):
        found.append(matching.Criterion("letter_top1", anchor["letter_top1"], label="letter top-1 %"))
    return found


def face_criterion(threshold_record: dict, *, margin: float = FACE_MARGIN) -> matching.Criterion | None:
    """The face's own criterion (its own column and verdict, beside the hands'): the aligned mouth and eyes/brows
    error (message_face) no more than margin interocular distances above the threshold record's (the ceiling: margin
    FACE_MARGIN; the human anchor: margin 0). None where the record has no face."""
    value = threshold_record.get(MESSAGE_FACE)
    if value is None:
        return None
    return matching.Criterion(MESSAGE_FACE, value + margin, higher_is_better=False,
                              label="aligned mouth and eyes error (interocular)")


# ------------------------------------------------------------------------------------------------------------
# each extraction matched on its own

def pick(record: dict, k: int) -> dict:
    """A copy of record with every field it keeps draw by draw (draw_values) set to its value in draw k (None where
    draw k does not define it): what extraction k alone read. A record extracted once (no draw_values) or whose
    draws do not reach k is returned as it is (copied)."""
    copy = dict(record)
    for name, values in (record.get("draw_values") or {}).items():
        if k < len(values):
            copy[name] = values[k]
    return copy


def extraction_matches(points: list[dict], threshold_record: dict, criteria_of, count: int) -> list[matching.Match]:
    """Each extraction matched on its own: for k in 0..count-1, every point and the threshold's record (the ceiling,
    or the human anchor: measured under the same shifts, so draw k of each is one extraction under one shift) as
    extraction k read them (`pick`), criteria_of(that record) as the threshold, the monotone match over the points."""
    count = min([max(1, count)] + [len(values) for record in (*points, threshold_record)
                                   for values in (record.get("draw_values") or {}).values()])
    return [matching.cheapest_rate([pick(point, k) for point in points], criteria_of(pick(threshold_record, k)),
                                   monotone=True) for k in range(max(1, count))]


def extraction_summary(matches: list[matching.Match]) -> dict:
    """The K per-extraction matches as one figure: kbps the median of their rates (a match not reached counts its
    best point's rate), kbps_min / kbps_max their range; reached when more than half of them reach the threshold
    (a tie: not reached); reached_extractions how many do; verdict_clear when all K agree."""
    rates = np.array([m.kbps for m in matches], np.float64)
    reached = sum(bool(m.reached) for m in matches)
    return {"kbps": float(np.median(rates)), "kbps_min": float(rates.min()), "kbps_max": float(rates.max()),
            "kbps_by_extraction": [float(r) for r in rates], "reached": reached * 2 > len(matches),
            "reached_extractions": reached, "extractions": len(matches),
            "verdict_clear": reached in (0, len(matches))}


def margin_at(found: matching.Match, points: list[dict], criteria: list[matching.Criterion]) -> dict[str, float]:
    """Each criterion's margin at the matched point (the upper bracket point, whose Q is shown; the best point where
    not reached): the monotone fit there minus the threshold (positive: meets), in the criterion's units."""
    ordered = sorted(points, key=lambda p: p["kbps"])
    judged = matching._fitted(ordered, criteria)
    at = next((j for o, j in zip(ordered, judged) if o is found.upper), None)
    if at is None:
        return {}
    out = {}
    for c in criteria:
        value = c.value(at)
        if value is not None:
            out[c.field] = value - c.threshold if c.higher_is_better else c.threshold - value
    return out


def q_to_refine(found: matching.Match, measured: set[int], q_range: tuple[int, int] = (MIN_Q, MAX_Q)) -> int | None:
    """The Q to measure next for a match, one step of its refinement; None when there is none to measure:
    - reached between two swept Q: the rounded geometric middle of the two, moved off them (None where the two are
      adjacent);
    - not reached (even the dearest point misses): the geometric middle of MIN_Q and the finest swept Q, moved off
      it (None where that is MIN_Q): the match is looked for beyond the sweep, at finer Q;
    - reached at the cheapest swept point (no lower bracket): the geometric middle of its Q and MAX_Q, moved off it
      (None where that is MAX_Q), for a bracket below it.
    None also where that Q is measured already. measured: the series' swept Q; q_range: the codec's quantiser scale
    (finest, coarsest): MPEG-4 Part 2 1-31 (MIN_Q, MAX_Q), H.264 QP 1-51, SVT-AV1 QP 1-63.
    """
    MIN_Q, MAX_Q = q_range        # noqa: N806 (the codec's own scale)
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
    """Sets operating_point (and operating_rule) on the swept point nearest the matched rate kbps (log-rate) among
    those that meet the threshold as measured (all of them where none does); operating_below_threshold says whether
    the flagged point misses it."""
    meeting = [r for r in points if matching.meets(r, criteria)]
    nearest = min(meeting or points, key=lambda r: abs(np.log(max(r["kbps"], 1e-9)) - np.log(max(kbps, 1e-9))))
    nearest["operating_point"] = True
    nearest["operating_below_threshold"] = not matching.meets(nearest, criteria)
    nearest["operating_rule"] = f"nearest the matched rate: {matching.threshold_text(criteria)}"


def at_default_refresh(points: list[dict], threshold_record: dict, criteria_of, count: int) -> dict:
    """A parameter series matched as `extraction_summary(extraction_matches(...))` with each point's rate at the
    codec's default refresh (kbps_default_refresh) instead of the video GOP's: the stream decodes to the same motion
    within rounding (comparisons.params.refresh), so what the viewer reads is the point's own. Points without that
    rate keep theirs."""
    moved = [dict(p, kbps=p["kbps_default_refresh"]) if p.get("kbps_default_refresh") is not None else p
             for p in points]
    summary = extraction_summary(extraction_matches(moved, threshold_record, criteria_of, count))
    frames = next((p.get("default_refresh_frames") for p in points if p.get("default_refresh_frames")), None)
    return {"kbps": summary["kbps"], "kbps_min": summary["kbps_min"], "kbps_max": summary["kbps_max"],
            "reached": summary["reached"], "refresh_frames": frames}


def matched_record(series: Series, found: matching.Match, criteria: list[matching.Criterion], *, clip: str,
                   fps_holds: float | None) -> dict:
    """The series at its matched rate ("matched" record): the criteria's fields are their monotone fits there (what
    the match was judged on; the measured values, interpolated, under "measured"), every other field interpolated
    in log-rate between the bracketing points (the point's own without a lower bracket). fps_holds: the lowest
    frame rate down to which the threshold holds. The caller adds the per-extraction summary
    (`extraction_summary`: kbps the median, its range, verdict_clear)."""
    lower = found.lower
    qs = [found.upper["q"]] + ([lower["q"]] if lower is not None else [])
    fields_at = "interpolated in log-rate between the bracketing points" if lower is not None else "the point's own"
    fields = matching.fields_at(found, (*INTELLIGIBILITY_FIELDS, *QUALITY_FIELDS, "joint_error_mm_mean"))
    measured = {name: fields.get(name) for name in found.fitted}
    return {"kind": "matched", "solution": series.solution, "codec": series.codec, "clip": clip,
            "reference": series.reference, "kbps": found.kbps,
            "q_low": min(qs), "q_high": max(qs),
            "bracket_kbps": [lower["kbps"] if lower is not None else found.upper["kbps"], found.upper["kbps"]],
            "q_shown": found.upper["q"], "threshold": matching.threshold_text(criteria),
            "reached": found.reached,
            "fps_holds": fps_holds, "fields_at": fields_at, "judged_on": JUDGED_ON,
            **fields, **found.fitted, "measured": measured}

"""The report's headline (issue 35): one cost per solution, a sentence a broadcaster can quote, the thresholds it
rests on and how the answer moves with them. Pure functions on records (dicts).

Records read: "run" (scenario, synthetic_reference, anchor), "anchor" (the source coded at Tran et al.'s point),
"uncoded" (the ceilings), "matched" (one per solution and codec: kbps the median of the per-extraction matched
rates, kbps_min / kbps_max, reached, verdict_clear, face_ok, codec_loss) and "sensitivity" (every series under every
threshold: threshold_name "human-anchored" or "ceiling-tied" with pck_margin).

- `best_rates(rows)`: per threshold, the cheapest reached rate of the parameter solutions (FBA, BBA), of the video
  solutions coding the person (the NSV family) per codec, and the ratio best video / best parameters;
- `holds_at(required, measured, fps_holds, reached)`: a requirement line judged on the frame rates measured only;
- `break_even_s(...)` and `equal_terms(records)`: the parameter streams at the video's refresh (GOP) and at their
  default, and what a session sends once (the avatar's download, the session descriptions: the run record's
  session_costs), with the duration of signing after which parameters plus the avatar cost less than video.
"""
from __future__ import annotations

import html
import math

from comparisons.reports import page
from media.domain import Solution

CODEC_NAMES = {"mpeg4": "MPEG-4 Part 2", "libx264": "H.264", "libsvtav1": "AV1"}
EXTRACTOR_LINE = ("Intelligibility here is read by a landmark extractor (MediaPipe Holistic's models through signcast's "
                  "own graph), not by people: a row that reaches the threshold keeps what the extractor finds of the "
                  "hands, face and letters, which is a proxy for what a signer reads.")
SYNTHETIC_LINE = ("The reference of this run is synthetic: the avatar's own lossless render, not a person. Every "
                  "solution carries that render, so FBA and BBA, which re-render it with the same model, start from "
                  "their own picture; run <code>signcast compare --video</code> on a clip of a person for the "
                  "person's message.")


def _finite(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def threshold_label(row: dict) -> str:
    """"human-anchored" or "ceiling-tied, 2 points"."""
    margin = row.get("pck_margin")
    return row["threshold_name"] if margin is None else f"{row['threshold_name']}, {_points([margin])}"


def _points(margins) -> str:
    """PCK margins in percentage points as text: "2 points", "1 point", "1, 2, 3, 4 points"."""
    return ", ".join(f"{m:g}" for m in margins) + (" point" if list(margins) == [1] else " points")


def best_rates(rows: list[dict]) -> list[dict]:
    """Per threshold (in the rows' order): best_parameters (kbps, solution, codec) the cheapest reached FBA/BBA row,
    best_video the cheapest reached NSV-family row of each codec ({codec: (kbps, solution)}), best_video_any the
    cheapest of those, and ratio = best video / best parameters (None where either is not reached)."""
    out = []
    for label in dict.fromkeys(threshold_label(r) for r in rows):
        mine = [r for r in rows if threshold_label(r) == label and r.get("reached") and _finite(r.get("kbps"))]
        params = [r for r in mine if Solution(r["solution"]).mpeg4_parameters]
        video = [r for r in mine if Solution(r["solution"]).natural]
        per_codec: dict[str, tuple[float, str]] = {}
        for r in sorted(video, key=lambda r: r["kbps"]):
            per_codec.setdefault(r["codec"], (r["kbps"], r["solution"]))
        best_param = min(params, key=lambda r: r["kbps"], default=None)
        best_video = min(per_codec.items(), key=lambda item: item[1][0], default=None)
        ratio = (best_video[1][0] / best_param["kbps"]) if best_param and best_video and best_param["kbps"] > 0 else None
        out.append({"threshold": label, "best_parameters": None if best_param is None else
                    (best_param["kbps"], best_param["solution"], best_param["codec"]),
                    "best_video": per_codec, "best_video_any": None if best_video is None else
                    (best_video[1][0], best_video[1][1], best_video[0]), "ratio": ratio})
    return out


def holds_at(required: float, measured: list[float], fps_holds: float | None, reached: bool | None) -> bool | None:
    """Whether the threshold holds at a frame rate meeting a requirement of `required` fps, judged only on the rates
    measured: the lowest measured rate at or above it (12.5 meets 12) within one frame per second; None ("?") where
    no such rate was measured, or the threshold is not reached at all; else whether the threshold holds down to it."""
    if not reached:
        return None
    candidates = [r for r in measured if required - 1e-6 <= r < required + 1.0]
    if not candidates:
        return None
    return fps_holds is not None and fps_holds <= min(candidates) + 1e-6


def break_even_s(video_kbps: float, parameter_kbps: float, parameter_once_bytes: int,
                 video_once_bytes: int = 0) -> float | None:
    """Seconds of signing after which parameters (parameter_kbps, plus parameter_once_bytes sent once per session:
    the avatar and its session description) cost less in all than video (video_kbps, plus its description):
    8 (once_p - once_v) / 1000 (v - p); 0 where parameters cost no more from the start; None where they never do
    (not cheaper per second)."""
    once = 8.0 * (parameter_once_bytes - video_once_bytes)
    if once <= 0 and parameter_kbps <= video_kbps:
        return 0.0
    if parameter_kbps >= video_kbps:
        return None
    return once / (1000.0 * (video_kbps - parameter_kbps))


def _duration(seconds: float) -> str:
    return f"{seconds:.1f} s" if seconds < 120 else f"{seconds / 60:.1f} min"


def equal_terms(records: list[dict]) -> str:
    """The parameter streams on equal terms with video: their matched rates with an intra plane every video GOP (the
    rates everywhere on this page) and at their codecs' default refresh; the avatar's download and the session
    descriptions, charged once per session; the break-even duration against the best video codec."""
    run = next((r for r in records if r.get("kind") == "run"), {})
    matched = [r for r in records if r.get("kind") == "matched"]
    params = [r for r in matched if Solution(r["solution"]).mpeg4_parameters]
    if not params:
        return ""
    costs = run.get("session_costs") or {}
    descriptions = costs.get("descriptions") or {}
    gop = run.get("gop_frames")
    refresh = {(r["solution"], r["codec"]): r.get("refresh_frames") for r in records
               if r.get("kind") == "point" and r.get("refresh_frames") is not None}
    rows = []
    for r in params:
        default = r.get("default_refresh") or {}
        mark = "" if r.get("reached") else "*"
        rows.append([html.escape(r["solution"]), html.escape(r["codec"]),
                     f"{_kbps(r.get('kbps'))}{mark}" + (f" (every {refresh[(r['solution'], r['codec'])]} frames)"
                                                         if refresh.get((r["solution"], r["codec"])) else ""),
                     (f"{_kbps(default.get('kbps'))}{'' if default.get('reached') else '*'}"
                      + (f" (every {default['refresh_frames']} frames)" if default.get("refresh_frames") else ""))
                     if default else "–",
                     str(descriptions.get(f"{r['solution']} {r['codec']}", "–"))])
    parts = ["<h3>Equal terms: refresh, the avatar and the session description</h3>",
             (f"<p>A video decoder can join or recover at each intra picture, every {gop or 12} frames here (the "
              "video's GOP). The parameter streams are coded the same way: an intra plane every GOP (the DCT coders "
              "every 16-frame segment, their finest), and every rate on this page is at that refresh; the codecs' "
              "default refresh (32 frames predictive, 64 DCT) is the second column. * not reached.</p>"),
             page.table("equal_terms", ["solution", "codec", "kbps, refresh every GOP",
                                        "kbps at the default refresh", "session description bytes"], rows,
                        escape=False)]
    avatar = costs.get("avatar_bytes")
    if avatar:
        parts.append(f"<p>The terminal needs the avatar to re-render FBA/BBA: {html.escape(str(costs.get('avatar_file')))}, "
                     f"{avatar:,} bytes as sent (its arrays are deflated already: zlib's best on it is "
                     f"{costs.get('avatar_zlib_bytes', 0):,}), charged once per session with the parameter stream's "
                     "session description; every solution's session description (the JSON line <code>signcast "
                     "live</code> sends on its control connection) is charged once per session too.</p>")
    reached = [r for r in matched if r.get("reached") and _finite(r.get("kbps"))]
    video = [r for r in reached if Solution(r["solution"]).natural]
    best_params = min((r for r in params if r.get("reached") and _finite(r.get("kbps"))), key=lambda r: r["kbps"],
                      default=None)
    best_video = min(video, key=lambda r: r["kbps"], default=None)
    if avatar and best_params is not None and best_video is not None:
        once_p = avatar + int(descriptions.get(f"{best_params['solution']} {best_params['codec']}", 0))
        once_v = int(descriptions.get(f"{best_video['solution']} {best_video['codec']}", 0))
        seconds = break_even_s(best_video["kbps"], best_params["kbps"], once_p, once_v)
        duration = run.get("clip_duration_s")
        against = (f"the best video, {best_video['solution']} as {CODEC_NAMES.get(best_video['codec'], best_video['codec'])} "
                   f"at {_kbps(best_video['kbps'])} kbit/s, against {best_params['solution']} {best_params['codec']} at "
                   f"{_kbps(best_params['kbps'])} kbit/s plus {once_p:,} bytes once")
        if seconds is None:
            text = f"Break-even: never: {against}; the parameters cost no less per second."
        else:
            text = (f"Break-even: after {_duration(seconds)} of signing, parameters plus the avatar cost less than "
                    f"video ({against}).")
            if _finite(duration):
                text += f" This clip lasts {duration:.1f} s."
            default = best_params.get("default_refresh") or {}
            if default.get("reached") and _finite(default.get("kbps")):
                at_default = break_even_s(best_video["kbps"], default["kbps"], once_p, once_v)
                text += (" At the default refresh: " + ("never" if at_default is None else
                                                         f"after {_duration(at_default)}") + ".")
        parts.append(f"<p><strong>{text}</strong></p>")
    return "".join(parts)


def _kbps(value) -> str:
    return f"{value:.1f}" if _finite(value) else "–"


def recommendation(records: list[dict]) -> str:
    """The plain-language sentence at the top: what sending this signing costs, readable, per kind of solution."""
    matched = [r for r in records if r.get("kind") == "matched"]
    if not matched:
        return ""
    threshold = next((r.get("threshold_name") for r in matched if r.get("threshold_name")), "ceiling-tied")
    reached = [r for r in matched if r.get("reached")]
    parts = []
    for codec in ("libsvtav1", "libx264", "mpeg4"):
        video = [r for r in reached if r.get("codec") == codec and Solution(r["solution"]).natural]
        if video:
            best = min(video, key=lambda r: r["kbps"])
            parts.append(f"{_kbps(best['kbps'])} kbit/s as {CODEC_NAMES[codec]} video ({best['solution']})")
    objects = [r for r in reached if r["solution"] == "SSV"]
    if objects:
        best = min(objects, key=lambda r: r["kbps"])
        parts.append(f"{_kbps(best['kbps'])} as the avatar's picture (SSV, {CODEC_NAMES.get(best['codec'], best['codec'])})")
    params = [r for r in reached if Solution(r["solution"]).mpeg4_parameters]
    if params:
        best = min(params, key=lambda r: r["kbps"])
        parts.append(f"{_kbps(best['kbps'])} as parameters ({best['solution']} {best['codec']})")
    missing = sorted({r["solution"] for r in matched} - {r["solution"] for r in reached})
    sentence = ("To send this signing so that it stays readable (" + html.escape(threshold) + " threshold) costs "
                + ("; ".join(parts) if parts else "more than any swept point: no solution reached the threshold") + ".")
    if missing:
        sentence += " Not reached at any swept point: " + ", ".join(missing) + "."
    unclear = [f"{r['solution']} {r.get('codec')}" for r in matched if r.get("verdict_clear") is False]
    if unclear:
        sentence += " Too close to call (the extractions disagree): " + ", ".join(unclear) + "."
    if any(r.get("face_threshold") is not None for r in matched):
        sentence += (" A solution reaches the threshold only where the hands and the face (aligned mouth and "
                     "eyes/brows error) both meet theirs.")
    return sentence


def solution_lines(records: list[dict]) -> str:
    """One plain sentence per solution (report order), as a list: its cheapest readable rate and codec, the other
    codecs' rates beside it, or that no swept point reached the threshold (with the best point's rate), and whether
    the extractions agree."""
    matched = [r for r in records if r.get("kind") == "matched" and _finite(r.get("kbps"))]
    items = []
    for solution in (s for s in Solution if any(r["solution"] == s for r in matched)):
        rows = sorted((r for r in matched if r["solution"] == solution), key=lambda r: r["kbps"])
        reached = [r for r in rows if r.get("reached")]
        names = {r["codec"]: CODEC_NAMES.get(r["codec"], r["codec"]) for r in rows}
        if reached:
            best, others = reached[0], reached[1:]
            text = f"readable from {_kbps(best['kbps'])} kbit/s as {names[best['codec']]}"
            if others:
                text += " (" + ", ".join(f"{_kbps(r['kbps'])} as {names[r['codec']]}" for r in others) + ")"
            unclear = [r for r in reached if r.get("verdict_clear") is False]
            if unclear:
                text += "; too close to call with " + ", ".join(
                    f"{names[r['codec']]} ({r.get('reached_extractions')} of {r.get('extractions')} extractions "
                    "reach it)" for r in unclear)
        else:
            best = rows[0]
            text = (f"not readable at any swept point (best point {_kbps(best['kbps'])} kbit/s as "
                    f"{names[best['codec']]}, below the threshold)")
        items.append(f"<li><strong>{html.escape(str(solution))}</strong>: {html.escape(text)}.</li>")
    return f'<ul class="per-solution">{"".join(items)}</ul>' if items else ""


def _thresholds(records: list[dict]) -> str:
    anchor = next((r for r in records if r.get("kind") == "anchor"), None)
    matched = [r for r in records if r.get("kind") == "matched"]
    texts = list(dict.fromkeys(str(r.get("threshold")) for r in matched))
    lines = []
    if anchor is not None:
        lines.append(f"<strong>Human-anchored</strong> (the matches above): the reference coded at Tran et al.'s point "
                     f"(H.264, {anchor.get('width')}×{anchor.get('height')}, {anchor.get('fps'):g} fps, "
                     f"{_kbps(anchor.get('kbps'))} kbit/s for a 60 kbit/s target), which signers found intelligible "
                     "(ASSETS 2013; TACCESS 2015), read by the same extractor under the same shifts: "
                     + html.escape("; ".join(texts)) + ".")
    sens = [r for r in records if r.get("kind") == "sensitivity" and r.get("threshold_name") == "ceiling-tied"]
    margins_of: dict[str, list[float]] = {}     # one line per distinct threshold (a face-only one is every margin's)
    for r in sorted(sens, key=lambda r: r["pck_margin"]):
        margins = margins_of.setdefault(r["threshold"], [])
        if r["pck_margin"] not in margins:
            margins.append(r["pck_margin"])
    ceiling = [f"{_points(margins)}: {threshold}" for threshold, margins in margins_of.items()]
    if ceiling:
        lines.append("<strong>Ceiling-tied</strong> (the uncoded reference re-extracted, minus a margin): "
                     + html.escape("; ".join(ceiling)) + ".")
    return "".join(f"<p>{line}</p>" for line in lines)


def sensitivity_table(records: list[dict]) -> str:
    """Matched rates (median and range over the extractions) of every series under every threshold, and the
    headline ratio under each."""
    rows = [r for r in records if r.get("kind") == "sensitivity"]
    if not rows:
        return ""
    labels = list(dict.fromkeys(threshold_label(r) for r in rows))
    series = list(dict.fromkeys((r["solution"], r["codec"]) for r in rows))
    body = []
    for solution, codec in series:
        cells = [html.escape(solution), html.escape(CODEC_NAMES.get(codec, codec))]
        for label in labels:
            row = next((r for r in rows if (r["solution"], r["codec"]) == (solution, codec)
                        and threshold_label(r) == label), None)
            if row is None:
                cells.append("–")
                continue
            text = _kbps(row["kbps"]) + ("" if row["reached"] else "*")
            if _finite(row.get("kbps_min")) and row.get("kbps_max", 0) > row["kbps_min"]:
                text += f" ({_kbps(row['kbps_min'])}–{_kbps(row['kbps_max'])})"
            cells.append(text)
        body.append(cells)
    best = {b["threshold"]: b for b in best_rates(rows)}
    body.append(["<strong>best video / best parameters</strong>", ""]
                + [("–" if best[label]["ratio"] is None else f"<strong>{best[label]['ratio']:.1f}×</strong>")
                   for label in labels])
    return ("<h3>Sensitivity: the matched rates under each threshold</h3><p>kbit/s, median over the extractions "
            "(each matched on its own) with their range; * not reached (the best point's rate). The last row is the "
            "headline ratio: the cheapest video solution coding the person (any codec) over the cheapest parameter "
            "stream, both reached.</p>"
            + page.table("sensitivity", ["solution", "codec", *labels], body, escape=False))


def headline_ratio_text(records: list[dict]) -> str:
    """'parameters cost X times less than the best video codec (range A-B over the sensitivity table)'."""
    rows = [r for r in records if r.get("kind") == "sensitivity"]
    best = best_rates(rows)
    if not best:
        return ""
    main = best[0]
    ratios = [b["ratio"] for b in best if b["ratio"] is not None]
    if main["ratio"] is None:
        text = (f"Under the {html.escape(main['threshold'])} threshold the ratio is undefined: "
                + ("no parameter stream" if main["best_parameters"] is None else "no video solution")
                + " reached it.")
    else:
        kbps_v, solution, codec = main["best_video_any"]
        kbps_p, psol, pcodec = main["best_parameters"]
        text = (f"Headline ratio ({html.escape(main['threshold'])}): the best video, {solution} as "
                f"{CODEC_NAMES.get(codec, codec)} at {_kbps(kbps_v)} kbit/s, costs {main['ratio']:.1f}× the best "
                f"parameters, {psol} {pcodec} at {_kbps(kbps_p)} kbit/s.")
    if ratios:
        text += f" Over the sensitivity table it runs from {min(ratios):.1f}× to {max(ratios):.1f}×."
    return f"<p><strong>{text}</strong></p>"


def headline_section(records: list[dict]) -> str:
    """The top of the report: the recommendation, the extractor's line, the synthetic reference where it is one, the
    thresholds, the headline ratio with its range and the sensitivity table."""
    run = next((r for r in records if r.get("kind") == "run"), {})
    sentence = recommendation(records)
    if not sentence:
        return ""
    parts = ["<h2>The answer</h2>", f"<p><strong>{sentence}</strong></p>", solution_lines(records),
             f"<p>{EXTRACTOR_LINE}</p>"]
    if run.get("synthetic_reference") or run.get("scenario") in ("word", "pose"):
        parts.append(f"<p><strong>{SYNTHETIC_LINE}</strong></p>")
    elif run.get("scenario") == "video":
        parts.append("<p>Every solution, the avatar's included, is matched against the person's video on the message "
                     "(handshape relative to the wrist over hand size, wrist location after one clip-wide similarity "
                     "on torso and face); an avatar's codec loss against its own lossless render is the second "
                     "figure in the table.</p>")
    parts.append(_thresholds(records))
    parts.append(headline_ratio_text(records))
    parts.append(equal_terms(records))
    parts.append(sensitivity_table(records))
    return "".join(parts)

"""The report's headline (issue 35): one cost per solution, a sentence a broadcaster can quote, the thresholds it
rests on and how the answer moves with them. Pure functions on records (dicts).

Records read: "run" (scenario, synthetic_reference, anchor), "anchor" (the source coded at Tran et al.'s point),
"uncoded" (the ceilings), "matched" (one per solution and codec: kbps the median of the per-extraction matched
rates, kbps_min / kbps_max, reached, verdict_clear, face_ok, codec_loss) and "sensitivity" (every series under every
threshold: threshold_name "human-anchored" or "ceiling-tied" with pck_margin).

- `best_rates(rows)`: per threshold, the cheapest reached rate of the parameter solutions (FBA, BBA), of the video
  solutions coding the person (the NSV family) per codec, and the ratio best video / best parameters;
- `holds_at(required, measured, fps_holds, reached)`: a requirement line judged on the frame rates measured only.
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
    return row["threshold_name"] if margin is None else f"{row['threshold_name']}, {margin:g} points"


def best_rates(rows: list[dict]) -> list[dict]:
    """Per threshold (in the rows' order): best_parameters (kbps, solution, codec) the cheapest reached FBA/BBA row,
    best_video the cheapest reached NSV-family row of each codec ({codec: (kbps, solution)}), best_video_any the
    cheapest of those, and ratio = best video / best parameters (None where either is not reached)."""
    out = []
    for label in dict.fromkeys(threshold_label(r) for r in rows):
        mine = [r for r in rows if threshold_label(r) == label and r.get("reached") and _finite(r.get("kbps"))]
        params = [r for r in mine if Solution(r["solution"]).mpeg4_parameters]
        video = [r for r in mine if Solution(r["solution"]) in Solution.natural_family()]
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
        video = [r for r in reached if r.get("codec") == codec and Solution(r["solution"]) in Solution.natural_family()]
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
    return sentence


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
    ceiling = list(dict.fromkeys(f"{r['pck_margin']:g} points: {r['threshold']}" for r in sens))
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
    parts = ["<h2>The answer</h2>", f"<p><strong>{sentence}</strong></p>", f"<p>{EXTRACTOR_LINE}</p>"]
    if run.get("synthetic_reference") or run.get("scenario") in ("word", "pose"):
        parts.append(f"<p><strong>{SYNTHETIC_LINE}</strong></p>")
    elif run.get("scenario") == "video":
        parts.append("<p>Every solution, the avatar's included, is matched against the person's video on the message "
                     "(handshape relative to the wrist over hand size, wrist location after one clip-wide similarity "
                     "on torso and face); an avatar's codec loss against its own lossless render is the second "
                     "figure in the table.</p>")
    parts.append(_thresholds(records))
    parts.append(headline_ratio_text(records))
    parts.append(sensitivity_table(records))
    return "".join(parts)

"""The comparison report: one self-contained HTML page (plots embedded as PNG) made from records only.

The page and its charts take Records (comparisons.reports.records.Record: read_typed_records from records.jsonl,
as_records in a study) and read each as its schema dict (Record.to_json); the helpers below work on those dicts.
Measured points carry at least solution, codec, q, fps, kbps, width and height. Points with a picture (width and height > 0: `signcast compare`,
`demo`, `video`) carry image quality where measured: image_psnr / ssim (whole frame), skin_psnr / skin_ssim
(face and hands) and object_psnr (inside the sent objects), each against that point's reference frames (see
`reference`). Points without a picture (width = height = 0: `signcast params`, `lab`) measure the animation
parameters themselves: param_psnr (parameter domain, seed 000 eq. 2.6), vpsnr and joint errors in mm, against
the motion before coding; the report never puts the two kinds of PSNR in one column or chart.
A record with kind == "stage" carries a stage's wall time (stage, wall_s); one with kind == "run" carries
the software versions and the backend. Points flagged operating_point == True are the solutions'
operating points (video Q = 12 at 25 fps, parameters at 25 fps). The page shows only the sections the
records have data for.

What a viewer can read (issue 13) comes first. Points may carry intelligibility fields (comparisons.judging.intelligibility:
hand_pck_20 and hand_pck_10 in percent, hand_error / hand_error_p90 in hand sizes, left_hand_found /
right_hand_found in percent of frames, face_error / face_error_p90 / mouth_error / eyes_error in interocular distances, letter_top1 /
letter_top3 in percent, hand_joint_error_mm / arm_joint_error_mm in mm) against their `reference` ("source video"
or "lossless render"). A record with kind == "matched" is one solution's (and codec's) operating point at matched
intelligibility: solution, codec, reference, kbps (interpolated between the swept Q values q_low and q_high),
threshold (text, e.g. "hand PCK@0.2 >= 98.0 %"), reached (bool), fps_holds (the lowest frames/s at which the
threshold holds, or null) and the intelligibility fields there. From them the page gives the table "kbps at matched
intelligibility" with the delivery channels each rate fits (DELIVERY_CHANNELS), the chart of rate against
intelligibility, and the requirement lines of EN 301 549 clause 6.5 and Tran et al. (ASSETS 2013).
"""
from __future__ import annotations

import html
import io
import re
from typing import NamedTuple

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from comparisons.judging.criteria import SOLUTIONS, criteria_table  # noqa: E402
from comparisons.reports.figures import figure_png, suptitle  # noqa: E402,F401
from comparisons.judging.landmark_draws import interval  # noqa: E402
from comparisons.reports import page  # noqa: E402
from comparisons.reports.records import Record, report_rows  # noqa: E402
from comparisons.video.codecs import CODECS as VIDEO_CODECS  # noqa: E402
from media.domain import BBA, FBA, PARAMETER_SOLUTIONS, SOLUTION_ORDER, VIDEO_SOLUTIONS, Solution  # noqa: E402
from media.errors import SigncastError  # noqa: E402

REQUIREMENTS = (("broadcast", 100.0), ("webcast", 56.0), ("phone line", 64.0))
MIN_COMFORT_FPS = 15.0




class Channel(NamedTuple):
    """A delivery channel: its payload rate in kbit/s; a rate fits below it (or at it, where inclusive)."""
    name: str
    short: str          # the label of a table cell's mark
    kbps: float
    inclusive: bool
    source: str


# Delivery channels, cheapest first: the source's three lines, and the rates MobileASL ran at on phones
# (public guidance notes: 15-25 kbit/s).
MOBILE_PHONE = Channel("MobileASL phone link", "phone 25", 25.0, True, "MobileASL (2006-): 15-25 kbit/s on phones")
MODEM = Channel("webcast (56 kbps modem)", "modem 56", 56.0, False, "the source: webcast < 56 kbps")
ISDN_B_CHANNEL = Channel("phone line (64 kbps ISDN B channel)", "ISDN 64", 64.0, False, "the source: phone line < 64 kbps")
BROADCAST = Channel("broadcast (100 kbps)", "broadcast 100", 100.0, False, "the source: broadcast < 100 kbps")
DELIVERY_CHANNELS = (MOBILE_PHONE, MODEM, ISDN_B_CHANNEL, BROADCAST)
# EN 301 549 clause 6.5, video communication for sign language: frames/s and pixels (width, height).
EN301549_MIN_FPS = 12.0
EN301549_PREFERRED_FPS = 20.0
QCIF = (176, 144)
CIF = (352, 288)
# Tran, Riskin, Ladner, Wobbrock (ASSETS 2013): intelligibility stops improving above 10 fps; recommended
# 10 fps at 60 kbit/s, measured at 320x240.
TRAN_FPS = 10.0
TRAN_KBPS = 60.0
TRAN_SIZE = (320, 240)
# The solutions of the matched-intelligibility table, in its order (seed 001's six and NSV3O with clothes).
MATCHED_SOLUTIONS = (*VIDEO_SOLUTIONS, FBA, BBA)
# Intelligibility fields a chart panel can show: (label with unit, higher is better).
INTELLIGIBILITY_PANELS = {
    "hand_pck_20": ("hand PCK@0.2\n(% of hand keypoints within 0.2 hand sizes)", True),
    "face_error": ("face error (interocular distances,\nmean; lower is better)", False),
    "letter_top1": ("fingerspelled letters recognised\nfirst (top-1 %)", True),
}
# the criteria's labels in a matched record's threshold text, per panel (comparisons.judging.matching.threshold_text)
THRESHOLD_LABELS = {"hand_pck_20": r"PCK@0\.2", "letter_top1": r"letter top-1"}
RENDERED_SOLUTIONS = Solution.avatars()   # pictures of the avatar: measured against its lossless render
# Today's video codecs, coded at matched quality; their quantiser is on their own scale, not MPEG-4's Q 1-31.
OTHER_VIDEO_CODECS = {"libx264": "H.264", "libsvtav1": "AV1"}
# One colour per series: ten distinct colours, then their light shades (drawn with another marker).
PALETTE = (*plt.get_cmap("tab10").colors, *plt.get_cmap("tab20").colors[1::2])
MARKERS = ("o", "^", "v", "<", ">")
# An image metric's record fields: (whole frame, face and hands)
IMAGE_METRICS = {"psnr": ("image_psnr", "skin_psnr"), "ssim": ("ssim", "skin_ssim")}


def points(records: list[dict]) -> list[dict]:
    return [r for r in records if r.get("kind", "point") == "point" and r.get("kbps") is not None]


def has_picture(record: dict) -> bool:
    """True for a point measured on decoded pictures (width and height > 0), False for parameters only."""
    return (record.get("width") or 0) > 0 and (record.get("height") or 0) > 0


def reference(record: dict) -> str:
    """What a point's quality is measured against, in words (a record's own "reference" field wins)."""
    if record.get("reference"):
        return str(record["reference"])
    clip = record.get("clip") or "the clip"
    if not has_picture(record):
        return f"{clip}: motion before coding (full-precision BAPs)"
    size = f"{record['width']}×{record['height']}"
    if record["solution"] in RENDERED_SOLUTIONS:
        return f"lossless render of {clip}, {size}"
    return f"source frames of {clip}, {size}"


def quantiser(record: dict) -> str:
    """The quantiser in words, with its scale: MPEG-4 Q (1-31), H.264 / AV1 QP on their own ranges, or a
    seed-002 coder's setting number (`signcast lab`)."""
    q, codec = record.get("q"), record.get("codec", "")
    if q is None:
        return "–"
    if record.get("setting") is not None:
        return f"setting {q} ({record['setting']})"
    if codec in OTHER_VIDEO_CODECS:
        low, high = VIDEO_CODECS[codec][1]
        scale = "CRF" if record.get("rate_control") == "crf" else "QP"
        return f"{OTHER_VIDEO_CODECS[codec]} {scale} {q} ({low}-{high})"
    clothes = [o["q"] for o in record.get("objects") or [] if isinstance(o, dict) and o.get("name") == "clothes"]
    return f"Q {q}" + (f" (+{clothes[0]} clothes)" if clothes else "")


def _series_key(record: dict) -> str:
    codec = record.get("codec", "")
    return f"{record['solution']} · {codec}" if codec else record["solution"]


def _order(solution: str) -> int:
    return SOLUTION_ORDER.index(solution) if solution in SOLUTION_ORDER else len(SOLUTION_ORDER)


def series_styles(records: list[dict]) -> dict[str, dict]:
    """A colour and marker for every solution · codec series in the records, so that no two codecs share one.

    MPEG-4 video and the parameter codecs come first (ten distinct colours), H.264 and AV1 after them, so a
    chart of the MPEG-4 series alone colours them as the page's other charts do.
    """
    names = sorted({(r.get("codec") in OTHER_VIDEO_CODECS, _order(r["solution"]), _series_key(r)) for r in points(records)})
    return {name: {"color": PALETTE[i % len(PALETTE)], "marker": MARKERS[(i // 10) % len(MARKERS)]}
            for i, (_, _, name) in enumerate(names)}


def _png(figure) -> bytes:
    """The figure as PNG bytes (110 dpi, tight), closed afterwards."""
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=110, bbox_inches="tight")
    plt.close(figure)
    return buffer.getvalue()


def _groups(records: list[dict], key) -> dict:
    groups: dict = {}
    for r in records:
        groups.setdefault(key(r), []).append(r)
    return dict(sorted(groups.items(), key=lambda kv: (_order(kv[1][0]["solution"]), kv[0])))


def _mean(values) -> float | None:
    present = [float(v) for v in values if isinstance(v, (int, float)) and np.isfinite(v)]
    return float(np.mean(present)) if present else None


def _by_quantiser(group: list[dict], fields: tuple[str, ...]) -> list[dict]:
    """One series' points at one frame rate, averaged over clips per quantiser, sorted by q:
    [{"q", "clips": [clip names], "record": first record, field: mean or None, ...}]."""
    rows = []
    for q, same_q in sorted(_groups(group, lambda r: r["q"]).items(), key=lambda kv: kv[0]):
        row = {"q": q, "clips": sorted({str(r.get("clip", "")) for r in same_q}), "record": same_q[0]}
        row.update({name: _mean(r.get(name) for r in same_q) for name in fields})
        rows.append(row)
    return rows


def _top_rate(group: list[dict]) -> tuple[float, list[dict]]:
    """The highest frame rate of a series and its points."""
    fps = max(g["fps"] for g in group)
    return fps, [g for g in group if g["fps"] == fps]


def _finish_rate_axes(axes, xlabel: str, title: str) -> None:
    """Log kbps axis, grid, and the legend outside on the right."""
    axes.set_xlabel(xlabel)
    axes.set_ylabel("kbps")
    axes.set_yscale("log")
    axes.set_title(title)
    axes.grid(True, which="both", alpha=0.3)
    if axes.lines:
        axes.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.0, 0.5))


def quantiser_sweeps(records: list[dict]) -> dict[str, tuple[float, list[dict]]]:
    """Per series with at least two quantisers: (top frame rate, kbps per Q averaged over clips).

    Only quantisers on a Q scale: MPEG-4 video at full resolution and the FBA/BBA codecs; H.264/AV1 (their own
    QP scale, coded at matched quality) and seed-002 coders (setting numbers) are left out.
    """
    swept = [r for r in points(records) if r.get("sweep") in ("q", None) and r.get("q") is not None
             and r.get("full_resolution", True) and r.get("setting") is None and r.get("codec") not in OTHER_VIDEO_CODECS]
    sweeps = {}
    for name, group in _groups(swept, _series_key).items():
        fps, top = _top_rate(group)
        rows = _by_quantiser(top, ("kbps",))
        if len(rows) >= 2:
            sweeps[name] = (fps, rows)
    return sweeps


def _clips_note(clips: list[str]) -> str:
    return f", mean of {len(clips)} clips" if len(clips) > 1 else ""


def chart_kbps_vs_q(records: list[dict], styles: dict | None = None):
    """kbps against Q at each series' top frame rate (averaged over clips), one line per solution and codec."""
    styles = styles or series_styles(records)
    figure, axes = plt.subplots(figsize=(7.5, 4.5))
    for name, (fps, rows) in quantiser_sweeps(records).items():
        axes.plot([r["q"] for r in rows], [r["kbps"] for r in rows], "-", ms=5,
                  label=f"{name} ({fps:g} fps{_clips_note(rows[0]['clips'])})", **styles[name])
    _finish_rate_axes(axes, "quantizer Q (MPEG-4 Part 2 for video; each FBA/BBA codec's own Q)",
                      "Bitrate against quantizer (source Figs. 4.10-4.15)")
    return figure


def linear_fits(records: list[dict]) -> list[dict]:
    """Per solution and codec at its operating Q: kbps = slope * fps + intercept over the frame-rate sweep."""
    fits = []
    swept = _groups([r for r in points(records) if r.get("sweep") == "fps"], _series_key)
    for name, group in swept.items():
        # The frame-rate sweep's top rate may have been measured once, in the quantizer sweep.
        extra = [r for r in points(records) if _series_key(r) == name and r.get("sweep") == "q"
                 and r.get("q") == group[0].get("q") and all(r["fps"] != g["fps"] for g in group)]
        group = group + extra[:1]
        fps = np.array([g["fps"] for g in group], dtype=float)
        kbps = np.array([g["kbps"] for g in group], dtype=float)
        if len(np.unique(fps)) < 2:
            continue
        slope, intercept = np.polyfit(fps, kbps, 1)
        predicted = slope * fps + intercept
        total = np.sum((kbps - kbps.mean()) ** 2)
        r2 = 1.0 - np.sum((kbps - predicted) ** 2) / total if total > 0 else 1.0
        fits.append({"series": name, "solution": group[0]["solution"], "q": group[0].get("q"), "slope_kbps_per_fps": slope,
                     "intercept_kbps": intercept, "r2": r2, "fps": fps.tolist(), "kbps": kbps.tolist()})
    return fits


def chart_kbps_vs_fps(records: list[dict], styles: dict | None = None):
    styles = styles or series_styles(records)
    figure, axes = plt.subplots(figsize=(7.5, 4.5))
    for fit in linear_fits(records):
        style = styles[fit["series"]]
        axes.plot(fit["fps"], fit["kbps"], ls="none", **style)
        span = np.array([min(fit["fps"]), max(fit["fps"])])
        axes.plot(span, fit["slope_kbps_per_fps"] * span + fit["intercept_kbps"], "-", color=style["color"],
                  label=f"{fit['series']}: {fit['slope_kbps_per_fps']:.2f}·fps + {fit['intercept_kbps']:.1f} (R²={fit['r2']:.3f})")
    for label, limit in REQUIREMENTS:
        axes.axhline(limit, color="grey", ls=":", lw=1)
        axes.text(axes.get_xlim()[0] if axes.lines else 10, limit, f" {label} {limit:g}", fontsize=7, va="bottom", color="grey")
    axes.axvline(MIN_COMFORT_FPS, color="grey", ls="--", lw=1)
    _finish_rate_axes(axes, "frames per second", "Bitrate against frame rate, with linear fits")
    return figure


def _picture_points(records: list[dict], metric: str) -> list[dict]:
    """Points with a picture measured with metric ("psnr" or "ssim") over the whole frame."""
    field = IMAGE_METRICS[metric][0]
    return [r for r in points(records) if has_picture(r) and r.get(field) is not None and r.get("full_resolution", True)]


def measured_against(records: list[dict]) -> str:
    """Which solutions' image quality is measured against which reference frames, in one line of text."""
    groups = _groups([r for r in points(records) if has_picture(r) and r.get("full_resolution", True)], reference)
    return "; ".join(f"{', '.join(dict.fromkeys(r['solution'] for r in group))} against the {name}"
                     for name, group in groups.items())


def chart_rate_quality(records: list[Record], metric: str, styles: dict | None = None):
    """Image quality (metric: "psnr" or "ssim"; whole frame and face-and-hands region) against kbps, each against
    the point's reference frames: each series' quantizer sweep at its top frame rate as a line, today's codecs at
    matched quality as single open markers. Points without a picture are left out."""
    return _chart_rate_quality(report_rows(records), metric, styles)


def _chart_rate_quality(records: list[dict], metric: str, styles: dict | None = None):
    styles = styles or series_styles(records)
    figure, panels = plt.subplots(1, 2, figsize=(12, 4.8), sharey=True)
    measured = _picture_points(records, metric)
    for panel, field, title in ((panels[0], IMAGE_METRICS[metric][0], "whole frame (unsent pixels count as error)"),
                                (panels[1], IMAGE_METRICS[metric][1], "face and hands")):
        swept = [r for r in measured if r.get("sweep") in ("q", None) and r.get(field) is not None]
        for name, group in _groups(swept, _series_key).items():
            rows = [r for r in _by_quantiser(_top_rate(group)[1], ("kbps", field)) if r[field] is not None]
            rows.sort(key=lambda r: r["kbps"])
            panel.plot([r["kbps"] for r in rows], [r[field] for r in rows], "-", ms=4, label=name, **styles[name])
        for r in (r for r in measured if r.get("sweep") == "codec" and r.get(field) is not None):
            name = _series_key(r)
            panel.plot([r["kbps"]], [r[field]], "D" if "264" in r["codec"] else "s", mfc="none", ms=7,
                       color=styles[name]["color"], label=f"{name} (matched quality)")
        for label, limit in REQUIREMENTS:
            panel.axvline(limit, color="grey", ls=":", lw=1)
        panel.set_xscale("log")
        panel.set_xlabel("kbps")
        panel.set_title(f"{metric.upper()}, {title}")
        panel.grid(True, which="both", alpha=0.3)
    panels[0].set_ylabel(metric.upper() + (" (dB)" if metric == "psnr" else "")
                         + " against the reference frames")
    suptitle(figure, measured_against(records))
    _figure_legend(figure, panels)
    return figure


def _figure_legend(figure, panels) -> None:
    """One legend on the right for the series of every panel (a series may have points in one panel only)."""
    entries = {}
    for panel in panels:
        for handle, label in zip(*panel.get_legend_handles_labels()):
            entries.setdefault(label, handle)
    if entries:
        figure.legend(list(entries.values()), list(entries), fontsize=7, loc="center left", bbox_to_anchor=(1.0, 0.5))


def _parameter_points(records: list[dict]) -> list[dict]:
    return [r for r in points(records) if not has_picture(r)]


def chart_parameter_quality(records: list[Record], styles: dict | None = None):
    """Parameter-domain PSNR (seed 000 eq. 2.6) and VPSNR against kbps, against the motion before coding, for
    points without a picture; each series at its top frame rate, averaged over clips per quantiser."""
    return _chart_parameter_quality(report_rows(records), styles)


def _chart_parameter_quality(records: list[dict], styles: dict | None = None):
    styles = styles or series_styles(records)
    figure, panels = plt.subplots(1, 2, figsize=(12, 4.8))
    measured = _parameter_points(records)
    for panel, metric, title in ((panels[0], "param_psnr", "parameter PSNR (seed 000 eq. 2.6)"),
                                 (panels[1], "vpsnr", "VPSNR (velocity)")):
        for name, group in _groups([r for r in measured if r.get(metric) is not None], _series_key).items():
            fps, top = _top_rate(group)
            rows = sorted((r for r in _by_quantiser(top, ("kbps", metric)) if r[metric] is not None), key=lambda r: r["kbps"])
            panel.plot([r["kbps"] for r in rows], [r[metric] for r in rows], "-", ms=4,
                       label=f"{name} ({fps:g} fps{_clips_note(rows[0]['clips'])})", **styles[name])
        panel.set_xscale("log")
        panel.set_xlabel("kbps")
        panel.set_ylabel(f"{metric.replace('param_', '').upper()} dB")
        panel.set_title(title)
        panel.grid(True, which="both", alpha=0.3)
    suptitle(figure, "Against the motion before coding (full-precision BAPs, rotation BAPs that move); "
                     "not comparable with image PSNR")
    _figure_legend(figure, panels)
    return figure


def operating_points(records: list[dict]) -> list[dict]:
    chosen = [r for r in points(records) if r.get("operating_point")]
    return sorted(chosen, key=lambda r: (_order(r["solution"]), r.get("codec", "")))


def requirement_rows(records: list[dict]) -> list[dict]:
    """For each solution and codec: the lowest rate measured at >= 15 fps, and which requirement lines it meets."""
    rows = []
    for name, group in _groups(points(records), _series_key).items():
        comfortable = [g for g in group if g["fps"] >= MIN_COMFORT_FPS - 1e-6 and g.get("full_resolution", True)]
        operating = [g for g in group if g.get("operating_point")]
        row = {"series": name}
        for label, source in (("operating point", operating), ("cheapest at ≥ 15 fps", comfortable)):
            if source:
                best = min(source, key=lambda g: g["kbps"])
                row[label] = best
        rows.append(row)
    return rows


def _fmt(value, digits=1) -> str:
    if value is None or (isinstance(value, float) and not np.isfinite(value)):
        return "–"
    if isinstance(value, float):
        return f"{value:.{digits}f}"
    return html.escape(str(value))


def _meets(kbps: float) -> str:
    return " ".join(("✔" if kbps < limit else "✘") + f" {label} &lt; {limit:g}" for label, limit in REQUIREMENTS)


def _table(name: str, header: list[str], rows: list[list]) -> str:
    """A table whose cells are HTML already (formatted by _fmt and the section builders)."""
    return page.table(name, header, rows, escape=False)


def _list(names) -> str:
    return ", ".join(html.escape(str(n)) for n in dict.fromkeys(names))


def _clips(clips: list[str]) -> str:
    return _list(clips) if len(clips) <= 4 else f"{html.escape(clips[0])} … {html.escape(clips[-1])} ({len(clips)})"


def _matched_summary(records: list[dict]) -> str:
    """The summary where the records have matched records: each solution and codec at its matched rate (the one cost
    of the whole page), its image quality interpolated there, a rate below the threshold marked as such."""
    rows = []
    for m in matched_records(records):
        picture = operating_picture(m, records)
        if not (picture.get("width") and picture.get("height")):
            continue
        qs = list(dict.fromkeys(q for q in (m.get("q_low"), m.get("q_high")) if q is not None))
        reached = bool(m.get("reached"))
        rows.append([_fmt(m["solution"]), _fmt(m.get("codec")), _fmt("Q " + "–".join(f"{q:g}" for q in qs) if qs else None),
                     _fmt(picture.get("fps"), 0) if picture.get("fps") is None else _fmt(float(picture["fps"]), 0),
                     _fmt(m.get("kbps"), 1) + ("" if reached else " (below threshold)"), _fmt(m.get("reference")),
                     _fmt(m.get("skin_psnr"), 2), _fmt(m.get("skin_ssim"), 3), _fmt(m.get("image_psnr"), 2),
                     _fmt(m.get("ssim"), 3), _meets(m["kbps"]) if reached and m.get("kbps") is not None
                     else "– (below threshold: the rate that meets it is higher)"])
    if not rows:
        return ""
    return ("<h2>Summary at the matched operating points</h2><p>Each solution and codec at its rate at matched "
            "intelligibility (the same rate as in every other section of this page), with its image quality "
            "interpolated there in log-rate between the bracketing Q, each against the frames named in “measured "
            "against”. A rate marked “below threshold” is the best swept point's: the threshold was not reached, "
            "so the requirement lines are not judged on it.</p>"
            + _table("summary", ["solution", "codec", "quantiser bracket", "fps", "kbps", "measured against",
                                 "PSNR face+hands dB", "SSIM face+hands", "PSNR whole frame dB", "SSIM whole frame",
                                 "requirements"], rows))


def _picture_summary(records: list[dict]) -> str:
    """The operating points with pictures: face-and-hands quality first, the reference of every row, whole-frame
    figures marked where the background was not sent. Where the records have matched records, the matched rates
    (`_matched_summary`)."""
    if matched_records(records):
        matched = _matched_summary(records)
        if matched:
            return matched
    pictures = [r for r in points(records) if has_picture(r)]
    rows = [r for r in operating_points(records) if has_picture(r)]
    heading = "Summary at the operating points" if rows else "Summary: the quantizer sweep"
    if rows:
        video = [r for r in rows if r["solution"] not in PARAMETER_SOLUTIONS]
        params = [r for r in rows if r["solution"] in PARAMETER_SOLUTIONS]
        parts = []
        if video:
            parts.append(f"video solutions at MPEG-4 Q = {_list(r['q'] for r in video)} and "
                         f"{_list(format(r['fps'], 'g') for r in video)} fps (the source's working point)")
        if params:
            rules = _list(r.get("operating_rule") or "operating point" for r in params)
            parts.append(f"FBA/BBA at {_list(format(r['fps'], 'g') for r in params)} fps, decoded and re-rendered by the "
                         f"terminal with the same kernels, each codec at its cheapest Q by the rule: {rules}")
        intro = "Operating points: " + "; ".join(parts) + "."
    else:
        rows = sorted((r for r in pictures if r.get("sweep") in ("q", None) and r.get("full_resolution", True)),
                      key=lambda r: (_order(r["solution"]), r.get("codec", ""), r.get("q") or 0))
        intro = "No point is flagged as an operating point: every quantizer of the sweep is listed."
    joint = any(r.get("joint_error_mm_mean") is not None for r in rows)
    dropped = [r["solution"] for r in rows if r.get("object_psnr") is not None]
    table_rows = []
    for r in rows:
        mark = " *" if r.get("object_psnr") is not None else ""
        cells = [_fmt(r["solution"]), _fmt(r.get("codec")), _fmt(quantiser(r)), _fmt(float(r["fps"]), 0),
                 _fmt(float(r["kbps"]), 2), _fmt(reference(r)), _fmt(r.get("skin_psnr"), 2), _fmt(r.get("skin_ssim"), 3),
                 _fmt(r.get("image_psnr"), 2) + mark, _fmt(r.get("ssim"), 3) + mark]
        if joint:
            cells.append(_fmt(r.get("joint_error_mm_mean"), 2))
        table_rows.append(cells + [_meets(r["kbps"])])
    header = ["solution", "codec", "quantiser", "fps", "kbps", "measured against", "PSNR face+hands dB", "SSIM face+hands",
              "PSNR whole frame dB", "SSIM whole frame", *(["joint error mm"] if joint else []), "requirements"]
    note = ""
    if dropped:
        note = (f"<p><small>* {_list(dropped)} send no background: the viewer's frame is empty there, so the whole-frame "
                "figures count every unsent pixel as error and read far lower. Read the face-and-hands columns for these "
                "rows; the PSNR inside the sent objects is under “Every measured point”.</small></p>")
    scales = ""
    if any(r.get("codec") in OTHER_VIDEO_CODECS for r in pictures):
        scales = (" MPEG-4's Q runs 1-31; H.264 and AV1 are coded at matched quality and their QP, on their own "
                  "scales, is not comparable with it.")
    return (f"<h2>{heading}</h2><p>" + intro + " Each row's quality is measured against the frames named in "
            "“measured against”; face and hands carry the message, so their figures come first." + scales + "</p>"
            + _table("summary", header, table_rows) + note)


def _parameter_summary(records: list[dict]) -> str:
    """Points without a picture, per series and quantiser, averaged over clips."""
    fields = ("kbps", "param_psnr", "vpsnr", "joint_error_mm_mean", "hand_joint_error_mm", "arm_joint_error_mm")
    # hands and arms apart, where the points carry them
    apart = any(r.get(f) is not None for r in _parameter_points(records) for f in fields[-2:])
    rows = []
    for name, group in _groups(_parameter_points(records), _series_key).items():
        for fps, same_fps in sorted(_groups(group, lambda r: r["fps"]).items(), key=lambda kv: -kv[0]):
            for row in _by_quantiser(same_fps, fields):
                first = row["record"]
                rows.append([_fmt(first["solution"]), _fmt(first.get("codec")), _fmt(quantiser(first)), _fmt(float(fps), 0),
                             _clips(row["clips"]), "motion before coding (full-precision BAPs)", _fmt(row["kbps"], 2),
                             _fmt(row["param_psnr"], 2), _fmt(row["vpsnr"], 2), _fmt(row["joint_error_mm_mean"], 2),
                             *([_fmt(row["hand_joint_error_mm"], 2), _fmt(row["arm_joint_error_mm"], 2)] if apart else [])])
    return ("<h2>Summary: parameter coding</h2><p>These points have no pictures: they measure the animation parameters "
            "themselves, each clip's coded and decoded motion against the same motion before coding. Their PSNR is "
            "parameter-domain (seed 000 eq. 2.6, over the rotation BAPs that move), not image PSNR: do not compare it "
            "with a video solution's. Values are means over the clips listed.</p>"
            + _table("parameter_summary", ["solution", "codec", "quantiser", "fps", "clips", "measured against", "kbps",
                                           "parameter PSNR dB", "VPSNR dB", "joint error mm",
                                           *(["hand joint error mm", "arm joint error mm"] if apart else [])], rows))


def _requirements(records: list[dict]) -> str:
    head = ("<h2>Against the source's requirement lines</h2><p>Broadcast &lt; 100 kbps, webcast &lt; 56 kbps, "
            "phone line &lt; 64 kbps, and at least 15 frames/s for signing comfort.")
    matched = matched_records(records)
    if matched:
        table = []
        for m in matched:
            fps = operating_picture(m, records).get("fps")
            reached = bool(m.get("reached")) and m.get("kbps") is not None
            table.append([_fmt(_series_key(m)), _fmt(m.get("kbps"), 1) + ("" if reached else " (below threshold)"),
                          "–" if fps is None else _check(fps >= MIN_COMFORT_FPS - 1e-6, f"{fps:g} fps"),
                          _meets(m["kbps"]) if reached else "– (below threshold)"])
        return (head + " Each row is the solution's rate at matched intelligibility (the page's one cost per "
                "solution); a rate below the threshold is not judged.</p>"
                + _table("requirements", ["series", "kbps at matched intelligibility", "≥ 15 frames/s", "meets"], table))
    rows = requirement_rows(records)
    if not any(len(row) > 1 for row in rows):
        rates = _list(format(fps, "g") for fps in sorted({r["fps"] for r in points(records)}))
        return head + f" No point here is an operating point or reaches 15 frames/s (measured at {rates} fps).</p>"
    table = []
    for row in rows:
        cells = [_fmt(row["series"])]
        for label in ("operating point", "cheapest at ≥ 15 fps"):
            best = row.get(label)
            if best is None:
                cells += ["–", "–"]
                continue
            where = "" if has_picture(best) else f", {best.get('clip')}"
            cells.append(_fmt(f"{best['kbps']:.1f} kbps ({quantiser(best)}, {best['fps']:g} fps{where})"))
            cells.append(_meets(best["kbps"]))
        table.append(cells)
    header = ["series", "operating point", "meets", "cheapest at ≥ 15 fps", "meets"]
    return head + "</p>" + _table("requirements", header, table)


def _criteria(records: list[dict]) -> str:
    matched = matched_records(records)
    below: set = set()
    basis = "kbps at each solution's operating point"
    if matched:
        # the matched rate of each solution's cheapest codec that reaches the threshold; a solution reaching it with
        # none: its cheapest best point, marked below the threshold (ranked last)
        kbps_by_solution = {}
        for s in SOLUTIONS:
            mine = [m for m in matched if m["solution"] == s and m.get("kbps") is not None]
            reached = [m["kbps"] for m in mine if m.get("reached")]
            kbps_by_solution[s] = min(reached) if reached else min((m["kbps"] for m in mine), default=None)
            if mine and not reached:
                below.add(s)
        basis = "kbps at matched intelligibility (each solution's cheapest codec reaching the threshold)"
    else:
        ops = operating_points(records)
        kbps_by_solution = {s: min((r["kbps"] for r in ops if r["solution"] == s), default=None) for s in SOLUTIONS}
    missing = [s for s, kbps in kbps_by_solution.items() if kbps is None]
    head = "<h2>Six criteria (source Tables 4.1-4.5 and 4.17)</h2>"
    if missing:
        # A bandwidth rank over some of the solutions would read as a rank over all six.
        return head + (f"<p>The bandwidth row ranks all six solutions at their operating points; these records have no "
                       f"operating point of {_list(missing)}, so the table is left out (run <code>signcast compare</code>).</p>")
    rows = criteria_table(kbps_by_solution, below, basis)
    return head + ("<p>Scores 1-6, 6 = best. The bandwidth row is recomputed from this run; the other rows are carried "
                   "over from the source with its reason.</p>"
                   + _table("criteria", ["criterion", *SOLUTIONS, "reason"],
                            [[_fmt(r["criterion"]), *[_fmt(r[s]) for s in SOLUTIONS], _fmt(r["reason"])] for r in rows]))


INTELLIGIBILITY_COLUMNS = ["measured against", "hand PCK@0.2 %", "hand error (hand sizes)", "hands found % (L / R)",
                           "face error (interocular distances)", "mouth / eyes error (interocular distances)"]


def _intelligibility_cells(record: dict) -> list[str]:
    """A point's intelligibility cells, in INTELLIGIBILITY_COLUMNS order."""
    return [_fmt(record.get("reference")), _fmt(record.get("hand_pck_20"), 1), _fmt(record.get("hand_error"), 3),
            _hands_found(record), _fmt(record.get("face_error"), 3), _mouth_eyes(record)]


def _mouth_eyes(record: dict) -> str:
    """The non-manual features' errors, "mouth / eyes", or "–" where neither was measured."""
    mouth, eyes = record.get("mouth_error"), record.get("eyes_error")
    return "–" if mouth is None and eyes is None else f"{_fmt(mouth, 3)} / {_fmt(eyes, 3)}"


def _every_point(records: list[dict]) -> str:
    def order(r):
        return (_order(r["solution"]), r.get("codec", ""), str(r.get("clip", "")), -r["fps"], r.get("q") or 0)
    html_parts = ["<h2>Every measured point</h2>"]
    pictures = sorted((r for r in points(records) if has_picture(r)), key=order)
    if pictures:
        legible = any(r.get("hand_pck_20") is not None or r.get("face_error") is not None for r in pictures)
        html_parts.append(_table("points", ["solution", "codec", "clip", "quantiser", "fps", "size", "kbps",
                                            "PSNR face+hands dB", "PSNR sent objects dB", "PSNR whole frame dB",
                                            "SSIM whole frame", *(INTELLIGIBILITY_COLUMNS if legible else [])],
                                 [[_fmt(r["solution"]), _fmt(r.get("codec")), _fmt(r.get("clip")), _fmt(quantiser(r)),
                                   _fmt(float(r["fps"]), 0), f"{r['width']}×{r['height']}", _fmt(float(r["kbps"]), 2),
                                   _fmt(r.get("skin_psnr"), 2), _fmt(r.get("object_psnr"), 2), _fmt(r.get("image_psnr"), 2),
                                   _fmt(r.get("ssim"), 3), *(_intelligibility_cells(r) if legible else [])]
                                  for r in pictures]))
    parameters = sorted(_parameter_points(records), key=order)
    # Without clips to average over, the parameter summary already lists every point.
    if len({(_series_key(r), r["fps"], r["q"]) for r in parameters}) < len(parameters):
        html_parts.append(_table("parameter_points", ["solution", "codec", "clip", "quantiser", "fps", "kbps",
                                                      "parameter PSNR dB", "VPSNR dB", "joint error mm mean", "max"],
                                 [[_fmt(r["solution"]), _fmt(r.get("codec")), _fmt(r.get("clip")), _fmt(quantiser(r)),
                                   _fmt(float(r["fps"]), 0), _fmt(float(r["kbps"]), 2), _fmt(r.get("param_psnr"), 2),
                                   _fmt(r.get("vpsnr"), 2), _fmt(r.get("joint_error_mm_mean"), 2),
                                   _fmt(r.get("joint_error_mm_max"), 2)] for r in parameters]))
    return "".join(html_parts) if len(html_parts) > 1 else ""


def _run(records: list[dict]) -> str:
    run = next((r for r in records if r.get("kind") == "run"), None)
    stages = [r for r in records if r.get("kind") == "stage"]
    parts = []
    if run is not None:
        versions = sorted((run.get("versions") or {}).items())
        parts.append(_table("versions", ["software", "version"],
                            [["backend", _fmt(run.get("backend"))]] + [[_fmt(k), _fmt(v)] for k, v in versions]))
    if stages:
        parts.append(_table("stages", ["stage", "wall time s"],
                            [[_fmt(s["stage"]), _fmt(float(s["wall_s"]), 2)] for s in stages]))
    return "<h2>Run</h2>" + "".join(parts) if parts else ""


# --------------------------------------------------------------------------- matched intelligibility (issue 13)
def matched_records(records: list[dict]) -> list[dict]:
    """The records of kind "matched" (one per solution and codec: its cheapest rate at matched intelligibility),
    in MATCHED_SOLUTIONS order."""
    chosen = [r for r in records if r.get("kind") == "matched" and r.get("solution")]
    return sorted(chosen, key=lambda r: (_matched_order(r["solution"]), str(r.get("codec") or "")))


def _matched_order(solution: str) -> int:
    return MATCHED_SOLUTIONS.index(solution) if solution in MATCHED_SOLUTIONS else len(MATCHED_SOLUTIONS) + _order(solution)


def fits(channel: Channel, kbps: float) -> bool:
    """True when a rate (kbit/s) fits the channel's payload rate."""
    return kbps <= channel.kbps if channel.inclusive else kbps < channel.kbps


def _channel_marks(kbps: float | None) -> str:
    """✔ / ✘ per delivery channel for a rate in kbit/s (HTML)."""
    if kbps is None:
        return "–"
    return "<br>".join('<span class="nowrap">' + ("✔ " if fits(c, kbps) else "✘ ") + html.escape(c.short) + "</span>"
                       for c in DELIVERY_CHANNELS)


def threshold_value(threshold: str | None, name: str = r"PCK@0\.2") -> float | None:
    """The value of a threshold written as text on the criterion whose label matches the regular expression name
    (default hand PCK@0.2: "hand PCK@0.2 >= 98.0 %" gives 98.0; r"letter top-1" the letters'), else None."""
    found = re.search(name + r"\D*?(?:>=|≥)\s*([0-9]+(?:\.[0-9]+)?)", threshold or "")
    return float(found.group(1)) if found else None


def _swept_for_intelligibility(records: list[dict], field: str) -> list[dict]:
    """Points of a quantizer sweep on a Q scale at full resolution that carry the intelligibility field."""
    return [r for r in points(records) if r.get(field) is not None and r.get("sweep") in ("q", None)
            and r.get("full_resolution", True) and r.get("setting") is None
            and r.get("codec") not in OTHER_VIDEO_CODECS]


def _intelligibility_references(records: list[dict]) -> list[str]:
    """The references ("source video", "lossless render", ...) the intelligibility figures are measured against."""
    measured = [r for r in points(records) + matched_records(records)
                if any(r.get(field) is not None for field in INTELLIGIBILITY_PANELS)]
    return list(dict.fromkeys(str(r.get("reference") or "unnamed reference") for r in measured))


def _against(references: list[str]) -> str:
    return "against the " + " / ".join(references) if references else "against an unnamed reference"


def operating_picture(matched: dict, records: list[dict]) -> dict:
    """fps (frames/s), width and height (pixels) of a matched operating point: the matched record's own where it
    carries them, else those of its swept points (same solution and codec, at q_low / q_high, top frame rate)."""
    own = {name: matched.get(name) for name in ("fps", "width", "height")}
    if all(value is not None for value in own.values()):
        return own
    bracket = {matched.get("q_low"), matched.get("q_high")} - {None}
    swept = [r for r in points(records) if r["solution"] == matched["solution"] and r.get("codec") == matched.get("codec")
             and r.get("sweep") in ("q", None) and (not bracket or r.get("q") in bracket)]
    if not swept:
        return own
    fps, top = _top_rate(swept)
    return {"fps": own["fps"] if own["fps"] is not None else fps,
            "width": own["width"] if own["width"] is not None else top[0].get("width"),
            "height": own["height"] if own["height"] is not None else top[0].get("height")}


def _plot_intelligibility_sweeps(panel, records: list[dict], field: str, styles: dict, dashed_references: set) -> None:
    """One line per solution · codec (and reference): its quantizer sweep at its top frame rate, the field's
    mean over clips per Q, against kbps."""
    matched_reference = {_series_key(m): m.get("reference") for m in matched_records(records) if m.get("reference")}
    swept = [r for r in _swept_for_intelligibility(records, field)
             if matched_reference.get(_series_key(r), r.get("reference")) == r.get("reference")]
    for (name, ref), group in _groups(swept, lambda r: (_series_key(r), str(r.get("reference") or ""))).items():
        fps, top = _top_rate(group)
        rows = sorted((r for r in _by_quantiser(top, ("kbps", field)) if r[field] is not None), key=lambda r: r["kbps"])
        label = f"{name} ({fps:g} fps{_clips_note(rows[0]['clips'])})" + (f", vs {ref}" if dashed_references else "")
        style = styles.get(name, {"color": "grey", "marker": "o"})
        panel.plot([r["kbps"] for r in rows], [r[field] for r in rows], "--" if ref in dashed_references else "-",
                   ms=4, label=label, **style)
        errors = [interval(r["record"], field) if len(r["clips"]) == 1 else None for r in rows]
        shown = [(r["kbps"], r[field], e) for r, e in zip(rows, errors) if e is not None]
        if shown:
            panel.errorbar([x for x, _, _ in shown], [y for _, y, _ in shown], yerr=[e for _, _, e in shown],
                           fmt="none", ecolor=style.get("color", "grey"), elinewidth=1, capsize=2, alpha=0.7)


def _plot_matched(panel, records: list[dict], field: str, styles: dict) -> None:
    """The matched operating points as stars: filled where the threshold is reached, open where not; a horizontal bar
    over the range of the rates matched extraction by extraction (kbps_min-kbps_max) where the record has one."""
    labelled = set()
    for m in matched_records(records):
        if m.get("kbps") is None or m.get(field) is None:
            continue
        reached = bool(m.get("reached", True))
        label = "matched operating point" if reached else "best point (threshold not reached)"
        color = styles.get(_series_key(m), {"color": "black"})["color"]
        low, high = m.get("kbps_min"), m.get("kbps_max")
        if isinstance(low, (int, float)) and isinstance(high, (int, float)) and high > low:
            panel.errorbar([m["kbps"]], [m[field]], xerr=[[max(m["kbps"] - low, 0.0)], [max(high - m["kbps"], 0.0)]],
                           fmt="none", ecolor=color, elinewidth=2, capsize=4, zorder=4)
        panel.plot([m["kbps"]], [m[field]], "*", ms=13, color=color, mec="black", mfc=color if reached else "none",
                   ls="none", label=None if label in labelled else label)
        labelled.add(label)


def _finish_intelligibility_panel(panel, field: str) -> None:
    for channel in DELIVERY_CHANNELS:
        panel.axvline(channel.kbps, color="grey", ls=":", lw=1)
    panel.set_xscale("log")
    panel.set_xlabel("kbps (dotted: delivery channels " + ", ".join(f"{c.kbps:g}" for c in DELIVERY_CHANNELS) + ")")
    panel.set_ylabel(INTELLIGIBILITY_PANELS[field][0], fontsize=8)
    panel.grid(True, which="both", alpha=0.3)


def chart_rate_intelligibility(records: list[Record], styles: dict | None = None):
    """Rate against intelligibility: hand PCK@0.2 (percent) against kbps (log) for every solution's quantizer
    sweep at its top frame rate, the threshold on it, the matched operating points marked; further panels with
    face error (interocular distances) and letter top-1 (percent) where the points carry them. Points measured as
    the mean of several landmark extractions carry bars of their 95 % t-interval (K - 1 degrees of freedom)."""
    return _chart_rate_intelligibility(report_rows(records), styles)


def _chart_rate_intelligibility(records: list[dict], styles: dict | None = None):
    styles = styles or series_styles(records)
    fields = [f for f in INTELLIGIBILITY_PANELS if f == "hand_pck_20" or _swept_for_intelligibility(records, f)]
    figure, panels = plt.subplots(len(fields), 1, figsize=(8.5, 3.6 * len(fields)), squeeze=False)
    panels = panels.T                                      # one row of panels, drawn one above the other
    references = _intelligibility_references(records)
    dashed = set(references[1:]) if len(references) > 1 else set()
    for panel, field in zip(panels[0], fields):
        _plot_intelligibility_sweeps(panel, records, field, styles, dashed)
        _plot_matched(panel, records, field, styles)
        _finish_intelligibility_panel(panel, field)
    for panel, field in zip(panels[0], fields):
        name = THRESHOLD_LABELS.get(field)
        thresholds = {threshold_value(m.get("threshold"), name) for m in matched_records(records)} - {None} if name else set()
        for value in sorted(thresholds):
            panel.axhline(value, color="firebrick", ls="--", lw=1)
            panel.text(panel.get_xlim()[0], value, f" threshold {value:g} %", fontsize=7, va="bottom", color="firebrick")
    panels[0][0].set_title("hand keypoints")
    extracted = any(isinstance(r.get("extractions"), int) and r["extractions"] > 1 for r in points(records))
    suptitle(figure, f"Rate against intelligibility, {_against(references)}"
                    + ("\nbars: 95 % t-interval over each point's landmark extractions" if extracted else "")
                    + ("; across the stars: the range of the rates matched extraction by extraction"
                       if any(isinstance(m.get("kbps_max"), (int, float)) for m in matched_records(records)) else ""),
                    fontsize=10)
    _figure_legend(figure, panels[0])
    return figure


def _fps_sweeps_for_intelligibility(records: list[dict]) -> dict[str, list[dict]]:
    """Per solution · codec: hand PCK@0.2 over its frame-rate sweep (with the Q sweep's point at the same Q and a
    frame rate the sweep lacks), averaged over clips per frame rate, sorted by fps."""
    swept = [r for r in points(records) if r.get("sweep") == "fps" and r.get("hand_pck_20") is not None]
    sweeps = {}
    for name, group in _groups(swept, _series_key).items():
        extra = [r for r in points(records) if _series_key(r) == name and r.get("sweep") == "q" and r.get("hand_pck_20") is not None
                 and r.get("q") == group[0].get("q") and all(r["fps"] != g["fps"] for g in group)]
        rows = [{"fps": fps, "hand_pck_20": _mean(r["hand_pck_20"] for r in same)}
                for fps, same in _groups(group + extra, lambda r: r["fps"]).items()]
        sweeps[name] = sorted(rows, key=lambda row: row["fps"])
    return sweeps


def chart_intelligibility_vs_fps(records: list[Record], styles: dict | None = None):
    """Hand PCK@0.2 (percent) against frame rate (frames/s) over each series' frame-rate sweep, with the guidance's
    frame-rate lines (EN 301 549: 12, preferably 20; Tran et al.: 10) and the threshold."""
    return _chart_intelligibility_vs_fps(report_rows(records), styles)


def _chart_intelligibility_vs_fps(records: list[dict], styles: dict | None = None):
    styles = styles or series_styles(records)
    figure, axes = plt.subplots(figsize=(7.5, 4.5))
    for name, rows in _fps_sweeps_for_intelligibility(records).items():
        axes.plot([r["fps"] for r in rows], [r["hand_pck_20"] for r in rows], "-", ms=5, label=name,
                  **styles.get(name, {"color": "grey", "marker": "o"}))
    for fps, words, style in ((TRAN_FPS, "Tran et al. 10", ":"), (EN301549_MIN_FPS, "EN 301 549 min 12", "-"),
                              (EN301549_PREFERRED_FPS, "EN 301 549 preferred 20", "--")):
        axes.axvline(fps, color="grey", ls=style, lw=1)
        axes.text(fps, axes.get_ylim()[0], f" {words}", rotation=90, fontsize=7, va="bottom", color="grey")
    for value in sorted({threshold_value(m.get("threshold")) for m in matched_records(records)} - {None}):
        axes.axhline(value, color="firebrick", ls="--", lw=1)
    axes.set_xlabel("frames per second")
    axes.set_ylabel(INTELLIGIBILITY_PANELS["hand_pck_20"][0], fontsize=8)
    axes.set_title(f"Intelligibility against frame rate, {_against(_intelligibility_references(records))}", fontsize=9)
    axes.grid(True, alpha=0.3)
    if axes.lines:
        axes.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.0, 0.5))
    return figure


def _bracket(matched: dict) -> str:
    """kbps (the median of the rates matched extraction by extraction), with their range where they differ, and the
    swept Q values bracketing it: "12.3 (11.8–13.0) (Q 8–12)"."""
    low, high = matched.get("q_low"), matched.get("q_high")
    qs = [f"{q:g}" for q in dict.fromkeys(q for q in (low, high) if q is not None)]
    low_rate, high_rate = matched.get("kbps_min"), matched.get("kbps_max")
    spread_text = ""
    if isinstance(low_rate, (int, float)) and isinstance(high_rate, (int, float)) and high_rate > low_rate:
        spread_text = f" ({_fmt(low_rate, 1)}–{_fmt(high_rate, 1)})"
    return _fmt(matched.get("kbps"), 1) + spread_text + (f" (Q {'–'.join(qs)})" if qs else "")


def _reached(matched: dict) -> str:
    """"✔ yes" or "✘ no: rate of the best point", with how clear the verdict is (`verdict_note`)."""
    if "reached" not in matched:
        return "–"
    verdict = "✔ yes" if matched["reached"] else "✘ no: rate of the best point"
    note = verdict_note(matched)
    return f"{verdict} ({note})" if note else verdict


def verdict_note(matched: dict) -> str:
    """How clear the verdict is, extraction by extraction ("all 4 extractions agree", "2 of 4 extractions reach it:
    too close to call", "one extraction"); "" where the record does not say."""
    clear = matched.get("verdict_clear")
    if clear is None:
        return ""
    count, reached = matched.get("extractions"), matched.get("reached_extractions")
    if isinstance(count, int) and isinstance(reached, int):
        if count < 2:
            return "one extraction"
        agree = f"all {count} extractions agree" if clear else f"{reached} of {count} extractions reach it"
        return agree if clear else f"{agree}: too close to call"
    return "" if clear else "too close to call"


def _hands_found(matched: dict) -> str:
    left, right = matched.get("left_hand_found"), matched.get("right_hand_found")
    if left is None and right is None:
        return "–"
    return f"L {_fmt(left, 0)} / R {_fmt(right, 0)}"


def _face_verdict(matched: dict) -> str:
    """The face's own verdict at the matched point: its aligned error against its threshold."""
    ok, value, limit = matched.get("face_ok"), matched.get("face_value"), matched.get("face_threshold")
    if ok is None:
        return "–"
    return f"{'✔' if ok else '✘'} {_fmt(value, 3)} (≤ {_fmt(limit, 3)})"


def _codec_loss(matched: dict) -> str:
    """An avatar's codec loss: its matched rate against its own lossless render (ceiling-tied)."""
    loss = matched.get("codec_loss")
    if not loss:
        return "–"
    return f"{_fmt(loss.get('kbps'), 1)}{'' if loss.get('reached') else ' (not reached)'} (Q {loss.get('q')})"


def _holds(matched: dict) -> str:
    fps = matched.get("fps_holds")
    return "–" if fps is None else f"{fps:g} fps"


def _matched_table(records: list[dict]) -> str:
    """One row per solution (and codec) with a matched record; a solution of MATCHED_SOLUTIONS without one says so."""
    matched = matched_records(records)
    joints = any(m.get(f) is not None for m in matched for f in ("hand_joint_error_mm", "arm_joint_error_mm"))
    message = any(m.get("message_pck") is not None for m in matched)
    loss = any(m.get("codec_loss") for m in matched)
    face = any(m.get("face_ok") is not None for m in matched)
    shared = shared_threshold(matched)
    rows = []
    for solution in dict.fromkeys([*MATCHED_SOLUTIONS, *(m["solution"] for m in matched)]):
        mine = [m for m in matched if m["solution"] == solution]
        if not mine:
            rows.append([_fmt(solution), "–", "–", "no matched record",
                         *["–"] * (10 + 2 * joints + 2 * message + face + loss - bool(shared))])
            continue
        for m in mine:
            cells = [_fmt(solution), _fmt(m.get("codec")), _fmt(m.get("reference")), _bracket(m),
                     *([_fmt(m.get("threshold"))] if not shared else []), _reached(m), _fmt(m.get("hand_pck_20"), 1), _fmt(m.get("hand_error"), 3), _hands_found(m),
                     _fmt(m.get("face_error"), 3), _mouth_eyes(m), _fmt(m.get("letter_top1"), 0)]
            if joints:
                cells += [_fmt(m.get("hand_joint_error_mm"), 1), _fmt(m.get("arm_joint_error_mm"), 1)]
            if message:
                cells += [_fmt(m.get("message_pck"), 1), _fmt(m.get("message_location"), 3)]
            if face:
                cells.append(_face_verdict(m))
            if loss:
                cells.append(_codec_loss(m))
            rows.append(cells + [_holds(m), _channel_marks(m.get("kbps") if m.get("reached") else None)])
    header = ["solution", "codec", "measured against", "kbps at matched intelligibility (range) (Q bracket)",
              *(["threshold"] if not shared else []), "reached", "hand PCK@0.2 %", "hand error (hand sizes)", "hands found % (left / right)",
              "face error (interocular distances)", "mouth / eyes error (interocular distances)", "letter top-1 %",
              *(["hand joint error mm", "arm joint error mm"] if joints else []),
              *(["handshape PCK@0.2 % (message)", "wrist location (shoulder widths)"] if message else []),
              *(["face (aligned mouth and eyes): its threshold, part of the match"] if face else []),
              *(["codec loss: kbps against the lossless render"] if loss else []), "holds down to",
              "delivery channels it fits"]
    return _table("matched", header, rows)


def shared_threshold(matched: list[dict]) -> str | None:
    """The threshold text every matched record shares, or None when they differ (the table then has a column)."""
    thresholds = {m.get("threshold") for m in matched}
    return next(iter(thresholds)) if len(thresholds) == 1 and None not in thresholds else None


def _matched_section(records: list[dict], styles: dict) -> str:
    """The top of the report: kbps at matched intelligibility per solution, the rate-intelligibility chart and
    intelligibility against frame rate."""
    parts = ["<h2>kbps at matched intelligibility</h2>"]
    if matched_records(records):
        channels = "; ".join(f"“{html.escape(c.short)}”, {html.escape(c.name)}: {'≤' if c.inclusive else '&lt;'} {c.kbps:g} kbps "
                             f"({html.escape(c.source)})" for c in DELIVERY_CHANNELS)
        parts.append(
            "<p>What a viewer can read: the landmarks of what the viewer sees (the decoded video, or the terminal's "
            "re-render of the decoded parameters) against the landmarks of the reference named in “measured against” — "
            "the <em>source video</em> measures the message's fidelity; the <em>lossless render</em> measures only an avatar "
            "solution's codec loss, not the avatar's own distance from the signer. Each solution's operating point is the "
            "cheapest rate whose intelligibility reaches the threshold, interpolated between the two swept Q values that "
            "bracket it; where no swept point reaches it, the row gives the best point's rate. Every intelligibility "
            "figure is the mean of several landmark extractions, each from the picture moved by an invisible fraction of "
            "a pixel; the threshold is judged on each criterion's monotone fit over the swept Q (intelligibility does not "
            "fall when bits are added, so where a dearer point reads lower, the extractor's noise is pooled), and the "
            "threshold's columns (hand PCK, letter top-1) give that fit at the matched rate. Each extraction is also matched on its own (every point and the threshold as that extraction, under one "
            "shift, read them): the rate is the median of those matched rates, with their range in brackets; “reached” "
            "is clear when all extractions agree, and too close to call when they do not. Hand errors are in hand "
            "sizes (about 10 cm of palm: 0.1 is about a centimetre), face errors in interocular distances. “Holds down "
            "to” is the lowest frame rate at which the threshold still holds. Delivery channels: " + channels + ".</p>"
            + _table_note(records)
            + (f"<p><strong>Threshold</strong> (every row): {html.escape(shared_threshold(matched_records(records)))}, "
               "tied to the uncoded reference (see each run's records).</p>"
               if shared_threshold(matched_records(records)) else "")
            + _matched_table(records))
    if _swept_for_intelligibility(records, "hand_pck_20"):
        parts.append(page.image("rate_vs_intelligibility", _png(_chart_rate_intelligibility(records, styles)),
                            "rate against intelligibility"))
    if _fps_sweeps_for_intelligibility(records):
        parts.append(page.image("intelligibility_vs_fps", _png(_chart_intelligibility_vs_fps(records, styles)),
                            "intelligibility against frame rate"))
    return "".join(parts) if len(parts) > 1 else ""


def _table_note(records: list[dict]) -> str:
    """Says which references the table mixes: rows against different references are not comparable."""
    references = list(dict.fromkeys(str(m.get("reference") or "–") for m in matched_records(records)))
    if len(references) < 2:
        return ""
    return (f"<p><small>Rows are measured against different references ({_list(references)}): compare the rates of rows "
            "with the same reference only.</small></p>")


def _check(ok: bool | None, words: str) -> str:
    return "? " + words if ok is None else ("✔ " if ok else "✘ ") + words


def _at_least(width, height, size: tuple[int, int]) -> bool | None:
    if not width or not height:
        return None
    return width >= size[0] and height >= size[1]


def _guidance_row(matched: dict, records: list[dict]) -> list[str]:
    """Which public requirement lines a matched operating point meets (see _guidance_section)."""
    picture = operating_picture(matched, records)
    fps, width, height, kbps = picture["fps"], picture["width"], picture["height"], matched.get("kbps")
    holds = matched.get("fps_holds")
    size = f"{width}×{height}" if width and height else "–"
    en_fps = ("–" if fps is None else f"{fps:g} fps: " + _check(fps >= EN301549_MIN_FPS, "≥ 12") + ", "
              + _check(fps >= EN301549_PREFERRED_FPS, "≥ 20 preferred"))
    from comparisons.reports.headline import holds_at
    rates = _measured_rates(matched, records)
    reached = matched.get("reached")
    en_fps += "; holds at ≥ 12: " + _check(holds_at(EN301549_MIN_FPS, rates, holds, reached), "").strip()
    en_size = (_check(_at_least(width, height, QCIF), "≥ QCIF 176×144") + ", "
               + _check(_at_least(width, height, CIF), "≥ CIF 352×288 preferred"))
    tran = [_check(holds_at(TRAN_FPS, rates, holds, reached), "holds at 10 fps"),
            _check(None if kbps is None or not reached else kbps <= TRAN_KBPS, f"≤ 60 kbps (at {_fmt(fps, 0)} fps)"),
            _check(_at_least(width, height, TRAN_SIZE), "≥ 320×240")]
    shown = _fmt(kbps, 1) + ("" if reached or kbps is None else " (below threshold)")
    return [_fmt(matched["solution"]), _fmt(matched.get("codec")), size, shown, en_fps, en_size, ", ".join(tran),
            "–" if kbps is None or not reached else _meets(kbps)]


def _measured_rates(matched: dict, records: list[dict]) -> list[float]:
    """The frame rates measured for a matched series at its shown Q (its frame-rate sweep and its own rate)."""
    return sorted({float(r["fps"]) for r in records if r.get("kind") == "point" and r.get("solution") == matched["solution"]
                   and r.get("codec") == matched.get("codec") and r.get("q") == matched.get("q_shown")
                   and isinstance(r.get("fps"), (int, float))})


def _guidance_section(records: list[dict]) -> str:
    """Requirement lines from public guidance, per matched operating point: EN 301 549 clause 6.5 (frame rate and
    resolution), Tran et al. (ASSETS 2013) and the source's kbps lines."""
    matched = matched_records(records)
    if not matched:
        return ""
    rows = [_guidance_row(m, records) for m in matched]
    return ("<h2>Requirement lines from public guidance</h2><p>EN 301 549 clause 6.5 (video communication for sign "
            "language): at least 12 frames/s, 20 or more preferred; at least QCIF (176×144), CIF (352×288) preferred. "
            "Tran, Riskin, Ladner and Wobbrock (ASSETS 2013), 320×240 video: intelligibility stops improving above 10 "
            "frames/s; they recommend 10 frames/s at 60 kbit/s. The source: broadcast &lt; 100, webcast &lt; 56, phone "
            "line &lt; 64 kbps. Each row is a solution's matched operating point: its frame rate and size (FBA and BBA: "
            "the size the terminal renders at, its own choice), its rate, and whether the threshold still holds at a "
            "lower frame rate (“holds down to” above; ? where that is not known: no frame-rate sweep, or the threshold not "
            "reached). The guidance judged natural "
            "video by viewers; these rows judge landmarks against the reference, so a ✔ says the rate and format fit the "
            "line, not that viewers were asked.</p>"
            + _table("guidance", ["solution", "codec", "size", "kbps", "EN 301 549 frame rate", "EN 301 549 resolution",
                                  "Tran et al. 2013", "source's lines"], rows))


def report_html(records: list[Record], *, poster_png: bytes | None = None,
                title: str = "signcast: cost and quality of transmitting sign language") -> str:
    """The HTML report (one page) of Records: the sections the records have data for;
    poster_png: the side by side's poster frame. The study layer writes it (pipeline.outputs.build_report).

    Raises SigncastError when the records hold no measured point.
    """
    records = report_rows(records)
    measured = points(records)
    if not measured:
        kinds = _list(sorted({str(r.get("kind", "point")) for r in records})) or "none"
        raise SigncastError(f"no measured points in the records (record kinds: {kinds}); nothing to report")
    styles = series_styles(records)
    pictures = [r for r in measured if has_picture(r)]
    parameters = _parameter_points(records)
    from comparisons.reports.headline import headline_section
    sections = [headline_section(records), _matched_section(records, styles), _guidance_section(records)]
    if pictures:
        sections.append(_picture_summary(records))
    if parameters:
        sections.append(_parameter_summary(records))
    if poster_png:
        sections.append("<h2>Side by side</h2><p><code>side_by_side.mp4</code> shows every solution's decoded output at its "
                        "operating point; this is one frame of it.</p>"
                        + page.image("poster", poster_png, "poster frame of side_by_side.mp4"))
    if quantiser_sweeps(records):
        sections.append("<h2>Bitrate against quantizer</h2>"
                        + page.image("kbps_vs_q", _png(chart_kbps_vs_q(records, styles)), "kbps vs Q"))
    fits = linear_fits(records)
    if fits:
        sections.append("<h2>Bitrate against frame rate</h2>"
                        + page.image("kbps_vs_fps", _png(chart_kbps_vs_fps(records, styles)), "kbps vs fps")
                        + _table("linear_fits", ["series", "quantiser", "slope kbps/fps", "intercept kbps", "R²"],
                                 [[_fmt(f["series"]), _fmt(f"Q {f['q']}" if f["q"] is not None else None),
                                   _fmt(f["slope_kbps_per_fps"], 2), _fmt(f["intercept_kbps"], 1), _fmt(f["r2"], 3)]
                                  for f in fits]))
    charts = [(metric, "PSNR vs kbps" if metric == "psnr" else "SSIM vs kbps") for metric in ("psnr", "ssim")
              if _picture_points(records, metric)]
    if charts:
        sections.append("<h2>Rate and image quality</h2><p>" + html.escape(measured_against(records))
                        + ". Object solutions send no background, so their whole-frame figures count the dropped pixels as "
                        "error; the face-and-hands region carries the message.</p>"
                        + "".join(page.image(f"{metric}_vs_kbps", _png(_chart_rate_quality(records, metric, styles)), alt)
                                  for metric, alt in charts))
    if any(r.get("param_psnr") is not None or r.get("vpsnr") is not None for r in parameters):
        sections.append("<h2>Rate and parameter quality</h2><p>Each clip's decoded parameters against the same motion before "
                        "coding (full-precision BAPs); parameter PSNR and VPSNR are not image figures.</p>"
                        + page.image("parameter_quality", _png(_chart_parameter_quality(records, styles)),
                                 "parameter PSNR and VPSNR vs kbps"))
    sections.append(_requirements(records))
    if operating_points(records) or matched_records(records):
        sections.append(_criteria(records))
    sections.append(_every_point(records))
    sections.append(_run(records))

    body = (f"<p>{len(measured)} measured points. Every rate is the size of bytes that a decoder turned back into "
            f"data.</p>\n" + "".join(sections))
    return page.page(title, body)

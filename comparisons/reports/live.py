"""The report of a loss sweep (`signcast live`), made from its records alone: per solution and loss rate, the rate
on the wire, what was lost and concealed, what a viewer can still read, and the latency; one figure of
intelligibility and latency against loss rate per solution; the MPEG-2 TS overhead of each solution.

Point records (kind "point", sweep "loss") carry solution, codec, q, loss_rate, kbps, delivered_kbps,
packet_loss, frames_lost, frames_concealed, latency_ms_p50 / _p95 and the intelligibility fields, one record per
reference; this report reads those measured against the source (REFERENCE). Records of kind "transport stream"
carry the TS figures."""
from __future__ import annotations

import html
from collections import defaultdict

import numpy as np

from comparisons.reports import page
from comparisons.reports.figures import figure_png
from comparisons.reports.records import Record, report_rows
from media.domain import SOLUTION_ORDER

REFERENCE = "source video"
PREFERRED_MS, HINDERS_MS = 400.0, 800.0        # EN 301 549 guidance on conversation latency
STAGES = ("encode", "packetise", "network", "buffer", "decode+render")
PLOT_LIMIT = 1e12                              # values beyond this (or not finite) are tabled, never plotted


def verdict(p95_ms) -> str:
    """EN 301 549 (clause 6.5) on a 95th-percentile latency: under 0.4 s "preferred", up to 0.8 s "misses
    0.4 s", above "hinders" (conversation); "" when unknown."""
    value = _number(p95_ms)
    if value is None:
        return ""
    return "preferred" if value < PREFERRED_MS else "misses 0.4 s" if value <= HINDERS_MS else "hinders (> 0.8 s)"


def _number(value):
    """A finite number within PLOT_LIMIT as float, else None (records may hold any number that validates)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    value = float(value)
    return value if value == value and abs(value) <= PLOT_LIMIT else None
COLUMNS = (("loss_rate", "loss %", 100.0, 1), ("kbps", "stream kbps", 1.0, 2),
           ("delivered_kbps", "delivered kbps", 1.0, 2), ("packet_loss", "packets lost %", 100.0, 1),
           ("frames_lost", "frames lost", 1.0, 0), ("frames_concealed", "frames concealed", 1.0, 0),
           ("hand_pck_20", "hand PCK@0.2 %", 1.0, 1), ("hand_error", "hand error", 1.0, 3),
           ("face_error", "face error (interocular)", 1.0, 3),
           ("letter_top1", "letter top-1 %", 1.0, 0), ("latency_ms_p50", "latency p50 ms", 1.0, 0),
           ("latency_ms_p95", "latency p95 ms", 1.0, 0))


def loss_points(records: list[dict]) -> list[dict]:
    """The loss sweep's points measured against REFERENCE, by solution order, codec and loss rate."""
    points = [r for r in records if r.get("kind", "point") == "point" and r.get("sweep") == "loss"
              and r.get("reference", REFERENCE) == REFERENCE
              and isinstance(r.get("solution"), str) and isinstance(r.get("codec"), str)]
    order = {name: k for k, name in enumerate(SOLUTION_ORDER)}
    return sorted(points, key=lambda r: (order.get(r["solution"], 99), r["codec"], _number(r.get("loss_rate")) or 0.0))


def aggregate(points: list[dict]) -> list[dict]:
    """One row per solution, codec and loss rate: the mean of each column's field over the repeated sessions
    (each with its own seed), with "sessions" and, per field, its min and max ("<field>_range")."""
    groups: dict[tuple, list[dict]] = defaultdict(list)
    for record in points:
        groups[(record["solution"], record["codec"], record.get("loss_rate") or 0.0)].append(record)
    rows = []
    for (solution, codec, loss), group in groups.items():
        row = {"solution": solution, "codec": codec, "q": group[0].get("q"), "loss_rate": loss,
               "clip": group[0].get("clip"), "sessions": len(group)}
        for name in [column for column, _, _, _ in COLUMNS[1:]] + [f"{stage}_ms_{p}" for stage in STAGES
                                                                     for p in ("p50", "p95")]:
            values = [float(r[name]) for r in group if isinstance(r.get(name), (int, float))
                      and not isinstance(r.get(name), bool)]
            mean = sum(values) / len(values) if values else None
            row[name] = mean if mean is None or mean == mean and abs(mean) != float("inf") else None
            row[f"{name}_range"] = (min(values), max(values)) if values else None
        rows.append(row)
    return rows


def series(points: list[dict]) -> dict[tuple[str, str], list[dict]]:
    out: dict[tuple[str, str], list[dict]] = defaultdict(list)
    for record in points:
        out[(record["solution"], record["codec"])].append(record)
    return dict(out)


def _cell(value, scale: float, digits: int) -> str:
    if value is None or isinstance(value, bool) or not isinstance(value, (int, float)):
        return ""
    scaled = float(value) * scale
    return f"{scaled:.{digits}f}" if abs(scaled) < 1e15 else f"{scaled:.3g}"


def table_rows(points: list[dict]) -> list[list]:
    """live_table.csv: one row per aggregated point (the header first)."""
    return [["solution", "codec", "q", "sessions", *(label for _, label, _, _ in COLUMNS)]] + [
        [r["solution"], r["codec"], r.get("q"), r.get("sessions", 1),
         *(_cell(r.get(name), scale, digits + 1) for name, _, scale, digits in COLUMNS)] for r in points]


def _pyplot():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def chart(points: list[dict]):
    """Panels against loss rate (percent of datagrams): hand PCK@0.2 (clips that show hands), face error (clips
    that show a face), letter top-1 (fingerspelling only), and latency median with the 95th percentile as a bar."""
    plt = _pyplot()
    groups = series(points)
    measures = [(field, label, title) for field, label, title in (
        ("hand_pck_20", "hand PCK@0.2 (%)", "hand keypoints within 0.2 hand sizes\nof the source's, on what the receiver shows"),
        ("face_error", "face error (interocular distances)",
         "mean face landmark distance from the source's,\non what the receiver shows"),
        ("letter_top1", "letters recognised first (%)",
         "letter top-1 on what the receiver shows\n(recogniser trained on other signers)"))
        if any(_number(r.get(field)) is not None for r in points)]
    panels = len(measures) + 1
    figure, axes = plt.subplots(1, panels, figsize=(4.4 * panels, 3.8), squeeze=False)
    axes = axes[0]
    for (solution, codec), rows in groups.items():
        label = f"{solution} ({codec}, Q{rows[0].get('q')})"
        rows = [r for r in rows if _number(r.get("loss_rate") or 0.0) is not None
                and 0.0 <= float(r.get("loss_rate") or 0.0) <= 1.0]
        loss = [100.0 * float(r.get("loss_rate") or 0.0) for r in rows]
        color = None
        for ax, (field, _, _) in zip(axes, measures):
            values = [_number(r.get(field)) for r in rows]
            values = [np.nan if v is None else v for v in values]
            line = ax.plot(loss, values, "o-", color=color, label=label)[0]
            color = line.get_color()
        p50 = [_number(r.get("latency_ms_p50")) for r in rows]
        p95 = [_number(r.get("latency_ms_p95")) for r in rows]
        kept = [(x, a, b if b is not None else a) for x, a, b in zip(loss, p50, p95) if a is not None]
        if kept:
            xs, a, b = zip(*kept)
            axes[-1].errorbar(xs, a, yerr=[[0] * len(a), [max(0.0, bb - aa) for aa, bb in zip(a, b)]], fmt="o-",
                              capsize=3, color=color, label=label)
    for ax, (_, label, title) in zip(axes, measures):
        ax.set(xlabel="datagrams lost (%)", ylabel=label, title=title)
    guidance = [axes[-1].axhline(PREFERRED_MS, color="green", lw=0.8, ls="--", label="EN 301 549: < 0.4 s preferred"),
                axes[-1].axhline(HINDERS_MS, color="red", lw=0.8, ls="--", label="> 0.8 s hinders conversation")]
    axes[-1].set(xlabel="datagrams lost (%)", ylabel="ms", title="latency, capture to ready-to-show\n"
                 "dot: median; bar: to the 95th percentile\n(means over sessions)")
    axes[-1].set_ylim(bottom=0)
    rates = sorted({100.0 * float(r.get("loss_rate") or 0.0) for r in points
                    if _number(r.get("loss_rate") or 0.0) is not None and 0.0 <= float(r.get("loss_rate") or 0.0) <= 1.0})
    for ax in axes:
        ax.grid(True, alpha=0.3)
        ax.set_xscale("symlog", linthresh=0.5, linscale=0.5)     # 0, 0.5, 1, 2, 5, 10 % spread evenly
        ax.set_xticks(rates, [f"{rate:g}" for rate in rates])
    if measures:
        axes[0].legend(fontsize=7)
    axes[-1].legend(handles=guidance, fontsize=7, loc="center right")     # the series are named in the first panel
    figure.tight_layout()
    return figure


_html_table = page.table



def _transport_streams(records: list[dict]) -> str:
    rows = [r for r in records if r.get("kind") == "transport stream"]
    if not rows:
        return ""
    table = [[r["solution"], r["codec"], _cell(r.get("stream_kbps"), 1, 2), _cell(r.get("signer_payload_kbps"), 1, 2),
              _cell(r.get("signer_overhead_kbps"), 1, 2), _cell(r.get("psi_kbps"), 1, 2), _cell(r.get("pcr_kbps"), 1, 2),
              _cell(r.get("total_kbps"), 1, 1), r.get("file", ""),
              "yes" if r.get("demuxed_intact") else "no",
              "not installed" if r.get("ffprobe_streams") is None else ", ".join(r["ffprobe_streams"])]
             for r in rows]
    return ("<h2>MPEG-2 transport stream</h2><p>Each solution's stream muxed with a programme video (carphone, "
            "H.264) into one TS through PyAV (FFmpeg's mpegts muxer, default settings), demuxed back and checked. "
            "Overhead of the signer's stream: its PID's TS headers, adaptation fields and stuffing, and PES headers, "
            "measured from the TS packets; the tables (PAT, PMT, SDT) and the PCR are shared by the programme and "
            "stated apart.</p>" + _html_table(
                "transport stream", ["solution", "codec", "stream kbps", "signer PID payload kbps", "signer TS+PES overhead kbps",
                 "PSI kbps", "PCR kbps", "whole TS kbps", "file", "demuxed intact", "ffprobe streams"], table))


def _latency_flags(points: list[dict]) -> str:
    """A paragraph naming every point whose 95th-percentile latency misses EN 301 549's 0.4 s, and those over
    0.8 s (conversation hindered)."""
    misses = [r for r in points if verdict(r.get("latency_ms_p95")) not in ("", "preferred")]
    if not points:
        return ""
    if not misses:
        return ("<p><b>EN 301 549:</b> every point's 95th-percentile latency is under 0.4 s (the preferred "
                "end-to-end delay).</p>")
    items = "".join(f"<li>{html.escape(str(r['solution']))} {html.escape(str(r['codec']))}"
                    + (f" at {_cell(r['loss_rate'], 100.0, 1)} % loss" if r.get("loss_rate") is not None else "")
                    + f": p95 {_cell(r.get('latency_ms_p95'), 1.0, 0)} ms, "
                    f"{html.escape(verdict(r.get('latency_ms_p95')))}</li>" for r in misses)
    return (f"<p><b>EN 301 549</b> prefers an end-to-end delay under 0.4 s and says over 0.8 s hinders "
            f"conversation. These points miss 0.4 s at the 95th percentile:</p><ul>{items}</ul>")


def _stage_table(points: list[dict]) -> str:
    """Latency per stage (p50 / p95 ms), where the records carry it."""
    rows = [r for r in points if any(r.get(f"{stage}_ms_p50") is not None for stage in STAGES)]
    if not rows:
        return ""
    table = [[r["solution"], r["codec"], _cell(r.get("loss_rate"), 100.0, 1),
              *(f"{_cell(r.get(f'{stage}_ms_p50'), 1.0, 0)} / {_cell(r.get(f'{stage}_ms_p95'), 1.0, 0)}"
                for stage in STAGES),
              f"{_cell(r.get('latency_ms_p50'), 1.0, 0)} / {_cell(r.get('latency_ms_p95'), 1.0, 0)}",
              verdict(r.get("latency_ms_p95"))] for r in rows]
    return ("<h2>Where the latency goes</h2><p>Per stage, median / 95th percentile ms over the frames shown: "
            "encode (capture to the encoder's output, with any look-ahead), packetise (to the last datagram "
            "sent), network (to its arrival), buffer (the jitter buffer's wait), decode+render (to ready to "
            "show). Each stage's percentiles are its own, so they do not add up to the total's.</p>"
            + _html_table("latency stages", ["solution", "codec", "loss %", *STAGES, "total", "EN 301 549 (p95)"],
                          table))


def report_html(records: list[dict], figure_png: bytes) -> str:
    points = aggregate(loss_points(records))
    run = next((r for r in records if r.get("kind") == "run"), {})
    clip = points[0]["clip"] if points else run.get("clip", "")
    burst = run.get("burst", 1.0) or 1.0
    model = ("Bernoulli loss" if burst <= 1 else f"Gilbert-Elliott loss, mean burst {burst:g} packets")
    head = (f"<p>Clip {html.escape(str(clip))}, "
            f"{run.get('clip_frames', '')} frames at {run.get('clip_fps', '')} fps, sent live over RTP/UDP on the "
            f"loopback interface through a relay with {model}, jitter {run.get('jitter_ms', 0):g} ms, seed "
            f"{run.get('seed', '')}, {run.get('repeats', 1)} session(s) per point (means below); FBA/BBA intra refresh "
            f"{html.escape(str(run.get('refresh', '')))} frames, units of "
            f"{html.escape(str(run.get('units', 'period')))}. Intelligibility is measured "
            f"on what the receiver showed (frames that never arrived held from the last shown one), against the "
            f"{REFERENCE}'s landmarks. Latency: from each frame's capture to the moment it was ready to show, over "
            f"the frames that arrived.</p>")
    rows = [[r["solution"], r["codec"], r.get("q"), r.get("sessions", 1),
             *(_cell(r.get(name), scale, digits) for name, _, scale, digits in COLUMNS), verdict(r.get("latency_ms_p95"))]
            for r in points]
    table = _html_table("loss sweep", ["solution", "codec", "Q", "sessions", *(label for _, label, _, _ in COLUMNS),
                                       "EN 301 549 (p95)"], rows)
    table = _latency_flags(points) + table + _stage_table(points)
    figure = (f"<h2>Intelligibility and latency against loss</h2><p>Measured against the {REFERENCE}'s landmarks; "
              f"latency against EN 301 549's guidance (under {PREFERRED_MS / 1000:g} s preferred, over "
              f"{HINDERS_MS / 1000:g} s hinders conversation).</p>"
              + page.image("loss", figure_png, "hand PCK, letter accuracy and latency against the share of datagrams "
                           "lost, per solution"))
    return page.page("signcast live: delivery over a lossy network",
                     f"{head}{figure}<h2>Every point</h2>{table}{_transport_streams(records)}", max_width_px=1300,
                     extra_style="td { text-align: right; }")


def received_sessions(records: list[dict]) -> list[dict]:
    """The delivery records `signcast receive` wrote (kind "point", sweep "receive"), one per received session."""
    return [r for r in records if r.get("kind", "point") == "point" and r.get("sweep") == "receive"]


RECEIVED_COLUMNS = (("frames_lost", "frames lost", 1.0, 0), ("frames_concealed", "frames concealed", 1.0, 0),
                    ("received_kbps", "arrived kbps (with IP/UDP/RTP headers)", 1.0, 2),
                    ("packets_received", "datagrams read", 1.0, 0), ("late_packets", "late datagrams", 1.0, 0),
                    ("discarded_packets", "refused datagrams", 1.0, 0), ("jitter_measured_ms", "jitter ms", 1.0, 0),
                    ("hold_ms", "jitter buffer hold ms", 1.0, 0), ("latency_ms_p50", "latency p50 ms", 1.0, 0),
                    ("latency_ms_p95", "latency p95 ms", 1.0, 0))


def receive_report_html(records: list[Record]) -> str:
    """The page of what `signcast receive` measured: per received session, what arrived, what was lost and
    concealed, and the latency (whole and per stage) against EN 301 549. A receiver has no reference to read the
    signing against, so the page has no intelligibility; `signcast live` measures that."""
    records = report_rows(records)
    sessions = received_sessions(records)
    head = ("<p>What the receiver measured of each session it received over RTP/UDP (the sender's side, and what "
            "a viewer could read of it, are measured by <code>signcast live</code>, which holds the reference): "
            "frames that never arrived were held from the last shown one. Latency: from each frame's capture to "
            "the moment it was ready to show, over the frames that arrived.</p>")
    rows = [[r["solution"], r["codec"], r.get("q"), r.get("clip"), f"{_cell(r.get('fps'), 1, 3)}",
             *(_cell(r.get(name), scale, digits) for name, _, scale, digits in RECEIVED_COLUMNS),
             verdict(r.get("latency_ms_p95"))] for r in sessions]
    table = _html_table("received sessions", ["solution", "codec", "Q", "clip", "fps",
                                              *(label for _, label, _, _ in RECEIVED_COLUMNS), "EN 301 549 (p95)"],
                        rows)
    body = f"{head}{_latency_flags(sessions)}<h2>Received sessions</h2>{table}{_stage_table(sessions)}"
    return page.page("signcast receive: what arrived", body, max_width_px=1300, extra_style="td { text-align: right; }")


def report_outputs(records: list[Record]) -> dict:
    """live_table.csv (rows), live_loss.png (bytes) and report.html (text) from the records, by file name; the study
    layer writes them (pipeline.outputs.write_outputs)."""
    records = report_rows(records)
    points = aggregate(loss_points(records))
    png = figure_png(chart(points) if points else None, empty="no measured point")
    return {"live_table.csv": table_rows(points), "live_loss.png": png, "report.html": report_html(records, png)}


def summary_text(records: list[Record]) -> str:
    """The loss sweep's table as text for the terminal (means over repeated sessions)."""
    records = report_rows(records)
    points = aggregate(loss_points(records))
    header = f"{'solution':9}{'codec':10}{'loss %':>7}{'kbps':>8}{'wire kbps':>10}{'lost fr':>8}{'PCK@0.2':>8}" \
             f"{'face':>7}{'letters':>8}{'p50 ms':>8}{'p95 ms':>8}  EN 301 549"
    lines = [header]
    for r in points:
        lines.append(f"{r['solution']:9}{r['codec']:10}{_cell(r.get('loss_rate'), 100, 1):>7}"
                     f"{_cell(r.get('kbps'), 1, 1):>8}{_cell(r.get('delivered_kbps'), 1, 1):>10}"
                     f"{_cell(r.get('frames_lost'), 1, 0):>8}{_cell(r.get('hand_pck_20'), 1, 1):>8}"
                     f"{_cell(r.get('face_error'), 1, 3):>7}{_cell(r.get('letter_top1'), 1, 0):>8}"
                     f"{_cell(r.get('latency_ms_p50'), 1, 0):>8}"
                     f"{_cell(r.get('latency_ms_p95'), 1, 0):>8}  {verdict(r.get('latency_ms_p95'))}")
    return "\n".join(lines)

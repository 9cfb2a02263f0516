"""The comparison report: one self-contained HTML page (plots embedded as PNG) made from records only.

Records are dicts as written to records.jsonl. Measured points carry at least solution, codec, q, fps,
kbps and, where measured, psnr / ssim (whole frame) and psnr_skin / ssim_skin (skin region) against
the common reference frames. A record with kind == "stage" carries a stage's wall time (stage, wall_s);
one with kind == "run" carries the software versions and the backend. Points flagged
operating_point == True are the solutions' operating points (video Q = 12 at 25 fps, parameters at 25 fps).
"""
from __future__ import annotations

import base64
import html
import io
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from comparisons.criteria import SOLUTIONS, criteria_table  # noqa: E402

REQUIREMENTS = (("broadcast", 100.0), ("webcast", 56.0), ("phone line", 64.0))
MIN_COMFORT_FPS = 15.0
SOLUTION_ORDER = ("NSV", "NSV2O", "NSV3O", "NSV3O+C", "SSV", "FBA", "BBA")
COLOURS = {"NSV": "#1f77b4", "NSV2O": "#ff7f0e", "NSV3O": "#2ca02c", "NSV3O+C": "#98df8a", "SSV": "#d62728",
           "FBA": "#9467bd", "BBA": "#8c564b"}


def points(records: list[dict]) -> list[dict]:
    return [r for r in records if r.get("kind", "point") == "point" and r.get("kbps") is not None]


def _series_key(record: dict) -> str:
    codec = record.get("codec", "")
    return f"{record['solution']} · {codec}" if codec else record["solution"]


def _order(solution: str) -> int:
    return SOLUTION_ORDER.index(solution) if solution in SOLUTION_ORDER else len(SOLUTION_ORDER)


def _png(figure) -> str:
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=110, bbox_inches="tight")
    plt.close(figure)
    return base64.b64encode(buffer.getvalue()).decode("ascii")


def _groups(records: list[dict], key) -> dict:
    groups: dict = {}
    for r in records:
        groups.setdefault(key(r), []).append(r)
    return dict(sorted(groups.items(), key=lambda kv: (_order(kv[1][0]["solution"]), kv[0])))


def _finish_rate_axes(axes, xlabel: str, title: str) -> None:
    """Log kbps axis, grid, and the legend outside on the right."""
    axes.set_xlabel(xlabel)
    axes.set_ylabel("kbps")
    axes.set_yscale("log")
    axes.set_title(title)
    axes.grid(True, which="both", alpha=0.3)
    if axes.lines:
        axes.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.0, 0.5))


def chart_kbps_vs_q(records: list[dict]):
    """kbps against Q at the operating frame rate, one line per solution and codec."""
    figure, axes = plt.subplots(figsize=(7.5, 4.5))
    for name, group in _groups([r for r in points(records) if r.get("sweep") in ("q", None) and r.get("q") is not None
                                and r.get("full_resolution", True)], _series_key).items():
        fps_values = sorted({g["fps"] for g in group})
        fps = max(fps_values)
        series = sorted((g["q"], g["kbps"]) for g in group if g["fps"] == fps)
        if len(series) < 2:
            continue
        q, kbps = zip(*series)
        axes.plot(q, kbps, "o-", label=f"{name} ({fps:g} fps)", color=COLOURS.get(group[0]["solution"]))
    _finish_rate_axes(axes, "quantizer Q", "Bitrate against quantizer (source Figs. 4.10-4.15)")
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


def chart_kbps_vs_fps(records: list[dict]):
    figure, axes = plt.subplots(figsize=(7.5, 4.5))
    for fit in linear_fits(records):
        colour = COLOURS.get(fit["solution"])
        axes.plot(fit["fps"], fit["kbps"], "o", color=colour)
        span = np.array([min(fit["fps"]), max(fit["fps"])])
        axes.plot(span, fit["slope_kbps_per_fps"] * span + fit["intercept_kbps"], "-", color=colour,
                  label=f"{fit['series']}: {fit['slope_kbps_per_fps']:.2f}·fps + {fit['intercept_kbps']:.1f} (R²={fit['r2']:.3f})")
    for label, limit in REQUIREMENTS:
        axes.axhline(limit, color="grey", ls=":", lw=1)
        axes.text(axes.get_xlim()[0] if axes.lines else 10, limit, f" {label} {limit:g}", fontsize=7, va="bottom", color="grey")
    axes.axvline(MIN_COMFORT_FPS, color="grey", ls="--", lw=1)
    _finish_rate_axes(axes, "frames per second", "Bitrate against frame rate, with linear fits")
    return figure


def chart_rate_quality(records: list[dict], metric: str):
    """quality (metric, whole frame and skin region) against kbps: each solution's quantizer sweep at its top
    frame rate as a line, today's codecs at matched quality as single markers."""
    figure, panels = plt.subplots(1, 2, figsize=(12, 4.8), sharey=True)
    measured = [r for r in points(records) if r.get(metric) is not None and r.get("full_resolution", True)]
    for panel, suffix, title in ((panels[0], "", "whole frame"), (panels[1], "_skin", "skin region (face and hands)")):
        swept = [r for r in measured if r.get("sweep") in ("q", None) and r.get(metric + suffix) is not None]
        for name, group in _groups(swept, _series_key).items():
            top_fps = max(g["fps"] for g in group)
            series = sorted((g["kbps"], g[metric + suffix]) for g in group if g["fps"] == top_fps)
            kbps, quality = zip(*series)
            panel.plot(kbps, quality, "o-", ms=4, label=name, color=COLOURS.get(group[0]["solution"]))
        for r in (r for r in measured if r.get("sweep") == "codec" and r.get(metric + suffix) is not None):
            panel.plot([r["kbps"]], [r[metric + suffix]], "D" if "264" in r["codec"] else "s", mfc="none", ms=7,
                       color=COLOURS.get(r["solution"]), label=_series_key(r))
        for label, limit in REQUIREMENTS:
            panel.axvline(limit, color="grey", ls=":", lw=1)
        panel.set_xscale("log")
        panel.set_xlabel("kbps")
        panel.set_title(f"{metric.upper()}, {title}")
        panel.grid(True, which="both", alpha=0.3)
    panels[0].set_ylabel(metric.upper() + (" (dB)" if metric == "psnr" else ""))
    handles, labels = panels[1].get_legend_handles_labels()
    if handles:
        figure.legend(handles, labels, fontsize=7, loc="center left", bbox_to_anchor=(1.0, 0.5))
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


def _table(name: str, header: list[str], rows: list[list]) -> str:
    head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{c}</td>" for c in row) + "</tr>" for row in rows)
    return f'<table data-table="{name}"><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>'


def _image(name: str, b64: str, alt: str) -> str:
    return f'<img class="chart" data-chart="{name}" alt="{html.escape(alt)}" src="data:image/png;base64,{b64}">'


def build_report(records: list[dict], out_path: str | Path, *, poster_png: bytes | None = None,
                 title: str = "signcast: cost and quality of transmitting sign language") -> Path:
    """Write the HTML report to out_path and return it."""
    out_path = Path(out_path)
    measured = points(records)
    run = next((r for r in records if r.get("kind") == "run"), {})
    stages = [r for r in records if r.get("kind") == "stage"]
    sections = []

    ops = operating_points(records)
    summary_rows = [[_fmt(r["solution"]), _fmt(r.get("codec")), _fmt(r.get("q"), 0), _fmt(float(r["fps"]), 0),
                     _fmt(float(r["kbps"]), 2), _fmt(r.get("psnr"), 2), _fmt(r.get("psnr_skin"), 2),
                     _fmt(r.get("ssim"), 3), _fmt(r.get("ssim_skin"), 3),
                     " ".join(("✔" if r["kbps"] < limit else "✘") + " " + label for label, limit in REQUIREMENTS)]
                    for r in ops]
    sections.append("<h2>Summary at the operating points</h2><p>Video at Q = 12 and 25 fps (the source's working point); "
                    "parameters at 25 fps, each codec at the cheapest Q whose re-rendered skin quality reaches SSV's "
                    "(matched quality). Quality is measured against the same reference frames for every solution; "
                    "FBA/BBA are decoded and re-rendered by the terminal with the same kernels.</p>"
                    + _table("summary", ["solution", "codec", "Q", "fps", "kbps", "PSNR dB", "PSNR skin dB", "SSIM",
                                         "SSIM skin", "requirements"], summary_rows))
    if poster_png:
        sections.append("<h2>Side by side</h2><p><code>side_by_side.mp4</code> shows every solution's decoded output at its "
                        "operating point; this is one frame of it.</p>"
                        + _image("poster", base64.b64encode(poster_png).decode("ascii"), "poster frame of side_by_side.mp4"))
    sections.append("<h2>Bitrate against quantizer</h2>" + _image("kbps_vs_q", _png(chart_kbps_vs_q(records)), "kbps vs Q"))
    fits = linear_fits(records)
    sections.append("<h2>Bitrate against frame rate</h2>" + _image("kbps_vs_fps", _png(chart_kbps_vs_fps(records)), "kbps vs fps")
                    + _table("linear_fits", ["series", "Q", "slope kbps/fps", "intercept kbps", "R²"],
                             [[_fmt(f["series"]), _fmt(f["q"], 0), _fmt(f["slope_kbps_per_fps"], 2), _fmt(f["intercept_kbps"], 1),
                               _fmt(f["r2"], 3)] for f in fits]))
    sections.append("<h2>Rate and quality on the common axis</h2><p>SSV, FBA and BBA are measured against the same "
                    "reference frames (the avatar rendered from the original motion); the natural-video solutions "
                    "against their source clip. Object solutions send no background, so their whole-frame figures count "
                    "the dropped pixels; the skin region (face and hands) carries the message.</p>"
                    + _image("psnr_vs_kbps", _png(chart_rate_quality(records, "psnr")), "PSNR vs kbps")
                    + _image("ssim_vs_kbps", _png(chart_rate_quality(records, "ssim")), "SSIM vs kbps"))
    requirement_table = []
    for row in requirement_rows(records):
        cells = [_fmt(row["series"])]
        for label in ("operating point", "cheapest at ≥ 15 fps"):
            best = row.get(label)
            if best is None:
                cells += ["–", "–"]
                continue
            cells.append(f"{best['kbps']:.1f} kbps (Q {_fmt(best.get('q'), 0)}, {best['fps']:g} fps)")
            cells.append(" ".join(("✔" if best["kbps"] < limit else "✘") + f" {label_} &lt; {limit:g}"
                                  for label_, limit in REQUIREMENTS))
        requirement_table.append(cells)
    sections.append("<h2>Against the source's requirement lines</h2><p>Broadcast &lt; 100 kbps, webcast &lt; 56 kbps, "
                    "phone line &lt; 64 kbps, and at least 15 frames/s for signing comfort.</p>"
                    + _table("requirements", ["series", "operating point", "meets", "cheapest at ≥ 15 fps", "meets"],
                             requirement_table))
    kbps_by_solution = {}
    for solution in SOLUTIONS:
        rates = [r["kbps"] for r in ops if r["solution"] == solution]
        kbps_by_solution[solution] = min(rates) if rates else None
    criteria = criteria_table(kbps_by_solution)
    sections.append("<h2>Six criteria (source Tables 4.1-4.5 and 4.17)</h2><p>Scores 1-6, 6 = best. The bandwidth row is "
                    "recomputed from this run; the other rows are carried over from the source with its reason.</p>"
                    + _table("criteria", ["criterion", *SOLUTIONS, "reason"],
                             [[_fmt(r["criterion"]), *[_fmt(r[s]) for s in SOLUTIONS], _fmt(r["reason"])] for r in criteria]))
    all_rows = [[_fmt(r["solution"]), _fmt(r.get("codec")), _fmt(r.get("q"), 0), _fmt(float(r["fps"]), 0),
                 f"{_fmt(r.get('width'))}×{_fmt(r.get('height'))}" if r.get("width") else "–",
                 _fmt(float(r["kbps"]), 2), _fmt(r.get("psnr"), 2), _fmt(r.get("psnr_skin"), 2), _fmt(r.get("ssim"), 3)]
                for r in sorted(measured, key=lambda r: (_order(r["solution"]), r.get("codec", ""), -(r["fps"]), r.get("q") or 0))]
    sections.append("<h2>Every measured point</h2>" + _table("points", ["solution", "codec", "Q", "fps", "size", "kbps", "PSNR",
                                                                          "PSNR skin", "SSIM"], all_rows))
    environment_rows = [[_fmt(k), _fmt(v)] for k, v in sorted((run.get("versions") or {}).items())]
    environment_rows.insert(0, ["backend", _fmt(run.get("backend"))])
    sections.append("<h2>Run</h2>" + _table("versions", ["software", "version"], environment_rows)
                    + _table("stages", ["stage", "wall time s"], [[_fmt(s["stage"]), _fmt(float(s["wall_s"]), 2)] for s in stages]))

    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{html.escape(title)}</title>
<style>
body {{ font-family: system-ui, sans-serif; margin: 2em auto; max-width: 1150px; color: #222; }}
table {{ border-collapse: collapse; margin: 0.8em 0 1.6em; font-size: 0.88em; }}
th, td {{ border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: left; vertical-align: top; }}
th {{ background: #f0f0f0; }}
img.chart {{ max-width: 100%; display: block; margin: 0.5em 0 1.2em; }}
#render-check {{ color: #888; font-size: 0.8em; }}
</style></head><body>
<h1>{html.escape(title)}</h1>
<p>{len(measured)} measured points. Every rate is the size of bytes that a decoder turned back into data.</p>
{''.join(sections)}
<p id="render-check">not checked</p>
<script>
window.addEventListener("load", () => {{
  const charts = [...document.querySelectorAll("img.chart")];
  const tables = [...document.querySelectorAll("table[data-table]")];
  const brokenCharts = charts.filter(i => !(i.complete && i.naturalWidth > 0)).map(i => i.dataset.chart);
  const emptyTables = tables.filter(t => t.tBodies[0].rows.length === 0).map(t => t.dataset.table);
  document.getElementById("render-check").textContent =
    `rendered ${{charts.length - brokenCharts.length}}/${{charts.length}} charts, ${{tables.length - emptyTables.length}}/${{tables.length}} tables` +
    (brokenCharts.length || emptyTables.length ? `; broken: ${{[...brokenCharts, ...emptyTables].join(", ")}}` : "; all ok");
}});
</script>
</body></html>"""
    out_path.parent.mkdir(parents=True, exist_ok=True)
    out_path.write_text(page, encoding="utf-8")
    return out_path

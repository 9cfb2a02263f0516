"""The report of a lexicon sweep (`signcast sweep`), made from its records alone: per language x solution x codec,
the median kbps at the matched operating point over the items, with the interquartile range; one figure; the
failed points with their reasons.

The matched operating point of one item (a clip, or a fingerspelled word) coded with one codec at one frame rate is
found by comparisons.judging.matching.cheapest_rate, the rule of `signcast compare`, over the item's swept Q: the cheapest
rate above which every swept point meets the threshold, interpolated in log-rate between the bracketing Q; judged on
the points as measured (forward kinematics is exact: no extractor's noise to pool, unlike compare's). The
sweep has no rendering, so its threshold is on parameter quality (forward kinematics of the avatar,
comparisons.params.study) against the uncoded, retargeted motion:
- the body: mean joint position error at most JOINT_ERROR_MM;
- the face, where the motion has one (its records say face_sent): the 90th percentile over frames of each frame's
  worst face point, the face bones' tails in the head's frame, at most FACE_ERROR_MM. The body's mean cannot see
  the face (its joints ride on the head, so a face left at rest costs a fraction of a millimetre of mean error);
  a face's message is local, one lip or brow wrong for a few frames, which the worst point of a frame shows and a
  mean over 44 points dilutes. A coder that does not send the face (seed 002's) reaches it only where the face
  moves less than that.
An item whose finest Q misses the threshold does not count in the median (the cell says how many reached it).

Point records (kind "point") carry language, item, solution, codec, q, fps, kbps and joint_error_mm_mean (and,
for a motion with a face, face_sent: whether the codec sent it, and face_joint_error_mm_p90); failed ones (kind
"failed") their reason.
"""
from __future__ import annotations

import html
from collections import defaultdict

import numpy as np

from comparisons.judging import matching
from comparisons.reports import page
from comparisons.reports.figures import figure_png, suptitle
from comparisons.reports.records import Record, report_rows
from media.domain import SOLUTION_ORDER

JOINT_ERROR_MM = 2.0        # the FBA root-translation step, and the key-frame analyser's translation bound
FACE_ERROR_MM = JOINT_ERROR_MM      # the same spatial bound, on each face point rather than on the body's mean
CRITERION = matching.Criterion("joint_error_mm_mean", JOINT_ERROR_MM, higher_is_better=False,
                               label="mean joint position error (mm)")
FACE_CRITERION = matching.Criterion("face_joint_error_mm_p90", FACE_ERROR_MM, higher_is_better=False,
                                    label="worst face point's error (mm, 90th percentile over frames)")
MEASURED_AGAINST = "the uncoded motion retargeted to the avatar"
THRESHOLD_TEXT = f"{CRITERION.text()} and, where the motion has a face, {FACE_CRITERION.text()}"
OPERATING_RULE = (f"cheapest rate at which every dearer swept Q keeps the {THRESHOLD_TEXT} against "
                  f"{MEASURED_AGAINST}; interpolated in log-rate between the bracketing Q (comparisons.judging.matching)")
ALL_LANGUAGES = "all"
BEST = "cheapest codec"


def language_item(record: dict) -> tuple[str, str]:
    """A sweep record's (language, item): its own fields, or its clip "language:item"."""
    if record.get("language") is not None and record.get("item") is not None:
        return record["language"], record["item"]
    language, _, item = str(record.get("clip", "")).partition(":")
    return language, item


def matched_points(records: list[dict]) -> list[dict]:
    """One dict per (language, item, codec, fps): solution, kbps at the matched operating point, reached (the
    threshold is met at some swept Q), q_met (the cheapest swept Q of the run that meets it) and q_missed (the next
    cheaper swept Q, which misses it; None when there is none)."""
    groups: dict[tuple, list[dict]] = defaultdict(list)
    for record in records:
        if record.get("kind", "point") == "point" and record.get("kbps") is not None:
            groups[(*language_item(record), record["codec"], float(record["fps"]))].append(record)
    matched = []
    for (language, item, codec, fps), points in groups.items():
        match = matching.cheapest_rate(points, criteria(points))
        matched.append({"language": language, "item": item, "codec": codec, "fps": fps,
                        "solution": points[0]["solution"], "kbps": match.kbps, "reached": match.reached,
                        "q_met": match.upper["q"], "q_missed": match.lower["q"] if match.lower else None})
    return matched


def criteria(points: list[dict]) -> list[matching.Criterion]:
    """The threshold of one item's points: CRITERION, and FACE_CRITERION where the motion has a face (its records
    say whether the codec sent it)."""
    has_face = any(point.get("face_sent") is not None for point in points)
    return [CRITERION, FACE_CRITERION] if has_face else [CRITERION]


def _spread(values: list[float]) -> dict:
    if not values:
        return {"median": None, "q1": None, "q3": None}
    q1, median, q3 = np.percentile(np.asarray(values, dtype=float), [25, 50, 75])
    return {"median": float(median), "q1": float(q1), "q3": float(q3)}


def _solution_order(solution: str) -> int:
    return SOLUTION_ORDER.index(solution) if solution in SOLUTION_ORDER else len(SOLUTION_ORDER)


def cells(matched: list[dict]) -> list[dict]:
    """One dict per (fps, language, solution, codec), languages also pooled as ALL_LANGUAGES, and per solution the
    column BEST (each item's cheapest codec of the solution): n items, n_reached, and median, q1, q3 of the
    matched kbps over the items that reached the threshold."""
    groups: dict[tuple, list[dict]] = defaultdict(list)
    for point in matched:
        for language in (point["language"], ALL_LANGUAGES):
            groups[(point["fps"], language, point["solution"], point["codec"])].append(point)
    best: dict[tuple, dict] = {}
    for point in matched:
        for language in (point["language"], ALL_LANGUAGES):
            key = (point["fps"], language, point["solution"], BEST, point["language"], point["item"])
            held = best.get(key)
            if held is None or (point["reached"], -point["kbps"]) > (held["reached"], -held["kbps"]):
                best[key] = point
    for key, point in best.items():
        groups[key[:4]].append(point)
    rows = []
    for (fps, language, solution, codec), points in groups.items():
        reached = [p["kbps"] for p in points if p["reached"]]
        rows.append({"fps": fps, "language": language, "solution": solution, "codec": codec, "n": len(points),
                     "n_reached": len(reached), **_spread(reached)})
    rows.sort(key=lambda r: (r["fps"], r["language"] == ALL_LANGUAGES, r["language"], _solution_order(r["solution"]),
                             r["codec"] == BEST, r["codec"]))
    return rows


def columns(table: list[dict]) -> list[tuple[str, str]]:
    """The (solution, codec) columns of the table, solutions in SOLUTION_ORDER, each solution's BEST last."""
    found = {(r["solution"], r["codec"]) for r in table}
    return sorted(found, key=lambda c: (_solution_order(c[0]), c[1] == BEST, c[1]))


def cell_text(cell: dict | None) -> str:
    """'12.3 [10.1-14.2]' (median [q1-q3] kbps), with '(k/n)' when only k of n items reached the threshold."""
    if cell is None:
        return ""
    if cell["median"] is None:
        return f"not reached (0/{cell['n']})"
    text = f"{cell['median']:.1f} [{cell['q1']:.1f}-{cell['q3']:.1f}]"
    return text + (f" ({cell['n_reached']}/{cell['n']})" if cell["n_reached"] < cell["n"] else "")


def _grid(table: list[dict]):
    """{fps: {language: {(solution, codec): cell}}} in the table's order."""
    grid: dict = {}
    for cell in table:
        grid.setdefault(cell["fps"], {}).setdefault(cell["language"], {})[(cell["solution"], cell["codec"])] = cell
    return grid


def summary_text(table: list[dict]) -> str:
    """The terminal table: per frame rate, languages x (solution, codec), median [IQR] kbps at the matched point."""
    wanted = columns(table)
    names = [f"{solution} {codec}" if codec == BEST else codec for solution, codec in wanted]
    lines = [(f"kbps at the matched operating point, median [IQR] over items ({THRESHOLD_TEXT}, against "
              f"{MEASURED_AGAINST})")]
    for fps, languages in _grid(table).items():
        width = max(len(n) for n in names + ["x" * 16])
        lines.append(f"{fps:g} fps".ljust(9) + " ".join(n.rjust(width) for n in names))
        for language, row in languages.items():
            lines.append(language.ljust(9) + " ".join(cell_text(row.get(c)).rjust(width) for c in wanted))
    return "\n".join(lines)


def table_rows(table: list[dict]) -> list[list]:
    """The cells as CSV rows (the header first): fps, language, solution, codec, items, items_reached, median_kbps,
    q1_kbps, q3_kbps."""
    return [["fps", "language", "solution", "codec", "items", "items_reached", "median_kbps", "q1_kbps", "q3_kbps"]] + [
        [f"{c['fps']:g}", c["language"], c["solution"], c["codec"], c["n"], c["n_reached"],
         *("" if c[k] is None else f"{c[k]:.3f}" for k in ("median", "q1", "q3"))] for c in table]


def _pyplot():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def chart(table: list[dict]):
    """One panel per frame rate: per language, each codec's median matched kbps with its IQR as a bar."""
    plt = _pyplot()
    grid = _grid(table)
    codecs = [c for c in columns(table) if c[1] != BEST]
    figure, panels = plt.subplots(len(grid), 1, figsize=(max(7.0, 0.55 * max(len(v) for v in grid.values()) + 3),
                                                          3.6 * len(grid)), squeeze=False)
    for axes, (fps, languages) in zip(panels[:, 0], grid.items()):
        names = list(languages)
        x = np.arange(len(names))
        for k, column in enumerate(codecs):
            offset = (k - (len(codecs) - 1) / 2) * 0.8 / max(len(codecs), 1)
            found = [(i, languages[n].get(column)) for i, n in enumerate(names)]
            found = [(i, c) for i, c in found if c is not None and c["median"] is not None]
            if not found:
                continue
            xs = np.array([i for i, _ in found]) + offset
            median = np.array([c["median"] for _, c in found])
            errors = np.array([[c["median"] - c["q1"] for _, c in found], [c["q3"] - c["median"] for _, c in found]])
            axes.errorbar(xs, median, yerr=errors, fmt="o", capsize=2, markersize=4, label=f"{column[1]} ({column[0]})")
        axes.set_xticks(x, names, rotation=45 if len(names) > 8 else 0)
        axes.set(ylabel="kbit/s at matched point", title=f"{fps:g} fps: median over items, bars: interquartile range")
        axes.set_ylim(0, axes.get_ylim()[1] * 1.2)        # headroom: no marker on the frame, none under the legend
        axes.grid(True, axis="y", alpha=0.3)
        axes.legend(fontsize=7, ncol=min(len(codecs), 5))
    suptitle(figure, f"Rate at the matched operating point, against {MEASURED_AGAINST}\n{CRITERION.text()}; "
                    f"where the motion has a face, {FACE_CRITERION.text()}", fontsize=9)
    figure.tight_layout()
    return figure


def face_note(records: list[dict]) -> str | None:
    """A sentence naming the codecs that did not send the swept motions' faces (records with face_sent false:
    seed 002's coders), or None when every codec sent them or no motion had a face."""
    faceless = sorted({r["codec"] for r in records if r.get("kind", "point") == "point" and r.get("face_sent") is False})
    if not faceless:
        return None
    return (f"Face not sent by {', '.join(faceless)}: these coders carry the signing joints only, so the face decodes "
            f"at rest, and they reach the threshold only on items whose face moves less than {FACE_ERROR_MM:g} mm "
            "(each frame's worst face point, in the head's frame).")


def _html_table(header: list[str], rows: list[list[str]], name: str = "table") -> str:
    return page.table(name, header, rows)


def _failed_section(records: list[dict]) -> str:
    failed = [r for r in records if r.get("kind") == "failed"]
    if not failed:
        return "<h2>Failed points</h2><p>None.</p>"
    reasons: dict[str, int] = defaultdict(int)
    for record in failed:
        reasons[record.get("reason", "")] += 1
    rows = [[r["clip"], r["codec"], r["q"], f"{r['fps']:g}", r.get("reason", "")] for r in failed[:100]]
    more = f"<p>First 100 of {len(failed)}.</p>" if len(failed) > 100 else ""
    return ("<h2>Failed points</h2>" + _html_table(["points", "reason"], [[n, reason] for reason, n in
                                                                           sorted(reasons.items(), key=lambda x: -x[1])])
            + _html_table(["clip", "codec", "Q", "fps", "reason"], rows) + more)


def report_html(records: list[dict], table: list[dict], figure_png: bytes) -> str:
    """The page: what was swept, the table per frame rate, the figure, the failed points."""
    points = [r for r in records if r.get("kind", "point") == "point"]
    failed = sum(1 for r in records if r.get("kind") == "failed")
    languages = sorted({language_item(r)[0] for r in points})
    items = {language_item(r) for r in points}
    wanted = columns(table)
    swept = (f"<p>{len(points)} points measured, {failed} failed; {len(languages)} "
             f"languages ({html.escape(', '.join(languages))}), {len(items)} items, codecs "
             f"{html.escape(', '.join(sorted({r['codec'] for r in points})))}, Q "
             f"{', '.join(str(q) for q in sorted({r['q'] for r in points}))}.</p>")
    legend = (f"<p>Each cell: median kbps at the matched operating point over the language's items, [first "
              f"quartile-third quartile]; (k/n) when only k of n items reached the threshold. Matched operating "
              f"point: {html.escape(OPERATING_RULE)}. &ldquo;{BEST}&rdquo;: each item's cheapest codec of the "
              f"solution.</p>")
    sections = [swept, legend]
    note = face_note(records)
    if note:
        sections.append(f"<p><b>{html.escape(note)}</b></p>")
    for fps, languages_rows in _grid(table).items():
        header = ["language", *(f"{s}: {c}" for s, c in wanted)]
        rows = [[language, *(cell_text(row.get(c)) for c in wanted)] for language, row in languages_rows.items()]
        sections.append(f"<h2>{fps:g} fps</h2>" + _html_table(header, rows, f"sweep_{fps:g}fps"))
    sections.append(f"<h2>Figure</h2><p>Measured against {MEASURED_AGAINST}; threshold {html.escape(THRESHOLD_TEXT)}."
                    "</p>" + page.image("sweep_kbps", figure_png,
                                        "median kbps at the matched operating point per language and codec"))
    sections.append(_failed_section(records))
    return page.page("signcast sweep", "".join(sections), max_width_px=1200, extra_style="td { text-align: right; }")


def report_outputs(records: list[Record]) -> dict:
    """sweep_table.csv (rows), sweep_kbps.png (bytes) and report.html (text) from the records, by file name; the
    study layer writes them (pipeline.outputs.write_outputs)."""
    records = report_rows(records)
    table = cells(matched_points(records))
    png = figure_png(chart(table) if table else None, empty="no measured point yet")
    return {"sweep_table.csv": table_rows(table), "sweep_kbps.png": png, "report.html": report_html(records, table, png)}

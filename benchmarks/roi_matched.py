"""NSV-ROI against plain H.264 at matched intelligibility (issue 39's last target): `signcast compare`'s own
matching, on the natural clips available here.

Per clip, two compare runs on the same scenario, thresholds and extractions:
1. NSV (MPEG-4 Part 2 and H.264 at constant QP) and NSV-ROI (H.264, CRF, the face and hands at addroi qoffset
   -0.12, the rest +0.12);
2. NSV-ROI with both qoffsets 0: the same x264 in CRF mode with its adaptive quantisation and no regions, the
   control that separates what the regions buy from what CRF mode buys over constant QP.

Printed per threshold: the matched kbps of each (median over the extractions, their range in brackets, * not
reached: the best swept point's rate) and the ratios NSV-ROI / H.264 QP and NSV-ROI / H.264 CRF. Lower frame
rates are not swept (--frame-rates none), and only these series are measured (compare --solutions).

Clips: "carphone" (the bundled 176x144 29.97 fps clip, a head and shoulders with no hands in view) and "avatar"
(the avatar fingerspelling ASL HELLO rendered at 320x240, 25 fps, written with libx264 at CRF 12: both hands and
the face moving in front of a static camera; benchmarks/compare_time.make_clip), or a video file of your own.

    .venv/bin/python benchmarks/roi_matched.py [--clips carphone,avatar,FILE] [--frames N] [--extractions N]
                                               [--out FILE]
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
from dataclasses import replace
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks.compare_time import make_clip  # noqa: E402
from pipeline.studies import compare  # noqa: E402
from pipeline.studies.shared import VideoSweep  # noqa: E402

PLAIN_CRF = (0.0, 0.0)


def settings_for(clip: str, frames: int | None, extractions: int) -> compare.CompareSettings:
    """NSV (MPEG-4, H.264 QP) and NSV-ROI on one clip; no frame-rate sweep, no parameter codecs."""
    return compare.CompareSettings(clip=clip, video=VideoSweep(qs=(4, 12, 31), frame_rates=(),
                                                               other_codecs=("libx264",)),
                                   param_codecs=(), other_solutions=("NSV",), solutions=("NSV", "NSV-ROI"),
                                   max_clip_frames=frames, extractions=extractions)


def matched_rows(settings: compare.CompareSettings, out: Path) -> list[dict]:
    compare.check(settings)
    result = compare.run(settings, out, progress=True)
    return [r for r in result.records if r.get("kind") == "matched"]


def _cell(row: dict | None) -> str:
    if row is None:
        return "–"
    low, high = row.get("kbps_min"), row.get("kbps_max")
    spread = f" ({low:.1f}-{high:.1f})" if low is not None and high is not None and high > low else ""
    return f"{row['kbps']:.1f}{'' if row['reached'] else '*'}{spread}"


def _ratio(a: dict | None, b: dict | None) -> str:
    if a is None or b is None or not (a["reached"] and b["reached"]) or b["kbps"] <= 0:
        return "–"
    return f"{a['kbps'] / b['kbps']:.2f}"


def table(clip: str, regions: list[dict], plain: list[dict]) -> list[str]:
    lines = []
    for threshold in dict.fromkeys(r["threshold_name"] for r in regions):
        def pick(rows, solution, codec):
            return next((r for r in rows if r["threshold_name"] == threshold and r["solution"] == solution
                         and r["codec"] == codec), None)
        mpeg4, qp = pick(regions, "NSV", "mpeg4"), pick(regions, "NSV", "libx264")
        roi, crf = pick(regions, "NSV-ROI", "libx264"), pick(plain, "NSV-ROI", "libx264")
        lines.append(f"| {clip} | {threshold} | {_cell(mpeg4)} | {_cell(qp)} | {_cell(crf)} | {_cell(roi)} "
                     f"| {_ratio(roi, qp)} | {_ratio(roi, crf)} |")
    return lines


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--clips", default="carphone,avatar")
    parser.add_argument("--frames", type=int, default=None, help="only the first N frames of each clip")
    parser.add_argument("--extractions", type=int, default=4)
    parser.add_argument("--out", default=None, help="append the rows as JSON lines to this file")
    args = parser.parse_args()
    lines = ["| clip | threshold | NSV MPEG-4 | NSV H.264 QP | H.264 CRF, no regions | NSV-ROI | ROI / QP | ROI / CRF |",
             "|---|---|---|---|---|---|---|---|"]
    with tempfile.TemporaryDirectory() as folder:
        work = Path(folder)
        for name in compare_names(args.clips):
            clip = str(make_clip(work)) if name == "avatar" else name
            settings = settings_for(clip, args.frames, args.extractions)
            regions = matched_rows(settings, work / f"{name}-regions")
            plain = matched_rows(replace(settings, solutions=("NSV-ROI",), roi_offsets=PLAIN_CRF),
                                 work / f"{name}-plain")
            lines += table(name, regions, plain)
            if args.out:
                with open(args.out, "a") as out:
                    out.write(json.dumps({"clip": name, "regions": regions, "plain_crf": plain}) + "\n")
    print("\n".join(lines))
    return 0


def compare_names(text: str) -> list[str]:
    return [part.strip() for part in text.split(",") if part.strip()]


if __name__ == "__main__":
    sys.exit(main())

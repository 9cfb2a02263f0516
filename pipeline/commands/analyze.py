"""`signcast analyze LANGUAGE [LANGUAGE ...] --out DIR`: statistics of real signing on the avatar (seed 002 ch. 5):
per DOF and per joint group of the language's whole fingerspelled alphabet, as CSV tables, PNG plots and
records.jsonl (one "motion_statistics" record per DOF and per group, after a "run" record with the versions)."""
from __future__ import annotations

import argparse
import math
from pathlib import Path

from media.errors import SigncastError
from pipeline.outputs import add_force_argument, output_folder


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "analyze", help="statistics of the retargeted lexicon per DOF and joint group (seed 002 ch. 5)",
        description="Fingerspell each LANGUAGE's whole alphabet on the avatar and write DIR/records.jsonl and, per "
                    "language, <lang>_dofs.csv, <lang>_groups.csv, <lang>_finger_correlation.csv, "
                    "<lang>_histograms.csv and PNG plots (value and frame-difference distributions, long-term PSD "
                    "per group, finger correlation).")
    parser.add_argument("languages", nargs="+", help="sign language codes, e.g. ase")
    parser.add_argument("--fps", type=float, default=25.0, help="frame rate of the analysed motion (default 25)")
    parser.add_argument("--out", required=True, type=Path, help="output folder")
    add_force_argument(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from comparisons.records import versions, write_records
    from media import lexicon

    if not (math.isfinite(args.fps) and 0 < args.fps <= 60):
        raise SigncastError(f"bad --fps {args.fps}: choose a frame rate in (0, 60]")
    languages = [lexicon.check_language(language) for language in args.languages]
    with output_folder(args.out, force=args.force):
        records = [{"kind": "run", "versions": versions()}]
        for language in languages:
            result = _analyze_language(language, args.fps, args.out)
            clip = f"{language}:alphabet"
            records += [{"kind": "motion_statistics", "level": level, "clip": clip, "fps": result.fps,
                         "frames": result.n_frames, **row}
                        for level, rows in (("dof", result.dof_rows), ("group", result.group_rows)) for row in rows]
        write_records(args.out / "records.jsonl", records)
    print(f"wrote records.jsonl, tables and plots to {args.out}")
    return 0


def _analyze_language(language: str, fps: float, out: Path):
    """Analyse one language's alphabet, write its tables and plots to out, print its group table."""
    from comparisons.lab_codecs import alphabet_motion, dof_layout, motion_dofs
    from comparisons.motion_analysis import analyze, write_analysis

    layout = dof_layout()
    motion = alphabet_motion(language, fps)
    result = analyze(motion_dofs(motion), motion.fps, list(layout.names), layout.groups)
    write_analysis(out, language, result)
    print(f"{language}: {result.n_frames} frames at {result.fps:g} fps, {len(result.dof_rows)} moving DOFs")
    print(f"{'group':>11} {'moving':>6} {'range':>8} {'<1Hz':>6} {'<3Hz':>6} {'<7Hz':>6} {'50dB down':>9}")
    for row in result.group_rows:
        if row["moving_dofs"]:
            print(f"{row['group']:>11} {row['moving_dofs']:>6} {math.degrees(row['mean_range']):7.1f}° "
                  f"{row['share_below_1Hz']:6.2f} {row['share_below_3Hz']:6.2f} {row['share_below_7Hz']:6.2f} "
                  f"{row['freq_50dB_down_Hz']:7.1f}Hz")
    return result

"""Statistics of real signing on the avatar (seed 002 ch. 5): per DOF and per joint group of each language's whole
fingerspelled alphabet. Writes records.jsonl (a "run" record with the versions, then one "motion_statistics" record
per DOF and per group) and, per language, the tables and plots of comparisons.lab.motion_analysis.analysis_outputs (`write_analysis`)."""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from comparisons.lab.codecs import alphabet_motion, dof_layout, motion_dofs
from comparisons.lab.motion_analysis import MotionAnalysis, analysis_outputs, analyze
from comparisons.reports.records import versions
from pipeline.outputs import write_outputs, write_records
from media import lexicon
from media.domain import check_fps
from media.errors import SigncastError


@dataclass(frozen=True)
class AnalyzeSettings:
    """languages: sign language codes; fps: frame rate of the analysed motion, frames per second."""

    languages: tuple[str, ...]
    fps: float = 25.0


def check(settings: AnalyzeSettings) -> None:
    """Refuse bad settings before any work (one-line SigncastError)."""
    check_fps(settings.fps)
    if not settings.languages:
        raise SigncastError("give at least one sign language, e.g. ase")
    for language in settings.languages:
        lexicon.check_language(language)


def write_analysis(out_dir: str | Path, prefix: str, analysis: MotionAnalysis) -> list[Path]:
    """The CSV tables and PNG plots of one analysis written to out_dir; the written paths."""
    return write_outputs(out_dir, analysis_outputs(prefix, analysis))


def run(settings: AnalyzeSettings, out: str | Path) -> tuple[list[dict], dict]:
    """Analyse every language; write records, tables and plots to out. Returns the records and, per language
    code, its analysis (comparisons.lab.motion_analysis)."""
    check(settings)
    out = Path(out)
    layout = dof_layout()
    records, results = [{"kind": "run", "versions": versions()}], {}
    for language in (lexicon.check_language(language) for language in settings.languages):
        motion = alphabet_motion(language, settings.fps)
        result = results[language] = analyze(motion_dofs(motion), motion.fps, list(layout.names), layout.groups)
        write_analysis(out, language, result)
        records += [{"kind": "motion_statistics", "level": level, "clip": f"{language}:alphabet", "fps": result.fps,
                     "frames": result.n_frames, **row}
                    for level, rows in (("dof", result.dof_rows), ("group", result.group_rows)) for row in rows]
    write_records(out / "records.jsonl", records)
    return records, results


def group_table(language: str, result) -> str:
    """The terminal table of one language: each joint group that moves."""
    lines = [f"{language}: {result.n_frames} frames at {result.fps:g} fps, {len(result.dof_rows)} moving DOFs",
             f"{'group':>11} {'moving':>6} {'range':>8} {'<1Hz':>6} {'<3Hz':>6} {'<7Hz':>6} {'50dB down':>9}"]
    for row in result.group_rows:
        if row["moving_dofs"]:
            lines.append(f"{row['group']:>11} {row['moving_dofs']:>6} {math.degrees(row['mean_range']):7.1f}° "
                         f"{row['share_below_1Hz']:6.2f} {row['share_below_3Hz']:6.2f} {row['share_below_7Hz']:6.2f} "
                         f"{row['freq_50dB_down_Hz']:7.1f}Hz")
    return "\n".join(lines)

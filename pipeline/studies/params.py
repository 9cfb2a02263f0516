"""The parameter-transmission study (seed 000 Tables 2.1, 3.1, 3.2): each fingerspelled letter retargeted to the
avatar, coded with each parameter codec at each Q, decoded, and measured (comparisons.params.study.measure_point).

Writes records.jsonl, params_table.csv and params_rate.png in the output folder, and each letter's
full-precision BAPs as a version 3.2 .bap file in bap/ (for other MPEG-4 body animation tools). The body alone
by default, as the source's tables; with `face`, the letters' FAPs too (media.face_parameters): FBA streams carry
them (paramset 3), BBA streams the face bones, each record says what the face adds (face_kbps), and each letter's
FAPs are written as a .fap file in fap/.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from comparisons.params.bap_file import format_bap
from comparisons.params.fap_file import format_fap
from comparisons.params.fba_mapping import motion_to_baps
from comparisons.params.codecs import codec_names, get_codec
from comparisons.params.study import measure_point, rate_figure, table_rows
from comparisons.reports.records import make_record
from pipeline.outputs import save_figure, write_records, write_rows, write_text
from media import lexicon
from media.domain import check_fps, solution_of
from media.errors import SigncastError
from media.fingerspelling import letter_motion
from pipeline.studies.shared import pose_file_kbps

DEFAULT_CODECS = ("fba-pred", "fba-dct", "bba-pred", "bba-dct", "bba-key")
DEFAULT_Q = (1, 2, 4, 8, 16, 31)


@dataclass(frozen=True)
class ParamsSettings:
    """language: sign language code; letters: the letters coded, each separately (e.g. "ABCDEFGHIJ"); codecs:
    parameter codecs; qs: global quantisation values; fps: coding frame rate, frames per second; face: code the
    face's FAPs with the body (else the body alone)."""

    language: str
    letters: str
    codecs: tuple[str, ...] = DEFAULT_CODECS
    qs: tuple[int, ...] = DEFAULT_Q
    fps: float = 10.0
    face: bool = False

    def units(self) -> list[str]:
        return [u for u in lexicon.split_word(self.language, self.letters) if u != " "]


def check(settings: ParamsSettings) -> None:
    """Refuse bad settings before any work (one-line SigncastError)."""
    check_fps(settings.fps)
    if not settings.codecs:
        raise SigncastError(f"no codec given; known: {', '.join(codec_names())}")
    for name in settings.codecs:
        get_codec(name)
    from comparisons.lab.codecs import check_codec_qs
    check_codec_qs(settings.codecs, settings.qs)
    settings.units()


def count_points(settings: ParamsSettings) -> int:
    from comparisons.lab.codecs import codec_qs
    return len(settings.units()) * sum(len(codec_qs(name, settings.qs)) for name in settings.codecs)


def run(settings: ParamsSettings, out: str | Path, *, progress: Callable[[int], object] | None = None) -> list[dict]:
    """Measure every (letter, codec, Q); write the records, the table, the plots and the .bap files to out.
    progress: called with 1 after each point."""
    from comparisons.lab.codecs import codec_qs
    check(settings)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    language, fps = settings.language, settings.fps
    records = []
    for unit in settings.units():
        motion = letter_motion(language, unit, fps)
        if not settings.face or motion.faps is None:
            motion = motion.without_face()
        else:
            write_text(out / "fap" / f"{language}_{unit}.fap", format_fap(motion.faps, fps, f"{language}_{unit}"))
        pose_kbps = pose_file_kbps(language, unit)
        write_text(out / "bap" / f"{language}_{unit}.bap", format_bap(motion_to_baps(motion), fps, f"{language}_{unit}"))
        for name in settings.codecs:
            solution = solution_of(name)
            for q in codec_qs(name, settings.qs):
                point = measure_point(motion, name, q)
                records.append(make_record(solution, f"{language}:{unit}", name, q, fps, 0, 0, point.pop("bits"),
                                           motion.duration_s, pose_kbps=pose_kbps, **point))
                if progress:
                    progress(1)
    write_records(out / "records.jsonl", records)
    write_rows(out / "params_table.csv", table_rows(records, list(settings.codecs), list(settings.qs)))
    save_figure(rate_figure(records, list(settings.codecs)), out / "params_rate.png", dpi=110)
    return records


def main_table(settings: ParamsSettings, records: list[dict]) -> str:
    """kbps (and distortion) per letter and codec at each Q; with the face, what it adds (or that it is not sent)
    and the face bones' error in the head's frame below each row."""
    qs = settings.qs
    lines = [f"{'sign':>5} {'codec':>9} " + " ".join(f"{'Q=' + str(q):>8}" for q in qs) + "   kbps (distortion rad^2)"]
    for unit in settings.units():
        for name in settings.codecs:
            qs = settings.qs
            mine = {r["q"]: r for r in records if r["clip"].endswith(":" + unit) and r["codec"] == name}
            lines.append(f"{unit:>5} {name:>9} " + " ".join(f"{mine[q]['kbps']:8.2f}" if q in mine else f"{'-':>8}"
                                                             for q in qs)
                         + "   (" + " ".join(f"{mine[q]['distortion']:.1e}" for q in qs if q in mine) + ")")
            qs = [q for q in settings.qs if q in mine]        # a seed-002 coder: its operating points only
            if any(mine[q].get("face_kbps") is not None for q in qs):
                lines.append(f"{'':>5} {'of which':>9} " + " ".join(f"{mine[q].get('face_kbps', 0.0):8.2f}" for q in qs)
                             + "   kbps the face adds")
            elif any(mine[q].get("face_sent") is False for q in qs):
                lines.append(f"{'':>5} {'':>9} face not sent: this coder carries the signing joints only, the face "
                             "decodes at rest")
            if any(mine[q].get("face_joint_error_mm") is not None for q in qs):
                lines.append(f"{'':>5} {'face':>9} " + " ".join(f"{mine[q]['face_joint_error_mm']:8.3f}" for q in qs)
                             + "   mm, the face bones' mean error in the head's frame")
    return "\n".join(lines)

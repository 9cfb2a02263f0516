"""The seed-002 study (seed 002 ch. 9) on real signing: for each language the avatar fingerspells its whole
alphabet (comparisons.lab.codecs.alphabet_motion, 25 fps); every seed-002 coder at every operating point and the
MPEG-4 FBA/BBA codecs at a set of Q are measured with comparisons.params.study.measure_point.

Writes in the output folder records.jsonl, lab_points.csv, lab_ranges.csv, lab_waveform_psnr.png and
lab_model_vpsnr.png (the tables and charts are comparisons.reports.lab', made from the records).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from comparisons.reports.lab import charts, operating_ranges, points_rows, ranges_rows
from comparisons.lab.codecs import MODEL_NAMES, WAVEFORM_NAMES, LabCodec, alphabet_motion, check_codec_qs, codec_qs
from comparisons.lab.settings import DEFAULT_CODECS, EVALUATION_LANGUAGES, FPS, MPEG4_Q
from comparisons.params.codecs import get_codec
from comparisons.params.study import measure_point
from comparisons.reports.records import make_record
from pipeline.outputs import write_outputs, write_records
from media import lexicon
from media.domain import solution_of
from media.errors import SigncastError


@dataclass(frozen=True)
class LabSettings:
    """languages: sign language codes; codecs: seed-002 coders and FBA/BBA codecs; mpeg4_q: the Q values of the
    FBA/BBA codecs (a seed-002 coder visits all its own operating points, unless limit_coders: then those of
    mpeg4_q among them, as --param-q means in every command: codec_qs)."""

    languages: tuple[str, ...] = tuple(EVALUATION_LANGUAGES)
    codecs: tuple[str, ...] = DEFAULT_CODECS
    mpeg4_q: tuple[int, ...] = MPEG4_Q
    limit_coders: bool = False


def check(settings: LabSettings) -> None:
    """Refuse bad settings before any work (one-line SigncastError)."""
    if not settings.codecs:
        raise SigncastError("no codec given")
    for name in settings.codecs:
        get_codec(name)
    for language in settings.languages:
        lexicon.check_language(language)
    check_codec_qs(settings.codecs, settings.mpeg4_q if settings.limit_coders else None)


def total_points(settings: LabSettings) -> int:
    limit = settings.mpeg4_q if settings.limit_coders else None
    return len(settings.languages) * sum(len(codec_qs(name, limit if name in WAVEFORM_NAMES + MODEL_NAMES
                                                       else settings.mpeg4_q)) for name in settings.codecs)


def measure_language(language: str, codecs, mpeg4_q=MPEG4_Q, progress: Callable[[int], object] | None = None,
                     coder_q: tuple[int, ...] | None = None) -> list[dict]:
    """Records of every codec and operating point on the language's whole alphabet."""
    motion = alphabet_motion(language, FPS)
    clip = f"{language}:alphabet"
    records = []
    for name in codecs:
        lab = name in WAVEFORM_NAMES + MODEL_NAMES
        qs = codec_qs(name, coder_q) if lab else mpeg4_q
        for q in qs:
            point = measure_point(motion, name, q)
            fields = {"family": "seed002-model" if name in MODEL_NAMES else "seed002-waveform" if lab else "mpeg4"}
            if lab:
                fields["setting"] = str(LabCodec(name).settings()[q - 1])
            records.append(make_record(solution_of(name), clip, name, q, FPS, 0, 0, point.pop("bits"), motion.duration_s,
                                       **fields, **point))
            if progress:
                progress(1)
    return records


def run(settings: LabSettings, out: str | Path, *, progress: Callable[[int], object] | None = None) -> list[dict]:
    """Measure every language, codec and operating point; write the records, tables and charts to out.
    progress: called with 1 after each point."""
    check(settings)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    records = []
    for language in settings.languages:
        records += measure_language(lexicon.check_language(language), settings.codecs, settings.mpeg4_q, progress,
                                    settings.mpeg4_q if settings.limit_coders else None)
    write_records(out / "records.jsonl", records)
    write_outputs(out, {"lab_points.csv": points_rows(records), "lab_ranges.csv": ranges_rows(records),
                        **charts(records)})
    return records


def ranges_table(records: list[dict]) -> str:
    """The terminal table: each codec's operating range per language."""
    lines = [f"{'codec':>9} {'clip':>14} {'kbps':>16} {'PSNR dB':>14} {'VPSNR dB':>14}"]
    for row in operating_ranges(records):
        lines.append(f"{row['codec']:>9} {row['clip']:>14} {row['kbps_min']:7.3f}-{row['kbps_max']:<8.3f} "
                     f"{row['param_psnr_min']:6.1f}-{row['param_psnr_max']:<7.1f} "
                     f"{row['vpsnr_min']:6.1f}-{row['vpsnr_max']:<7.1f}")
    return "\n".join(lines)

"""`signcast lab [LANGUAGE ...] --codec ... --out DIR`: the seed-002 coders (and the MPEG-4 FBA/BBA codecs)
on each language's whole fingerspelled alphabet: records, operating ranges, and the charts of seed 002 ch. 9."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from media.errors import SigncastError
from pipeline.outputs import add_force_argument, output_folder


def add_parser(subparsers) -> None:
    from comparisons.lab_charts import MPEG4_CODECS, MPEG4_Q
    from comparisons.lab_codecs import EVALUATION_LANGUAGES, LAB_CODEC_NAMES

    parser = subparsers.add_parser(
        "lab", help="seed-002 motion coders on whole-alphabet sequences: PSNR/VPSNR vs kbps charts",
        description="Fingerspell each LANGUAGE's whole alphabet on the avatar, code it with every seed-002 coder at "
                    "every operating point and with the MPEG-4 FBA/BBA codecs, decode, and write DIR/records.jsonl, "
                    "DIR/lab_points.csv, DIR/lab_ranges.csv, DIR/lab_waveform_psnr.png, DIR/lab_model_vpsnr.png.")
    parser.add_argument("languages", nargs="*", default=list(EVALUATION_LANGUAGES),
                        help=f"sign language codes (default: {' '.join(EVALUATION_LANGUAGES)}, never used to train "
                             "the coders' tables)")
    parser.add_argument("--codec", default=",".join(LAB_CODEC_NAMES + MPEG4_CODECS), help="comma-separated codecs")
    parser.add_argument("--fba-q", default=",".join(map(str, MPEG4_Q)), help="Q values for the FBA/BBA codecs")
    parser.add_argument("--out", required=True, type=Path, help="output folder")
    add_force_argument(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from tqdm import tqdm

    from comparisons.lab_charts import count_points, operating_ranges, run_lab
    from comparisons.param_codecs import get_codec
    from media import lexicon

    codecs = [c.strip() for c in args.codec.split(",") if c.strip()]
    if not codecs:
        raise SigncastError("no codec given")
    for name in codecs:
        get_codec(name)
    try:
        fba_q = [int(v) for v in args.fba_q.split(",") if v.strip()]
    except ValueError:
        raise SigncastError(f"bad --fba-q {args.fba_q!r}: give comma-separated integers in 1..31") from None
    if not fba_q or any(not 1 <= q <= 31 for q in fba_q):
        raise SigncastError(f"bad --fba-q {args.fba_q!r}: every Q must lie in 1..31")
    languages = [lexicon.check_language(language) for language in args.languages]
    total = len(languages) * count_points(codecs, fba_q)
    with output_folder(args.out, force=args.force), tqdm(total=total, desc="lab", unit="point", file=sys.stderr) as bar:
        records = run_lab(args.out, languages, codecs, fba_q, progress=bar.update)
    print(f"{'codec':>9} {'clip':>14} {'kbps':>16} {'PSNR dB':>14} {'VPSNR dB':>14}")
    for row in operating_ranges(records):
        print(f"{row['codec']:>9} {row['clip']:>14} {row['kbps_min']:7.3f}-{row['kbps_max']:<8.3f} "
              f"{row['psnr_min']:6.1f}-{row['psnr_max']:<7.1f} {row['vpsnr_min']:6.1f}-{row['vpsnr_max']:<7.1f}")
    print(f"wrote {args.out / 'records.jsonl'}, lab_points.csv, lab_ranges.csv, lab_waveform_psnr.png, lab_model_vpsnr.png")
    return 0

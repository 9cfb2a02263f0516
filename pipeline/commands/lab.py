"""`signcast lab [LANGUAGES] --codecs ... --param-q ... --out DIR`: the seed-002 coders (and the MPEG-4 FBA/BBA
codecs) on each language's whole fingerspelled alphabet: records, operating ranges, and the charts of seed 002
ch. 9 (the study is pipeline.studies.lab)."""
from __future__ import annotations

import argparse
import sys

from pipeline.commands import options
from pipeline.outputs import output_folder


def add_parser(subparsers) -> None:
    from comparisons.lab.settings import DEFAULT_CODECS, EVALUATION_LANGUAGES, MPEG4_Q

    parser = subparsers.add_parser(
        "lab", help="seed-002 motion coders on whole-alphabet sequences: PSNR/VPSNR vs kbps charts",
        description="Fingerspell each LANGUAGE's whole alphabet on the avatar, code it with every seed-002 coder at "
                    "every operating point and with the MPEG-4 FBA/BBA codecs, decode, and write DIR/records.jsonl, "
                    "DIR/lab_points.csv, DIR/lab_ranges.csv, DIR/lab_waveform_psnr.png, DIR/lab_model_vpsnr.png.")
    parser.add_argument("languages", nargs="?", default=",".join(EVALUATION_LANGUAGES),
                        help=f"sign language codes, comma-separated (default: {','.join(EVALUATION_LANGUAGES)}, never "
                             "used to train the coders' tables)")
    options.add_codecs(parser, ",".join(DEFAULT_CODECS))
    parser.add_argument("--param-q", default=None,
                        help=f"quantisation values 1..31, comma-separated, as in every command: FBA/BBA's Q, and a "
                             f"seed-002 coder's operating points 1..N among them (default: {','.join(map(str, MPEG4_Q))} "
                             f"for FBA/BBA, every operating point of a seed-002 coder)")
    options.add_out(parser)
    options.add_no_progress(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    return execute(args.languages, args.codecs, args.param_q, args.out, args.force, progress=not args.no_progress)


def execute(languages: str, codecs: str | None, param_q: str | None, out, force: bool, progress: bool = True) -> int:
    """The lab study (also `params --alphabet`); None takes the lab's default codecs or Q."""
    from tqdm import tqdm

    from pipeline.studies import lab
    settings = lab.LabSettings(options.names(languages), options.names(codecs) if codecs is not None else lab.DEFAULT_CODECS,
                               options.parse_qs(param_q, "--param-q") if param_q is not None else lab.MPEG4_Q,
                               limit_coders=param_q is not None)
    lab.check(settings)
    with output_folder(out, force=force) as partial, \
            tqdm(total=lab.total_points(settings), desc="lab", unit="point", file=sys.stderr,
                 disable=not progress) as bar:
        records = lab.run(settings, partial, progress=bar.update)
    print(lab.ranges_table(records))
    print(f"wrote {out / 'records.jsonl'}, lab_points.csv, lab_ranges.csv, lab_waveform_psnr.png, lab_model_vpsnr.png")
    return 0

"""`signcast params LANGUAGE LETTERS --codecs fba-pred,... --param-q 1,2,4,8,16,31 --fps 10 --out DIR`: code each
fingerspelled letter as MPEG-4 FBA/BBA animation parameters and measure rate and distortion (seed 000 Tables 2.1,
3.1, 3.2; the study is pipeline.studies.params). With --alphabet: whole alphabets, as `signcast lab`."""
from __future__ import annotations

import argparse
import sys

from media.errors import SigncastError
from pipeline.commands import options
from pipeline.outputs import output_folder


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "params", help="code fingerspelled letters as MPEG-4 FBA/BBA parameters; rate and distortion",
        description="For each letter of LETTERS (e.g. ABCDEFGHIJ) of sign language LANGUAGE, retarget the real "
                    "lexicon clip to the avatar, code it with each parameter codec at each Q, decode it, and "
                    "write DIR/records.jsonl, DIR/params_table.csv and DIR/params_rate.png.")
    parser.add_argument("language", help="sign language code, e.g. ase (with --alphabet: comma-separated codes)")
    parser.add_argument("letters", nargs="?", help="letters to code, each separately, e.g. ABCDEFGHIJ")
    parser.add_argument("--alphabet", action="store_true",
                        help="code each language's whole alphabet fingerspelled in order with every codec (seed-002 "
                             "coders and FBA/BBA) and draw the charts of seed 002 ch. 9 (PSNR and VPSNR vs kbps); "
                             "same as `signcast lab` (its default codecs and Q)")
    parser.add_argument("--codecs", default=None, help=f"parameter codecs, comma-separated (default {options.PARAM_CODECS})")
    parser.add_argument("--param-q", default=None,
                        help=f"global quantisation values 1..31, comma-separated (default {options.PARAM_Q})")
    parser.add_argument("--fps", type=float, default=10.0, help="coding frame rate (default 10, as seed 000 §2.4.2)")
    parser.add_argument("--face", action="store_true",
                        help="code the signer's face too (MPEG-4 FAPs; BBA: the face bones) and report what it adds; "
                             "default: the body alone, as the source's Tables 2.1 and 3.1")
    options.add_out(parser)
    options.add_no_progress(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if args.alphabet:
        from pipeline.commands import lab
        return lab.execute(args.language, args.codecs, args.param_q, args.out, args.force,
                           progress=not args.no_progress)
    if not args.letters:
        raise SigncastError("give the LETTERS to code (e.g. ABCDEFGHIJ), or --alphabet for whole alphabets")
    from tqdm import tqdm

    from pipeline.studies import params
    settings = params.ParamsSettings(args.language, args.letters, options.names(args.codecs or options.PARAM_CODECS),
                                     options.parse_qs(args.param_q or options.PARAM_Q, "--param-q"), args.fps,
                                     args.face)
    params.check(settings)
    with output_folder(args.out, force=args.force) as out, \
            tqdm(total=params.count_points(settings), desc="params", unit="point", file=sys.stderr,
                 disable=args.no_progress) as bar:
        records = params.run(settings, out, progress=bar.update)
    print(params.main_table(settings, records))
    print(f"wrote {args.out / 'records.jsonl'}, {args.out / 'params_table.csv'}, {args.out / 'params_rate.png'}")
    return 0

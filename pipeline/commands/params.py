"""`signcast params LANGUAGE LETTERS --codec fba-pred,... --q 1,2,4,8,16,31 --fps 10 --out DIR`:
code each fingerspelled letter as MPEG-4 FBA/BBA animation parameters and measure rate and distortion
(seed 000 Tables 2.1, 3.1, 3.2)."""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from media.errors import SigncastError
from pipeline.outputs import add_force_argument, output_folder

DEFAULT_CODECS = "fba-pred,fba-dct,bba-pred,bba-dct,bba-key"
DEFAULT_Q = "1,2,4,8,16,31"


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
                             "same as `signcast lab`")
    parser.add_argument("--codec", default=DEFAULT_CODECS, help=f"comma-separated codecs (default {DEFAULT_CODECS})")
    parser.add_argument("--q", default=DEFAULT_Q, help=f"comma-separated global quantisation values 1..31 (default {DEFAULT_Q})")
    parser.add_argument("--fps", type=float, default=10.0, help="coding frame rate (default 10, as seed 000 §2.4.2)")
    parser.add_argument("--out", required=True, type=Path, help="output folder")
    add_force_argument(parser)
    parser.set_defaults(func=run)


def _q_values(text: str) -> list[int]:
    try:
        values = [int(part) for part in text.split(",") if part.strip()]
    except ValueError:
        raise SigncastError(f"bad --q {text!r}: give comma-separated integers in 1..31") from None
    if not values or any(not 1 <= q <= 31 for q in values):
        raise SigncastError(f"bad --q {text!r}: every Q must lie in 1..31")
    return values


def run(args: argparse.Namespace) -> int:
    if args.alphabet:
        return _run_alphabet(args)
    if not args.letters:
        raise SigncastError("give the LETTERS to code (e.g. ABCDEFGHIJ), or --alphabet for whole alphabets")
    from comparisons.param_codecs import codec_names, get_codec
    from comparisons.param_study import run_study
    from media import lexicon

    if not (math.isfinite(args.fps) and 0 < args.fps <= 60):
        raise SigncastError(f"bad --fps {args.fps}: choose a frame rate in (0, 60], e.g. 10, 15, 20 or 25")
    codecs = [c.strip() for c in args.codec.split(",") if c.strip()]
    if not codecs:
        raise SigncastError(f"no codec given; known: {', '.join(codec_names())}")
    for name in codecs:
        get_codec(name)
    qs = _q_values(args.q)
    units = [u for u in lexicon.split_word(args.language, args.letters) if u != " "]
    from tqdm import tqdm

    with output_folder(args.out, force=args.force), \
            tqdm(total=len(units) * len(codecs) * len(qs), desc="params", unit="point", file=sys.stderr) as bar:
        records = run_study(args.language, units, codecs, qs, args.fps, args.out, progress=bar.update)
    print(f"{'sign':>5} {'codec':>9} " + " ".join(f"{'Q=' + str(q):>8}" for q in qs) + "   kbps (distortion rad^2)")
    for unit in units:
        for name in codecs:
            mine = {r["q"]: r for r in records if r["clip"].endswith(":" + unit) and r["codec"] == name}
            print(f"{unit:>5} {name:>9} " + " ".join(f"{mine[q]['kbps']:8.2f}" for q in qs)
                  + "   (" + " ".join(f"{mine[q]['distortion']:.1e}" for q in qs) + ")")
    print(f"wrote {args.out / 'records.jsonl'}, {args.out / 'params_table.csv'}, {args.out / 'params_rate.png'}")
    return 0


def _run_alphabet(args: argparse.Namespace) -> int:
    """Whole alphabets: the seed-002 charts, through the lab command (its codecs and FBA/BBA Q defaults)."""
    from comparisons.lab_charts import MPEG4_CODECS, MPEG4_Q
    from comparisons.lab_codecs import LAB_CODEC_NAMES
    from pipeline.commands import lab

    codecs = args.codec if args.codec != DEFAULT_CODECS else ",".join(LAB_CODEC_NAMES + MPEG4_CODECS)
    fba_q = args.q if args.q != DEFAULT_Q else ",".join(map(str, MPEG4_Q))
    languages = [language.strip() for language in args.language.split(",") if language.strip()]
    return lab.run(argparse.Namespace(languages=languages, codec=codecs, fba_q=fba_q, out=args.out,
                                      force=args.force))

"""`signcast sweep --languages ase,gsg --items A,B,C --codecs fba-pred,bba-dct --q 4,16 --fps 25 --executor local|ray
--out DIR`: languages x items x codecs x Q x fps of parameter transmission on a local process pool or on Ray,
resumable (the study is pipeline.studies.sweep; the report comparisons.reports.sweep)."""
from __future__ import annotations

import argparse
import sys

from media.errors import SigncastError
from pipeline.commands import options

DEFAULT_Q = "1,4,16,31"
DEFAULT_FRAME_RATES = "10,25"


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "sweep", help="whole-lexicon parameter-codec study on a process pool or Ray, resumable",
        description="Measure every point of languages x items x codecs x Q x fps (each item retargeted to the "
                    "avatar once, coded and decoded with each codec at each Q) on a local process "
                    "pool or on Ray. Records stream into DIR/records.jsonl; run the same command again to resume "
                    "an interrupted sweep (finished points are skipped; records of other points already in DIR stay, "
                    "so a sweep can be extended) and --force to start over. Writes DIR/report.html, "
                    "DIR/sweep_table.csv and DIR/sweep_kbps.png.")
    parser.add_argument("--languages", required=True,
                        help="sign language codes, comma-separated (e.g. ase,gsg), or 'all' for every language")
    parser.add_argument("--items", default=None,
                        help="letters or words, comma-separated (default: every letter of each language); a word "
                             "is fingerspelled from the language's letters")
    options.add_codecs(parser)
    parser.add_argument("--q", "--param-q", dest="q", default=DEFAULT_Q,
                        help=f"quantisation values 1..31, comma-separated (default {DEFAULT_Q})")
    parser.add_argument("--fps", "--frame-rates", dest="fps", default=DEFAULT_FRAME_RATES,
                        help=f"coding frame rates, comma-separated (default {DEFAULT_FRAME_RATES})")
    parser.add_argument("--executor", default="local",
                        help="local (a process pool on this machine, the default) or ray")
    parser.add_argument("--workers", default=None,
                        help="worker processes (local) or Ray CPUs (default: every CPU of this machine)")
    parser.add_argument("--address", default=None,
                        help="with --executor ray: the Ray cluster to join (default: start Ray on this machine); "
                             "every node needs signcast installed")
    parser.add_argument("--skip-failed", action="store_true",
                        help="on resuming, leave points recorded as failed alone (default: retry them)")
    parser.add_argument("--max-units", default=None,
                        help="stop after N work units (an item with all its frame rates, codecs and Q); run again "
                             "to continue")
    options.add_out(parser)
    options.add_no_progress(parser)
    parser.set_defaults(func=run)


def _count(text: str | None, option: str) -> int | None:
    if text is None:
        return None
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise SigncastError(f"bad {option} {text!r}: give a whole number, at least 1")
    return value


def settings_from(args: argparse.Namespace):
    from media import lexicon
    from pipeline.studies import sweep
    languages = options.names(args.languages)
    if [name.lower() for name in languages] == ["all"]:
        languages = tuple(lexicon.languages())
    return sweep.SweepSettings(
        languages=languages, items=None if args.items is None else options.names(args.items),
        codecs=options.names(args.codecs), qs=options.parse_qs(args.q, "--q"),
        frame_rates=options.parse_floats(args.fps, "--fps"), executor=args.executor.strip().lower(),
        workers=_count(args.workers, "--workers"), address=args.address, skip_failed=args.skip_failed)


def run(args: argparse.Namespace) -> int:
    from tqdm import tqdm

    from comparisons.reports import sweep as sweep_report
    from pipeline.studies import sweep
    settings = settings_from(args)
    max_units = _count(args.max_units, "--max-units")
    sweep.check(settings)
    last = {}
    with tqdm(desc="sweep", unit="point", file=sys.stderr, disable=args.no_progress, dynamic_ncols=True,
              delay=0.5) as bar:
        def progress(state: sweep.SweepState) -> None:
            if bar.total != state.total:           # the first call: points finished earlier do not count in the rate
                bar.reset(total=state.total)
                bar.initial = bar.n = state.skipped
            bar.update(state.finished - bar.n)
            bar.set_postfix_str(f"running {state.running}, failed {state.failed}"
                                + (", stopping after the running units (Ctrl-C again: now)" if state.stopping else ""))
            last["state"] = state

        try:
            result = sweep.run(settings, args.out, force=args.force, progress=progress, max_units=max_units)
        except KeyboardInterrupt:
            bar.close()
            state = last.get("state")
            done = f"{state.finished} of {state.total} points finished" if state else "stopped"
            print(f"signcast sweep: interrupted: {done}, kept in {args.out / sweep.RECORDS}; run the same command "
                  f"again to resume", file=sys.stderr)
            return 130
    state = result.state
    print(sweep_report.summary_text(sweep_report.cells(sweep_report.matched_points(result.records))))
    note = sweep_report.face_note(result.records)
    if note:
        print(note)
    left = state.total - state.finished
    print(f"{state.done} points measured, {state.failed} failed, {state.skipped} finished earlier"
          + (f", {left} left (run again to continue)" if left else "") + f"; {result.wall_s:.1f} s")
    print(f"wrote {args.out / sweep.RECORDS}, {args.out / 'report.html'}, {args.out / 'sweep_table.csv'}, "
          f"{args.out / 'sweep_kbps.png'}")
    return 0

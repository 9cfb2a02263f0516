"""The command-line convention, in one place: every list is comma-separated (`--video-q 2,12,31`), every frame size
is `--size WxH`, and one thing has one option name in every command:

--video-q        MPEG-4 video quantisers (video, compare)
--video-codecs   today's video codecs coded at matched quality, or none (video, compare)
--param-q        FBA/BBA (and motion coder) quantisation values (params, lab, compare)
--codecs         parameter codecs: FBA/BBA and the seed-002 motion coders (params, lab, compare)
--fps            the one frame rate a command codes, renders or analyses at; --frame-rates: the rates a sweep visits
--size WxH       the rendered signer's size; --max-size WxH: the size a natural clip is scaled down to fit
--out DIR        the output folder (--force: reuse a non-empty one); --no-progress hides progress bars

Options are read as text and turned into values by the parse_* functions, which raise SigncastError (one line,
exit code 2) on bad input.
"""
from __future__ import annotations

import argparse
import math
from pathlib import Path

from media.errors import SigncastError
from pipeline.outputs import add_force_argument

PARAM_CODECS = "fba-pred,fba-dct,bba-pred,bba-dct,bba-key"
PARAM_Q = "1,2,4,8,16,31"
VIDEO_Q = "2,6,12,24,31"
VIDEO_CODECS = "libx264,libsvtav1"


def names(text: str) -> tuple[str, ...]:
    """'a, b,c' -> ('a', 'b', 'c')."""
    return tuple(part.strip() for part in str(text).split(",") if part.strip())


def parse_floats(text: str, option: str) -> tuple[float, ...]:
    """'25,15,10' -> (25.0, 15.0, 10.0); anything else raises SigncastError."""
    try:
        values = tuple(float(part) for part in names(text))
    except ValueError:
        values = ()
    if not values or not all(math.isfinite(v) for v in values):
        raise SigncastError(f"bad {option} {text!r}: give comma-separated numbers, e.g. 25,15,10")
    return values


def parse_qs(text: str, option: str) -> tuple[int, ...]:
    from media.domain import parse_qs as parse
    return tuple(parse(text, option))


def parse_video_codecs(text: str, option: str = "--video-codecs") -> tuple[str, ...]:
    from pipeline.checks import video_codecs
    return video_codecs(names(text), option)


def parse_max_size(text: str) -> tuple[int, int] | None:
    """--max-size: (width, height) in pixels, or None for 'none'. An upper limit: any size from the smallest frame
    (MIN_SIDE) up is accepted, odd or beyond the largest frame (a clip that fits is kept as it is)."""
    from media.domain import MIN_SIDE, SIZES
    key = str(text).strip().lower()
    if key == "none":
        return None
    if key in SIZES:
        return SIZES[key]
    try:
        width, height = (int(part) for part in key.split("x"))
    except ValueError:
        raise SigncastError(f"bad --max-size {text!r}: write WIDTHxHEIGHT, e.g. 352x288, or none") from None
    if min(width, height) < MIN_SIDE:
        raise SigncastError(f"bad --max-size {text!r}: width and height must be at least {MIN_SIDE} pixels")
    return width, height


def add_out(parser: argparse.ArgumentParser, default: Path | None = None) -> None:
    if default is None:
        parser.add_argument("--out", required=True, type=Path, help="output folder")
    else:
        parser.add_argument("--out", type=Path, default=default, help=f"output folder (default ./{default})")
    add_force_argument(parser)


def add_no_progress(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--no-progress", action="store_true", help="hide progress bars")


def add_codecs(parser: argparse.ArgumentParser, default: str = PARAM_CODECS) -> None:
    parser.add_argument("--codecs", default=default, help=f"parameter codecs, comma-separated (default {default})")


def add_param_q(parser: argparse.ArgumentParser, default: str = PARAM_Q) -> None:
    parser.add_argument("--param-q", default=default,
                        help=f"parameter quantisation values 1..31, comma-separated (default {default})")


def add_video_q(parser: argparse.ArgumentParser, default: str = VIDEO_Q, rule: str = "") -> None:
    parser.add_argument("--video-q", default=default,
                        help=f"MPEG-4 quantisers, comma-separated{'; ' + rule if rule else ''} (default {default})")


def add_video_codecs(parser: argparse.ArgumentParser, default: str = VIDEO_CODECS) -> None:
    parser.add_argument("--video-codecs", default=default,
                        help=f"today's video codecs coded at matched quality, comma-separated (default {default}; "
                             "none for none)")


def add_size(parser: argparse.ArgumentParser, default: str, what: str = "rendered signer size") -> None:
    parser.add_argument("--size", default=default, metavar="WxH", help=f"{what} WxH (default {default})")


def add_max_size(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--max-size", default="352x288", metavar="WxH",
                        help="scale a larger natural video down to fit WxH, aspect kept (default 352x288, CIF; "
                             "none keeps the size)")

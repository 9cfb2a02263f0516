"""The MPEG-4 body animation text file (.bap), read in versions 3.1 and 3.2, written in 3.2.

Layout (mpeg4-facts.md §2.7, after visage `FBAEncoder.cpp`; VREng `bap.hpp` for the counts):
lines starting with `#` are comments; a header line `<version> <name> <frame rate> <frames>`;
then per frame a mask line of 186 (3.1) or 296 (3.2) 0/1 flags and a line with the frame number
followed by the values of the masked BAPs, in id order. Values are integers (1e-5 rad; mm for
181..183). A BAP left out of a frame's mask keeps its previous value (0 before it is first set).

The format has no checksum: a damaged digit, or a 0 and a 1 swapped in a mask, can decode to other
values without any sign. The reader rejects what it can see: values outside each BAP's legal range
(comparisons/bap_table.py: rotations within +-pi, translations within +-100 m), frame rates outside
media/text_files.py's range, frame numbers out of sequence, a frame count that disagrees with the
frames present, and more than media/text_files.MAX_VALUES values (checked before allocating).
"""
from __future__ import annotations

import re
import reprlib
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from comparisons import bap_table
from media import text_files
from media.errors import SigncastError

VERSION_COUNTS = {"3.1": bap_table.N_STANDARD_BAPS, "3.2": bap_table.N_BAPS}
_LOW = np.array([b.range[0] for b in bap_table.BAPS], dtype=np.int64)     # (296,) BAP units, index = id - 1
_HIGH = np.array([b.range[1] for b in bap_table.BAPS], dtype=np.int64)
_INTEGER = re.compile(r"[+-]?[0-9]{1,18}")                                  # fits int64 before the range check


def format_bap(values: np.ndarray, fps: float, name: str = "signcast") -> str:
    """Text of a version 3.2 .bap file for (T, 296) integer BAP values."""
    values = np.asarray(values)
    if values.ndim != 2 or values.shape[1] != bap_table.N_BAPS:
        raise SigncastError(f"BAP values must be (T, {bap_table.N_BAPS}), got {values.shape}")
    if not name or any(c.isspace() for c in name):
        raise SigncastError(f"a .bap animation name must be one word, got {name!r}")
    fps_text = str(int(fps)) if float(fps).is_integer() else f"{fps:g}"
    lines = ["# MPEG-4 body animation parameters written by signcast", f"3.2 {name} {fps_text} {len(values)}"]
    previous = np.zeros(bap_table.N_BAPS, dtype=np.int64)
    for t, row in enumerate(values.astype(np.int64)):
        mask = (row != previous) | (t == 0) & (row != 0)
        lines.append(" ".join("1" if m else "0" for m in mask))
        lines.append(" ".join([str(t)] + [str(v) for v in row[mask]]))
        previous = row
    return "\n".join(lines) + "\n"


def write_bap(path: str | Path, values: np.ndarray, fps: float, name: str = "signcast") -> Path:
    path = Path(path)
    path.write_text(format_bap(values, fps, name))
    return path


def parse_bap(text: str) -> tuple[np.ndarray, float, str]:
    """(values (T, 296) int64 BAP units, fps, name) from .bap text of version 3.1 or 3.2."""
    return _parse(text.splitlines())


def read_bap(path: str | Path) -> tuple[np.ndarray, float, str]:
    """(values (T, 296) int64 BAP units, fps, name) from a .bap file of version 3.1 or 3.2."""
    return _parse(text_files.read_lines(path, ".bap file"))


def _parse(lines: Iterable[str]) -> tuple[np.ndarray, float, str]:
    numbered = ((n, line.split()) for n, line in enumerate(lines, start=1))
    content = ((n, tokens) for n, tokens in numbered if tokens and not tokens[0].startswith("#"))
    n, header = next(content, (0, None))
    if header is None:
        raise SigncastError(".bap file is empty")
    if len(header) != 4 or header[0] not in VERSION_COUNTS:
        raise SigncastError(f".bap line {n}: expected '<version 3.1|3.2> <name> <fps> <frames>', "
                            f"got {reprlib.repr(' '.join(header))}")
    count = VERSION_COUNTS[header[0]]
    try:
        fps = float(header[2])
    except ValueError:
        raise SigncastError(f".bap line {n}: bad frame rate {reprlib.repr(header[2])}") from None
    if not header[3].isascii() or not header[3].isdigit() or len(header[3]) > 18:
        raise SigncastError(f".bap line {n}: bad frame count {reprlib.repr(header[3])}")
    n_frames = int(header[3])
    text_files.check_fps(fps, f".bap line {n}")
    text_files.check_size(n_frames, bap_table.N_BAPS, f".bap line {n}")
    values = np.zeros((n_frames, bap_table.N_BAPS), dtype=np.int64)
    current = np.zeros(bap_table.N_BAPS, dtype=np.int64)
    first_frame = None
    for t in range(n_frames):
        mask_line, mask_tokens = next(content, (0, None))
        value_line, value_tokens = next(content, (0, None))
        if value_tokens is None:
            raise SigncastError(f".bap file announces {n_frames} frames but holds {t} (truncated)")
        if len(mask_tokens) != count or any(tok not in ("0", "1") for tok in mask_tokens):
            raise SigncastError(f".bap line {mask_line}: expected {count} mask flags 0/1")
        mask = np.array([tok == "1" for tok in mask_tokens])
        if not all(_INTEGER.fullmatch(tok) for tok in value_tokens):
            raise SigncastError(f".bap line {value_line}: values must be integers of at most 18 digits")
        numbers = np.array([int(tok) for tok in value_tokens], dtype=np.int64)
        if len(numbers) != 1 + int(mask.sum()):
            raise SigncastError(f".bap line {value_line}: {int(mask.sum())} masked BAPs but {len(numbers) - 1} values")
        first_frame = int(numbers[0]) if first_frame is None else first_frame
        if int(numbers[0]) != first_frame + t:
            raise SigncastError(f".bap line {value_line}: frame number {numbers[0]}, expected {first_frame + t}")
        ids = np.flatnonzero(mask)
        outside = (numbers[1:] < _LOW[ids]) | (numbers[1:] > _HIGH[ids])
        if outside.any():
            bap = int(ids[np.argmax(outside)])
            raise SigncastError(f".bap line {value_line}: BAP {bap + 1} = {numbers[1:][np.argmax(outside)]} is outside "
                                f"its range {_LOW[bap]}..{_HIGH[bap]}")
        current[ids] = numbers[1:]
        values[t] = current
    if next(content, None) is not None:
        raise SigncastError(f".bap file announces {n_frames} frames but holds more (padded)")
    return values, fps, header[1]

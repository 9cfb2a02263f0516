"""The MPEG-4 face animation text file (.fap), version 2.1: writer and reader.

Layout (the FAP twin of the .bap file, comparisons/bap_file.py; mpeg4-facts.md §2.7, visage
`FBAEncoder.cpp`): lines starting with `#` are comments; a header line `2.1 <name> <frame rate>
<frames>`; then per frame a mask line of 68 0/1 flags (FAP ids 1..68) and a line with the frame
number followed by the values of the masked FAPs, in id order. Values are integers in FAP units
(1/1024 of the face's FAPU, or 1e-5 rad). A FAP left out of a frame's mask keeps its previous
value (0 before it is first set).

FAPs 1 (viseme) and 2 (expression) are high-level FAPs whose values are structures, not one
number; signcast neither writes nor reads them: they are 0 and always masked out, and a file that
masks them in is refused.

The format has no checksum: a damaged digit, or a 0 and a 1 swapped in a mask, can decode to other
values without any sign. The reader rejects what it can see: values outside each FAP's range
(comparisons/fap_table.limits()), frame rates outside media/text_files.py's range, frame numbers
out of sequence, a frame count that disagrees with the frames present, and more than
media/text_files.MAX_VALUES values (checked before allocating).
"""
from __future__ import annotations

import re
import reprlib
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from comparisons import fap_table
from media import text_files
from media.errors import SigncastError

VERSION = "2.1"
HIGH_LEVEL = 2                                                          # FAPs 1..2 are never sent
_LIMITS = fap_table.limits()                                            # (68,) FAP units, index = id - 1
_INTEGER = re.compile(r"[+-]?[0-9]{1,18}")                              # fits int64 before the range check


def format_fap(faps: np.ndarray, fps: float, name: str = "signcast") -> str:
    """Text of a version 2.1 .fap file for (T, 68) integer FAP values (FAPs 1 and 2 must be 0)."""
    faps = np.asarray(faps)
    if faps.ndim != 2 or faps.shape[1] != fap_table.N_FAPS or not np.issubdtype(faps.dtype, np.integer):
        raise SigncastError(f"FAP values must be (T, {fap_table.N_FAPS}) integers, got {faps.shape} {faps.dtype}")
    if not name or any(c.isspace() for c in name):
        raise SigncastError(f"a .fap animation name must be one word, got {name!r}")
    if np.any(faps[:, :HIGH_LEVEL]):
        raise SigncastError("FAPs 1 (viseme) and 2 (expression) are not written: they must be 0")
    outside = np.abs(faps) > _LIMITS
    if outside.any():
        t, index = np.argwhere(outside)[0]
        raise SigncastError(f"FAP {index + 1} = {faps[t, index]} at frame {t} is outside its range "
                            f"{-_LIMITS[index]}..{_LIMITS[index]}")
    fps_text = str(int(fps)) if float(fps).is_integer() else f"{fps:g}"
    lines = ["# MPEG-4 face animation parameters written by signcast", f"{VERSION} {name} {fps_text} {len(faps)}"]
    previous = np.zeros(fap_table.N_FAPS, dtype=np.int64)
    for t, row in enumerate(faps.astype(np.int64)):
        mask = (row != previous) | (t == 0) & (row != 0)
        lines.append(" ".join("1" if m else "0" for m in mask))
        lines.append(" ".join([str(t)] + [str(v) for v in row[mask]]))
        previous = row
    return "\n".join(lines) + "\n"


def write_fap(path: str | Path, faps: np.ndarray, fps: float, name: str = "signcast") -> Path:
    path = Path(path)
    path.write_text(format_fap(faps, fps, name))
    return path


def parse_fap(text: str) -> tuple[np.ndarray, float, str]:
    """(FAP values (T, 68) int64 FAP units, fps, name) from .fap text of version 2.1."""
    return _parse(text.splitlines())


def read_fap(path: str | Path) -> tuple[np.ndarray, float, str]:
    """(FAP values (T, 68) int64 FAP units, fps, name) from a .fap file of version 2.1."""
    return _parse(text_files.read_lines(path, ".fap file"))


def _parse(lines: Iterable[str]) -> tuple[np.ndarray, float, str]:
    numbered = ((n, line.split()) for n, line in enumerate(lines, start=1))
    content = ((n, tokens) for n, tokens in numbered if tokens and not tokens[0].startswith("#"))
    n, header = next(content, (0, None))
    if header is None:
        raise SigncastError(".fap file is empty")
    if len(header) != 4 or header[0] != VERSION:
        raise SigncastError(f".fap line {n}: expected '{VERSION} <name> <fps> <frames>', "
                            f"got {reprlib.repr(' '.join(header))}")
    try:
        fps = float(header[2])
    except ValueError:
        raise SigncastError(f".fap line {n}: bad frame rate {reprlib.repr(header[2])}") from None
    if not header[3].isascii() or not header[3].isdigit() or len(header[3]) > 18:
        raise SigncastError(f".fap line {n}: bad frame count {reprlib.repr(header[3])}")
    n_frames = int(header[3])
    text_files.check_fps(fps, f".fap line {n}")
    text_files.check_size(n_frames, fap_table.N_FAPS, f".fap line {n}")
    faps = np.zeros((n_frames, fap_table.N_FAPS), dtype=np.int64)
    current = np.zeros(fap_table.N_FAPS, dtype=np.int64)
    first_frame = None
    for t in range(n_frames):
        mask_line, mask_tokens = next(content, (0, None))
        value_line, value_tokens = next(content, (0, None))
        if value_tokens is None:
            raise SigncastError(f".fap file announces {n_frames} frames but holds {t} (truncated)")
        if len(mask_tokens) != fap_table.N_FAPS or any(tok not in ("0", "1") for tok in mask_tokens):
            raise SigncastError(f".fap line {mask_line}: expected {fap_table.N_FAPS} mask flags 0/1")
        mask = np.array([tok == "1" for tok in mask_tokens])
        if mask[:HIGH_LEVEL].any():
            raise SigncastError(f".fap line {mask_line}: FAPs 1 (viseme) and 2 (expression) are not supported")
        if not all(_INTEGER.fullmatch(tok) for tok in value_tokens):
            raise SigncastError(f".fap line {value_line}: values must be integers of at most 18 digits")
        numbers = np.array([int(tok) for tok in value_tokens], dtype=np.int64)
        if len(numbers) != 1 + int(mask.sum()):
            raise SigncastError(f".fap line {value_line}: {int(mask.sum())} masked FAPs but {len(numbers) - 1} values")
        first_frame = int(numbers[0]) if first_frame is None else first_frame
        if int(numbers[0]) != first_frame + t:
            raise SigncastError(f".fap line {value_line}: frame number {numbers[0]}, expected {first_frame + t}")
        ids = np.flatnonzero(mask)
        outside = np.abs(numbers[1:]) > _LIMITS[ids]
        if outside.any():
            index = int(ids[np.argmax(outside)])
            raise SigncastError(f".fap line {value_line}: FAP {index + 1} = {numbers[1:][np.argmax(outside)]} is "
                                f"outside its range {-_LIMITS[index]}..{_LIMITS[index]}")
        current[ids] = numbers[1:]
        faps[t] = current
    if next(content, None) is not None:
        raise SigncastError(f".fap file announces {n_frames} frames but holds more (padded)")
    return faps, fps, header[1]

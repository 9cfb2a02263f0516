"""The layout the MPEG-4 animation text files share (.bap for the body, .fap for the face): writer and reader.

Lines starting with `#` are comments; a header line `<version> <name> <frame rate> <frames>`; then per frame a
mask line of N 0/1 flags (parameter ids 1..N) and a line with the frame number followed by the values of the
masked parameters, in id order. A parameter left out of a frame's mask keeps its previous value (0 before it is
first set). The writer masks in what changed (and, on the first frame, what is not 0).

The format has no checksum; the reader rejects what it can see: a bad header, frame rates outside
media/text_files.py's range, more than media/text_files.MAX_VALUES values (checked before allocating), masks of
the wrong length, values outside each parameter's range, frame numbers out of sequence, and a frame count that
disagrees with the frames present. Every refusal is one SigncastError line naming the file kind and line.
"""
from __future__ import annotations

import re
import reprlib
from collections.abc import Callable, Iterable
from dataclasses import dataclass

import numpy as np

from media import text_files
from media.errors import SigncastError

_INTEGER = re.compile(r"[+-]?[0-9]{1,18}")                                  # fits int64 before the range check


@dataclass(frozen=True)
class TextLayout:
    """One file kind: kind ('.bap', '.fap'), unit ('BAP', 'FAP'), versions (version -> mask length), the
    version written, n_values (parameters per frame in memory), low and high ((n_values,) int64 legal range),
    comment (the writer's first line), check_mask (called with the mask line's number and its (N,) bool mask;
    raises to refuse it)."""
    kind: str
    unit: str
    versions: dict[str, int]
    written_version: str
    n_values: int
    low: np.ndarray
    high: np.ndarray
    comment: str
    check_mask: Callable[[int, np.ndarray], None] | None = None


def format_text(layout: TextLayout, values: np.ndarray, fps: float, name: str) -> str:
    """Text of a file of `layout` for (T, n_values) integer values (checked against the layout's range)."""
    values = np.asarray(values)
    if values.ndim != 2 or values.shape[1] != layout.n_values or not np.issubdtype(values.dtype, np.integer):
        raise SigncastError(f"{layout.unit} values must be (T, {layout.n_values}) integers, got {values.shape} "
                            f"{values.dtype}")
    if not name or any(c.isspace() for c in name):
        raise SigncastError(f"a {layout.kind} animation name must be one word, got {name!r}")
    outside = (values < layout.low) | (values > layout.high)
    if outside.any():
        t, index = np.argwhere(outside)[0]
        raise SigncastError(f"{layout.unit} {index + 1} = {values[t, index]} at frame {t} is outside its range "
                            f"{layout.low[index]}..{layout.high[index]}")
    fps_text = str(int(fps)) if float(fps).is_integer() else f"{fps:g}"
    lines = [layout.comment, f"{layout.written_version} {name} {fps_text} {len(values)}"]
    previous = np.zeros(layout.n_values, dtype=np.int64)
    for t, row in enumerate(values.astype(np.int64)):
        mask = (row != previous) | (t == 0) & (row != 0)
        lines.append(" ".join("1" if m else "0" for m in mask))
        lines.append(" ".join([str(t)] + [str(v) for v in row[mask]]))
        previous = row
    return "\n".join(lines) + "\n"


def parse_text(layout: TextLayout, lines: Iterable[str]) -> tuple[np.ndarray, float, str]:
    """(values (T, n_values) int64, fps, name) of the lines of a file of `layout`."""
    kind, unit = layout.kind, layout.unit
    numbered = ((n, line.split()) for n, line in enumerate(lines, start=1))
    content = ((n, tokens) for n, tokens in numbered if tokens and not tokens[0].startswith("#"))
    n, header = next(content, (0, None))
    if header is None:
        raise SigncastError(f"{kind} file is empty")
    if len(header) != 4 or header[0] not in layout.versions:
        raise SigncastError(f"{kind} line {n}: expected '<version {'|'.join(layout.versions)}> <name> <fps> <frames>', "
                            f"got {reprlib.repr(' '.join(header))}")
    count = layout.versions[header[0]]
    try:
        fps = float(header[2])
    except ValueError:
        raise SigncastError(f"{kind} line {n}: bad frame rate {reprlib.repr(header[2])}") from None
    if not header[3].isascii() or not header[3].isdigit() or len(header[3]) > 18:
        raise SigncastError(f"{kind} line {n}: bad frame count {reprlib.repr(header[3])}")
    n_frames = int(header[3])
    text_files.check_fps(fps, f"{kind} line {n}")
    text_files.check_size(n_frames, layout.n_values, f"{kind} line {n}")
    values = np.zeros((n_frames, layout.n_values), dtype=np.int64)
    current = np.zeros(layout.n_values, dtype=np.int64)
    first_frame = None
    for t in range(n_frames):
        mask_line, mask_tokens = next(content, (0, None))
        value_line, value_tokens = next(content, (0, None))
        if value_tokens is None:
            raise SigncastError(f"{kind} file announces {n_frames} frames but holds {t} (truncated)")
        if len(mask_tokens) != count or any(tok not in ("0", "1") for tok in mask_tokens):
            raise SigncastError(f"{kind} line {mask_line}: expected {count} mask flags 0/1")
        mask = np.array([tok == "1" for tok in mask_tokens])
        if layout.check_mask is not None:
            layout.check_mask(mask_line, mask)
        if not all(_INTEGER.fullmatch(tok) for tok in value_tokens):
            raise SigncastError(f"{kind} line {value_line}: values must be integers of at most 18 digits")
        numbers = np.array([int(tok) for tok in value_tokens], dtype=np.int64)
        if len(numbers) != 1 + int(mask.sum()):
            raise SigncastError(f"{kind} line {value_line}: {int(mask.sum())} masked {unit}s but {len(numbers) - 1} values")
        first_frame = int(numbers[0]) if first_frame is None else first_frame
        if int(numbers[0]) != first_frame + t:
            raise SigncastError(f"{kind} line {value_line}: frame number {numbers[0]}, expected {first_frame + t}")
        ids = np.flatnonzero(mask)
        outside = (numbers[1:] < layout.low[ids]) | (numbers[1:] > layout.high[ids])
        if outside.any():
            index = int(ids[np.argmax(outside)])
            raise SigncastError(f"{kind} line {value_line}: {unit} {index + 1} = {numbers[1:][np.argmax(outside)]} is "
                                f"outside its range {layout.low[index]}..{layout.high[index]}")
        current[ids] = numbers[1:]
        values[t] = current
    if next(content, None) is not None:
        raise SigncastError(f"{kind} file announces {n_frames} frames but holds more (padded)")
    return values, fps, header[1]

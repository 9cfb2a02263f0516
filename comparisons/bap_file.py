"""The MPEG-4 body animation text file (.bap), read in versions 3.1 and 3.2, written in 3.2.

Layout (mpeg4-facts.md §2.7, after visage `FBAEncoder.cpp`; VREng `bap.hpp` for the counts):
lines starting with `#` are comments; a header line `<version> <name> <frame rate> <frames>`;
then per frame a mask line of 186 (3.1) or 296 (3.2) 0/1 flags and a line with the frame number
followed by the values of the masked BAPs, in id order. Values are integers (1e-5 rad; mm for
181..183). A BAP left out of a frame's mask keeps its previous value (0 before it is first set).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from comparisons import bap_table
from media.errors import SigncastError

VERSION_COUNTS = {"3.1": bap_table.N_STANDARD_BAPS, "3.2": bap_table.N_BAPS}


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
    """(values (T, 296) int64, fps, name) from .bap text of version 3.1 or 3.2."""
    lines = [(n, line.split()) for n, line in enumerate(text.splitlines(), start=1)
             if line.strip() and not line.lstrip().startswith("#")]
    if not lines:
        raise SigncastError(".bap file is empty")
    n, header = lines[0]
    if len(header) != 4 or header[0] not in VERSION_COUNTS:
        raise SigncastError(f".bap line {n}: expected '<version 3.1|3.2> <name> <fps> <frames>', got {' '.join(header)!r}")
    count = VERSION_COUNTS[header[0]]
    try:
        fps, n_frames = float(header[2]), int(header[3])
    except ValueError:
        raise SigncastError(f".bap line {n}: bad frame rate or frame count") from None
    if not (fps > 0 and n_frames >= 0):
        raise SigncastError(f".bap line {n}: frame rate must be positive and frame count non-negative")
    body = lines[1:]
    if len(body) != 2 * n_frames:
        raise SigncastError(f".bap file announces {n_frames} frames but holds {len(body) // 2} (truncated or padded)")
    values = np.zeros((n_frames, bap_table.N_BAPS), dtype=np.int64)
    current = np.zeros(bap_table.N_BAPS, dtype=np.int64)
    for t in range(n_frames):
        (mask_line, mask_tokens), (value_line, value_tokens) = body[2 * t], body[2 * t + 1]
        if len(mask_tokens) != count or any(tok not in ("0", "1") for tok in mask_tokens):
            raise SigncastError(f".bap line {mask_line}: expected {count} mask flags 0/1")
        mask = np.array([tok == "1" for tok in mask_tokens])
        try:
            numbers = [int(tok) for tok in value_tokens]
        except ValueError:
            raise SigncastError(f".bap line {value_line}: values must be integers") from None
        if len(numbers) != 1 + int(mask.sum()):
            raise SigncastError(f".bap line {value_line}: {int(mask.sum())} masked BAPs but {len(numbers) - 1} values")
        current[:count][mask] = numbers[1:]
        values[t] = current
    return values, fps, header[1]


def read_bap(path: str | Path) -> tuple[np.ndarray, float, str]:
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as error:
        raise SigncastError(f"cannot read .bap file {path}: {error.strerror}") from None
    return parse_bap(text)

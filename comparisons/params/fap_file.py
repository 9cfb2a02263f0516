"""The MPEG-4 face animation text file (.fap), version 2.1: writer and reader.

Layout (the FAP twin of the .bap file, comparisons/params/bap_file.py; mpeg4-facts.md §2.7, visage
`FBAEncoder.cpp`): lines starting with `#` are comments; a header line `2.1 <name> <frame rate>
<frames>`; then per frame a mask line of 68 0/1 flags (FAP ids 1..68) and a line with the frame
number followed by the values of the masked FAPs, in id order. Values are integers in FAP units
(1/1024 of the face's FAPU, or 1e-5 rad). A FAP left out of a frame's mask keeps its previous
value (0 before it is first set).

FAPs 1 (viseme) and 2 (expression) are high-level FAPs whose values are structures, not one
number; signcast neither writes nor reads them: they are 0 and always masked out, and a file that
masks them in is refused.

The format has no checksum: a damaged digit, or a 0 and a 1 swapped in a mask, can decode to other
values without any sign. The reader (comparisons/params/text.py, shared with .bap files) rejects what it can
see: values outside each FAP's range
(comparisons/fap_table.limits()), frame rates outside media/text_files.py's range, frame numbers
out of sequence, a frame count that disagrees with the frames present, and more than
media/text_files.MAX_VALUES values (checked before allocating).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from comparisons.params import fap_table
from comparisons.params.text import TextLayout, format_text, parse_text
from media import text_files
from media.errors import SigncastError

VERSION = "2.1"
HIGH_LEVEL = 2                                                          # FAPs 1..2 are never sent


def _refuse_high_level(line: int, mask: np.ndarray) -> None:
    if mask[:HIGH_LEVEL].any():
        raise SigncastError(f".fap line {line}: FAPs 1 (viseme) and 2 (expression) are not supported")


_LIMITS = fap_table.limits()                                            # (68,) FAP units, index = id - 1
LAYOUT = TextLayout(kind=".fap", unit="FAP", versions={VERSION: fap_table.N_FAPS}, written_version=VERSION,
                    n_values=fap_table.N_FAPS, low=-_LIMITS, high=_LIMITS,
                    comment="# MPEG-4 face animation parameters written by signcast", check_mask=_refuse_high_level)


def format_fap(faps: np.ndarray, fps: float, name: str = "signcast") -> str:
    """Text of a version 2.1 .fap file for (T, 68) integer FAP values (FAPs 1 and 2 must be 0)."""
    faps = np.asarray(faps)
    if faps.ndim == 2 and faps.shape[1] == fap_table.N_FAPS and np.any(faps[:, :HIGH_LEVEL]):
        raise SigncastError("FAPs 1 (viseme) and 2 (expression) are not written: they must be 0")
    return format_text(LAYOUT, faps, fps, name)


def parse_fap(text: str) -> tuple[np.ndarray, float, str]:
    """(FAP values (T, 68) int64 FAP units, fps, name) from .fap text of version 2.1."""
    return parse_text(LAYOUT, text.splitlines())


def read_fap(path: str | Path) -> tuple[np.ndarray, float, str]:
    """(FAP values (T, 68) int64 FAP units, fps, name) from a .fap file of version 2.1."""
    return parse_text(LAYOUT, text_files.read_lines(path, ".fap file"))

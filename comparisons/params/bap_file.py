"""The MPEG-4 body animation text file (.bap), read in versions 3.1 and 3.2, written in 3.2.

Layout (mpeg4-facts.md §2.7, after visage `FBAEncoder.cpp`; VREng `bap.hpp` for the counts):
lines starting with `#` are comments; a header line `<version> <name> <frame rate> <frames>`;
then per frame a mask line of 186 (3.1) or 296 (3.2) 0/1 flags and a line with the frame number
followed by the values of the masked BAPs, in id order. Values are integers (1e-5 rad; mm for
181..183). A BAP left out of a frame's mask keeps its previous value (0 before it is first set).

The format has no checksum: a damaged digit, or a 0 and a 1 swapped in a mask, can decode to other
values without any sign. The reader (comparisons/params/text.py, shared with .fap files) rejects what it can
see: values outside each BAP's legal range (comparisons/params/bap_table.py: rotations within +-pi, translations within
+-100 m), frame rates outside media/text_files.py's range, frame numbers out of sequence, a frame count that
disagrees with the frames present, and more than media/text_files.MAX_VALUES values (checked before allocating).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from comparisons.params import bap_table
from comparisons.params.text import TextLayout, format_text, parse_text
from media import text_files

VERSION_COUNTS = {"3.1": bap_table.N_STANDARD_BAPS, "3.2": bap_table.N_BAPS}
LAYOUT = TextLayout(
    kind=".bap", unit="BAP", versions=VERSION_COUNTS, written_version="3.2", n_values=bap_table.N_BAPS,
    low=np.array([b.range[0] for b in bap_table.BAPS], dtype=np.int64),      # (296,) BAP units, index = id - 1
    high=np.array([b.range[1] for b in bap_table.BAPS], dtype=np.int64),
    comment="# MPEG-4 body animation parameters written by signcast")


def format_bap(values: np.ndarray, fps: float, name: str = "signcast") -> str:
    """Text of a version 3.2 .bap file for (T, 296) integer BAP values."""
    return format_text(LAYOUT, values, fps, name)


def parse_bap(text: str) -> tuple[np.ndarray, float, str]:
    """(values (T, 296) int64 BAP units, fps, name) from .bap text of version 3.1 or 3.2."""
    return parse_text(LAYOUT, text.splitlines())


def read_bap(path: str | Path) -> tuple[np.ndarray, float, str]:
    """(values (T, 296) int64 BAP units, fps, name) from a .bap file of version 3.1 or 3.2."""
    return parse_text(LAYOUT, text_files.read_lines(path, ".bap file"))

"""Reading text files that users hand to signcast (.bvh, .bap, records.jsonl): limits and decoding.

Files are read line by line as UTF-8 (a leading byte-order mark is skipped), so memory follows what
is decoded, not the file size. What a reader accepts, checked before it allocates:
- MAX_VALUES numbers decoded from one file (frames x values per frame; 256 MB as float64 or int64):
  72 minutes of all 296 BAPs at 25 fps, or 18 minutes at 25 fps of the avatar's 163-joint BVH
  (492 channels and 163 quaternions of 4 values per frame);
- lines of at most MAX_LINE_CHARS characters;
- frame rates from MIN_FPS to MAX_FPS frames per second.
"""
from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path

from media.errors import SigncastError

MAX_VALUES = 32_000_000
MAX_LINE_CHARS = 1 << 20
MIN_FPS, MAX_FPS = 1.0, 1000.0


def read_lines(path: str | Path, what: str) -> Iterator[str]:
    """The lines of the text file at path, newline included; `what` names the file in error messages."""
    path = Path(path)
    try:
        with path.open(encoding="utf-8-sig") as handle:
            while line := handle.readline(MAX_LINE_CHARS + 1):
                if len(line) > MAX_LINE_CHARS:
                    raise SigncastError(f"{what} {path} has a line longer than {MAX_LINE_CHARS} characters")
                yield line
    except UnicodeDecodeError:
        raise SigncastError(f"{what} {path} is not UTF-8 text") from None
    except OSError as error:
        raise SigncastError(f"cannot read {what} {path}: {error.strerror or error}") from None


def check_size(n_frames: int, values_per_frame: int, what: str) -> None:
    """Refuse to decode n_frames x values_per_frame numbers when that exceeds MAX_VALUES."""
    if n_frames * values_per_frame > MAX_VALUES:
        raise SigncastError(f"{what}: {n_frames} frames of {values_per_frame} values exceed what signcast reads "
                            f"(at most {MAX_VALUES} values)")


def check_fps(fps: float, what: str) -> None:
    """Refuse a frame rate (frames per second) outside MIN_FPS..MAX_FPS, NaN included."""
    if not (math.isfinite(fps) and MIN_FPS <= fps <= MAX_FPS):
        raise SigncastError(f"{what}: frame rate {fps:g} fps is outside {MIN_FPS:g}..{MAX_FPS:g} fps")

"""Checks the commands run on their arguments before the work: a memory estimate and video codec names.

Every command that takes a frame size (`render`, `video --ssv`, `compare`, `demo`) parses it with
media.domain.parse_size and, once it knows the frame count, calls check_memory with the bytes per pixel it will hold.
"""
from __future__ import annotations

import os

from media.errors import SigncastError

MEMORY_LIMIT_VARIABLE = "SIGNCAST_MEMORY_LIMIT_MB"
NO_CODECS = ("none", "")


def memory_limit_bytes() -> int:
    """The memory a command may plan to hold, bytes: $SIGNCAST_MEMORY_LIMIT_MB if set, else the memory the
    system has available now (MemAvailable on Linux, free physical pages elsewhere)."""
    configured = os.environ.get(MEMORY_LIMIT_VARIABLE)
    if configured:
        try:
            return int(float(configured) * 2**20)
        except ValueError:
            raise SigncastError(f"bad {MEMORY_LIMIT_VARIABLE}={configured!r}: give a number of MiB") from None
    try:
        with open("/proc/meminfo", encoding="ascii") as meminfo:
            for line in meminfo:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")


def check_memory(n_frames: int, width: int, height: int, bytes_per_pixel: float, what: str,
                 advice: str = "choose a smaller --size or a shorter word") -> int:
    """Refuse work that would hold n_frames x width x height x bytes_per_pixel bytes of frames (and labels)
    beyond memory_limit_bytes(), with `advice` on what to change. Returns the estimate in bytes."""
    estimate = int(n_frames * width * height * bytes_per_pixel)
    limit = memory_limit_bytes()
    if estimate > limit:
        raise SigncastError(f"{what} would hold about {estimate / 2**30:.2f} GiB ({n_frames} frames of "
                            f"{width}x{height} at {bytes_per_pixel:g} bytes per pixel), more than the limit of "
                            f"{limit / 2**30:.2f} GiB (available memory, or ${MEMORY_LIMIT_VARIABLE}): {advice}")
    return estimate


def video_codecs(names, option: str) -> tuple[str, ...]:
    """Today's codecs coded at matched quality ('none' or '' for none), checked against comparisons.video.codecs."""
    from comparisons.video.codecs import CODECS

    chosen = tuple(name for name in names if name.strip().lower() not in NO_CODECS)
    known = [name for name in CODECS if name != "mpeg4"]
    for name in chosen:
        if name not in known:
            raise SigncastError(f"bad {option} {name!r}: choose from {', '.join(known)}, or none")
    return chosen

"""Result records: one JSON object per measured point, written one per line to records.jsonl.

Every record carries solution, clip, codec, q, fps, width, height, bits, duration_s and kbps (kilobits
per second, 1 kbit = 1000 bits), plus an open set of further fields: quality (psnr, ssim, psnr_skin,
ssim_skin, ...), areas, sweep labels. `kind` is "point" for a measured point; a "run" record carries
the software versions and the backend.
"""
from __future__ import annotations

import json
import math
import platform
from importlib import metadata
from pathlib import Path

import numpy as np

from media.errors import SigncastError

REQUIRED_FIELDS = ("solution", "clip", "codec", "q", "fps", "width", "height", "bits", "duration_s", "kbps")
_VERSIONED = ("signcast", "numpy", "av", "opencv-contrib-python-headless", "scikit-image", "warp-lang")


def make_record(solution: str, clip: str, codec: str, q: float | None, fps: float, width: int, height: int,
                bits: int, duration_s: float, **fields) -> dict:
    """A measured point; kbps = bits / duration_s / 1000. Extra fields (quality, areas, ...) are kept as given."""
    if duration_s <= 0:
        raise SigncastError(f"a record needs a positive duration, got {duration_s}")
    record = {"kind": "point", "solution": solution, "clip": clip, "codec": codec, "q": q, "fps": float(fps),
              "width": int(width), "height": int(height), "bits": int(bits), "duration_s": float(duration_s),
              "kbps": bits / duration_s / 1000.0}
    record.update(fields)
    return record


def versions() -> dict[str, str]:
    """Versions of Python, FFmpeg (through PyAV) and the packages the measurements depend on."""
    found = {"python": platform.python_version()}
    for name in _VERSIONED:
        try:
            found[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            continue
    try:
        import av
        found["ffmpeg"] = ".".join(str(part) for part in av.library_versions.get("libavcodec", ()))
    except (ImportError, AttributeError):
        pass
    return found


def _plain(value):
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def write_records(path: str | Path, records: list[dict]) -> Path:
    """Write records as JSON lines (NaN and infinities become null); returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", encoding="utf-8") as handle:
        for record in records:
            handle.write(json.dumps(_plain(record), sort_keys=False) + "\n")
    return path


def read_records(path: str | Path) -> list[dict]:
    """Read records.jsonl back; a malformed line raises SigncastError naming the line."""
    path = Path(path)
    if not path.is_file():
        raise SigncastError(f"records file not found: {path}")
    records = []
    with path.open(encoding="utf-8") as handle:
        for number, line in enumerate(handle, 1):
            if not line.strip():
                continue
            try:
                record = json.loads(line)
            except json.JSONDecodeError as error:
                raise SigncastError(f"{path}:{number}: not a JSON record ({error.msg})") from None
            if not isinstance(record, dict):
                raise SigncastError(f"{path}:{number}: a record must be a JSON object")
            records.append(record)
    return records

"""Result records: one JSON object per measured point, written one per line to records.jsonl.

Every record carries solution, clip, codec, q, fps, width, height, bits, duration_s and kbps (kilobits
per second, 1 kbit = 1000 bits), plus an open set of further fields: quality (psnr, ssim, psnr_skin,
ssim_skin, ...), areas, sweep labels. `kind` is "point" for a measured point; a "run" record carries
the software versions and the backend.

Reading checks each line before anything uses it, and names the line when it rejects one:
- a line is a JSON object of at most media/text_files.MAX_LINE_CHARS characters, in UTF-8;
- numbers anywhere are finite (NaN is read as null, as write_records writes it);
- the fields the report reads have their types: STRING_FIELDS strings, NUMBER_FIELDS numbers or null,
  CONTAINER_FIELDS objects or lists; point and stage records carry the fields in NEEDED;
- a file holds at most MAX_RECORD_VALUES JSON values (a record holds 10 to 140), checked as it is read,
  which keeps the decoded records within a few hundred MB.
"""
from __future__ import annotations

import json
import math
import platform
import reprlib
from importlib import metadata
from pathlib import Path

import numpy as np

from media import text_files
from media.errors import SigncastError

REQUIRED_FIELDS = ("solution", "clip", "codec", "q", "fps", "width", "height", "bits", "duration_s", "kbps")
STRING_FIELDS = ("kind", "solution", "clip", "codec", "sweep", "stage", "setting", "operating_rule")
NUMBER_FIELDS = ("q", "fps", "width", "height", "bits", "duration_s", "kbps", "psnr", "psnr_skin", "psnr_object", "ssim",
                 "ssim_skin", "ssim_object", "vpsnr", "joint_error_mm_mean", "joint_error_mm_max", "wall_s")
CONTAINER_FIELDS = {"versions": dict, "objects": list}
NEEDED = {"point": ("solution", "fps"), "stage": ("stage", "wall_s")}
MAX_RECORD_VALUES = 2_000_000
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


def write_records(path: str | Path, records: list[dict], *, append: bool = False) -> Path:
    """Write records as JSON lines (NaN and infinities become null); returns the path.

    append: add them to the end of the file (closed, so flushed, on return: an interrupted run keeps them)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("a" if append else "w", encoding="utf-8") as handle:
        for record in records:
            handle.write(json.dumps(_plain(record), sort_keys=False) + "\n")
    return path


def read_records(path: str | Path) -> list[dict]:
    """Read records.jsonl back; a malformed line raises SigncastError naming the line (see the module's checks)."""
    path = Path(path)
    if not path.is_file():
        raise SigncastError(f"records file not found: {path}")
    records, n_values = [], 0
    for number, line in enumerate(text_files.read_lines(path, "records file"), 1):
        if not line.strip():
            continue
        try:
            record = json.loads(line, parse_constant=_nan_as_null)
        except (ValueError, RecursionError) as error:   # ValueError: bad JSON, or an integer past Python's digit limit
            raise SigncastError(f"{path}:{number}: not a JSON record ({getattr(error, 'msg', error)})") from None
        if not isinstance(record, dict):
            raise SigncastError(f"{path}:{number}: a record must be a JSON object")
        values = list(_values(record))
        problem = _problem(record, values)
        if problem:
            raise SigncastError(f"{path}:{number}: {problem}")
        n_values += 1 + len(values)
        if n_values > MAX_RECORD_VALUES:
            raise SigncastError(f"{path}:{number}: more than {MAX_RECORD_VALUES} values in one records file")
        records.append(record)
    return records


def _nan_as_null(constant: str) -> float | None:
    """NaN means not measured, as null does (write_records writes it so); Infinity stays, to be rejected."""
    return None if constant == "NaN" else float(constant)


def _is_number(value) -> bool:
    """A finite int or float (not a bool)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return False
    try:
        return math.isfinite(value)
    except OverflowError:                                # an int too large for a float
        return False


def _values(record: dict):
    """(top-level field, value) for every JSON value inside record, nested ones included."""
    stack = list(record.items())
    while stack:
        field, value = stack.pop()
        yield field, value
        if isinstance(value, dict):
            stack.extend((field, v) for v in value.values())
        elif isinstance(value, list):
            stack.extend((field, v) for v in value)


def _problem(record: dict, values: list[tuple[str, object]]) -> str | None:
    """What is wrong with one record's field types, or None; values: _values(record)."""
    for field in STRING_FIELDS:
        if field in record and not isinstance(record[field], str):
            return f"field {field!r} must be a string, got {reprlib.repr(record[field])}"
    for field in NEEDED.get(record.get("kind", "point"), ()):
        if record.get(field) is None:
            return f"a {record.get('kind', 'point')} record needs field {field!r}"
    for field in NUMBER_FIELDS:
        if record.get(field) is not None and not _is_number(record[field]):
            return f"field {field!r} must be a finite number, got {reprlib.repr(record[field])}"
    for field, kind in CONTAINER_FIELDS.items():
        if field in record and not isinstance(record[field], kind):
            return f"field {field!r} must be {'an object' if kind is dict else 'a list'}, got {reprlib.repr(record[field])}"
    for field, value in values:
        if isinstance(value, (int, float)) and not isinstance(value, bool) and not _is_number(value):
            return f"field {field!r} holds {reprlib.repr(value)}, not a finite number"
    return None

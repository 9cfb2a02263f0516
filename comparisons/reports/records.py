"""Result records: one typed Record per measured point (or run, stage, ...), one JSON object a line in records.jsonl.

A Record has a kind ("point" for a measured point; "run" carries the software versions and the backend, "stage"
a stage's wall time, and other kinds their own fields), the point fields solution, clip, codec, q, fps, width,
height, bits, duration_s and kbps (kilobits per second, 1 kbit = 1000 bits), and named quality fields that
keep the two kinds of quality apart:
- image quality, for points with a picture (width and height > 0), luma dB against the point's reference frames:
  image_psnr / ssim (whole frame), skin_psnr / skin_ssim (face and hands), object_psnr / object_ssim (inside the
  sent objects);
- parameter quality, for points without a picture (width = height = 0): param_psnr (parameter domain, seed 000
  eq. 2.6), vpsnr, joint_error_mm_mean / joint_error_mm_max and group_errors (per joint group: mean, max); for a
  motion with a face, face_sent (in extra: false for a codec that carries the signing joints only, whose face
  decodes at rest), face_kbps (what the FAPs add over the body alone), fap_error (mean |error|, FAP units) and
  face_joint_error_mm / face_joint_error_mm_max / face_joint_error_mm_p90 (the face bones' tails in the head's
  frame, mm: the face's own movement, which the joint errors over the whole body hide behind the head's pose; p90:
  the 90th percentile over frames of each frame's worst face point);
- transport, for points delivered live (TRANSPORT_FIELDS: loss, delivered rate with headers, concealed frames,
  latency);
Any other field (areas, sweep labels, flags, ...) is kept as given in Record.extra.

Every written line carries "schema": SCHEMA_VERSION. A line without "schema" is a legacy record (signcast
before schema 2, or a producer not yet moved to the new names) and is renamed on reading: psnr becomes
image_psnr on a point with a picture and param_psnr on a point without one (width = height = 0); psnr_skin,
psnr_object, ssim_skin, ssim_object become skin_psnr, object_psnr, skin_ssim, object_ssim. A legacy psnr that
cannot be placed (no width and height, or not on a point) is rejected; a null one is dropped.

Reading checks each line before anything uses it, and names the line when it rejects one:
- a line is a JSON object of at most media/text_files.MAX_LINE_CHARS characters, in UTF-8;
- "schema", where present, is SCHEMA_VERSION, and a schema line carries none of the legacy names;
- numbers anywhere are finite (NaN is read as null, as records_text writes it);
- the fields the report reads have their types: STRING_FIELDS strings or null, NUMBER_FIELDS numbers or null,
  CONTAINER_FIELDS objects or lists; point and stage records carry the fields in NEEDED;
- a file holds at most MAX_RECORD_VALUES JSON values (a record holds 10 to 140), checked as it is read,
  which keeps the decoded records within a few hundred MB.
Fields that are null, other than a point's own fields, are left out when a record is written.
"""
from __future__ import annotations

import dataclasses
import json
import math
import platform
import reprlib
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path

import numpy as np

from media.domain import kbps
from media import text_files
from media.errors import SigncastError

SCHEMA_VERSION = 2
REQUIRED_FIELDS = ("solution", "clip", "codec", "q", "fps", "width", "height", "bits", "duration_s", "kbps")
IMAGE_QUALITY_FIELDS = ("image_psnr", "skin_psnr", "object_psnr", "ssim", "skin_ssim", "object_ssim")
PARAM_QUALITY_FIELDS = ("param_psnr", "vpsnr", "joint_error_mm_mean", "joint_error_mm_max", "face_kbps", "fap_error",
                        "face_joint_error_mm", "face_joint_error_mm_max", "face_joint_error_mm_p90", "group_errors")
# what a viewer can read: landmarks extracted from what the viewer sees against the reference's landmarks
INTELLIGIBILITY_FIELDS = ("hand_error", "hand_error_p90", "hand_pck_10", "hand_pck_20", "left_hand_found",
                          "right_hand_found", "face_error", "face_error_p90", "mouth_error", "eyes_error", "letter_top1", "letter_top3",
                          "hand_joint_error_mm", "arm_joint_error_mm")
# live delivery (pipeline/live): the network's configured loss, what was measured at the receiver, and latency
TRANSPORT_FIELDS = ("loss_rate", "packet_loss", "delivered_kbps", "overhead_kbps", "frames_lost", "frames_concealed",
                    "latency_ms_p50", "latency_ms_p95")
# legacy name -> schema 2 name; "psnr" depends on the point (see _legacy)
LEGACY_NAMES = {"psnr_skin": "skin_psnr", "psnr_object": "object_psnr", "ssim_skin": "skin_ssim",
                "ssim_object": "object_ssim"}
STRING_FIELDS = ("kind", "solution", "clip", "codec", "sweep", "stage", "setting", "operating_rule", "backend",
                 "reference")
NUMBER_FIELDS = ("q", "fps", "width", "height", "bits", "duration_s", "kbps", *IMAGE_QUALITY_FIELDS,
                 *PARAM_QUALITY_FIELDS[:-1], *INTELLIGIBILITY_FIELDS, *TRANSPORT_FIELDS, "wall_s", "psnr", *LEGACY_NAMES)
CONTAINER_FIELDS = {"versions": dict, "objects": list, "group_errors": dict}
NULLABLE = ("group_errors",)                         # the other container fields, where present, are never null
NEEDED = {"point": ("solution", "fps"), "stage": ("stage", "wall_s")}
MAX_RECORD_VALUES = 2_000_000
_VERSIONED = ("signcast", "numpy", "av", "opencv-contrib-python-headless", "scikit-image", "warp-lang")


@dataclass(frozen=True)
class Record:
    """One record of records.jsonl (see the module's description of the fields)."""
    kind: str = "point"
    solution: str | None = None
    clip: str | None = None
    codec: str | None = None
    q: float | None = None
    fps: float | None = None
    width: int | None = None
    height: int | None = None
    bits: int | None = None
    duration_s: float | None = None
    kbps: float | None = None              # bits / duration_s / 1000
    sweep: str | None = None
    setting: str | None = None
    operating_rule: str | None = None
    # image quality (points with a picture), dB / SSIM against the point's reference frames
    image_psnr: float | None = None
    skin_psnr: float | None = None
    object_psnr: float | None = None
    ssim: float | None = None
    skin_ssim: float | None = None
    object_ssim: float | None = None
    # parameter quality (points without a picture), against the motion before coding; never mixed with image_psnr
    param_psnr: float | None = None        # parameter-domain dB (seed 000 eq. 2.6)
    vpsnr: float | None = None
    joint_error_mm_mean: float | None = None
    joint_error_mm_max: float | None = None
    face_kbps: float | None = None         # kbit/s the face adds over the same body coded alone
    fap_error: float | None = None         # mean |decoded - original| of the moving FAPs, FAP units
    face_joint_error_mm: float | None = None       # face bones' tails in the head's frame: mean error, mm
    face_joint_error_mm_max: float | None = None   # and the largest
    face_joint_error_mm_p90: float | None = None   # 90th percentile over frames of each frame's worst face point
    group_errors: dict | None = None       # joint group -> [mean, max] weighted error
    # intelligibility (comparisons.judging.intelligibility), against `reference`: "source video" (message fidelity) or
    # "lossless render" (codec loss of an avatar solution); errors per frame, then mean (and 90th percentile)
    reference: str | None = None
    hand_error: float | None = None        # hand keypoint error in hand sizes
    hand_error_p90: float | None = None
    hand_pck_10: float | None = None       # % of hand keypoints within 0.1 hand sizes
    hand_pck_20: float | None = None       # % within 0.2 hand sizes
    left_hand_found: float | None = None   # % of the frames showing the hand in the reference where it is found
    right_hand_found: float | None = None
    face_error: float | None = None        # face keypoint error in interocular distances
    face_error_p90: float | None = None
    mouth_error: float | None = None       # lip points' error after removing the face's offset, interocular distances
    eyes_error: float | None = None        # eye, brow and iris points' error, likewise
    letter_top1: float | None = None       # % of fingerspelled letters recognised first (fingerspelling only)
    letter_top3: float | None = None       # % among the first three
    hand_joint_error_mm: float | None = None   # parameter points: joint position error of the hands, mm
    arm_joint_error_mm: float | None = None    # and of the arms (shoulder to wrist), mm
    # transport (live delivery), loss in one unit, a fraction 0..1 (reports show percent): loss_rate, the network
    # model's configured loss; packet_loss, the share of the sent datagrams that never reached the receiver in time; delivered_kbps, whole datagrams (IPv4 + UDP + RTP
    # headers and payload) over the clip's duration; overhead_kbps, delivered_kbps less the stream's own kbps;
    # frames_lost, frames whose data did not arrive; frames_concealed, those shown by holding another frame;
    # latency_ms_p50 / _p95, capture to ready-to-show per received frame, median and 95th percentile, ms
    loss_rate: float | None = None
    packet_loss: float | None = None
    delivered_kbps: float | None = None
    overhead_kbps: float | None = None
    frames_lost: int | None = None
    frames_concealed: int | None = None
    latency_ms_p50: float | None = None
    latency_ms_p95: float | None = None
    # stage and run records
    stage: str | None = None
    wall_s: float | None = None
    backend: str | None = None
    versions: dict | None = None
    objects: list | None = None
    extra: dict = field(default_factory=dict)

    @property
    def has_picture(self) -> bool:
        return (self.width or 0) > 0 and (self.height or 0) > 0

    def to_json(self) -> dict:
        """The JSON object of one line: schema, kind, a point's own fields, then the other fields that are set."""
        out = {"schema": SCHEMA_VERSION, "kind": self.kind}
        for name in _TYPED:
            value = getattr(self, name)
            if value is not None or (self.kind == "point" and name in REQUIRED_FIELDS):
                out[name] = value
        out.update(self.extra)
        return out

    @classmethod
    def from_json(cls, data: dict) -> Record:
        """A Record from one line's JSON object (legacy lines renamed); SigncastError says what is wrong."""
        if not isinstance(data, dict):
            raise SigncastError("a record must be a JSON object")
        problem = _problem(data, list(_values(data)))
        if problem:
            raise SigncastError(problem)
        data = dict(data)
        if "schema" in data:
            del data["schema"]                          # _problem checked it is SCHEMA_VERSION
            for name in ("psnr", *LEGACY_NAMES):
                if name in data:
                    new = "'image_psnr' or 'param_psnr'" if name == "psnr" else repr(LEGACY_NAMES[name])
                    raise SigncastError(f"field {name!r} is not in records schema {SCHEMA_VERSION} (use {new})")
        else:
            data = _legacy(data)
        typed = {name: data.pop(name) for name in _TYPED if name in data}
        record = cls(kind=data.pop("kind", "point"), **typed, extra=data)
        if record.kind == "point" and record.width is not None and record.height is not None and not record.has_picture:
            image = [name for name in IMAGE_QUALITY_FIELDS if getattr(record, name) is not None]
            if image:
                raise SigncastError(f"a point without a picture (width {record.width}, height {record.height}) cannot "
                                    f"carry image quality {image[0]!r}")
        return record


_TYPED = tuple(f.name for f in dataclasses.fields(Record) if f.name not in ("kind", "extra"))


def _check_schema(data: dict) -> str | None:
    schema = data.get("schema", SCHEMA_VERSION)
    if isinstance(schema, bool) or schema != SCHEMA_VERSION or not isinstance(schema, int):
        shown = json.dumps(schema)
        shown = shown if len(shown) <= 40 else shown[:37] + "..."
        return (f"unknown records schema {shown}: this signcast reads schema {SCHEMA_VERSION} "
                "and legacy records without a 'schema' field")
    return None


def _legacy(data: dict) -> dict:
    """A record without "schema" with the schema 2 names (see the module's description)."""
    for old, new in LEGACY_NAMES.items():
        if old in data:
            if new in data:
                raise SigncastError(f"legacy record holds both {old!r} and {new!r}")
            data[new] = data.pop(old)
    if "psnr" in data:
        value = data.pop("psnr")
        width, height = data.get("width"), data.get("height")
        if data.get("kind", "point") == "point" and width is not None and height is not None:
            new = "image_psnr" if width > 0 and height > 0 else "param_psnr"
        elif value is None:
            return data
        else:
            raise SigncastError("legacy record (no 'schema' field): its 'psnr' is image PSNR on a point with width and "
                                "height > 0 and parameter PSNR on one with width = height = 0, and this record has "
                                f"kind {data.get('kind', 'point')!r}, width {width!r}, height {height!r}")
        if new in data:
            raise SigncastError(f"legacy record holds both 'psnr' and {new!r}")
        data[new] = value
    return data


def make_record(solution: str, clip: str, codec: str, q: float | None, fps: float, width: int, height: int,
                bits: int, duration_s: float, **fields) -> dict:
    """A measured point as a dict (Record.to_json's fields without schema); kbps = bits / duration_s / 1000.
    Extra fields (quality, areas, ...) are kept as given."""
    if duration_s <= 0:
        raise SigncastError(f"a record needs a positive duration, got {duration_s}")
    record = {"kind": "point", "solution": solution, "clip": clip, "codec": codec, "q": q, "fps": float(fps),
              "width": int(width), "height": int(height), "bits": int(bits), "duration_s": float(duration_s),
              "kbps": kbps(bits, duration_s)}
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


def as_record(record: Record | dict) -> Record:
    """A Record from a Record or a record dict (legacy names renamed, types checked; NaN and infinities as null)."""
    if isinstance(record, Record):
        record = record.to_json()
    return Record.from_json(_plain(record))


def as_records(records: list[Record | dict]) -> list[Record]:
    """as_record of each: what a study hands to a report. SigncastError names the record that is rejected."""
    typed = []
    for number, record in enumerate(records, 1):
        try:
            typed.append(as_record(record))
        except SigncastError as error:
            raise SigncastError(f"record {number} of {len(records)}: {error}") from None
    return typed


def report_rows(records: list[Record]) -> list[dict]:
    """What a report reads of Records: each one's schema dict (Record.to_json). The reports take Records only;
    a study turns its dict rows into Records (as_record) where it hands them over, and read_typed_records gives
    them from records.jsonl. TypeError names the first item that is not a Record (a caller's bug)."""
    rows = []
    for number, record in enumerate(records, 1):
        if not isinstance(record, Record):
            raise TypeError(f"a report takes Records, got {type(record).__name__} as item {number} of "
                            f"{len(records)} (convert it with comparisons.reports.records.as_record)")
        rows.append(record.to_json())
    return rows


def normalize_records(records: list[Record | dict]) -> list[dict]:
    """Records as schema dicts (what read_records returns): legacy names renamed, null optional fields left out."""
    return [as_record(r).to_json() for r in records]


def records_text(records: list[Record | dict], where: str = "records.jsonl") -> str:
    """records (Records or dicts, legacy names renamed) as JSON lines with "schema" (NaN and infinities become
    null), one per line, each ending in a newline. A record that Record.from_json rejects raises SigncastError
    naming it (where: the file it was meant for). pipeline.outputs.write_records writes them."""
    lines = []
    for number, record in enumerate(records, 1):
        try:
            lines.append(json.dumps(as_record(record).to_json(), sort_keys=False) + "\n")
        except SigncastError as error:
            raise SigncastError(f"record {number} of {len(records)} to {where}: {error}") from None
    return "".join(lines)


def read_typed_records(path: str | Path) -> list[Record]:
    """Read records.jsonl back as Records; a malformed line raises SigncastError naming the line (see the
    module's checks)."""
    path = Path(path)
    if not path.is_file():
        raise SigncastError(f"records file not found: {path}")
    records, n_values = [], 0
    for number, line in enumerate(text_files.read_lines(path, "records file"), 1):
        if not line.strip():
            continue
        try:
            data = json.loads(line, parse_constant=_nan_as_null)
        except (ValueError, RecursionError) as error:   # ValueError: bad JSON, or an integer past Python's digit limit
            raise SigncastError(f"{path}:{number}: not a JSON record ({getattr(error, 'msg', error)})") from None
        if not isinstance(data, dict):
            raise SigncastError(f"{path}:{number}: a record must be a JSON object")
        n_values += 1 + sum(1 for _ in _values(data))
        try:
            records.append(Record.from_json(data))
        except SigncastError as error:
            raise SigncastError(f"{path}:{number}: {error}") from None
        if n_values > MAX_RECORD_VALUES:
            raise SigncastError(f"{path}:{number}: more than {MAX_RECORD_VALUES} values in one records file")
    return records


def read_records(path: str | Path) -> list[dict]:
    """Read records.jsonl back as schema dicts (Record.to_json of each line); a malformed line raises SigncastError
    naming the line (see the module's checks)."""
    return [record.to_json() for record in read_typed_records(path)]


def _nan_as_null(constant: str) -> float | None:
    """NaN means not measured, as null does (records_text writes it so); Infinity stays, to be rejected."""
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
        field_name, value = stack.pop()
        yield field_name, value
        if isinstance(value, dict):
            stack.extend((field_name, v) for v in value.values())
        elif isinstance(value, list):
            stack.extend((field_name, v) for v in value)


def _problem(record: dict, values: list[tuple[str, object]]) -> str | None:
    """What is wrong with one record's schema or field types, or None; values: _values(record)."""
    problem = _check_schema(record)
    if problem:
        return problem
    for name in STRING_FIELDS:             # null: not given (Record.to_json writes a point's own fields as null)
        if record.get(name) is not None and not isinstance(record[name], str):
            return f"field {name!r} must be a string, got {reprlib.repr(record[name])}"
    for name in NEEDED.get(record.get("kind", "point"), ()):
        if record.get(name) is None:
            return f"a {record.get('kind', 'point')} record needs field {name!r}"
    for name in NUMBER_FIELDS:
        if record.get(name) is not None and not _is_number(record[name]):
            return f"field {name!r} must be a finite number, got {reprlib.repr(record[name])}"
    for name, kind in CONTAINER_FIELDS.items():
        if name in record and not isinstance(record[name], kind) and not (name in NULLABLE and record[name] is None):
            return (f"field {name!r} must be {'an object' if kind is dict else 'a list'}, "
                    f"got {reprlib.repr(record[name])}")
    for name, value in values:
        if isinstance(value, (int, float)) and not isinstance(value, bool) and not _is_number(value):
            return f"field {name!r} holds {reprlib.repr(value)}, not a finite number"
    return None

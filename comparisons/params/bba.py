"""MPEG-4 BBA (bone-based animation, SMS) stream: data model, binary writer and reader, Motion glue.

Per frame (seed 000 §3.4.4, preda-digest.md §2.4-2.5): an animationMaskVector (KeyFrameIndex,
the IDs 0..1023 of the bones updated, a hierarchical mask per bone) and an animationValueVector
(Euler angles in the rotation order, translations), coded with the FBA coders reused on SMS values
(frame-predictive + arithmetic coding, or 16-frame DCT; comparisons/params/coding.py). A frame
start code precedes every frame (for the DCT coder: every 16-frame segment), so a server can cut
a frame short and a decoder resynchronises; muscle data follows its own start code so a weak
terminal can skip it.

Binary layout (field widths and start-code values are signcast's; the thesis gives neither):

    BBA start code 0x000001D0
    header: version u8 (30 = 3.0), frame_rate u8, seconds u4, frequency_offset u1, coding u2
            (0 predictive, 1 DCT), keyframes u1, Q u5, intra period u6, header period u6,
            frames u24 (display frames of the stream), rotationOrder u5, tight_ranges u1,
            number of bones u10, per bone: boneID u10, animatable mask (5 level-1 bits + level-2
            bits of the set types), step exponent u4 (step = 2^e units), [tight ranges: per
            animatable value I max, I min, P max, P min, 7 bits each], CRC-8
    per unit (a frame; for the DCT coder a segment of up to 16 frames): frame start code
            0x000001D1, is_intra u1, frame number (intra: u24, predicted: u8 = the number modulo
            256), KeyFrameIndex u5, [DCT: frames - 1 u4], [P: same_mask u1], [NSBB u10, per
            bone boneID u10 + hierarchical mask], values (arithmetic-coded levels, or DCT
            blocks), NSBM u10, CRC-8; if NSBM > 0: muscle start code 0x000001D2, per muscle:
            muscleID u10, NCP u6, NK u6, MM bits (4 per control point, 1 per knot), values s20;
            CRC-8
    header copy: before every header-period-th intra unit (0: never) the BBA start code and
            the header again, bit for bit
    end code 0x000001D3

Hierarchical bone mask: a bone's header announces which of the 16 elementary motions it may
carry; in a frame, one level-1 bit per announced motion type (translation, rotation, scale,
scaleOrientation, center) and, for each set type, one bit per announced elementary motion. A
bone with one animatable angle costs 2 bits, a bone with all 16 costs 21, the 2..21 of the thesis.

Units: angles 1e-5 rad (the BBA schema bound +-314159 = pi), translations mm. rotationOrder is an
SBBone field, not stream data; signcast sends one order for all bones in the header (Shoemake
packing, see ORDER_NAMES). The CRC-8 fields (polynomial 0x07 over the raw bits since the start
code) are signcast's: they let a decoder tell a damaged frame from a good one before resynchronising.

Frame numbers count display frames, the frames of the decoded Motion (key frames expanded): a
unit's number is the display frame of its first frame, and the first frame has KeyFrameIndex 0.
The resilient decoder places every good unit at its number, holds the last good frame over the
frames it did not get, and reports those frames; the header's frame count fixes the length,
and a predicted unit is used only when its number follows its reference's. A damaged header
loses the stream unless a header copy is intact: the decoder then decodes every unit, also
those before the copy, with it (a whole-stream decoder; a live one resumes at the copy).

Predictive values: an intra level is the absolute value; a P level is the change from the
decoder's previous value, for angles folded into (-pi, pi] (ANGLE_PERIOD), and the decoder folds
its angle sums the same way, so an angle crossing +-pi costs a small level. Where a P level
does not fit the range fields' alphabet the unit is sent intra; where an intra level does not
fit, the encoder raises SigncastError (nothing is clipped).

Live decoding (signcast's API, not in the thesis): split_units cuts a stream at its start codes
(header, each unit with its muscle data, header copies, end code) so a packetiser sends whole
units; LiveDecoder decodes them one by one as they arrive, with read_stream(resilient=True)'s rules,
in time proportional to each unit, and reports the frames lost so far.

A decoder holds at most MAX_DECODED_VALUES frames x values per frame; larger streams are refused
before their frames are decoded.

Speed (tests/test_conformance.py pins what the decoder returns; bba.decode_levels gives those integers): each
distinct set of bone masks is laid out once (_layout: keys, steps); the predictive levels of a stream
whose frames share one mask set run in one compiled loop (comparisons/params/bba_levels.py); header and mask
fields are gathered into one integer before the BitWriter takes them; the decoder reads the bone
tables and masks with comparisons/params/bba_masks.py and converts all frames' Euler angles in one compiled call
(media.rotations.from_euler_table, scipy's from_euler to rounding). Streams of one mask set without muscles are
written from arrays (values (F, P), KeyFrameIndex (F,)); encode_motion and decode_motion (what
comparisons/param_codecs.BbaCodec uses) go from a Motion to bytes and back without any BBAFrame, with
the bytes and Motion of motion_to_stream + write_stream and read_stream + stream_to_motion. decode_motion
reads a stream whose units all carry one bone list and no muscles in one kernel call (_read_uniform,
comparisons/params/bba_units.py), its Motion column plan cached per stream; on anything else, damage included,
it falls back to the unit-by-unit reader, which raises the errors.
"""
from __future__ import annotations

import functools
import itertools
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from comparisons.params import bap_table
from comparisons.params import keyframes as kf
from comparisons.params import coding as pc
from comparisons.params.bits import BitReader, BitWriter, find_start_codes
from comparisons.params.fba_mapping import avatar_bap_map
from comparisons.params import bba_header as header_kernel
from comparisons.params import bba_levels as level_kernel
from comparisons.params import bba_masks as mask_kernel
from comparisons.params import bba_units as unit_kernel
from comparisons.params import bba_values as split_kernel
from comparisons.params import bba_writer as writer_kernel
from comparisons.params import arithmetic as crc_kernel
from media import rotations
from media.avatar import Skeleton, load_avatar
from media.errors import SigncastError
from media.motion import Motion

BBA_START_CODE, FRAME_START_CODE, MUSCLE_START_CODE, END_CODE = 0xD0, 0xD1, 0xD2, 0xD3
VERSION = 30
MASK_FIELDS = ("TranslationOnX", "TranslationOnY", "TranslationOnZ",
               "RotationOnAxis1", "RotationOnAxis2", "RotationOnAxis3",
               "ScaleOnX", "ScaleOnY", "ScaleOnZ",
               "ScaleOrientationOnAxeX", "ScaleOrientationOnAxeY", "ScaleOrientationOnAxeZ", "ScaleOrientationValue",
               "CenterOnX", "CenterOnY", "CenterOnZ")
MASK_TYPES = (("isTranslation", (0, 1, 2)), ("isRotation", (3, 4, 5)), ("isScale", (6, 7, 8)),
              ("isScaleOrientation", (9, 10, 11, 12)), ("isCenter", (13, 14, 15)))
ROTATION_BITS = (3, 4, 5)
_GROUP_START = np.array([bits[0] for _, bits in MASK_TYPES] + [16], dtype=np.int64)   # comparisons/params/bba_masks.py
TRANSLATION_BITS = (0, 1, 2)
MUSCLE_VALUE_BITS = 20
VALUE_LIMIT = (1 << (MUSCLE_VALUE_BITS - 1)) - 1   # |bone value|: BBA XML's 20-bit signed integers, as muscles'
DEFAULT_INTRA_PERIOD = 32
DEFAULT_INTRA_SEGMENTS = 4
FRAME_NUMBER_BITS = 24                 # intra units' frame number and the header's frame count
P_FRAME_NUMBER_BITS = 8                # predicted units: the frame number modulo 256
ANGLE_PERIOD = 628318                  # 2 pi in 1e-5 rad, rounded: angles are values modulo this
# Most frames x values per frame a decoder holds. Decoded, a value costs about 100 bytes (Python
# ints in per-bone lists, measured), so 2^22 keeps a decoded stream near 0.4 GB: 61 680 frames of
# the avatar's 68 fingerspelling values, 41 min at 25 fps or 17 min at 60 fps.
MAX_DECODED_VALUES = 1 << 22


def _order_names() -> tuple[str, ...]:
    """Shoemake's packing code = ((first_axis * 2 + parity) * 2 + repetition) * 2 + frame."""
    names = []
    for code in range(24):
        frame, rest = code & 1, code >> 1
        repetition, rest = rest & 1, rest >> 1
        parity, first = rest & 1, rest >> 1
        second = (first + 1 + parity) % 3
        third = first if repetition else 3 - first - second
        axes = "".join("XYZ"[a] for a in (first, second, third))
        names.append(axes + "s" if frame == 0 else axes[::-1] + "r")
    return tuple(names)


ORDER_NAMES = _order_names()


@dataclass
class MuscleUpdate:
    """One SBMuscle's update: NCP control points, NK knots, mask bits (4 per control point:
    x, y, z, weight; then 1 per knot) and one integer value per set bit."""
    muscle_id: int
    n_control_points: int
    n_knots: int
    mask: list[int]
    values: list[int]


@dataclass
class BBAFrame:
    """kfi: KeyFrameIndex (frames to interpolate before this one); bones: boneID -> 16-bit mask
    (bit k = MASK_FIELDS[k]); values: boneID -> integers for the set bits in bit order."""
    kfi: int
    bones: dict[int, int]
    values: dict[int, list[int]]
    muscles: list[MuscleUpdate] = field(default_factory=list)


@dataclass
class BBAHeader:
    name: str
    fps: float
    coding: str = "pred"             # "pred" or "dct"
    q: int = 1
    intra_period: int = DEFAULT_INTRA_PERIOD   # frames (pred) or segments (dct)
    keyframes: bool = False
    rotation_order: int = 0
    header_period: int = 0           # a header copy before every n-th intra unit (0: never)


@dataclass
class BBAStream:
    header: BBAHeader
    frames: list[BBAFrame]


@functools.lru_cache(maxsize=4096)
def _bits(mask: int) -> tuple[int, ...]:
    return tuple(k for k in range(16) if mask >> k & 1)


def _keys(frame: BBAFrame) -> list[tuple[int, int]]:
    return [(bone, bit) for bone in sorted(frame.bones) for bit in _bits(frame.bones[bone])]


def _flat_values(frame: BBAFrame) -> list[int]:
    return [v for bone in sorted(frame.bones) for v in frame.values[bone]]


def fold_angles(values: np.ndarray) -> np.ndarray:
    """Integer angles (1e-5 rad, any shape) folded into (-pi, pi], i.e. -314158..314159."""
    half = ANGLE_PERIOD // 2
    return half - (half - np.asarray(values, dtype=np.int64)) % ANGLE_PERIOD


def _fold(values: np.ndarray, is_angle: np.ndarray) -> np.ndarray:
    """values (P,) int64 with the angles among them (is_angle, (P,) bool) folded."""
    return np.where(is_angle, fold_angles(values), values)


def _is_angle(keys: list[tuple[int, int]]) -> np.ndarray:
    return np.array([bit in ROTATION_BITS for _, bit in keys], dtype=bool)


def display_numbers(frames: list[BBAFrame]) -> np.ndarray:
    """(F,) int64 display frame of each stream frame (key frames expanded): the first frame is
    frame 0 and each later one comes KeyFrameIndex + 1 frames after its predecessor."""
    gaps = np.array([0] + [f.kfi + 1 for f in frames[1:]], dtype=np.int64)
    return np.cumsum(gaps)


_EXPONENTS: dict[int, tuple[Skeleton, dict[int, int]]] = {}


def _rotation_step_exponents(skeleton: Skeleton) -> dict[int, int]:
    """boneID (skeleton index) -> log2 of the rotation step: the finest FBA step of the BAPs the
    bone maps to (the thesis used the FBA ranges converted to SMS units), else 2^7."""
    cached = _EXPONENTS.get(id(skeleton))
    if cached and cached[0] is skeleton:
        return cached[1]
    exponents = {}
    bap_map = avatar_bap_map(skeleton)
    for bone in bap_map.bones:
        step = min(bap_table.bap(i).step for i in bone.baps)
        exponents[skeleton.index(bone.bone)] = round(np.log2(step))
    _EXPONENTS[id(skeleton)] = (skeleton, exponents)
    return exponents


def step_of(bone_id: int, bit: int, skeleton: Skeleton) -> int:
    if bit in TRANSLATION_BITS:
        return 2
    return 1 << _rotation_step_exponents(skeleton).get(bone_id, 7)


_EXPONENT_ITEMS: dict[int, tuple[Skeleton, tuple[tuple[int, int], ...]]] = {}


def _exponent_items(skeleton: Skeleton) -> tuple[tuple[int, int], ...]:
    """_rotation_step_exponents as a hashable key for _layout (cached per skeleton)."""
    cached = _EXPONENT_ITEMS.get(id(skeleton))
    if cached and cached[0] is skeleton:
        return cached[1]
    items = tuple(sorted(_rotation_step_exponents(skeleton).items()))
    _EXPONENT_ITEMS[id(skeleton)] = (skeleton, items)
    return items


@dataclass(frozen=True)
class _Layout:
    """The values of a frame with given bone masks, in stream order: keys (boneID, bit), base steps
    (P,) int64, which are angles (P,) bool, and the number of values of each bone (sorted boneIDs)."""
    bones: tuple[int, ...]
    keys: list[tuple[int, int]]
    steps: np.ndarray
    is_angle: np.ndarray
    counts: list[int]


@functools.lru_cache(maxsize=1024)
def _layout(bones: tuple[tuple[int, int], ...], exponents: tuple[tuple[int, int], ...]) -> _Layout:
    """bones: sorted (boneID, mask) pairs; exponents: (boneID, rotation step exponent) pairs (default 7).
    Cached: a stream has few distinct masks. The arrays are read-only."""
    exponent = dict(exponents)
    keys = [(b, bit) for b, mask in bones for bit in _bits(mask)]
    steps = np.array([2 if bit in TRANSLATION_BITS else 1 << exponent.get(b, 7) for b, bit in keys], dtype=np.int64)
    is_angle = _is_angle(keys)
    steps.flags.writeable = False
    is_angle.flags.writeable = False
    return _Layout(tuple(b for b, _ in bones), keys, steps, is_angle, [len(_bits(mask)) for _, mask in bones])


def _frame_layout(bones: dict[int, int], exponents: tuple[tuple[int, int], ...]) -> _Layout:
    return _layout(tuple(sorted(bones.items())), exponents)


# --------------------------------------------------------------------------------- writing

def _write_fps(writer: BitWriter, fps: float) -> None:
    rate, seconds, offset = pc.frame_rate_fields(fps)
    writer.write(rate, 8)
    writer.write(seconds, 4)
    writer.write_bit(offset)


def _write_animatable(writer: BitWriter, mask: int) -> None:
    for _, bits in MASK_TYPES:
        writer.write_bit(int(any(mask >> b & 1 for b in bits)))
    for _, bits in MASK_TYPES:
        if any(mask >> b & 1 for b in bits):
            for b in bits:
                writer.write_bit(mask >> b & 1)


def _write_bone_mask(writer: BitWriter, mask: int, animatable: int) -> None:
    for _, bits in MASK_TYPES:
        allowed = [b for b in bits if animatable >> b & 1]
        if allowed:
            used = any(mask >> b & 1 for b in allowed)
            writer.write_bit(int(used))
            if used:
                for b in allowed:
                    writer.write_bit(mask >> b & 1)


def _units(stream: BBAStream) -> list[list[int]]:
    """Frame indices of each coded unit: one frame (predictive) or a 16-frame segment (DCT)."""
    n = len(stream.frames)
    if stream.header.coding == "dct":
        return [list(range(s, min(s + pc.SEGMENT, n))) for s in range(0, n, pc.SEGMENT)]
    return [[t] for t in range(n)]


def _intra_flags(stream: BBAStream, units: list[list[int]]) -> list[bool]:
    flags = []
    for k, unit in enumerate(units):
        changed = k == 0 or stream.frames[unit[0]].bones != stream.frames[units[k - 1][0]].bones
        flags.append(bool(k % stream.header.intra_period == 0 or changed))
    return flags


def _check_stream(stream: BBAStream) -> None:
    h = stream.header
    _check_header(h)
    if not stream.frames:
        raise SigncastError("a BBA stream needs at least one frame")
    if stream.frames[0].kfi:
        raise SigncastError("the first BBA frame has KeyFrameIndex 0: there is no frame before it to interpolate from")
    previous = None
    for frame in stream.frames:
        if not 0 <= frame.kfi <= kf.MAX_KFI:
            raise SigncastError(f"KeyFrameIndex {frame.kfi} outside 0..31")
        if h.coding == "dct" and (frame.kfi or frame.muscles):
            raise SigncastError("the DCT BBA coder carries neither key frames nor muscles")
        if frame.bones != previous:                       # most frames repeat their predecessor's masks
            for bone in frame.bones:
                if not 0 <= bone <= 1023:
                    raise SigncastError(f"boneID {bone} outside 0..1023")
            previous = frame.bones
        counts = list(map(len, map(frame.values.get, frame.bones, itertools.repeat(()))))
        if counts != list(map(int.bit_count, frame.bones.values())):
            for bone, mask in frame.bones.items():
                if len(frame.values.get(bone, ())) != mask.bit_count():
                    raise SigncastError(f"bone {bone}: {mask.bit_count()} mask bits but "
                                        f"{len(frame.values.get(bone, ()))} values")
    _check_size(*_size(stream.frames))
    largest = max((abs(v) for frame in stream.frames for values in frame.values.values() for v in values), default=0)
    if largest > VALUE_LIMIT:
        raise SigncastError(f"a BBA bone value of magnitude {largest} is beyond +-{VALUE_LIMIT}")


def _size(frames: list[BBAFrame]) -> tuple[int, int]:
    """(display frames, distinct values per frame) of a stream's frames."""
    if not frames:
        return 0, 0
    animatable: dict[int, int] = {}
    previous = None
    for frame in frames:
        if frame.bones != previous:
            for bone, mask in frame.bones.items():
                animatable[bone] = animatable.get(bone, 0) | mask
            previous = frame.bones
    return int(display_numbers(frames)[-1]) + 1, sum(mask.bit_count() for mask in animatable.values())


def _check_size(n_frames: int, n_values: int) -> None:
    """SigncastError when n_frames display frames of n_values values each exceed the decoder's cap."""
    if n_frames * max(n_values, 1) > MAX_DECODED_VALUES or n_frames >> FRAME_NUMBER_BITS:
        raise SigncastError(f"BBA stream of {n_frames} frames x {n_values} values is above the decoder's "
                            f"limit of {MAX_DECODED_VALUES} values: cut it into shorter streams")


def _intra_levels(values: np.ndarray, keys: list[tuple[int, int]], steps: np.ndarray, q: int) -> np.ndarray:
    """Levels of absolute values (P,) (angles folded into (-pi, pi] where they would not fit).
    SigncastError when a value does not fit the alphabets at this Q."""
    limit = pc.level_limit(q)
    level = pc.quantize(values, steps * q)
    level = np.where((np.abs(level) > limit) & _is_angle(keys), pc.quantize(fold_angles(values), steps * q), level)
    over = np.flatnonzero(np.abs(level) > limit)
    if len(over):
        bone, bit = keys[over[0]]
        raise SigncastError(f"BBA bone {bone} {MASK_FIELDS[bit]} = {int(values[over[0]])} cannot be sent at Q={q}: "
                            f"its level exceeds the range fields' limit of {limit}")
    return level


def _p_levels(change: np.ndarray, is_angle: np.ndarray, step: np.ndarray) -> np.ndarray:
    """Levels of P residuals (P,): an angle's change is folded into (-pi, pi]; near +-pi the
    other side's equivalent (a full turn away) is taken where it quantises with less error, so a
    decoded stream re-encodes to the same levels (its changes are exact multiples of the step)."""
    folded = _fold(change, is_angle)
    level = pc.quantize(folded, step)
    other = folded - np.sign(folded) * ANGLE_PERIOD
    other_level = pc.quantize(other, step)
    closer = np.abs(other_level * step - other) < np.abs(level * step - folded)
    return np.where(is_angle & (np.abs(folded) > ANGLE_PERIOD // 2 - step) & closer, other_level, level)


def _levels(stream: BBAStream, units, intra_flags, skeleton, key_index: dict[tuple[int, int], int]):
    """First pass: quantised levels of every unit (what the decoder will rebuild). A predicted
    unit whose levels do not fit the alphabets is sent intra instead (intra_flags is updated).
    key_index: (boneID, bit) -> column of the stream's keys. Returns per unit (keys, steps, level,
    columns) (predictive) or (keys, steps, dc, ac, n) (DCT)."""
    exponents = _exponent_items(skeleton)
    if stream.header.coding == "pred" and len(_runs(stream.frames)) == 1:
        return _uniform_levels(stream, intra_flags, exponents, key_index)
    return _levels_by_unit(stream, units, intra_flags, exponents, key_index)


def _levels_by_unit(stream: BBAStream, units, intra_flags, exponents, key_index: dict[tuple[int, int], int]):
    """_levels unit by unit in NumPy: any stream (masks changing between units, DCT segments)."""
    q = stream.header.q
    held = np.zeros(len(key_index), dtype=np.int64)            # the decoder's values, by stream key
    columns_of: dict[tuple[int, ...], np.ndarray] = {}
    per_unit = []
    for k, unit in enumerate(units):
        frame = stream.frames[unit[0]]
        masks = tuple(sorted(frame.bones.items()))
        layout = _layout(masks, exponents)
        keys, steps = layout.keys, layout.steps
        values = np.array([[v for b in layout.bones for v in stream.frames[t].values[b]] for t in unit],
                          dtype=np.int64).reshape(len(unit), len(keys))
        if stream.header.coding == "pred":
            columns = columns_of.get(masks)
            if columns is None:
                columns = columns_of[masks] = np.array([key_index[key] for key in keys], dtype=np.int64)
            is_angle = layout.is_angle
            previous = held[columns]
            if not intra_flags[k]:
                level = _p_levels(values[0] - previous, is_angle, steps * q)
                intra_flags[k] = bool(np.any(np.abs(level) > pc.level_limit(q)))
            if intra_flags[k]:
                level = _intra_levels(values[0], keys, steps, q)
                recon = level * steps * q
            else:
                recon = _fold(previous + level * steps * q, is_angle)
            per_unit.append((keys, steps, level, columns))
            held[columns] = recon
        else:
            n = len(unit)
            dc_step, ac_step = pc.dct_steps(steps, q)
            dc, ac = pc.dct_levels(values, dc_step, ac_step)
            per_unit.append((keys, steps, dc, ac, n))
    return per_unit


def _uniform_levels(stream: BBAStream, intra_flags: list[bool], exponents, key_index: dict[tuple[int, int], int]):
    """_levels of a predictive stream whose frames all carry the same bone masks (one unit per frame), in
    one compiled loop (comparisons/params/bba_levels.py)."""
    frames = stream.frames
    layout = _frame_layout(frames[0].bones, exponents)
    values = np.array([list(itertools.chain.from_iterable(map(frame.values.__getitem__, layout.bones)))
                       for frame in frames], dtype=np.int64).reshape(len(frames), len(layout.keys))
    intra = np.array(intra_flags, dtype=bool)
    levels = _predictive_levels(stream.header.q, layout, values, intra)
    intra_flags[:] = intra.tolist()
    columns = np.array([key_index[key] for key in layout.keys], dtype=np.int64)
    return [(layout.keys, layout.steps, level, columns) for level in levels]


def _predictive_levels(q: int, layout: _Layout, values: np.ndarray, intra: np.ndarray) -> np.ndarray:
    """(F, P) int64 levels of values (F, P) int64 (one unit per frame, all of `layout`); intra (F,) bool,
    in: units sent intra by rule, out: also those whose P levels do not fit. SigncastError when an intra
    level does not fit."""
    levels = np.zeros(values.shape, dtype=np.int64)
    limit = pc.level_limit(q)
    status = level_kernel.predictive_levels(values, layout.steps, layout.is_angle, q, limit, ANGLE_PERIOD, intra, levels)
    if status >= 0:
        unit, p = status % len(values), status // len(values)
        bone, bit = layout.keys[p]
        raise SigncastError(f"BBA bone {bone} {MASK_FIELDS[bit]} = {int(values[unit, p])} cannot be sent at Q={q}: "
                            f"its level exceeds the range fields' limit of {limit}")
    return levels


def write_stream(stream: BBAStream, skeleton: Skeleton | None = None) -> bytes:
    """Binary BBA stream of `stream` (values are quantised here)."""
    skeleton = skeleton or load_avatar().skeleton
    _check_stream(stream)
    frames = stream.frames
    if not any(frame.muscles for frame in frames) and len(_runs(frames)) == 1:
        # One mask set, no muscles (what motion_to_stream makes): the array path.
        layout = _frame_layout(frames[0].bones, _exponent_items(skeleton))
        values = np.array([list(itertools.chain.from_iterable(map(frame.values.__getitem__, layout.bones)))
                           for frame in frames], dtype=np.int64).reshape(len(frames), len(layout.keys))
        kfi = np.array([frame.kfi for frame in frames], dtype=np.int64)
        return _write_arrays(stream.header, _MaskSet(frames[0].bones, skeleton), kfi, values, skeleton)
    units = _units(stream)
    intra_flags = _intra_flags(stream, units)
    bones = sorted({b for f in frames for b in f.bones})
    animatable = {b: 0 for b in bones}
    for frame in frames:
        for b, m in frame.bones.items():
            animatable[b] |= m
    keys = [(b, k) for b in bones for k in _bits(animatable[b])]
    levels = _levels(stream, units, intra_flags, skeleton, {key: j for j, key in enumerate(keys)})
    firsts = [frames[unit[0]] for unit in units]
    plan = _UnitPlan(units, display_numbers(frames), [f.kfi for f in firsts],
                     [k > 0 and f.bones == firsts[k - 1].bones for k, f in enumerate(firsts)],
                     [tuple(sorted(f.bones.items())) for f in firsts], [f.muscles for f in firsts])
    return _write_levels(stream.header, plan, intra_flags, levels, bones, animatable, keys, skeleton)


@dataclass
class _UnitPlan:
    """What the writer needs of each coded unit: units (frame indices), numbers (F,) display frame of
    each frame, and per unit its first frame's KeyFrameIndex, whether its masks equal the previous
    unit's, its sorted (boneID, mask) pairs and its muscle updates."""
    units: list[list[int]]
    numbers: np.ndarray
    kfi: list[int]
    same: list[bool]
    masks: list[tuple[tuple[int, int], ...]]
    muscles: list[list[MuscleUpdate]]


def _write_levels(header: BBAHeader, plan: _UnitPlan, intra_flags, levels, bones, animatable, keys, skeleton) -> bytes:
    """write_stream after the levels: the range fields (predictive) and the bits."""
    if header.coding == "pred":
        # Levels by unit and stream key (0 where a unit does not carry the key: the range fields
        # cover 0 anyway), intra units and predicted units apart.
        by_key = np.zeros((len(levels), len(keys)), dtype=np.int64)
        carried = np.zeros((len(levels), len(keys)), dtype=bool)
        for u, (_, _, level, columns) in enumerate(levels):
            by_key[u, columns] = level
            carried[u, columns] = True
        fields, tight = _range_choice(by_key, carried, np.array(intra_flags, dtype=bool), header.q)
        return _write(header, plan, intra_flags, levels, bones, animatable, fields, tight, skeleton)
    return _write(header, plan, intra_flags, levels, bones, animatable, None, False, skeleton)


def _range_choice(by_key: np.ndarray, carried: np.ndarray | None, intra: np.ndarray, q: int) -> tuple[np.ndarray, bool]:
    """(fields (4, K) int64, tight) of a predictive stream: by_key (U, K) int64 levels by unit and stream key
    (0 where not carried), carried (U, K) bool (None: every unit carries every key; the fields and the choice
    are then kernels/bba_writer's range_fields and range_cost_gap, the same numbers and the same choice, NumPy's
    sums deciding a near tie), intra (U,) bool. Tight ranges unless the default alphabets are estimated (log2
    of alphabet sizes per coded level) to cost less than the range fields they save."""
    if carried is None:
        fields = writer_kernel.range_fields(by_key, intra, q, pc.RANGE_DELTA)
    else:
        fields = np.zeros((4, by_key.shape[1]), dtype=np.int64)
        fields[0], fields[1] = pc.range_fields(by_key[intra], q)
        fields[2], fields[3] = pc.range_fields(by_key[~intra], q)
    if fields.max(initial=0) > pc.DEFAULT_RANGE_FIELD:
        return fields, True
    default = np.full_like(fields, pc.DEFAULT_RANGE_FIELD)
    if carried is None:
        n_intra = int(np.count_nonzero(intra))
        choice = writer_kernel.range_cost_gap(fields, n_intra, len(intra) - n_intra, q, pc.RANGE_DELTA,
                                              pc.DEFAULT_RANGE_FIELD, pc.RANGE_BITS)
        if choice >= 0:
            return (default, False) if choice else (fields, True)
        counts = np.empty((2, by_key.shape[1]), dtype=np.int64)
        counts[0], counts[1] = n_intra, len(intra) - n_intra
    else:
        counts = np.array([carried[intra].sum(axis=0), carried[~intra].sum(axis=0)], dtype=np.int64)
    if _estimated_bits(default, counts, q) < _estimated_bits(fields, counts, q) + 4 * pc.RANGE_BITS * by_key.shape[1]:
        return default, False
    return fields, True


def _estimated_bits(fields: np.ndarray, counts: np.ndarray, q: int) -> float:
    """Bits of coding counts (2, K) levels (intra, predicted) of each key in the alphabets of fields (4, K),
    estimated as log2 of the alphabet sizes."""
    i_low, i_high = pc.alphabet(fields[0], fields[1], q)
    p_low, p_high = pc.alphabet(fields[2], fields[3], q)
    return float((counts[0] * np.log2(i_high - i_low + 1)).sum() + (counts[1] * np.log2(p_high - p_low + 1)).sum())


def _check_header(h: BBAHeader) -> None:
    pc.check_q(h.q)
    if h.coding not in ("pred", "dct"):
        raise SigncastError(f"unknown BBA coding {h.coding!r}: choose 'pred' or 'dct'")
    if not 1 <= h.intra_period <= 63:
        raise SigncastError(f"BBA intra period {h.intra_period} outside 1..63")
    if not 0 <= h.header_period <= 63:
        raise SigncastError(f"BBA header period {h.header_period} outside 0..63")
    if not 0 <= h.rotation_order < 24:
        raise SigncastError(f"rotationOrder {h.rotation_order} outside 0..23")


@dataclass(frozen=True)
class _ArrayTables:
    """What `_write_arrays` needs of its streams' one set of bone masks, made once per set (`_array_tables`): the
    bits of a unit's bone list (read-only uint8 0/1) and the (value, number of bits) of the header's bone table."""
    list_bits: np.ndarray
    bone_table: tuple[int, int]


@functools.lru_cache(maxsize=256)
def _array_tables(masks: tuple[tuple[int, int], ...], exponents: tuple[tuple[int, int], ...]) -> _ArrayTables:
    """The `_ArrayTables` of sorted (boneID, mask) pairs, every bone animatable as it is sent (cached)."""
    return _ArrayTables(_bit_array(*_bone_list_bits(masks, tuple(mask for _, mask in masks))),
                        _bone_table_bits(masks, exponents))


class _MaskSet(Mapping):
    """A stream's one set of bone masks: boneID -> mask, read-only, in the order it was given (the encoder's: by each
    bone's first sent value), with what `_write_arrays` derives from it for a skeleton: masks, the sorted (boneID,
    mask) pairs, their `_Layout` and `_ArrayTables`. SigncastError for a boneID outside 0..1023."""

    def __init__(self, bones: Mapping[int, int], skeleton: Skeleton) -> None:
        self._bones = dict(bones)
        if self._bones and (min(self._bones) < 0 or max(self._bones) > 1023):
            raise SigncastError(f"boneID {next(b for b in self._bones if not 0 <= b <= 1023)} outside 0..1023")
        self.masks = tuple(sorted(self._bones.items()))
        exponents = _exponent_items(skeleton)
        self.layout = _layout(self.masks, exponents)
        self.tables = _array_tables(self.masks, exponents)

    def __getitem__(self, bone: int) -> int:
        return self._bones[bone]

    def __iter__(self):
        return iter(self._bones)

    def __len__(self) -> int:
        return len(self._bones)


_MASK_SETS: dict[tuple[bytes, bytes], tuple[Skeleton, _MaskSet]] = {}


def _mask_set_of(bone_ids: np.ndarray, masks: np.ndarray, skeleton: Skeleton) -> _MaskSet:
    """The `_MaskSet` of bone_ids (M,) int64 with masks (M,) int64, in that order (cached: an encoder meets the same
    few sets again and again, and hashing their bytes is cheaper than building the set)."""
    key = (bone_ids.tobytes(), masks.tobytes())
    cached = _MASK_SETS.get(key)
    if cached is not None and cached[0] is skeleton:
        return cached[1]
    made = _MaskSet(dict(zip(bone_ids.tolist(), masks.tolist())), skeleton)
    if len(_MASK_SETS) >= 256:
        _MASK_SETS.clear()
    _MASK_SETS[key] = (skeleton, made)
    return made


def _write_arrays(header: BBAHeader, bones: _MaskSet, kfi: np.ndarray, values: np.ndarray,
                  skeleton: Skeleton) -> bytes:
    """write_stream of a stream whose frames all carry the bone masks `bones` and no muscles, given as
    arrays: kfi (F,) int64 KeyFrameIndex of each frame, values (F, P) int64 in stream order (bones
    sorted, bits ascending). The same checks and the same bytes as write_stream of its BBAFrames."""
    _check_header(header)
    n = len(kfi)
    if not n:
        raise SigncastError("a BBA stream needs at least one frame")
    if kfi[0]:
        raise SigncastError("the first BBA frame has KeyFrameIndex 0: there is no frame before it to interpolate from")
    numbers, bad, any_kfi, largest = writer_kernel.frame_checks(   # numbers: display frames, KeyFrameIndex + 1 apart
        np.ascontiguousarray(kfi, dtype=np.int64), np.ascontiguousarray(values, dtype=np.int64), kf.MAX_KFI)
    if bad >= 0:
        raise SigncastError(f"KeyFrameIndex {int(kfi[bad])} outside 0..31")
    if header.coding == "dct" and any_kfi:
        raise SigncastError("the DCT BBA coder carries neither key frames nor muscles")
    masks, layout, mask_tables = bones.masks, bones.layout, bones.tables
    _check_size(int(numbers[-1]) + 1, len(layout.keys))
    if largest > VALUE_LIMIT:
        shown = "2**63 or more" if largest == np.iinfo(np.int64).max else largest
        raise SigncastError(f"a BBA bone value of magnitude {shown} is beyond +-{VALUE_LIMIT}")
    list_bits = mask_tables.list_bits
    q = header.q
    n_display = int(numbers[-1]) + 1
    if header.coding == "pred":
        intra = np.arange(n) % header.intra_period == 0
        levels = _predictive_levels(q, layout, values, intra)
        fields, tight = _range_choice(levels, None, intra, q)
        lows, highs = pc.alphabet(fields[0::2], fields[1::2], q)        # (2, P): intra, predicted
        sizes = highs - lows + 1
        smallest, largest_size = int(sizes.min(initial=1)), int(sizes.max(initial=1))     # pc.make_models' checks
        if smallest < 1:
            raise SigncastError(f"an alphabet needs at least one symbol, got {smallest}")
        if largest_size > pc.MAX_TOTAL // 2:
            raise SigncastError(f"alphabet of {largest_size} symbols is too large for a frequency limit of {pc.MAX_TOTAL}")
        low_i, low_p, sizes_i, sizes_p = lows[0], lows[1], sizes[0], sizes[1]
        header_bits = _bit_array(*_header_bits(header, n_display, len(masks), mask_tables.bone_table, tight))
        detail = np.zeros(4, dtype=np.int64)
        room = (2 * (len(header_bits) + 8 * fields.size) + len(list_bits) + 4 * 32 * (len(layout.keys) + 1) + 256)
        size = (len(header_bits) + 8 * fields.size + 64 + n * room) * 23 // 22 // 8 + 64
        while True:
            buffer = np.zeros(size, dtype=np.uint8)
            n_bits = writer_kernel.write_predictive_stream(
                buffer, header_bits, tight, fields, pc.RANGE_BITS, list_bits, header.header_period, numbers, kfi,
                intra, levels, low_i, sizes_i, low_p, sizes_p, pc.MAX_TOTAL, detail)
            if n_bits != writer_kernel.STATUS_FULL:
                break
            size *= 2
        if n_bits == writer_kernel.STATUS_LIMIT:                # models that would be halved: unit by unit
            columns = np.arange(len(layout.keys), dtype=np.int64)
            plan = _UnitPlan([[t] for t in range(n)], numbers, kfi.tolist(), [k > 0 for k in range(n)], [masks] * n,
                             [[]] * n)
            return _write(header, plan, intra.tolist(), [(layout.keys, layout.steps, level, columns) for level in levels],
                          list(layout.bones), bones, fields, tight, skeleton)
        if n_bits == writer_kernel.STATUS_SYMBOL:
            raise SigncastError(f"symbol {int(detail[2])} outside the model's alphabet 0..{int(detail[3]) - 1}")
        return buffer[:(n_bits + 7) >> 3].tobytes()
    starts = np.arange(0, n, pc.SEGMENT)
    sizes = np.minimum(starts + pc.SEGMENT, n) - starts
    dc = np.zeros((len(starts), len(layout.keys)), dtype=np.int64)
    ac = np.zeros((len(starts), pc.SEGMENT - 1, len(layout.keys)), dtype=np.int64)
    dc_step, ac_step = pc.dct_steps(layout.steps, q)
    for u, (start, size) in enumerate(zip(starts.tolist(), sizes.tolist())):
        dc[u], ac[u, :size - 1] = pc.dct_levels(values[start:start + size], dc_step, ac_step)
    intra = np.arange(len(starts)) % header.intra_period == 0
    header_bits = _bit_array(*_header_bits(header, n_display, len(masks), mask_tables.bone_table, False))
    tables = pc.vlc_tables()
    detail = np.zeros(1, dtype=np.int64)
    size = (3 * len(header_bits) + len(starts) * (len(list_bits) + 72 * len(layout.keys) * pc.SEGMENT + 512)) * 23 // 22 // 8 + 64
    while True:
        buffer = np.zeros(size, dtype=np.uint8)
        n_bits = writer_kernel.write_dct_stream(
            buffer, header_bits, list_bits, header.header_period, numbers[starts], sizes, intra, dc, ac,
            *tables["dc_intra"].arrays()[:2], *tables["dc_inter"].arrays()[:2], *tables["ac"].arrays()[:2],
            pc.N_CATEGORIES, detail)
        if n_bits != writer_kernel.STATUS_FULL:
            break
        size *= 2
    if n_bits == writer_kernel.STATUS_DCT_LEVEL:
        raise SigncastError(f"DCT level {int(detail[0])} exceeds the largest category")
    if n_bits == writer_kernel.STATUS_DCT_CODE:
        raise SigncastError(f"symbol {int(detail[0])} has no code in this Huffman table")
    return buffer[:(n_bits + 7) >> 3].tobytes()


class _Bits:
    """Fields gathered MSB first into one integer, then written to a BitWriter in one call: the same
    bits (emulation prevention is the writer's, bit by bit) with far fewer calls. Has BitWriter's
    write and write_bit, so the field writers take either."""

    def __init__(self) -> None:
        self.value = 0
        self.n_bits = 0

    def write(self, value: int, n_bits: int) -> None:
        value = int(value)
        if value < 0 or value >> n_bits:
            raise SigncastError(f"value {value} does not fit in {n_bits} bits")
        self.value = (self.value << n_bits) | value
        self.n_bits += n_bits

    def write_bit(self, bit: int) -> None:
        self.value = (self.value << 1) | (1 if bit else 0)
        self.n_bits += 1

    def flush(self, writer: BitWriter) -> BitWriter:
        """Write the gathered bits to `writer`; returns it."""
        writer.write(self.value, self.n_bits)
        self.value = self.n_bits = 0
        return writer


def _write_header(writer: BitWriter, header: BBAHeader, n_frames: int, bones, animatable, fields, tight,
                  skeleton) -> None:
    """The BBA start code and the header (the same bits for the first header and its copies)."""
    writer.start_code(BBA_START_CODE)
    header_start = writer.n_bits - 8               # the CRC covers the start code's last byte
    table = _bone_table_bits(tuple((b, animatable[b]) for b in bones), _exponent_items(skeleton))
    writer.write(*_header_bits(header, n_frames, len(bones), table, tight))
    if tight:
        pc.write_range_fields(writer, fields)
    _write_crc(writer, header_start)


def _header_bits(header: BBAHeader, n_frames: int, n_bones: int, table: tuple[int, int], tight: bool) -> tuple[int, int]:
    """(value, number of bits) of the header's fields after its start code, up to the range fields; table: the
    (value, number of bits) of its bone table (`_bone_table_bits`) of n_bones bones."""
    return _header_field_bits(header.fps, header.coding, header.keyframes, header.q, header.intra_period,
                              header.header_period, n_frames, header.rotation_order, tight, n_bones, table)


@functools.lru_cache(maxsize=256)
def _header_field_bits(fps: float, coding: str, keyframes: bool, q: int, intra_period: int, header_period: int,
                       n_frames: int, rotation_order: int, tight: bool, n_bones: int, table: tuple[int, int]
                       ) -> tuple[int, int]:
    """`_header_bits` of the header's fields (cached: a sweep writes many streams with the same header)."""
    writer = _Bits()
    writer.write(VERSION, 8)
    _write_fps(writer, fps)
    writer.write(0 if coding == "pred" else 1, 2)
    writer.write_bit(int(keyframes))
    writer.write(q, 5)
    writer.write(intra_period, 6)
    writer.write(header_period, 6)
    writer.write(n_frames, FRAME_NUMBER_BITS)
    writer.write(rotation_order, 5)
    writer.write_bit(int(tight))
    writer.write(n_bones, 10)
    writer.write(*table)
    return writer.value, writer.n_bits


@functools.lru_cache(maxsize=256)
def _bit_array(value: int, n_bits: int) -> np.ndarray:
    """(n_bits,) uint8 0/1: value's bits MSB first (read-only; cached)."""
    bits = np.unpackbits(np.frombuffer(value.to_bytes((n_bits + 7) // 8, "big"), dtype=np.uint8))[8 * ((n_bits + 7) // 8) - n_bits:]
    bits.flags.writeable = False
    return bits


@functools.lru_cache(maxsize=64)
def _bone_table_bits(animatable: tuple[tuple[int, int], ...], exponents: tuple[tuple[int, int], ...]) -> tuple[int, int]:
    """(value, number of bits) of the header's bone table: per bone its ID, animatable mask and
    rotation step exponent. animatable: (boneID, mask) pairs in stream order."""
    bits, exponent = _Bits(), dict(exponents)
    for b, mask in animatable:
        bits.write(b, 10)
        _write_animatable(bits, mask)
        bits.write(exponent.get(b, 7), 4)
    return bits.value, bits.n_bits


@functools.lru_cache(maxsize=256)
def _bone_list_bits(masks: tuple[tuple[int, int], ...], animatable: tuple[int, ...]) -> tuple[int, int]:
    """(value, number of bits) of a unit's bone list: NSBB, then per bone its ID and hierarchical mask.
    masks: sorted (boneID, mask) pairs; animatable: each bone's animatable mask."""
    bits = _Bits()
    bits.write(len(masks), 10)
    for (b, mask), allowed in zip(masks, animatable):
        bits.write(b, 10)
        _write_bone_mask(bits, mask, allowed)
    return bits.value, bits.n_bits


def _write(h: BBAHeader, plan: _UnitPlan, intra_flags, levels, bones, animatable, fields, tight, skeleton) -> bytes:
    numbers = plan.numbers
    writer = BitWriter()
    _write_header(writer, h, int(numbers[-1]) + 1, bones, animatable, fields, tight, skeleton)
    models = None
    if h.coding == "pred":
        low_i, high_i = pc.alphabet(fields[0], fields[1], h.q)
        low_p, high_p = pc.alphabet(fields[2], fields[3], h.q)
    tables = pc.vlc_tables() if h.coding == "dct" else None
    previous_dc = None
    n_intra = 0
    for k, (unit, intra) in enumerate(zip(plan.units, intra_flags)):
        muscles = plan.muscles[k]
        if intra:
            if h.header_period and n_intra and n_intra % h.header_period == 0:
                _write_header(writer, h, int(numbers[-1]) + 1, bones, animatable, fields, tight, skeleton)
            n_intra += 1
        writer.start_code(FRAME_START_CODE)
        unit_start = writer.n_bits
        data, writer = writer, _Bits()
        writer.write_bit(int(intra))
        number = int(numbers[unit[0]])
        if intra:
            writer.write(number, FRAME_NUMBER_BITS)
        else:
            writer.write(number % (1 << P_FRAME_NUMBER_BITS), P_FRAME_NUMBER_BITS)
        writer.write(plan.kfi[k], 5)
        if h.coding == "dct":
            writer.write(len(unit) - 1, 4)
        if not intra:
            writer.write_bit(int(plan.same[k]))
        if intra or not plan.same[k]:
            masks = plan.masks[k]
            writer.write(*_bone_list_bits(masks, tuple(animatable[b] for b, _ in masks)))
        writer = writer.flush(data)
        if h.coding == "pred":
            _, _, level, idx = levels[k]
            if intra:
                models = {"I": pc.make_models(low_i, high_i), "P": pc.make_models(low_p, high_p)}
            chosen, low = (models["I"], low_i) if intra else (models["P"], low_p)
            pc.write_levels(writer, level, chosen.subset(idx), low[idx] if len(idx) else low[:0])
        else:
            _, _, dc, ac, _ = levels[k]
            dc_values = dc if intra else dc - previous_dc
            pc.write_dct_blocks(writer, tables, dc_values, intra, ac)
            previous_dc = dc
        writer.write(len(muscles), 10)
        _write_crc(writer, unit_start)
        if muscles:
            writer.start_code(MUSCLE_START_CODE)
            muscle_start = writer.n_bits
            for muscle in muscles:
                writer.write(muscle.muscle_id, 10)
                writer.write(muscle.n_control_points, 6)
                writer.write(muscle.n_knots, 6)
                if len(muscle.mask) != 4 * muscle.n_control_points + muscle.n_knots or sum(muscle.mask) != len(muscle.values):
                    raise SigncastError(f"muscle {muscle.muscle_id}: mask and values do not match NCP/NK")
                for bit in muscle.mask:
                    writer.write_bit(bit)
                for value in muscle.values:
                    writer.write_signed(value, MUSCLE_VALUE_BITS)
            _write_crc(writer, muscle_start)
    writer.start_code(END_CODE)
    return writer.getvalue()


def _write_crc(writer: BitWriter, start_bit: int) -> None:
    """CRC-8 of the raw bits written since start_bit (signcast's; lets a decoder detect a damaged
    frame before it resynchronises)."""
    writer.write(int(crc_kernel.crc8_bytes(writer.buffer, start_bit, writer.n_bits)), 8)   # crc8_bits, no copy


def _check_crc(reader: BitReader, start_bit: int, what: str) -> None:
    expected = int(crc_kernel.crc8_bytes(reader.array, start_bit, reader.pos))   # crc8_bits, a byte at a time
    if reader.read(8) != expected:
        raise SigncastError(f"corrupt BBA stream: {what} fails its CRC check")


# --------------------------------------------------------------------------------- reading

@dataclass
class _DecoderState:
    header: BBAHeader
    n_frames: int                             # display frames of the stream
    bones: dict[int, int]                     # boneID -> animatable mask
    exponents: dict[int, int]
    keys: list[tuple[int, int]]
    fields: np.ndarray | None
    held: np.ndarray | None = None            # (len(keys),) int64 the decoder's values, by header key
    models: dict | None = None
    previous_bones: dict | None = None
    previous_dc: np.ndarray | None = None
    synced: bool = False
    columns: dict = field(default_factory=dict)   # sorted (boneID, mask) pairs -> (layout, header columns)
    animatable: np.ndarray | None = None      # (1024,) int64 animatable mask by boneID, -1: not in the header
    alphabets: tuple | None = None            # predictive: (I low, I high, P low, P high) levels, (len(keys),) each
    previous_layout: tuple | None = None      # _unit_layout of previous_bones
    uniform: dict = field(default_factory=dict)   # _uniform_layout's cache


# version, frame_rate, seconds, frequency_offset, coding, keyframes, Q, intra period, header period, frames,
# rotationOrder, tight_ranges, number of bones: the header's fixed fields, bits each
_HEADER_WIDTHS = np.array([8, 8, 4, 1, 2, 1, 5, 6, 6, FRAME_NUMBER_BITS, 5, 1, 10], dtype=np.int64)


def _read_header(data: bytes, position: int) -> _DecoderState:
    """The header after the BBA start code whose 00 00 01 prefix is at byte `position`: a good header in one
    kernel call (kernels/bba_header.read_header), anything else by `_read_header_checked`, which raises the
    error. Both give the same state for a good header."""
    values = np.zeros(len(_HEADER_WIDTHS), dtype=np.int64)
    status, ids, masks, steps, key_ids, key_bits, fields, alphabets, animatable = header_kernel.read_header(
        np.frombuffer(data, dtype=np.uint8), 8 * (position + 4), 8 * (position + 3), _HEADER_WIDTHS, _GROUP_START,
        pc.RANGE_BITS, pc.DEFAULT_RANGE_FIELD, pc.RANGE_DELTA, values)
    version, rate, seconds, offset, coding, keyframes, q, intra_period, header_period, n_frames, order, tight, \
        _ = values.tolist()
    if status or version != VERSION or rate == 0 or intra_period == 0 or n_frames == 0 or order >= 24:
        return _read_header_checked(data, position)
    id_list = ids.tolist()
    header = BBAHeader("", pc.fps_from_fields(rate, seconds, offset), "pred" if coding == 0 else "dct", q,
                       intra_period, bool(keyframes), order, header_period)
    pred = coding == 0
    return _DecoderState(header, n_frames, dict(zip(id_list, masks.tolist())), dict(zip(id_list, steps.tolist())),
                         list(zip(key_ids.tolist(), key_bits.tolist())), fields if pred else None,
                         animatable=animatable, alphabets=tuple(alphabets) if pred else None)


def _read_header_checked(data: bytes, position: int) -> _DecoderState:
    """`_read_header` field by field, with an error for each way a header can be wrong."""
    reader = BitReader(data, start_byte=position + 4)
    values = np.zeros(len(_HEADER_WIDTHS), dtype=np.int64)    # the fixed fields in one call, checked in order
    n_read = header_kernel.read_fields(reader.array, reader.end_bit, reader.registers, _HEADER_WIDTHS, values)
    version, rate, seconds, offset, coding, keyframes, q, intra_period, header_period, n_frames, order, tight, \
        n_bones = values.tolist()
    if n_read >= 1 and version != VERSION:
        raise SigncastError("unsupported BBA stream version")
    if n_read >= 4:
        fps = pc.fps_from_fields(rate, seconds, offset)
    if n_read >= 5 and coding > 1:
        raise SigncastError(f"corrupt BBA stream: coding type {coding}")
    if n_read >= 11 and (q == 0 or intra_period == 0 or n_frames == 0 or order >= 24):
        raise SigncastError("corrupt BBA stream header")
    if n_read < len(_HEADER_WIDTHS):
        raise SigncastError("truncated stream: it ends inside a field")
    keyframes = bool(keyframes)
    ids, masks, steps = (np.zeros(n_bones, dtype=np.int64) for _ in range(3))
    status = mask_kernel.read_bone_table(reader.array, reader.end_bit, reader.registers, _GROUP_START, ids, masks, steps)
    if status == mask_kernel.TRUNCATED:
        raise SigncastError("truncated stream: it ends inside a field")
    if status == mask_kernel.EMPTY_TYPE:
        raise SigncastError("corrupt BBA stream: an announced motion type has no elementary motion")
    id_list, mask_list = ids.tolist(), masks.tolist()
    bones, exponents = dict(zip(id_list, mask_list)), dict(zip(id_list, steps.tolist()))
    if len(bones) == n_bones:                   # no boneID twice: the keys in one kernel call
        keys = list(zip(*(a.tolist() for a in header_kernel.header_keys(ids, masks))))
    else:
        keys = [(b, k) for b in sorted(bones) for k in _bits(bones[b])]
    fields = None
    if coding == 0 and tight:                   # param_coding.read_range_fields, on local reader state
        fields = np.zeros((4, len(keys)), dtype=np.int64)
        status = header_kernel.read_range_fields(reader.array, reader.end_bit, reader.registers, fields, pc.RANGE_BITS)
        if status == header_kernel.END_OF_DATA:
            raise SigncastError("truncated stream: it ends inside a field")
        if status:
            raise SigncastError("corrupt stream: missing marker bit in the range fields")
    elif coding == 0:
        fields = np.full((4, len(keys)), pc.DEFAULT_RANGE_FIELD, dtype=np.int64)
    _check_crc(reader, 8 * (position + 3), "the header")
    if not reader.at_start_code():
        raise SigncastError("corrupt BBA stream: header does not end at a start code")
    header = BBAHeader("", fps, "pred" if coding == 0 else "dct", q, intra_period, keyframes, order, header_period)
    animatable = np.full(1024, -1, dtype=np.int64)
    if len(bones) == n_bones:                   # no boneID twice: the arrays as read
        animatable[ids] = masks
    else:
        animatable[list(bones)] = list(bones.values())
    alphabets = None if fields is None else pc.pf.alphabets(fields, q, pc.RANGE_DELTA)   # pc.alphabet of I, P
    return _DecoderState(header, n_frames, bones, exponents, keys, fields, animatable=animatable, alphabets=alphabets)


def _unit_number(field: int, intra: bool, kfi: int, n: int, display_end: int, state: _DecoderState,
                 strict: bool) -> int:
    """Display frame of a unit's first frame, from its frame-number field. The unit (n frames, the
    KeyFrameIndex frames before it interpolated) must start at display_end, the frame after the
    last one placed (resilient: at or after it), inside the stream's frame count."""
    expected = display_end + kfi
    if not intra and field != expected % (1 << P_FRAME_NUMBER_BITS):
        raise SigncastError("corrupt BBA stream: a predicted unit does not follow its reference")
    number = field if intra else expected
    start = number - kfi
    if start < display_end or (strict and start != display_end) or (kfi and start == 0) or number + n > state.n_frames:
        raise SigncastError(f"corrupt BBA stream: a unit numbered {number} after frame {display_end - 1}, "
                            f"in a stream of {state.n_frames} frames")
    return number


@dataclass
class _Unit:
    """A decoded unit as arrays: KeyFrameIndex of its first frame, boneID -> mask, the layout of those
    masks, rows (n, P) int64 the values of its n frames in layout order, and its muscle updates."""
    kfi: int
    bones: dict[int, int]
    layout: _Layout
    rows: np.ndarray
    muscles: list[MuscleUpdate]


def _unit_frames(unit: _Unit) -> list[BBAFrame]:
    """The unit's BBAFrames (muscles on the first)."""
    frames = []
    layout = unit.layout
    for row in unit.rows.tolist():
        values, j = {}, 0
        for b, count in zip(layout.bones, layout.counts):
            values[b] = row[j:j + count]
            j += count
        frames.append(BBAFrame(unit.kfi, dict(unit.bones), values, unit.muscles if not frames else []))
    return frames


def _read_unit(reader: BitReader, state: _DecoderState, skip_muscles: bool, display_end: int,
               strict: bool) -> tuple[int, list[BBAFrame]]:
    """(display frame of the unit's first frame, its frames)."""
    number, unit = _read_unit_rows(reader, state, skip_muscles, display_end, strict)
    return number, _unit_frames(unit)


def _read_unit_rows(reader: BitReader, state: _DecoderState, skip_muscles: bool, display_end: int,
                    strict: bool) -> tuple[int, _Unit]:
    """(display frame of the unit's first frame, the unit)."""
    h = state.header
    unit_start = reader.pos
    intra = bool(reader.read_bit())
    number_field = reader.read(FRAME_NUMBER_BITS if intra else P_FRAME_NUMBER_BITS)
    kfi = reader.read(5)
    n_frames = reader.read(4) + 1 if h.coding == "dct" else 1
    same = False if intra else bool(reader.read_bit())
    if not intra and not state.synced:
        raise SigncastError("predicted frame without a decoded reference")
    if same:
        bones = dict(state.previous_bones)
        layout, idx = state.previous_layout
    else:
        bones = _read_unit_bones(reader, state)
        layout, idx = _unit_layout(state, bones)
    keys, steps = layout.keys, layout.steps
    if h.coding == "pred":
        low_i, high_i, low_p, high_p = state.alphabets
        if intra:
            state.models = {"I": pc.make_models(low_i, high_i), "P": pc.make_models(low_p, high_p)}
        chosen, low = (state.models["I"], low_i) if intra else (state.models["P"], low_p)
        level = pc.read_levels(reader, chosen.subset(idx), low[idx] if len(idx) else low[:0])
        if intra:
            recon = level * steps * h.q
        else:
            recon = _fold(state.held[idx] + level * steps * h.q, layout.is_angle)
        rows = recon[None]
    else:
        tables = pc.vlc_tables()
        dc, ac = pc.read_dct_blocks(reader, tables, intra, n_frames, len(keys))
        if not intra:
            if state.previous_dc is None or len(state.previous_dc) != len(dc):
                raise SigncastError("corrupt BBA stream: DCT segment without a DC reference")
            dc += state.previous_dc
        dc_step, ac_step = pc.dct_steps(steps, h.q)
        rows = pc.dct_reconstruct(dc, ac, dc_step, ac_step)
    if len(rows) and np.abs(rows).max(initial=0) > VALUE_LIMIT:
        raise SigncastError(f"corrupt BBA stream: a decoded bone value beyond +-{VALUE_LIMIT}")
    n_muscles = reader.read(10)
    _check_crc(reader, unit_start, "a frame")
    number = _unit_number(number_field, intra, kfi, len(rows), display_end, state, strict)
    muscles = []
    if n_muscles and not skip_muscles:
        if reader.read_start_code() != MUSCLE_START_CODE:
            raise SigncastError("corrupt BBA frame: muscle data without its start code")
        muscle_start = reader.pos
        for _ in range(n_muscles):
            muscle_id, ncp, nk = reader.read(10), reader.read(6), reader.read(6)
            mask = [reader.read_bit() for _ in range(4 * ncp + nk)]
            values = [reader.read_signed(MUSCLE_VALUE_BITS) for _ in range(sum(mask))]
            muscles.append(MuscleUpdate(muscle_id, ncp, nk, mask, values))
        _check_crc(reader, muscle_start, "muscle data")
    if h.coding == "dct":
        state.previous_dc = dc
    state.held[idx] = rows[-1]
    state.previous_bones = bones
    state.previous_layout = (layout, idx)
    state.synced = True
    return number, _Unit(kfi, bones, layout, rows, muscles)


def _read_unit_bones(reader: BitReader, state: _DecoderState) -> dict[int, int]:
    """A unit's bone list: boneID -> mask (bit k = MASK_FIELDS[k]), in stream order."""
    ids, masks = _read_unit_bone_arrays(reader, state)
    return dict(zip(ids.tolist(), masks.tolist()))


def _read_unit_bone_arrays(reader: BitReader, state: _DecoderState) -> tuple[np.ndarray, np.ndarray]:
    """A unit's bone list as read: boneIDs and masks (NSBB,) int64, in stream order."""
    ids, masks, result = np.zeros(1023, dtype=np.int64), np.zeros(1023, dtype=np.int64), np.zeros(2, dtype=np.int64)
    status = mask_kernel.read_unit_bones(reader.array, reader.end_bit, reader.registers, _GROUP_START, state.animatable,
                                         ids, masks, result)
    if status == mask_kernel.TRUNCATED:
        raise SigncastError("truncated stream: it ends inside a field")
    if status == mask_kernel.UNKNOWN_BONE:
        raise SigncastError(f"corrupt BBA frame: bone {int(result[1])} is not in the stream header")
    n = int(result[0])
    return ids[:n].copy(), masks[:n].copy()


def _unit_layout(state: _DecoderState, bones: dict[int, int]) -> tuple[_Layout, np.ndarray]:
    """The layout of a unit's bone masks and the header columns (indices into state.keys) of its keys."""
    masks = tuple(sorted(bones.items()))
    cached = state.columns.get(masks)
    if cached is None:
        if state.held is None:
            state.held = np.zeros(len(state.keys), dtype=np.int64)
        layout = _layout(masks, tuple(sorted(state.exponents.items())))
        index = {key: j for j, key in enumerate(state.keys)}
        cached = state.columns[masks] = (layout, np.array([index[key] for key in layout.keys], dtype=np.int64))
    return cached


def _check_unit_end(reader: BitReader, end_byte: int) -> None:
    """The unit's data must end with next_start_code() stuffing exactly at the next start code."""
    remaining = 8 * end_byte - reader.pos
    stuffing = [(reader.data[p >> 3] >> (7 - (p & 7))) & 1 for p in range(reader.pos, 8 * end_byte)]
    if not 1 <= remaining <= 8 or stuffing != [0] + [1] * (remaining - 1):
        raise SigncastError("corrupt BBA frame: its data does not end at the next start code")


def _find_header(data: bytes, codes: list[tuple[int, int]], resilient: bool) -> _DecoderState:
    """The stream header: the first one (strict), or the first intact copy (resilient)."""
    if not resilient:
        if BitReader(data).read_start_code() != BBA_START_CODE:
            raise SigncastError("not a BBA stream: it does not start with the BBA start code")
        return _read_header(data, codes[0][0])
    for position, code in codes:
        if code == BBA_START_CODE:
            try:
                return _read_header(data, position)
            except SigncastError:
                continue
    raise SigncastError("corrupt BBA stream: no intact stream header (and no header copy)")


def _conceal(frames: list[BBAFrame], n: int) -> None:
    """Append n frames holding the last frame (the rest pose when there is none)."""
    hold = frames[-1] if frames else BBAFrame(0, {}, {})
    frames.extend(BBAFrame(0, dict(hold.bones), dict(hold.values)) for _ in range(n))


def read_stream(data: bytes, *, resilient: bool = False, skip_muscles: bool = False) -> tuple[BBAStream, list[int]]:
    """Decode a binary BBA stream. Returns the stream (reconstructed values) and the display
    frames that were lost (indices of the frames of stream_to_motion's Motion; without key
    frames, also of the returned frames).

    resilient: a damaged unit is dropped and decoding resumes at the next start code (predicted
    units after it are lost until the next intra unit); each good unit is placed at its frame
    number, and every frame not decoded is concealed by holding the last good frame (KeyFrameIndex
    0), so the stream has its frame count. A damaged header is replaced by an intact header copy
    when the stream has one. Without it, damage raises SigncastError.
    skip_muscles: ignore muscle data (a weak terminal), jumping to the next frame start code.
    Streams above MAX_DECODED_VALUES frames x values are refused before their frames are decoded."""
    state, records, lost = _read_units(data, resilient, skip_muscles)
    frames: list[BBAFrame] = []
    for record in records:
        if isinstance(record, int):
            _conceal(frames, record)
        else:
            frames.extend(_unit_frames(record))
    return BBAStream(state.header, frames), lost


def _read_units(data: bytes, resilient: bool, skip_muscles: bool
                ) -> tuple[_DecoderState, list[_Unit | int], list[int]]:
    """read_stream's decoding: (decoder state, the decoded units in display order with the number of
    frames to conceal (int) where units were lost, the lost display frames)."""
    data = bytes(data)
    codes = find_start_codes(data)
    end_position = len(data) - 4
    if not resilient:
        if not codes or codes[-1][1] != END_CODE:
            raise SigncastError("truncated BBA stream: the end code is missing")
        if codes[-1][0] != end_position:
            raise SigncastError("corrupt BBA stream: data after the end code")
    state = _find_header(data, codes, resilient)
    _check_size(state.n_frames, len(state.keys))
    # The stream ends with its 4-byte end code; in resilient mode also when that code is damaged.
    codes = [(p, c) for p, c in codes if p < end_position] + [(end_position, END_CODE)]
    header_span = None if resilient else data[codes[0][0]:codes[1][0]]
    records: list[_Unit | int] = []
    lost: list[int] = []
    display_end = 0
    for k, (position, code) in enumerate(codes[:-1]):
        if code == MUSCLE_START_CODE:
            continue
        if code == BBA_START_CODE:
            if resilient or data[position:codes[k + 1][0]] == header_span:
                continue
            raise SigncastError("corrupt BBA stream: a header copy differs from the header")
        if code != FRAME_START_CODE:
            if resilient:
                continue
            raise SigncastError(f"corrupt BBA stream: unexpected start code 0x{code:02X}")
        end = codes[k + 1][0]
        has_muscles = codes[k + 1][1] == MUSCLE_START_CODE
        unit_end = codes[k + 2][0] if has_muscles and not skip_muscles else end
        reader = BitReader(data, start_byte=position + 4, end_byte=unit_end)
        try:
            number, unit = _read_unit_rows(reader, state, skip_muscles or not has_muscles, display_end, not resilient)
            _check_unit_end(reader, unit_end)
        except SigncastError:
            if not resilient:
                raise
            state.synced = False
            state.previous_dc = None
            continue
        start = number - unit.kfi
        if start > display_end:
            records.append(start - display_end)
            lost.extend(range(display_end, number))
        records.append(unit)
        display_end = number + len(unit.rows)
    if display_end < state.n_frames:
        if not resilient:
            raise SigncastError(f"corrupt BBA stream: {display_end} of its {state.n_frames} frames")
        records.append(state.n_frames - display_end)
        lost.extend(range(display_end, state.n_frames))
    return state, records, lost


# --------------------------------------------------------------------------------- live decoding

def split_units(data: bytes) -> list[bytes]:
    """The stream cut before each of its start codes except the muscle start code, for a packetiser
    that sends whole units: the header (with any bytes before it), each unit (its frame start code
    to the next unit, muscle data included), each header copy, the end code. Each piece ends with
    the next_start_code() stuffing before the next piece; b"".join(pieces) is the stream."""
    data = bytes(data)
    cuts = [position for position, code in find_start_codes(data) if code != MUSCLE_START_CODE]
    bounds = [0, *cuts[1:], len(data)]
    return [data[a:b] for a, b in itertools.pairwise(bounds) if b > a]


class LiveDecoder:
    """Resilient decoding of a BBA stream unit by unit, as a live receiver gets them (split_units'
    pieces, some possibly lost or damaged): each piece is decoded in time proportional to its size,
    with the decoder state read_stream(resilient=True) keeps between units.

    header: the stream's header piece; None to wait for one (a header copy, or the header fed
    first). SigncastError if it is given and damaged.
    feed(piece) -> [(display frame number, BBAFrame)] of the frames the piece decoded (none for a
    header, a damaged unit, or a predicted unit whose reference was lost). `lost` lists the display
    frames known lost so far: the frames between the last decoded unit and a later one (held by
    read_stream), and after finish() (or the end code) those after the last decoded unit; `dropped`
    counts the pieces that decoded to nothing."""

    def __init__(self, header: bytes | None = None, *, skip_muscles: bool = False) -> None:
        self.state: _DecoderState | None = None
        self.skip_muscles = skip_muscles
        self.display_end = 0
        self.lost: list[int] = []
        self.dropped = 0
        self.finished = False
        if header is not None:
            self.state = self._read_header_piece(bytes(header))

    @property
    def header(self) -> BBAHeader | None:
        return None if self.state is None else self.state.header

    @property
    def n_frames(self) -> int | None:
        """Display frames of the stream (from its header), None before a header arrived."""
        return None if self.state is None else self.state.n_frames

    @staticmethod
    def _first_code(piece: bytes, codes: list[tuple[int, int]]) -> tuple[int, int | None]:
        """(byte offset, code) of the piece's opening start code: at byte 0, or at byte 1 after the
        whole stuffing byte 0111 1111 (the stream's first piece); code None when it has none."""
        if codes and (codes[0][0] == 0 or (codes[0][0] == 1 and piece[0] == 0x7F)):
            return codes[0]
        return 0, None

    @classmethod
    def _read_header_piece(cls, piece: bytes) -> _DecoderState:
        codes = find_start_codes(piece)
        position, code = cls._first_code(piece, codes)
        if code != BBA_START_CODE:
            raise SigncastError("not a BBA stream header: it does not start with the BBA start code")
        # _read_header checks that a start code follows the header: the piece ends before it.
        end = codes[1][0] if len(codes) > 1 else len(piece)
        state = _read_header(piece[:end] + bytes([0, 0, 1, END_CODE]), position)
        _check_size(state.n_frames, len(state.keys))
        return state

    def feed(self, piece: bytes) -> list[tuple[int, BBAFrame]]:
        """Decode one piece of split_units; see the class docstring."""
        piece = bytes(piece)
        codes = find_start_codes(piece)
        position, code = self._first_code(piece, codes)
        if code == BBA_START_CODE:
            if self.state is None:
                try:
                    self.state = self._read_header_piece(piece)
                except SigncastError:
                    self.dropped += 1
            return []
        if code == END_CODE:
            self.finish()
            return []
        if code != FRAME_START_CODE or self.state is None or self.finished:
            self.dropped += 1
            return []
        state = self.state
        has_muscles = len(codes) > 1 and codes[1][1] == MUSCLE_START_CODE
        end = codes[1][0] if len(codes) > 1 else len(piece)
        unit_end = (codes[2][0] if len(codes) > 2 else len(piece)) if has_muscles and not self.skip_muscles else end
        reader = BitReader(piece, start_byte=position + 4, end_byte=unit_end)
        try:
            number, frames = _read_unit(reader, state, self.skip_muscles or not has_muscles, self.display_end, False)
            _check_unit_end(reader, unit_end)
        except SigncastError:
            state.synced = False
            state.previous_dc = None
            self.dropped += 1
            return []
        if number - frames[0].kfi > self.display_end:
            self.lost.extend(range(self.display_end, number))
        self.display_end = number + len(frames)
        return [(number + k, frame) for k, frame in enumerate(frames)]

    def finish(self) -> list[int]:
        """End of the stream: the frames after the last decoded unit are lost (added to `lost`,
        which is returned). Once finished, further units are dropped."""
        if not self.finished and self.state is not None and self.display_end < self.state.n_frames:
            self.lost.extend(range(self.display_end, self.state.n_frames))
            self.display_end = self.state.n_frames
        self.finished = True
        return self.lost


# --------------------------------------------------------------------------------- Motion glue

def motion_to_stream(motion: Motion, q: int, coding: str = "pred", *, keyframes: bool = False,
                     threshold_rad: float | None = None, intra_period: int | None = None,
                     rotation_order: int = 0, header_period: int = 0, name: str = "signcast",
                     skeleton: Skeleton | None = None) -> BBAStream:
    """The encoder's analysis: bone IDs (skeleton indices), Euler values (1e-5 rad, mm), the mask
    of the values the motion moves (the same in every frame), and key frames (KeyFrameIndex) when
    asked.
    header_period: repeat the header before every n-th intra unit (0: never), so a resilient
    decoder survives a damaged header."""
    header, mask, kfi, values = _motion_arrays(motion, q, coding, keyframes, threshold_rad, intra_period,
                                               rotation_order, header_period, name, skeleton or load_avatar().skeleton)
    spans, start = {}, 0                                # bone -> its values' slice of a row (stream order)
    for b in sorted(mask):
        spans[b] = (start, start + mask[b].bit_count())
        start = spans[b][1]
    frames = [BBAFrame(k, dict(mask), {b: row[a:e] for b, (a, e) in spans.items()})
              for k, row in zip(kfi.tolist(), values.tolist())]
    return BBAStream(header, frames)


def encode_motion(motion: Motion, q: int, coding: str = "pred", *, keyframes: bool = False,
                  skeleton: Skeleton | None = None) -> bytes:
    """write_stream(motion_to_stream(motion, q, coding, keyframes=keyframes)) without building the
    per-frame BBAFrames: the same bytes."""
    skeleton = skeleton or load_avatar().skeleton
    header, mask, kfi, values = _motion_arrays(motion, q, coding, keyframes, None, None, 0, 0, "signcast", skeleton)
    return _write_arrays(header, mask, kfi, values, skeleton)


def _to_euler(q: np.ndarray, order: str) -> np.ndarray:
    """rotations.to_euler(q, order) of quaternions (..., 4) in one compiled pass (media.rotations.euler_split: the
    same angles to rounding, a bone held from the previous frame not recomputed)."""
    return rotations.euler_split(q, order)


def _motion_arrays(motion: Motion, q: int, coding: str, keyframes: bool, threshold_rad: float | None,
                   intra_period: int | None, rotation_order: int, header_period: int, name: str,
                   skeleton: Skeleton) -> tuple[BBAHeader, _MaskSet, np.ndarray, np.ndarray]:
    """motion_to_stream's analysis as arrays: (header, boneID -> mask of every frame (`_MaskSet`), kfi (K,) int64,
    values (K, P) int64 in stream order: bones sorted, bits ascending). The values and the mask are
    comparisons/params/bba_values.py `motion_values` (`_motion_arrays_numpy` is the same in NumPy; tests compare them)."""
    q = pc.check_q(q)
    if keyframes and coding != "pred":
        raise SigncastError("key frames are coded with the predictive BBA coder only")
    plan = _column_plan(tuple(motion.bone_names), skeleton)
    if keyframes:
        keys_frames = kf.key_frames(motion, threshold_rad if threshold_rad is not None else kf.default_threshold_rad(q))
        angles = _to_euler(motion.rotations[keys_frames], ORDER_NAMES[rotation_order])    # (K, B, 3)
        translation = motion.root_translation[keys_frames]
        gaps = np.diff(keys_frames, prepend=keys_frames[0] - 1) - 1       # KeyFrameIndex; 0 for the first
    else:
        angles = _to_euler(motion.rotations, ORDER_NAMES[rotation_order])
        translation = motion.root_translation
        gaps = np.zeros(motion.n_frames, dtype=np.int64)
    values, bones, masks, first_sent = split_kernel.motion_values(
        angles, np.ascontiguousarray(translation, dtype=np.float64), plan[1], plan[2], plan[3], q,
        bap_table.ROTATION_UNIT_RAD, bap_table.TRANSLATION_UNIT_M, ANGLE_PERIOD, *plan[5:])
    # the masks in the order the NumPy form fills its dict (by each bone's first sent column)
    ranked = np.argsort(first_sent, kind="stable")
    mask = _mask_set_of(bones[ranked], masks[ranked], skeleton)
    if intra_period is None:
        intra_period = DEFAULT_INTRA_PERIOD if coding == "pred" else DEFAULT_INTRA_SEGMENTS
    header = BBAHeader(name, motion.fps, coding, q, intra_period, keyframes, rotation_order, header_period)
    return header, mask, gaps.astype(np.int64), values


def _motion_arrays_numpy(motion: Motion, q: int, coding: str, keyframes: bool, threshold_rad: float | None,
                         intra_period: int | None, rotation_order: int, header_period: int, name: str,
                         skeleton: Skeleton) -> tuple[BBAHeader, dict[int, int], np.ndarray, np.ndarray]:
    """`_motion_arrays` in NumPy: its readable reference (tests compare the two)."""
    q = pc.check_q(q)
    if keyframes and coding != "pred":
        raise SigncastError("key frames are coded with the predictive BBA coder only")
    order = ORDER_NAMES[rotation_order]
    columns, source, steps, is_angle, first_of = _column_plan(tuple(motion.bone_names), skeleton)[:5]
    keys_frames = np.arange(motion.n_frames)
    if keyframes:
        keys_frames = kf.key_frames(motion, threshold_rad if threshold_rad is not None else kf.default_threshold_rad(q))
    # Only the key frames' angles are needed (each frame's are its own: the same numbers as all frames' rows).
    angles = _to_euler(motion.rotations[keys_frames] if keyframes else motion.rotations, order)    # (K, B, 3)
    rot = np.round(angles / bap_table.ROTATION_UNIT_RAD).astype(np.int64)
    trans = np.round(motion.root_translation[keys_frames] / bap_table.TRANSLATION_UNIT_M).astype(np.int64)
    # value columns (boneID, bit) (_column_plan) from [root translation, each bone's three angles]
    values = np.concatenate([trans, rot.reshape(len(keys_frames), 3 * rot.shape[1])], axis=1)[:, source]
    if intra_period is None:
        intra_period = DEFAULT_INTRA_PERIOD if coding == "pred" else DEFAULT_INTRA_SEGMENTS
    # Every frame carries every value that is ever sent (not only those changing in its intra
    # period), so an intra unit refreshes the whole pose: after a loss, the frames from the next
    # intra unit on are exact, and the frames a decoder reports lost are the only wrong ones.
    # (a value out of int64's range, -2**63 after the cast, is sent too, so that the writer rejects it)
    sent = np.flatnonzero(np.any((pc.quantize(_fold(values, is_angle), steps * q) != 0)
                                 | (values == np.iinfo(np.int64).min), axis=0))
    mask: dict[int, int] = {}
    for c in sent.tolist():
        b, bit = columns[c]
        mask[b] = mask.get(b, 0) | (1 << bit)
    sent_columns = [first_of[(b, bit)] for b in sorted(mask) for bit in _bits(mask[b])]
    gaps = np.diff(keys_frames, prepend=keys_frames[0] - 1) - 1           # KeyFrameIndex; 0 for the first
    header = BBAHeader(name, motion.fps, coding, q, intra_period, keyframes, rotation_order, header_period)
    return header, mask, gaps.astype(np.int64), np.ascontiguousarray(values[:, sent_columns], dtype=np.int64)


_COLUMN_PLANS: dict[tuple, tuple] = {}     # _column_plan's cache: (bone names, id(skeleton)) -> (skeleton, plan)


def _column_plan(bone_names: tuple[str, ...], skeleton: Skeleton) -> tuple:
    """The candidate value columns of a Motion with these bones, cached: (columns: (boneID, bit) of each,
    source (C,) int64: each column's index in [root translation (3), angles of bone j axis a (3 j + a)],
    steps (C,) int64 base steps, is_angle (C,) bool, first_of: (boneID, bit) -> its first column; and as
    comparisons/params/bba_values.py `motion_values` takes them: first (C,) int64 each column's first_of, key_order (U,)
    int64 the first columns sorted by (boneID, bit), key_bone and key_bit (U,) int64 theirs). The
    columns: per bone in the Motion's order, the root's translation before the root's angles, then the
    three angles; the root's translation last when the Motion does not carry the root."""
    cached = _COLUMN_PLANS.get((bone_names, id(skeleton)))
    if cached is not None and cached[0] is skeleton:
        return cached[1]
    bone_ids = [skeleton.index(name_) for name_ in bone_names]
    root = int(np.flatnonzero(skeleton.parents < 0)[0])
    columns, source = [], []
    for j, b in enumerate(bone_ids):
        if b == root:
            for axis, bit in enumerate(TRANSLATION_BITS):
                columns.append((b, bit))
                source.append(axis)
        for axis, bit in enumerate(ROTATION_BITS):
            columns.append((b, bit))
            source.append(3 + 3 * j + axis)
    if root not in bone_ids:
        for axis, bit in enumerate(TRANSLATION_BITS):
            columns.append((root, bit))
            source.append(axis)
    exponents = _rotation_step_exponents(skeleton)
    steps = np.array([2 if bit in TRANSLATION_BITS else 1 << exponents.get(b, 7) for b, bit in columns], dtype=np.int64)
    first_of = {key: c for c, key in reversed(list(enumerate(columns)))}
    keys = sorted(first_of)
    plan = (columns, np.array(source, dtype=np.int64), steps, _is_angle(columns), first_of,
            np.array([first_of[key] for key in columns], dtype=np.int64),
            np.array([first_of[key] for key in keys], dtype=np.int64),
            np.array([b for b, _ in keys], dtype=np.int64), np.array([bit for _, bit in keys], dtype=np.int64))
    for array in plan[1:4] + plan[5:]:
        array.flags.writeable = False
    if len(_COLUMN_PLANS) >= 64:
        _COLUMN_PLANS.clear()
    _COLUMN_PLANS[(bone_names, id(skeleton))] = (skeleton, plan)
    return plan


def _runs(frames: list[BBAFrame]) -> list[tuple[int, int]]:
    """[start, stop) of the runs of consecutive frames with equal bone masks."""
    starts = [0] + [t for t in range(1, len(frames)) if frames[t].bones != frames[t - 1].bones]
    return list(zip(starts, starts[1:] + [len(frames)]))


def stream_to_motion(stream: BBAStream, skeleton: Skeleton | None = None) -> Motion:
    """Motion of the decoded stream: held values, Euler -> quaternions, key frames expanded."""
    skeleton = skeleton or load_avatar().skeleton
    frames = stream.frames
    runs = []
    for start, stop in _runs(frames):
        bones = frames[start].bones
        sent = sorted(bones)
        n_keys = sum(bones[b].bit_count() for b in sent)
        flat = np.array([list(itertools.chain.from_iterable(map(frame.values.__getitem__, sent)))
                         for frame in frames[start:stop]], dtype=np.float64).reshape(stop - start, n_keys)
        runs.append((bones, flat))
    kfi = np.array([frame.kfi for frame in frames], dtype=np.int64)
    return _motion_of_runs(stream.header, runs, kfi, skeleton)


def decode_motion(data: bytes, skeleton: Skeleton | None = None) -> Motion:
    """stream_to_motion(read_stream(data)[0]) without building the per-frame BBAFrames: the same Motion,
    the same SigncastErrors."""
    skeleton = skeleton or load_avatar().skeleton
    data = bytes(data)
    uniform = _read_uniform(data)
    if uniform is not None:
        state, bones, rows, kfi = uniform
        return _motion_of_runs(state.header, [(bones, rows.astype(np.float64))], kfi, skeleton)
    state, records, _ = _read_units(data, False, False)
    runs: list[tuple[dict[int, int], list[np.ndarray]]] = []
    kfi = np.zeros(sum(len(unit.rows) for unit in records), dtype=np.int64)
    t = 0
    for unit in records:                        # strict decoding: every record is a unit
        if not runs or unit.bones != runs[-1][0]:
            runs.append((unit.bones, []))
        runs[-1][1].append(unit.rows)
        kfi[t:t + len(unit.rows)] = unit.kfi     # every frame of a unit has its KeyFrameIndex, as in read_stream
        t += len(unit.rows)
    return _motion_of_runs(state.header, [(bones, np.concatenate(rows).astype(np.float64)) for bones, rows in runs],
                           kfi, skeleton)


@dataclass(frozen=True, eq=False)
class BBALevels:
    """The integers a BBA stream defines, before any rotation arithmetic: header; kfi (F,) int64
    KeyFrameIndex of every coded frame (F frames: key frames only when header.keyframes); bone_ids (B,)
    int64 ascending and bone_masks (B,) int64 (bit k = MASK_FIELDS[k]) of the frames' one bone list;
    values (F, P) int64 in stream order (bones ascending, mask bits ascending): angles in 1e-5 rad,
    translations in mm. This is what tests/test_conformance.py pins exactly."""
    header: BBAHeader
    kfi: np.ndarray
    bone_ids: np.ndarray
    bone_masks: np.ndarray
    values: np.ndarray


def decode_levels(data: bytes) -> BBALevels:
    """The decoder's integer output of a strict (non-resilient) decode of a BBA stream whose frames all
    carry one bone list (what encode_motion writes), muscle data ignored: the fast reader (_read_uniform)
    when it takes the stream, otherwise read_stream's frames. SigncastError on damage, and for a stream whose
    bone list changes between frames (read_stream returns those frames one by one)."""
    data = bytes(data)
    uniform = _read_uniform(data)
    if uniform is not None:
        state, bones, rows, kfi = uniform
        header = state.header
    else:
        stream, _ = read_stream(data, skip_muscles=True)
        header, frames = stream.header, stream.frames
        bones = frames[0].bones if frames else {}
        if any(frame.bones != bones for frame in frames):
            raise SigncastError("the stream's bone list changes between frames: read it with read_stream")
        rows = np.array([_flat_values(frame) for frame in frames], dtype=np.int64).reshape(
            len(frames), sum(mask.bit_count() for mask in bones.values()))
        kfi = np.array([frame.kfi for frame in frames], dtype=np.int64)
    ids = np.array(sorted(bones), dtype=np.int64)
    masks = np.array([bones[b] for b in sorted(bones)], dtype=np.int64)
    return BBALevels(header, kfi.astype(np.int64), ids, masks, rows.astype(np.int64))


def _read_uniform(data: bytes) -> tuple[_DecoderState, dict[int, int], np.ndarray, np.ndarray] | None:
    """Strict decoding (_read_units(data, False, False)) of a stream whose units all carry the first unit's
    bone list and no muscle data, every unit in one kernel call (comparisons/params/bba_units.py): (decoder state,
    boneID -> mask, values (F, P) int64 of every frame in layout order, KeyFrameIndex (F,) int64 of every
    frame). None for any other stream, and for any damage: the unit-by-unit reader then raises its error."""
    try:
        codes = find_start_codes(data)
        if (len(codes) < 3 or codes[-1] != (len(data) - 4, END_CODE) or codes[0] != (1, BBA_START_CODE)
                or data[0] != 0x7F or codes[1][1] != FRAME_START_CODE):
            return None
        state = _uniform_header(data)
        header_span = data[codes[0][0]:codes[1][0]]
        positions, ends = [], []                       # each unit's start code and the next start code
        for k, (position, code) in enumerate(codes[1:-1], start=1):
            if code == FRAME_START_CODE:
                positions.append(position)
                ends.append(codes[k + 1][0])
            elif code != BBA_START_CODE or data[position:codes[k + 1][0]] != header_span:
                return None
        reader = BitReader(data, start_byte=codes[1][0] + 4, end_byte=codes[2][0])
        if not reader.read_bit():
            return None
        reader.read(FRAME_NUMBER_BITS + 5 + (4 if state.header.coding == "dct" else 0))
        ids, masks = _read_unit_bone_arrays(reader, state)
    except SigncastError:
        return None
    bones = dict(zip(ids.tolist(), masks.tolist()))
    layout, idx, alphabets = _uniform_layout(state, bones)
    starts = 8 * np.array(positions, dtype=np.int64) + 32
    ends = 8 * np.array(ends, dtype=np.int64)
    array = np.frombuffer(data, dtype=np.uint8)
    h = state.header
    n_units = len(starts)
    if h.coding == "pred":
        if alphabets is None:
            return None
        low_i, sizes_i, low_p, sizes_p = alphabets
        rows = np.empty((n_units, len(idx)), dtype=np.int64)
        kfi = np.empty(n_units, dtype=np.int64)
        if unit_kernel.read_predictive_units(array, starts, ends, _GROUP_START, state.animatable, ids, masks,
                                             layout.steps, layout.is_angle, h.q, VALUE_LIMIT, ANGLE_PERIOD, low_i,
                                             sizes_i, low_p, sizes_p, pc.MAX_TOTAL, state.n_frames, rows, kfi):
            return None
        return state, bones, rows, kfi
    tables = pc.vlc_tables()
    dc = np.zeros((n_units, len(idx)), dtype=np.int64)
    ac = np.zeros((n_units, pc.SEGMENT - 1, len(idx)), dtype=np.int64)
    sizes, unit_kfi = np.empty(n_units, dtype=np.int64), np.empty(n_units, dtype=np.int64)
    readers = tuple(tables[name].arrays()[2:] for name in ("dc_intra", "dc_inter", "ac"))
    luts = _VLC_LUTS.get(id(tables))            # keyed on the fixed tables, not on the stream
    if luts is None or luts[0] is not tables:
        luts = _VLC_LUTS[id(tables)] = (tables, tuple(unit_kernel.huffman_lut(*reader) for reader in readers))
    if unit_kernel.read_dct_units(array, starts, ends, _GROUP_START, state.animatable, ids, masks, *readers, luts[1],
                                  pc.N_CATEGORIES, state.n_frames, dc, ac, sizes, unit_kfi):
        return None
    dc_step, ac_step = pc.dct_steps(layout.steps, h.q)
    segments = [pc.dct_reconstruct(dc[u], ac[u, :n - 1], dc_step, ac_step) for u, n in enumerate(sizes.tolist())]
    rows = np.concatenate(segments)
    if len(rows) and np.abs(rows).max(initial=0) > VALUE_LIMIT:
        return None
    return state, bones, rows, np.repeat(unit_kfi, sizes)


def _uniform_header(data: bytes) -> _DecoderState:
    """_find_header(data, codes, False) and _check_size of a stream that starts with 0x7F and its BBA start
    code at byte 1 (raises SigncastError on damage)."""
    state = _read_header(data, 1)
    _check_size(state.n_frames, len(state.keys))
    return state


def _uniform_layout(state: _DecoderState, bones: dict[int, int]) -> tuple[_Layout, np.ndarray, tuple | None]:
    """The layout of a unit's bones, their header columns, and (predictive) the alphabets of those values:
    (intra first level, intra sizes, predicted first level, predicted sizes) (P,) int64 each, None when a
    model could not be made (make_models raises). Cached in the shared state (by the masks)."""
    masks = tuple(sorted(bones.items()))
    cached = state.uniform.get(masks)
    if cached is None:
        layout = _layout(masks, tuple(sorted(state.exponents.items())))
        if bones == state.bones:                # the header's bones: layout.keys is state.keys
            idx = np.arange(len(state.keys), dtype=np.int64)
        else:
            index = {key: j for j, key in enumerate(state.keys)}
            idx = np.array([index[key] for key in layout.keys], dtype=np.int64)
        alphabets = None
        if state.alphabets is not None:
            low_i, high_i, low_p, high_p = (np.ascontiguousarray(a[idx], dtype=np.int64) for a in state.alphabets)
            sizes_i, sizes_p = high_i - low_i + 1, high_p - low_p + 1
            if min(sizes_i.min(initial=1), sizes_p.min(initial=1)) >= 1 and max(
                    sizes_i.max(initial=1), sizes_p.max(initial=1)) <= pc.MAX_TOTAL // 2:
                alphabets = (low_i, sizes_i, low_p, sizes_p)
        cached = state.uniform[masks] = (layout, idx, alphabets)
    return cached


def _motion_of_runs(header: BBAHeader, runs: list[tuple[dict[int, int], np.ndarray]], kfi: np.ndarray,
                    skeleton: Skeleton) -> Motion:
    """stream_to_motion of frames given as runs of equal bone masks: (boneID -> mask, values (n, P)
    float64 in stream order: bones sorted, bits ascending); kfi (F,) int64 KeyFrameIndex of every frame."""
    plan = _runs_plan(tuple(tuple(sorted(mask.items())) for mask, _ in runs), skeleton)
    rotated, n_values, names, columns = plan
    n_frames = len(kfi)
    if n_frames:
        _check_size(int(kfi[1:].sum()) + n_frames, n_values)
    order = ORDER_NAMES[header.rotation_order]
    n_columns = 3 * len(rotated) + 3
    table = np.zeros((n_frames, n_columns))
    held = np.zeros(n_columns)
    start = 0
    for (_, flat), (source, target) in zip(runs, columns):
        stop = start + len(flat)
        block = table[start:stop]
        block[:] = held
        block[:, target] = flat[:, source]
        held = block[-1]
        start = stop
    key_q = rotations.from_euler_table(table, len(rotated), bap_table.ROTATION_UNIT_RAD, order)   # (F, R, 4)
    key_t = table[:, 3 * len(rotated):] * bap_table.TRANSLATION_UNIT_M                 # (F, 3)
    if not kfi[1:].any():
        quats, trans = key_q, key_t
    else:                                       # the gaps before frames 1.., expanded in one batch
        quats, trans = kf.regenerate(key_q, key_t, kfi)
    return Motion(header.fps, names, quats, trans)


_PLANS: dict[tuple, tuple] = {}      # _runs_plan's cache: (masks of the runs, id(skeleton)) -> (skeleton, plan)
_VLC_LUTS: dict[int, tuple] = {}     # id(pc.vlc_tables()) -> (those tables, their huffman_lut (dc_intra, dc_inter, ac))


def _runs_plan(masks: tuple[tuple[tuple[int, int], ...], ...], skeleton: Skeleton) -> tuple:
    """What _motion_of_runs derives from the runs' masks (sorted (boneID, mask) pairs per run), cached:
    (rotated boneIDs (the root's included), values per frame (animatable bits), their bone names,
    per run (source, target) the columns of its values and of the held table they go to). The held
    table has columns 3 r .. 3 r + 2 for the angles of rotated[r], then the root's translation.
    SigncastError when a bone is not in the skeleton."""
    cached = _PLANS.get((masks, id(skeleton)))
    if cached is not None and cached[0] is skeleton:
        return cached[1]
    bones = sorted({b for m in masks for b, _ in m})
    root = int(np.flatnonzero(skeleton.parents < 0)[0])
    rotated = sorted({b for m in masks for b, bits in m if bits & 0b111000} | {root})
    for b in bones:
        if b >= len(skeleton):
            raise SigncastError(f"BBA stream animates bone {b}, the avatar has {len(skeleton)}")
    animatable: dict[int, int] = {}
    for mask in masks:
        for bone, bits in mask:
            animatable[bone] = animatable.get(bone, 0) | bits
    column = {(b, bit): 3 * r + axis for r, b in enumerate(rotated) for axis, bit in enumerate(ROTATION_BITS)}
    column |= {(root, bit): 3 * len(rotated) + axis for axis, bit in enumerate(TRANSLATION_BITS)}
    columns = []
    for mask in masks:
        keys = [(b, bit) for b, bits in mask for bit in _bits(bits)]
        source = [k for k, key in enumerate(keys) if key in column]
        columns.append((np.array(source, dtype=np.int64), np.array([column[keys[k]] for k in source], dtype=np.int64)))
    plan = (rotated, sum(bits.bit_count() for bits in animatable.values()), tuple(skeleton.names[b] for b in rotated),
            columns)
    if len(_PLANS) >= 256:
        _PLANS.clear()
    _PLANS[(masks, id(skeleton))] = (skeleton, plan)
    return plan

"""MPEG-4 FBA stream of FAPs (face) and BAPs (body): predictive and DCT coders, with their decoders.

Syntax (mpeg4-facts.md §2.1-2.4, after the visage FBA encoder that follows ISO/IEC 14496-2
Amd.1; seed 000 §2.1; seed 004 "BAP Grouping"):

    fba_object_start_code 0x000001BA
    repeat: [fba_object_plane_start_code 0x000001BB before every intra plane]
        is_intra u1, fba_object_mask u2 (1 FAPs, 2 BAPs, 3 both)
        intra: is_frame_rate u1 (1), frame_rate u8, seconds u4, frequency_offset u1, is_time_code u1 (0)
        skip_frames u1 (0)
        the face block (mask 1 or 3), then the body block (mask 2 or 3); a block is
          intra: quant u5 (fap_quant / bap_quant), per group (10 FAP / 24 BAP groups): marker u1,
                 mask_type u2 (0 none, 3 all, 1 + one bit per parameter in group order), gender u1,
                 coding_type u1 (0 predictive, 1 DCT)
          predictive intra: is_i_new_max, is_i_new_min, is_p_new_max, is_p_new_min u1 each;
                 range fields (param_coding); then the arithmetic-coded levels of every masked parameter
          predictive P plane: the arithmetic-coded residual levels
          DCT plane (a segment of up to 16 frames): is_short u1 [+ frames-1 u4], per masked parameter a DCT block
    visual_object_sequence_end_code 0x000001B1
    CRC-32 (zlib) of all the bytes before it, 4 bytes (signcast's container check, not in the standard:
    the FBA syntax itself has no check, so bit errors in Huffman-coded DCT data would decode silently)

The face and body blocks are one implementation, parameterised by a ParameterSet (FAPS, BAPS): the
count, the groups in coding order, the base steps (effective step = base x quant, linear for both:
mpeg4-facts.md §1.7 for FAPs; signcast's BAPs use the same linear scale) and the mask-type rules.
FAP group 1 (viseme, expression: high-level FAPs) always has mask type 0: signcast codes only the
low-level FAPs 3..68; FAP mask type 2 (interpolated FAPs) is refused, as is BAP mask type 2.
Chosen here (the standard's face block carries gender and coding type; visage reuses them for the
body): each block carries its own coding_type, as in the standard, and the encoder writes the same
in both; the decoder refuses a plane whose blocks differ (their planes would span different frames).
A DCT plane's blocks each carry is_short and must agree. FAP DCT blocks use the VLC tables trained
on BAPs (comparisons/tables/param_vlc.json: size categories, so any level up to 2^20 has a code).

Masks (which parameters are sent) are set at each intra plane and hold until the next; parameters
outside the mask keep their last value (0 at the start). The encoder masks in exactly the
parameters whose quantised value changes during the intra period, so unchanged groups cost 3 bits.
A change of parameter set (the face appearing or disappearing, `face_frames`) forces an intra plane;
a plane without the face resets it to neutral (every FAP 0), so frames without the face decode to
FAPs 0 and the face's next intra plane is coded against 0. The body is in every plane or in none.

Chosen here (no source): intra period 32 frames (predictive) and 4 segments (DCT); the 7-bit
range fields (param_coding); the encoder sends tight ranges for an intra period unless the default
(+-31 fields) alphabets are estimated to cost less (log2 of the alphabet sizes per coded level).
Nothing is clipped. A predictive period ends early where a residual is too large for the range
fields (a step-64 angle crossing +-pi, a root jump over ~15 m): the next intra plane starts at that
frame and sends absolute values, so the stream stays standard and every value decodes within half
a step. No ASL letter crosses +-pi (their streams are byte-identical to before). Wrapping angle
residuals modulo 2 pi would be cheaper only for motion that keeps crossing it (a root twist
jittering about pi: 2.3x the bytes with intra escapes, ~1.03x with DCT), but 2 pi is not a whole
number of 1e-5 rad units and a standard decoder does not wrap. A value whose intra level is too
large (|root translation| > ~15 m) is refused with SigncastError; FAP values beyond
fap_table.limits() are refused before coding (within them every level fits). A DCT segment shorter
than 16 frames (the stream's last, or one before a parameter-set change) sets is_short; the
stream's last segment always does.

Speed (comparisons/params/frames.py): the encoder's decisions (changed mask, closed-loop levels, range
fields) and all P planes of an intra period are one kernel call each; the decoder reads the P planes
after an intra plane in one call (`_read_predicted_planes`), and falls back to reading field by field
at anything else (another header, damage), so its checks and messages are those of the plain loop.
The P-frame models are sparse (only the symbols coded so far carry a count: the alphabets of Q = 1 run
to ~10^5 symbols per plane, and allocating and touching Fenwick trees of that size cost more than the
coding); the decoder hands them to the dense banks (pc.LevelFrames) when an intra period outgrows
SPARSE_KEYS planes. Both write and read exactly the bits of those banks. A DCT segment keeps
param_coding's NumPy matrix products (their summation order is BLAS's) and does the rounding around
them in kernels, bit for bit; the encoder writes a segment's fields with the bit kernels directly.

Streams hold at most MAX_FRAMES frames; the encoder refuses longer input and the decoder stops
with SigncastError before storing frame MAX_FRAMES + 1 (a 15.6 kB DCT stream can hold 400,000
still frames, 0.95 GB once decoded).
"""
from __future__ import annotations

import functools
import zlib
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from comparisons.params import bap_table
from comparisons.params import fap_table
from comparisons.params import coding as pc
from comparisons.params.bits import BitReader, BitWriter
from comparisons.params.entropy import MAX_TOTAL
from comparisons.params import arithmetic as kc
from comparisons.params import frames as pf
from media.errors import SigncastError

OBJECT_START_CODE = 0xBA
PLANE_START_CODE = 0xBB
END_CODE = 0xB1
PARAMSET_FAP, PARAMSET_BAP, PARAMSET_BOTH = 1, 2, 3
PREDICTIVE, DCT = 0, 1
DEFAULT_INTRA_PERIOD = 32
DEFAULT_INTRA_SEGMENTS = 4
MAX_FRAMES = 216_000        # 1 h at 60 fps, 2 h at 30 fps; decoded (T, 296) int64 <= 511 MB
DECODE_BLOCK = 1024         # the decoder stores frames in blocks of this many
MAX_ABS_VALUE = 2 ** 31 - 1  # input guard, far beyond any BAP's range


@dataclass(frozen=True, eq=False)
class ParameterSet:
    """What the coder needs to know of one parameter set (FAPs or BAPs).

    name: "FAP" or "BAP" (messages, and `<name>_quant`); paramset_bit: its bit in fba_object_mask;
    count: parameters (ids 1..count, index = id - 1); group_members: ids of each group in coding
    order; base_steps: (count,) int64 quantisation step per parameter, its units (the effective step
    is base x quant); quant_label: how encoder messages name the quant; mask_type_2: why mask type 2
    is refused (decoder message); empty_groups: 1-based groups whose mask type must be 0;
    describe: (id, value) -> "BAP 181 (name) value 16000 mm" for messages."""
    name: str
    paramset_bit: int
    count: int
    group_members: tuple[tuple[int, ...], ...]
    base_steps: np.ndarray
    quant_label: str
    mask_type_2: str
    empty_groups: tuple[int, ...]
    describe: Callable[[int, int], str]
    group_order: np.ndarray = field(init=False)
    group_starts: np.ndarray = field(init=False)
    empty_group_flags: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        order = np.array([i - 1 for group in self.group_members for i in group], dtype=np.int64)
        object.__setattr__(self, "group_order", order)
        starts = np.concatenate([[0], np.cumsum([len(group) for group in self.group_members])]).astype(np.int64)
        object.__setattr__(self, "group_starts", starts)
        flags = np.array([g in self.empty_groups for g in range(1, len(self.group_members) + 1)], dtype=bool)
        object.__setattr__(self, "empty_group_flags", flags)

    def steps(self, quant: int) -> np.ndarray:
        """(count,) int64 effective quantisation steps at this quant (1..31)."""
        return self.base_steps * quant

    def coded_order(self, mask: np.ndarray) -> np.ndarray:
        """0-based indices of the masked parameters, in coding order (group by group)."""
        return self.group_order[np.asarray(mask, dtype=bool)[self.group_order]]


def _describe_bap(bap_id: int, value: int) -> str:
    bap = bap_table.bap(bap_id)
    return f"BAP {bap.id} ({bap.name}) value {value} {'mm' if bap.is_translation else 'x 1e-5 rad'}"


def _describe_fap(fap_id: int, value: int) -> str:
    fap = fap_table.fap(fap_id)
    return f"FAP {fap.id} ({fap.name}) value {value} {'x 1e-5 rad' if fap.unit == 'AU' else fap.unit + '/1024'}"


BAPS = ParameterSet("BAP", PARAMSET_BAP, bap_table.N_BAPS, bap_table.GROUP_MEMBERS, bap_table.steps(), "Q",
                    "BAP mask type 2 is not defined", (), _describe_bap)
FAPS = ParameterSet("FAP", PARAMSET_FAP, fap_table.N_FAPS, fap_table.GROUP_MEMBERS, fap_table.steps(), "fap_quant",
                    "FAP mask type 2 (interpolated FAPs) is not supported", (1,), _describe_fap)
PARAMETER_SETS = (FAPS, BAPS)          # the order of the blocks in a plane: face, then body
_FAP_LIMITS = fap_table.limits()       # (68,) int64, computed once
_FAP_LIMITS.flags.writeable = False


def coded_order(mask: np.ndarray, parameter_set: ParameterSet = BAPS) -> np.ndarray:
    """0-based indices of the masked parameters (default: BAPs), in coding order (group by group)."""
    return parameter_set.coded_order(mask)


def plane_header_bits(intra: bool, fps: float, paramset: int = PARAMSET_BAP) -> tuple[int, int]:
    """(value, bit count) of a plane header: is_intra, fba_object_mask, [is_frame_rate 1, frame_rate,
    seconds, frequency_offset, is_time_code 0], skip_frames 0."""
    if paramset < 0 or paramset >> 2:
        raise SigncastError(f"value {paramset} does not fit in 2 bits")
    if not intra:
        return paramset << 1, 4
    rate, seconds, offset = pc.frame_rate_fields(fps)
    value = (((((1 << 2 | paramset) << 1 | 1) << 8 | rate) << 4 | seconds) << 1 | offset) << 2
    return value, 19


def write_plane_header(writer: BitWriter, intra: bool, fps: float, paramset: int = PARAMSET_BAP) -> None:
    writer.write(*plane_header_bits(intra, fps, paramset))


def read_plane_header(reader: BitReader) -> tuple[bool, int, float | None]:
    """(is_intra, fba_object_mask 1..3, frame rate or None)."""
    intra = bool(reader.read_bit())
    paramset = reader.read(2)
    if paramset == 0:
        raise SigncastError("corrupt FBA stream: object plane carries neither FAPs nor BAPs")
    fps = None
    if intra:
        if reader.read_bit():
            rate, seconds, offset = reader.read(8), reader.read(4), reader.read_bit()
            fps = pc.fps_from_fields(rate, seconds, offset)
        if reader.read_bit():
            raise SigncastError("corrupt FBA stream: time codes are not supported")
    if reader.read_bit():
        raise SigncastError("corrupt FBA stream: frame skipping is not supported")
    return intra, paramset, fps


def write_group_masks(writer: BitWriter, mask: np.ndarray, parameter_set: ParameterSet = BAPS) -> None:
    """Per group: marker 1, mask type u2 (0 none, 3 all, 1 then one bit per parameter). mask: (count,) bool."""
    mask = np.ascontiguousarray(mask, dtype=bool)
    writer.reserve(parameter_set.count + 3 * len(parameter_set.group_members))
    pf.write_group_masks(writer.buffer, writer.state, mask, parameter_set.group_starts, parameter_set.group_order)


def read_group_masks(reader: BitReader, parameter_set: ParameterSet = BAPS) -> np.ndarray:
    """(count,) bool mask of the parameters an intra plane sends."""
    mask = np.zeros(parameter_set.count, dtype=bool)
    status, number = pf.read_group_masks(reader.array, reader.end_bit, reader.registers, parameter_set.group_starts,
                                         parameter_set.group_order, parameter_set.empty_group_flags, mask)
    if status == pf.END_OF_DATA:
        raise SigncastError("truncated stream: it ends inside a field")
    if status == pf.MISSING_MARKER:
        raise SigncastError("corrupt FBA stream: missing marker bit in the group masks")
    if status == pf.MASK_TYPE_2:
        raise SigncastError(f"corrupt FBA stream: {parameter_set.mask_type_2}")
    if status == pf.EMPTY_GROUP:
        raise SigncastError(f"corrupt FBA stream: {parameter_set.name} group {number} is never sent "
                            "(high-level FAPs, viseme and expression, are not supported)")
    return mask


SETTLING_PARAMETERS = 8    # parameters that jump once and hold before a one-frame intra plane pays for itself
SETTLING_MIN_FRAMES = 8


@dataclass
class _Track:
    """One parameter set being coded: its values (T, count) int64, quant, and the decoder's values (count,)."""
    parameter_set: ParameterSet
    values: np.ndarray
    quant: int
    held: np.ndarray


def _changed_mask(block: np.ndarray, held: np.ndarray, steps: np.ndarray) -> np.ndarray:
    """(count,) bool: the parameters of block (T, count) whose quantised difference from held is ever nonzero."""
    return pf.changed_mask(np.asarray(block, dtype=np.int64), np.asarray(held, dtype=np.int64),
                           np.ascontiguousarray(np.broadcast_to(steps, np.shape(block)[1:]), dtype=np.int64))


def _predictive_decisions(track: _Track, block: np.ndarray):
    """The predictive coder's decisions for `block` (T, count) of one track: (frames it can carry,
    mask (count,) bool, coded order, intra levels (P,), P levels (T - 1, P), decoder values (T, P)).
    SigncastError if an intra value cannot be sent."""
    pset, q = track.parameter_set, track.quant
    mask, order, intra, p_levels, recon = pf.masked_levels(block, track.held, pset.steps(q), pset.group_order)
    if pf.first_beyond(intra[None], pc.level_limit(q)) == 0:
        index = int(order[np.flatnonzero(np.abs(intra) > pc.level_limit(q))[0]])
        raise SigncastError(f"{pset.describe(index + 1, int(block[0, index]))} cannot be sent at "
                            f"{pset.quant_label}={q}: an FBA intra plane carries at most "
                            f"+-{pc.level_limit(q) * int(pset.base_steps[index]) * q}")
    return 1 + pf.first_beyond(p_levels, pc.level_limit(q)), mask, order, intra, p_levels, recon


def _predictive_period(tracks: list[_Track], start: int, stop: int) -> list[tuple]:
    """Each track's decisions for the longest prefix of frames start..stop that one intra period can
    carry for all of them (a residual too large for the range fields ends it early)."""
    while True:
        decisions = [_predictive_decisions(track, track.values[start:stop]) for track in tracks]
        frames = min(d[0] for d in decisions)
        if start + frames == stop:
            return decisions
        stop = start + frames


def _settles_at_once(tracks: list[_Track], start: int, stop: int) -> bool:
    """Whether SETTLING_PARAMETERS or more parameters of the plane (all its tracks) change from the
    held values at frame `start` and then hold until `stop` (a rest pose set at the start of a
    stream): in one intra period they would be masked in and cost a zero residual in every P frame,
    so a one-frame intra plane that sets them is cheaper."""
    if stop - start < SETTLING_MIN_FRAMES:
        return False
    settled = sum(pf.settled_count(track.values[start:stop], track.held, track.parameter_set.steps(track.quant))
                  for track in tracks)
    return settled >= SETTLING_PARAMETERS


def _prefer_tight_ranges(fields: np.ndarray, n_p_frames: int, q: int) -> bool:
    """Send the per-parameter ranges `fields` (4, P) when their 28 bits per masked parameter cost
    less than coding every level in the default alphabets (estimated as log2 of the alphabet
    sizes), or when the defaults are too small."""
    if fields.max(initial=0) > pc.DEFAULT_RANGE_FIELD:
        return True
    return _alphabet_bits(fields, n_p_frames, q) + 4 * pc.RANGE_BITS * fields.shape[1] < _default_bits(
        fields.shape[1], n_p_frames, q)


def _alphabet_bits(fields: np.ndarray, n_p_frames: int, q: int) -> float:
    """log2 of the alphabet sizes that range fields (4, P) announce: one intra frame and n_p_frames P frames."""
    i_low, i_high, p_low, p_high = pf.alphabets(fields, q, pc.RANGE_DELTA)
    return float(np.log2(i_high - i_low + 1).sum() + n_p_frames * np.log2(p_high - p_low + 1).sum())


@functools.lru_cache(maxsize=4096)
def _default_bits(n_params: int, n_p_frames: int, q: int) -> float:
    return _alphabet_bits(np.full((4, n_params), pc.DEFAULT_RANGE_FIELD, dtype=np.int64), n_p_frames, q)


def _write_block_intra_header(writer: BitWriter, track: _Track, mask: np.ndarray, coding: int,
                              tail: int = 0, tail_bits: int = 0) -> None:
    """quant, group masks, gender 0, coding_type, then `tail` in `tail_bits` bits."""
    writer.write(track.quant, 5)
    write_group_masks(writer, mask, track.parameter_set)
    writer.write(coding << tail_bits | tail, 2 + tail_bits)     # gender 0, coding_type, the tail


def _write_predictive_intra_block(writer: BitWriter, track: _Track, decisions: tuple) -> tuple[np.ndarray, np.ndarray]:
    """One track's block of an intra plane; returns its P alphabets (low (P,), high (P,))."""
    _, mask, order, intra, p_levels, _ = decisions
    q = track.quant
    fields = pf.range_fields(intra, p_levels, q, pc.RANGE_DELTA)
    tight = _prefer_tight_ranges(fields, len(p_levels), q)
    if not tight:
        fields = np.full((4, len(order)), pc.DEFAULT_RANGE_FIELD, dtype=np.int64)
    i_low, i_high, p_low, p_high = pf.alphabets(fields, q, pc.RANGE_DELTA)
    _write_block_intra_header(writer, track, mask, PREDICTIVE, 15 if tight else 0, 4)    # is_i/p_new_max/min
    if tight:
        pc.write_range_fields(writer, fields)
    _write_intra_levels(writer, intra, i_low, i_high)
    return p_low, p_high


def _write_intra_levels(writer: BitWriter, intra: np.ndarray, low: np.ndarray, high: np.ndarray) -> None:
    """The levels (P,) of an intra plane in alphabets low..high (P,): one frame of all-ones models, the bits of
    pc.LevelFrames(low, high, [0, P], once=True).write(writer, intra[None])."""
    bad = pf.check_symbols(intra[None], low, high)
    if bad >= 0:
        raise SigncastError(f"symbol {int(intra[bad] - low[bad])} outside the model's alphabet "
                            f"0..{int(high[bad] - low[bad])}")
    sizes = high - low + 1
    offsets, scalars = pf.new_scalars(sizes, MAX_TOTAL)
    writer.reserve(pf.PRECISION * 4 * (len(low) + 2))
    pf.write_level_frames(writer.buffer, writer.state, 0, 0, intra[None], low, np.array([0, len(low)]), sizes, offsets,
                          _NO_COUNTS, _NO_COUNTS, scalars, np.arange(len(low)), True)


def _read_intra_levels(reader: BitReader, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """(P,) int64 levels of an intra plane in alphabets low..high (P,): _write_intra_levels' inverse."""
    sizes = high - low + 1
    offsets, scalars = pf.new_scalars(sizes, MAX_TOTAL)
    out = np.empty(len(low), dtype=np.int64)
    pc.check_level_status(pf.read_level_frame(reader.array, reader.end_bit, reader.registers, low,
                                              np.array([0, len(low)]), sizes, offsets, _NO_COUNTS, _NO_COUNTS,
                                              scalars, np.arange(len(low)), out, True))
    return out


_NO_COUNTS = np.zeros(0, dtype=np.int64)


def _paramset(tracks: list[_Track]) -> int:
    return sum(track.parameter_set.paramset_bit for track in tracks)


def _write_p_planes(writer: BitWriter, alphabets: list[tuple[np.ndarray, np.ndarray]], levels: list[np.ndarray],
                    header: int, header_bits: int) -> None:
    """The P planes of an intra period: per frame the plane header, then each track's levels (F, P_k) in its
    alphabets (low, high) (P_k,), arithmetic-coded with fresh adaptive models (the bits of pc.LevelFrames.write,
    with comparisons/params/frames.py sparse models: no arrays the size of the alphabets)."""
    if len(alphabets) == 1:
        (low, high), levels = alphabets[0], levels[0]
        starts = np.array([0, len(low)], dtype=np.int64)
    else:
        low = np.concatenate([a[0] for a in alphabets])
        high = np.concatenate([a[1] for a in alphabets])
        starts = np.cumsum([0] + [len(a[0]) for a in alphabets])
        levels = np.concatenate(levels, axis=1)
    bad = pf.check_symbols(levels, low, high)
    if bad >= 0:
        p = bad % len(low)
        raise SigncastError(f"symbol {int(levels.flat[bad] - low[p])} outside the model's alphabet "
                            f"0..{int(high[p] - low[p])}")
    sizes = high - low + 1
    writer.reserve(len(levels) * (header_bits + 4 * pf.PRECISION * (len(low) + len(starts))))
    pf.write_sparse_frames(writer.buffer, writer.state, header, header_bits, levels, low, starts, sizes,
                           *pf.new_sparse(sizes, len(levels)), MAX_TOTAL)


def _write_predictive_period(writer: BitWriter, tracks: list[_Track], start: int, stop: int, fps: float) -> int:
    """Codes one intra period of frames start..(at most) stop; returns the frames it holds."""
    if _settles_at_once(tracks, start, stop):      # values that jump once and hold: an intra plane of one frame
        stop = start + 1
    decisions = _predictive_period(tracks, start, stop)
    paramset = _paramset(tracks)
    writer.start_code(PLANE_START_CODE)
    write_plane_header(writer, True, fps, paramset)
    alphabets = [_write_predictive_intra_block(writer, track, d) for track, d in zip(tracks, decisions)]
    n_frames = len(decisions[0][5])
    if n_frames > 1:
        _write_p_planes(writer, alphabets, [d[4] for d in decisions], *plane_header_bits(False, fps, paramset))
    for track, d in zip(tracks, decisions):
        track.held[d[2]] = d[5][-1]
    return n_frames


def _dct_levels(segment: np.ndarray, dc_step: np.ndarray, ac_step: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """pc.dct_levels, bitwise: its matrix product, then the rounding in one kernel."""
    return pf.dct_quantise(np.matmul(pc.dct_matrix(len(segment)), segment), dc_step, ac_step)


def _dct_reconstruct(dc: np.ndarray, ac: np.ndarray, dc_step: np.ndarray, ac_step: np.ndarray) -> np.ndarray:
    """pc.dct_reconstruct, bitwise: its coefficients and rounding in kernels, its matrix product."""
    return pf.round_to_int(np.matmul(pc.dct_matrix(len(ac) + 1).T, pf.dct_coefficients(dc, ac, dc_step, ac_step)))


def dct_period(block: np.ndarray, held: np.ndarray, q: int, parameter_set: ParameterSet = BAPS):
    """The DCT coder's decisions for one intra period of `block` (T, count): (mask (count,) bool,
    coded order, DC step, AC step, segments [(n_frames, DC levels (P,), AC levels (n_frames - 1, P))])."""
    steps_all = parameter_set.base_steps
    mask = pf.changed_mask(np.ascontiguousarray(block, dtype=np.int64), np.asarray(held, dtype=np.int64), steps_all * q)
    order = parameter_set.coded_order(mask)
    dc_step, ac_step = pc.dct_steps(steps_all[order], q)
    segments = []
    for start in range(0, len(block), pc.SEGMENT):
        segment = block[start:start + pc.SEGMENT, order]
        segments.append((len(segment), *_dct_levels(segment, dc_step, ac_step)))
    return mask, order, dc_step, ac_step, segments


def dct_training_symbols(values: np.ndarray, q: int, intra_segments: int = DEFAULT_INTRA_SEGMENTS) -> list:
    """(DC values as coded, AC levels, intra) of every segment the DCT coder would code of BAP
    values (T, 296) (VLC design)."""
    held = np.zeros(bap_table.N_BAPS, dtype=np.int64)
    out = []
    period = intra_segments * pc.SEGMENT
    for start in range(0, len(values), period):
        _, order, dc_step, ac_step, segments = dct_period(values[start:start + period], held, q)
        previous = None
        for k, (n, dc, ac) in enumerate(segments):
            out.append((dc if k == 0 else dc - previous, ac, k == 0))
            previous = dc
            held[order] = _dct_reconstruct(dc, ac, dc_step, ac_step)[n - 1]
    return out


def _write_dct_period(writer: BitWriter, tracks: list[_Track], start: int, stop: int, fps: float,
                      is_last_period: bool) -> int:
    """Codes frames start..stop as one intra period of DCT segments; returns the frames it holds. (The bits of
    writer.write / write_group_masks / pc.write_dct_blocks, written by their kernels after one reserve per
    segment.)"""
    tables = pc.vlc_tables()
    dc_tables = {True: tables["dc_intra"].arrays()[:2], False: tables["dc_inter"].arrays()[:2]}
    ac_codes, ac_lengths = tables["ac"].arrays()[:2]
    periods = [dct_period(track.values[start:stop], track.held, track.quant, track.parameter_set)
               for track in tracks]
    paramset = _paramset(tracks)
    intra_header, p_header = plane_header_bits(True, fps, paramset), plane_header_bits(False, fps, paramset)
    n_segments = len(periods[0][4])
    previous_dc = [None] * len(tracks)
    buffer_bits = 64 + sum(8 + track.parameter_set.count + 3 * len(track.parameter_set.group_members)
                           for track in tracks)
    for k in range(n_segments):
        intra = k == 0
        if intra:
            writer.start_code(PLANE_START_CODE)
        n = periods[0][4][k][0]
        writer.reserve(buffer_bits + sum(72 * n * len(order) for _, order, _, _, _ in periods))
        kc.put_bits(writer.buffer, writer.state, *(intra_header if intra else p_header))
        short = is_last_period and k == n_segments - 1 or n < pc.SEGMENT
        for j, (track, (mask, order, dc_step, ac_step, segments)) in enumerate(zip(tracks, periods)):
            _, dc, ac = segments[k]
            if intra:
                pset = track.parameter_set
                kc.put_bits(writer.buffer, writer.state, track.quant, 5)
                pf.write_group_masks(writer.buffer, writer.state, mask, pset.group_starts, pset.group_order)
                kc.put_bits(writer.buffer, writer.state, DCT, 2)                # gender 0, coding_type
            kc.put_bits(writer.buffer, writer.state, *((16 | n - 1, 5) if short else (0, 1)))   # is_short [+ frames - 1]
            dc_values = dc if intra else dc - previous_dc[j]
            status, detail = kc.write_dct_blocks(writer.buffer, writer.state, dc_values, ac, *dc_tables[intra],
                                                 ac_codes, ac_lengths, pc.N_CATEGORIES)
            if status == 1:
                raise SigncastError(f"DCT level {detail} exceeds the largest category")
            if status == 2:
                raise SigncastError(f"symbol {detail} has no code in this Huffman table")
            previous_dc[j] = dc
            track.held[order] = _dct_reconstruct(dc, ac, dc_step, ac_step)[n - 1]
    return stop - start


def _checked_tracks(values, faps, face_frames, q: int,
                    fap_quant: int) -> tuple[_Track | None, _Track | None, np.ndarray]:
    """(face track or None, body track or None, face_frames (T,) bool) of encode_fba's input."""
    if values is None and faps is None:
        raise SigncastError("an FBA stream needs BAP values, FAP values or both")
    body = face = None
    n_frames = None
    if values is not None:
        values = np.asarray(values, dtype=np.int64)
        if values.ndim != 2 or values.shape[1] != bap_table.N_BAPS or len(values) == 0:
            raise SigncastError(f"BAP values must be (T >= 1, {bap_table.N_BAPS}), got {values.shape}")
        n_frames = len(values)
        if n_frames > MAX_FRAMES:
            raise SigncastError(f"an FBA stream holds at most {MAX_FRAMES} frames, got {n_frames}: split the motion")
        if values.min() < -MAX_ABS_VALUE or values.max() > MAX_ABS_VALUE:    # keeps the int64 level arithmetic exact
            raise SigncastError(f"BAP values beyond +-{MAX_ABS_VALUE} cannot be coded (rotations are within +-314159)")
        body = _Track(BAPS, values, q, np.zeros(BAPS.count, dtype=np.int64))
    if faps is not None:
        faps = np.asarray(faps)
        if faps.ndim != 2 or faps.shape[1] != fap_table.N_FAPS or len(faps) == 0 or (
                n_frames is not None and len(faps) != n_frames):
            expected = "T >= 1" if n_frames is None else f"T = {n_frames}, as the BAPs"
            raise SigncastError(f"FAP values must be ({expected}, {fap_table.N_FAPS}), got {faps.shape}")
        if not np.issubdtype(faps.dtype, np.integer):
            raise SigncastError(f"FAP values must be integers (FAP units), got {faps.dtype}")
        n_frames = len(faps)
        if n_frames > MAX_FRAMES:
            raise SigncastError(f"an FBA stream holds at most {MAX_FRAMES} frames, got {n_frames}: split the motion")
        faps = faps.astype(np.int64)
        if np.any(faps[:, :2]):
            raise SigncastError("FAPs 1 (viseme) and 2 (expression) are not sent: they must be 0")
        outside = np.abs(faps) > _FAP_LIMITS
        if outside.any():
            t, index = np.argwhere(outside)[0]
            raise SigncastError(f"{_describe_fap(int(index) + 1, int(faps[t, index]))} at frame {t} is outside "
                                f"its range +-{int(_FAP_LIMITS[index])}")
        face = _Track(FAPS, faps, fap_quant, np.zeros(FAPS.count, dtype=np.int64))
    if face_frames is None:
        face_frames = np.full(n_frames, face is not None)
    else:
        face_frames = np.asarray(face_frames)
        if face is None:
            raise SigncastError("face_frames needs FAP values")
        if face_frames.shape != (n_frames,) or face_frames.dtype != bool:
            raise SigncastError(f"face_frames must be ({n_frames},) bool, got {face_frames.shape} {face_frames.dtype}")
        if body is None and not face_frames.all():
            raise SigncastError("a face-only FBA stream must carry the face in every frame")
    return face, body, face_frames


def encode_fba(values: np.ndarray | None, fps: float, q: int, coding: str = "pred", *,
               faps: np.ndarray | None = None, fap_quant: int | None = None, face_frames: np.ndarray | None = None,
               intra_period: int = DEFAULT_INTRA_PERIOD, intra_segments: int = DEFAULT_INTRA_SEGMENTS) -> bytes:
    """FBA stream of BAP values (T, 296) int64 and/or FAP values (T, 68) int64 at `fps`.

    q: global quantisation Q (bap_quant) in 1..31; fap_quant: the FAPs' (1..31, default q).
    values None: a face-only stream (fba_object_mask 1); faps None: body only (2); both: 3.
    face_frames: (T,) bool, the frames whose planes carry the face (default all); the face appears
    and disappears through intra planes, and frames without it decode to FAPs 0.
    coding: "pred" (frame-predictive + arithmetic coding) or "dct" (16-frame DCT + VLC).
    SigncastError for more than MAX_FRAMES frames, FAPs 1-2 not 0 or FAPs outside fap_table.limits(),
    or a value the stream cannot carry.

    Round-trip bound (decode_fba of the stream), per parameter in its own unit, with s its base step
    (bap_table.steps(); FAPs fap_table.steps()) and Q the quantiser (q; FAPs fap_quant): predictive
    floor(s Q / 2) (closed-loop levels, nothing clipped); DCT, an n-frame segment's coefficients each within half
    their step (s Q for DC, s Q / 3 for AC) through the orthonormal inverse transform, plus the final rounding:
    0.5 (s Q / sqrt(n) + (n - 1) (s Q / 3) sqrt(2 / n)) + 0.5, at most 1.01 s Q + 0.5. Tested with the rates
    (within 2 % of stored figures) in tests/test_encoder_bounds.py and tests/test_fap_coding.py. The bytes may
    differ between CPUs for DCT (float products); the predictive coder is integer arithmetic throughout."""
    q = pc.check_q(q)
    fap_quant = q if fap_quant is None else pc.check_q(fap_quant, "fap_quant")
    face, body, face_frames = _checked_tracks(values, faps, face_frames, q, fap_quant)
    if coding not in ("pred", "dct"):
        raise SigncastError(f"unknown FBA coding {coding!r}: choose 'pred' or 'dct'")
    period = intra_period if coding == "pred" else intra_segments * pc.SEGMENT
    if period < 1:
        raise SigncastError("the intra period must be at least one frame (segment)")
    n_frames = len(face_frames)
    switches = np.append(np.flatnonzero(np.diff(face_frames.astype(np.int8))) + 1, n_frames)
    writer = BitWriter()
    writer.start_code(OBJECT_START_CODE)
    start = 0
    while start < n_frames:
        face_on = bool(face_frames[start])
        if face is not None and not face_on:
            face.held[:] = 0                          # a plane without the face leaves it neutral
        tracks = [track for track in (face if face_on else None, body) if track is not None]
        stop = min(start + period, int(switches[np.searchsorted(switches, start, side="right")]))
        if coding == "dct":
            start += _write_dct_period(writer, tracks, start, stop, fps, stop >= n_frames)
        else:
            start += _write_predictive_period(writer, tracks, start, stop, fps)
    writer.start_code(END_CODE)
    data = writer.getvalue()
    return data + zlib.crc32(data).to_bytes(4, "big")


@dataclass(frozen=True, eq=False)
class DecodedFba:
    """A decoded FBA stream. baps: (T, 296) int64 BAP units, None for a face-only stream;
    faps: (T, 68) int64 FAP units, None when no plane carries the face; fps: frames per second;
    face_frames: (T,) bool, the frames whose planes carry the face (the others hold FAPs 0), None
    when faps is None."""
    baps: np.ndarray | None
    faps: np.ndarray | None
    fps: float
    face_frames: np.ndarray | None = None

    @property
    def n_frames(self) -> int:
        return len(self.baps if self.baps is not None else self.faps)

    def baps_or_rest(self) -> np.ndarray:
        """(T, 296) int64: the BAPs, or the body at rest (all 0) for a face-only stream."""
        return self.baps if self.baps is not None else np.zeros((self.n_frames, BAPS.count), dtype=np.int64)


class _DecodedFrames:
    """Decoded frames of `width` values, stored in blocks of 64, 128, ... up to DECODE_BLOCK frames so
    that memory grows with the frames decoded (the decoder checks the frame limit before extending)."""

    def __init__(self, width: int) -> None:
        self.width = width
        self.blocks: list[np.ndarray | None] = []
        self.count = 0
        self.room = 0                       # free rows in the last block

    def _grow(self) -> None:
        size = min(DECODE_BLOCK, 64 << len(self.blocks))
        self.blocks.append(np.zeros((size, self.width), dtype=np.int64))
        self.room = size

    def extend(self, rows: np.ndarray) -> None:
        """rows: (n, width) int64 frames, or a (width,) frame."""
        rows = np.atleast_2d(rows)
        done = 0
        while done < len(rows):
            if not self.room:
                self._grow()
            block = self.blocks[-1]
            row = len(block) - self.room
            taken = min(len(rows) - done, self.room)
            block[row:row + taken] = rows[done:done + taken]
            self.count += taken
            self.room -= taken
            done += taken

    def skip(self, n: int) -> None:
        """n frames of zeros (the blocks are allocated zeroed)."""
        while n > 0:
            if not self.room:
                self._grow()
            taken = min(n, self.room)
            self.count += taken
            self.room -= taken
            n -= taken

    def array(self) -> np.ndarray:
        """(count, width) int64; releases each block once copied, so the peak is the output plus one block."""
        out = np.empty((self.count, self.width), dtype=np.int64)
        row = 0
        for k in range(len(self.blocks)):
            taken = min(len(self.blocks[k]), self.count - row)
            out[row:row + taken] = self.blocks[k][:taken]
            row += taken
            self.blocks[k] = None
        return out


class _BlockDecoder:
    """Decodes one parameter set's blocks; `held` (count,) int64 is the decoder's current values."""

    def __init__(self, parameter_set: ParameterSet) -> None:
        self.parameter_set = parameter_set
        self.held = np.zeros(parameter_set.count, dtype=np.int64)
        self.coding: int | None = None

    def read_plane(self, reader: BitReader, intra: bool) -> np.ndarray:
        """This block of one plane: the frames it holds, (n, count) int64."""
        if intra:
            self._read_intra_header(reader)
        if self.coding == DCT:
            return self._read_dct_segment(reader, intra)
        if intra:
            self.held[self.order] = _read_intra_levels(reader, *self.i_alphabet) * self.steps
        else:
            self.held[self.order] += self.p_frames.read(reader) * self.steps
        return self.held[None].copy()

    @property
    def p_frames(self) -> pc.LevelFrames:
        """The P-frame models of this intra period (made at the first predicted plane, or those the fast
        path left: p_source, its _SparseModels and this block's track)."""
        if self._p_frames is None:
            if self.p_source is not None:
                models, k = self.p_source
                self._p_frames = models.dense().track(k)
            else:
                low, high = self.p_alphabet
                self._p_frames = pc.LevelFrames(low, high, [0, len(low)])
        return self._p_frames

    @p_frames.setter
    def p_frames(self, frames: pc.LevelFrames) -> None:
        self._p_frames = frames

    def _read_intra_header(self, reader: BitReader) -> None:
        pset = self.parameter_set
        q = reader.read(5)
        if q == 0:
            raise SigncastError(f"corrupt FBA stream: {pset.name.lower()}_quant 0")
        mask = read_group_masks(reader, pset)
        reader.read_bit()                    # gender
        self.coding = reader.read_bit()
        self.order = pset.coded_order(mask)
        if self.coding == PREDICTIVE:
            flags = [reader.read_bit(), reader.read_bit(), reader.read_bit(), reader.read_bit()]
            if len(set(flags)) != 1:
                raise SigncastError("corrupt FBA stream: mixed range flags are not supported")
            fields = (pc.read_range_fields(reader, len(self.order)) if flags[0]
                      else np.full((4, len(self.order)), pc.DEFAULT_RANGE_FIELD, dtype=np.int64))
            i_low, i_high, p_low, p_high = pf.alphabets(fields, q, pc.RANGE_DELTA)
            if len(i_low) and max((i_high - i_low).max(), (p_high - p_low).max()) >= 32768:
                raise SigncastError("corrupt FBA stream: impossible value ranges")
            self.steps = pset.steps(q)[self.order]
            self.i_alphabet = (i_low, i_high)
            self.p_alphabet = (p_low, p_high)
            self._p_frames: pc.LevelFrames | None = None
            self.p_source: tuple[_SparseModels, int] | None = None
        else:
            self.dc_step, self.ac_step = pc.dct_steps(pset.base_steps[self.order], q)
            self.previous_dc = None

    def _read_dct_segment(self, reader: BitReader, intra: bool) -> np.ndarray:
        tables = pc.vlc_tables()
        n = pc.SEGMENT
        if reader.read_bit():
            n = reader.read(4) + 1
        dc, ac = pc.read_dct_blocks(reader, tables, intra, n, len(self.order))
        if not intra:
            dc += self.previous_dc
        self.previous_dc = dc
        segment = _dct_reconstruct(dc, ac, self.dc_step, self.ac_step)
        rows = np.repeat(self.held[None], n, axis=0)
        rows[:, self.order] = segment
        self.held = rows[-1].copy()
        return rows


PREDICTED_CHUNK = 64       # predicted planes the fast path decodes per kernel call
SPARSE_KEYS = 32           # counted symbols a sparse P-frame model holds (an intra period's 31 P frames)


class _SparseModels:
    """The P-frame models of the blocks of one intra plane, all their columns concatenated (low, high
    (P,) alphabets, track_starts (K + 1,)), as comparisons/params/frames.py sparse models; `dense()` turns
    them into the equivalent pc.LevelFrames once (streams whose P planes outgrow SPARSE_KEYS, and the
    field-by-field path), after which the sparse arrays are no longer used."""

    def __init__(self, low: np.ndarray, high: np.ndarray, track_starts: np.ndarray) -> None:
        self.low, self.high, self.track_starts = low, high, track_starts
        self.sizes = high - low + 1
        self.arrays = pf.new_sparse(self.sizes, SPARSE_KEYS)
        self._dense: pc.LevelFrames | None = None

    def dense(self) -> pc.LevelFrames:
        if self._dense is None:
            frames = pc.LevelFrames(self.low, self.high, self.track_starts)
            _, offsets, counts, tree, scalars, _ = frames.bank_arrays()
            pf.sparse_to_dense(self.sizes, *self.arrays, offsets, counts, tree, scalars)
            self._dense = frames
        return self._dense


def _read_predicted_planes(reader: BitReader, blocks: list[_BlockDecoder], paramset: int, room: int,
                           face_frames: _DecodedFrames | None, body_frames: _DecodedFrames | None) -> int:
    """Decodes the predicted planes that follow an intra plane of predictive blocks (all of them with
    one kernel call per PREDICTED_CHUNK planes), at most `room`, into face_frames / body_frames; returns
    how many. It stops before anything else (a start code, another plane header, the end, the frame
    limit), which decode_fba then reads field by field with its checks and messages."""
    if len(blocks) == 1:
        block = blocks[0]
        low, high = block.p_alphabet
        starts = np.array([0, len(low)], dtype=np.int64)
        held, columns, steps = block.held, block.order, block.steps
        width = block.parameter_set.count
    else:
        low = np.concatenate([b.p_alphabet[0] for b in blocks])
        high = np.concatenate([b.p_alphabet[1] for b in blocks])
        starts = np.cumsum([0] + [len(b.order) for b in blocks])
        held = np.concatenate([b.held for b in blocks])
        columns = np.concatenate([blocks[0].order, blocks[1].order + FAPS.count])
        steps = np.concatenate([b.steps for b in blocks])
        width = len(held)
    models = _SparseModels(low, high, starts)
    for k, b in enumerate(blocks):              # the field-by-field path continues with the same models
        b.p_source = (models, k)
        b.p_frames = None
    total = 0
    status = 0
    while total < room:
        out = np.empty((min(PREDICTED_CHUNK, room - total), width), dtype=np.int64)
        full = False
        if models._dense is None:
            status, n = pf.read_sparse_planes(reader.array, reader.end_bit, reader.registers, paramset, low, starts,
                                              models.sizes, *models.arrays, MAX_TOTAL, columns, steps, held, out)
            if status == pf.SPARSE_FULL:
                models.dense()
                status, full = 0, True
        else:
            frames = models.dense()
            status, n = pf.read_predicted_planes(reader.array, reader.end_bit, reader.registers, paramset, low,
                                                 starts, *frames.bank_arrays(), columns, steps, held, out)
        if n:
            if face_frames is not None:
                face_frames.extend(out[:n, :FAPS.count])
            if body_frames is not None:
                body_frames.extend(out[:n, width - BAPS.count:])
            total += n
        pc.check_level_status(status)
        if n < len(out) and not full:
            break
    if len(blocks) > 1:
        for b, offset in zip(blocks, (0, FAPS.count)):
            b.held = held[offset:offset + b.parameter_set.count].copy()
    return total


def decode_fba(data: bytes, *, max_frames: int = MAX_FRAMES) -> DecodedFba:
    """The FAPs and/or BAPs of an FBA stream (DecodedFba); SigncastError if it is corrupt or
    truncated, or holds more than `max_frames` frames (checked while decoding: memory stays within
    the limit)."""
    data = bytes(data)
    if len(data) < 12 or zlib.crc32(data[:-4]).to_bytes(4, "big") != data[-4:]:
        raise SigncastError("corrupt or truncated FBA stream: checksum mismatch")
    data = data[:-4]
    reader = BitReader(data)
    if reader.read_start_code() != OBJECT_START_CODE:
        raise SigncastError("not an FBA stream: it does not start with fba_object_start_code")
    face, body = _BlockDecoder(FAPS), _BlockDecoder(BAPS)
    body_frames = _DecodedFrames(BAPS.count)
    face_frames: _DecodedFrames | None = None         # created at the first plane with the face
    face_flags = bytearray()
    n_frames = 0
    fps = None
    paramset = has_body = None
    while True:
        if reader.at_start_code():
            code = reader.read_start_code()
            if code == END_CODE:
                break
            if code != PLANE_START_CODE:
                raise SigncastError(f"corrupt FBA stream: unexpected start code 0x{code:02X}")
        intra, plane_paramset, plane_fps = read_plane_header(reader)
        if intra:
            fps = plane_fps or fps
            if has_body is None:
                has_body = bool(plane_paramset & PARAMSET_BAP)
            elif has_body != bool(plane_paramset & PARAMSET_BAP):
                raise SigncastError("corrupt FBA stream: the body (BAPs) must be in every plane or in none")
            paramset = plane_paramset
            if not paramset & PARAMSET_FAP:
                face.held[:] = 0
        elif paramset is None:
            raise SigncastError("corrupt FBA stream: a predicted plane comes before any intra plane")
        elif plane_paramset != paramset:
            raise SigncastError("corrupt FBA stream: the parameter set changes in a predicted plane")
        blocks = [decoder for decoder in (face, body) if paramset & decoder.parameter_set.paramset_bit]
        rows = [decoder.read_plane(reader, intra) for decoder in blocks]
        if len({decoder.coding for decoder in blocks}) != 1:
            raise SigncastError("corrupt FBA stream: the face and body blocks of a plane use different coding types")
        n = len(rows[0])
        if any(len(r) != n for r in rows):
            raise SigncastError("corrupt FBA stream: the face and body blocks of a plane hold different frame counts")
        if n_frames + n > max_frames:
            raise SigncastError(f"FBA stream holds more than {max_frames} frames, the decoder's limit")
        if paramset & PARAMSET_FAP:
            if face_frames is None:
                face_frames = _DecodedFrames(FAPS.count)
                face_frames.skip(n_frames)
            face_frames.extend(rows[0])
        elif face_frames is not None:
            face_frames.skip(n)
        if paramset & PARAMSET_BAP:
            body_frames.extend(rows[-1])
        face_flags.extend([bool(paramset & PARAMSET_FAP)] * n)
        n_frames += n
        if intra and blocks[0].coding == PREDICTIVE:
            n = _read_predicted_planes(reader, blocks, paramset, max_frames - n_frames,
                                       face_frames if paramset & PARAMSET_FAP else None,
                                       body_frames if paramset & PARAMSET_BAP else None)
            if face_frames is not None and not paramset & PARAMSET_FAP:
                face_frames.skip(n)
            face_flags.extend([bool(paramset & PARAMSET_FAP)] * n)
            n_frames += n
    if reader.pos != 8 * len(data):
        raise SigncastError("corrupt FBA stream: data after the end code")
    if not n_frames or fps is None:
        raise SigncastError("corrupt FBA stream: no frames")
    faps = None if face_frames is None else face_frames.array()
    return DecodedFba(body_frames.array() if has_body else None, faps, fps,
                      None if faps is None else np.frombuffer(bytes(face_flags), dtype=bool).copy())

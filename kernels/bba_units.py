"""Numba-compiled whole-stream readers of the BBA stream's units (comparisons/bba_codec.py documents the format).

The common stream, decoded strictly: every unit carries the same bone list and no muscle data. One call reads
every unit (its fields, bone list, coded values, CRC-8 and next_start_code stuffing) and checks what the
per-unit reader does (bba_codec._read_unit_rows, _unit_number, _check_unit_end, and that the units cover the
header's frame count). At the first unit that is not of this common form, or not right, it returns FALLBACK
and does not say why: the caller then decodes the stream unit by unit, which reaches the same verdict and
raises its error. So this path decides no error message; it only makes good streams fast.

Units are given by starts (U,) int64, the bit after each unit's frame start code, and ends (U,) int64, the
bit of the next start code. bone_ids, bone_masks (B,) int64: the bone list every unit must carry, in stream
order. Values per unit are in the layout order of comparisons/bba_codec._layout (P of them).

Predictive units: the levels are arithmetic-coded with one adaptive model per value, all reset at each
intra unit (kernels/entropy_coding.py decode_frame_window, the bits of comparisons/entropy.decode_frame; the
bank is int32 here: its totals stay at most the limit, at most WINDOW_MAX_TOTAL, else FALLBACK);
an intra value is level x step x Q, a predicted one the previous value plus that, angles folded into
(-period / 2, period / 2]. DCT units: kernels/entropy_coding.read_dct_blocks per segment, the inter DC
levels added to the previous segment's; the caller applies the inverse DCT (NumPy, as the per-unit reader).
Imports nothing of signcast's Python modules.
"""
import numpy as np
from numba import njit

from kernels.bba_levels import _fold
from kernels.bba_masks import read_unit_bones
from kernels.entropy_coding import (
    TOTAL,
    WINDOW_MAX_TOTAL,
    crc8_bytes,
    decode_frame_window,
    get_local,
    init_bank,
    read_dct_blocks,
)

OK, FALLBACK = 0, 1
FRAME_NUMBER_BITS, P_FRAME_NUMBER_BITS, KFI_BITS, MUSCLE_COUNT_BITS, CRC_BITS = 24, 8, 5, 10, 8


@njit(cache=True)
def _bits_local(data, end_bit: int, pos: int, run: int, n_bits: int) -> tuple[int, int, int]:
    """get_bits on local state: (value or -1, pos, run)."""
    value = 0
    for _ in range(n_bits):
        bit, pos, run = get_local(data, end_bit, pos, run)
        if bit < 0:
            return -1, pos, run
        value = (value << 1) | bit
    return value, pos, run


@njit(cache=True)
def _ends_at_start_code(data, pos: int, end_bit: int) -> bool:
    """_check_unit_end: 1..8 bits remain, a 0 then 1s."""
    remaining = end_bit - pos
    if not 1 <= remaining <= 8:
        return False
    if (data[pos >> 3] >> (7 - (pos & 7))) & 1:
        return False
    for p in range(pos + 1, end_bit):
        if not (data[p >> 3] >> (7 - (p & 7))) & 1:
            return False
    return True


@njit(cache=True)
def _read_head(data, end_bit: int, pos: int, run: int, u: int, dct: bool, group_start, animatable, bone_ids,
               bone_masks, registers, ids, masks, result) -> tuple[int, int, int, int, int, int, int]:
    """A unit's fields before its values: (status, intra, frame-number field, KeyFrameIndex, frames, pos, run)."""
    intra, pos, run = get_local(data, end_bit, pos, run)
    if intra < 0:
        return FALLBACK, 0, 0, 0, 0, pos, run
    number_field, pos, run = _bits_local(data, end_bit, pos, run, FRAME_NUMBER_BITS if intra else P_FRAME_NUMBER_BITS)
    kfi, pos, run = _bits_local(data, end_bit, pos, run, KFI_BITS)
    if number_field < 0 or kfi < 0:
        return FALLBACK, 0, 0, 0, 0, pos, run
    n_frames = 1
    if dct:
        n_frames, pos, run = _bits_local(data, end_bit, pos, run, 4)
        if n_frames < 0:
            return FALLBACK, 0, 0, 0, 0, pos, run
        n_frames += 1
    same = 0
    if not intra:
        if u == 0:                                 # a predicted unit without a decoded reference
            return FALLBACK, 0, 0, 0, 0, pos, run
        same, pos, run = get_local(data, end_bit, pos, run)
        if same < 0:
            return FALLBACK, 0, 0, 0, 0, pos, run
    if intra or not same:
        registers[0], registers[1], registers[2] = pos, run, 0
        if read_unit_bones(data, end_bit, registers, group_start, animatable, ids, masks, result) != 0:
            return FALLBACK, 0, 0, 0, 0, pos, run
        if result[0] != len(bone_ids):
            return FALLBACK, 0, 0, 0, 0, pos, run
        for b in range(len(bone_ids)):
            if ids[b] != bone_ids[b] or masks[b] != bone_masks[b]:
                return FALLBACK, 0, 0, 0, 0, pos, run
        pos, run = registers[0], registers[1]
    return OK, intra, number_field, kfi, n_frames, pos, run


@njit(cache=True)
def _read_tail(data, end_bit: int, start: int, pos: int, run: int, intra: int, number_field: int, kfi: int,
               n: int, display_end: int, n_total: int) -> int:
    """NSBM, the CRC-8, the unit's place (strict _unit_number) and its end: the display frame after the
    unit, or -1."""
    _, pos, run = _bits_local(data, end_bit, pos, run, MUSCLE_COUNT_BITS)   # no muscle start code: ignored
    expected_crc = crc8_bytes(data, start, pos)
    crc, pos, run = _bits_local(data, end_bit, pos, run, CRC_BITS)
    if crc < 0 or crc != expected_crc:
        return -1
    expected = display_end + kfi
    if not intra and number_field != expected % (1 << P_FRAME_NUMBER_BITS):
        return -1
    number = number_field if intra else expected
    if number - kfi != display_end or (kfi and number == kfi) or number + n > n_total:
        return -1
    if not _ends_at_start_code(data, pos, end_bit):
        return -1
    return number + n


@njit(cache=True)
def _reset_bank(sizes, offsets, counts, tree, scalars, limit: int) -> None:
    counts[:] = 1
    init_bank(sizes, offsets, tree, scalars, limit)


@njit(cache=True)
def read_predictive_units(data, starts, ends, group_start, animatable, bone_ids, bone_masks, steps, is_angle,
                          q: int, value_limit: int, period: int, low_i, sizes_i, low_p, sizes_p, limit: int,
                          n_total: int, rows, kfi_out) -> int:
    """Every predictive unit: values into rows (U, P) int64, KeyFrameIndex into kfi_out (U,). low_*, sizes_*
    (P,) int64: the intra and predicted alphabets (first level, number of levels) of each value; limit: the
    models' frequency limit. Returns OK or FALLBACK."""
    if not 1 <= limit <= WINDOW_MAX_TOTAL:            # the int32 bank's bound
        return FALLBACK
    n_values = len(steps)
    offsets_p = np.zeros(n_values + 1, dtype=np.int64)
    coded_i, coded_p = False, False
    for p in range(n_values):
        offsets_p[p + 1] = offsets_p[p] + sizes_p[p]
        coded_i = coded_i or sizes_i[p] != 1
        coded_p = coded_p or sizes_p[p] != 1
    counts_p = np.ones(offsets_p[-1], dtype=np.int32)
    tree_p = np.empty(offsets_p[-1] + n_values, dtype=np.int32)
    scalars_i, scalars_p = np.zeros((n_values, 5), dtype=np.int64), np.empty((n_values, 5), dtype=np.int64)
    scalars_i[:, TOTAL] = sizes_i                  # all the fresh intra models need
    members = np.arange(n_values)
    held = np.zeros(n_values, dtype=np.int64)
    levels = np.empty(n_values, dtype=np.int64)
    registers = np.zeros(3, dtype=np.int64)
    ids, masks, result = np.empty(1023, dtype=np.int64), np.empty(1023, dtype=np.int64), np.zeros(2, dtype=np.int64)
    display_end = 0
    for u in range(len(starts)):
        start, end_bit = starts[u], ends[u]
        status, intra, number_field, kfi, n, pos, run = _read_head(data, end_bit, start, 0, u, False, group_start,
                                                                   animatable, bone_ids, bone_masks, registers,
                                                                   ids, masks, result)
        if status:
            return FALLBACK
        if intra:
            _reset_bank(sizes_p, offsets_p, counts_p, tree_p, scalars_p, limit)
            if coded_i:                            # fresh intra models, each coding one level
                status, pos, run, _ = decode_frame_window(data, end_bit, pos, run, 0, counts_p, tree_p, scalars_i,
                                                         offsets_p, members, levels, 0, True)
        elif coded_p:
            status, pos, run, _ = decode_frame_window(data, end_bit, pos, run, 0, counts_p, tree_p, scalars_p,
                                                     offsets_p, members, levels, 0, False)
        if status:
            return FALLBACK
        if not (coded_i if intra else coded_p):
            levels[:] = 0
        for p in range(n_values):
            step = steps[p] * q
            if intra:
                value = (levels[p] + low_i[p]) * step
            else:
                value = held[p] + (levels[p] + low_p[p]) * step
                if is_angle[p]:
                    value = _fold(value, period)
            if abs(value) > value_limit:
                return FALLBACK
            rows[u, p] = value
            held[p] = value
        display_end = _read_tail(data, end_bit, start, pos, run, intra, number_field, kfi, n, display_end, n_total)
        if display_end < 0:
            return FALLBACK
        kfi_out[u] = kfi
    return OK if display_end == n_total else FALLBACK


@njit(cache=True)
def read_dct_units(data, starts, ends, group_start, animatable, bone_ids, bone_masks, dc_intra, dc_inter, ac_table,
                   n_categories: int, n_total: int, dc_out, ac_out, sizes, kfi_out) -> int:
    """Every DCT unit (segment): DC levels (DC differences of inter segments added up) into dc_out (U, P),
    AC levels into ac_out (U, 15, P) (zero-filled), frames into sizes (U,), KeyFrameIndex into kfi_out (U,).
    dc_intra, dc_inter, ac_table: the canonical Huffman tables as tuples (first code, count, start, symbols)
    of int64 arrays (comparisons/entropy.CanonicalHuffman.arrays()[2:]). Returns OK or FALLBACK."""
    registers = np.zeros(3, dtype=np.int64)
    ids, masks, result = np.empty(1023, dtype=np.int64), np.empty(1023, dtype=np.int64), np.zeros(2, dtype=np.int64)
    state = np.zeros(2, dtype=np.int64)
    display_end = 0
    for u in range(len(starts)):
        start, end_bit = starts[u], ends[u]
        status, intra, number_field, kfi, n, pos, run = _read_head(data, end_bit, start, 0, u, True, group_start,
                                                                   animatable, bone_ids, bone_masks, registers,
                                                                   ids, masks, result)
        if status:
            return FALLBACK
        state[0], state[1] = pos, run
        table = dc_intra if intra else dc_inter
        if read_dct_blocks(data, end_bit, state, table[0], table[1], table[2], table[3], ac_table[0], ac_table[1],
                           ac_table[2], ac_table[3], n_categories, dc_out[u], ac_out[u, :n - 1]):
            return FALLBACK
        pos, run = state[0], state[1]
        if not intra:
            for p in range(dc_out.shape[1]):
                dc_out[u, p] += dc_out[u - 1, p]
        display_end = _read_tail(data, end_bit, start, pos, run, intra, number_field, kfi, n, display_end, n_total)
        if display_end < 0:
            return FALLBACK
        sizes[u], kfi_out[u] = n, kfi
    return OK if display_end == n_total else FALLBACK

"""Numba-compiled whole-stream readers of the BBA stream's units (comparisons/params/bba.py documents the format).

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
intra unit (comparisons/params/arithmetic.py decode_frame_window, the bits of comparisons/entropy.decode_frame; the
bank is int32 here: its totals stay at most the limit, at most WINDOW_MAX_TOTAL, else FALLBACK);
an intra value is level x step x Q, a predicted one the previous value plus that, angles folded into
(-period / 2, period / 2]. The predicted models are sparse while they hold few symbols (read_predictive_units:
at Q 1 the alphabets hold thousands of levels, a Fenwick bank of them costs its initialisation and cache misses).
DCT units: kernels/entropy_coding.read_dct_blocks per segment (its codes through LUT_BITS look-up tables where
no emulation-prevention bit can intervene), the inter DC levels added to the previous segment's; the caller
applies the inverse DCT (NumPy, as the per-unit reader).
Imports nothing of signcast's Python modules.
"""
import numpy as np
from numba import njit

from comparisons.params.arithmetic import (
    MAX_ZERO_RUN,
    PRECISION,
    TOP,
    TOTAL,
    WINDOW_MAX_TOTAL,
    _bits_local,
    _close_window,
    _get_code_local,
    _narrow_window,
    _open_window,
    _run_after,
    _window_target,
    crc8_bytes,
    decode_frame_window,
    get_local,
    init_bank,
)
from comparisons.params.bba_levels import _fold
from comparisons.params.bba_masks import read_unit_bones
from comparisons.params.frames import _sparse_add, _sparse_find, new_sparse

OK, FALLBACK = 0, 1
SPARSE_CAPACITY = 32                               # chosen here: keys a sparse model holds (param_frames' reader's)
FRAME_NUMBER_BITS, P_FRAME_NUMBER_BITS, KFI_BITS, MUSCLE_COUNT_BITS, CRC_BITS = 24, 8, 5, 10, 8


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
def _head_scratch():
    """_read_head's work arrays, made once per stream: (registers (3,), bone ids (1023,), masks (1023,),
    result (2,)) int64."""
    return (np.zeros(3, dtype=np.int64), np.empty(1023, dtype=np.int64), np.empty(1023, dtype=np.int64),
            np.zeros(2, dtype=np.int64))


@njit(cache=True)
def _read_head(data, starts, ends, u: int, dct: bool, group_start, animatable, bone_ids, bone_masks, scratch
               ) -> tuple[int, int, int, int, int, int, int]:
    """Unit u's fields (bits starts[u]:ends[u]) before its values: (status, intra, frame-number field,
    KeyFrameIndex, frames, pos, run). scratch: _head_scratch()."""
    registers, ids, masks, result = scratch
    end_bit, pos, run = ends[u], starts[u], 0
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
def _read_tail(data, starts, ends, u: int, pos: int, run: int, intra: int, number_field: int, kfi: int,
               n: int, display_end: int, n_total: int) -> int:
    """Unit u's NSBM, CRC-8, place (strict _unit_number) and end: the display frame after the unit, or -1."""
    start, end_bit = starts[u], ends[u]
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
def _dense_of_sparse(sizes, offsets, counts, tree, scalars, limit: int, totals, keys, extra, used) -> None:
    """Loads sparse models (comparisons/params/frames.py: count 1 + extra of each key, 1 elsewhere) into the bank
    (entropy_coding's form: all-ones Fenwick trees, then each key's extra added)."""
    counts[:] = 1
    init_bank(sizes, offsets, tree, scalars, limit)
    for m in range(len(sizes)):
        base = offsets[m]
        tbase = base + m
        n = sizes[m]
        for s in range(used[m]):
            symbol, e = keys[m, s], extra[m, s]
            counts[base + symbol] += e
            i = symbol + 1
            while i <= n:
                tree[tbase + i] += e
                i += i & -i
        scalars[m, TOTAL] = totals[m]


@njit(cache=True)
def _sparse_window(data, end_bit: int, pos: int, run: int, sizes, totals, keys, extra, used, limit: int,
                   out) -> tuple[int, int, int]:
    """entropy_coding.decode_frame_window (not fresh, model p for value p, over 0) with sparse models
    (comparisons/params/frames.py: the same counts, so the same symbols, model updates and reader state after):
    (status, pos, run), status as decode_frame_window's, or -4 for a zero run it would hand to
    decode_frame_local."""
    if not 0 <= run < MAX_ZERO_RUN:
        return -4, pos, run
    pos0, run0 = pos, run
    window, buf, n_buf, byte_at, value = _open_window(data, end_bit, pos, run)
    n_read, low, high, status = PRECISION, 0, TOP, 0
    for m in range(len(sizes)):
        total = totals[m]
        target = _window_target(value, low, high - low + 1, total)
        if target < 0:
            status = -1
            break
        slot, symbol, sym_low, excess = _sparse_find(keys, extra, used, m, target)
        low, high, value, buf, n_buf, byte_at, n_bits = _narrow_window(low, high, sym_low, sym_low + 1 + excess,
                                                                       total, value, buf, n_buf, byte_at, window)
        n_read += n_bits
        _sparse_add(keys, extra, used, totals, limit, sizes[m], m, slot, symbol)
        out[m] = symbol
    status, pos, run, _ = _close_window(window, pos0, run0, 0, end_bit, n_read, status)
    return status, pos, run


@njit(cache=True)
def read_predictive_units(data, starts, ends, group_start, animatable, bone_ids, bone_masks, steps, is_angle,
                          q: int, value_limit: int, period: int, low_i, sizes_i, low_p, sizes_p, limit: int,
                          n_total: int, rows, kfi_out) -> int:
    """Every predictive unit: values into rows (U, P) int64, KeyFrameIndex into kfi_out (U,). low_*, sizes_*
    (P,) int64: the intra and predicted alphabets (first level, number of levels) of each value; limit: the
    models' frequency limit. Returns OK or FALLBACK.

    The predicted models start each intra period as sparse models (comparisons/params/frames.py: only the symbols
    coded so far, the same counts and bits as the Fenwick bank); when one of them holds SPARSE_CAPACITY keys
    they are loaded into a Fenwick bank, decoded by decode_frame_window until the next intra unit."""
    if not 1 <= limit <= WINDOW_MAX_TOTAL:            # the int32 bank's bound
        return FALLBACK
    n_values = len(steps)
    offsets_p = np.zeros(n_values + 1, dtype=np.int64)
    coded_i, coded_p = False, False
    for p in range(n_values):
        offsets_p[p + 1] = offsets_p[p] + sizes_p[p]
        coded_i = coded_i or sizes_i[p] != 1
        coded_p = coded_p or sizes_p[p] != 1
    counts_p = np.ones(0, dtype=np.int32)          # the Fenwick bank, made when a sparse model fills up
    tree_p = np.empty(0, dtype=np.int32)
    scalars_i, scalars_p = np.zeros((n_values, 5), dtype=np.int64), np.empty((n_values, 5), dtype=np.int64)
    scalars_i[:, TOTAL] = sizes_i                  # all the fresh intra models need
    totals, keys, extra, used = new_sparse(sizes_p, SPARSE_CAPACITY)
    sparse = True
    members = np.arange(n_values)
    held = np.zeros(n_values, dtype=np.int64)
    levels = np.empty(n_values, dtype=np.int64)
    scratch = _head_scratch()
    display_end = 0
    for u in range(len(starts)):
        end_bit = ends[u]
        status, intra, number_field, kfi, n, pos, run = _read_head(data, starts, ends, u, False, group_start,
                                                                   animatable, bone_ids, bone_masks, scratch)
        if status:
            return FALLBACK
        # one call site of the windowed decoder, `fresh` a run-time flag: a literal True and False would compile it
        # twice, and inline it twice here
        windowed = False
        if intra:
            sparse = True                          # fresh predicted models
            for p in range(n_values):
                totals[p], used[p] = sizes_p[p], 0
            windowed = coded_i                     # fresh intra models, each coding one level
        elif coded_p:
            if sparse:
                for p in range(n_values):
                    if used[p] >= SPARSE_CAPACITY:
                        sparse = False
                        break
                if not sparse:
                    if len(counts_p) == 0:
                        counts_p = np.ones(offsets_p[-1], dtype=np.int32)
                        tree_p = np.empty(offsets_p[-1] + n_values, dtype=np.int32)
                    _dense_of_sparse(sizes_p, offsets_p, counts_p, tree_p, scalars_p, limit, totals, keys, extra, used)
            if sparse:
                status, pos, run = _sparse_window(data, end_bit, pos, run, sizes_p, totals, keys, extra, used, limit,
                                                  levels)
            else:
                windowed = True
        if windowed:
            fresh = intra != 0
            status, pos, run, _ = decode_frame_window(data, end_bit, pos, run, 0, counts_p, tree_p,
                                                     scalars_i if fresh else scalars_p, offsets_p, members, levels, 0,
                                                     fresh)
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
        display_end = _read_tail(data, starts, ends, u, pos, run, intra, number_field, kfi, n, display_end, n_total)
        if display_end < 0:
            return FALLBACK
        kfi_out[u] = kfi
    return OK if display_end == n_total else FALLBACK


LUT_BITS = 10                                      # chosen here: bits a Huffman look-up table decodes at once


@njit(cache=True)
def huffman_lut(first_code, count, start, symbols):
    """Look-up table of a canonical Huffman table (entropy_coding's reading arrays): (symbol, code length)
    (2^LUT_BITS,) int64 each by the next LUT_BITS bits; length 0 where no code of at most LUT_BITS bits is
    their prefix. Where codes are not prefix-free the shortest wins, as in the bit-by-bit reader."""
    size = 1 << LUT_BITS
    lut_symbol, lut_length = np.zeros(size, dtype=np.int64), np.zeros(size, dtype=np.int64)
    for length in range(1, min(len(count) - 1, LUT_BITS) + 1):
        for index in range(count[length]):
            code = first_code[length] + index
            for e in range(max(code << (LUT_BITS - length), 0), min((code + 1) << (LUT_BITS - length), size)):
                if lut_length[e] == 0:
                    lut_symbol[e], lut_length[e] = symbols[start[length] + index], length
    return lut_symbol, lut_length


@njit(cache=True)
def _read_dct_blocks(data, end_bit: int, pos: int, run: int, dc, dc_lut, ac, ac_lut, n_categories: int, dc_out,
                     ac_out) -> tuple[int, int, int]:
    """entropy_coding.read_dct_blocks (its statuses) with table look-ups: (status, pos, run). dc, ac: a table's
    (first code, count, start, symbols); dc_lut, ac_lut: their huffman_lut.

    A code comes from its table when the next LUT_BITS bits hold no emulation-prevention bit (the zero run
    cannot reach MAX_ZERO_RUN in them) and a code of at most LUT_BITS bits, else bit by bit
    (entropy_coding._get_code_local); a value's cat bits (sign, then cat - 1 low bits) are read at once where
    they hold no emulation-prevention bit either (entropy_coding._bits_local). The table read and the value
    read are written out in this loop rather than called: every call or inlined helper taking an array costs
    reference-count updates, which cost ~5x the ~16 ns the look-up itself takes."""
    n_ac = ac_out.shape[0]
    n_data = len(data)
    dc_symbol, dc_length = dc_lut[0], dc_lut[1]
    ac_symbol, ac_length = ac_lut[0], ac_lut[1]
    dc_first, dc_count, dc_start, dc_symbols = dc[0], dc[1], dc[2], dc[3]
    ac_first, ac_count, ac_start, ac_symbols = ac[0], ac[1], ac[2], ac[3]
    for p in range(len(dc_out)):
        k = -1                                    # -1: the DC code; then the AC position the next value fills
        while True:
            symbol = -1
            byte = pos >> 3
            if run + LUT_BITS < MAX_ZERO_RUN and pos + LUT_BITS <= end_bit and byte + 2 < n_data:
                window = (np.int64(data[byte]) << 16) | (np.int64(data[byte + 1]) << 8) | np.int64(data[byte + 2])
                peek = (window >> (24 - (pos & 7) - LUT_BITS)) & ((1 << LUT_BITS) - 1)
                length = dc_length[peek] if k < 0 else ac_length[peek]
                if length:
                    symbol = dc_symbol[peek] if k < 0 else ac_symbol[peek]
                    pos += length
                    run = _run_after(peek >> (LUT_BITS - length), length, run)
            if symbol < 0:
                if k < 0:
                    symbol, pos, run = _get_code_local(data, end_bit, pos, run, dc_first, dc_count, dc_start,
                                                       dc_symbols)
                else:
                    symbol, pos, run = _get_code_local(data, end_bit, pos, run, ac_first, ac_count, ac_start,
                                                       ac_symbols)
                if symbol < 0:
                    return symbol, pos, run
            if k < 0:
                cat = symbol
            else:
                if symbol == 0:                   # end of block
                    break
                k += (symbol - 1) // (n_categories - 1)          # the zeros before this value
                if k >= n_ac:
                    return -3, pos, run
                cat = (symbol - 1) % (n_categories - 1) + 1
            value = 0
            if cat:
                byte = pos >> 3
                if run + cat < MAX_ZERO_RUN and (pos & 7) + cat <= 24 and pos + cat <= end_bit and byte + 2 < n_data:
                    window = (np.int64(data[byte]) << 16) | (np.int64(data[byte + 1]) << 8) | np.int64(data[byte + 2])
                    bits = (window >> (24 - (pos & 7) - cat)) & ((1 << cat) - 1)
                    pos += cat
                    run = _run_after(bits, cat, run)
                else:
                    bits, pos, run = _bits_local(data, end_bit, pos, run, cat)
                    if bits < 0:
                        return -1, pos, run
                magnitude = (1 << (cat - 1)) + (bits & ((1 << (cat - 1)) - 1))
                value = -magnitude if bits >> (cat - 1) else magnitude
            if k < 0:
                dc_out[p] = value
            else:
                ac_out[k, p] = value
            k += 1
            if k >= n_ac:
                break
    return 0, pos, run


@njit(cache=True)
def read_dct_units(data, starts, ends, group_start, animatable, bone_ids, bone_masks, dc_intra, dc_inter, ac_table,
                   luts, n_categories: int, n_total: int, dc_out, ac_out, sizes, kfi_out) -> int:
    """Every DCT unit (segment): DC levels (DC differences of inter segments added up) into dc_out (U, P),
    AC levels into ac_out (U, 15, P) (zero-filled), frames into sizes (U,), KeyFrameIndex into kfi_out (U,).
    dc_intra, dc_inter, ac_table: the canonical Huffman tables as tuples (first code, count, start, symbols)
    of int64 arrays (comparisons/entropy.CanonicalHuffman.arrays()[2:]); luts: their huffman_lut, in that
    order. Returns OK or FALLBACK."""
    scratch = _head_scratch()
    display_end = 0
    for u in range(len(starts)):
        end_bit = ends[u]
        status, intra, number_field, kfi, n, pos, run = _read_head(data, starts, ends, u, True, group_start,
                                                                   animatable, bone_ids, bone_masks, scratch)
        if status:
            return FALLBACK
        if intra:
            status, pos, run = _read_dct_blocks(data, end_bit, pos, run, dc_intra, luts[0], ac_table, luts[2],
                                                n_categories, dc_out[u], ac_out[u, :n - 1])
        else:
            status, pos, run = _read_dct_blocks(data, end_bit, pos, run, dc_inter, luts[1], ac_table, luts[2],
                                                n_categories, dc_out[u], ac_out[u, :n - 1])
        if status:
            return FALLBACK
        if not intra:
            for p in range(dc_out.shape[1]):
                dc_out[u, p] += dc_out[u - 1, p]
        display_end = _read_tail(data, starts, ends, u, pos, run, intra, number_field, kfi, n, display_end, n_total)
        if display_end < 0:
            return FALLBACK
        sizes[u], kfi_out[u] = n, kfi
    return OK if display_end == n_total else FALLBACK

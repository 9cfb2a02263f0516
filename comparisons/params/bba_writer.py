"""Numba-compiled whole-stream writers of the BBA stream (comparisons/params/bba.py documents the format).

The inverse of comparisons/params/bba_units.py for the streams comparisons/bba_codec._write_arrays makes: every unit
carries the same bone list and no muscle data. One call writes the whole stream, bit for bit what the
per-field writer (bba_codec._write with comparisons/bitstream.BitWriter) writes: the BBA start code and
header (its data bits given, then the range fields and CRC-8), each unit (frame start code, fields, bone
list on intra units, values, NSBM = 0, CRC-8), a header copy before every header_period-th intra unit after
the first, and the end code. Start codes follow MPEG next_start_code() stuffing (a 0, then 1s to the byte
boundary); data bits get a 1 after 22 consecutive 0s (comparisons/params/bits.py).

Predictive values: per unit, the symbols level - low coded from a fresh arithmetic coder and flushed
(kernels/entropy_coding.encode_frame's integer arithmetic and bits); an intra unit codes each value with a
fresh all-ones model of its intra alphabet (used once), a predicted unit with the adaptive model of its
predicted alphabet, all reset at every intra unit. The coder's settled bits go a chunk at a time (arithmetic.renormalise_encoder,
inlined: the bit-at-a-time loop's bits; Numba's cache keys a kernel on its own file, so a change to the inlined
primitives is a change here too). The adaptive models are kept in excess form (counts - 1,
Fenwick tree - (i & -i), as comparisons/params/frames.py), so a fresh bank is all zeros. A unit whose alphabets
all have one symbol writes no coded bits. DCT values: kernels/entropy_coding.write_dct_blocks per segment,
an inter segment's DC levels as differences from the previous segment's.

The writer state (bit position, zero run) and the coder registers are local variables. The caller gives a
zero-filled buffer large enough (STATUS_FULL otherwise, nothing is valid then). Imports nothing of
signcast's Python modules.
"""
import math

import numpy as np
from numba import njit

from comparisons.params.arithmetic import (
    MAX_ZERO_RUN,
    PRECISION,
    TOP,
    crc8_bytes,
    encode_interval,
    finish_encoder,
    put_bit_local,
    write_dct_blocks,
)

BBA_START_CODE, FRAME_START_CODE, END_CODE = 0xD0, 0xD1, 0xD3
FRAME_NUMBER_BITS, P_FRAME_NUMBER_BITS, KFI_BITS, MUSCLE_COUNT_BITS, CRC_BITS = 24, 8, 5, 10, 8
STATUS_FULL = -1            # the buffer is too small
STATUS_SYMBOL = -2          # a level outside its alphabet (detail: unit, value, symbol, alphabet size)
STATUS_DCT_LEVEL = -3       # a DCT level beyond the largest category (detail[0]: the level)
STATUS_DCT_CODE = -4        # a DCT symbol without a Huffman code (detail[0]: the symbol)
STATUS_LIMIT = -5           # a predicted model would reach the frequency limit (the caller writes otherwise)


@njit(cache=True)
def _put_bits(buffer, pos: int, run: int, value: int, n_bits: int) -> tuple[int, int]:
    for shift in range(n_bits - 1, -1, -1):
        pos, run = put_bit_local(buffer, pos, run, (value >> shift) & 1)
    return pos, run


@njit(cache=True)
def _put_array(buffer, pos: int, run: int, bits) -> tuple[int, int]:
    """bits (N,) uint8 of 0 and 1, in order."""
    for k in range(len(bits)):
        pos, run = put_bit_local(buffer, pos, run, bits[k])
    return pos, run


@njit(cache=True)
def _start_code(buffer, pos: int, code: int) -> int:
    """next_start_code() stuffing then the byte-aligned 0x000001<code> (zero run 0 after it): the position."""
    pos += 1                                      # the 0 bit (the buffer is zero-filled)
    while pos & 7:
        buffer[pos >> 3] |= np.uint8(0x80 >> (pos & 7))
        pos += 1
    byte = pos >> 3
    buffer[byte + 2] = 1
    buffer[byte + 3] = code
    return pos + 32


@njit(cache=True)
def _header(buffer, pos: int, header_bits, tight: bool, fields, range_bits: int) -> int:
    """The BBA start code, the header's data bits, the range fields (tight: a marker 1 before every 4 values
    of each row, then each field in range_bits bits), the CRC-8 from the start code's last byte: the position."""
    pos = _start_code(buffer, pos, BBA_START_CODE)
    start = pos - 8
    pos, run = _put_array(buffer, pos, 0, header_bits)
    if tight:
        for r in range(fields.shape[0]):
            for j in range(fields.shape[1]):
                if j % 4 == 0:
                    pos, run = put_bit_local(buffer, pos, run, 1)
                pos, run = _put_bits(buffer, pos, run, fields[r, j], range_bits)
    pos, run = _put_bits(buffer, pos, run, crc8_bytes(buffer, start, pos), CRC_BITS)
    return pos


@njit(cache=True)
def _unit_head(buffer, pos: int, header_bits, tight: bool, fields, range_bits: int, header_period: int,
               n_intra: int, intra: bool, number: int, kfi: int, dct_frames: int, list_bits
               ) -> tuple[int, int, int, int]:
    """A header copy where due, the frame start code and the unit's fields up to its values: (position, zero
    run, unit start, intra units so far). dct_frames: the segment's frames (DCT), 0 (predictive)."""
    if intra:
        if header_period and n_intra and n_intra % header_period == 0:
            pos = _header(buffer, pos, header_bits, tight, fields, range_bits)
        n_intra += 1
    pos = _start_code(buffer, pos, FRAME_START_CODE)
    start = pos
    pos, run = put_bit_local(buffer, pos, 0, 1 if intra else 0)
    if intra:
        pos, run = _put_bits(buffer, pos, run, number, FRAME_NUMBER_BITS)
    else:
        pos, run = _put_bits(buffer, pos, run, number % (1 << P_FRAME_NUMBER_BITS), P_FRAME_NUMBER_BITS)
    pos, run = _put_bits(buffer, pos, run, kfi, KFI_BITS)
    if dct_frames:
        pos, run = _put_bits(buffer, pos, run, dct_frames - 1, 4)
    if intra:
        pos, run = _put_array(buffer, pos, run, list_bits)
    else:
        pos, run = put_bit_local(buffer, pos, run, 1)      # same_mask: every unit carries the first unit's bone list
    return pos, run, start, n_intra


@njit(cache=True)
def _unit_tail(buffer, pos: int, run: int, start: int) -> int:
    """NSBM = 0 and the unit's CRC-8: the position."""
    pos, run = _put_bits(buffer, pos, run, 0, MUSCLE_COUNT_BITS)
    pos, run = _put_bits(buffer, pos, run, crc8_bytes(buffer, start, pos), CRC_BITS)
    return pos


@njit(cache=True)
def _encode_levels(buffer, pos: int, run: int, levels, u: int, low, sizes, fresh: bool, coded, n_coded) -> tuple[int, int]:
    """entropy_coding.encode_frame of unit u's symbols levels[u] - low: a fresh coder, flushed. fresh: all-ones
    models used once. Otherwise model p is all ones plus one count for each of the n_coded[p] symbols it coded
    since its reset, coded[p, :n_coded[p]] (the symbol is then added): its total stays below the frequency
    limit (see write_predictive_stream), so the models are never halved."""
    low_, high, pending = 0, TOP, 0
    for p in range(levels.shape[1]):
        symbol = levels[u, p] - low[p]
        cumulative = symbol
        count = 1
        total = sizes[p]
        if not fresh:
            k = n_coded[p]
            for j in range(k):
                earlier = coded[p, j]
                if earlier < symbol:
                    cumulative += 1
                elif earlier == symbol:
                    count += 1
            total += k
            coded[p, k] = symbol
            n_coded[p] = k + 1
        pos, run, low_, high, pending = encode_interval(buffer, pos, run, low_, high, pending, cumulative,
                                                        cumulative + count, total)
    return finish_encoder(buffer, pos, run, low_, pending)


@njit(cache=True)
def write_predictive_stream(buffer, header_bits, tight: bool, fields, range_bits: int, list_bits, header_period: int,
                            numbers, kfi, intra, levels, low_i, sizes_i, low_p, sizes_p, limit: int, detail) -> int:
    """The whole predictive stream into buffer (zero-filled uint8); returns the bits written or a STATUS_*.

    header_bits (H,) uint8 0/1: the header's data bits after its start code, up to the range fields; fields
    (4, P) int64 (written when tight) in range_bits bits each; list_bits (L,) uint8 0/1: the bone list (NSBB
    and each bone's ID and mask) intra units carry; header_period: a header copy before every n-th intra unit
    after the first (0: never). Per unit (U,) int64: numbers (display frame), kfi (KeyFrameIndex), intra
    (bool); levels (U, P) int64. low_*, sizes_* (P,) int64: the intra and predicted alphabets (first level,
    number of levels); limit: the adaptive models' frequency limit (entropy_coding.update halves a model whose
    total exceeds it; a predicted model's total here is its size plus the predicted units since the last intra
    unit, which must stay within limit: STATUS_LIMIT otherwise, nothing written). detail (4,) int64 says what a
    STATUS_SYMBOL was."""
    n_units, n_values = levels.shape
    capacity = 8 * len(buffer)
    coded_i, coded_p = False, False
    for p in range(n_values):
        coded_i = coded_i or sizes_i[p] != 1
        coded_p = coded_p or sizes_p[p] != 1
    for u in range(n_units):
        if not (coded_i if intra[u] else coded_p):
            continue                              # nothing coded: the levels are not looked at
        low, sizes = (low_i, sizes_i) if intra[u] else (low_p, sizes_p)
        for p in range(n_values):
            symbol = levels[u, p] - low[p]
            if symbol < 0 or symbol >= sizes[p]:
                detail[0], detail[1], detail[2], detail[3] = u, p, symbol, sizes[p]
                return STATUS_SYMBOL
    run_p, longest = 0, 0                         # predicted units since the last intra unit
    largest = 0
    for p in range(n_values):
        largest = max(largest, sizes_p[p])
    for u in range(n_units):
        run_p = 0 if intra[u] else run_p + 1
        longest = max(longest, run_p)
    if largest + longest > limit:
        return STATUS_LIMIT
    coded = np.empty((n_values, max(longest, 1)), dtype=np.int64)
    n_coded = np.zeros(n_values, dtype=np.int64)
    pos = _header(buffer, 0, header_bits, tight, fields, range_bits)
    n_intra = 0
    for u in range(n_units):
        # Room for this unit: a header copy, the fields and bone list, at most 4 PRECISION bits a value
        # (entropy.encode_frame's reserve) with their emulation-prevention bits, the tail, the end code.
        room = 2 * (len(header_bits) + 8 * fields.size) + len(list_bits) + 4 * PRECISION * (n_values + 1) + 256
        if pos + room + room // MAX_ZERO_RUN > capacity:
            return STATUS_FULL
        pos, run, start, n_intra = _unit_head(buffer, pos, header_bits, tight, fields, range_bits, header_period,
                                              n_intra, intra[u], numbers[u], kfi[u], 0, list_bits)
        fresh = intra[u] != 0                     # a run-time flag: a literal True and False compile twice
        if fresh:
            n_coded[:] = 0
        if coded_i if fresh else coded_p:
            pos, run = _encode_levels(buffer, pos, run, levels, u, low_i if fresh else low_p,
                                      sizes_i if fresh else sizes_p, fresh, coded, n_coded)
        pos = _unit_tail(buffer, pos, run, start)
    return _start_code(buffer, pos, END_CODE)


@njit(cache=True)
def write_dct_stream(buffer, header_bits, list_bits, header_period: int, numbers, sizes, intra, dc, ac,
                     dc_intra_codes, dc_intra_lengths, dc_inter_codes, dc_inter_lengths, ac_codes, ac_lengths,
                     n_categories: int, detail) -> int:
    """The whole DCT stream into buffer (zero-filled uint8); returns the bits written or a STATUS_*.

    header_bits, list_bits, header_period as write_predictive_stream (a DCT header has no range fields). Per
    segment (U,) int64: numbers (display frame of its first frame), sizes (frames, 1..16), intra (bool); dc
    (U, P) int64 DC levels, ac (U, 15, P) int64 AC levels (rows sizes[u] - 1 on are not written). The Huffman
    tables as codes and lengths (comparisons/entropy.CanonicalHuffman.arrays()[:2]). detail (1,) int64 says
    what a STATUS_DCT_* was."""
    n_units, n_values = dc.shape
    capacity = 8 * len(buffer)
    no_fields = np.zeros((0, 0), dtype=np.int64)
    dc_values = np.empty(n_values, dtype=np.int64)
    state = np.zeros(2, dtype=np.int64)
    pos = _header(buffer, 0, header_bits, False, no_fields, 0)
    n_intra = 0
    for u in range(n_units):
        # Room: a header copy, the fields and bone list, 72 bits a coefficient (param_coding's reserve).
        room = 2 * len(header_bits) + len(list_bits) + 72 * n_values * sizes[u] + 256
        if pos + room + room // MAX_ZERO_RUN > capacity:
            return STATUS_FULL
        pos, run, start, n_intra = _unit_head(buffer, pos, header_bits, False, no_fields, 0, header_period,
                                              n_intra, intra[u], numbers[u], 0, sizes[u], list_bits)
        for p in range(n_values):
            dc_values[p] = dc[u, p] if intra[u] else dc[u, p] - dc[u - 1, p]
        state[0], state[1] = pos, run
        if intra[u]:
            status, value = write_dct_blocks(buffer, state, dc_values, ac[u, :sizes[u] - 1], dc_intra_codes,
                                             dc_intra_lengths, ac_codes, ac_lengths, n_categories)
        else:
            status, value = write_dct_blocks(buffer, state, dc_values, ac[u, :sizes[u] - 1], dc_inter_codes,
                                             dc_inter_lengths, ac_codes, ac_lengths, n_categories)
        if status:
            detail[0] = value
            return STATUS_DCT_LEVEL if status == 1 else STATUS_DCT_CODE
        pos = _unit_tail(buffer, state[0], state[1], start)
    return _start_code(buffer, pos, END_CODE)


@njit(cache=True)
def range_fields(levels, intra, q, delta):
    """(4, K) int64 range fields of a predictive stream whose units all carry every key: rows I max, I min,
    P max, P min, each the smallest field whose alphabet holds the levels (F, K) of the intra units (intra
    (F,) bool) or of the others: ceil(max(top, 0) q / delta) with top the largest level (the smallest's
    negation for a min field), 0 where there is no such unit (comparisons/param_coding.range_fields)."""
    n, k = levels.shape
    top = np.zeros((4, k), np.int64)
    for t in range(n):
        row = 0 if intra[t] else 2
        for c in range(k):
            v = levels[t, c]
            top[row, c] = max(top[row, c], v)
            top[row + 1, c] = max(top[row + 1, c], -v)
    fields = np.empty((4, k), np.int64)
    for r in range(4):
        for c in range(k):
            fields[r, c] = -(-top[r, c] * q // delta)
    return fields


# Relative gap below which `range_cost_gap` leaves the choice to the caller's NumPy sums: its sequential sums of
# K <= 1023 terms (each a count times log2) differ from NumPy's pairwise ones by far less (< 1e-12).
COST_MARGIN = 1e-9


@njit(cache=True)
def range_cost_gap(fields, n_intra, n_predicted, q, delta, default_field, field_bits):
    """The choice of comparisons/bba_codec._range_choice for units that all carry every key, compiled: fields
    (4, K) int64 (`range_fields`), n_intra and n_predicted the units of each kind. The default alphabets win
    where their estimated cost, sum over keys of n_intra log2(intra alphabet size) + n_predicted log2(predicted
    alphabet size), is below the tight fields' plus the fields' own 4 field_bits K bits. Returns 1 (default),
    0 (tight) or -1 (the two within COST_MARGIN of each other: the caller decides with NumPy's sums)."""
    k = fields.shape[1]
    default_cost = 0.0
    tight_cost = 0.0
    default_low, default_high = -(default_field * delta // q), default_field * delta // q
    default_bits = math.log2(default_high - default_low + 1)
    for c in range(k):
        default_cost += n_intra * default_bits + n_predicted * default_bits
        i_size = fields[0, c] * delta // q + (fields[1, c] * delta // q) + 1
        p_size = fields[2, c] * delta // q + (fields[3, c] * delta // q) + 1
        tight_cost += n_intra * math.log2(i_size) + n_predicted * math.log2(p_size)
    tight_cost += 4 * field_bits * k
    if abs(default_cost - tight_cost) <= COST_MARGIN * (default_cost + tight_cost):
        return -1
    return 1 if default_cost < tight_cost else 0


@njit(cache=True)
def frame_checks(kfi, values, max_kfi):
    """What comparisons/bba_codec._write_arrays checks of its arrays, in one pass: kfi (F,) int64 KeyFrameIndex of
    each frame, values (F, P) int64. Returns (numbers (F,) int64 the display frames, cumsum(kfi + 1) - 1; the index
    of the first KeyFrameIndex outside 0..max_kfi, or -1; whether any KeyFrameIndex is nonzero; the largest
    |value|, 0 for none; int64's most negative number, whose magnitude int64 cannot hold (what an out-of-range
    quantisation gives), counts as its largest number)."""
    numbers = np.empty(len(kfi), np.int64)
    total = 0
    bad = -1
    nonzero = False
    for t in range(len(kfi)):
        total += kfi[t] + 1
        numbers[t] = total - 1
        if bad < 0 and not 0 <= kfi[t] <= max_kfi:
            bad = t
        nonzero = nonzero or kfi[t] != 0
    largest = 0
    for t in range(values.shape[0]):
        for p in range(values.shape[1]):
            v = values[t, p]
            magnitude = -v if v < 0 else v
            if magnitude < 0:                   # -(-2**63) wraps
                magnitude = 9223372036854775807
            largest = max(largest, magnitude)
    return numbers, bad, nonzero, largest

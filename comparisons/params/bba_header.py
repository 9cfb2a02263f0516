"""Numba-compiled pieces of the BBA header reader (comparisons/params/bba.py `_read_header`).

`read_header` is the whole header of a good stream in one call (the reader's pieces below, its CRC and the start
code after it); it decides no error: on anything unusual it returns FALLBACK and the caller's checked reader
(comparisons/params/bba.py `_read_header_checked`) reads the header again and raises its error.
The range fields are kernels/param_frames.read_range_fields' (imported here for the header reader's callers).
Imports nothing of signcast's Python modules.
"""
import numpy as np
from numba import njit

from comparisons.params.bba_masks import read_bone_table
from comparisons.params.arithmetic import _bits_local, crc8_bytes
from comparisons.params.frames import alphabets as field_alphabets
from comparisons.params.frames import read_range_fields

OK, END_OF_DATA, MISSING_MARKER = 0, -1, -10        # param_frames' statuses
FALLBACK = 1                                        # read_header: not a plain good header; ask the checked reader


@njit(cache=True)
def header_keys(ids, masks):
    """The header's values in stream order (bones by ascending ID, bits ascending): (boneIDs (K,), bits (K,))
    int64 of bones ids (B,) with animatable masks (B,) of at most 16 bits."""
    order = np.argsort(ids, kind="mergesort")
    n = 0
    for b in range(len(ids)):
        for k in range(16):
            n += (masks[b] >> k) & 1
    key_ids, key_bits = np.empty(n, dtype=np.int64), np.empty(n, dtype=np.int64)
    j = 0
    for i in range(len(order)):
        b = order[i]
        for k in range(16):
            if (masks[b] >> k) & 1:
                key_ids[j], key_bits[j] = ids[b], k
                j += 1
    return key_ids, key_bits


@njit(cache=True)
def read_fields(data, end_bit: int, state, widths, out) -> int:
    """Fields of widths (N,) int64 bits each (at most 62) one after the other, as get_bits reads them, into out
    (N,) int64; state (3,) int64 the reader (position, zero run, bits read past the end), left after the
    last field read. Returns how many were read: N, or fewer where the data end inside the next one."""
    pos, run = state[0], state[1]
    n = 0
    for k in range(len(widths)):
        value, new_pos, new_run = _bits_local(data, end_bit, pos, run, widths[k])
        if value < 0:
            break
        out[k], pos, run = value, new_pos, new_run
        n += 1
    state[0], state[1] = pos, run
    return n


@njit(cache=True)
def _at_start_code(data, pos: int, end_bit: int) -> bool:
    """BitReader.at_start_code: next_start_code()'s stuffing (a 0, then 1s to the byte's end) and a start code
    prefix 00 00 01 follow pos, the start code's fourth byte inside end_bit."""
    if pos >= end_bit:
        return False
    n_stuff = 8 - (pos & 7)
    if data[pos >> 3] & ((1 << n_stuff) - 1) != (1 << (n_stuff - 1)) - 1:
        return False
    byte = (pos + n_stuff) >> 3
    return (byte + 4 <= end_bit >> 3 and byte + 3 <= len(data) and data[byte] == 0 and data[byte + 1] == 0
            and data[byte + 2] == 1)


@njit(cache=True)
def read_header(data, start_bit: int, crc_start_bit: int, widths, group_start, range_bits: int, default_field: int,
                delta: int, values):
    """The BBA header whose fields start at start_bit (the bit after its start code; its CRC-8 covers the bits
    from crc_start_bit), data (N,) uint8 the whole stream. values (13,) int64 receives the fixed fields of
    widths (comparisons/bba_codec._HEADER_WIDTHS: ..., coding at 4, Q at 6, tight ranges at 11, bone count at
    12). Returns (status, ids, masks, exponents (B,) int64 the bone table, key_ids, key_bits (K,) int64 the
    values in stream order, fields (4, K) int64 the range fields (announced, or default_field each where the
    header carries none; (4, 0) for a DCT stream), alphabets (4, K) int64 their levels (param_frames.alphabets:
    I low, I high, P low, P high), animatable (1024,) int64 mask by boneID, -1 where absent). status is OK,
    or FALLBACK where a field is missing, a boneID repeats, the coding type is unknown, a range field lacks
    its marker, the CRC differs or no start code follows: the checked reader then says which."""
    end_bit = 8 * len(data)
    registers = np.zeros(3, dtype=np.int64)
    registers[0] = start_bit
    empty = np.empty(0, dtype=np.int64)
    no_table = np.empty((4, 0), dtype=np.int64)
    animatable = np.full(1024, -1, dtype=np.int64)
    if read_fields(data, end_bit, registers, widths, values) < len(widths) or values[4] > 1 or values[6] == 0:
        return FALLBACK, empty, empty, empty, empty, empty, no_table, no_table, animatable
    n_bones = values[12]
    ids, masks, exponents = np.zeros(n_bones, np.int64), np.zeros(n_bones, np.int64), np.zeros(n_bones, np.int64)
    if read_bone_table(data, end_bit, registers, group_start, ids, masks, exponents) != OK:
        return FALLBACK, empty, empty, empty, empty, empty, no_table, no_table, animatable
    for b in range(n_bones):
        if animatable[ids[b]] >= 0:
            return FALLBACK, empty, empty, empty, empty, empty, no_table, no_table, animatable
        animatable[ids[b]] = masks[b]
    key_ids, key_bits = header_keys(ids, masks)
    pred = values[4] == 0
    fields = np.full((4, len(key_ids) if pred else 0), default_field, dtype=np.int64)
    if pred and values[11] and read_range_fields(data, end_bit, registers, fields, range_bits) != OK:
        return FALLBACK, empty, empty, empty, empty, empty, no_table, no_table, animatable
    expected = crc8_bytes(data, crc_start_bit, registers[0])
    crc, pos, _ = _bits_local(data, end_bit, registers[0], registers[1], 8)
    if crc != expected or not _at_start_code(data, pos, end_bit):
        return FALLBACK, empty, empty, empty, empty, empty, no_table, no_table, animatable
    low_i, high_i, low_p, high_p = field_alphabets(fields, values[6], delta)
    alphabets = np.empty((4, fields.shape[1]), dtype=np.int64)
    alphabets[0], alphabets[1], alphabets[2], alphabets[3] = low_i, high_i, low_p, high_p
    return OK, ids, masks, exponents, key_ids, key_bits, fields, alphabets, animatable

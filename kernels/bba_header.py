"""Numba-compiled pieces of the BBA header reader (comparisons/bba_codec.py `_read_header`).

`read_range_fields` is kernels/param_frames.read_range_fields (fields (R, P) row by row, each in n_bits, a
marker bit 1 before every 4 parameters of a row; emulation-prevention bits dropped) with the reader's
position and zero run in locals (entropy_coding.get_local) instead of the state array: the same bits, the
same statuses, the same reader state after it. Imports nothing of signcast's Python modules.
"""
import numpy as np
from numba import njit

from kernels.entropy_coding import MAX_ZERO_RUN, get_local

OK, END_OF_DATA, MISSING_MARKER = 0, -1, -10        # param_frames' statuses


@njit(cache=True)
def _bits_local(data, end_bit: int, pos: int, run: int, n_bits: int) -> tuple[int, int, int]:
    """n_bits (at most 62) data bits as get_local reads them one by one: (value or -1, pos, run). When the
    zero run cannot reach MAX_ZERO_RUN inside them (run + n_bits below it), no emulation-prevention bit can
    lie among them: they are the raw bits, read at once."""
    byte = pos >> 3
    if run + n_bits < MAX_ZERO_RUN and (pos & 7) + n_bits <= 24 and pos + n_bits <= end_bit and byte + 2 < len(data):
        window = (np.int64(data[byte]) << 16) | (np.int64(data[byte + 1]) << 8) | np.int64(data[byte + 2])
        value = (window >> (24 - (pos & 7) - n_bits)) & ((1 << n_bits) - 1)
        if value == 0:
            run += n_bits
        else:
            trailing = 0
            while not (value >> trailing) & 1:
                trailing += 1
            run = trailing
        return value, pos + n_bits, run
    value = 0
    for _ in range(n_bits):
        bit, pos, run = get_local(data, end_bit, pos, run)
        if bit < 0:
            return -1, pos, run
        value = (value << 1) | bit
    return value, pos, run


@njit(cache=True)
def read_range_fields(data, end_bit: int, state, fields, n_bits: int) -> int:
    """param_frames.read_range_fields into fields (R, P) int64; state (3,) int64 the reader (position, zero
    run, bits read past the end). Returns OK, END_OF_DATA or MISSING_MARKER."""
    pos, run = state[0], state[1]
    status = OK
    for r in range(fields.shape[0]):
        for j in range(fields.shape[1]):
            if j % 4 == 0:
                marker, pos, run = get_local(data, end_bit, pos, run)
                if marker < 0:
                    status = END_OF_DATA
                    break
                if marker != 1:
                    status = MISSING_MARKER
                    break
            value, pos, run = _bits_local(data, end_bit, pos, run, n_bits)
            if value < 0:
                status = END_OF_DATA
                break
            fields[r, j] = value
        if status:
            break
    state[0], state[1] = pos, run
    return status


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

"""Numba-compiled readers of the BBA stream's bone masks (comparisons/params/bba.py documents the format).

Two loops of many one-bit fields: the header's bone table (per bone its boneID u10, animatable mask:
5 level-1 bits then, for each announced motion type, one bit per elementary motion of the type; the
rotation step exponent u4) and a unit's bone list (boneID u10 and the hierarchical mask: per motion
type the bone may carry, a used bit, then one bit per elementary motion it may carry). They read
through kernels/entropy_coding's bit reader (emulation prevention included) with the position and zero run
in locals, taken from and left in the BitReader's state array (registers); comparisons/params/bba.py raises SigncastError from the status codes.

Motion types are given as group_start (6,) int64: the elementary-motion bits of type g are
group_start[g] .. group_start[g + 1] - 1 (MASK_TYPES: 0-2, 3-5, 6-8, 9-12, 13-15).
"""
import numpy as np
from numba import njit

from comparisons.params.arithmetic import _bits_local, get_local

OK, TRUNCATED, EMPTY_TYPE, UNKNOWN_BONE = 0, -1, -2, -3


@njit(cache=True, inline="always")
def _read_motion_bits(data, end_bit: int, pos: int, run: int, first: int, stop: int, allowed_mask: int, mask: int
                      ) -> tuple[int, int, int]:
    """One bit per elementary motion b in first..stop - 1 that allowed_mask has (-1: every one), set at bit b of
    mask: (mask, pos, run), mask -1 when the data ends first."""
    for b in range(first, stop):
        if (allowed_mask >> b) & 1:
            bit, pos, run = get_local(data, end_bit, pos, run)
            if bit < 0:
                return -1, pos, run
            mask |= bit << b
    return mask, pos, run


@njit(cache=True)
def read_bone_table(data: np.ndarray, end_bit: int, registers: np.ndarray, group_start: np.ndarray,
                    ids: np.ndarray, masks: np.ndarray, exponents: np.ndarray) -> int:
    """Fill ids, masks, exponents (n,) int64 with the header's n = len(ids) bone entries.
    Returns OK, TRUNCATED, or EMPTY_TYPE (a motion type announced without any elementary motion)."""
    n_types = len(group_start) - 1
    present = np.zeros(n_types, dtype=np.int64)
    pos, run = registers[0], registers[1]
    status = OK
    for k in range(len(ids)):
        bone, pos, run = _bits_local(data, end_bit, pos, run, 10)
        if bone < 0:
            status = TRUNCATED
            break
        any_present = False
        for g in range(n_types):
            present[g], pos, run = get_local(data, end_bit, pos, run)
            if present[g] < 0:
                status = TRUNCATED
                break
            any_present = any_present or present[g] == 1
        if status:
            break
        mask = 0
        for g in range(n_types):
            if present[g]:
                mask, pos, run = _read_motion_bits(data, end_bit, pos, run, group_start[g], group_start[g + 1], -1,
                                                   mask)
                if mask < 0:
                    status = TRUNCATED
                    break
        if status:
            break
        if any_present and mask == 0:
            status = EMPTY_TYPE
            break
        exponent, pos, run = _bits_local(data, end_bit, pos, run, 4)
        if exponent < 0:
            status = TRUNCATED
            break
        ids[k], masks[k], exponents[k] = bone, mask, exponent
    registers[0], registers[1] = pos, run
    return status


@njit(cache=True)
def read_unit_bones(data: np.ndarray, end_bit: int, registers: np.ndarray, group_start: np.ndarray,
                    animatable: np.ndarray, ids: np.ndarray, masks: np.ndarray, result: np.ndarray) -> int:
    """A unit's bone list: NSBB u10, then per bone its boneID and hierarchical mask.

    animatable: (1024,) int64 the header's animatable mask per boneID, -1 for a bone not in the header.
    ids, masks: (1023,) int64 filled with the entries in stream order; result[0] = their number
    (NSBB), result[1] = the boneID not in the header (status UNKNOWN_BONE). Returns OK, TRUNCATED or
    UNKNOWN_BONE."""
    pos, run = registers[0], registers[1]
    status = OK
    n, pos, run = _bits_local(data, end_bit, pos, run, 10)
    if n < 0:
        status = TRUNCATED
    else:
        result[0] = n
    for k in range(max(n, 0)):
        bone, pos, run = _bits_local(data, end_bit, pos, run, 10)
        if bone < 0:
            status = TRUNCATED
            break
        allowed_mask = animatable[bone]
        if allowed_mask < 0:
            result[1] = bone
            status = UNKNOWN_BONE
            break
        mask = 0
        for g in range(len(group_start) - 1):
            allowed = False
            for b in range(group_start[g], group_start[g + 1]):
                allowed = allowed or (allowed_mask >> b) & 1 == 1
            if not allowed:
                continue
            used, pos, run = get_local(data, end_bit, pos, run)
            if used < 0:
                status = TRUNCATED
                break
            if used:
                mask, pos, run = _read_motion_bits(data, end_bit, pos, run, group_start[g], group_start[g + 1],
                                                   allowed_mask, mask)
                if mask < 0:
                    status = TRUNCATED
                    break
        if status:
            break
        ids[k], masks[k] = bone, mask
    registers[0], registers[1] = pos, run
    return status

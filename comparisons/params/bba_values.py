"""Numba loop of the BBA encoder's analysis after the Euler split (comparisons/params/bba.py `_motion_arrays`):
rounding to the stream's units, the sent columns and the bone masks, integer work but for one division and rint
per value (tests/test_bba_encode_speed.py compares it with the NumPy form, `_motion_arrays_numpy`).
"""
import numpy as np
from numba import njit


@njit(cache=True)
def _to_int(x: float) -> int:
    """np.round(x).astype(np.int64) of one value: round half to even; out of int64's range (or NaN) the
    x86 conversion's answer, -2**63, as NumPy's cast gives there."""
    r = np.rint(x)
    if not -9.223372036854775e18 <= r <= 9.223372036854775e18:
        return -9223372036854775807 - 1
    return int(r)


@njit(cache=True)
def motion_values(angles, translation, source, steps, is_angle, q, rotation_unit, translation_unit, period,
                  first, key_order, key_bone, key_bit):
    """The BBA encoder's values and mask (comparisons/params/bba.py `_motion_arrays`) from the Euler split.

    angles (K, B, 3) radians, translation (K, 3) metres; source (C,) each candidate column's index in
    [translation (3), bone j axis a (3 + 3 j + a)]; steps (C,) base steps; is_angle (C,); q the global
    quantisation; first (C,) each column's first column of its (boneID, bit); key_order (U,) the first
    columns sorted by (boneID, bit), key_bone / key_bit (U,) theirs. Values are round(angle / rotation_unit)
    and round(translation / translation_unit) (np.round: half to even). A column is sent when a frame's
    value, folded into (-period / 2, period / 2] where it is an angle, quantises to a non-zero level at
    steps * q, i.e. 2 |v| > steps * q (param_coding.quantize); a value out of int64's range (-2**63) is sent,
    so that the writer rejects it. Returns (values (K, P) int64 of the sent
    (boneID, bit) in stream order, bones (M,) int64 ascending with masks (M,) int64 their sent bits, and
    order (M,) each bone's first sent column: `_motion_arrays` builds its mask dict in that order)."""
    n, n_bones = angles.shape[0], angles.shape[1]
    n_columns = len(source)
    raw = np.empty((n, 3 + 3 * n_bones), np.int64)
    for t in range(n):
        for a in range(3):
            raw[t, a] = _to_int(translation[t, a] / translation_unit)
        for b in range(n_bones):
            for a in range(3):
                raw[t, 3 + 3 * b + a] = _to_int(angles[t, b, a] / rotation_unit)
    half = period // 2
    sent = np.zeros(n_columns, np.bool_)
    sent_at = np.full(n_columns, n_columns, np.int64)      # key (its first column) -> first sent column of it
    for c in range(n_columns):
        limit = steps[c] * q
        s = source[c]
        for t in range(n):
            v = raw[t, s]
            if is_angle[c]:
                v = half - (half - v) % period
            if abs(v) > limit // 2 or v == -9223372036854775807 - 1:    # 2 |v| > limit, without overflow
                sent[first[c]] = True
                sent_at[first[c]] = min(sent_at[first[c]], c)
                break
    n_sent = 0
    n_masks = 0
    last = 0
    for u in range(len(key_order)):
        if sent[key_order[u]]:
            n_sent += 1
            if n_sent == 1 or key_bone[u] != key_bone[last]:
                n_masks += 1
            last = u
    values = np.empty((n, n_sent), np.int64)
    bones = np.empty(n_masks, np.int64)
    masks = np.zeros(n_masks, np.int64)
    order = np.full(n_masks, n_columns, np.int64)
    p = 0
    m = -1
    for u in range(len(key_order)):
        c = key_order[u]
        if sent[c]:
            if m < 0 or key_bone[u] != bones[m]:
                m += 1
                bones[m] = key_bone[u]
            masks[m] |= np.int64(1) << key_bit[u]
            order[m] = min(order[m], sent_at[c])
            s = source[c]
            for t in range(n):
                values[t, p] = raw[t, s]
            p += 1
    return values, bones, masks, order

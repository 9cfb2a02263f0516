"""Numba-compiled whole-loop kernels of the FBA/BBA parameter streams (comparisons/fba_codec.py,
comparisons/param_coding.py document the syntax): closed-loop predictive quantisation, group masks
and range fields, and every frame of levels of an intra period in one call each way.

They build on kernels/entropy_coding.py (bit writer with start-code emulation prevention, the
Witten-Neal-Cleary arithmetic coder over Fenwick-tree model banks) and write exactly the bits the
per-field calls wrote, so streams stay byte-identical. Like entropy_coding they import nothing of
the package's Python modules and return status codes; comparisons/ raises SigncastError from them.

Status codes of the readers: 0 done, -1 the data ends inside a field, -2 corrupt arithmetic-coded
data, -3 arithmetic-coded data ends early; the group-mask and range-field readers add their own
(see each docstring).
"""
import numpy as np
from numba import njit

from kernels.entropy_coding import (
    HALF,
    HISTORY,
    INCREMENT,
    LIMIT,
    MAX_ZERO_RUN,
    PRECISION,
    QUARTER,
    THREE_QUARTERS,
    TOP,
    TOP_BIT,
    TOTAL,
    N,
    get_bit,
    get_bits,
    put_bit,
    put_bits,
)

END_OF_DATA, CORRUPT_CODE, CODE_ENDS_EARLY = -1, -2, -3


# ------------------------------------------------------------------ quantisation (param_coding.quantize)

@njit(cache=True)
def quantize_one(value: int, step: int) -> int:
    """Level 0 if |v| <= step/2, else sign(v) (|v| + step//2) // step."""
    magnitude = abs(value)
    if 2 * magnitude <= step:
        return 0
    level = (magnitude + step // 2) // step
    return -level if value < 0 else level


@njit(cache=True)
def changed_mask(block, held, steps):
    """(C,) bool: the columns of block (T, C) whose quantised difference from held (C,) is ever nonzero."""
    n_frames, n_columns = block.shape
    mask = np.zeros(n_columns, dtype=np.bool_)
    for c in range(n_columns):
        for t in range(n_frames):
            if quantize_one(block[t, c] - held[c], steps[c]) != 0:
                mask[c] = True
                break
    return mask


@njit(cache=True)
def settled_count(block, held, steps) -> int:
    """Columns of block (T, C) whose level against held is nonzero in frame 0 and the same in every frame."""
    n_frames, n_columns = block.shape
    count = 0
    for c in range(n_columns):
        first = quantize_one(block[0, c] - held[c], steps[c])
        if first == 0:
            continue
        same = True
        for t in range(1, n_frames):
            if quantize_one(block[t, c] - held[c], steps[c]) != first:
                same = False
                break
        if same:
            count += 1
    return count


@njit(cache=True)
def predictive_levels(values, steps):
    """Closed loop over values (T, P): intra levels (P,), P-frame residual levels (T - 1, P) and the
    decoder's reconstruction (T, P), all int64."""
    n_frames, n_params = values.shape
    intra = np.empty(n_params, dtype=np.int64)
    recon = np.empty((n_frames, n_params), dtype=np.int64)
    p_levels = np.empty((max(n_frames - 1, 0), n_params), dtype=np.int64)
    for p in range(n_params):
        step = steps[p]
        level = quantize_one(values[0, p], step)
        intra[p] = level
        current = level * step
        recon[0, p] = current
        for t in range(1, n_frames):
            level = quantize_one(values[t, p] - current, step)
            p_levels[t - 1, p] = level
            current += level * step
            recon[t, p] = current
    return intra, p_levels, recon


@njit(cache=True)
def masked_levels(block, held, steps, group_order):
    """The predictive coder's decisions for block (T, C): the changed mask (C,), the coded order (masked
    columns in group order, (P,)), and predictive_levels of those columns."""
    mask = changed_mask(block, held, steps)
    n = 0
    for c in group_order:
        if mask[c]:
            n += 1
    order = np.empty(n, dtype=np.int64)
    n = 0
    for c in group_order:
        if mask[c]:
            order[n] = c
            n += 1
    values = np.empty((block.shape[0], len(order)), dtype=np.int64)
    masked_steps = np.empty(len(order), dtype=np.int64)
    for j in range(len(order)):
        masked_steps[j] = steps[order[j]]
        for t in range(block.shape[0]):
            values[t, j] = block[t, order[j]]
    intra, p_levels, recon = predictive_levels(values, masked_steps)
    return mask, order, intra, p_levels, recon


@njit(cache=True)
def first_beyond(levels, limit: int) -> int:
    """The first row of levels (N, P) holding a |level| > limit, or N."""
    for t in range(levels.shape[0]):
        for p in range(levels.shape[1]):
            if abs(levels[t, p]) > limit:
                return t
    return levels.shape[0]


@njit(cache=True)
def range_fields(intra, p_levels, q: int, delta: int):
    """(4, P) int64 range fields (param_coding.range_fields): I max, I min of intra (P,), P max, P min of
    p_levels (N, P); a field is ceil(|extreme level| x q / delta), 0 for no levels."""
    n_params = len(intra)
    fields = np.zeros((4, n_params), dtype=np.int64)
    for p in range(n_params):
        fields[0, p] = (max(intra[p], 0) * q + delta - 1) // delta
        fields[1, p] = (max(-intra[p], 0) * q + delta - 1) // delta
        top, bottom = 0, 0
        for t in range(p_levels.shape[0]):
            top = max(top, p_levels[t, p])
            bottom = max(bottom, -p_levels[t, p])
        fields[2, p] = (top * q + delta - 1) // delta
        fields[3, p] = (bottom * q + delta - 1) // delta
    return fields


@njit(cache=True)
def alphabets(fields, q: int, delta: int):
    """(I low, I high, P low, P high) (P,) int64 levels that range fields (4, P) announce (param_coding.alphabet)."""
    n_params = fields.shape[1]
    out = np.empty((4, n_params), dtype=np.int64)
    for p in range(n_params):
        out[0, p] = -(fields[1, p] * delta // q)
        out[1, p] = fields[0, p] * delta // q
        out[2, p] = -(fields[3, p] * delta // q)
        out[3, p] = fields[2, p] * delta // q
    return out[0], out[1], out[2], out[3]


# ------------------------------------------------------------------ group masks and range fields

@njit(cache=True)
def write_group_masks(buffer, state, mask, group_starts, members) -> None:
    """Per group (its parameters members[group_starts[g]:group_starts[g + 1]], 0-based): marker 1,
    mask type u2 (0 none, 3 all, 1 then one bit per parameter)."""
    for g in range(len(group_starts) - 1):
        put_bit(buffer, state, 1)
        a, b = group_starts[g], group_starts[g + 1]
        count = 0
        for i in range(a, b):
            if mask[members[i]]:
                count += 1
        if count == 0:
            put_bits(buffer, state, 0, 2)
        elif count == b - a:
            put_bits(buffer, state, 3, 2)
        else:
            put_bits(buffer, state, 1, 2)
            for i in range(a, b):
                put_bit(buffer, state, 1 if mask[members[i]] else 0)


MISSING_MARKER, MASK_TYPE_2, EMPTY_GROUP = -10, -11, -12


@njit(cache=True)
def read_group_masks(data, end_bit, state, group_starts, members, empty_groups, mask) -> tuple[int, int]:
    """Inverse of write_group_masks into mask (count,) bool (zeroed). empty_groups (G,) bool: groups
    whose mask type must be 0. Returns (0, 0), or (status, 1-based group): END_OF_DATA,
    MISSING_MARKER, MASK_TYPE_2, EMPTY_GROUP."""
    for g in range(len(group_starts) - 1):
        marker = get_bit(data, end_bit, state, False)
        if marker < 0:
            return END_OF_DATA, g + 1
        if marker != 1:
            return MISSING_MARKER, g + 1
        kind = get_bits(data, end_bit, state, 2)
        if kind < 0:
            return END_OF_DATA, g + 1
        if kind == 2:
            return MASK_TYPE_2, g + 1
        if kind and empty_groups[g]:
            return EMPTY_GROUP, g + 1
        a, b = group_starts[g], group_starts[g + 1]
        if kind == 3:
            for i in range(a, b):
                mask[members[i]] = True
        elif kind == 1:
            for i in range(a, b):
                bit = get_bit(data, end_bit, state, False)
                if bit < 0:
                    return END_OF_DATA, g + 1
                mask[members[i]] = bit == 1
    return 0, 0


@njit(cache=True)
def write_range_fields(buffer, state, fields, n_bits: int) -> None:
    """fields (R, P) row by row, each in n_bits; a marker bit 1 before every 4 parameters of a row."""
    for r in range(fields.shape[0]):
        for j in range(fields.shape[1]):
            if j % 4 == 0:
                put_bit(buffer, state, 1)
            put_bits(buffer, state, fields[r, j], n_bits)


@njit(cache=True)
def read_range_fields(data, end_bit, state, fields, n_bits: int) -> int:
    """Inverse of write_range_fields into fields (R, P). Returns 0, END_OF_DATA or MISSING_MARKER."""
    for r in range(fields.shape[0]):
        for j in range(fields.shape[1]):
            if j % 4 == 0:
                marker = get_bit(data, end_bit, state, False)
                if marker < 0:
                    return END_OF_DATA
                if marker != 1:
                    return MISSING_MARKER
            value = get_bits(data, end_bit, state, n_bits)
            if value < 0:
                return END_OF_DATA
            fields[r, j] = value
    return 0


# ------------------------------------------------------------------ frames of arithmetic-coded levels

@njit(cache=True)
def _coded(sizes, members, a: int, b: int) -> bool:
    """Whether a frame of members[a:b] is coded at all (some alphabet has more than one symbol)."""
    for k in range(a, b):
        if sizes[members[k]] > 1:
            return True
    return False


@njit(cache=True)
def check_symbols(levels, low, high) -> int:
    """Index into levels (F, P), flattened, of the first level outside [low, high] (P,), or -1."""
    n_frames, n_params = levels.shape
    for f in range(n_frames):
        for p in range(n_params):
            if levels[f, p] < low[p] or levels[f, p] > high[p]:
                return f * n_params + p
    return -1


# ------------------------------------------------------------------ the arithmetic coder with its state in locals
# The same integer arithmetic and bits as entropy_coding.encode_symbol / decode_symbol (and the same
# reader positions as its history ring), with the bit position, zero run and coder registers held in
# local variables and the bank addressed by offsets instead of array views: several times faster.
# A bank here is in excess form: counts (sum of sizes,) and Fenwick tree (sum of sizes + M,) hold
# count - 1 and tree - (i & -i), so a fresh bank is all zeros (np.zeros: untouched pages cost nothing,
# while the alphabets of Q = 1 run to ~10^6 symbols per plane); offsets and scalars as entropy_coding.

@njit(cache=True)
def _put(buffer, pos: int, run: int, bit: int) -> tuple[int, int]:
    """entropy_coding.put_bit on local state: (position, zero run) after the bit."""
    if bit:
        buffer[pos >> 3] |= np.uint8(0x80 >> (pos & 7))
        return pos + 1, 0
    pos += 1
    run += 1
    if run == MAX_ZERO_RUN:
        buffer[pos >> 3] |= np.uint8(0x80 >> (pos & 7))
        return pos + 1, 0
    return pos, run


@njit(cache=True)
def new_scalars(sizes, limit: int):
    """offsets (M + 1,) of each model's counts and scalars (M, 5) (total, top bit, increment 1, limit, n)
    of a bank of all-ones models of these alphabet sizes (M,)."""
    offsets = np.zeros(len(sizes) + 1, dtype=np.int64)
    scalars = np.empty((len(sizes), 5), dtype=np.int64)
    for m in range(len(sizes)):
        n = sizes[m]
        offsets[m + 1] = offsets[m] + n
        top = 1
        while top * 2 <= n:
            top *= 2
        scalars[m, TOTAL] = n
        scalars[m, TOP_BIT] = top
        scalars[m, INCREMENT] = 1
        scalars[m, LIMIT] = limit
        scalars[m, N] = n
    return offsets, scalars


@njit(cache=True)
def _update(counts, tree, scalars, m: int, base: int, symbol: int) -> None:
    """entropy_coding.update for model m of a bank in excess form (counts at base, tree at base + m)."""
    increment, n = scalars[m, INCREMENT], scalars[m, N]
    counts[base + symbol] += increment
    scalars[m, TOTAL] += increment
    tbase = base + m
    if scalars[m, TOTAL] > scalars[m, LIMIT]:
        total = 0
        for k in range(n):
            count = (counts[base + k] + 2) // 2            # (count + 1) // 2 of count = 1 + excess
            total += count
            counts[base + k] = count - 1
            tree[tbase + k + 1] = count
        for i in range(1, n + 1):
            parent = i + (i & -i)
            if parent <= n:
                tree[tbase + parent] += tree[tbase + i]
        for i in range(1, n + 1):
            tree[tbase + i] -= i & -i
        scalars[m, TOTAL] = total
        return
    i = symbol + 1
    while i <= n:
        tree[tbase + i] += increment
        i += i & -i


@njit(cache=True)
def _encode_track(buffer, pos: int, run: int, symbols, a: int, b: int, offsets, counts, tree, scalars,
                  members, fresh: bool) -> tuple[int, int]:
    """entropy_coding.encode_frame of symbols[a:b] with models members[a:b]: a fresh coder, flushed.
    fresh: the models are all-ones and used once (counts and tree are not read nor updated)."""
    low, high, pending = 0, TOP, 0
    for p in range(a, b):
        m = members[p]
        base = offsets[m]
        tbase = base + m
        symbol = symbols[p]
        cumulative = symbol                       # the all-ones part of the prefix sum
        excess = 0
        if not fresh:
            i = symbol
            while i > 0:
                cumulative += tree[tbase + i]
                i -= i & -i
            excess = counts[base + symbol]
        total = scalars[m, TOTAL]
        span = high - low + 1
        high = low + span * (cumulative + 1 + excess) // total - 1
        low = low + span * cumulative // total
        while True:
            if high < HALF:
                bit = 0
            elif low >= HALF:
                bit = 1
                low -= HALF
                high -= HALF
            elif low >= QUARTER and high < THREE_QUARTERS:
                pending += 1
                low -= QUARTER
                high -= QUARTER
                low <<= 1
                high = (high << 1) | 1
                continue
            else:
                break
            pos, run = _put(buffer, pos, run, bit)
            for _ in range(pending):
                pos, run = _put(buffer, pos, run, 1 - bit)
            pending = 0
            low <<= 1
            high = (high << 1) | 1
        if not fresh:
            _update(counts, tree, scalars, m, base, symbol)
    bit = 0 if low < QUARTER else 1
    pos, run = _put(buffer, pos, run, bit)
    for _ in range(pending + 1):
        pos, run = _put(buffer, pos, run, 1 - bit)
    return pos, run


@njit(cache=True)
def write_level_frames(buffer, state, header: int, header_bits: int, levels, low, track_starts,
                       sizes, offsets, counts, tree, scalars, members, fresh: bool) -> None:
    """Frames of levels (F, P): per frame the plane header (header_bits bits of header, none when 0),
    then per track k (columns track_starts[k]:track_starts[k + 1]) the symbols level - low coded
    from a fresh arithmetic coder with the bank's models members[column] and flushed
    (entropy_coding.encode_frame); a track whose alphabets all have one symbol writes nothing. fresh:
    one frame with all-ones models that are then dropped (counts and tree may be empty)."""
    symbols = np.empty(levels.shape[1], dtype=np.int64)
    pos, run = state[0], state[1]
    for f in range(levels.shape[0]):
        for shift in range(header_bits - 1, -1, -1):
            pos, run = _put(buffer, pos, run, (header >> shift) & 1)
        for p in range(levels.shape[1]):
            symbols[p] = levels[f, p] - low[p]
        for k in range(len(track_starts) - 1):
            a, b = track_starts[k], track_starts[k + 1]
            if _coded(sizes, members, a, b):
                pos, run = _encode_track(buffer, pos, run, symbols, a, b, offsets, counts, tree, scalars, members,
                                         fresh)
    state[0], state[1] = pos, run


RING = 32                     # >= HISTORY, a power of two


@njit(cache=True)
def _look(data, end_bit: int, ring, at: int, pos: int, run: int, over: int) -> tuple[int, int, int, int, int]:
    """entropy_coding.next_bit on local state: (bit, at, pos, run, over); the state before the bit goes
    into ring[at % RING]."""
    k = at & (RING - 1)
    ring[k, 0], ring[k, 1], ring[k, 2] = pos, run, over
    if pos >= end_bit:
        return 0, at + 1, pos + 1, (run + 1) % MAX_ZERO_RUN, over + 1
    bit = (data[pos >> 3] >> (7 - (pos & 7))) & 1
    pos += 1
    if bit:
        return 1, at + 1, pos, 0, over
    run += 1
    if run == MAX_ZERO_RUN:
        run = 0
        if pos < end_bit and (data[pos >> 3] >> (7 - (pos & 7))) & 1:
            pos += 1                              # a stuffing bit; a 0 (start code, or damage) is left unread
    return 0, at + 1, pos, run, over


@njit(cache=True)
def _decode_track(data, end_bit: int, state, ring, a: int, b: int, offsets, counts, tree, scalars, members,
                  out, fresh: bool) -> int:
    """entropy_coding.decode_frame of members[a:b] into out[a:b] (symbols), the reader state (pos, zero
    run, overrun) left where the encoder's bits ended. Returns 0, CORRUPT_CODE or CODE_ENDS_EARLY."""
    pos, run, over = state[0], state[1], state[2]
    at = 0
    value = 0
    for _ in range(PRECISION):
        bit, at, pos, run, over = _look(data, end_bit, ring, at, pos, run, over)
        value = (value << 1) | bit
    low, high = 0, TOP
    for p in range(a, b):
        m = members[p]
        base = offsets[m]
        tbase = base + m
        span = high - low + 1
        total = scalars[m, TOTAL]
        target = ((value - low + 1) * total - 1) // span
        if not 0 <= target < total:
            return CORRUPT_CODE
        if fresh:
            symbol, cumulative, excess = target, target, 0
        else:
            position, remaining, step, n = 0, target, scalars[m, TOP_BIT], scalars[m, N]
            while step:
                nxt = position + step
                if nxt <= n and (nxt & -nxt) + tree[tbase + nxt] <= remaining:
                    position = nxt
                    remaining -= (nxt & -nxt) + tree[tbase + nxt]
                step >>= 1
            symbol = position
            cumulative = target - remaining
            excess = counts[base + symbol]
        high = low + span * (cumulative + 1 + excess) // total - 1
        low = low + span * cumulative // total
        while True:
            if high < HALF:
                pass
            elif low >= HALF:
                low -= HALF
                high -= HALF
                value -= HALF
            elif low >= QUARTER and high < THREE_QUARTERS:
                low -= QUARTER
                high -= QUARTER
                value -= QUARTER
            else:
                break
            low <<= 1
            high = (high << 1) | 1
            bit, at, pos, run, over = _look(data, end_bit, ring, at, pos, run, over)
            value = (value << 1) | bit
        if not fresh:
            _update(counts, tree, scalars, m, base, symbol)
        out[p] = symbol
    oldest = (at - HISTORY) & (RING - 1) if at >= HISTORY else 0
    state[0], state[1], state[2] = ring[oldest, 0], ring[oldest, 1], ring[oldest, 2]
    return CODE_ENDS_EARLY if state[0] > end_bit else 0


@njit(cache=True)
def _read_frame(data, end_bit, state, ring, low, track_starts, sizes, offsets, counts, tree, scalars, members,
                out, fresh: bool) -> int:
    for k in range(len(track_starts) - 1):
        a, b = track_starts[k], track_starts[k + 1]
        if _coded(sizes, members, a, b):
            status = _decode_track(data, end_bit, state, ring, a, b, offsets, counts, tree, scalars, members, out,
                                   fresh)
            if status:
                return status
        else:
            for p in range(a, b):
                out[p] = 0
        for p in range(a, b):
            out[p] += low[p]
    return 0


@njit(cache=True)
def read_level_frame(data, end_bit, state, low, track_starts, sizes, offsets, counts, tree, scalars, members,
                     out, fresh: bool) -> int:
    """Inverse of one frame of write_level_frames without its header: levels (P,) into out. Returns 0,
    CORRUPT_CODE or CODE_ENDS_EARLY."""
    ring = np.empty((RING, 3), dtype=np.int64)
    return _read_frame(data, end_bit, state, ring, low, track_starts, sizes, offsets, counts, tree, scalars,
                       members, out, fresh)


@njit(cache=True)
def at_start_code(data, end_bit: int, pos: int) -> bool:
    """bitstream.BitReader.at_start_code at bit pos: next_start_code stuffing, then 00 00 01 and its code byte."""
    if pos >= end_bit:
        return False
    n_stuff = 8 - (pos & 7)
    if (data[pos >> 3] & ((1 << n_stuff) - 1)) != (1 << (n_stuff - 1)) - 1:
        return False
    byte = (pos + n_stuff) >> 3
    if byte + 4 > end_bit // 8:
        return False
    return data[byte] == 0 and data[byte + 1] == 0 and data[byte + 2] == 1


@njit(cache=True)
def read_predicted_planes(data, end_bit, state, paramset: int, low, track_starts, sizes, offsets, counts, tree,
                          scalars, members, columns, steps, held, out) -> tuple[int, int]:
    """Decodes predicted planes (header: is_intra 0, fba_object_mask == paramset, skip_frames 0, then
    write_level_frames' frame) until a start code, the end of the data, a plane header that is anything
    else, or len(out) planes. Each plane adds levels x steps (P,) to held[columns] and stores held in
    out (N, W). Returns (status, planes decoded): status 0 with the reader before any plane it did
    not decode (the caller reads that one field by field, and its errors), or CORRUPT_CODE /
    CODE_ENDS_EARLY inside a plane."""
    levels = np.empty(len(low), dtype=np.int64)
    ring = np.empty((RING, 3), dtype=np.int64)
    count = 0
    while count < out.shape[0]:
        if state[0] >= end_bit or at_start_code(data, end_bit, state[0]):
            break
        saved0, saved1, saved2 = state[0], state[1], state[2]
        header = get_bits(data, end_bit, state, 4)
        if header != paramset << 1:
            state[0], state[1], state[2] = saved0, saved1, saved2
            break
        status = _read_frame(data, end_bit, state, ring, low, track_starts, sizes, offsets, counts, tree, scalars,
                             members, levels, False)
        if status:
            return status, count
        for p in range(len(levels)):
            held[columns[p]] += levels[p] * steps[p]
        out[count, :] = held
        count += 1
    return 0, count

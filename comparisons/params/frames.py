"""Numba-compiled whole-loop kernels of the FBA/BBA parameter streams (comparisons/params/fba.py,
comparisons/params/coding.py document the syntax): closed-loop predictive quantisation, group masks
and range fields, and every frame of levels of an intra period in one call each way.

They build on comparisons/params/arithmetic.py (bit writer with start-code emulation prevention, the
Witten-Neal-Cleary arithmetic coder over Fenwick-tree model banks) and write exactly the bits the
per-field calls wrote, so streams stay byte-identical (the encoder's renormalisation, inlined from arithmetic.py,
writes its settled bits a chunk at a time since issue 33: the same bits; Numba's cache keys a kernel on its own
file, so a change to the inlined primitives is a change here too). Like entropy_coding they import nothing of
the package's Python modules and return status codes; comparisons/ raises SigncastError from them.

The P frames of the FBA stream use sparse models (write_sparse_frames, read_sparse_planes: see that
section), which code the same bits as the Fenwick banks without arrays the size of the alphabets; the
DCT helpers do the elementwise rounding around param_coding's NumPy matrix products.

Status codes of the readers: 0 done, -1 the data ends inside a field, -2 corrupt arithmetic-coded
data, -3 arithmetic-coded data ends early; the group-mask and range-field readers add their own
(see each docstring).
"""
import math

import numpy as np
from numba import njit

from comparisons.params.arithmetic import (
    HISTORY,
    INCREMENT,
    LIMIT,
    MAX_ZERO_RUN,
    PRECISION,
    TOP,
    TOP_BIT,
    TOTAL,
    N,
    _bits_local,
    _window_target,
    encode_interval,
    finish_encoder,
    get_bit,
    get_bits,
    get_local,
    give_back,
    narrow,
    put_bit,
    put_bit_local,
    put_bits,
    read_bits_local,
    set_uniform_scalars,
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
    """Inverse of write_range_fields into fields (R, P); state (3,) int64 the reader (position, zero run, bits
    read past the end), kept in locals while reading (entropy_coding.get_local, _bits_local: the bits get_bit
    reads one by one, fields read at once where no emulation-prevention bit can lie among them) and left after
    the last bit read. Returns 0, END_OF_DATA or MISSING_MARKER."""
    pos, run = state[0], state[1]
    status = 0
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
def new_scalars(sizes, limit: int):
    """offsets (M + 1,) of each model's counts and scalars (M, 5) (total, top bit, increment 1, limit, n)
    of a bank of all-ones models of these alphabet sizes (M,)."""
    offsets = np.zeros(len(sizes) + 1, dtype=np.int64)
    scalars = np.empty((len(sizes), 5), dtype=np.int64)
    for m in range(len(sizes)):
        n = sizes[m]
        offsets[m + 1] = offsets[m] + n
        set_uniform_scalars(scalars, m, n, limit)
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
        pos, run, low, high, pending = encode_interval(buffer, pos, run, low, high, pending, cumulative,
                                                       cumulative + 1 + excess, scalars[m, TOTAL])
        if not fresh:
            _update(counts, tree, scalars, m, base, symbol)
    return finish_encoder(buffer, pos, run, low, pending)


@njit(cache=True, inline="always")
def _start_frame(buffer, pos: int, run: int, header: int, header_bits: int, levels, f: int, low, symbols
                 ) -> tuple[int, int]:
    """Frame f's plane header (header_bits bits of header, none when 0) into buffer, and its symbols
    levels[f] - low (P,) into symbols: (pos, run)."""
    for shift in range(header_bits - 1, -1, -1):
        pos, run = put_bit_local(buffer, pos, run, (header >> shift) & 1)
    for p in range(levels.shape[1]):
        symbols[p] = levels[f, p] - low[p]
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
        pos, run = _start_frame(buffer, pos, run, header, header_bits, levels, f, low, symbols)
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
        total = scalars[m, TOTAL]
        target = _window_target(value, low, high - low + 1, total)
        if target < 0:
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
        low, high, n_bits, subtract = narrow(low, high, cumulative, cumulative + 1 + excess, total)
        for _ in range(n_bits):
            bit, at, pos, run, over = _look(data, end_bit, ring, at, pos, run, over)
            value = (value << 1) | bit
        value -= subtract
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


# ------------------------------------------------------------------ sparse adaptive models (P frames)
# The P-frame models of an intra period start all-ones and see one symbol per frame, so at most a few
# dozen of their (up to ~15,000 at Q = 1) counts ever leave 1. A sparse model keeps only those: per
# model m, its symbols with a count above 1, sorted, keys[m, :used[m]], and their excess count - 1,
# extra[m, :used[m]]; totals[m] is the model's total. The cumulative count of symbol s is
# s + (excess of the keys below s), so coding reads and updates exactly the numbers of the Fenwick bank
# (entropy_coding's increment 1, halving above `limit`) and writes the same bits, without allocating or
# touching arrays the size of the alphabets. A model holds at most keys.shape[1] keys; the readers
# stop (SPARSE_FULL) before a plane that could exceed it, and the caller goes on with a dense bank
# (sparse_to_dense), so time per symbol stays bounded on any stream.

SPARSE_FULL = -20


@njit(cache=True, _nrt=False)
def _sparse_add(keys, extra, used, totals, limit: int, size: int, m: int, slot: int, symbol: int) -> None:
    """One more count of symbol (at keys[m, slot] already, or to be inserted there); halves the model
    (count -> (count + 1) // 2, as entropy_coding.update) when its total exceeds limit.

    Called once per coded value, so compiled apart and without the runtime's reference counting (`_nrt=False`:
    it allocates nothing). Inlined, or with reference counting, every call updated its four arrays' counts
    atomically, which made the BBA predictive reader ~1.5x slower."""
    n = used[m]
    if slot < n and keys[m, slot] == symbol:
        extra[m, slot] += 1
    else:
        for s in range(n, slot, -1):
            keys[m, s] = keys[m, s - 1]
            extra[m, s] = extra[m, s - 1]
        keys[m, slot] = symbol
        extra[m, slot] = 1
        used[m] = n + 1
    totals[m] += 1
    if totals[m] > limit:
        total = size
        kept = 0
        for s in range(used[m]):
            e = (extra[m, s] + 2) // 2 - 1
            if e:
                keys[m, kept] = keys[m, s]
                extra[m, kept] = e
                kept += 1
                total += e
        used[m] = kept
        totals[m] = total


@njit(cache=True, inline="always")
def _sparse_find(keys, extra, used, m: int, target: int) -> tuple[int, int, int, int]:
    """The symbol of sparse model m whose cumulative interval holds target (0 <= target < its total):
    (slot: where the symbol is or would be inserted among the keys, symbol, its cumulative count, its
    extra count)."""
    below = 0                                  # extra counts of the keys below the target's symbol
    for s in range(used[m]):
        start = keys[m, s] + below
        if target < start:
            return s, target - below, target, 0
        if target <= start + extra[m, s]:
            return s, keys[m, s], start, extra[m, s]
        below += extra[m, s]
    return used[m], target - below, target, 0


@njit(cache=True)
def new_sparse(sizes, capacity: int):
    """Fresh all-ones sparse models of these alphabet sizes (M,): (totals (M,), keys (M, capacity),
    extra (M, capacity), used (M,))."""
    n_models = len(sizes)
    totals = np.empty(n_models, dtype=np.int64)
    for m in range(n_models):
        totals[m] = sizes[m]
    return (totals, np.empty((n_models, capacity), dtype=np.int64), np.empty((n_models, capacity), dtype=np.int64),
            np.zeros(n_models, dtype=np.int64))


@njit(cache=True)
def sparse_to_dense(sizes, totals, keys, extra, used, offsets, counts, tree, scalars) -> None:
    """Loads sparse models into a fresh bank of new_scalars (excess form, counts and tree zeroed)."""
    for m in range(len(sizes)):
        n = sizes[m]
        base = offsets[m]
        tbase = base + m
        for s in range(used[m]):
            counts[base + keys[m, s]] = extra[m, s]
            tree[tbase + keys[m, s] + 1] = extra[m, s]
        for i in range(1, n + 1):
            parent = i + (i & -i)
            if parent <= n:
                tree[tbase + parent] += tree[tbase + i]
        scalars[m, TOTAL] = totals[m]


@njit(cache=True)
def _sparse_encode_track(buffer, pos: int, run: int, symbols, a: int, b: int, sizes, totals, keys, extra, used,
                         limit: int) -> tuple[int, int]:
    """_encode_track of symbols[a:b], model p for column p, with sparse models."""
    low, high, pending = 0, TOP, 0
    for p in range(a, b):
        symbol = symbols[p]
        cumulative = symbol
        excess = 0
        slot = used[p]
        for s in range(used[p]):
            key = keys[p, s]
            if key >= symbol:
                slot = s
                if key == symbol:
                    excess = extra[p, s]
                break
            cumulative += extra[p, s]
        pos, run, low, high, pending = encode_interval(buffer, pos, run, low, high, pending, cumulative,
                                                       cumulative + 1 + excess, totals[p])
        _sparse_add(keys, extra, used, totals, limit, sizes[p], p, slot, symbol)
    return finish_encoder(buffer, pos, run, low, pending)


@njit(cache=True)
def write_sparse_frames(buffer, state, header: int, header_bits: int, levels, low, track_starts, sizes, totals,
                        keys, extra, used, limit: int) -> None:
    """write_level_frames (not fresh; model p codes column p) with sparse models of capacity >= len(levels)."""
    symbols = np.empty(levels.shape[1], dtype=np.int64)
    columns = np.arange(levels.shape[1])             # model p for column p
    pos, run = state[0], state[1]
    for f in range(levels.shape[0]):
        pos, run = _start_frame(buffer, pos, run, header, header_bits, levels, f, low, symbols)
        for k in range(len(track_starts) - 1):
            a, b = track_starts[k], track_starts[k + 1]
            if _coded(sizes, columns, a, b):
                pos, run = _sparse_encode_track(buffer, pos, run, symbols, a, b, sizes, totals, keys, extra, used,
                                                limit)
    state[0], state[1] = pos, run


@njit(cache=True)
def _sparse_decode_track(data, end_bit: int, state, a: int, b: int, sizes, totals, keys, extra, used,
                         limit: int, out) -> int:
    """_decode_track of columns a:b (model p for column p) with sparse models. The reader state that the encoder's bits end at
    (the state HISTORY bits before the last read) is found by reading again from the start instead of keeping
    a ring of states."""
    pos0, run0, over0 = state[0], state[1], state[2]
    value, pos, run, over = read_bits_local(data, end_bit, pos0, run0, over0, 0, PRECISION)
    at = PRECISION
    low, high = 0, TOP
    for p in range(a, b):
        total = totals[p]
        target = _window_target(value, low, high - low + 1, total)
        if target < 0:
            return CORRUPT_CODE
        slot, symbol, cumulative, excess = _sparse_find(keys, extra, used, p, target)
        low, high, n_bits, subtract = narrow(low, high, cumulative, cumulative + 1 + excess, total)
        value, pos, run, over = read_bits_local(data, end_bit, pos, run, over, value, n_bits)
        value -= subtract
        at += n_bits
        _sparse_add(keys, extra, used, totals, limit, sizes[p], p, slot, symbol)
        out[p] = symbol
    pos, run, over = give_back(data, end_bit, pos0, run0, over0, pos, over, at)
    state[0], state[1], state[2] = pos, run, over
    return CODE_ENDS_EARLY if pos > end_bit else 0


@njit(cache=True)
def read_sparse_planes(data, end_bit, state, paramset: int, low, track_starts, sizes, totals, keys, extra, used,
                       limit: int, columns, steps, held, out) -> tuple[int, int]:
    """read_predicted_planes (model p for column p) with sparse models. Also returns SPARSE_FULL, with the
    reader before the plane, when a model holds keys.shape[1] keys."""
    levels = np.empty(len(low), dtype=np.int64)
    capacity = keys.shape[1]
    count = 0
    while count < out.shape[0]:
        if state[0] >= end_bit or at_start_code(data, end_bit, state[0]):
            break
        for m in range(len(used)):
            if used[m] >= capacity:
                return SPARSE_FULL, count
        saved0, saved1, saved2 = state[0], state[1], state[2]
        header = get_bits(data, end_bit, state, 4)
        if header != paramset << 1:
            state[0], state[1], state[2] = saved0, saved1, saved2
            break
        for k in range(len(track_starts) - 1):
            a, b = track_starts[k], track_starts[k + 1]
            coded = False
            for p in range(a, b):
                if sizes[p] > 1:
                    coded = True
                    break
            if coded:
                status = _sparse_decode_track(data, end_bit, state, a, b, sizes, totals, keys, extra, used, limit,
                                              levels)
                if status:
                    return status, count
            else:
                for p in range(a, b):
                    levels[p] = 0
            for p in range(a, b):
                levels[p] += low[p]
        for p in range(len(levels)):
            held[columns[p]] += levels[p] * steps[p]
        out[count, :] = held
        count += 1
    return 0, count


# ------------------------------------------------------------------ DCT levels around NumPy's matrix products
# param_coding.dct_levels / dct_reconstruct without their elementwise NumPy passes: the same IEEE operations
# per element (the DCT matrix products stay NumPy's, whose summation order is BLAS's).

@njit(cache=True)
def dct_quantise(coefficients, dc_step, ac_step):
    """coefficients (n, P) -> DC levels (P,), AC levels (n - 1, P): sign(c) floor(|c| / step + 0.5)."""
    n, n_params = coefficients.shape
    dc = np.empty(n_params, dtype=np.int64)
    ac = np.empty((n - 1, n_params), dtype=np.int64)
    for p in range(n_params):
        c = coefficients[0, p]
        level = np.int64(math.floor(abs(c) / dc_step[p] + 0.5))
        dc[p] = -level if c < 0 else (level if c > 0 else 0)
    for k in range(1, n):
        for p in range(n_params):
            c = coefficients[k, p]
            level = np.int64(math.floor(abs(c) / ac_step[p] + 0.5))
            ac[k - 1, p] = -level if c < 0 else (level if c > 0 else 0)
    return dc, ac


@njit(cache=True)
def dct_coefficients(dc, ac, dc_step, ac_step):
    """(n, P) float64 [dc x dc_step; ac x ac_step] of levels dc (P,), ac (n - 1, P)."""
    n_params = len(dc)
    out = np.empty((ac.shape[0] + 1, n_params))
    for p in range(n_params):
        out[0, p] = dc[p] * dc_step[p]
    for k in range(ac.shape[0]):
        for p in range(n_params):
            out[k + 1, p] = ac[k, p] * ac_step[p]
    return out


@njit(cache=True)
def round_to_int(values):
    """np.round(values).astype(np.int64) of finite values (n, P)."""
    out = np.empty(values.shape, dtype=np.int64)
    for k in range(values.shape[0]):
        for p in range(values.shape[1]):
            out[k, p] = np.int64(np.rint(values[k, p]))
    return out

"""Numba-compiled kernels of the parameter streams' bit I/O and adaptive arithmetic coder.

They are the inner loops of comparisons/params/bits.py (BitWriter, BitReader: MPEG start-code
emulation prevention) and comparisons/params/entropy.py (Witten-Neal-Cleary arithmetic coder with
Fenwick-tree frequency models), which document the formats; those modules own the state arrays and
raise SigncastError from the status codes these kernels return. Compiled nopython with cache=True
(once per machine, then loaded from __pycache__). They live outside `comparisons` so that
coverage-instrumented imports (benchmarks/fuzz.py instruments comparisons and media with atheris)
leave their bytecode alone: Numba cannot compile instrumented bytecode.

State arrays (int64): writer (bits written, zero run) over a zero-filled uint8 buffer; reader
(bit position, zero run, bits read past the end); coder registers (low, high, pending follow
bits) or (low, high, value); a frequency model is counts (n,), Fenwick tree (n + 1,) and scalars
(total, top bit, increment, limit, n); a bank of models concatenates them (model m's counts
at offsets[m], its tree at offsets[m] + m) with scalars (M, 5).
"""
import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.extending import intrinsic

MAX_ZERO_RUN = 22
PRECISION = 32
TOP = (1 << PRECISION) - 1
HALF = 1 << (PRECISION - 1)
QUARTER = 1 << (PRECISION - 2)
THREE_QUARTERS = HALF + QUARTER
HISTORY = PRECISION - 2      # reader states the decoder remembers, to give back its over-read bits
TOTAL, TOP_BIT, INCREMENT, LIMIT, N = range(5)     # a model's scalars


@njit(cache=True)
def put_raw_bit(buffer: np.ndarray, state: np.ndarray, bit: int) -> None:
    """One bit into a zero-filled buffer at bit state[0], no emulation prevention."""
    n = state[0]
    if bit:
        buffer[n >> 3] |= np.uint8(0x80 >> (n & 7))
    state[0] = n + 1


@njit(cache=True)
def put_bit(buffer: np.ndarray, state: np.ndarray, bit: int) -> None:
    """One data bit, with start-code emulation prevention (state[1]: the current zero run)."""
    put_raw_bit(buffer, state, bit)
    if bit:
        state[1] = 0
    else:
        state[1] += 1
        if state[1] == MAX_ZERO_RUN:
            put_raw_bit(buffer, state, 1)
            state[1] = 0


@njit(cache=True)
def put_bits(buffer: np.ndarray, state: np.ndarray, value: int, n_bits: int) -> None:
    for shift in range(n_bits - 1, -1, -1):
        put_bit(buffer, state, (value >> shift) & 1)


@njit(cache=True)
def align(buffer: np.ndarray, state: np.ndarray) -> None:
    put_raw_bit(buffer, state, 0)
    while state[0] & 7:
        put_raw_bit(buffer, state, 1)


@njit(cache=True)
def get_raw_bit(data: np.ndarray, end_bit: int, state: np.ndarray, lookahead: bool) -> int:
    """The bit at state[0]; past end_bit a 0 (lookahead) or -1 (truncated)."""
    pos = state[0]
    if pos >= end_bit:
        if not lookahead:
            return -1
        state[2] += 1
        state[0] = pos + 1
        return 0
    state[0] = pos + 1
    return (data[pos >> 3] >> (7 - (pos & 7))) & 1


@njit(cache=True)
def get_bit(data: np.ndarray, end_bit: int, state: np.ndarray, lookahead: bool) -> int:
    """One data bit, dropping emulation-prevention bits; -1 when the data ends (not lookahead)."""
    bit = get_raw_bit(data, end_bit, state, lookahead)
    if bit < 0:
        return -1
    if bit:
        state[1] = 0
        return 1
    state[1] += 1
    if state[1] == MAX_ZERO_RUN:
        state[1] = 0
        if state[0] < end_bit:
            position = state[0]
            if get_raw_bit(data, end_bit, state, False) == 0:
                # Not a stuffing bit: this is a start code (or damage); leave it unread.
                state[0] = position
        elif not lookahead:
            return -1
    return 0


@njit(cache=True)
def get_bits(data: np.ndarray, end_bit: int, state: np.ndarray, n_bits: int) -> int:
    value = 0
    for _ in range(n_bits):
        bit = get_bit(data, end_bit, state, False)
        if bit < 0:
            return -1
        value = (value << 1) | bit
    return value


@njit(cache=True)
def crc8(data: np.ndarray, start_bit: int, end_bit: int) -> int:
    """CRC-8 (polynomial x^8 + x^2 + x + 1, initial 0) of data's bits start_bit..end_bit - 1, MSB first."""
    return _crc8_bits(data, 0, start_bit, end_bit)


@njit(cache=True, inline="always")
def _crc8_bits(data: np.ndarray, crc: int, start_bit: int, end_bit: int) -> int:
    """crc updated with data's bits start_bit..end_bit - 1, one at a time."""
    for position in range(start_bit, end_bit):
        bit = (data[position >> 3] >> (7 - (position & 7))) & 1
        feedback = ((crc >> 7) & 1) ^ bit
        crc = (crc << 1) & 0xFF
        if feedback:
            crc ^= 0x07
    return crc


def _crc8_table() -> np.ndarray:
    table = np.zeros(256, dtype=np.int64)
    for byte in range(256):
        crc = byte
        for _ in range(8):
            crc = ((crc << 1) ^ 0x07) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
        table[byte] = crc
    return table


CRC8_TABLE = _crc8_table()


@njit(cache=True)
def crc8_bytes(data: np.ndarray, start_bit: int, end_bit: int) -> int:
    """crc8, whole bytes at a time through a 256-entry table (the same CRC: it is linear in the bits)."""
    position = min(end_bit, (start_bit + 7) & ~7)
    crc = _crc8_bits(data, 0, start_bit, position)
    while position + 8 <= end_bit:
        crc = CRC8_TABLE[crc ^ data[position >> 3]]
        position += 8
    return _crc8_bits(data, crc, position, end_bit)


@njit(cache=True)
def prefix(tree: np.ndarray, symbol: int) -> int:
    total = 0
    i = symbol
    while i > 0:
        total += tree[i]
        i -= i & -i
    return total


@njit(cache=True)
def find(tree: np.ndarray, scalars: np.ndarray, target: int) -> tuple[int, int]:
    """(symbol, its cumulative low) whose interval holds `target`."""
    position, remaining, step, n = 0, target, scalars[TOP_BIT], scalars[N]
    while step:
        nxt = position + step
        if nxt <= n and tree[nxt] <= remaining:
            position = nxt
            remaining -= tree[nxt]
        step >>= 1
    return position, target - remaining


@njit(cache=True)
def update(counts: np.ndarray, tree: np.ndarray, scalars: np.ndarray, symbol: int) -> None:
    increment, n = scalars[INCREMENT], scalars[N]
    counts[symbol] += increment
    scalars[TOTAL] += increment
    if scalars[TOTAL] > scalars[LIMIT]:
        total = 0
        for k in range(n):
            counts[k] = (counts[k] + 1) // 2
            total += counts[k]
            tree[k + 1] = counts[k]
        for i in range(1, n + 1):                 # O(n) Fenwick build
            parent = i + (i & -i)
            if parent <= n:
                tree[parent] += tree[i]
        scalars[TOTAL] = total
        return
    i = symbol + 1
    while i <= n:
        tree[i] += increment
        i += i & -i


@njit(cache=True)
def finish_state(buffer: np.ndarray, writer_state: np.ndarray, registers: np.ndarray) -> None:
    """finish_encoder on the state arrays: writer (bits written, zero run), registers (low, high, pending)."""
    writer_state[0], writer_state[1] = finish_encoder(buffer, writer_state[0], writer_state[1], registers[0],
                                                      registers[2])
    registers[2] = 0


@njit(cache=True)
def encode_symbol(buffer: np.ndarray, writer_state: np.ndarray, registers: np.ndarray, counts: np.ndarray,
                  tree: np.ndarray, scalars: np.ndarray, symbol: int) -> None:
    """One symbol: registers (low, high, pending follow bits) int64; the model is updated."""
    sym_low = prefix(tree, symbol)
    sym_high = sym_low + counts[symbol]
    total = scalars[TOTAL]
    pos, run, low, high, pending = encode_interval(buffer, writer_state[0], writer_state[1], registers[0],
                                                   registers[1], registers[2], sym_low, sym_high, total)
    writer_state[0], writer_state[1] = pos, run
    registers[0], registers[1], registers[2] = low, high, pending
    update(counts, tree, scalars, symbol)


@njit(cache=True)
def next_bit(data: np.ndarray, end_bit: int, reader_state: np.ndarray, history: np.ndarray,
              history_at: np.ndarray) -> int:
    """A lookahead bit; the reader state before it goes into the ring `history` (HISTORY, 3)."""
    k = history_at[0] % HISTORY
    history[k, 0] = reader_state[0]
    history[k, 1] = reader_state[1]
    history[k, 2] = reader_state[2]
    history_at[0] += 1
    return get_bit(data, end_bit, reader_state, True)


@njit(cache=True)
def fill(data, end_bit, reader_state, history, history_at) -> int:
    value = 0
    for _ in range(PRECISION):
        value = (value << 1) | next_bit(data, end_bit, reader_state, history, history_at)
    return value


@njit(cache=True)
def decode_symbol(data: np.ndarray, end_bit: int, reader_state: np.ndarray, history: np.ndarray,
                  history_at: np.ndarray, registers: np.ndarray, counts: np.ndarray, tree: np.ndarray,
                  scalars: np.ndarray) -> int:
    """One symbol (registers: low, high, value), or -1 when the data cannot be arithmetic-coded."""
    low, high, value = registers[0], registers[1], registers[2]
    total = scalars[TOTAL]
    target = _window_target(value, low, high - low + 1, total)
    if target < 0:
        return -1
    symbol, sym_low = find(tree, scalars, target)
    low, high, n_bits, subtract = narrow(low, high, sym_low, sym_low + counts[symbol], total)
    for _ in range(n_bits):
        value = (value << 1) | next_bit(data, end_bit, reader_state, history, history_at)
    value -= subtract
    registers[0] = low
    registers[1] = high
    registers[2] = value
    update(counts, tree, scalars, symbol)
    return symbol


@njit(cache=True)
def init_bank(sizes, offsets, tree, scalars, limit) -> None:
    """All-ones Fenwick trees and each model's scalars (total, top bit, increment 1, limit, n)."""
    for m in range(len(sizes)):
        n = sizes[m]
        start = offsets[m] + m
        for i in range(n + 1):
            tree[start + i] = i & -i
        set_uniform_scalars(scalars, m, n, limit)


@njit(cache=True, inline="always")
def set_uniform_scalars(scalars, m: int, n: int, limit: int) -> None:
    """Model m's scalars (total, top bit, increment 1, limit, n) for n symbols of count 1."""
    top = 1
    while top * 2 <= n:
        top *= 2
    scalars[m, TOTAL] = n
    scalars[m, TOP_BIT] = top
    scalars[m, INCREMENT] = 1
    scalars[m, LIMIT] = limit
    scalars[m, N] = n


@njit(cache=True)
def encode_frame(buffer, writer_state, counts, tree, scalars, offsets, members, symbols) -> None:
    registers = np.array([0, TOP, 0], dtype=np.int64)
    for k in range(len(members)):
        m = members[k]
        start, n = offsets[m], scalars[m, N]
        encode_symbol(buffer, writer_state, registers, counts[start:start + n], tree[start + m:start + m + n + 1],
                      scalars[m], symbols[k])
    finish_state(buffer, writer_state, registers)


@njit(cache=True)
def decode_frame(data, end_bit, reader_state, counts, tree, scalars, offsets, members, out) -> int:
    history = np.zeros((HISTORY, 3), dtype=np.int64)
    history_at = np.zeros(1, dtype=np.int64)
    registers = np.array([0, TOP, fill(data, end_bit, reader_state, history, history_at)], dtype=np.int64)
    for k in range(len(members)):
        m = members[k]
        start, n = offsets[m], scalars[m, N]
        symbol = decode_symbol(data, end_bit, reader_state, history, history_at, registers,
                               counts[start:start + n], tree[start + m:start + m + n + 1], scalars[m])
        if symbol < 0:
            return -1
        out[k] = symbol
    return rewind(reader_state, history, history_at, end_bit)



@njit(cache=True)
def rewind(reader_state, history, history_at, end_bit) -> int:
    """Put the reader back where the arithmetic decoder's look-ahead began (the oldest position in its history);
    -2 when that lies past the data's end, else 0."""
    at = history_at[0]
    oldest = at % HISTORY if at >= HISTORY else 0
    reader_state[0] = history[oldest, 0]
    reader_state[1] = history[oldest, 1]
    reader_state[2] = history[oldest, 2]
    return -2 if reader_state[0] > end_bit else 0

@njit(cache=True)
def encode_run(buffer, writer_state, counts, tree, scalars, symbols) -> None:
    registers = np.array([0, TOP, 0], dtype=np.int64)
    for k in range(len(symbols)):
        encode_symbol(buffer, writer_state, registers, counts, tree, scalars, symbols[k])
    finish_state(buffer, writer_state, registers)


@njit(cache=True)
def decode_run(data, end_bit, reader_state, counts, tree, scalars, out, max_overrun) -> int:
    history = np.zeros((HISTORY, 3), dtype=np.int64)
    history_at = np.zeros(1, dtype=np.int64)
    registers = np.array([0, TOP, fill(data, end_bit, reader_state, history, history_at)], dtype=np.int64)
    for k in range(len(out)):
        symbol = decode_symbol(data, end_bit, reader_state, history, history_at, registers, counts, tree, scalars)
        if symbol < 0:
            return -1
        out[k] = symbol
        if reader_state[2] > max_overrun:
            return -3
    return rewind(reader_state, history, history_at, end_bit)


# ------------------------------------------------------------------ DCT blocks with canonical Huffman VLC
# A table is (codes (S,), lengths (S,)) for writing and (first_code, count, start (L + 1,) by code
# length, symbols sorted by (length, symbol)) for reading (comparisons/params/entropy.py CanonicalHuffman).

@njit(cache=True)
def category(value: int, n_categories: int) -> int:
    magnitude = abs(value)
    bits = 0
    while magnitude:
        bits += 1
        magnitude >>= 1
    return min(bits, n_categories - 1)


@njit(cache=True)
def put_local(buffer, pos: int, run: int, value: int, n_bits: int) -> tuple[int, int]:
    """put_bits with the writer state (bits written, zero run) in locals: returns the new state."""
    for shift in range(n_bits - 1, -1, -1):
        if (value >> shift) & 1:
            buffer[pos >> 3] |= np.uint8(0x80 >> (pos & 7))
            pos += 1
            run = 0
        else:
            pos += 1
            run += 1
            if run == MAX_ZERO_RUN:
                buffer[pos >> 3] |= np.uint8(0x80 >> (pos & 7))
                pos += 1
                run = 0
    return pos, run


@njit(cache=True)
def _code_and_bits(codes, lengths, symbol: int, value: int, cat: int) -> tuple[int, int, int]:
    """(bits, bit count, status) of a Huffman code followed by the sign and low bits of value in
    category cat; status 2 when the symbol has no code, 1 when value exceeds the category."""
    if symbol >= len(lengths) or lengths[symbol] == 0:
        return 0, 0, 2
    bits, n = codes[symbol], lengths[symbol]
    if cat:
        magnitude = abs(value)
        if magnitude >> cat:
            return 0, 0, 1
        bits = (bits << 1) | (1 if value < 0 else 0)
        bits = (bits << (cat - 1)) | (magnitude - (1 << (cat - 1)))
        n += cat
    return bits, n, 0


@njit(cache=True)
def write_dct_blocks(buffer, state, dc_values, ac, dc_codes, dc_lengths, ac_codes, ac_lengths,
                     n_categories: int) -> tuple[int, int]:
    """Every parameter's block of a segment (param_coding.write_dct_block). Returns (0, 0), or
    (1, level) for a level beyond the largest category, or (2, symbol) for a symbol without a code."""
    n_ac = ac.shape[0]
    pos, run = state[0], state[1]
    for p in range(len(dc_values)):
        cat = category(dc_values[p], n_categories)
        bits, n, status = _code_and_bits(dc_codes, dc_lengths, cat, dc_values[p], cat)
        if status:
            state[0], state[1] = pos, run
            return status, cat if status == 2 else dc_values[p]
        pos, run = put_local(buffer, pos, run, bits, n)
        last = -1
        for k in range(n_ac):
            if ac[k, p] != 0:
                last = k
        zeros = 0
        for k in range(last + 1):
            level = ac[k, p]
            if level == 0:
                zeros += 1
                continue
            cat = category(level, n_categories)
            symbol = 1 + zeros * (n_categories - 1) + cat - 1
            bits, n, status = _code_and_bits(ac_codes, ac_lengths, symbol, level, cat)
            if status:
                state[0], state[1] = pos, run
                return status, symbol if status == 2 else level
            pos, run = put_local(buffer, pos, run, bits, n)
            zeros = 0
        if last < n_ac - 1:
            if ac_lengths[0] == 0:
                state[0], state[1] = pos, run
                return 2, 0
            pos, run = put_local(buffer, pos, run, ac_codes[0], ac_lengths[0])
    state[0], state[1] = pos, run
    return 0, 0


@njit(cache=True)
def get_local(data, end_bit: int, pos: int, run: int) -> tuple[int, int, int]:
    """get_bit (not look-ahead) with the reader's position and zero run in locals: (bit or -1, pos, run)."""
    if pos >= end_bit:
        return -1, pos, run
    bit = (data[pos >> 3] >> (7 - (pos & 7))) & 1
    pos += 1
    if bit:
        return 1, pos, 0
    run += 1
    if run == MAX_ZERO_RUN:
        run = 0
        if pos >= end_bit:
            return -1, pos, run
        if (data[pos >> 3] >> (7 - (pos & 7))) & 1:
            pos += 1                           # a stuffing bit; a 0 (start code, or damage) is left unread
    return 0, pos, run


@njit(cache=True, inline="always")
def _run_after(bits: int, n_bits: int, run: int) -> int:
    """The zero run after reading the n_bits raw bits `bits` (MSB first) on a zero run of `run`: its trailing
    zeros, or run + n_bits when all are zero."""
    if bits == 0:
        return run + n_bits
    trailing = 0
    while not (bits >> trailing) & 1:
        trailing += 1
    return trailing


@njit(cache=True)
def _bits_local(data, end_bit: int, pos: int, run: int, n_bits: int) -> tuple[int, int, int]:
    """n_bits (at most 62) data bits as get_local reads them one by one: (value or -1, pos, run). When the
    zero run cannot reach MAX_ZERO_RUN inside them (run + n_bits below it), no emulation-prevention bit can
    lie among them: they are the raw bits, read at once."""
    byte = pos >> 3
    if run + n_bits < MAX_ZERO_RUN and (pos & 7) + n_bits <= 24 and pos + n_bits <= end_bit and byte + 2 < len(data):
        window = (np.int64(data[byte]) << 16) | (np.int64(data[byte + 1]) << 8) | np.int64(data[byte + 2])
        value = (window >> (24 - (pos & 7) - n_bits)) & ((1 << n_bits) - 1)
        return value, pos + n_bits, _run_after(value, n_bits, run)
    value = 0
    for _ in range(n_bits):
        bit, pos, run = get_local(data, end_bit, pos, run)
        if bit < 0:
            return -1, pos, run
        value = (value << 1) | bit
    return value, pos, run


@njit(cache=True)
def _get_code_local(data, end_bit: int, pos: int, run: int, first_code, count, start,
                    symbols) -> tuple[int, int, int]:
    code = 0
    for length in range(1, len(count)):
        bit, pos, run = get_local(data, end_bit, pos, run)
        if bit < 0:
            return -1, pos, run
        code = (code << 1) | bit
        if count[length]:
            index = code - first_code[length]
            if 0 <= index < count[length]:
                return symbols[start[length] + index], pos, run
    return -2, pos, run


@njit(cache=True)
def _get_value_local(data, end_bit: int, pos: int, run: int, cat: int) -> tuple[bool, int, int, int]:
    if not cat:
        return True, 0, pos, run
    negative, pos, run = get_local(data, end_bit, pos, run)
    if negative < 0:
        return False, 0, pos, run
    rest = 0
    for _ in range(cat - 1):
        bit, pos, run = get_local(data, end_bit, pos, run)
        if bit < 0:
            return False, 0, pos, run
        rest = (rest << 1) | bit
    magnitude = (1 << (cat - 1)) + rest
    return True, -magnitude if negative else magnitude, pos, run


@njit(cache=True)
def read_dct_blocks(data, end_bit, state, dc_first, dc_count, dc_start, dc_symbols, ac_first, ac_count, ac_start,
                    ac_symbols, n_categories: int, dc_out, ac_out) -> int:
    """Inverse of write_dct_blocks into dc_out (P,), ac_out (size - 1, P) (zero-filled). Returns 0,
    -1 truncated, -2 bits that match no code, -3 an AC run past the end of the segment."""
    n_ac = ac_out.shape[0]
    pos, run = state[0], state[1]
    status = 0
    for p in range(len(dc_out)):
        cat, pos, run = _get_code_local(data, end_bit, pos, run, dc_first, dc_count, dc_start, dc_symbols)
        if cat < 0:
            status = cat
            break
        ok, dc_out[p], pos, run = _get_value_local(data, end_bit, pos, run, cat)
        if not ok:
            status = -1
            break
        k = 0
        while k < n_ac:
            symbol, pos, run = _get_code_local(data, end_bit, pos, run, ac_first, ac_count, ac_start, ac_symbols)
            if symbol < 0:
                status = symbol
                break
            if symbol == 0:
                break
            zeros = (symbol - 1) // (n_categories - 1)
            cat = (symbol - 1) % (n_categories - 1)
            k += zeros
            if k >= n_ac:
                status = -3
                break
            ok, ac_out[k, p], pos, run = _get_value_local(data, end_bit, pos, run, cat + 1)
            if not ok:
                status = -1
                break
            k += 1
        if status:
            break
    state[0], state[1] = pos, run
    return status


# ------------------------------------------------------------------ the arithmetic decoder with its state in locals
# decode_frame's integer arithmetic and reader positions with the reader state (bit position, zero run, bits
# read past the end) and the coder registers in local variables, the bank addressed by offsets instead of
# array views, and no history ring: the reader state the decoder gives back (HISTORY look-ahead bits
# before its last) is found again by re-reading from where the frame began.

@njit(cache=True)
def look_local(data, end_bit: int, pos: int, run: int, over: int) -> tuple[int, int, int, int]:
    """get_bit(lookahead=True) on local state: (bit, pos, run, over); past end_bit a 0 bit and over + 1."""
    if pos >= end_bit:
        run += 1
        if run == MAX_ZERO_RUN:
            run = 0
        return 0, pos + 1, run, over + 1
    bit = (np.int64(data[pos >> 3]) >> (7 - (pos & 7))) & 1
    pos += 1
    run = (run + 1) & (bit - 1)                # 0 after a 1 bit; no branch on the data
    if run == MAX_ZERO_RUN:
        run = 0
        if pos < end_bit and (data[pos >> 3] >> (7 - (pos & 7))) & 1:
            pos += 1                           # a stuffing bit; a 0 (start code, or damage) is left unread
    return bit, pos, run, over


@njit(cache=True, inline="always")
def read_bits_local(data, end_bit: int, pos: int, run: int, over: int, value: int, n_bits: int
                    ) -> tuple[int, int, int, int]:
    """n_bits look-ahead bits (look_local) shifted into value below them: (value, pos, run, over)."""
    for _ in range(n_bits):
        bit, pos, run, over = look_local(data, end_bit, pos, run, over)
        value = (value << 1) | bit
    return value, pos, run, over


@njit(cache=True)
def update_member(counts, tree, scalars, offsets, m: int, symbol: int) -> None:
    """update() of model m of a bank (counts at offsets[m], tree at offsets[m] + m)."""
    _update_inline(counts, tree, scalars, offsets, m, symbol)


@njit(cache=True)
def _scale(span: int, cumulative: int, total: int) -> int:
    """span * cumulative // total of non-negative values below 2^63, as an unsigned division (no floor fix-up)."""
    return np.int64(np.uint64(span * cumulative) // np.uint64(total))


@njit(cache=True, inline="always")
def narrow(low: int, high: int, sym_low: int, sym_high: int, total: int) -> tuple[int, int, int, int]:
    """The decoder's interval [low, high] narrowed to the cumulative counts [sym_low, sym_high) of total and
    renormalised: (low, high, bits to shift into the value, what to subtract from it), as renormalise_decoder."""
    span = high - low + 1
    return renormalise_decoder(low + _scale(span, sym_low, total), low + _scale(span, sym_high, total) - 1)


@njit(cache=True)
def decode_frame_local(data, end_bit: int, pos: int, run: int, over: int, counts, tree, scalars, offsets, members,
                       out, out_start: int, fresh: bool) -> tuple[int, int, int, int]:
    """decode_frame on local reader state: the symbols of members into out[out_start:], then the reader
    given back to where the encoder's bits ended. fresh: every model is all-ones and codes one symbol
    before it is dropped (only scalars' totals are read; counts, tree and scalars are not updated).
    Returns (status, pos, run, over): status 0, -1 (data that cannot be arithmetic-coded) or -2 (the
    coded bits run past end_bit)."""
    pos0, run0, over0 = pos, run, over
    value, pos, run, over = read_bits_local(data, end_bit, pos, run, over, 0, PRECISION)
    n_read = PRECISION
    low, high = 0, TOP
    for k in range(len(members)):
        m = members[k]
        total = scalars[m, TOTAL]
        target = _window_target(value, low, high - low + 1, total)
        if target < 0:
            return -1, pos, run, over
        if fresh:
            symbol, sym_low, sym_high = target, target, target + 1
        else:
            symbol, sym_low, sym_high = _bank_find(counts, tree, scalars, offsets, m, target)
        low, high, n_bits, subtract = narrow(low, high, sym_low, sym_high, total)
        value, pos, run, over = read_bits_local(data, end_bit, pos, run, over, value, n_bits)
        value -= subtract
        n_read += n_bits
        if not fresh:
            update_member(counts, tree, scalars, offsets, m, symbol)
        out[out_start + k] = symbol
    pos, run, over = give_back(data, end_bit, pos0, run0, over0, pos, over, n_read)
    return (-2 if pos > end_bit else 0), pos, run, over


@njit(cache=True)
def give_back(data, end_bit: int, pos0: int, run0: int, over0: int, pos: int, over: int, n_read: int
              ) -> tuple[int, int, int]:
    """The reader state (pos, run, over) after the first n_read - HISTORY of n_read look-ahead bits read from
    (pos0, run0, over0), which ended at (pos, over): what decode_frame's history ring gives back. Without
    emulation-prevention bits or bits past the end among them (pos - pos0 == n_read), HISTORY bits back and
    the zero run counted backwards; else they are read again."""
    if over == over0 and pos - pos0 == n_read:
        back = pos - HISTORY
        zeros = 0
        while zeros < MAX_ZERO_RUN and back - zeros > pos0:
            p = back - zeros - 1
            if (data[p >> 3] >> (7 - (p & 7))) & 1:
                return back, zeros, over
            zeros += 1
        if back - zeros == pos0 and run0 + zeros < MAX_ZERO_RUN:
            return back, run0 + zeros, over
    pos, run, over = pos0, run0, over0
    for _ in range(n_read - HISTORY):
        _, pos, run, over = look_local(data, end_bit, pos, run, over)
    return pos, run, over


# ------------------------------------------------------------------ the arithmetic decoder on a bit window
# decode_frame_local's symbols, model updates, statuses and reader state, faster:
# - the unit's emulation-prevention bits are found first: where the zero runs (with the reader's run) stay below
#   MAX_ZERO_RUN the coded bits are the raw bits, else they are copied once without the dropped bits
#   (_strip); the decoder then takes its bits several at a time from a 56-bit window;
# - the renormalisation loop runs as two counts: k E1/E2 shifts (the leading bits low and high share) and then
#   k3 E3 shifts (bits where low is 1 and high 0 after the top bit), with exactly the loop's subtractions;
#   this needs low <= high after each symbol, which totals of at most 2^30 guarantee (span > QUARTER after every
#   renormalisation, and a count of at least 1): totals and limits of at most WINDOW_MAX_TOTAL and increments of
#   at most WINDOW_MAX_INCREMENT keep every total below 2^26;
# - the Fenwick search without data-dependent branches;
# - the reader state given back from the clean-bit index and the zero run counted backwards (mod MAX_ZERO_RUN:
#   the reader's run restarts at every MAX_ZERO_RUN zeros, whether or not a stuffing bit follows).
# A frame outside those bounds (a run >= MAX_ZERO_RUN, a total above WINDOW_MAX_TOTAL) goes to decode_frame_local.

WINDOW_MAX_TOTAL = 1 << 24
WINDOW_MAX_INCREMENT = 1 << 16


def _byte_tables() -> tuple[np.ndarray, np.ndarray]:
    lead, trail = np.zeros(256, dtype=np.int64), np.zeros(256, dtype=np.int64)
    for byte in range(256):
        lead[byte] = 8 - byte.bit_length()
        trail[byte] = 8 if byte == 0 else (byte & -byte).bit_length() - 1
    return lead, trail


LEADING_ZEROS8, TRAILING_ZEROS8 = _byte_tables()


@intrinsic
def _ctlz64(typingctx, x):
    """LLVM's count-leading-zeros of an int64 (64 for 0)."""
    if not isinstance(x, types.Integer):
        return None

    def codegen(context, builder, signature, args):
        value = context.cast(builder, args[0], signature.args[0], types.int64)
        return builder.ctlz(value, ir.Constant(ir.IntType(1), 0))

    return types.int64(x), codegen


@njit(cache=True)
def _clz32(x: int) -> int:
    """Leading zeros of a value below 2^32, as a 32-bit value (32 for 0)."""
    return _ctlz64(x) - 32


@njit(cache=True)
def _has_stuffing(data, end_bit: int, pos: int, run: int) -> bool:
    """Whether look_local from (pos, run) meets MAX_ZERO_RUN zeros before end_bit (where a stuffing bit
    may be dropped or a start code left unread)."""
    zeros, pos, found = _zero_run_bits(data, pos, min(end_bit, (pos + 7) & ~7), run)
    if found:
        return True
    while pos + 8 <= end_bit:
        byte = data[pos >> 3]
        if zeros + LEADING_ZEROS8[byte] >= MAX_ZERO_RUN:
            return True
        zeros = zeros + 8 if byte == 0 else TRAILING_ZEROS8[byte]
        pos += 8
    return _zero_run_bits(data, pos, end_bit, zeros)[2]


@njit(cache=True, inline="always")
def _zero_run_bits(data, pos: int, stop: int, zeros: int) -> tuple[int, int, bool]:
    """The zero run after bits pos..stop - 1 read one at a time from a run of `zeros`: (zeros, where the scan
    stopped, whether the run reached MAX_ZERO_RUN)."""
    while pos < stop:
        if (data[pos >> 3] >> (7 - (pos & 7))) & 1:
            zeros = 0
        else:
            zeros += 1
            if zeros >= MAX_ZERO_RUN:
                return zeros, pos, True
        pos += 1
    return zeros, pos, False


@njit(cache=True)
def _strip(data, end_bit: int, pos: int, run: int, clean, stuffed) -> tuple[int, int]:
    """The bits look_local reads from (pos, run) before end_bit, into the zero-filled clean (MSB first), and the
    clean index that follows each dropped stuffing bit into stuffed: (clean bits, stuffing bits)."""
    n, n_stuffed = 0, 0
    while pos < end_bit:
        bit = (data[pos >> 3] >> (7 - (pos & 7))) & 1
        pos += 1
        if bit:
            clean[n >> 3] |= np.uint8(0x80 >> (n & 7))
            run = 0
        else:
            run += 1
            if run == MAX_ZERO_RUN:
                run = 0
                if pos < end_bit and (data[pos >> 3] >> (7 - (pos & 7))) & 1:
                    pos += 1
                    stuffed[n_stuffed] = n + 1
                    n_stuffed += 1
        n += 1
    return n, n_stuffed


@njit(cache=True)
def _refill(source, source_end: int, buf: int, n_buf: int, byte_at: int) -> tuple[int, int, int]:
    """Bytes of source (bits at and past source_end read as 0) into the window buf (n_buf bits) up to 56 bits."""
    buf &= (1 << n_buf) - 1
    while n_buf <= 48:
        first = byte_at << 3
        byte = 0
        if first < source_end:
            byte = np.int64(source[byte_at])
            if first + 8 > source_end:
                byte &= (0xFF << (8 - (source_end - first))) & 0xFF
        buf = (buf << 8) | byte
        n_buf += 8
        byte_at += 1
    return buf, n_buf, byte_at


@njit(cache=True)
def _clean_bit(source, source_start: int, source_end: int, c: int) -> int:
    p = source_start + c
    if p >= source_end:
        return 0
    return (source[p >> 3] >> (7 - (p & 7))) & 1


@njit(cache=True)
def _state_at(source, source_start: int, source_end: int, n_clean: int, stuffed, n_stuffed: int, pos0: int,
              run0: int, over0: int, j: int) -> tuple[int, int, int]:
    """The reader state (pos, run, over) before clean bit j of the bits read from (pos0, run0, over0)."""
    zeros = 0
    c = j
    if j > n_clean:
        zeros = j - n_clean
        c = n_clean
    while c > 0 and not _clean_bit(source, source_start, source_end, c - 1):
        zeros += 1
        c -= 1
    if c == 0:
        zeros += run0
    if j <= n_clean:
        skipped = 0
        for s in range(n_stuffed):
            if stuffed[s] <= j:
                skipped += 1
        return pos0 + j + skipped, zeros % MAX_ZERO_RUN, over0
    return pos0 + n_stuffed + j, zeros % MAX_ZERO_RUN, over0 + j - n_clean


@njit(cache=True, inline="always")
def _update_inline(counts, tree, scalars, offsets, m: int, symbol: int) -> None:
    """update_member, inlined into the decoder's loop (a call passes every array field by field)."""
    base = offsets[m]
    tbase = base + m
    increment, n = scalars[m, INCREMENT], scalars[m, N]
    counts[np.uint64(base + symbol)] += increment
    total = scalars[m, TOTAL] + increment
    scalars[m, TOTAL] = total
    if total > scalars[m, LIMIT]:
        total = 0
        for k in range(n):
            counts[base + k] = (counts[base + k] + 1) // 2
            total += counts[base + k]
            tree[tbase + k + 1] = counts[base + k]
        for i in range(1, n + 1):
            parent = i + (i & -i)
            if parent <= n:
                tree[tbase + parent] += tree[tbase + i]
        scalars[m, TOTAL] = total
        return
    i = symbol + 1
    while i <= n:
        tree[np.uint64(tbase + i)] += increment
        i += i & -i


@njit(cache=True, inline="always")
def _open_window(data, end_bit: int, pos: int, run: int):
    """The bit window of a decoder reading data from bit pos (zero run `run`) up to end_bit: the emulation-
    prevention bits stripped once when there are any (_strip), the window filled and the first PRECISION bits
    read. Returns (window, buf, n_buf, byte_at, value), window = (source, source_start, source_end, n_clean,
    stuffed, n_stuffed): _state_at maps bits consumed from source back to a position in data."""
    n_clean = max(end_bit - pos, 0)
    stuffed = np.zeros(1, dtype=np.int64)
    n_stuffed = 0
    if _has_stuffing(data, end_bit, pos, run):
        clean = np.zeros(n_clean // 8 + 1, dtype=np.uint8)
        stuffed = np.zeros(n_clean // MAX_ZERO_RUN + 1, dtype=np.int64)
        n_clean, n_stuffed = _strip(data, end_bit, pos, run, clean, stuffed)
        source, source_start, source_end = clean, 0, n_clean
    else:
        source, source_start, source_end = data, pos, end_bit
    byte_at = source_start >> 3
    buf, n_buf, byte_at = _refill(source, source_end, 0, 0, byte_at)
    n_buf -= source_start & 7
    value = (buf >> (n_buf - PRECISION)) & TOP
    n_buf -= PRECISION
    return (source, source_start, source_end, n_clean, stuffed, n_stuffed), buf, n_buf, byte_at, value


@njit(cache=True, inline="always")
def _bank_find(counts, tree, scalars, offsets, m: int, target: int) -> tuple[int, int, int]:
    """The symbol of model m of a bank whose interval holds the cumulative count target (0 <= target < total):
    (symbol, its cumulative count, the next symbol's), by a Fenwick search without data-dependent branches."""
    base = offsets[m]
    tbase = base + m
    position, remaining, step, n = 0, target, scalars[m, TOP_BIT], scalars[m, N]
    while step:
        nxt = position + step
        weight = tree[np.uint64(tbase + min(nxt, n))]
        take = (nxt <= n) & (weight <= remaining)
        position = nxt if take else position
        remaining = remaining - weight if take else remaining
        step >>= 1
    sym_low = target - remaining
    return position, sym_low, sym_low + counts[np.uint64(base + position)]


@njit(cache=True, inline="always")
def _window_target(value: int, low: int, span: int, total: int) -> int:
    """The cumulative count the decoder's value points at in the interval [low, low + span) of a model with this
    total, or -1 for a value outside it (damage)."""
    if value < low:
        return -1
    target = np.int64((np.uint64(value - low + 1) * np.uint64(total) - np.uint64(1)) // np.uint64(span))
    return target if target < total else -1


@njit(cache=True, inline="always")
def _narrow_window(low: int, high: int, sym_low: int, sym_high: int, total: int, value: int, buf: int, n_buf: int,
                   byte_at: int, window):
    """narrow with its bits taken from the bit window (_open_window's) at once. Returns (low, high, value, buf,
    n_buf, byte_at, bits consumed)."""
    source, source_end = window[0], window[2]
    low, high, n_bits, subtract = narrow(low, high, sym_low, sym_high, total)
    if n_buf < n_bits:
        buf, n_buf, byte_at = _refill(source, source_end, buf, n_buf, byte_at)
    n_buf -= n_bits
    value = (value << n_bits) - subtract + ((buf >> n_buf) & ((1 << n_bits) - 1))
    return low, high, value, buf, n_buf, byte_at, n_bits


@njit(cache=True)
def decode_frame_window(data, end_bit: int, pos: int, run: int, over: int, counts, tree, scalars, offsets, members,
                        out, out_start: int, fresh: bool) -> tuple[int, int, int, int]:
    """decode_frame_local (same arguments, results and model updates) on a bit window."""
    if not 0 <= run < MAX_ZERO_RUN:
        return decode_frame_local(data, end_bit, pos, run, over, counts, tree, scalars, offsets, members, out,
                                  out_start, fresh)
    for k in range(len(members)):
        m = members[k]
        if not 1 <= scalars[m, TOTAL] <= WINDOW_MAX_TOTAL or (not fresh and not (
                scalars[m, LIMIT] <= WINDOW_MAX_TOTAL and 0 <= scalars[m, INCREMENT] <= WINDOW_MAX_INCREMENT)):
            return decode_frame_local(data, end_bit, pos, run, over, counts, tree, scalars, offsets, members, out,
                                      out_start, fresh)
    pos0, run0, over0 = pos, run, over
    window, buf, n_buf, byte_at, value = _open_window(data, end_bit, pos, run)
    n_read, low, high, status = PRECISION, 0, TOP, 0
    for k in range(len(members)):
        m = members[k]
        total = scalars[m, TOTAL]
        target = _window_target(value, low, high - low + 1, total)
        if target < 0:
            status = -1
            break
        if fresh:
            symbol, sym_low, sym_high = target, target, target + 1
        else:
            symbol, sym_low, sym_high = _bank_find(counts, tree, scalars, offsets, m, target)
        low, high, value, buf, n_buf, byte_at, n_bits = _narrow_window(low, high, sym_low, sym_high, total, value,
                                                                       buf, n_buf, byte_at, window)
        n_read += n_bits
        if not fresh:
            _update_inline(counts, tree, scalars, offsets, m, symbol)
        out[out_start + k] = symbol
    return _close_window(window, pos0, run0, over0, end_bit, n_read, status)


@njit(cache=True, inline="always")
def _close_window(window, pos0: int, run0: int, over0: int, end_bit: int, n_read: int, status: int
                  ) -> tuple[int, int, int, int]:
    """A window decoder's (status, pos, run, over) after n_read clean bits of window (_open_window's, from
    (pos0, run0, over0)): the reader given back HISTORY bits when status is 0 (and status -2 when that lies past
    end_bit), else left after every bit read."""
    source, source_start, source_end, n_clean, stuffed, n_stuffed = window
    j = n_read - HISTORY if status == 0 else n_read
    pos, run, over = _state_at(source, source_start, source_end, n_clean, stuffed, n_stuffed, pos0, run0, over0, j)
    if status == 0 and pos > end_bit:
        status = -2
    return status, pos, run, over


# ------------------------------------------------------------------ the arithmetic coder's primitives
# Every arithmetic-coded stream (the FBA and BBA levels through entropy.py, frames.py and bba_writer.py /
# bba_units.py, seed 002's lab streams, the shape CAE of comparisons/video/shape_cae.py) narrows its interval and
# renormalises with these functions; Numba inlines them into each caller's loop, so each caller keeps its own
# bit source and sink (state arrays, local state, a bit window) and its model (Fenwick banks, sparse models,
# binary contexts). Registers are PRECISION = 32-bit low and high (Witten, Neal and Cleary 1987, bits plus
# follow); the encoder's bits go through start-code emulation prevention (a 1 after MAX_ZERO_RUN zeros) unless
# the caller passes max_run = NO_STUFFING (the shape payload, which has no start codes).

NO_STUFFING = 1 << 62            # a zero run no stream reaches: no emulation-prevention bits


@njit(cache=True, inline="always")
def put_bit_run(buffer, pos: int, run: int, bit: int, max_run: int) -> tuple[int, int]:
    """One bit into a zero-filled buffer at bit pos, a 1 inserted after max_run zeros in a row; (pos, run)."""
    if bit:
        buffer[pos >> 3] |= np.uint8(0x80 >> (pos & 7))
        return pos + 1, 0
    pos += 1
    run += 1
    if run == max_run:
        buffer[pos >> 3] |= np.uint8(0x80 >> (pos & 7))
        return pos + 1, 0
    return pos, run


@njit(cache=True, inline="always")
def put_bit_local(buffer, pos: int, run: int, bit: int) -> tuple[int, int]:
    """put_bit on local state: one data bit with emulation prevention; (position, zero run) after it."""
    return put_bit_run(buffer, pos, run, bit, MAX_ZERO_RUN)


@njit(cache=True, inline="always")
def finish_coder(buffer, pos: int, run: int, low: int, pending: int, max_run: int) -> tuple[int, int]:
    """The coder's flush: the bit that selects the final quarter (0 below QUARTER, else 1), then pending + 1
    copies of its complement; (position, zero run)."""
    bit = 0 if low < QUARTER else 1
    pos, run = put_bit_run(buffer, pos, run, bit, max_run)
    for _ in range(pending + 1):
        pos, run = put_bit_run(buffer, pos, run, 1 - bit, max_run)
    return pos, run


@njit(cache=True, inline="always")
def finish_encoder(buffer, pos: int, run: int, low: int, pending: int) -> tuple[int, int]:
    """finish_coder with emulation prevention."""
    return finish_coder(buffer, pos, run, low, pending, MAX_ZERO_RUN)


@njit(cache=True, inline="always")
def renormalise_coder(buffer, pos: int, run: int, low: int, high: int, pending: int,
                      max_run: int) -> tuple[int, int, int, int, int]:
    """The encoder's renormalisation after narrowing [low, high] to a symbol: emits the settled bits (E1: the
    interval in the lower half, bit 0; E2: upper half, bit 1) each followed by the pending follow bits, and
    counts a follow bit for each E3 (the interval straddles the middle within the second and third quarters);
    returns (position, zero run, low, high, pending)."""
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
        pos, run = put_bit_run(buffer, pos, run, bit, max_run)
        for _ in range(pending):
            pos, run = put_bit_run(buffer, pos, run, 1 - bit, max_run)
        pending = 0
        low <<= 1
        high = (high << 1) | 1
    return pos, run, low, high, pending


# The longest chunk `put_chunk` writes in one go: its bits, shifted to the chunk's place in a byte, fit 64 bits.
CHUNK_BITS = 56


@njit(cache=True, inline="always")
def put_chunk(buffer, pos: int, run: int, chunk: int, n_bits: int) -> tuple[int, int]:
    """n_bits (1..CHUNK_BITS) bits of chunk, MSB first, into a zero-filled buffer at bit pos with emulation prevention
    (a 1 after MAX_ZERO_RUN zeros in a row): (pos, zero run), what n_bits put_bit_run calls give. A chunk that no
    inserted bit can fall in (its leading zeros after the run, and any run inside it, shorter than MAX_ZERO_RUN) is
    ORed into its (at most 8) bytes at once; any other goes bit by bit."""
    lead = n_bits - (64 - _ctlz64(chunk))                # the chunk's leading zeros (n_bits for 0)
    if run + lead >= MAX_ZERO_RUN or (n_bits >= MAX_ZERO_RUN and chunk != 0):
        for shift in range(n_bits - 1, -1, -1):
            pos, run = put_bit_run(buffer, pos, run, (chunk >> shift) & 1, MAX_ZERO_RUN)
        return pos, run
    if chunk == 0:
        return pos + n_bits, run + n_bits
    end = (pos & 7) + n_bits                             # <= 63: the chunk's end from its first byte's start
    aligned = chunk << (64 - end)                        # its first bit at the word's top (int64: wraps, & 0xFF below)
    byte = pos >> 3
    for k in range((end + 7) >> 3):
        buffer[byte + k] |= np.uint8((aligned >> (56 - 8 * k)) & 0xFF)
    return pos + n_bits, _ctlz64(chunk & -chunk) ^ 63     # the zeros after its last 1


@njit(cache=True, inline="always")
def renormalise_encoder(buffer, pos: int, run: int, low: int, high: int,
                        pending: int) -> tuple[int, int, int, int, int]:
    """renormalise_coder with emulation prevention, its bits a chunk at a time: the same bits and registers
    (tests/test_bba_units.py compares the two). The E1/E2 steps are the leading bits low and high share
    (renormalise_decoder's count); the first of them is followed by the pending follow bits, the others by none,
    so all of them go as one chunk (`put_chunk`). No E1/E2 step can follow an E3 step (after one, low < HALF <=
    high still), so the E3 steps come after them all: the positions after the top bit where low has a 1 and high a 0."""
    shifts = _clz32(low ^ high)
    if shifts:
        top = low >> (PRECISION - shifts)                # the settled bits
        first = top >> (shifts - 1)
        n_bits = shifts + pending
        if n_bits <= CHUNK_BITS:
            chunk = ((((first << pending) | ((1 - first) * ((1 << pending) - 1))) << (shifts - 1))
                     | (top & ((1 << (shifts - 1)) - 1)))
            pos, run = put_chunk(buffer, pos, run, chunk, n_bits)
        else:
            pos, run = put_bit_run(buffer, pos, run, first, MAX_ZERO_RUN)
            for _ in range(pending):
                pos, run = put_bit_run(buffer, pos, run, 1 - first, MAX_ZERO_RUN)
            for shift in range(shifts - 2, -1, -1):
                pos, run = put_bit_run(buffer, pos, run, (top >> shift) & 1, MAX_ZERO_RUN)
        pending = 0
        low = (low << shifts) & TOP
        high = ((high << shifts) | ((1 << shifts) - 1)) & TOP
    follow = _clz32(~(low & ~high) & (HALF - 1)) - 1
    if follow > 0:
        pending += follow
        low = (low << follow) & (HALF - 1)
        high = (((high << follow) | ((1 << follow) - 1)) & TOP) | HALF
    return pos, run, low, high, pending


@njit(cache=True, inline="always")
def encode_interval(buffer, pos: int, run: int, low: int, high: int, pending: int, sym_low: int, sym_high: int,
                    total: int) -> tuple[int, int, int, int, int]:
    """The encoder's interval [low, high] narrowed to the cumulative counts [sym_low, sym_high) of total and
    renormalised, its bits into buffer with emulation prevention: (pos, run, low, high, pending)."""
    span = high - low + 1
    return renormalise_encoder(buffer, pos, run, low + _scale(span, sym_low, total),
                               low + _scale(span, sym_high, total) - 1, pending)


@njit(cache=True, inline="always")
def renormalise_decoder(low: int, high: int) -> tuple[int, int, int, int]:
    """The decoder's renormalisation after narrowing to a symbol (low <= high): the E1/E2 shifts (the leading
    bits low and high share) and then the E3 shifts (after the top bit, the bits where low is 1 and high 0),
    all at once. Returns (low, high, n_bits, subtract): the caller reads the next n_bits code bits into its value
    register, value = (value << n_bits) - subtract + those bits (int64 arithmetic, exact modulo 2^64), which is
    the bit-by-bit loop's value."""
    shifts = _clz32(low ^ high)
    out_bits = (low >> (PRECISION - shifts)) << PRECISION
    low = (low << shifts) - out_bits
    high = (high << shifts) - out_bits + ((1 << shifts) - 1)
    follow = _clz32(~(low & ~high) & (HALF - 1)) - 1
    low = (low << follow) & (HALF - 1)
    high = (((high << follow) | ((1 << follow) - 1)) & TOP) | HALF
    return low, high, shifts + follow, (out_bits << follow) + ((1 << follow) - 1) * HALF

"""Entropy coders: an adaptive multi-symbol arithmetic coder and a static canonical Huffman coder.

Arithmetic coder. An integer coder in the Witten-Neal-Cleary form that the MPEG-4 FBA coder uses
(mpeg4-facts.md §2.5: bits-plus-follow renormalisation, cumulative-frequency models, one model
per parameter, frequencies +1 per coded symbol, halving at a limit), widened from 16 to 32-bit
registers so large alphabets (thousands of quantised BAP levels) keep full precision. Models
are Fenwick trees, so coding a symbol costs O(log n) for an alphabet of n symbols.

Termination: `finish()` writes 2 bits (plus pending follow bits). The decoder fills a 32-bit
register ahead of what it needs; after the last symbol it hands the 30 over-read bits back to the
BitReader, so the next field is read from exactly where the encoder's output ended. This makes
the coder usable in the middle of a bit stream, and lets a container check that a coded payload
ends exactly where it should (the check that catches truncated or damaged data).

Huffman coder. Code lengths from symbol frequencies (length-limited by flattening), canonical
code assignment; the code tables are fixed by their lengths, so formats only store lengths.
"""
from __future__ import annotations

import heapq
from collections import deque

import numpy as np

from comparisons.bitstream import BitReader, BitWriter
from media.errors import SigncastError

PRECISION = 32
TOP = (1 << PRECISION) - 1
HALF = 1 << (PRECISION - 1)
QUARTER = 1 << (PRECISION - 2)
THREE_QUARTERS = HALF + QUARTER
MAX_TOTAL = 1 << 16          # keeps span * total well inside the coder's precision


class FrequencyModel:
    """Adaptive frequency table over symbols 0..n-1 (Fenwick tree of counts).

    Every symbol starts with count 1 (as the FBA coder's uniform start); each coded symbol adds
    `increment`; when the total exceeds `limit` every count is halved, rounding up.
    """

    def __init__(self, n_symbols: int, increment: int = 1, limit: int = MAX_TOTAL) -> None:
        if n_symbols < 1:
            raise SigncastError(f"an alphabet needs at least one symbol, got {n_symbols}")
        if n_symbols > limit // 2:
            raise SigncastError(f"alphabet of {n_symbols} symbols is too large for a frequency limit of {limit}")
        self.n = n_symbols
        self.increment = increment
        self.limit = limit
        self.counts = [1] * n_symbols
        index = np.arange(1, n_symbols + 1)
        self.tree = [0] + (index & -index).tolist()          # Fenwick tree of all-ones counts
        self.total = n_symbols
        self._top_bit = 1 << (n_symbols.bit_length() - 1)

    def _rebuild(self) -> None:
        n = self.n
        cumulative = np.concatenate([[0], np.cumsum(self.counts, dtype=np.int64)])
        index = np.arange(1, n + 1)
        self.tree = [0] + (cumulative[index] - cumulative[index - (index & -index)]).tolist()
        self.total = int(cumulative[-1])
        self._top_bit = 1 << (n.bit_length() - 1)

    def _prefix(self, symbol: int) -> int:
        """Sum of counts of symbols < symbol."""
        total, i, tree = 0, symbol, self.tree
        while i > 0:
            total += tree[i]
            i -= i & -i
        return total

    def interval(self, symbol: int) -> tuple[int, int]:
        low = self._prefix(symbol)
        return low, low + self.counts[symbol]

    def find(self, target: int) -> tuple[int, int, int]:
        """The symbol whose interval holds cumulative count `target`, and that interval."""
        position, remaining, step, tree, n = 0, target, self._top_bit, self.tree, self.n
        while step:
            nxt = position + step
            if nxt <= n and tree[nxt] <= remaining:
                position = nxt
                remaining -= tree[nxt]
            step >>= 1
        low = target - remaining
        return position, low, low + self.counts[position]

    def update(self, symbol: int) -> None:
        self.counts[symbol] += self.increment
        self.total += self.increment
        if self.total > self.limit:
            self.counts = [(c + 1) // 2 for c in self.counts]
            self._rebuild()
            return
        i, tree, n = symbol + 1, self.tree, self.n
        while i <= n:
            tree[i] += self.increment
            i += i & -i


class ArithmeticEncoder:
    """Writes arithmetic-coded symbols into a BitWriter (with its emulation prevention)."""

    def __init__(self, writer: BitWriter) -> None:
        self.writer = writer
        self.low = 0
        self.high = TOP
        self.pending = 0

    def _emit(self, bit: int) -> None:
        self.writer.write_bit(bit)
        opposite = 1 - bit
        for _ in range(self.pending):
            self.writer.write_bit(opposite)
        self.pending = 0

    def encode(self, model: FrequencyModel, symbol: int) -> None:
        if not 0 <= symbol < model.n:
            raise SigncastError(f"symbol {symbol} outside the model's alphabet 0..{model.n - 1}")
        sym_low, sym_high = model.interval(symbol)
        total = model.total
        span = self.high - self.low + 1
        self.high = self.low + span * sym_high // total - 1
        self.low = self.low + span * sym_low // total
        while True:
            if self.high < HALF:
                self._emit(0)
            elif self.low >= HALF:
                self._emit(1)
                self.low -= HALF
                self.high -= HALF
            elif self.low >= QUARTER and self.high < THREE_QUARTERS:
                self.pending += 1
                self.low -= QUARTER
                self.high -= QUARTER
            else:
                break
            self.low <<= 1
            self.high = (self.high << 1) | 1
        model.update(symbol)

    def finish(self) -> None:
        """Two bits (plus pending follow bits) pin the final interval; any bits may follow."""
        self.pending += 1
        self._emit(0 if self.low < QUARTER else 1)


class ArithmeticDecoder:
    """Decodes what ArithmeticEncoder wrote, from a BitReader positioned at its first bit."""

    def __init__(self, reader: BitReader) -> None:
        self.reader = reader
        self.low = 0
        self.high = TOP
        self._history: deque = deque(maxlen=PRECISION - 2)
        self.value = 0
        for _ in range(PRECISION):
            self.value = (self.value << 1) | self._next_bit()

    def _next_bit(self) -> int:
        self._history.append(self.reader.state)
        return self.reader.read_bit(lookahead=True)

    def decode(self, model: FrequencyModel) -> int:
        span = self.high - self.low + 1
        total = model.total
        target = ((self.value - self.low + 1) * total - 1) // span
        if not 0 <= target < total:
            raise SigncastError("corrupt arithmetic-coded data")
        symbol, sym_low, sym_high = model.find(target)
        self.high = self.low + span * sym_high // total - 1
        self.low = self.low + span * sym_low // total
        while True:
            if self.high < HALF:
                pass
            elif self.low >= HALF:
                self.low -= HALF
                self.high -= HALF
                self.value -= HALF
            elif self.low >= QUARTER and self.high < THREE_QUARTERS:
                self.low -= QUARTER
                self.high -= QUARTER
                self.value -= QUARTER
            else:
                break
            self.low <<= 1
            self.high = (self.high << 1) | 1
            self.value = (self.value << 1) | self._next_bit()
        model.update(symbol)
        return symbol

    def finish(self) -> None:
        """Give back the over-read register bits; SigncastError if the data ended too early."""
        self.reader.state = self._history[0]
        if self.reader.pos > self.reader.end_bit:
            raise SigncastError("truncated stream: arithmetic-coded data ends early")


def encode_sequence(symbols, n_symbols: int, increment: int = 1) -> bytes:
    """A whole sequence with one adaptive model: 32-bit count, then the coded symbols."""
    writer = BitWriter()
    symbols = [int(s) for s in symbols]
    writer.write(len(symbols), 32)
    model = FrequencyModel(n_symbols, increment)
    encoder = ArithmeticEncoder(writer)
    for s in symbols:
        encoder.encode(model, s)
    encoder.finish()
    return writer.getvalue()


def decode_sequence(data: bytes, n_symbols: int, increment: int = 1) -> list[int]:
    """Inverse of encode_sequence; SigncastError when the data is truncated or has trailing bytes."""
    reader = BitReader(data)
    count = reader.read(32)
    if count > 8 * len(data) * 64:
        raise SigncastError("corrupt arithmetic-coded sequence: impossible symbol count")
    model = FrequencyModel(n_symbols, increment)
    decoder = ArithmeticDecoder(reader)
    symbols = [decoder.decode(model) for _ in range(count)]
    decoder.finish()
    if (reader.pos + 7) // 8 != len(data):
        raise SigncastError(f"corrupt arithmetic-coded sequence: coded data ends at byte "
                            f"{(reader.pos + 7) // 8} of {len(data)}")
    return symbols


def adaptive_code_length_bits(symbols, n_symbols: int, increment: int = 1) -> float:
    """sum -log2 p(s) under the adaptive model: what an ideal coder with the same model would spend."""
    model = FrequencyModel(n_symbols, increment)
    bits = 0.0
    for s in symbols:
        low, high = model.interval(int(s))
        bits -= np.log2((high - low) / model.total)
        model.update(int(s))
    return float(bits)


def empirical_entropy_bits(symbols) -> float:
    """n * H(p) in bits, with p the symbols' relative frequencies (the zero-order bound)."""
    _, counts = np.unique(np.asarray(symbols), return_counts=True)
    p = counts / counts.sum()
    return float(-(counts * np.log2(p)).sum())


# ---------------------------------------------------------------------------------------------
# Static Huffman coding with canonical codes


def huffman_code_lengths(frequencies, max_length: int = 24) -> list[int]:
    """Code length per symbol (0 for symbols of frequency 0) of a Huffman code, at most max_length."""
    freqs = [int(f) for f in frequencies]
    if any(f < 0 for f in freqs):
        raise SigncastError("symbol frequencies must be non-negative")
    used = [i for i, f in enumerate(freqs) if f > 0]
    lengths = [0] * len(freqs)
    if not used:
        return lengths
    if len(used) == 1:
        lengths[used[0]] = 1
        return lengths
    while True:
        heap = [(freqs[i], i, (i,)) for i in used]
        heapq.heapify(heap)
        depth = {i: 0 for i in used}
        tie = len(freqs)
        while len(heap) > 1:
            f1, _, s1 = heapq.heappop(heap)
            f2, _, s2 = heapq.heappop(heap)
            for s in s1 + s2:
                depth[s] += 1
            heapq.heappush(heap, (f1 + f2, tie, s1 + s2))
            tie += 1
        if max(depth.values()) <= max_length:
            for i in used:
                lengths[i] = depth[i]
            return lengths
        freqs = [(f + 1) // 2 if f else 0 for f in freqs]   # flatten and retry


class CanonicalHuffman:
    """Canonical prefix code from code lengths (symbols of length 0 have no code)."""

    def __init__(self, lengths) -> None:
        self.lengths = [int(x) for x in lengths]
        if any(x < 0 or x > 32 for x in self.lengths):
            raise SigncastError("Huffman code lengths must lie in 0..32")
        if sum(2.0 ** -x for x in self.lengths if x) > 1.0 + 1e-12:
            raise SigncastError("Huffman code lengths violate the Kraft inequality")
        order = sorted((x, s) for s, x in enumerate(self.lengths) if x)
        self.codes: dict[int, tuple[int, int]] = {}
        self._first_code: dict[int, int] = {}
        self._symbols_by_length: dict[int, list[int]] = {}
        code, previous = 0, 0
        for length, symbol in order:
            code <<= length - previous
            previous = length
            self._first_code.setdefault(length, code)
            self._symbols_by_length.setdefault(length, []).append(symbol)
            self.codes[symbol] = (code, length)
            code += 1
        self.max_length = max(self.lengths) if order else 0

    def encode(self, writer: BitWriter, symbol: int) -> None:
        try:
            code, length = self.codes[symbol]
        except KeyError:
            raise SigncastError(f"symbol {symbol} has no code in this Huffman table") from None
        writer.write(code, length)

    def decode(self, reader: BitReader) -> int:
        code = 0
        for length in range(1, self.max_length + 1):
            code = (code << 1) | reader.read_bit()
            symbols = self._symbols_by_length.get(length)
            if symbols:
                index = code - self._first_code[length]
                if 0 <= index < len(symbols):
                    return symbols[index]
        raise SigncastError("corrupt stream: bits match no Huffman code")

    def cost_bits(self, symbol: int) -> int:
        return self.codes[symbol][1]

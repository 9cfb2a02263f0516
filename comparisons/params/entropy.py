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

Speed: the models' Fenwick trees live in int64 arrays and the coder's loops are Numba-compiled
kernels (comparisons/params/arithmetic.py) that write straight into BitWriter's buffer or read BitReader's
data: one call per symbol (ArithmeticEncoder, ArithmeticDecoder), per frame of a ModelBank
(encode_frame, decode_frame) or per run of symbols of one model (encode_symbols, decode_symbols). The
integer arithmetic is unchanged, so the streams are bit-identical to the pure-Python coder's.
"""
from __future__ import annotations

import heapq

import numpy as np

from comparisons.params import arithmetic as kc
from comparisons.params.bits import BitReader, BitWriter
from media.errors import SigncastError

PRECISION = kc.PRECISION
TOP = kc.TOP
HALF = kc.HALF
QUARTER = kc.QUARTER
THREE_QUARTERS = kc.THREE_QUARTERS
MAX_LIMIT = kc.QUARTER        # totals stay at or below the coder's smallest span (2^30) so no symbol's interval is empty
MAX_TOTAL = 1 << 16          # keeps span * total well inside the coder's precision
HISTORY = kc.HISTORY      # reader states the decoder remembers, to give back its over-read bits


class FrequencyModel:
    """Adaptive frequency table over symbols 0..n-1 (Fenwick tree of counts).

    Every symbol starts with count 1 (as the FBA coder's uniform start); each coded symbol adds
    `increment`; when the total exceeds `limit` every count is halved, rounding up.
    counts: (n,) int64; tree: (n + 1,) int64 Fenwick tree; scalars: total, top bit, increment,
    limit, n (int64, what the kernels read)."""

    def __init__(self, n_symbols: int, increment: int = 1, limit: int = MAX_TOTAL) -> None:
        if n_symbols < 1:
            raise SigncastError(f"an alphabet needs at least one symbol, got {n_symbols}")
        if not 2 <= limit <= MAX_LIMIT or not 0 <= increment <= limit:
            raise SigncastError(f"a frequency limit must be 2..{MAX_LIMIT} and the increment 0..limit, got {limit} "
                                f"and {increment}")
        if n_symbols > limit // 2:
            raise SigncastError(f"alphabet of {n_symbols} symbols is too large for a frequency limit of {limit}")
        self.n = n_symbols
        self.increment = increment
        self.limit = limit
        self.counts = np.ones(n_symbols, dtype=np.int64)
        index = np.arange(n_symbols + 1, dtype=np.int64)
        self.tree = index & -index                          # Fenwick tree of all-ones counts
        self.scalars = np.array([n_symbols, 1 << (n_symbols.bit_length() - 1), increment, limit, n_symbols],
                                dtype=np.int64)

    @property
    def total(self) -> int:
        return int(self.scalars[kc.TOTAL])

    def interval(self, symbol: int) -> tuple[int, int]:
        low = int(kc.prefix(self.tree, symbol))
        return low, low + int(self.counts[symbol])

    def find(self, target: int) -> tuple[int, int, int]:
        """The symbol whose interval holds cumulative count `target`, and that interval."""
        symbol, low = kc.find(self.tree, self.scalars, target)
        return int(symbol), int(low), int(low + self.counts[symbol])

    def update(self, symbol: int) -> None:
        kc.update(self.counts, self.tree, self.scalars, symbol)


class ArithmeticEncoder:
    """Writes arithmetic-coded symbols into a BitWriter (with its emulation prevention)."""

    def __init__(self, writer: BitWriter) -> None:
        self.writer = writer
        self.registers = np.array([0, TOP, 0], dtype=np.int64)     # low, high, pending

    def encode(self, model: FrequencyModel, symbol: int) -> None:
        if not 0 <= symbol < model.n:
            raise SigncastError(f"symbol {symbol} outside the model's alphabet 0..{model.n - 1}")
        self.writer.reserve(2 * int(self.registers[2]) + 2 * PRECISION + 4)
        kc.encode_symbol(self.writer.buffer, self.writer.state, self.registers, model.counts, model.tree,
                      model.scalars, symbol)

    def finish(self) -> None:
        """Two bits (plus pending follow bits) pin the final interval; any bits may follow."""
        self.writer.reserve(2 * int(self.registers[2]) + 6)
        kc.finish_state(self.writer.buffer, self.writer.state, self.registers)


class ArithmeticDecoder:
    """Decodes what ArithmeticEncoder wrote, from a BitReader positioned at its first bit."""

    def __init__(self, reader: BitReader) -> None:
        self.reader = reader
        self.history = np.zeros((HISTORY, 3), dtype=np.int64)
        self.history_at = np.zeros(1, dtype=np.int64)
        value = kc.fill(reader.array, reader.end_bit, reader.registers, self.history, self.history_at)
        self.registers = np.array([0, TOP, value], dtype=np.int64)      # low, high, value

    def decode(self, model: FrequencyModel) -> int:
        symbol = kc.decode_symbol(self.reader.array, self.reader.end_bit, self.reader.registers, self.history,
                               self.history_at, self.registers, model.counts, model.tree, model.scalars)
        if symbol < 0:
            raise SigncastError("corrupt arithmetic-coded data")
        return int(symbol)

    def finish(self) -> None:
        """Give back the over-read register bits; SigncastError if the data ended too early."""
        at = int(self.history_at[0])
        self.reader.registers[:] = self.history[at % HISTORY if at >= HISTORY else 0]
        if self.reader.pos > self.reader.end_bit:
            raise SigncastError("truncated stream: arithmetic-coded data ends early")


class ModelBank:
    """Adaptive models (as FrequencyModel, increment 1, limit MAX_TOTAL) of several parameters in
    shared arrays, so one kernel call codes a whole frame of levels, one symbol per member.

    sizes: (M,) alphabet sizes. members: (k,) int64 indices of the models a frame codes, in order
    (`subset` picks them; the subset shares the counts, so coding through it updates the bank)."""

    def __init__(self, sizes, members: np.ndarray | None = None, _arrays=None) -> None:
        if _arrays is None:
            sizes = np.asarray(sizes, dtype=np.int64).reshape(-1)
            if np.any(sizes < 1):
                raise SigncastError(f"an alphabet needs at least one symbol, got {int(sizes.min())}")
            if np.any(sizes > MAX_TOTAL // 2):
                raise SigncastError(f"alphabet of {int(sizes.max())} symbols is too large for a frequency "
                                    f"limit of {MAX_TOTAL}")
            offsets = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
            counts = np.ones(int(offsets[-1]), dtype=np.int64)
            tree = np.empty(int(offsets[-1]) + len(sizes), dtype=np.int64)
            scalars = np.empty((len(sizes), 5), dtype=np.int64)
            kc.init_bank(sizes, offsets, tree, scalars, MAX_TOTAL)
            _arrays = (sizes, offsets, counts, tree, scalars)
        self.sizes, self.offsets, self.counts, self.tree, self.scalars = _arrays
        self.members = np.arange(len(self.sizes), dtype=np.int64) if members is None else members

    def __len__(self) -> int:
        return len(self.members)

    def subset(self, members) -> ModelBank:
        """The models `members` (indices into this bank's members), sharing their counts."""
        return ModelBank(None, self.members[np.asarray(members, dtype=np.int64)], _arrays=(
            self.sizes, self.offsets, self.counts, self.tree, self.scalars))

    def member_sizes(self) -> np.ndarray:
        return self.sizes[self.members]


def encode_frame(writer: BitWriter, bank: ModelBank, symbols: np.ndarray) -> None:
    """symbols (k,) int64, one per member of `bank`, arithmetic-coded from a fresh coder and
    flushed (the same bits as an ArithmeticEncoder coding them in turn, then finish())."""
    symbols = np.ascontiguousarray(symbols, dtype=np.int64)
    sizes = bank.member_sizes()
    bad = np.flatnonzero((symbols < 0) | (symbols >= sizes))
    if len(bad):
        k = int(bad[0])
        raise SigncastError(f"symbol {int(symbols[k])} outside the model's alphabet 0..{int(sizes[k]) - 1}")
    writer.reserve(4 * PRECISION * (len(symbols) + 1))
    kc.encode_frame(writer.buffer, writer.state, bank.counts, bank.tree, bank.scalars, bank.offsets, bank.members,
                  symbols)


def decode_frame(reader: BitReader, bank: ModelBank) -> np.ndarray:
    """(k,) int64 symbols of what encode_frame wrote; SigncastError on corrupt or truncated data."""
    out = np.empty(len(bank.members), dtype=np.int64)
    status = kc.decode_frame(reader.array, reader.end_bit, reader.registers, bank.counts, bank.tree, bank.scalars,
                           bank.offsets, bank.members, out)
    if status == -1:
        raise SigncastError("corrupt arithmetic-coded data")
    if status == -2:
        raise SigncastError("truncated stream: arithmetic-coded data ends early")
    return out


def encode_symbols(writer: BitWriter, model: FrequencyModel, symbols) -> None:
    """symbols (n,) coded in turn with one adaptive model from a fresh coder, then flushed: the same
    bits as ArithmeticEncoder.encode for each and finish()."""
    symbols = np.ascontiguousarray(symbols, dtype=np.int64).reshape(-1)
    bad = np.flatnonzero((symbols < 0) | (symbols >= model.n))
    if len(bad):
        raise SigncastError(f"symbol {int(symbols[bad[0]])} outside the model's alphabet 0..{model.n - 1}")
    writer.reserve(4 * PRECISION * (len(symbols) + 1))
    kc.encode_run(writer.buffer, writer.state, model.counts, model.tree, model.scalars, symbols)


def decode_symbols(reader: BitReader, model: FrequencyModel, count: int, max_overrun: int | None = None) -> np.ndarray:
    """(count,) int64 symbols of what encode_symbols wrote, the reader left where its bits end.
    max_overrun: stop with SigncastError as soon as the register fill has read more than this many
    bits past the end (the symbols claimed are not in the data). SigncastError on corrupt data."""
    out = np.empty(count, dtype=np.int64)
    status = kc.decode_run(reader.array, reader.end_bit, reader.registers, model.counts, model.tree, model.scalars,
                         out, np.iinfo(np.int64).max if max_overrun is None else max_overrun)
    if status == -1:
        raise SigncastError("corrupt arithmetic-coded data")
    if status == -2:
        raise SigncastError("truncated stream: arithmetic-coded data ends early")
    if status == -3:
        raise SigncastError("corrupt arithmetic-coded section: the data ends before its symbols do")
    return out


def encode_sequence(symbols, n_symbols: int, increment: int = 1) -> bytes:
    """A whole sequence with one adaptive model: 32-bit count, then the coded symbols."""
    writer = BitWriter()
    symbols = [int(s) for s in symbols]
    writer.write(len(symbols), 32)
    encode_symbols(writer, FrequencyModel(n_symbols, increment), symbols)
    return writer.getvalue()


def decode_sequence(data: bytes, n_symbols: int, increment: int = 1) -> list[int]:
    """Inverse of encode_sequence; SigncastError when the data is truncated or has trailing bytes."""
    reader = BitReader(data)
    count = reader.read(32)
    if count > 8 * len(data) * 64:
        raise SigncastError("corrupt arithmetic-coded sequence: impossible symbol count")
    symbols = decode_symbols(reader, FrequencyModel(n_symbols, increment), count).tolist()
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
        self._arrays = None

    def arrays(self) -> tuple[np.ndarray, ...]:
        """The kernels' view (int64): codes (S,), lengths (S,), and by code length 0..max_length:
        first code, number of codes, start in `symbols`; symbols (sorted by length, then symbol)."""
        if self._arrays is None:
            codes = np.zeros(len(self.lengths), dtype=np.int64)
            for symbol, (code, _) in self.codes.items():
                codes[symbol] = code
            first = np.zeros(self.max_length + 1, dtype=np.int64)
            count = np.zeros(self.max_length + 1, dtype=np.int64)
            start = np.zeros(self.max_length + 1, dtype=np.int64)
            symbols = []
            for length in range(1, self.max_length + 1):
                members = self._symbols_by_length.get(length, [])
                first[length] = self._first_code.get(length, 0)
                count[length], start[length] = len(members), len(symbols)
                symbols += members
            self._arrays = (codes, np.array(self.lengths, dtype=np.int64), first, count, start,
                            np.array(symbols, dtype=np.int64))
        return self._arrays

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

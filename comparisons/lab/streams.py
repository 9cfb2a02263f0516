"""The container every motion coder of seed 002 writes: header, entropy-coded symbol streams, raw bits, CRC.

A coded motion is one `bytes` object:

    magic "SCM1" | coder id (u8) | entropy stage id (u8) | q (u8) | T (u32) | D (u16) | fps x 1000 (u32)
    | sections ... | CRC-32 of everything before it (u32)

Each section is one of
    b"S" varint(alphabet) varint(count) varint(n_bytes) bytes   symbols in [0, alphabet), entropy coded
    b"R" varint(count) varint(n_bytes) bytes                    integers of known bit widths, packed MSB first
    b"H" varint(n_bytes) bytes                                  coder side information (fixed layout per coder)
    b"C" varint(count) varint(n_bytes) bytes                    wavelet coefficients (D, n_blocks, 16), context
                                                                coded (comparisons/lab/context.py), count = their number

A second, compact layout (write_compact / read_compact, at the end of this module) frames a coder whose stream is
one self-delimiting payload (wavelet-cx): magic b"Sc", coder id, q, varint T, varint fps code, payload, CRC-32.
The CRC-32 starts from the coder's model tag (0 for none; wavelet-cx: a CRC of its trained priors), so a stream
coded with other trained tables fails the check instead of decoding to wrong motion, at no extra byte.

Writer and reader are used in the same order by a coder's encoder and decoder. The reader checks
every length and the CRC, so corrupt or truncated input raises SigncastError instead of decoding
to wrong motion. Both ends bound the header before anything is allocated: T <= MAX_FRAMES,
T x D <= MAX_VALUES, 0.001 <= fps <= MAX_FPS. Every count the decoder reads is bounded by the header:
a section's count must equal, or for variable-length sections not exceed, what the coder's layout
derives from it.

The entropy stage is a parameter (`EntropyStage`): `arithmetic` (default: the adaptive multi-symbol
arithmetic coder of comparisons/params/entropy.py, one adaptive model per section), `huffman` (static canonical
Huffman of comparisons/params/entropy.py, code lengths sent in the section) or `fixed` (ceil(log2(alphabet))
bits per symbol, i.e. no entropy coding).

Speed: arithmetic-coded sections and signed sections are coded by comparisons/lab/stream_loops.py (one call for a
coder's n per-DOF sections: `symbol_rows`), with the same bytes as the entropy stage's own coder; a section
the compiled reader does not accept is read again by the checking reader here, which names the damage.
"""
from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass
from typing import Callable

import numpy as np

from comparisons.lab import context as lab_context
from comparisons.lab import stream_loops as lab_streams
from media.errors import SigncastError

MAGIC = b"SCM1"
_HEADER = struct.Struct("<4sBBBIHI")
_MAX_MAGNITUDE_CLASS = 40
MAX_FRAMES = 1 << 18  # 2.9 h at 25 fps: bounds what a (possibly crafted) header can make a decoder allocate
# frames x channels of one coded motion: 15 min of the 183-DOF signing layout at 25 fps; a decoded (T, D)
# float64 array then takes at most 32 MiB, and a decoder at most a few such arrays
MAX_VALUES = 1 << 22
MAX_FPS = 1000.0  # frames per second: above any motion capture of signing; decoders size windows by fps


# ---------------------------------------------------------------- entropy stages

@dataclass(frozen=True)
class EntropyStage:
    """A lossless coder of a symbol array: encode(symbols (n,) int64, alphabet) -> bytes and
    decode(bytes, n, alphabet) -> symbols (n,) int64."""
    name: str
    stage_id: int
    encode: Callable[[np.ndarray, int], bytes]
    decode: Callable[[bytes, int, int], np.ndarray]


def _fixed_width(alphabet: int) -> int:
    return max(int(alphabet - 1).bit_length(), 0)


def _fixed_encode(symbols: np.ndarray, alphabet: int) -> bytes:
    width = _fixed_width(alphabet)
    return pack_bits(symbols, np.full(len(symbols), width))


def _fixed_decode(data: bytes, count: int, alphabet: int) -> np.ndarray:
    width = _fixed_width(alphabet)
    return unpack_bits(data, np.full(count, width))


ARITHMETIC_INCREMENT = 16  # count added per coded symbol: faster adaptation than +1 on short motion clips


def _arithmetic_encode(symbols: np.ndarray, alphabet: int) -> bytes:
    from comparisons.params.bits import BitWriter
    from comparisons.params.entropy import FrequencyModel, encode_symbols
    writer = BitWriter()
    encode_symbols(writer, FrequencyModel(alphabet, ARITHMETIC_INCREMENT), symbols)
    return writer.getvalue()


def _arithmetic_decode(data: bytes, count: int, alphabet: int) -> np.ndarray:
    from comparisons.params.bits import BitReader
    from comparisons.params.entropy import PRECISION, FrequencyModel, decode_symbols
    reader = BitReader(data)
    # the decoder reads its register ahead by at most PRECISION bits; reading further past the end
    # means the symbols claimed are not in the data (finish() would fail): stop then, not after `count`
    symbols = decode_symbols(reader, FrequencyModel(alphabet, ARITHMETIC_INCREMENT), count, max_overrun=PRECISION)
    if (reader.pos + 7) // 8 != len(data):
        raise SigncastError("corrupt arithmetic-coded section: data does not end where the symbols do")
    return symbols


_MODEL_LIMIT = 1 << 16  # comparisons.params.entropy.MAX_TOTAL: the adaptive models' frequency limit
_MAX_OVERRUN = 32       # comparisons.params.entropy.PRECISION: bits the decoder's register may read past a payload


def _compiled_sections(stage: EntropyStage, alphabet: int) -> bool:
    """Whether comparisons/lab/stream_loops.py codes this stage's sections: the arithmetic stage, for every alphabet
    FrequencyModel accepts (larger ones take the checking path, which rejects them)."""
    return stage.stage_id == 1 and 1 <= alphabet <= _MODEL_LIMIT // 2


def _encode_sections(rows: np.ndarray, alphabet: int) -> bytes:
    """Complete arithmetic-coded sections (tag, lengths, payload), one per row of rows (n, count) int64."""
    out = np.empty(lab_streams.section_capacity(len(rows), rows.shape[1]), dtype=np.uint8)
    n_bytes = lab_streams.encode_sections(rows, alphabet, ARITHMETIC_INCREMENT, _MODEL_LIMIT, out)
    return out[:n_bytes].tobytes()


def _huffman_encode(symbols: np.ndarray, alphabet: int) -> bytes:
    """Static canonical Huffman: a flag bit, the code lengths of the used symbols, then the codes.
    Flag 0 means fixed-length codes instead, used when the table would make the section longer
    (so the Huffman stage never lengthens the code, seed 002 §7.4)."""
    from comparisons.params.bits import BitWriter
    from comparisons.params.entropy import CanonicalHuffman, huffman_code_lengths
    lengths = huffman_code_lengths(np.bincount(symbols, minlength=alphabet), max_length=24)
    index_bits = max(int(alphabet - 1).bit_length(), 1)
    used = [s for s, n in enumerate(lengths) if n]
    coded_bits = (index_bits + 1) + len(used) * (index_bits + 5) + int(np.sum(np.asarray(lengths)[symbols]))
    writer = BitWriter()
    if coded_bits >= _fixed_width(alphabet) * len(symbols):
        writer.write(0, 1)
        for symbol in symbols.tolist():
            writer.write(symbol, _fixed_width(alphabet))
        return writer.getvalue()
    writer.write(1, 1)
    writer.write(len(used), index_bits + 1)
    for symbol in used:
        writer.write(symbol, index_bits)
        writer.write(lengths[symbol], 5)
    code = CanonicalHuffman(lengths)
    for symbol in symbols.tolist():
        code.encode(writer, symbol)
    return writer.getvalue()


def _huffman_decode(data: bytes, count: int, alphabet: int) -> np.ndarray:
    from comparisons.params.bits import BitReader
    from comparisons.params.entropy import CanonicalHuffman
    reader = BitReader(data)
    if reader.read(1) == 0:
        symbols = [reader.read(_fixed_width(alphabet)) for _ in range(count)]
    else:
        index_bits = max(int(alphabet - 1).bit_length(), 1)
        lengths = [0] * alphabet
        for _ in range(reader.read(index_bits + 1)):
            symbol = reader.read(index_bits)
            if symbol >= alphabet:
                raise SigncastError("corrupt Huffman section: symbol outside the alphabet")
            lengths[symbol] = reader.read(5)
        code = CanonicalHuffman(lengths)
        symbols = [code.decode(reader) for _ in range(count)]
    if (reader.pos + 7) // 8 != len(data):
        raise SigncastError("corrupt Huffman section: data does not end where the symbols do")
    return np.asarray(symbols, dtype=np.int64)


_STAGES: dict[str, EntropyStage] = {
    "fixed": EntropyStage("fixed", 0, _fixed_encode, _fixed_decode),
    "arithmetic": EntropyStage("arithmetic", 1, _arithmetic_encode, _arithmetic_decode),
    "huffman": EntropyStage("huffman", 2, _huffman_encode, _huffman_decode),
}
STAGE_NAMES = tuple(_STAGES)
DEFAULT_STAGE = "arithmetic"


def entropy_stage(name: str) -> EntropyStage:
    if name not in _STAGES:
        raise SigncastError(f"unknown entropy stage {name!r}; choose from {', '.join(_STAGES)}")
    return _STAGES[name]


def check_size(n_frames: int, n_channels: int, what: str) -> None:
    """SigncastError unless 0 < n_frames <= MAX_FRAMES, n_channels > 0 and n_frames x n_channels <= MAX_VALUES."""
    if not (0 < n_frames <= MAX_FRAMES and 0 < n_channels and n_frames * n_channels <= MAX_VALUES):
        raise SigncastError(f"{what}: {n_frames} frames x {n_channels} channels is outside the coded-motion "
                            f"limits ({MAX_FRAMES} frames, {MAX_VALUES} frames x channels)")


def _stage_by_id(stage_id: int) -> EntropyStage:
    for stage in _STAGES.values():
        if stage.stage_id == stage_id:
            return stage
    raise SigncastError(f"corrupt motion stream: unknown entropy stage id {stage_id}")


# ---------------------------------------------------------------- bit packing

def pack_bits(values: np.ndarray, widths: np.ndarray) -> bytes:
    """Non-negative integers `values` (n,) written MSB first in `widths` (n,) bits each (<= 57)."""
    values = np.asarray(values, dtype=np.int64)
    widths = np.asarray(widths, dtype=np.int64)
    if len(values) == 0 or widths.sum() == 0:
        return b""
    if np.any(values < 0) or np.any(widths > 57) or np.any(values >> widths != 0):
        raise ValueError("value does not fit its bit width (at most 57)")
    max_width = int(widths.max())
    shifts = np.arange(max_width - 1, -1, -1)
    bits = (values[:, None] >> shifts[None, :]) & 1
    keep = shifts[None, :] < widths[:, None]
    return np.packbits(bits[keep].astype(np.uint8)).tobytes()


def unpack_bits(data: bytes, widths: np.ndarray) -> np.ndarray:
    """Inverse of pack_bits for widths <= 57: integers (n,) int64. Memory is a few int64 per value,
    whatever the widths (no (n, max width) bit grid: one wide value among millions must not cost GBs)."""
    widths = np.asarray(widths, dtype=np.int64)
    total = int(widths.sum())
    if (total + 7) // 8 != len(data):
        raise SigncastError("corrupt motion stream: raw bit section has the wrong length")
    if np.any(widths > 57):
        raise ValueError("unpack_bits reads at most 57 bits per value")
    starts = np.cumsum(widths) - widths
    padded = np.frombuffer(bytes(data) + bytes(8), dtype=np.uint8)
    first = starts >> 3
    window = np.zeros(len(widths), dtype=np.uint64)  # the 8 bytes holding each value, big-endian
    for k in range(8):
        window = (window << np.uint64(8)) | padded[first + k]
    aligned = window << (starts & 7).astype(np.uint64)
    values = aligned >> np.maximum(64 - widths, 0).astype(np.uint64)
    return np.where(widths > 0, values, 0).astype(np.int64)


def magnitude_classes(values: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Signed integers -> (class, mantissa, mantissa width), JPEG style.

    class = bit length of |v| (0 for v = 0); the mantissa holds the sign and the bits of |v| below
    its leading one, so it takes `class` bits. The classes go through the entropy stage, the
    mantissas are sent raw."""
    values = np.asarray(values, dtype=np.int64)
    magnitude = np.abs(values)
    nonzero = magnitude > 0
    classes = np.frexp(magnitude.astype(np.float64))[1].astype(np.int64)  # bit length, exact below 2**53
    if np.any(classes > _MAX_MAGNITUDE_CLASS):
        raise ValueError("integer too large for the magnitude-class code")
    sign = (values < 0).astype(np.int64)
    low = magnitude - np.where(nonzero, np.left_shift(1, np.maximum(classes - 1, 0)), 0)
    mantissa = np.where(nonzero, (sign << np.maximum(classes - 1, 0)) | low, 0)
    return classes, mantissa, classes.copy()


def from_magnitude_classes(classes: np.ndarray, mantissa: np.ndarray) -> np.ndarray:
    classes = np.asarray(classes, dtype=np.int64)
    mantissa = np.asarray(mantissa, dtype=np.int64)
    nonzero = classes > 0
    top = np.maximum(classes - 1, 0)
    sign = np.where(nonzero, mantissa >> top, 0)
    low = mantissa & (np.left_shift(1, top) - 1)
    magnitude = np.where(nonzero, np.left_shift(1, top) + low, 0)
    return np.where(sign == 1, -magnitude, magnitude)


# ---------------------------------------------------------------- varints

def _varint(value: int) -> bytes:
    if value < 0:
        raise ValueError("varint must be non-negative")
    out = bytearray()
    while True:
        byte = value & 0x7F
        value >>= 7
        if value:
            out.append(byte | 0x80)
        else:
            out.append(byte)
            return bytes(out)


# ---------------------------------------------------------------- writer / reader

@dataclass(frozen=True)
class StreamInfo:
    """What the fixed header says: coder id, q, frames T, DOFs D, fps."""
    coder_id: int
    q: int
    n_frames: int
    n_dofs: int
    fps: float


class StreamWriter:
    """Builds one coded motion; sections are written in the order the decoder reads them."""

    def __init__(self, coder_id: int, q: int, n_frames: int, n_dofs: int, fps: float, stage: str | None = None):
        self.stage = entropy_stage(stage or DEFAULT_STAGE)
        if not (0 <= q < 256):
            raise SigncastError(f"quality index {q} out of range 0..255")
        if n_dofs >= 2**16:
            raise SigncastError(f"cannot code {n_dofs} DOFs (at most {2**16 - 1})")
        check_size(n_frames, n_dofs, "cannot code")
        if not 0.001 <= fps <= MAX_FPS:
            raise SigncastError(f"cannot code motion at {fps} fps (0.001 to {MAX_FPS:g})")
        self.parts = [_HEADER.pack(MAGIC, coder_id, self.stage.stage_id, q, n_frames, n_dofs,
                                   int(round(fps * 1000)))]

    def header(self, payload: bytes) -> None:
        self.parts += [b"H", _varint(len(payload)), payload]

    def symbols(self, symbols: np.ndarray, alphabet: int) -> None:
        symbols = np.asarray(symbols, dtype=np.int64).ravel()
        if alphabet < 1 or (len(symbols) and (symbols.min() < 0 or symbols.max() >= alphabet)):
            raise ValueError(f"symbols outside alphabet of {alphabet}")
        if len(symbols) and _compiled_sections(self.stage, alphabet):
            self.parts.append(_encode_sections(symbols[None], alphabet))
            return
        data = self.stage.encode(symbols, alphabet) if len(symbols) else b""
        self.parts += [b"S", _varint(alphabet), _varint(len(symbols)), _varint(len(data)), data]

    def symbol_rows(self, rows: np.ndarray, alphabet: int) -> None:
        """Each row of rows (n, count) as its own symbol section (own adaptive model): the bytes of n
        symbols() calls, in one compiled call for the arithmetic stage."""
        rows = np.ascontiguousarray(rows, dtype=np.int64)
        if rows.ndim != 2:
            raise ValueError("symbol rows must be a 2-D array")
        if rows.size and (alphabet < 1 or rows.min() < 0 or rows.max() >= alphabet):
            raise ValueError(f"symbols outside alphabet of {alphabet}")
        if rows.size and _compiled_sections(self.stage, alphabet):
            self.parts.append(_encode_sections(rows, alphabet))
            return
        for row in rows:
            self.symbols(row, alphabet)

    def raw(self, values: np.ndarray, widths: np.ndarray) -> None:
        values = np.asarray(values, dtype=np.int64).ravel()
        data = pack_bits(values, np.asarray(widths, dtype=np.int64).ravel())
        self.parts += [b"R", _varint(len(values)), _varint(len(data)), data]

    def signed(self, values: np.ndarray) -> None:
        """Signed integers as entropy-coded magnitude classes plus raw mantissas (magnitude_classes, pack_bits,
        in one compiled pass)."""
        values = np.ascontiguousarray(np.asarray(values).ravel(), dtype=np.int64)
        classes = np.empty(len(values), dtype=np.int64)
        packed = np.zeros((len(values) * _MAX_MAGNITUDE_CLASS + 7) // 8, dtype=np.uint8)
        n_bytes = lab_streams.signed_to_bytes(values, _MAX_MAGNITUDE_CLASS, classes, packed)
        if n_bytes < 0:
            raise ValueError("integer too large for the magnitude-class code")
        self.symbols(classes, _MAX_MAGNITUDE_CLASS + 1)
        self.parts += [b"R", _varint(len(values)), _varint(n_bytes), packed[:n_bytes].tobytes()]

    def context_coded(self, coeffs: np.ndarray) -> None:
        """Wavelet coefficients (D, n_blocks, 16) int64 as one b"C" section (comparisons/lab/context.py: binarised,
        context-modelled binary range coding; the section's own models, whatever the entropy stage)."""
        coeffs = np.ascontiguousarray(coeffs, dtype=np.int64)
        if coeffs.ndim != 3 or coeffs.shape[2] != lab_context.BLOCK:
            raise ValueError("context-coded coefficients must be (D, n_blocks, 16)")
        out = np.zeros(lab_context.payload_capacity(coeffs.size), dtype=np.uint8)
        n_bytes = lab_context.encode(coeffs, out)
        if n_bytes > len(out):  # a noise-like input: code again into the size the first pass measured
            out = np.zeros(n_bytes, dtype=np.uint8)
            n_bytes = lab_context.encode(coeffs, out)
        if n_bytes < 0:
            raise ValueError(f"coefficient too large for the context coder (|v| < 2^{lab_context.MAX_CLASS})")
        self.parts += [b"C", _varint(coeffs.size), _varint(n_bytes), out[:n_bytes].tobytes()]

    def finish(self) -> bytes:
        body = b"".join(self.parts)
        return body + struct.pack("<I", zlib.crc32(body))


class StreamReader:
    """Reads what StreamWriter wrote, checking lengths and the CRC; raises SigncastError on damage."""

    def __init__(self, data: bytes, coder_id: int, coder_name: str):
        data = bytes(data)
        self.name = coder_name
        if len(data) < _HEADER.size + 4:
            raise SigncastError(f"corrupt {coder_name} stream: truncated ({len(data)} bytes)")
        body, (crc,) = data[:-4], struct.unpack("<I", data[-4:])
        if zlib.crc32(body) != crc:
            raise SigncastError(f"corrupt {coder_name} stream: checksum mismatch (damaged or truncated)")
        magic, cid, stage_id, q, n_frames, n_dofs, fps_milli = _HEADER.unpack_from(body)
        if magic != MAGIC:
            raise SigncastError(f"not a signcast motion stream (magic {magic!r})")
        if cid != coder_id:
            raise SigncastError(f"{coder_name} decoder got a stream of coder id {cid}")
        self.stage = _stage_by_id(stage_id)
        if not 1 <= fps_milli <= 1000 * MAX_FPS:
            raise SigncastError(f"corrupt {coder_name} stream: impossible header (frame rate {fps_milli / 1000} fps)")
        check_size(n_frames, n_dofs, f"corrupt {coder_name} stream: impossible header")
        self.info = StreamInfo(cid, q, n_frames, n_dofs, fps_milli / 1000.0)
        self.body = body
        self.array = np.frombuffer(body, dtype=np.uint8)
        self.pos = _HEADER.size

    def _fail(self, what: str) -> SigncastError:
        return SigncastError(f"corrupt {self.name} stream: {what}")

    def _varint(self) -> int:
        value, shift = 0, 0
        while True:
            if self.pos >= len(self.body) or shift > 63:
                raise self._fail("bad length field")
            byte = self.body[self.pos]
            self.pos += 1
            value |= (byte & 0x7F) << shift
            shift += 7
            if not byte & 0x80:
                return value

    def _tag(self, tag: bytes) -> None:
        if self.body[self.pos:self.pos + 1] != tag:
            raise self._fail(f"expected section {tag!r}")
        self.pos += 1

    def _take(self, n: int) -> bytes:
        if self.pos + n > len(self.body):
            raise self._fail("section runs past the end")
        chunk = self.body[self.pos:self.pos + n]
        self.pos += n
        return chunk

    def header(self) -> bytes:
        self._tag(b"H")
        return self._take(self._varint())

    def symbols(self, alphabet: int, count: int, *, at_most: bool = False) -> np.ndarray:
        """The next symbol section: (count,) int64 in [0, alphabet); with `at_most`, any length up to `count`
        (the caller's bound from the header). A count field outside that is rejected before decoding."""
        self._tag(b"S")
        got_alphabet, got_count = self._varint(), self._varint()
        if got_alphabet != alphabet or got_count > count or (got_count != count and not at_most):
            raise self._fail(f"symbol section does not match the coder's layout (alphabet {got_alphabet}, "
                             f"{got_count} symbols where {'at most ' if at_most else ''}{count} fit)")
        data = self._take(self._varint())
        if got_count == 0:
            return np.zeros(0, dtype=np.int64)
        if _compiled_sections(self.stage, alphabet):
            symbols = np.empty(got_count, dtype=np.int64)
            payload = np.frombuffer(data, dtype=np.uint8)
            if lab_streams.decode_payload(payload, alphabet, ARITHMETIC_INCREMENT, _MODEL_LIMIT, _MAX_OVERRUN,
                                          symbols) == 0:
                return symbols
            # not accepted: the checking decoder below says what is wrong
        try:
            symbols = np.asarray(self.stage.decode(data, got_count, alphabet), dtype=np.int64)
        except SigncastError:
            raise
        except Exception as error:  # a damaged entropy payload must not escape as a traceback
            raise self._fail(f"entropy payload undecodable ({error})") from None
        if len(symbols) != got_count or symbols.min() < 0 or symbols.max() >= alphabet:
            raise self._fail("symbols out of range")
        return symbols

    def symbol_rows(self, alphabet: int, n_rows: int, count: int) -> np.ndarray:
        """n_rows sections of exactly `count` symbols each, as StreamWriter.symbol_rows wrote them: (n_rows, count)."""
        if n_rows and count and _compiled_sections(self.stage, alphabet):
            rows = np.empty((n_rows, count), dtype=np.int64)
            end = lab_streams.decode_sections(self.array, self.pos, alphabet, ARITHMETIC_INCREMENT, _MODEL_LIMIT,
                                              _MAX_OVERRUN, rows)
            if end >= 0:
                self.pos = end
                return rows
            # not accepted: re-read section by section, which says what is wrong
        return np.array([self.symbols(alphabet, count) for _ in range(n_rows)], dtype=np.int64).reshape(n_rows, count)

    def raw(self, widths: np.ndarray) -> np.ndarray:
        self._tag(b"R")
        count = self._varint()
        widths = np.asarray(widths, dtype=np.int64).ravel()
        if count != len(widths):
            raise self._fail("raw section does not match the coder's layout")
        return unpack_bits(self._take(self._varint()), widths)

    def signed(self, count: int, *, at_most: bool = False) -> np.ndarray:
        """Signed integers written by StreamWriter.signed: (count,) int64, or up to `count` with `at_most`."""
        classes = self.symbols(_MAX_MAGNITUDE_CLASS + 1, count, at_most=at_most)
        start = self.pos
        self._tag(b"R")
        if self._varint() == len(classes):
            packed = np.frombuffer(self._take(self._varint()), dtype=np.uint8)
            values = np.empty(len(classes), dtype=np.int64)
            if lab_streams.signed_from_bytes(classes, packed, values) == 0:
                return values
        self.pos = start  # not accepted: the checking reader says what is wrong
        mantissa = self.raw(classes)
        return from_magnitude_classes(classes, mantissa)

    def context_coded(self, n_dofs: int, n_blocks: int) -> np.ndarray:
        """The b"C" section StreamWriter.context_coded wrote: (n_dofs, n_blocks, 16) int64; the count must be
        exactly that (the caller derives it from the header, so the allocation is bounded)."""
        self._tag(b"C")
        count = self._varint()
        if count != n_dofs * n_blocks * lab_context.BLOCK:
            raise self._fail(f"context-coded section holds {count} coefficients where "
                             f"{n_dofs * n_blocks * lab_context.BLOCK} fit")
        payload = np.frombuffer(self._take(self._varint()), dtype=np.uint8).copy()  # the kernel's buffer is writable
        coeffs = np.zeros((n_dofs, n_blocks, lab_context.BLOCK), dtype=np.int64)
        if lab_context.decode(payload, coeffs) != 0:
            raise self._fail("context-coded payload undecodable (damaged or truncated)")
        return coeffs

    def finish(self) -> None:
        if self.pos != len(self.body):
            raise self._fail(f"{len(self.body) - self.pos} unexpected bytes after the last section")


# ---------------------------------------------------------------- compact framing (one payload, one CRC)
# A second container layout, for coders whose whole stream is one self-delimiting payload (ContextWaveletCoder,
# `framing = "compact"`; comparisons/lab/codecs.LabCodec writes it instead of its SCL1 wrapper around SCM1). The
# SCL1 + SCM1 framing (two magics, fixed-width header, raw 183-bit DOF mask, section header, two CRCs) takes ~58
# bytes (docs/motion-lab.md: its share of short clips); this one is 10 bytes plus what the payload spends:
#
#     magic "Sc" | coder id (u8) | q (u8) | varint(T) | varint(fps code) | payload | CRC-32 of everything before
#
# fps code (chosen here): 2 fps when fps is a whole number, else 2 round(1000 fps) + 1, so 10 and 25 fps take one
# byte. The payload runs to the CRC: the coder's own entropy coder says where it ends, and the coder checks it.
# Integrity: CRC-32 (ISO 3309 / ITU-T V.42 polynomial, zlib.crc32) as in the SCM1 layout, kept rather than a CRC-16:
# 2 more bytes per clip buy a 1-in-4e9 rather than 1-in-65536 chance that a damaged stream decodes to wrong motion
# unnoticed, and the payload's own end check catches most damage only when it is in the range coder's last bytes.
# Bounds: T <= MAX_FRAMES, 0.001 <= fps <= MAX_FPS, varints of at most 9 bytes, all before anything is allocated.

COMPACT_MAGIC = b"Sc"
_COMPACT_MIN = len(COMPACT_MAGIC) + 2 + 1 + 1 + 4
_MAX_VARINT_BYTES = 9


@dataclass(frozen=True)
class CompactStream:
    """A compact stream's header and payload: q (operating point index), n_frames T, fps, payload bytes."""
    q: int
    n_frames: int
    fps: float
    payload: bytes


def fps_code(fps: float) -> int:
    """The compact header's frame-rate code (see above); SigncastError outside 0.001 .. MAX_FPS."""
    if not (np.isfinite(fps) and 0.001 <= fps <= MAX_FPS):
        raise SigncastError(f"cannot code motion at {fps} fps (0.001 to {MAX_FPS:g})")
    milli = round(fps * 1000)
    return 2 * (milli // 1000) if milli % 1000 == 0 else 2 * milli + 1


def _fps_of_code(code: int) -> float | None:
    milli = 1000 * (code >> 1) if code % 2 == 0 else code >> 1
    return milli / 1000.0 if 1 <= milli <= 1000 * MAX_FPS else None


def write_compact(coder_id: int, q: int, n_frames: int, fps: float, payload: bytes, model_tag: int = 0) -> bytes:
    """The compact stream of a payload (the coder's whole coded clip); model_tag (uint32) identifies the tables
    both ends must share: the CRC-32 starts from it."""
    if not (0 <= coder_id < 256 and 0 <= q < 256):
        raise SigncastError(f"coder id {coder_id} / quality index {q} out of range 0..255")
    if not 0 < n_frames <= MAX_FRAMES:
        raise SigncastError(f"cannot code {n_frames} frames (1 to {MAX_FRAMES})")
    body = COMPACT_MAGIC + bytes([coder_id, q]) + _varint(n_frames) + _varint(fps_code(fps)) + bytes(payload)
    return body + struct.pack("<I", zlib.crc32(body, model_tag))


def read_compact(data: bytes, coder_id: int, coder_name: str, model_tag: int = 0) -> CompactStream:
    """Checks magic, CRC (started from model_tag, as write_compact), coder id and header bounds of a compact
    stream; SigncastError on any damage, and on a stream coded with other tables."""
    data = bytes(data)
    if len(data) < _COMPACT_MIN or data[:len(COMPACT_MAGIC)] != COMPACT_MAGIC:
        raise SigncastError(f"not a compact {coder_name} stream (bad magic or truncated, {len(data)} bytes)")
    body, (crc,) = data[:-4], struct.unpack("<I", data[-4:])
    if zlib.crc32(body, model_tag) != crc:
        other = ", or coded with other trained tables" if model_tag else ""
        raise SigncastError(f"corrupt {coder_name} stream: checksum mismatch (damaged or truncated{other})")
    pos = len(COMPACT_MAGIC)
    if body[pos] != coder_id:
        raise SigncastError(f"{coder_name} decoder got a stream of coder id {body[pos]}")
    q = body[pos + 1]
    pos += 2
    fields = []
    for _ in range(2):
        value, shift = 0, 0
        while True:
            if pos >= len(body) or shift >= 7 * _MAX_VARINT_BYTES:
                raise SigncastError(f"corrupt {coder_name} stream: bad header field")
            byte = body[pos]
            pos += 1
            value |= (byte & 0x7F) << shift
            shift += 7
            if not byte & 0x80:
                break
        fields.append(value)
    n_frames, code = fields
    fps = _fps_of_code(code)
    if not 0 < n_frames <= MAX_FRAMES or fps is None:
        raise SigncastError(f"corrupt {coder_name} stream: impossible header ({n_frames} frames, fps code {code})")
    return CompactStream(q, n_frames, fps, body[pos:])

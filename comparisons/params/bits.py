"""Bit-level writer and reader for the FBA and BBA streams, with MPEG start codes.

Start codes are the MPEG-4 32-bit, byte-aligned codes 0x000001XX (facts: mpeg4-facts.md §2.1,
visage `FBAEncoder.cpp`). Before a start code the writer emits MPEG `next_start_code` stuffing:
one 0 bit then 1 bits up to the byte boundary, or 0111 1111 when already aligned. Inside coded
data the writer inserts a 1 bit after 22 consecutive 0 bits (`bit_in_psc_layer`, mpeg4-facts.md
§2.5) so a start code (23 zeros then a 1) can never be emulated; the reader drops those bits.

Speed: the bit loops are Numba-compiled kernels (comparisons/params/arithmetic.py). The writer keeps its bytes in a zero-filled uint8 buffer and its state
(bits written, current zero run) in an int64 array, so the arithmetic coder's kernels
(comparisons/params/entropy.py) write into it directly; the reader likewise keeps (bit position, zero run,
overrun) in an int64 array.
"""
from __future__ import annotations

import numpy as np

from comparisons.params import arithmetic as kc
from media.errors import SigncastError

START_CODE_PREFIX = b"\x00\x00\x01"
MAX_ZERO_RUN = kc.MAX_ZERO_RUN
_POS, _ZERO_RUN, _OVERRUN = 0, 1, 2        # BitReader state; BitWriter state is (bits written, zero run)


class BitWriter:
    """Accumulates bits MSB-first; `getvalue()` returns the bytes (last byte zero-padded)."""

    def __init__(self) -> None:
        self.buffer = np.zeros(256, dtype=np.uint8)
        self.state = np.zeros(2, dtype=np.int64)        # bits written, zero run

    @property
    def n_bits(self) -> int:
        return int(self.state[0])

    def reserve(self, n_bits: int) -> None:
        """Room for n_bits more data bits (and their emulation-prevention bits)."""
        needed = (int(self.state[0]) + n_bits + n_bits // MAX_ZERO_RUN + 16) // 8 + 1
        if needed > len(self.buffer):
            grown = np.zeros(max(needed, 2 * len(self.buffer)), dtype=np.uint8)
            grown[:len(self.buffer)] = self.buffer
            self.buffer = grown

    def write_bit(self, bit: int) -> None:
        """One data bit, with start-code emulation prevention."""
        self.reserve(1)
        kc.put_bit(self.buffer, self.state, 1 if bit else 0)

    def write(self, value: int, n_bits: int) -> None:
        """Unsigned `value` in `n_bits` bits, MSB first."""
        if n_bits == 0:
            return
        value = int(value)
        if value < 0 or value >> n_bits:
            raise SigncastError(f"value {value} does not fit in {n_bits} bits")
        self.reserve(n_bits)
        while n_bits > 62:                               # the kernel works on int64
            n_bits -= 62
            kc.put_bits(self.buffer, self.state, value >> n_bits, 62)
            value &= (1 << n_bits) - 1
        kc.put_bits(self.buffer, self.state, value, n_bits)

    def write_signed(self, value: int, n_bits: int) -> None:
        """Two's complement `value` in `n_bits` bits."""
        low, high = -(1 << (n_bits - 1)), (1 << (n_bits - 1)) - 1
        if not low <= value <= high:
            raise SigncastError(f"value {value} does not fit in {n_bits} signed bits")
        self.write(value & ((1 << n_bits) - 1), n_bits)

    def align_for_start_code(self) -> None:
        """MPEG next_start_code(): a 0 then 1s to the byte boundary (0111 1111 when aligned)."""
        self.reserve(8)
        kc.align(self.buffer, self.state)

    def start_code(self, code: int) -> None:
        """Stuffing, then the byte-aligned 32-bit start code 0x000001<code>."""
        self.align_for_start_code()
        self.reserve(32)
        byte = int(self.state[0]) >> 3
        self.buffer[byte:byte + 4] = np.frombuffer(START_CODE_PREFIX + bytes([code]), dtype=np.uint8)
        self.state[0] += 32
        self.state[1] = 0

    def getvalue(self) -> bytes:
        return self.buffer[:(int(self.state[0]) + 7) >> 3].tobytes()


class BitReader:
    """Reads what BitWriter wrote. Reading past the end raises SigncastError, except in
    `lookahead` reads (the arithmetic decoder's register fill), which return 0 bits there."""

    def __init__(self, data: bytes, start_byte: int = 0, end_byte: int | None = None) -> None:
        self.data = bytes(data)
        self.array = np.frombuffer(self.data, dtype=np.uint8)
        self.end_bit = 8 * (len(self.data) if end_byte is None else end_byte)
        self.registers = np.array([8 * start_byte, 0, 0], dtype=np.int64)   # position, zero run, overrun

    @property
    def pos(self) -> int:
        return int(self.registers[_POS])

    @pos.setter
    def pos(self, value: int) -> None:
        self.registers[_POS] = value

    @property
    def overrun(self) -> int:
        return int(self.registers[_OVERRUN])

    @property
    def state(self) -> tuple[int, int, int]:
        return tuple(int(v) for v in self.registers)

    @state.setter
    def state(self, value: tuple[int, int, int]) -> None:
        self.registers[:] = value

    def read_bit(self, lookahead: bool = False) -> int:
        bit = kc.get_bit(self.array, self.end_bit, self.registers, lookahead)
        if bit < 0:
            raise SigncastError("truncated stream: it ends inside a field")
        return bit

    def read(self, n_bits: int) -> int:
        value = 0
        while n_bits > 62:
            value = (value << 62) | self._read_bits(62)
            n_bits -= 62
        return (value << n_bits) | self._read_bits(n_bits)

    def _read_bits(self, n_bits: int) -> int:
        value = kc.get_bits(self.array, self.end_bit, self.registers, n_bits)
        if value < 0:
            raise SigncastError("truncated stream: it ends inside a field")
        return value

    def read_signed(self, n_bits: int) -> int:
        value = self.read(n_bits)
        return value - (1 << n_bits) if value >> (n_bits - 1) else value

    def at_start_code(self) -> bool:
        """True when the stuffing of next_start_code() and a start code prefix follow."""
        pos = self.pos
        if pos >= self.end_bit:
            return False
        n_stuff = 8 - (pos & 7)
        stuffing = self.data[pos >> 3] & ((1 << n_stuff) - 1)
        if stuffing != (1 << (n_stuff - 1)) - 1:
            return False
        byte = (pos + n_stuff) >> 3
        return self.data[byte:byte + 3] == START_CODE_PREFIX and byte + 4 <= self.end_bit // 8

    def read_start_code(self) -> int:
        """Consume stuffing and a start code; returns its last byte. SigncastError if absent."""
        if not self.at_start_code():
            if self.pos >= self.end_bit:
                raise SigncastError("truncated stream: a start code is missing at the end")
            raise SigncastError(f"corrupt stream: expected a start code at bit {self.pos}")
        byte = (self.pos >> 3) + 1
        self.registers[_POS] = 8 * (byte + 4)
        self.registers[_ZERO_RUN] = 0
        return self.data[byte + 3]


def find_start_codes(data: bytes, start: int = 0) -> list[tuple[int, int]]:
    """(byte offset of the 00 00 01 prefix, code byte) of every byte-aligned start code."""
    found = []
    position = data.find(START_CODE_PREFIX, start)
    while position >= 0 and position + 3 < len(data):
        found.append((position, data[position + 3]))
        position = data.find(START_CODE_PREFIX, position + 3)
    return found


def crc8_bits(data: bytes, start_bit: int, end_bit: int) -> int:
    """CRC-8 (polynomial x^8 + x^2 + x + 1, 0x07, initial 0) of the raw bits [start_bit, end_bit)."""
    if start_bit < 0 or end_bit > 8 * len(data):
        raise SigncastError(f"CRC range [{start_bit}, {end_bit}) outside {len(data)} bytes")
    return int(kc.crc8(np.frombuffer(bytes(data), dtype=np.uint8), start_bit, end_bit))

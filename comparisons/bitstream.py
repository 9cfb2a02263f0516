"""Bit-level writer and reader for the FBA and BBA streams, with MPEG start codes.

Start codes are the MPEG-4 32-bit, byte-aligned codes 0x000001XX (facts: mpeg4-facts.md §2.1,
visage `FBAEncoder.cpp`). Before a start code the writer emits MPEG `next_start_code` stuffing:
one 0 bit then 1 bits up to the byte boundary, or 0111 1111 when already aligned. Inside coded
data the writer inserts a 1 bit after 22 consecutive 0 bits (`bit_in_psc_layer`, mpeg4-facts.md
§2.5) so a start code (23 zeros then a 1) can never be emulated; the reader drops those bits.
"""
from __future__ import annotations

from media.errors import SigncastError

START_CODE_PREFIX = b"\x00\x00\x01"
MAX_ZERO_RUN = 22


class BitWriter:
    """Accumulates bits MSB-first; `getvalue()` returns the bytes (last byte zero-padded)."""

    def __init__(self) -> None:
        self._bytes = bytearray()
        self._current = 0
        self._n_current = 0
        self._zero_run = 0
        self.n_bits = 0

    def _raw_bit(self, bit: int) -> None:
        self._current = (self._current << 1) | bit
        self._n_current += 1
        self.n_bits += 1
        if self._n_current == 8:
            self._bytes.append(self._current)
            self._current = 0
            self._n_current = 0

    def write_bit(self, bit: int) -> None:
        """One data bit, with start-code emulation prevention."""
        self._raw_bit(bit)
        if bit:
            self._zero_run = 0
        else:
            self._zero_run += 1
            if self._zero_run == MAX_ZERO_RUN:
                self._raw_bit(1)
                self._zero_run = 0

    def write(self, value: int, n_bits: int) -> None:
        """Unsigned `value` in `n_bits` bits, MSB first."""
        if n_bits == 0:
            return
        if value < 0 or value >> n_bits:
            raise SigncastError(f"value {value} does not fit in {n_bits} bits")
        for shift in range(n_bits - 1, -1, -1):
            self.write_bit((value >> shift) & 1)

    def write_signed(self, value: int, n_bits: int) -> None:
        """Two's complement `value` in `n_bits` bits."""
        low, high = -(1 << (n_bits - 1)), (1 << (n_bits - 1)) - 1
        if not low <= value <= high:
            raise SigncastError(f"value {value} does not fit in {n_bits} signed bits")
        self.write(value & ((1 << n_bits) - 1), n_bits)

    def align_for_start_code(self) -> None:
        """MPEG next_start_code(): a 0 then 1s to the byte boundary (0111 1111 when aligned)."""
        self._raw_bit(0)
        while self._n_current:
            self._raw_bit(1)

    def start_code(self, code: int) -> None:
        """Stuffing, then the byte-aligned 32-bit start code 0x000001<code>."""
        self.align_for_start_code()
        for byte in START_CODE_PREFIX + bytes([code]):
            for shift in range(7, -1, -1):
                self._raw_bit((byte >> shift) & 1)
        self._zero_run = 0

    def getvalue(self) -> bytes:
        if self._n_current:
            return bytes(self._bytes) + bytes([self._current << (8 - self._n_current)])
        return bytes(self._bytes)


class BitReader:
    """Reads what BitWriter wrote. Reading past the end raises SigncastError, except in
    `lookahead` reads (the arithmetic decoder's register fill), which return 0 bits there."""

    def __init__(self, data: bytes, start_byte: int = 0, end_byte: int | None = None) -> None:
        self.data = bytes(data)
        self.end_bit = 8 * (len(self.data) if end_byte is None else end_byte)
        self.pos = 8 * start_byte
        self._zero_run = 0
        self.overrun = 0

    @property
    def state(self) -> tuple[int, int, int]:
        return self.pos, self._zero_run, self.overrun

    @state.setter
    def state(self, value: tuple[int, int, int]) -> None:
        self.pos, self._zero_run, self.overrun = value

    def _raw_bit(self, lookahead: bool = False) -> int:
        if self.pos >= self.end_bit:
            if not lookahead:
                raise SigncastError("truncated stream: it ends inside a field")
            self.overrun += 1
            self.pos += 1
            return 0
        bit = (self.data[self.pos >> 3] >> (7 - (self.pos & 7))) & 1
        self.pos += 1
        return bit

    def read_bit(self, lookahead: bool = False) -> int:
        bit = self._raw_bit(lookahead)
        if bit:
            self._zero_run = 0
            return 1
        self._zero_run += 1
        if self._zero_run == MAX_ZERO_RUN:
            self._zero_run = 0
            if self.pos < self.end_bit:
                position = self.pos
                if not self._raw_bit():
                    # Not a stuffing bit: this is a start code (or damage); leave it unread.
                    self.pos = position
            elif not lookahead:
                raise SigncastError("truncated stream: it ends inside a field")
        return 0

    def read(self, n_bits: int) -> int:
        value = 0
        for _ in range(n_bits):
            value = (value << 1) | self.read_bit()
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
        stuffing = 0
        for k in range(n_stuff):
            p = pos + k
            stuffing = (stuffing << 1) | ((self.data[p >> 3] >> (7 - (p & 7))) & 1)
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
        self.pos = 8 * (byte + 4)
        self._zero_run = 0
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
    crc = 0
    for position in range(start_bit, end_bit):
        bit = (data[position >> 3] >> (7 - (position & 7))) & 1
        feedback = ((crc >> 7) & 1) ^ bit
        crc = (crc << 1) & 0xFF
        if feedback:
            crc ^= 0x07
    return crc

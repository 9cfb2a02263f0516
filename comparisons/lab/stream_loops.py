"""Numba kernels of the seed-002 container's arithmetic-coded symbol sections (comparisons/lab/streams.py
documents the format): many sections per call, so that a coder writing one section per DOF pays one
kernel call, not one model, writer and call per section.

A section is b"S" varint(alphabet) varint(count) varint(n_bytes) bytes, the bytes being the symbols
coded with a fresh adaptive model and a fresh coder (comparisons/params/arithmetic.py: encode_run,
decode_run, whose bits these kernels reuse unchanged, so the bytes are those of one
comparisons.params.entropy.encode_symbols call per section). Models start with every count 1, add
`increment` per symbol and halve above `limit` (entropy.FrequencyModel's scalars).

The decoder returns status -1 at the first thing it does not accept (tag, lengths, an undecodable
or overlong payload); the caller then re-reads those sections with its checking reader, which says
what is wrong. Compiled with cache=True: the cache does not track comparisons/params/arithmetic.py, whose
kernels are compiled into these; clear __pycache__ when their bits change.
"""
import numpy as np
from numba import njit

from comparisons.params import arithmetic as kc

TAG_SYMBOLS = 83  # b"S"
MAX_VARINT_BYTES = 8  # longer length fields go to the caller's reader (which bounds them at 63 bits)


@njit(cache=True)
def _put_varint(out: np.ndarray, pos: int, value: int) -> int:
    while True:
        byte = value & 0x7F
        value >>= 7
        if value:
            out[pos] = byte | 0x80
            pos += 1
        else:
            out[pos] = byte
            return pos + 1


@njit(cache=True)
def _model(alphabet: int, increment: int, limit: int):
    counts = np.ones(alphabet, dtype=np.int64)
    tree = np.empty(alphabet + 1, dtype=np.int64)
    for i in range(alphabet + 1):
        tree[i] = i & -i
    top = 1
    while top * 2 <= alphabet:
        top *= 2
    scalars = np.array([alphabet, top, increment, limit, alphabet], dtype=np.int64)
    return counts, tree, scalars


@njit(cache=True)
def payload_capacity(count: int) -> int:
    """Bytes the coded payload of `count` symbols can take (BitWriter.reserve's bound: coder and emulation bits)."""
    bits = 4 * kc.PRECISION * (count + 1)
    return (bits + bits // kc.MAX_ZERO_RUN + 16) // 8 + 1


@njit(cache=True)
def section_capacity(n_rows: int, count: int) -> int:
    """Bytes that n_rows sections of `count` symbols can take: payloads, tags and three varints each."""
    return n_rows * (payload_capacity(count) + 1 + 3 * 10)


@njit(cache=True)
def encode_sections(rows: np.ndarray, alphabet: int, increment: int, limit: int, out: np.ndarray) -> int:
    """rows (n, count) int64 symbols in [0, alphabet), each coded as one section into `out` (section_capacity
    bytes); returns the number of bytes written."""
    n_rows, count = rows.shape
    scratch = np.zeros(payload_capacity(count), dtype=np.uint8)
    state = np.zeros(2, dtype=np.int64)
    pos = 0
    for r in range(n_rows):
        counts, tree, scalars = _model(alphabet, increment, limit)
        state[0] = 0
        state[1] = 0
        kc.encode_run(scratch, state, counts, tree, scalars, rows[r])
        n_bytes = (state[0] + 7) >> 3
        out[pos] = TAG_SYMBOLS
        pos = _put_varint(out, pos + 1, alphabet)
        pos = _put_varint(out, pos, count)
        pos = _put_varint(out, pos, n_bytes)
        for k in range(n_bytes):
            out[pos + k] = scratch[k]
            scratch[k] = 0
        pos += n_bytes
    return pos


@njit(cache=True)
def _get_varint(data: np.ndarray, pos: int) -> tuple[int, int]:
    """(value, next position), or (-1, pos) when it runs past the data or is longer than MAX_VARINT_BYTES."""
    value, shift = 0, 0
    for _ in range(MAX_VARINT_BYTES):
        if pos >= len(data):
            return -1, pos
        byte = data[pos]
        pos += 1
        value |= np.int64(byte & 0x7F) << shift
        shift += 7
        if not byte & 0x80:
            return value, pos
    return -1, pos


@njit(cache=True)
def decode_payload(payload: np.ndarray, alphabet: int, increment: int, limit: int, max_overrun: int,
                   out: np.ndarray) -> int:
    """The len(out) symbols of one section's payload into out; 0, or -1 (see the module docstring)."""
    counts, tree, scalars = _model(alphabet, increment, limit)
    reader = np.zeros(3, dtype=np.int64)
    if kc.decode_run(payload, 8 * len(payload), reader, counts, tree, scalars, out, max_overrun) != 0:
        return -1
    return 0 if (reader[0] + 7) >> 3 == len(payload) else -1


@njit(cache=True)
def decode_sections(data: np.ndarray, pos: int, alphabet: int, increment: int, limit: int, max_overrun: int,
                    out: np.ndarray) -> int:
    """Reads out.shape[0] sections of exactly out.shape[1] symbols of `alphabet` from data[pos:] into out;
    returns the position after them, or -1 (see the module docstring)."""
    count = out.shape[1]
    for r in range(out.shape[0]):
        if pos >= len(data) or data[pos] != TAG_SYMBOLS:
            return -1
        got_alphabet, pos = _get_varint(data, pos + 1)
        got_count, pos = _get_varint(data, pos)
        n_bytes, pos = _get_varint(data, pos)
        if got_alphabet != alphabet or got_count != count or n_bytes < 0 or pos + n_bytes > len(data):
            return -1
        if decode_payload(data[pos:pos + n_bytes], alphabet, increment, limit, max_overrun, out[r]) != 0:
            return -1
        pos += n_bytes
    return pos


# ------------------------------------------------------------------ signed integers: magnitude classes + raw mantissas
# (coded_streams.magnitude_classes: class = bit length of |v|; the mantissa, `class` bits, holds the sign then the
# bits of |v| below its leading one; mantissas are packed MSB first, the last byte zero-padded)

@njit(cache=True)
def signed_to_bytes(values: np.ndarray, max_class: int, classes: np.ndarray, packed: np.ndarray) -> int:
    """Classes (n,) of values (n,) int64 into `classes` and their mantissas packed into `packed` (zero-filled,
    at least ceil(n max_class / 8) bytes); returns the packed length in bytes, or -1 when a |value| needs
    more than max_class bits."""
    bit = 0
    for i in range(len(values)):
        value = values[i]
        magnitude = -value if value < 0 else value
        if magnitude < 0:                     # -2**63
            return -1
        n_bits = 0
        while magnitude >> n_bits:
            n_bits += 1
        if n_bits > max_class:
            return -1
        classes[i] = n_bits
        if n_bits:
            mantissa = ((1 if value < 0 else 0) << (n_bits - 1)) | (magnitude - (1 << (n_bits - 1)))
            for shift in range(n_bits - 1, -1, -1):
                if (mantissa >> shift) & 1:
                    packed[bit >> 3] |= np.uint8(0x80 >> (bit & 7))
                bit += 1
    return (bit + 7) >> 3


@njit(cache=True)
def signed_from_bytes(classes: np.ndarray, packed: np.ndarray, values: np.ndarray) -> int:
    """Inverse of signed_to_bytes into values (n,); -1 when `packed` is not exactly the mantissas' bytes
    (classes must be 0..62)."""
    total = 0
    for i in range(len(classes)):
        total += classes[i]
    if (total + 7) >> 3 != len(packed):
        return -1
    bit = 0
    for i in range(len(classes)):
        n_bits = classes[i]
        mantissa = 0
        for _ in range(n_bits):
            mantissa = (mantissa << 1) | ((packed[bit >> 3] >> (7 - (bit & 7))) & 1)
            bit += 1
        if n_bits == 0:
            values[i] = 0
        else:
            top = n_bits - 1
            magnitude = (1 << top) + (mantissa & ((1 << top) - 1))
            values[i] = -magnitude if (mantissa >> top) == 1 else magnitude
    return 0

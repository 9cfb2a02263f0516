"""Binarised adaptive arithmetic coding of signed integer levels: a coder whose cost stays within a few per cent
of the zero-order empirical entropy however large the alphabet.

Why: a multi-symbol adaptive model (comparisons/entropy.FrequencyModel) must learn one count per symbol. On the FBA
predictive coder's residual levels at Q 1 (benchmarks/params.py: 12,939 levels over an alphabet of 5,451) that
learning costs +9 % over n H(p) with increment 4 and +17 % with the standard's increment 1. Binarising the level
and coding each binary decision with its own adaptive model shares what is learnt between neighbouring values, as
H.264's CABAC does for coefficient levels (ISO/IEC 14496-10 §9.3.2.3, UEGk binarisation; the scheme here is
chosen for signcast, not taken from a standard).

Binarisation of a level v, each bin coded with the arithmetic coder of comparisons/params/entropy.py:
1. significance: v != 0 (one adaptive binary model);
2. sign: v < 0 (one adaptive binary model);
3. bucket k = floor(log2 |v|), 0..MAX_BUCKET (one adaptive model over MAX_BUCKET + 1 symbols): |v| lies in
   [2^k, 2^(k+1));
4. the k bits of |v| - 2^k, most significant first: the first CONTEXT_BITS of them with adaptive binary models
   chosen by (k, the bits so far), the rest with a fixed 1/2 model (one bit each: below the top bits the
   distribution inside a bucket is nearly flat).
Every adaptive model starts from counts (1, 1, ...) and adds INCREMENT per coded bin (halving at the entropy
module's limit). The stream: the level count (32 bits), then the coded bins, then the coder's termination.

Levels must satisfy |v| < 2^(MAX_BUCKET + 1).
"""
from __future__ import annotations

import numpy as np

from comparisons.params.bits import BitReader, BitWriter
from comparisons.params.entropy import ArithmeticDecoder, ArithmeticEncoder, FrequencyModel
from media.errors import SigncastError

MAX_BUCKET = 40
CONTEXT_BITS = 2
INCREMENT = 4
MAX_LEVELS = 1 << 22           # both sides refuse more: the decoder before it allocates (32 MiB of int64)


class _Models:
    """The adaptive models of one coded sequence (significance, sign, bucket, top bits per bucket) and the fixed
    1/2 model of the remaining bits."""

    def __init__(self, increment: int) -> None:
        self.increment = increment
        self.significant = FrequencyModel(2, increment)
        self.negative = FrequencyModel(2, increment)
        self.bucket = FrequencyModel(MAX_BUCKET + 1, increment)
        self.flat = FrequencyModel(2, 0)
        self.top_bits: dict[tuple[int, int], FrequencyModel] = {}

    def bit_model(self, k: int, position: int, prefix: int) -> FrequencyModel:
        """The model of bit `position` (0 = most significant) of bucket k's offset, given the bits before it."""
        if position >= CONTEXT_BITS:
            return self.flat
        model = self.top_bits.get((k, prefix))
        if model is None:
            model = self.top_bits[(k, prefix)] = FrequencyModel(2, self.increment)
        return model


def encode_levels(levels, increment: int = INCREMENT) -> bytes:
    """Signed integer levels (n,) -> bytes: the count (32 bits), then the binarised, arithmetic-coded levels."""
    levels = np.asarray(levels).reshape(-1)
    if levels.size and not np.issubdtype(levels.dtype, np.integer):
        raise SigncastError(f"levels must be integers, got {levels.dtype}")
    if len(levels) > MAX_LEVELS:
        raise SigncastError(f"at most {MAX_LEVELS} levels in one sequence, got {len(levels)}")
    if levels.size and int(np.abs(levels.astype(np.int64)).max()) >= 1 << (MAX_BUCKET + 1):
        raise SigncastError(f"levels must lie within +-(2^{MAX_BUCKET + 1} - 1)")
    writer = BitWriter()
    writer.write(len(levels), 32)
    encoder = ArithmeticEncoder(writer)
    models = _Models(increment)
    for value in levels.tolist():
        encoder.encode(models.significant, int(value != 0))
        if value == 0:
            continue
        encoder.encode(models.negative, int(value < 0))
        magnitude = abs(value)
        k = magnitude.bit_length() - 1
        encoder.encode(models.bucket, k)
        offset, prefix = magnitude - (1 << k), 1
        for position in range(k):
            bit = (offset >> (k - 1 - position)) & 1
            encoder.encode(models.bit_model(k, position, prefix), bit)
            prefix = 2 * prefix + bit
    encoder.finish()
    return writer.getvalue()


def decode_levels(data: bytes, increment: int = INCREMENT) -> np.ndarray:
    """(n,) int64 levels of encode_levels' bytes; SigncastError on truncated, damaged or trailing data."""
    reader = BitReader(data)
    if len(data) < 4:
        raise SigncastError("truncated level sequence: no count")
    count = reader.read(32)
    if count > MAX_LEVELS:
        raise SigncastError(f"corrupt level sequence: impossible count {count} for {len(data)} bytes")
    decoder = ArithmeticDecoder(reader)
    models = _Models(increment)
    levels = np.zeros(count, dtype=np.int64)
    for i in range(count):
        if not decoder.decode(models.significant):
            continue
        negative = decoder.decode(models.negative)
        k = decoder.decode(models.bucket)
        offset, prefix = 0, 1
        for position in range(k):
            bit = decoder.decode(models.bit_model(k, position, prefix))
            offset, prefix = 2 * offset + bit, 2 * prefix + bit
        magnitude = (1 << k) + offset
        levels[i] = -magnitude if negative else magnitude
    decoder.finish()
    if (reader.pos + 7) // 8 != len(data):
        raise SigncastError(f"corrupt level sequence: coded data ends at byte {(reader.pos + 7) // 8} of {len(data)}")
    return levels

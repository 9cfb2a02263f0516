"""Lossless binary shape coding in the manner of MPEG-4 Visual (context-based arithmetic encoding, CAE).

A mask sequence (T, H, W) bool is cut into 16x16 binary alpha blocks (BABs) on a grid anchored at the
frame's top-left corner. Each frame codes its bounding box in BAB units, then every BAB inside it with a
mode: all transparent, all opaque, intra CAE (10-pixel causal template of the current frame, as MPEG-4's
intra context), and in predicted frames also inter CAE (4 causal pixels + 5 pixels of the motion-compensated
previous shape, as MPEG-4's inter context) and "copy" (the motion-compensated previous shape is exact:
MPEG-4's "no update" mode). Shape motion vectors are integer-pel, predicted from the left / top / top-right
BABs and coded as differences. Pixels to the right of the current BAB that are not decoded yet are read as
the BAB's last decoded column (border replication).

Departures from the standard, stated: (1) probabilities are adaptive counts per context, reset at every
intra frame (every `gop` frames) to a prior: in version 4 the pixel contexts' P(0) trained on rendered masks
(comparisons/video/shape_priors.py, tools/make_shape_priors.py) at TRAINED_WEIGHT counts, elsewhere (and in
versions 2-3) a hand-made prior skewed towards "the pixel repeats its neighbours / its motion-compensated
pixel"; the standard's fixed tables are not reproduced here;
(2) modes and motion-vector differences are binarised and coded by the same arithmetic coder instead of
VLCs; (3) one arithmetic codeword covers the whole sequence; (4) no transposed scan; lossy shape is the alpha
threshold, an encoder's choice under a per-frame budget of wrong pixels (encode_shape's shape_error) that the
decoder needs no word of, and in version 5 also size conversion (below); (5) every predicted frame refers to
the previous frame in display order.

Size conversion (version 5, lossy streams only): every intra / inter CAE BAB codes its conversion ratio (CR 1,
1/2, 1/4: two adaptive binary decisions, context = intra or inter x the left BAB's CR) before its pixels. At
CR 1/2 (1/4) the BAB is reduced to 8x8 (4x4), a cell opaque when at least 2 of its 4 (8 of its 16) pixels are,
as the standard's downsampling; CAE codes the reduced BAB with the full-size templates over a reduced
neighbourhood (the decoded canvas above and left reduced the same way; in inter mode the motion-compensated
previous shape reduced the same way) in contexts of their own (CTX_INTRA_LOW, CTX_INTER_LOW, hand-made
prior), and both ends upsample it back in 2x stages (comparisons/video/shape_cae.py _upsample: a weighted sum
of the 2x2 reduced pixels towards the output pixel's quadrant, own x 4, others x 2, and the 8 around them x 1,
opaque above 9 of 18, ties to the own pixel; the ring above and left from the decoded canvas, right and below
replicated). This upsampler is this coder's own, NOT the standard's (its threshold table
grgchInterpolationFilterTh is not reproduced). The encoder tries CR 1/4, then 1/2, and takes the first whose
upsampled BAB passes the alpha threshold test within the frame's budget and whose wrong pixels x CR_LAMBDA
stay within the bits it is estimated to save (the budget is shared with the uniform / copy decisions).

Stream layout (versions 4 and 5): a 22-byte header (magic, version, width, height, frames, gop, payload length, then a
CRC-32 of the 18 header bytes before it and of the payload) and the arithmetic-coded payload. Each frame codes a
presence flag, then its box: in version 3 a predicted frame after a present one first codes whether its box is
the previous frame's (adaptive context), and only otherwise the four raw fields; version 2 (still read and, on
request, written, as is 3) always codes them raw. Version 4 is version 3 with the trained pixel priors. Version 1 streams (CRC of the payload alone) are rejected. Masks are at most MAX_SIDE pixels wide and high and
frames x height x width <= MAX_PIXELS (decoded masks <= 256 MiB); both ends check this before coding or
allocating. The decoder rejects bad magic, truncation and corruption (length / CRC / impossible values,
a payload that ends before the last frame) with SigncastError.

Speed: the per-pixel and per-block work (contexts, the arithmetic coder, mode decisions with their bit
estimate, the shape motion search) runs in Numba kernels, one call per frame (comparisons/video/shape_cae.py); this
module owns the state and the checks. Streams are byte-identical to the pure-Python coder this replaced
(tests/test_shape_speed_identity.py); benchmarks/shape_coding.py measures both directions.
"""
from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from comparisons.video import shape_cae as kc
from comparisons.video.shape_cae import (
    BAB,
    COPY,
    COUNT_LIMIT,
    INTER_CAE,
    INTRA_CAE,
    N_CONTEXTS,
    OPAQUE,
    SEARCH_RANGE,
    TRANSPARENT,
)
from media.errors import SigncastError

__all__ = ["BAB", "COUNT_LIMIT", "MAX_PIXELS", "MAX_SIDE", "MODE_NAMES", "N_CONTEXTS", "SEARCH_RANGE",
           "BinaryArithmeticDecoder", "BinaryArithmeticEncoder", "ShapeStats", "decode_shape", "encode_shape"]

MAGIC = b"SCSH"
VERSION = 4                            # 2: the CRC covers the header too; 3: predicted frames may reuse the box;
VERSIONS = (2, 3, 4, 5)                # 4: trained pixel priors (comparisons/video/shape_priors.py); 5: 4 + size
LOSSY_VERSIONS = (5,)                  # conversion (CR 1/2, 1/4), lossy shape only. Read and written
_HEADER = struct.Struct(">4sBHHIBII")
_CRC_OFFSET = _HEADER.size - 4         # the CRC is the header's last field
MAX_SIDE = 4096                        # pixels, width and height
MAX_PIXELS = 1 << 28                   # frames x height x width: decoded (T, H, W) bool masks take <= 256 MiB
PRIOR_WEIGHT = 8                       # initial count of the likely symbol in a pixel context
TRAINED_WEIGHT = 128                   # version 4: initial zeros + ones of a trained pixel context
MAX_SHAPE_ERROR = 10.0                 # percent of the object's pixels, the most lossy shape may cost
CR_LAMBDA = 6.0                        # version 5: bits a wrong pixel of size conversion must save (encoder)
ALPHA_TH = 3                           # lossy shape: wrong pixels allowed per 4x4 sub-block of a uniform / copied BAB

MODE_NAMES = {TRANSPARENT: "transparent", OPAQUE: "opaque", INTRA_CAE: "intra_cae", INTER_CAE: "inter_cae",
              COPY: "copy"}
CR_NAMES = {kc.CR_FULL: "1", kc.CR_HALF: "1/2", kc.CR_QUARTER: "1/4"}
_DECODER_ERRORS = {
    kc.PAYLOAD_ENDS: "corrupt shape stream: the payload ends before the last frame",
    kc.BAD_BOX: "corrupt shape stream: impossible bounding box",
    kc.BAD_MV: "corrupt shape stream: shape motion vector out of range",
}


# ----------------------------------------------------------------------------------------------------
# binary arithmetic coder (32-bit registers, bits-plus-follow renormalisation) with adaptive contexts

@lru_cache(maxsize=8)
def _prior_counts(n_contexts: int, trained: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Initial (zeros, ones) counts (n_contexts,) int64 per context (cached, read-only: an intra frame resets
    the model to copies of them).

    trained (stream version 4): a pixel context that tools/make_shape_priors.py saw starts at TRAINED_WEIGHT
    counts split by its trained P(0) (each side at least 1); the others as below.

    A prior for the pixel contexts, skewed like the standard's fixed tables: a pixel tends to repeat its
    causal neighbours (intra) or its motion-compensated co-located pixel (inter), the more strongly the
    more of the template agrees; every other context starts at 1:1."""
    counts = np.ones((2, n_contexts), np.int64)  # zeros, ones

    def prior(ctx: int, likely: int, weight: int) -> None:
        if ctx < n_contexts:
            counts[likely, ctx] = weight

    for ctx in range(1024):
        bits = [(ctx >> k) & 1 for k in range(10)]
        near = bits[0] + bits[3] + bits[4] + bits[5]          # left, up-right, up, up-left
        likely = 1 if near > 2 or (near == 2 and bits[0]) else 0
        if sum(bits) in (0, 10):
            weight = PRIOR_WEIGHT * 8
        elif near in (0, 4):
            weight = PRIOR_WEIGHT * 2
        else:
            weight = 2
        prior(kc.CTX_INTRA + ctx, likely, weight)
        prior(kc.CTX_INTRA_LOW + ctx, likely, weight)
    for ctx in range(512):
        bits = [(ctx >> k) & 1 for k in range(9)]
        likely = bits[6]
        if sum(bits) in (0, 9):
            weight = PRIOR_WEIGHT * 8
        elif sum(bits[4:]) in (0, 5):
            weight = PRIOR_WEIGHT * 2
        else:
            weight = 2
        prior(kc.CTX_INTER + ctx, likely, weight)
        prior(kc.CTX_INTER_LOW + ctx, likely, weight)
    if trained:
        from comparisons.video.shape_priors import PIXEL_P0

        p0 = np.asarray(PIXEL_P0, np.int64)
        seen = np.flatnonzero(p0 >= 0)
        zeros = np.clip((p0[seen] * TRAINED_WEIGHT + 32768) >> 16, 1, TRAINED_WEIGHT - 1)
        counts[0, kc.CTX_INTRA + seen] = zeros
        counts[1, kc.CTX_INTRA + seen] = TRAINED_WEIGHT - zeros
    counts.flags.writeable = False
    return counts[0], counts[1]


@lru_cache(maxsize=1)
def _cost_table() -> np.ndarray:
    """comparisons.video.shape_cae.cost_table(), computed once (8 MiB)."""
    return kc.cost_table()


class _AdaptiveModel:
    """Counts of zeros and ones per context (n_contexts,) int64, updated by the kernels; P(0) in 1/65536 units."""

    def __init__(self, n_contexts: int, trained: bool = False):
        if n_contexts < 1:
            raise SigncastError(f"an adaptive model needs at least 1 context, not {n_contexts}")
        zeros, ones = _prior_counts(n_contexts, trained and n_contexts == N_CONTEXTS)
        self.zeros, self.ones = zeros.copy(), ones.copy()


class BinaryArithmeticEncoder:
    """Codes bits under adaptive context probabilities; `code(ctx, bit)` returns the bit."""

    def __init__(self, n_contexts: int = N_CONTEXTS):
        self.n_contexts = n_contexts
        self.model = _AdaptiveModel(n_contexts)
        self.registers = np.array([0, kc.TOP, 0, 0], np.int64)   # low, high, pending, bits written
        self.buffer = np.zeros(4096, np.uint8)                    # the bits, packed

    def reset_model(self, trained: bool = False) -> None:
        """The model back to its prior (trained: version 4's trained pixel prior)."""
        self.model = _AdaptiveModel(self.n_contexts, trained)

    def reserve(self, n_bits: int) -> None:
        """Room for n_bits more output bits past the pending ones (the kernels do not check)."""
        need = (int(self.registers[kc.NBITS]) + int(self.registers[kc.PENDING]) + n_bits) // 8 + 8
        if need > self.buffer.size:
            grown = np.zeros(max(need, 2 * self.buffer.size), np.uint8)
            grown[:self.buffer.size] = self.buffer
            self.buffer = grown

    def code(self, ctx: int, bit: int) -> int:
        if not 0 <= ctx < self.n_contexts:
            raise SigncastError(f"context {ctx} outside 0..{self.n_contexts - 1}")
        self.reserve(kc.BITS_PER_SYMBOL)
        return kc.encode(self.buffer, self.registers, self.model.zeros, self.model.ones, ctx, int(bit) & 1)

    def code_raw(self, value: int, n_bits: int) -> int:
        """An n-bit unsigned integer at probability 1/2 per bit, most significant first."""
        self.reserve(kc.BITS_PER_SYMBOL * n_bits)
        kc.encode_raw(self.buffer, self.registers, int(value), int(n_bits))
        return value

    def finish(self) -> bytes:
        self.reserve(2)
        kc.finish(self.buffer, self.registers)
        return self.buffer[:(int(self.registers[kc.NBITS]) + 7) // 8].tobytes()


class BinaryArithmeticDecoder:
    """Mirror of BinaryArithmeticEncoder; `code(ctx, _)` returns the decoded bit. SigncastError when it needs
    more bits than the payload and the register's 32-bit read-ahead hold."""

    def __init__(self, payload: bytes, n_contexts: int = N_CONTEXTS):
        self.n_contexts = n_contexts
        self.model = _AdaptiveModel(n_contexts)
        self.data = np.frombuffer(bytes(payload), np.uint8)
        value = int.from_bytes(bytes(payload[:4]).ljust(4, b"\0"), "big")
        self.registers = np.array([0, kc.TOP, value, 32, kc.OK], np.int64)   # low, high, value, position, status

    def reset_model(self, trained: bool = False) -> None:
        """The model back to its prior (trained: version 4's trained pixel prior)."""
        self.model = _AdaptiveModel(self.n_contexts, trained)

    def check(self, status: int) -> None:
        """SigncastError for a kernel's error status."""
        if status != kc.OK:
            raise SigncastError(_DECODER_ERRORS[status])

    def code(self, ctx: int, _bit: int = 0) -> int:
        if not 0 <= ctx < self.n_contexts:
            raise SigncastError(f"context {ctx} outside 0..{self.n_contexts - 1}")
        bit = kc.decode(self.data, self.registers, self.model.zeros, self.model.ones, ctx)
        self.check(int(self.registers[kc.STATUS]))
        return bit

    def code_raw(self, _value: int, n_bits: int) -> int:
        value = kc.decode_raw(self.data, self.registers, int(n_bits))
        self.check(int(self.registers[kc.STATUS]))
        return value


# ----------------------------------------------------------------------------------------------------
# the shape syntax: one kernel call codes (comparisons.video.shape_cae.encode_frame) or decodes (decode_frame) a frame

@dataclass
class ShapeStats:
    """What a coded shape sequence holds: size and mode counts."""

    n_bytes: int
    frames: int
    mode_counts: dict[str, int]
    error_pixels: int = 0       # decoded pixels unlike the input masks (0: lossless)
    object_pixels: int = 0      # opaque pixels of the input masks, all frames
    reconstruction: np.ndarray | None = None   # (T, H, W) bool: the encoder's decoded masks (lossy coding only)
    cr_counts: dict[str, int] | None = None    # version 5: coded (intra / inter CAE) BABs per conversion ratio

    @property
    def bits_per_frame(self) -> float:
        return 8.0 * self.n_bytes / max(1, self.frames)

    @property
    def shape_error(self) -> float:
        """Percent: wrong pixels over the object's pixels (0 for lossless coding or an empty object)."""
        return 100.0 * self.error_pixels / max(1, self.object_pixels)


class _Canvas:
    """The current and previous decoded frames as flat uint8 arrays (one 0/1 byte per pixel, with a border of
    SEARCH_RANGE + 2 zero pixels, so that motion-compensated templates never leave the array), plus the BAB
    mode grids and this frame's motion vectors."""

    def __init__(self, blocks_y: int, blocks_x: int):
        self.blocks_y, self.blocks_x = blocks_y, blocks_x
        self.border = SEARCH_RANGE + 4      # CR 1/4 reads 4 + 8 (a reduced cell, the vector) outside a BAB
        self.stride = blocks_x * BAB + 2 * self.border
        self.rows = blocks_y * BAB + 2 * self.border
        self.current = np.zeros(self.stride * self.rows, np.uint8)
        self.previous = np.zeros(self.stride * self.rows, np.uint8)
        self.modes = np.zeros((blocks_y, blocks_x), np.int64)            # TRANSPARENT is 0
        self.previous_modes = np.zeros((blocks_y, blocks_x), np.int64)
        self.mvs = np.zeros((blocks_y, blocks_x, 2), np.int64)            # (dx, dy) pixels
        self.has_mv = np.zeros((blocks_y, blocks_x), np.uint8)
        self.box = np.zeros(5, np.int64)                                  # previous frame: present, by0, by1, bx0, bx1
        self.counts = np.zeros(len(MODE_NAMES), np.int64)
        self.crs = np.zeros((blocks_y, blocks_x), np.int64)              # version 5: this frame's CR per BAB
        self.cr_counts = np.zeros(len(CR_NAMES), np.int64)

    def next_frame(self) -> None:
        self.previous, self.current = self.current, self.previous
        self.current.fill(0)
        self.previous_modes, self.modes = self.modes, self.previous_modes
        self.modes.fill(TRANSPARENT)
        self.has_mv.fill(0)
        self.crs.fill(kc.CR_FULL)

    def to_array(self, height: int, width: int) -> np.ndarray:
        b = self.border
        return self.current.reshape(self.rows, self.stride)[b:b + height, b:b + width].astype(bool)

    def mode_counts(self) -> dict[str, int]:
        return {MODE_NAMES[mode]: int(self.counts[mode]) for mode in MODE_NAMES}

    def cr_shares(self) -> dict[str, int]:
        return {CR_NAMES[cr]: int(self.cr_counts[cr]) for cr in CR_NAMES}


# ----------------------------------------------------------------------------------------------------
# public API

def _check_size(frames: int, height: int, width: int, what: str) -> None:
    """SigncastError unless 1 <= height, width <= MAX_SIDE and frames x height x width <= MAX_PIXELS."""
    if not (1 <= width <= MAX_SIDE and 1 <= height <= MAX_SIDE):
        raise SigncastError(f"{what}: {width}x{height} masks are outside 1..{MAX_SIDE} pixels a side")
    if not 1 <= frames * height * width <= MAX_PIXELS:
        raise SigncastError(f"{what}: {frames} frames of {width}x{height} exceed the limit of {MAX_PIXELS} "
                            "mask pixels per stream (split the sequence)")


def _check_masks(masks: np.ndarray) -> np.ndarray:
    masks = np.asarray(masks)
    if masks.ndim != 3 or masks.shape[0] < 1:
        raise SigncastError(f"shape masks must be (T, H, W) with T >= 1, got {masks.shape}")
    _check_size(*masks.shape, "cannot code shape masks")
    return np.asarray(masks, dtype=bool)  # no copy of boolean masks


def _frames(frames: int, gop: int, canvas: _Canvas, coder, version: int):
    """Frame indices t with inter (0 for intra), after moving the canvas on and, at intra frames, resetting
    the coder's model to the prior of the stream version."""
    for t in range(frames):
        if t:
            canvas.next_frame()
        inter = t % gop != 0
        if not inter:
            coder.reset_model(version >= 4)
        yield t, int(inter)


def encode_shape(masks: np.ndarray, gop: int = 12, shape_error: float = 0.0,
                 version: int | None = None) -> tuple[bytes, ShapeStats]:
    """Code a binary mask sequence (T, H, W) bool; returns the stream and its statistics.

    Frames 0, gop, 2*gop, ... are intra (probabilities reset); the others are predicted from the previous frame.
    shape_error 0 (percent) codes losslessly. Above 0 the encoder may decode up to floor(shape_error / 100 x
    the frame's opaque pixels) pixels of each frame wrongly (so the clip's shape error, wrong pixels over
    object pixels, stays <= shape_error %), spent as the standard's alpha threshold: a BAB with at most
    ALPHA_TH wrong pixels in every 4x4 sub-block is coded transparent, opaque or copied from the
    motion-compensated previous shape (at the predicted vector first, then at the searched one), first come
    first served in scan order (version 5 also reduced CAE BABs). In versions 2-4 the stream format and the
    decoder are the lossless ones: lossy shape is an encoder's choice, and stats.shape_error reports what it
    cost. version None codes versions 3 and 4 (and with shape_error > 0 also 5, size conversion) and keeps the
    shortest stream (the trained priors fit rendered masks and can cost a ragged natural outline a few %);
    2 writes the format without the same-box flag (the bytes of the coder before issue 39), 3 without the
    trained priors, 4 with them, 5 (shape_error > 0 only) version 4 with size conversion (CR 1/2, 1/4: see the
    module docstring); stats.cr_counts then counts the coded BABs per CR.
    """
    if version is None:
        candidates = (3, 4, 5) if shape_error > 0 else (3, 4)
        return min((encode_shape(masks, gop, shape_error, v) for v in candidates), key=lambda coded: len(coded[0]))
    masks = _check_masks(masks)
    if not 1 <= gop <= 255:
        raise SigncastError(f"shape GOP must be 1..255 frames, got {gop}")
    if version not in VERSIONS:
        raise SigncastError(f"shape stream version must be one of {VERSIONS}, got {version}")
    if not 0.0 <= shape_error <= MAX_SHAPE_ERROR:
        raise SigncastError(f"shape error must be 0..{MAX_SHAPE_ERROR} percent of the object's pixels, "
                            f"got {shape_error}")
    if version in LOSSY_VERSIONS and shape_error <= 0:
        raise SigncastError(f"shape stream version {version} (size conversion) codes lossy shape only: "
                            "give shape_error > 0, or version 3 or 4 for lossless shape")
    frames, height, width = masks.shape
    blocks_y, blocks_x = -(-height // BAB), -(-width // BAB)
    padded = np.zeros((frames, blocks_y * BAB, blocks_x * BAB), bool)
    padded[:, :height, :width] = masks
    object_pixels = padded.sum(axis=(1, 2))
    budgets = np.floor(shape_error / 100.0 * object_pixels).astype(np.int64)
    alpha_th = ALPHA_TH if shape_error > 0 else 0
    coder = BinaryArithmeticEncoder()
    canvas = _Canvas(blocks_y, blocks_x)
    words = np.zeros(canvas.previous.size, np.uint16)          # motion-search scratch (row_words)
    costs = _cost_table()
    frame_bits = kc.BITS_PER_SYMBOL * (kc.SYMBOLS_PER_FRAME + kc.SYMBOLS_PER_BLOCK * blocks_y * blocks_x)
    wrong = 0
    reconstruction = np.zeros_like(masks) if alpha_th else None
    for t, inter in _frames(frames, gop, canvas, coder, version):
        coder.reserve(frame_bits)
        kc.encode_frame(padded[t].view(np.uint8), canvas.current, canvas.previous, canvas.stride, canvas.border,
                        canvas.modes, canvas.previous_modes, canvas.mvs, canvas.has_mv, coder.model.zeros,
                        coder.model.ones, coder.buffer, coder.registers, canvas.counts, inter, costs, words, alpha_th,
                        int(budgets[t]), canvas.box, int(version >= 3), canvas.crs, canvas.cr_counts,
                        int(version >= 5), CR_LAMBDA)
        if alpha_th:    # the kernel's budget also counts the padding past the frame's edge; report what is seen
            reconstruction[t] = canvas.to_array(height, width)
            wrong += int(np.count_nonzero(reconstruction[t] != masks[t]))
    payload = coder.finish()
    fields = _HEADER.pack(MAGIC, version, width, height, frames, gop, len(payload), 0)[:_CRC_OFFSET]
    stream = fields + struct.pack(">I", zlib.crc32(payload, zlib.crc32(fields))) + payload
    return stream, ShapeStats(len(stream), frames, canvas.mode_counts(), int(wrong), int(object_pixels.sum()),
                              reconstruction, canvas.cr_shares() if version >= 5 else None)


def decode_shape(stream: bytes) -> np.ndarray:
    """Decode a stream from encode_shape back to masks (T, H, W) bool, bit-exact."""
    stream = bytes(stream)
    if len(stream) < _HEADER.size:
        raise SigncastError(f"shape stream truncated: {len(stream)} bytes, the header alone takes {_HEADER.size}")
    magic, version, width, height, frames, gop, length, crc = _HEADER.unpack_from(stream)
    if magic != MAGIC:
        raise SigncastError("not a signcast shape stream (bad magic)")
    if version not in VERSIONS:
        raise SigncastError(f"unsupported shape stream version {version} (this signcast reads versions "
                            f"{', '.join(map(str, VERSIONS))}; version 1 streams, whose header is outside the CRC, "
                            "must be coded again)")
    payload = stream[_HEADER.size:]
    if len(payload) != length:
        raise SigncastError(f"shape stream truncated or padded: payload {len(payload)} bytes, header says {length}")
    if zlib.crc32(payload, zlib.crc32(stream[:_CRC_OFFSET])) != crc:
        raise SigncastError("corrupt shape stream: CRC mismatch (header or payload damaged)")
    if gop == 0 or frames == 0:
        raise SigncastError("corrupt shape stream: no frames or a GOP of 0")
    _check_size(frames, height, width, "corrupt shape stream")
    blocks_y, blocks_x = -(-height // BAB), -(-width // BAB)
    coder = BinaryArithmeticDecoder(payload)
    canvas = _Canvas(blocks_y, blocks_x)
    masks = np.zeros((frames, height, width), bool)
    for t, inter in _frames(frames, gop, canvas, coder, version):
        coder.check(kc.decode_frame(coder.data, coder.registers, canvas.current, canvas.previous, canvas.stride,
                                    canvas.border, canvas.modes, canvas.previous_modes, canvas.mvs, canvas.has_mv,
                                    coder.model.zeros, coder.model.ones, canvas.counts, inter, canvas.box,
                                    int(version >= 3), canvas.crs, canvas.cr_counts, int(version >= 5)))
        masks[t] = canvas.to_array(height, width)
    return masks


def shape_bit_account(stream: bytes) -> dict:
    """Where a stream from encode_shape spends its bits (statistics for benchmarks/shape_coding.py; the stream is
    checked by decode_shape first). Returns frames, total_bits (the whole stream, header included), modes (the
    count of each BAB mode), bits (information in bits by category: header = presence flag and bounding box,
    mode, mv, intra_cae and inter_cae pixels; their sum is the payload to within the coder's few bits of
    termination), mv_blocks and mv_nonzero (blocks with a shape motion vector, and those whose vector differs
    from its prediction), and learning_bits: the pixel bits beyond what a model that already knew each GOP's
    context statistics would spend (sum over GOPs and contexts of n x the empirical entropy), the price of
    adaptive models that start from the prior at every intra frame; pixel_counts (2, N_CONTEXTS) int64, the
    decoded zeros and ones per context (tools/make_shape_priors.py trains the version 4 prior from them)."""
    masks = decode_shape(stream)
    stream = bytes(stream)
    _, version, width, height, frames, gop, _, _ = _HEADER.unpack_from(stream)
    blocks_y, blocks_x = -(-height // BAB), -(-width // BAB)
    coder = BinaryArithmeticDecoder(stream[_HEADER.size:])
    canvas = _Canvas(blocks_y, blocks_x)
    costs = np.zeros(kc.N_COSTS, np.float64)
    hist = np.zeros((2, N_CONTEXTS), np.int64)
    mv_blocks = np.zeros(2, np.int64)
    learning = 0.0

    def gop_entropy() -> float:
        n = hist.sum(axis=0)
        used = n > 0
        with np.errstate(divide="ignore", invalid="ignore"):
            p = hist[:, used] / n[used]
            terms = np.where(p > 0, -p * np.log2(np.where(p > 0, p, 1)), 0.0)
        return float((terms.sum(axis=0) * n[used]).sum())

    entropy = 0.0
    pixel_counts = np.zeros_like(hist)
    for t, inter in _frames(frames, gop, canvas, coder, version):
        if not inter:
            entropy += gop_entropy()
            pixel_counts += hist
            hist[:] = 0
        coder.check(kc.account_frame(coder.data, coder.registers, canvas.current, canvas.previous, canvas.stride,
                                     canvas.border, canvas.modes, canvas.previous_modes, canvas.mvs, canvas.has_mv,
                                     coder.model.zeros, coder.model.ones, canvas.counts, inter, canvas.box,
                                     int(version >= 3), costs, hist, mv_blocks, canvas.crs, canvas.cr_counts,
                                     int(version >= 5)))
    entropy += gop_entropy()
    pixel_counts += hist
    pixel_bits = costs[kc.COST_INTRA] + costs[kc.COST_INTER]
    learning = pixel_bits - entropy
    names = ("header", "mode", "mv", "intra_cae", "inter_cae", "cr")
    assert masks.shape[0] == frames
    return {"frames": frames, "total_bits": 8 * len(stream), "modes": canvas.mode_counts(),
            "bits": {name: float(costs[k]) for k, name in enumerate(names)},
            "crs": canvas.cr_shares(), "mv_blocks": int(mv_blocks[0]), "mv_nonzero": int(mv_blocks[1]), "learning_bits": learning,
            "pixel_counts": pixel_counts}

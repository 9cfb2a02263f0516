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
intra frame (every `gop` frames) to a prior skewed towards "the pixel repeats its neighbours / its
motion-compensated pixel", instead of the standard's fixed tables, which are not reproduced here;
(2) modes and motion-vector differences are binarised and coded by the same arithmetic coder instead of
VLCs; (3) one arithmetic codeword covers the whole sequence; (4) no size conversion and no transposed
scan (both lossy or optional tools); (5) every predicted frame refers to the previous frame in display order.

Stream layout (version 2): a 22-byte header (magic, version, width, height, frames, gop, payload length, then a
CRC-32 of the 18 header bytes before it and of the payload) and the arithmetic-coded payload. Version 1
streams (CRC of the payload alone) are rejected. Masks are at most MAX_SIDE pixels wide and high and
frames x height x width <= MAX_PIXELS (decoded masks <= 256 MiB); both ends check this before coding or
allocating. The decoder rejects bad magic, truncation and corruption (length / CRC / impossible values,
a payload that ends before the last frame) with SigncastError.
"""
from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from media.errors import SigncastError

BAB = 16
MAGIC = b"SCSH"
VERSION = 2                            # 2: the CRC covers the header too
_HEADER = struct.Struct(">4sBHHIBII")
_CRC_OFFSET = _HEADER.size - 4         # the CRC is the header's last field
MAX_SIDE = 4096                        # pixels, width and height
MAX_PIXELS = 1 << 28                   # frames x height x width: decoded (T, H, W) bool masks take <= 256 MiB
SEARCH_RANGE = 8                       # shape motion vectors lie in [-8, 8] pixels per component
COUNT_LIMIT = 1024                     # adaptive counts are halved past this total
PRIOR_WEIGHT = 8                       # initial count of the likely symbol in a pixel context

TRANSPARENT, OPAQUE, INTRA_CAE, INTER_CAE, COPY = 0, 1, 2, 3, 4
MODE_NAMES = {TRANSPARENT: "transparent", OPAQUE: "opaque", INTRA_CAE: "intra_cae", INTER_CAE: "inter_cae",
              COPY: "copy"}
_INTRA_ORDER = (TRANSPARENT, OPAQUE, INTRA_CAE)
_INTER_ORDER = (TRANSPARENT, OPAQUE, COPY, INTER_CAE, INTRA_CAE)

# context index ranges of the adaptive model
_CTX_INTRA = 0                         # 1024 intra pixel contexts
_CTX_INTER = 1024                      # 512 inter pixel contexts
_CTX_MODE_I = 1536                     # 81 neighbour contexts x 2 bins
_CTX_MODE_P = _CTX_MODE_I + 81 * 2     # 25 contexts x 4 bins
_CTX_MV = _CTX_MODE_P + 25 * 4         # per component: zero, sign, 8 magnitude bins
_CTX_PRESENT = _CTX_MV + 2 * 10
N_CONTEXTS = _CTX_PRESENT + 1


# ----------------------------------------------------------------------------------------------------
# binary arithmetic coder (32-bit registers, bits-plus-follow renormalisation) with adaptive contexts

_TOP = (1 << 32) - 1
_HALF = 1 << 31
_QUARTER = 1 << 30


@lru_cache(maxsize=4)
def _prior_counts(n_contexts: int) -> tuple[tuple[int, ...], tuple[int, ...]]:
    """Initial (zeros, ones) counts per context (cached: an intra frame resets the model to them).

    A prior for the pixel contexts, skewed like the standard's fixed tables: a pixel tends to repeat its
    causal neighbours (intra) or its motion-compensated co-located pixel (inter), the more strongly the
    more of the template agrees; every other context starts at 1:1."""
    counts = ([1] * n_contexts, [1] * n_contexts)  # zeros, ones

    def prior(ctx: int, likely: int, weight: int) -> None:
        if ctx < n_contexts:
            counts[likely][ctx] = weight

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
        prior(_CTX_INTRA + ctx, likely, weight)
    for ctx in range(512):
        bits = [(ctx >> k) & 1 for k in range(9)]
        likely = bits[6]
        if sum(bits) in (0, 9):
            weight = PRIOR_WEIGHT * 8
        elif sum(bits[4:]) in (0, 5):
            weight = PRIOR_WEIGHT * 2
        else:
            weight = 2
        prior(_CTX_INTER + ctx, likely, weight)
    return tuple(counts[0]), tuple(counts[1])


class _AdaptiveModel:
    """Counts of zeros and ones per context; P(0) in 1/65536 units."""

    def __init__(self, n_contexts: int):
        zeros, ones = _prior_counts(n_contexts)
        self.zeros, self.ones = list(zeros), list(ones)

    def p0(self, ctx: int) -> int:
        zeros = self.zeros[ctx]
        p = (zeros << 16) // (zeros + self.ones[ctx])
        return 1 if p < 1 else (65535 if p > 65535 else p)

    def update(self, ctx: int, bit: int) -> None:
        if bit:
            self.ones[ctx] += 1
        else:
            self.zeros[ctx] += 1
        if self.zeros[ctx] + self.ones[ctx] > COUNT_LIMIT:
            self.zeros[ctx] = (self.zeros[ctx] + 1) >> 1
            self.ones[ctx] = (self.ones[ctx] + 1) >> 1

    def bit_costs(self, start: int, stop: int) -> tuple[np.ndarray, np.ndarray]:
        """-log2 P(0) and -log2 P(1) for contexts start..stop-1 (arrays), for mode decisions."""
        zeros = np.array(self.zeros[start:stop], np.float64)
        ones = np.array(self.ones[start:stop], np.float64)
        total = zeros + ones
        return -np.log2(zeros / total), -np.log2(ones / total)


class BinaryArithmeticEncoder:
    """Codes bits under adaptive context probabilities; `code(ctx, bit)` returns the bit."""

    def __init__(self, n_contexts: int = N_CONTEXTS):
        self.model = _AdaptiveModel(n_contexts)
        self.low, self.high, self.pending = 0, _TOP, 0
        self.bits = bytearray()  # one 0/1 byte per coded bit

    def reset_model(self) -> None:
        self.model = _AdaptiveModel(len(self.model.zeros))

    def _code_p0(self, bit: int, p0: int) -> None:
        low, high = self.low, self.high
        split = low + (((high - low + 1) * p0) >> 16) - 1
        if bit:
            low = split + 1
        else:
            high = split
        bits = self.bits
        while True:
            if high < _HALF:
                bits.append(0)
                if self.pending:
                    bits.extend([1] * self.pending)
                    self.pending = 0
            elif low >= _HALF:
                bits.append(1)
                if self.pending:
                    bits.extend([0] * self.pending)
                    self.pending = 0
                low -= _HALF
                high -= _HALF
            elif low >= _QUARTER and high < _HALF + _QUARTER:
                self.pending += 1
                low -= _QUARTER
                high -= _QUARTER
            else:
                break
            low <<= 1
            high = (high << 1) | 1
        self.low, self.high = low, high

    def code(self, ctx: int, bit: int) -> int:
        self._code_p0(bit, self.model.p0(ctx))
        self.model.update(ctx, bit)
        return bit

    def code_raw(self, value: int, n_bits: int) -> int:
        """An n-bit unsigned integer at probability 1/2 per bit, most significant first."""
        for shift in range(n_bits - 1, -1, -1):
            self._code_p0((value >> shift) & 1, 32768)
        return value

    def finish(self) -> bytes:
        self.pending += 1
        if self.low < _QUARTER:
            self.bits.append(0)
            self.bits.extend([1] * self.pending)
        else:
            self.bits.append(1)
            self.bits.extend([0] * self.pending)
        self.pending = 0
        return np.packbits(np.frombuffer(self.bits, np.uint8)).tobytes()


class BinaryArithmeticDecoder:
    """Mirror of BinaryArithmeticEncoder; `code(ctx, _)` returns the decoded bit. SigncastError when it needs
    more bits than the payload and the register's 32-bit read-ahead hold."""

    def __init__(self, payload: bytes, n_contexts: int = N_CONTEXTS):
        self.model = _AdaptiveModel(n_contexts)
        self.bits = np.unpackbits(np.frombuffer(payload, np.uint8)).tobytes()  # one 0/1 byte per bit
        self.position = 32
        value = 0
        for bit in self.bits[:32].ljust(32, b"\0"):
            value = (value << 1) | bit
        self.value, self.low, self.high = value, 0, _TOP

    def reset_model(self) -> None:
        self.model = _AdaptiveModel(len(self.model.zeros))

    def _decode_p0(self, p0: int) -> int:
        low, high, value = self.low, self.high, self.value
        split = low + (((high - low + 1) * p0) >> 16) - 1
        if value <= split:
            bit, high = 0, split
        else:
            bit, low = 1, split + 1
        bits, position, n = self.bits, self.position, len(self.bits)
        while True:
            if high < _HALF:
                pass
            elif low >= _HALF:
                low -= _HALF
                high -= _HALF
                value -= _HALF
            elif low >= _QUARTER and high < _HALF + _QUARTER:
                low -= _QUARTER
                high -= _QUARTER
                value -= _QUARTER
            else:
                break
            low <<= 1
            high = (high << 1) | 1
            if position < n:
                value = (value << 1) | bits[position]
            elif position < n + 32:  # the 32-bit register may read ahead past the payload, no further
                value <<= 1
            else:
                raise SigncastError("corrupt shape stream: the payload ends before the last frame")
            position += 1
        self.low, self.high, self.value, self.position = low, high, value, position
        return bit

    def code(self, ctx: int, _bit: int = 0) -> int:
        bit = self._decode_p0(self.model.p0(ctx))
        self.model.update(ctx, bit)
        return bit

    def code_raw(self, _value: int, n_bits: int) -> int:
        value = 0
        for _ in range(n_bits):
            value = (value << 1) | self._decode_p0(32768)
        return value


# ----------------------------------------------------------------------------------------------------
# the shape syntax, shared by encoder and decoder (the encoder passes true values, the decoder gets them back)

@dataclass
class ShapeStats:
    """What a coded shape sequence holds: size and mode counts."""

    n_bytes: int
    frames: int
    mode_counts: dict[str, int]

    @property
    def bits_per_frame(self) -> float:
        return 8.0 * self.n_bytes / max(1, self.frames)


class _Canvas:
    """The current and previous decoded frames as flat bytearrays (one 0/1 byte per pixel, with a border),
    plus the BAB mode grids. Bytes, not lists: 1 byte a pixel instead of 8, and a zero-copy array view."""

    def __init__(self, blocks_y: int, blocks_x: int):
        self.blocks_y, self.blocks_x = blocks_y, blocks_x
        self.border = SEARCH_RANGE + 2
        self.stride = blocks_x * BAB + 2 * self.border
        self.rows = blocks_y * BAB + 2 * self.border
        self.current = bytearray(self.stride * self.rows)
        self.previous = bytearray(self.stride * self.rows)
        self.modes = [[TRANSPARENT] * blocks_x for _ in range(blocks_y)]
        self.previous_modes = [[TRANSPARENT] * blocks_x for _ in range(blocks_y)]
        self.mvs: dict[tuple[int, int], tuple[int, int]] = {}

    def index(self, y: int, x: int) -> int:
        return (y + self.border) * self.stride + x + self.border

    def next_frame(self) -> None:
        self.previous, self.current = self.current, bytearray(len(self.current))
        self.previous_modes = self.modes
        self.modes = [[TRANSPARENT] * self.blocks_x for _ in range(self.blocks_y)]
        self.mvs = {}

    def grid(self, flat: bytearray) -> np.ndarray:
        """(rows, stride) uint8 view of `current` or `previous`, border included."""
        return np.frombuffer(flat, np.uint8).reshape(self.rows, self.stride)

    def to_array(self, height: int, width: int) -> np.ndarray:
        b = self.border
        return self.grid(self.current)[b:b + height, b:b + width].astype(bool)


def _bits_for(count: int) -> int:
    return max(1, (count - 1).bit_length())


def _code_mode(coder, canvas: _Canvas, by: int, bx: int, inter: bool, mode: int) -> int:
    modes = canvas.modes
    if inter:
        left = modes[by][bx - 1] if bx > 0 else TRANSPARENT
        ctx0 = _CTX_MODE_P + (canvas.previous_modes[by][bx] * 5 + left) * 4
        order = _INTER_ORDER
    else:
        def coarse(m: int) -> int:
            return m if m < INTRA_CAE else INTRA_CAE
        left = coarse(modes[by][bx - 1]) if bx > 0 else 0
        top = coarse(modes[by - 1][bx]) if by > 0 else 0
        top_left = coarse(modes[by - 1][bx - 1]) if by > 0 and bx > 0 else 0
        top_right = coarse(modes[by - 1][bx + 1]) if by > 0 and bx + 1 < canvas.blocks_x else 0
        ctx0 = _CTX_MODE_I + (((left * 3 + top) * 3 + top_left) * 3 + top_right) * 2
        order = _INTRA_ORDER
    for position, candidate in enumerate(order[:-1]):
        if coder.code(ctx0 + position, int(mode == candidate)):
            return candidate
    return order[-1]


def _mv_predictor(canvas: _Canvas, by: int, bx: int) -> tuple[int, int]:
    for neighbour in ((by, bx - 1), (by - 1, bx), (by - 1, bx + 1)):
        if neighbour in canvas.mvs:
            return canvas.mvs[neighbour]
    return (0, 0)


def _code_mv_component(coder, component: int, value: int) -> int:
    base = _CTX_MV + component * 10
    if not coder.code(base, int(value != 0)):
        return 0
    negative = coder.code(base + 1, int(value < 0))
    magnitude, limit = 1, 2 * SEARCH_RANGE
    while magnitude < limit and coder.code(base + 2 + min(magnitude - 1, 7), int(abs(value) > magnitude)):
        magnitude += 1
    return -magnitude if negative else magnitude


def _code_cae_block(coder, canvas: _Canvas, y0: int, x0: int, block, mv: tuple[int, int] | None) -> None:
    """Intra (mv None) or inter CAE of one BAB, pixel by pixel in raster order, written into canvas.current.

    block: the 16x16 bits as a flat list for the encoder, or None for the decoder.
    """
    cur, stride = canvas.current, canvas.stride
    s2 = 2 * stride
    code = coder.code
    if mv is not None:
        prev = canvas.previous
        shift = mv[1] * stride + mv[0]
    for r in range(BAB):
        row = canvas.index(y0 + r, x0)
        for c in range(BAB):
            i = row + c
            if mv is None:
                ctx = (cur[i - 1] | cur[i - 2] << 1 | cur[i - stride + 2] << 2 | cur[i - stride + 1] << 3
                       | cur[i - stride] << 4 | cur[i - stride - 1] << 5 | cur[i - stride - 2] << 6
                       | cur[i - s2 + 1] << 7 | cur[i - s2] << 8 | cur[i - s2 - 1] << 9)
            else:
                j = i + shift
                ctx = _CTX_INTER + (cur[i - 1] | cur[i - stride + 1] << 1 | cur[i - stride] << 2
                                    | cur[i - stride - 1] << 3 | prev[j + stride] << 4 | prev[j + 1] << 5
                                    | prev[j] << 6 | prev[j - 1] << 7 | prev[j - stride] << 8)
            cur[i] = code(ctx, block[r * BAB + c] if block is not None else 0)
        # not-yet-decoded pixels right of the BAB read as its last column (cleared again after the BAB)
        cur[row + BAB] = cur[row + BAB + 1] = cur[row + BAB - 1]
    for r in range(BAB):
        row = canvas.index(y0 + r, x0)
        cur[row + BAB] = cur[row + BAB + 1] = 0


_OPAQUE_ROW, _TRANSPARENT_ROW = b"\x01" * BAB, bytes(BAB)


def _fill_block(canvas: _Canvas, y0: int, x0: int, mode: int, mv: tuple[int, int]) -> None:
    cur, prev, stride = canvas.current, canvas.previous, canvas.stride
    shift = mv[1] * stride + mv[0]
    for r in range(BAB):
        start = canvas.index(y0 + r, x0)
        if mode == COPY:
            cur[start:start + BAB] = prev[start + shift:start + shift + BAB]
        else:
            cur[start:start + BAB] = _OPAQUE_ROW if mode == OPAQUE else _TRANSPARENT_ROW


def _code_frame(coder, canvas: _Canvas, inter: bool, frame: np.ndarray | None, counts: dict[int, int]) -> None:
    """Code (encoder: frame is the padded (Hb, Wb) bool mask) or decode (frame None) one frame."""
    by_count, bx_count = canvas.blocks_y, canvas.blocks_x
    if frame is not None:
        rows, cols = np.nonzero(frame.reshape(by_count, BAB, bx_count, BAB).any(axis=(1, 3)))
        present = int(len(rows) > 0)
    else:
        present = 0
    if not coder.code(_CTX_PRESENT, present):
        return
    nby, nbx = _bits_for(by_count), _bits_for(bx_count)
    box = (rows.min(), rows.max(), cols.min(), cols.max()) if frame is not None else (0, 0, 0, 0)
    by0 = coder.code_raw(int(box[0]), nby)
    by1 = coder.code_raw(int(box[1]), nby)
    bx0 = coder.code_raw(int(box[2]), nbx)
    bx1 = coder.code_raw(int(box[3]), nbx)
    if not (by0 <= by1 < by_count and bx0 <= bx1 < bx_count):
        raise SigncastError("corrupt shape stream: impossible bounding box")
    encoder = frame is not None
    if encoder:
        searcher = _MotionSearch(canvas, frame) if inter else None
    for by in range(by0, by1 + 1):
        for bx in range(bx0, bx1 + 1):
            y0, x0 = by * BAB, bx * BAB
            mode, mv, block = TRANSPARENT, (0, 0), None
            if encoder:
                block_array = frame[y0:y0 + BAB, x0:x0 + BAB]
                mode, mv = _choose_mode(coder, canvas, searcher, by, bx, block_array, inter)
                block = block_array.astype(np.uint8).ravel().tolist()
            mode = _code_mode(coder, canvas, by, bx, inter, mode)
            if mode in (COPY, INTER_CAE):
                predictor = _mv_predictor(canvas, by, bx)
                dx = predictor[0] + _code_mv_component(coder, 0, mv[0] - predictor[0])
                dy = predictor[1] + _code_mv_component(coder, 1, mv[1] - predictor[1])
                if abs(dx) > SEARCH_RANGE or abs(dy) > SEARCH_RANGE:
                    raise SigncastError("corrupt shape stream: shape motion vector out of range")
                mv = (dx, dy)
                canvas.mvs[(by, bx)] = mv
            canvas.modes[by][bx] = mode
            counts[mode] += 1
            if mode == INTRA_CAE:
                _code_cae_block(coder, canvas, y0, x0, block, None)
            elif mode == INTER_CAE:
                _code_cae_block(coder, canvas, y0, x0, block, mv)
            else:
                _fill_block(canvas, y0, x0, mode, mv)


# ----------------------------------------------------------------------------------------------------
# encoder-side decisions: motion search and mode choice by estimated cost under the current probabilities

class _MotionSearch:
    """Integer-pel block matching of the current mask against the previous decoded shape."""

    def __init__(self, canvas: _Canvas, frame: np.ndarray):
        b = canvas.border
        self.previous = canvas.grid(canvas.previous)  # previous frame with a border of `b` zero pixels
        self.border = b
        offsets = np.arange(-SEARCH_RANGE, SEARCH_RANGE + 1)
        self.offsets = [(dx, dy) for dy in offsets for dx in offsets]

    def best(self, y0: int, x0: int, block: np.ndarray, predictor: tuple[int, int]) -> tuple[tuple[int, int], int]:
        b, r = self.border, SEARCH_RANGE
        window = self.previous[b + y0 - r:b + y0 + BAB + r, b + x0 - r:b + x0 + BAB + r]
        views = np.lib.stride_tricks.sliding_window_view(window, (BAB, BAB))  # (2r+1, 2r+1, 16, 16)
        errors = (views != block.astype(np.uint8)).sum(axis=(2, 3))
        distance = np.abs(np.arange(-r, r + 1)[None, :] - predictor[0]) + np.abs(np.arange(-r, r + 1)[:, None] - predictor[1])
        score = errors * 64 + distance  # fewest mismatches, then nearest to the predictor
        dy, dx = np.unravel_index(int(np.argmin(score)), score.shape)
        return (int(dx) - r, int(dy) - r), int(errors[dy, dx])


def _window(flat: bytearray, canvas: _Canvas, y: int, x: int, height: int, width: int) -> np.ndarray:
    """A (height, width) int32 copy of a piece of a flat canvas whose top-left pixel is (y, x) in frame coordinates."""
    b = canvas.border
    return canvas.grid(flat)[y + b:y + b + height, x + b:x + b + width].astype(np.int32)


def _estimate_cae_bits(coder, canvas: _Canvas, y0: int, x0: int, block: np.ndarray, mv) -> float:
    """Approximate CAE cost of a BAB in bits, from vectorised contexts and the current probabilities."""
    window = _window(canvas.current, canvas, y0 - 2, x0 - 2, BAB + 2, BAB + 4)
    window[2:, 2:2 + BAB] = block
    window[2:, 2 + BAB:] = block[:, -1:]

    def at(dy: int, dx: int) -> np.ndarray:
        return window[2 + dy:2 + dy + BAB, 2 + dx:2 + dx + BAB]
    bits = block.astype(np.int32)
    if mv is None:
        ctx = (at(0, -1) | at(0, -2) << 1 | at(-1, 2) << 2 | at(-1, 1) << 3 | at(-1, 0) << 4 | at(-1, -1) << 5
               | at(-1, -2) << 6 | at(-2, 1) << 7 | at(-2, 0) << 8 | at(-2, -1) << 9)
        cost0, cost1 = coder.model.bit_costs(_CTX_INTRA, _CTX_INTRA + 1024)
    else:
        prev = _window(canvas.previous, canvas, y0 + mv[1] - 1, x0 + mv[0] - 1, BAB + 2, BAB + 2)

        def mc(dy: int, dx: int) -> np.ndarray:
            return prev[1 + dy:1 + dy + BAB, 1 + dx:1 + dx + BAB]
        ctx = (at(0, -1) | at(-1, 1) << 1 | at(-1, 0) << 2 | at(-1, -1) << 3 | mc(1, 0) << 4 | mc(0, 1) << 5
               | mc(0, 0) << 6 | mc(0, -1) << 7 | mc(-1, 0) << 8)
        cost0, cost1 = coder.model.bit_costs(_CTX_INTER, _CTX_INTER + 512)
    return float(np.where(bits > 0, cost1[ctx], cost0[ctx]).sum())


def _choose_mode(coder, canvas: _Canvas, searcher, by: int, bx: int, block: np.ndarray, inter: bool):
    opaque = int(block.sum())
    if opaque == 0:
        return TRANSPARENT, (0, 0)
    if opaque == BAB * BAB:
        return OPAQUE, (0, 0)
    y0, x0 = by * BAB, bx * BAB
    if not inter:
        return INTRA_CAE, (0, 0)
    predictor = _mv_predictor(canvas, by, bx)
    mv, errors = searcher.best(y0, x0, block, predictor)
    if errors == 0:
        return COPY, mv
    mv_bits = 2.0 + 2.0 * (abs(mv[0] - predictor[0]) + abs(mv[1] - predictor[1]))
    inter_bits = _estimate_cae_bits(coder, canvas, y0, x0, block, mv) + mv_bits
    intra_bits = _estimate_cae_bits(coder, canvas, y0, x0, block, None)
    return (INTER_CAE, mv) if inter_bits < intra_bits else (INTRA_CAE, (0, 0))


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


def encode_shape(masks: np.ndarray, gop: int = 12) -> tuple[bytes, ShapeStats]:
    """Code a binary mask sequence (T, H, W) bool losslessly; returns the stream and its statistics.

    Frames 0, gop, 2*gop, ... are intra (probabilities reset); the others are predicted from the previous frame.
    """
    masks = _check_masks(masks)
    if not 1 <= gop <= 255:
        raise SigncastError(f"shape GOP must be 1..255 frames, got {gop}")
    frames, height, width = masks.shape
    blocks_y, blocks_x = -(-height // BAB), -(-width // BAB)
    padded = np.zeros((frames, blocks_y * BAB, blocks_x * BAB), bool)
    padded[:, :height, :width] = masks
    coder = BinaryArithmeticEncoder()
    canvas = _Canvas(blocks_y, blocks_x)
    counts = {mode: 0 for mode in MODE_NAMES}
    for t in range(frames):
        if t:
            canvas.next_frame()
        inter = t % gop != 0
        if not inter:
            coder.reset_model()
        _code_frame(coder, canvas, inter, padded[t], counts)
    payload = coder.finish()
    fields = _HEADER.pack(MAGIC, VERSION, width, height, frames, gop, len(payload), 0)[:_CRC_OFFSET]
    stream = fields + struct.pack(">I", zlib.crc32(payload, zlib.crc32(fields))) + payload
    return stream, ShapeStats(len(stream), frames, {MODE_NAMES[m]: n for m, n in counts.items()})


def decode_shape(stream: bytes) -> np.ndarray:
    """Decode a stream from encode_shape back to masks (T, H, W) bool, bit-exact."""
    stream = bytes(stream)
    if len(stream) < _HEADER.size:
        raise SigncastError(f"shape stream truncated: {len(stream)} bytes, the header alone takes {_HEADER.size}")
    magic, version, width, height, frames, gop, length, crc = _HEADER.unpack_from(stream)
    if magic != MAGIC:
        raise SigncastError("not a signcast shape stream (bad magic)")
    if version != VERSION:
        raise SigncastError(f"unsupported shape stream version {version} (this signcast reads version {VERSION}; "
                            "version 1 streams, whose header is outside the CRC, must be coded again)")
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
    counts = {mode: 0 for mode in MODE_NAMES}
    masks = np.zeros((frames, height, width), bool)
    for t in range(frames):
        if t:
            canvas.next_frame()
        inter = t % gop != 0
        if not inter:
            coder.reset_model()
        _code_frame(coder, canvas, inter, None, counts)
        masks[t] = canvas.to_array(height, width)
    return masks

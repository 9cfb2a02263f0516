"""Numba-compiled kernels of the binary shape coder (context-based arithmetic encoding, CAE).

They are the per-pixel and per-block loops of comparisons/video/shape.py, which documents the stream format
and owns the state arrays; it raises SigncastError from the status codes these kernels return. One call codes
or decodes a whole frame: bounding box, BAB modes, shape motion vectors, the CAE pixels, and on the encoder
side the shape motion search and the intra / inter decision by estimated bits. Compiled nopython with
cache=True (once per machine, then loaded from __pycache__); they live outside `comparisons` so that
coverage-instrumented imports (benchmarks/fuzz.py) leave their bytecode alone, as comparisons/params/arithmetic.py.

Byte-identity with the pure-Python coder they replaced (tests/test_shape_speed_identity.py): the bit
estimate sums its 256 per-pixel costs in the order of NumPy's pairwise summation (8 accumulators over blocks
of 128, numpy/_core/src/umath/loops_utils.h.src), and reads -log2(a / (a + b)) from a table that NumPy's
own log2 fills (`cost_table`), so mode decisions compare the very same floats.

State arrays: a canvas is a flat uint8 array (rows x stride, one 0/1 byte a pixel, a `border` of zero pixels
around the frame); modes (blocks_y, blocks_x) int64; motion vectors (blocks_y, blocks_x, 2) int64 (dx, dy)
with has_mv (blocks_y, blocks_x) uint8; a model is zeros, ones (N_CONTEXTS,) int64 counts; encoder registers
(low, high, pending follow bits, bits written) int64 over a zero-filled uint8 buffer (bits packed, most
significant first); decoder registers (low, high, value, bit position, status) int64 over the payload.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from comparisons.params.arithmetic import (  # the one arithmetic coder (32-bit registers, bits plus follow)
    NO_STUFFING,
    TOP,  # noqa: F401  (comparisons/video/shape.py starts its registers at kc.TOP)
    finish_coder,
    renormalise_coder,
    renormalise_decoder,
)

I = np.int64    # canvas bytes are uint8: cast before mixing them with int64 (uint8 | int64 is float64)

# format constants (comparisons/video/shape.py re-exports and documents them)
BAB = 16
SEARCH_RANGE = 8
COUNT_LIMIT = 1024
TRANSPARENT, OPAQUE, INTRA_CAE, INTER_CAE, COPY = 0, 1, 2, 3, 4
CTX_INTRA = 0                          # 1024 intra pixel contexts
CTX_INTER = 1024                       # 512 inter pixel contexts
CTX_MODE_I = 1536                      # 81 neighbour contexts x 2 bins
CTX_MODE_P = CTX_MODE_I + 81 * 2       # 25 contexts x 4 bins
CTX_MV = CTX_MODE_P + 25 * 4           # per component: zero, sign, 8 magnitude bins
CTX_PRESENT = CTX_MV + 2 * 10
CTX_SAME_BOX = CTX_PRESENT + 1         # version 3: "the previous frame's bounding box" flag of a predicted frame
CTX_CR = CTX_SAME_BOX + 1              # version 5: size conversion, (intra / inter) x left BAB's CR (3) x 2 bins
CTX_INTRA_LOW = CTX_CR + 2 * 3 * 2     # version 5: 1024 intra pixel contexts of reduced (CR 1/2, 1/4) BABs
CTX_INTER_LOW = CTX_INTRA_LOW + 1024   # version 5: 512 inter pixel contexts of reduced BABs
N_CONTEXTS = CTX_INTER_LOW + 512
CR_FULL, CR_HALF, CR_QUARTER = 0, 1, 2            # version 5: a coded BAB's conversion ratio 1, 1/2, 1/4
CR_FACTOR = (1, 2, 4)
UPSAMPLE_TH = 9                        # weighted sum (0..18) above which an upsampled pixel is opaque (= 9: its own)

LOW, HIGH, PENDING, NBITS = range(4)              # encoder registers
VALUE, POSITION, STATUS = 2, 3, 4                 # decoder registers (LOW, HIGH as the encoder's)
OK, PAYLOAD_ENDS, BAD_BOX, BAD_MV = range(4)      # decoder status codes
# bits one coded symbol can add: after renormalisation the range exceeds 2^30, a symbol keeps >= 1/65536 of
# it (>= 2^14) and each renormalising shift doubles it, so <= 17 shifts (each one output bit, now or pending)
BITS_PER_SYMBOL = 18
SYMBOLS_PER_BLOCK = 4 + 2 * 17 + 2 + BAB * BAB     # mode bins, two MV components, the CR bins, the pixels
SYMBOLS_PER_FRAME = 2 + 4 * 12                     # presence, same-box flag, the box (<= 12 raw bits per field)
MAX_COUNT = COUNT_LIMIT                            # a context's counts stay in 1..MAX_COUNT - 1


def cost_table() -> np.ndarray:
    """(MAX_COUNT, MAX_COUNT) float64: [a, b] = -log2(a / (a + b)) bits, computed by NumPy as the original
    estimate did (row and column 0 unused)."""
    counts = np.arange(MAX_COUNT, dtype=np.float64)
    a, b = counts[:, None], counts[None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        return -np.log2(a / (a + b))


# ------------------------------------------------------------------------------------------------ the coder

@njit(cache=True)
def p0(zeros: np.ndarray, ones: np.ndarray, ctx: int) -> int:
    """P(0) of a context in 1/65536 units, clamped to 1..65535."""
    z = zeros[ctx]
    p = (z << 16) // (z + ones[ctx])
    return max(1, min(p, 65535))


@njit(cache=True)
def update(zeros: np.ndarray, ones: np.ndarray, ctx: int, bit: int) -> None:
    if bit:
        ones[ctx] += 1
    else:
        zeros[ctx] += 1
    if zeros[ctx] + ones[ctx] > COUNT_LIMIT:
        zeros[ctx] = (zeros[ctx] + 1) >> 1
        ones[ctx] = (ones[ctx] + 1) >> 1


@njit(cache=True)
def encode_p0(buffer: np.ndarray, regs: np.ndarray, bit: int, p_zero: int) -> None:
    """One bit at P(0) = p_zero / 65536 (comparisons/params/arithmetic.py's coder, no emulation prevention)."""
    low, high = regs[LOW], regs[HIGH]
    split = low + (((high - low + 1) * p_zero) >> 16) - 1
    if bit:
        low = split + 1
    else:
        high = split
    regs[NBITS], _, regs[LOW], regs[HIGH], regs[PENDING] = renormalise_coder(
        buffer, regs[NBITS], 0, low, high, regs[PENDING], NO_STUFFING)


@njit(cache=True)
def encode(buffer: np.ndarray, regs: np.ndarray, zeros: np.ndarray, ones: np.ndarray, ctx: int, bit: int) -> int:
    encode_p0(buffer, regs, bit, p0(zeros, ones, ctx))
    update(zeros, ones, ctx, bit)
    return bit


@njit(cache=True)
def encode_raw(buffer: np.ndarray, regs: np.ndarray, value: int, n_bits: int) -> None:
    """An n-bit unsigned integer at probability 1/2 per bit, most significant first."""
    for shift in range(n_bits - 1, -1, -1):
        encode_p0(buffer, regs, (value >> shift) & 1, 32768)


@njit(cache=True)
def finish(buffer: np.ndarray, regs: np.ndarray) -> None:
    """The final bits that select the last interval (needs PENDING + 2 bits of room)."""
    regs[NBITS], _ = finish_coder(buffer, regs[NBITS], 0, regs[LOW], regs[PENDING], NO_STUFFING)
    regs[PENDING] = 0


@njit(cache=True)
def decode_p0(data: np.ndarray, regs: np.ndarray, p_zero: int) -> int:
    """One bit at P(0) = p_zero / 65536; past the payload and its 32-bit read-ahead, status PAYLOAD_ENDS and
    bit 0 from then on."""
    if regs[STATUS] != OK:
        return 0
    low, high, value, position = regs[LOW], regs[HIGH], regs[VALUE], regs[POSITION]
    n = data.size * 8
    split = low + (((high - low + 1) * p_zero) >> 16) - 1
    if value <= split:
        bit = 0
        high = split
    else:
        bit = 1
        low = split + 1
    low, high, n_bits, subtract = renormalise_decoder(low, high)
    if position + n_bits > n + 32:
        regs[STATUS] = PAYLOAD_ENDS
        return 0
    for _ in range(n_bits):
        value = (value << 1) | ((I(data[position >> 3]) >> (7 - (position & 7))) & 1 if position < n else 0)
        position += 1
    value -= subtract
    regs[LOW], regs[HIGH], regs[VALUE], regs[POSITION] = low, high, value, position
    return bit


@njit(cache=True)
def decode(data: np.ndarray, regs: np.ndarray, zeros: np.ndarray, ones: np.ndarray, ctx: int) -> int:
    bit = decode_p0(data, regs, p0(zeros, ones, ctx))
    update(zeros, ones, ctx, bit)
    return bit


@njit(cache=True)
def decode_raw(data: np.ndarray, regs: np.ndarray, n_bits: int) -> int:
    value = 0
    for _ in range(n_bits):
        value = (value << 1) | decode_p0(data, regs, 32768)
    return value


# -------------------------------------------------------------------------------------------- the syntax

@njit(cache=True)
def _bits_for(count: int) -> int:
    """Bits of a raw field holding 0..count-1 (at least 1)."""
    bits = 1
    while (1 << bits) < count:
        bits += 1
    return bits


@njit(cache=True)
def _coarse(mode: int) -> int:
    return min(mode, INTRA_CAE)


@njit(cache=True)
def _mode_context(modes: np.ndarray, previous_modes: np.ndarray, by: int, bx: int, inter: int) -> int:
    """The first context of a BAB's mode bins: the co-located previous mode and the left mode (inter), or the
    left, top, top-left and top-right modes reduced to transparent / opaque / CAE (intra)."""
    if inter:
        left = modes[by, bx - 1] if bx > 0 else TRANSPARENT
        return CTX_MODE_P + (previous_modes[by, bx] * 5 + left) * 4
    blocks_x = modes.shape[1]
    left = _coarse(modes[by, bx - 1]) if bx > 0 else 0
    top = _coarse(modes[by - 1, bx]) if by > 0 else 0
    top_left = _coarse(modes[by - 1, bx - 1]) if by > 0 and bx > 0 else 0
    top_right = _coarse(modes[by - 1, bx + 1]) if by > 0 and bx + 1 < blocks_x else 0
    return CTX_MODE_I + (((left * 3 + top) * 3 + top_left) * 3 + top_right) * 2


@njit(cache=True)
def _mode_order(inter: int) -> np.ndarray:
    if inter:
        return np.array((TRANSPARENT, OPAQUE, COPY, INTER_CAE, INTRA_CAE), np.int64)
    return np.array((TRANSPARENT, OPAQUE, INTRA_CAE), np.int64)


@njit(cache=True)
def _mv_predictor(mvs: np.ndarray, has_mv: np.ndarray, by: int, bx: int) -> tuple[int, int]:
    """The motion vector of the left, else top, else top-right BAB of this frame that has one, else (0, 0)."""
    blocks_x = has_mv.shape[1]
    if bx > 0 and has_mv[by, bx - 1]:
        return mvs[by, bx - 1, 0], mvs[by, bx - 1, 1]
    if by > 0 and has_mv[by - 1, bx]:
        return mvs[by - 1, bx, 0], mvs[by - 1, bx, 1]
    if by > 0 and bx + 1 < blocks_x and has_mv[by - 1, bx + 1]:
        return mvs[by - 1, bx + 1, 0], mvs[by - 1, bx + 1, 1]
    return 0, 0


@njit(cache=True)
def _intra_context(cur: np.ndarray, i: int, stride: int) -> int:
    s2 = 2 * stride
    return (I(cur[i - 1]) | I(cur[i - 2]) << 1 | I(cur[i - stride + 2]) << 2 | I(cur[i - stride + 1]) << 3
            | I(cur[i - stride]) << 4 | I(cur[i - stride - 1]) << 5 | I(cur[i - stride - 2]) << 6
            | I(cur[i - s2 + 1]) << 7 | I(cur[i - s2]) << 8 | I(cur[i - s2 - 1]) << 9)


@njit(cache=True)
def _inter_context(cur: np.ndarray, prev: np.ndarray, i: int, j: int, stride: int) -> int:
    return CTX_INTER + (I(cur[i - 1]) | I(cur[i - stride + 1]) << 1 | I(cur[i - stride]) << 2
                        | I(cur[i - stride - 1]) << 3 | I(prev[j + stride]) << 4 | I(prev[j + 1]) << 5 | I(prev[j]) << 6 | I(prev[j - 1]) << 7
                        | I(prev[j - stride]) << 8)


@njit(cache=True)
def _fill_block(cur: np.ndarray, prev: np.ndarray, stride: int, start: int, mode: int, shift: int) -> None:
    """Transparent, opaque or copy (of the previous frame `shift` flat pixels away) BAB at flat index start."""
    for r in range(BAB):
        row = start + r * stride
        for c in range(BAB):
            if mode == COPY:
                cur[row + c] = prev[row + shift + c]
            else:
                cur[row + c] = 1 if mode == OPAQUE else 0


@njit(cache=True)
def _clear_right(cur: np.ndarray, stride: int, start: int) -> None:
    """Clear the two not-yet-decoded pixels right of each BAB row that CAE replicated there."""
    for r in range(BAB):
        row = start + r * stride
        cur[row + BAB] = 0
        cur[row + BAB + 1] = 0


# ----------------------------------------------------------------------------- encoder-side decisions

@njit(cache=True)
def _sum_128(values: np.ndarray, start: int) -> float:
    """NumPy's pairwise sum of 128 float64 values: 8 accumulators, then a balanced tree of them."""
    r0, r1, r2, r3 = values[start], values[start + 1], values[start + 2], values[start + 3]
    r4, r5, r6, r7 = values[start + 4], values[start + 5], values[start + 6], values[start + 7]
    for i in range(start + 8, start + 128, 8):
        r0 += values[i]
        r1 += values[i + 1]
        r2 += values[i + 2]
        r3 += values[i + 3]
        r4 += values[i + 4]
        r5 += values[i + 5]
        r6 += values[i + 6]
        r7 += values[i + 7]
    return ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))


@njit(cache=True)
def numpy_sum_256(values: np.ndarray) -> float:
    """np.sum of 256 contiguous float64 values, rounding for rounding (pairwise: 128 + 128)."""
    return 0.0 + (_sum_128(values, 0) + _sum_128(values, 128))


@njit(cache=True)
def estimate_cae_bits(frame: np.ndarray, y0: int, x0: int, cur: np.ndarray, prev: np.ndarray, stride: int,
                      border: int, inter: int, mv_x: int, mv_y: int, zeros: np.ndarray, ones: np.ndarray,
                      costs: np.ndarray, window: np.ndarray, bits: np.ndarray) -> float:
    """Approximate CAE cost in bits of the BAB of frame (padded (Hb, Wb) uint8) at pixel (y0, x0): intra
    (inter 0) or inter with motion vector (mv_x, mv_y). Pixels right of the BAB read as its last column;
    those above and left are the decoded canvas. window (BAB + 2, BAB + 4) and bits (BAB * BAB,) are scratch."""
    for r in range(BAB + 2):
        y = y0 - 2 + r
        for c in range(BAB + 4):
            x = x0 - 2 + c
            if r < 2 or c < 2:
                window[r, c] = cur[(y + border) * stride + x + border]
            elif c < BAB + 2:
                window[r, c] = frame[y, x]
            else:
                window[r, c] = frame[y, x0 + BAB - 1]
    for r in range(BAB):
        for c in range(BAB):
            wr, wc = r + 2, c + 2
            if inter:
                j = (y0 + mv_y + r + border) * stride + x0 + mv_x + c + border
                ctx = CTX_INTER + (window[wr, wc - 1] | window[wr - 1, wc + 1] << 1 | window[wr - 1, wc] << 2
                                   | window[wr - 1, wc - 1] << 3 | I(prev[j + stride]) << 4 | I(prev[j + 1]) << 5
                                   | I(prev[j]) << 6 | I(prev[j - 1]) << 7 | I(prev[j - stride]) << 8)
            else:
                ctx = (window[wr, wc - 1] | window[wr, wc - 2] << 1 | window[wr - 1, wc + 2] << 2
                       | window[wr - 1, wc + 1] << 3 | window[wr - 1, wc] << 4 | window[wr - 1, wc - 1] << 5
                       | window[wr - 1, wc - 2] << 6 | window[wr - 2, wc + 1] << 7 | window[wr - 2, wc] << 8
                       | window[wr - 2, wc - 1] << 9)
            if frame[y0 + r, x0 + c]:
                bits[r * BAB + c] = costs[ones[ctx], zeros[ctx]]
            else:
                bits[r * BAB + c] = costs[zeros[ctx], ones[ctx]]
    return numpy_sum_256(bits)


@njit(cache=True)
def row_words(prev: np.ndarray, words: np.ndarray) -> None:
    """words (prev.size,) uint16: [i] holds the 16 pixels prev[i .. i + 15] in bits 15 .. 0 (zeros past the end)."""
    n = prev.size
    word = 0
    for i in range(n - 1, -1, -1):
        word = (word >> 1) | (I(prev[i]) << 15)
        words[i] = word


@njit(cache=True)
def _popcount16(x: int) -> int:
    x = x - ((x >> 1) & 0x5555)
    x = (x & 0x3333) + ((x >> 2) & 0x3333)
    x = (x + (x >> 4)) & 0x0F0F
    return (x + (x >> 8)) & 0x1F


@njit(cache=True)
def motion_search(frame: np.ndarray, y0: int, x0: int, words: np.ndarray, stride: int, border: int,
                  pred_x: int, pred_y: int) -> tuple[int, int, int]:
    """(dx, dy, mismatches) of integer-pel block matching of the BAB at (y0, x0) against the previous frame
    (its row_words) over [-SEARCH_RANGE, SEARCH_RANGE]^2: fewest mismatching pixels, then nearest (L1) to the
    predictor, then first in raster order of (dy, dx)."""
    block = np.empty(BAB, np.int64)
    for r in range(BAB):
        word = 0
        for c in range(BAB):
            word = (word << 1) | I(frame[y0 + r, x0 + c])
        block[r] = word
    best_score, best_x, best_y, best_errors = 1 << 62, 0, 0, 0
    for dy in range(-SEARCH_RANGE, SEARCH_RANGE + 1):
        for dx in range(-SEARCH_RANGE, SEARCH_RANGE + 1):
            distance = abs(dx - pred_x) + abs(dy - pred_y)
            start = (y0 + dy + border) * stride + x0 + dx + border
            errors = 0
            for r in range(BAB):
                errors += _popcount16(I(words[start + r * stride]) ^ block[r])
                if errors * 64 + distance >= best_score:   # cannot win any more: ties keep the earlier one
                    break
            score = errors * 64 + distance
            if score < best_score:
                best_score, best_x, best_y, best_errors = score, dx, dy, errors
    return best_x, best_y, best_errors


# --------------------------------------------------------------------------------------------- frames

@njit(cache=True)
def _bounding_box(frame: np.ndarray) -> tuple[int, int, int, int]:
    """(by0, by1, bx0, bx1) BABs holding an opaque pixel, or by0 = -1 when none does."""
    height, width = frame.shape
    y_min, y_max, x_min, x_max = height, -1, width, -1
    for y in range(height):
        for x in range(width):
            if frame[y, x]:
                y_min = min(y_min, y)
                y_max = max(y_max, y)
                x_min = min(x_min, x)
                x_max = max(x_max, x)
    if y_max < 0:
        return -1, -1, -1, -1
    return y_min // BAB, y_max // BAB, x_min // BAB, x_max // BAB


# what the accounting charges (statistics only, see the end of this module)
COST_HEADER, COST_MODE, COST_MV, COST_INTRA, COST_INTER, COST_CR = 0, 1, 2, 3, 4, 5
N_COSTS = 6


@njit(cache=True)
def _decode_symbol(data: np.ndarray, regs: np.ndarray, zeros: np.ndarray, ones: np.ndarray, ctx: int,
                   costs: np.ndarray, category: int, charge: int) -> int:
    """decode(), and with charge the symbol's information -log2 p in bits added to costs[category]."""
    if not charge:
        return decode(data, regs, zeros, ones, ctx)
    p = p0(zeros, ones, ctx)
    bit = decode(data, regs, zeros, ones, ctx)
    costs[category] += -np.log2((65536 - p) / 65536.0) if bit else -np.log2(p / 65536.0)
    return bit


@njit(cache=True)
def _cae_pixels(buffer: np.ndarray, data: np.ndarray, regs: np.ndarray, zeros: np.ndarray, ones: np.ndarray,
                cur: np.ndarray, prev: np.ndarray, stride: int, start: int, shift: int, mode: int, encoding: int,
                frame: np.ndarray, y0: int, x0: int, costs: np.ndarray, pixel_hist: np.ndarray, charge: int) -> None:
    """The 256 intra or inter CAE pixels of the BAB at flat canvas index start (shift: the flat offset of the
    motion-compensated previous pixels), coded into buffer from frame's BAB at (y0, x0) (encoding), or decoded
    from data; either way written into cur. Decoding with charge, costs (N_COSTS,) and pixel_hist (2, N_CONTEXTS)
    get each pixel's information and value."""
    category = COST_INTRA if mode == INTRA_CAE else COST_INTER
    for r in range(BAB):
        row = start + r * stride
        for c in range(BAB):
            i = row + c
            if mode == INTRA_CAE:
                ctx = _intra_context(cur, i, stride)
            else:
                ctx = _inter_context(cur, prev, i, i + shift, stride)
            if encoding:
                cur[i] = encode(buffer, regs, zeros, ones, ctx, I(frame[y0 + r, x0 + c]))
            else:
                bit = _decode_symbol(data, regs, zeros, ones, ctx, costs, category, charge)
                cur[i] = bit
                if charge:
                    pixel_hist[bit, ctx] += 1
        cur[row + BAB] = cur[row + BAB + 1] = cur[row + BAB - 1]
    _clear_right(cur, stride, start)


@njit(cache=True)
def _block_errors(frame: np.ndarray, y0: int, x0: int, prev: np.ndarray, stride: int, border: int, mode: int,
                  mv_x: int, mv_y: int, alpha_th: int) -> int:
    """Pixels of the BAB at (y0, x0) that transparent, opaque or copy (at (mv_x, mv_y)) would get wrong, or -1
    when a 4x4 sub-block has more than alpha_th of them (the standard's alpha threshold test)."""
    total = 0
    for sy in range(0, BAB, 4):
        for sx in range(0, BAB, 4):
            errors = 0
            for r in range(sy, sy + 4):
                for c in range(sx, sx + 4):
                    if mode == COPY:
                        value = I(prev[(y0 + mv_y + r + border) * stride + x0 + mv_x + c + border])
                    else:
                        value = 1 if mode == OPAQUE else 0
                    errors += value ^ I(frame[y0 + r, x0 + c])
            if errors > alpha_th:
                return -1
            total += errors
    return total


# ------------------------------------------------------------------- size conversion (version 5: CR 1/2, 1/4)
# A coded BAB may be coded at CR 1/2 (8x8) or 1/4 (4x4), as MPEG-4's size conversion: a cell of f x f pixels is
# opaque when at least half of them are (2 of 4, 8 of 16); CAE codes the reduced BAB with templates over a
# reduced neighbourhood (the decoded canvas above and left reduced the same way; the motion-compensated previous
# shape too), and both ends upsample it back to 16x16 (_upsample). The upsampler is this coder's own, not the
# standard's: the standard's threshold table (grgchInterpolationFilterTh) is not reproduced.

@njit(cache=True)
def _canvas_cell(canvas: np.ndarray, stride: int, border: int, y: int, x: int, f: int) -> int:
    """1 when at least half of the f x f canvas pixels whose top-left is frame pixel (y, x) are opaque."""
    s = 0
    for r in range(f):
        base = (y + r + border) * stride + x + border
        for c in range(f):
            s += I(canvas[base + c])
    return 1 if 2 * s >= f * f else 0


@njit(cache=True)
def _downsample(frame: np.ndarray, y0: int, x0: int, f: int, small: np.ndarray) -> None:
    """small[:n, :n] (n = BAB / f): the frame's BAB at (y0, x0) reduced by f (a cell opaque when >= half is)."""
    n = BAB // f
    for r in range(n):
        for c in range(n):
            s = 0
            for rr in range(f):
                for cc in range(f):
                    s += I(frame[y0 + r * f + rr, x0 + c * f + cc])
            small[r, c] = 1 if 2 * s >= f * f else 0


@njit(cache=True)
def _reduced_border(cur: np.ndarray, stride: int, border: int, y0: int, x0: int, f: int, grid: np.ndarray,
                    rows: int) -> None:
    """The 2 reduced rows above (cells -2..n+1) and the 2 reduced columns left of rows 0..rows-1 of the BAB at
    (y0, x0), from the decoded canvas reduced by f, into grid[r + 2, c + 2]."""
    n = BAB // f
    for r in range(-2, 0):
        for c in range(-2, n + 2):
            grid[r + 2, c + 2] = _canvas_cell(cur, stride, border, y0 + r * f, x0 + c * f, f)
    for r in range(rows):
        for c in range(-2, 0):
            grid[r + 2, c + 2] = _canvas_cell(cur, stride, border, y0 + r * f, x0 + c * f, f)


@njit(cache=True)
def _upsample_stage(grid: np.ndarray, m: int, out: np.ndarray) -> None:
    """out[:2m, :2m] from grid (m + 4, m + 4): an m x m reduced BAB at grid[2:m+2, 2:m+2] with its 2-cell ring
    (above and left decoded, right and below replicated). Each reduced pixel P gives a 2x2 block; the pixel of
    quadrant (dy, dx) weighs the 2x2 of reduced pixels towards its quadrant (P x 4, the other three x 2) and the
    8 pixels around that 2x2 (corners excluded) x 1, and is opaque above UPSAMPLE_TH (ties go to P)."""
    for i in range(m):
        for j in range(m):
            gi, gj = i + 2, j + 2
            p = grid[gi, gj]
            for a in range(2):
                dy = 1 if a else -1
                for b in range(2):
                    dx = 1 if b else -1
                    s = 4 * p + 2 * (grid[gi, gj + dx] + grid[gi + dy, gj] + grid[gi + dy, gj + dx])
                    s += grid[gi - dy, gj] + grid[gi - dy, gj + dx] + grid[gi + 2 * dy, gj] + grid[gi + 2 * dy, gj + dx]
                    s += grid[gi, gj - dx] + grid[gi + dy, gj - dx] + grid[gi, gj + 2 * dx] + grid[gi + dy, gj + 2 * dx]
                    out[2 * i + a, 2 * j + b] = 1 if s > UPSAMPLE_TH or (s == UPSAMPLE_TH and p) else 0


@njit(cache=True)
def _upsample(cur: np.ndarray, stride: int, border: int, y0: int, x0: int, f: int, small: np.ndarray,
              grid: np.ndarray, half: np.ndarray, up: np.ndarray) -> None:
    """up (BAB, BAB): the reduced BAB small[:n, :n] (n = BAB / f) upsampled by f, in 2x stages (CR 1/4 twice),
    each stage's ring above and left read from the decoded canvas reduced to its scale. Scratch: grid
    (BAB / 2 + 4, BAB / 2 + 4), half (BAB / 2, BAB / 2)."""
    source = small
    g = f
    while g > 1:
        m = BAB // g
        _reduced_border(cur, stride, border, y0, x0, g, grid, m)
        for r in range(m):
            for c in range(m):
                grid[r + 2, c + 2] = source[r, c]
            grid[r + 2, m + 2] = grid[r + 2, m + 3] = source[r, m - 1]
        for r in range(m + 2, m + 4):
            for c in range(m + 4):
                grid[r, c] = grid[m + 1, c]
        target = up if g == 2 else half
        _upsample_stage(grid, m, target)
        source = half
        g //= 2


@njit(cache=True)
def _up_errors(frame: np.ndarray, y0: int, x0: int, up: np.ndarray, alpha_th: int) -> int:
    """Pixels of up (BAB, BAB) unlike the frame's BAB at (y0, x0), or -1 when a 4x4 sub-block has more than
    alpha_th of them."""
    total = 0
    for sy in range(0, BAB, 4):
        for sx in range(0, BAB, 4):
            errors = 0
            for r in range(sy, sy + 4):
                for c in range(sx, sx + 4):
                    errors += I(up[r, c]) ^ I(frame[y0 + r, x0 + c])
            if errors > alpha_th:
                return -1
            total += errors
    return total


@njit(cache=True)
def _reduced_prediction(prev: np.ndarray, stride: int, border: int, y0: int, x0: int, mv_x: int, mv_y: int,
                        f: int, pred: np.ndarray) -> None:
    """pred[r + 1, c + 1], r, c in -1..n: the motion-compensated previous shape reduced by f (inter CAE at CR < 1)."""
    n = BAB // f
    for r in range(-1, n + 1):
        for c in range(-1, n + 1):
            pred[r + 1, c + 1] = _canvas_cell(prev, stride, border, y0 + mv_y + r * f, x0 + mv_x + c * f, f)


@njit(cache=True)
def _reduced_context(grid: np.ndarray, pred: np.ndarray, r: int, c: int, mode: int) -> int:
    """The pixel context of reduced cell (r, c): grid holds the reduced BAB at [r + 2, c + 2] with its ring,
    pred the reduced motion-compensated shape at [r + 1, c + 1]; the full-size templates, in their own contexts."""
    wr, wc = r + 2, c + 2
    if mode == INTRA_CAE:
        return CTX_INTRA_LOW + (grid[wr, wc - 1] | grid[wr, wc - 2] << 1 | grid[wr - 1, wc + 2] << 2
                                | grid[wr - 1, wc + 1] << 3 | grid[wr - 1, wc] << 4 | grid[wr - 1, wc - 1] << 5
                                | grid[wr - 1, wc - 2] << 6 | grid[wr - 2, wc + 1] << 7 | grid[wr - 2, wc] << 8
                                | grid[wr - 2, wc - 1] << 9)
    pr, pc = r + 1, c + 1
    return CTX_INTER_LOW + (grid[wr, wc - 1] | grid[wr - 1, wc + 1] << 1 | grid[wr - 1, wc] << 2
                            | grid[wr - 1, wc - 1] << 3 | pred[pr + 1, pc] << 4 | pred[pr, pc + 1] << 5
                            | pred[pr, pc] << 6 | pred[pr, pc - 1] << 7 | pred[pr - 1, pc] << 8)


@njit(cache=True)
def _cae_reduced(buffer: np.ndarray, data: np.ndarray, regs: np.ndarray, zeros: np.ndarray, ones: np.ndarray,
                 cur: np.ndarray, prev: np.ndarray, stride: int, border: int, y0: int, x0: int, mv_x: int, mv_y: int,
                 f: int, mode: int, encoding: int, small: np.ndarray, grid: np.ndarray, pred: np.ndarray,
                 costs: np.ndarray, pixel_hist: np.ndarray, charge: int) -> None:
    """The (BAB / f)^2 CAE pixels of a reduced BAB: coded from small (encoding) or decoded into it. Pixels right
    of the reduced BAB that are not decoded yet read as its last decoded column, as at full size."""
    n = BAB // f
    category = COST_INTRA if mode == INTRA_CAE else COST_INTER
    _reduced_border(cur, stride, border, y0, x0, f, grid, n)
    if mode == INTER_CAE:
        _reduced_prediction(prev, stride, border, y0, x0, mv_x, mv_y, f, pred)
    for r in range(n):
        for c in range(n):
            ctx = _reduced_context(grid, pred, r, c, mode)
            if encoding:
                bit = encode(buffer, regs, zeros, ones, ctx, I(small[r, c]))
            else:
                bit = _decode_symbol(data, regs, zeros, ones, ctx, costs, category, charge)
                small[r, c] = bit
                if charge:
                    pixel_hist[bit, ctx] += 1
            grid[r + 2, c + 2] = bit
        grid[r + 2, n + 2] = grid[r + 2, n + 3] = grid[r + 2, n + 1]


@njit(cache=True)
def _cr_context(crs: np.ndarray, by: int, bx: int, mode: int) -> int:
    left = crs[by, bx - 1] if bx > 0 else CR_FULL
    return CTX_CR + ((1 if mode == INTER_CAE else 0) * 3 + left) * 2


@njit(cache=True)
def _write_block(cur: np.ndarray, stride: int, start: int, up: np.ndarray) -> None:
    for r in range(BAB):
        for c in range(BAB):
            cur[start + r * stride + c] = up[r, c]


@njit(cache=True)
def encode_frame(frame: np.ndarray, cur: np.ndarray, prev: np.ndarray, stride: int, border: int,
                 modes: np.ndarray, previous_modes: np.ndarray, mvs: np.ndarray, has_mv: np.ndarray,
                 zeros: np.ndarray, ones: np.ndarray, buffer: np.ndarray, regs: np.ndarray, counts: np.ndarray,
                 inter: int, costs: np.ndarray, words: np.ndarray, alpha_th: int, budget: int,
                 box: np.ndarray, predict_box: int, crs: np.ndarray, cr_counts: np.ndarray, use_cr: int,
                 cr_lambda: float) -> int:
    """Code one frame (padded (blocks_y * BAB, blocks_x * BAB) uint8 mask) into buffer, writing the decoded
    result into cur (flat canvas) and modes / mvs / has_mv; counts (5,) gets the modes used. The caller
    leaves room in buffer for BITS_PER_SYMBOL x (SYMBOLS_PER_FRAME + SYMBOLS_PER_BLOCK x blocks) bits.
    Lossy shape (alpha_th > 0, the standard's alpha threshold): a BAB is coded transparent, opaque or copied
    when none of its 4x4 sub-blocks has more than alpha_th wrong pixels and the frame's wrong pixels stay
    <= budget. box (5,) int64: (present, by0, by1, bx0, bx1) of the previous frame, replaced by this one's;
    predict_box (version 3): a predicted frame whose box is the previous frame's says so in one flag.
    use_cr (version 5): every intra / inter CAE BAB codes its conversion ratio (crs (blocks_y, blocks_x) int64
    gets it, cr_counts (3,) counts them); lossy, the encoder tries CR 1/4, then 1/2, and takes the first whose
    upsampled BAB passes the alpha threshold test within the frame's budget, as the standard's encoder, and
    (unlike it) whose wrong pixels x cr_lambda stay within the bits it saves (estimated: the full-size CAE
    estimate x (1 - 1 / f^2)): the budget is shared with the transparent / opaque / copy decisions, which save
    more bits per wrong pixel.
    Returns the frame's wrong pixels."""
    blocks_y, blocks_x = modes.shape
    by0, by1, bx0, bx1 = _bounding_box(frame)
    flagged = predict_box != 0 and inter != 0 and box[0] == 1
    same = box[1] == by0 and box[2] == by1 and box[3] == bx0 and box[4] == bx1
    box[0], box[1], box[2], box[3], box[4] = (1 if by0 >= 0 else 0), by0, by1, bx0, bx1
    if not encode(buffer, regs, zeros, ones, CTX_PRESENT, 1 if by0 >= 0 else 0):
        return 0
    if not (flagged and encode(buffer, regs, zeros, ones, CTX_SAME_BOX, 1 if same else 0)):
        nby, nbx = _bits_for(blocks_y), _bits_for(blocks_x)
        encode_raw(buffer, regs, by0, nby)
        encode_raw(buffer, regs, by1, nby)
        encode_raw(buffer, regs, bx0, nbx)
        encode_raw(buffer, regs, bx1, nbx)
    order = _mode_order(inter)
    window = np.zeros((BAB + 2, BAB + 4), np.int64)
    bits = np.zeros(BAB * BAB, np.float64)
    no_costs, no_hist = np.zeros(N_COSTS), np.zeros((2, 1), np.int64)
    small = np.zeros((BAB // 2, BAB // 2), np.int64)
    half = np.zeros((BAB // 2, BAB // 2), np.int64)
    grid = np.zeros((BAB // 2 + 4, BAB // 2 + 4), np.int64)
    pred = np.zeros((BAB // 2 + 2, BAB // 2 + 2), np.int64)
    up = np.zeros((BAB, BAB), np.int64)
    wrong = 0
    if inter:
        row_words(prev, words)
    for by in range(by0, by1 + 1):
        for bx in range(bx0, bx1 + 1):
            y0, x0 = by * BAB, bx * BAB
            start = (y0 + border) * stride + x0 + border
            # the mode decision: uniform BABs are transparent / opaque; in predicted frames an exact match of the
            # motion-compensated previous shape is copied, else inter or intra CAE, whichever the estimate favours.
            # Lossy, a BAB within the alpha threshold (and the frame's budget) is transparent, opaque or copied.
            opaque = 0
            for r in range(BAB):
                for c in range(BAB):
                    opaque += I(frame[y0 + r, x0 + c])
            mode, mv_x, mv_y, errors = INTRA_CAE, 0, 0, -1
            if opaque == 0:
                mode = TRANSPARENT
            elif opaque == BAB * BAB:
                mode = OPAQUE
            else:
                if alpha_th > 0:
                    uniform = OPAQUE if 2 * opaque > BAB * BAB else TRANSPARENT
                    errors = _block_errors(frame, y0, x0, prev, stride, border, uniform, 0, 0, alpha_th)
                    if 0 <= errors <= budget - wrong:
                        mode = uniform
                        wrong += errors
                if mode == INTRA_CAE and inter:
                    pred_x, pred_y = _mv_predictor(mvs, has_mv, by, bx)
                    if alpha_th > 0:
                        errors = _block_errors(frame, y0, x0, prev, stride, border, COPY, pred_x, pred_y, alpha_th)
                    if 0 < errors <= budget - wrong:
                        mode, mv_x, mv_y = COPY, pred_x, pred_y
                        wrong += errors
                    else:
                        mv_x, mv_y, errors = motion_search(frame, y0, x0, words, stride, border, pred_x, pred_y)
                        if errors > 0:
                            if alpha_th > 0:
                                errors = _block_errors(frame, y0, x0, prev, stride, border, COPY, mv_x, mv_y,
                                                       alpha_th)
                            if alpha_th == 0 or errors > budget - wrong:
                                errors = -1
                        if errors >= 0:
                            mode = COPY
                            wrong += errors
                        else:
                            mv_bits = 2.0 + 2.0 * (abs(mv_x - pred_x) + abs(mv_y - pred_y))
                            inter_bits = estimate_cae_bits(frame, y0, x0, cur, prev, stride, border, 1, mv_x, mv_y,
                                                           zeros, ones, costs, window, bits) + mv_bits
                            intra_bits = estimate_cae_bits(frame, y0, x0, cur, prev, stride, border, 0, 0, 0,
                                                           zeros, ones, costs, window, bits)
                            if inter_bits < intra_bits:
                                mode = INTER_CAE
                            else:
                                mode, mv_x, mv_y = INTRA_CAE, 0, 0
            # the mode, as binary decisions along `order`
            ctx0 = _mode_context(modes, previous_modes, by, bx, inter)
            for position in range(order.size - 1):
                if encode(buffer, regs, zeros, ones, ctx0 + position, 1 if mode == order[position] else 0):
                    break
            if mode == COPY or mode == INTER_CAE:
                pred_x, pred_y = _mv_predictor(mvs, has_mv, by, bx)
                _encode_mv_component(buffer, regs, zeros, ones, 0, mv_x - pred_x)
                _encode_mv_component(buffer, regs, zeros, ones, 1, mv_y - pred_y)
                mvs[by, bx, 0], mvs[by, bx, 1], has_mv[by, bx] = mv_x, mv_y, 1
            modes[by, bx] = mode
            counts[mode] += 1
            shift = mv_y * stride + mv_x
            cr = CR_FULL
            if use_cr and (mode == INTRA_CAE or mode == INTER_CAE):
                if alpha_th > 0:
                    full_bits = estimate_cae_bits(frame, y0, x0, cur, prev, stride, border,
                                                  1 if mode == INTER_CAE else 0, mv_x, mv_y, zeros, ones, costs,
                                                  window, bits)
                    for candidate in (CR_QUARTER, CR_HALF):
                        f = CR_FACTOR[candidate]
                        _downsample(frame, y0, x0, f, small)
                        _upsample(cur, stride, border, y0, x0, f, small, grid, half, up)
                        errors = _up_errors(frame, y0, x0, up, alpha_th)
                        saving = full_bits * (1.0 - 1.0 / (f * f))
                        if 0 <= errors <= budget - wrong and errors * cr_lambda <= saving:
                            cr = candidate
                            wrong += errors
                            break
                ctx = _cr_context(crs, by, bx, mode)
                if encode(buffer, regs, zeros, ones, ctx, 1 if cr != CR_FULL else 0):
                    encode(buffer, regs, zeros, ones, ctx + 1, 1 if cr == CR_QUARTER else 0)
                crs[by, bx] = cr
                cr_counts[cr] += 1
            if cr != CR_FULL:
                _cae_reduced(buffer, buffer, regs, zeros, ones, cur, prev, stride, border, y0, x0, mv_x, mv_y,
                             CR_FACTOR[cr], mode, 1, small, grid, pred, no_costs, no_hist, 0)
                _write_block(cur, stride, start, up)
            elif mode == INTRA_CAE or mode == INTER_CAE:
                _cae_pixels(buffer, buffer, regs, zeros, ones, cur, prev, stride, start, shift, mode, 1, frame, y0, x0,
                            no_costs, no_hist, 0)
            else:
                _fill_block(cur, prev, stride, start, mode, shift)
    return wrong


@njit(cache=True)
def _encode_mv_component(buffer: np.ndarray, regs: np.ndarray, zeros: np.ndarray, ones: np.ndarray,
                         component: int, value: int) -> None:
    """A motion-vector difference: nonzero flag, sign, then unary magnitude bins (the last 8+ share one)."""
    base = CTX_MV + component * 10
    if not encode(buffer, regs, zeros, ones, base, 1 if value != 0 else 0):
        return
    encode(buffer, regs, zeros, ones, base + 1, 1 if value < 0 else 0)
    magnitude, limit = 1, 2 * SEARCH_RANGE
    while magnitude < limit and encode(buffer, regs, zeros, ones, base + 2 + min(magnitude - 1, 7),
                                       1 if abs(value) > magnitude else 0):
        magnitude += 1


@njit(cache=True)
def _decode_mv_component(data: np.ndarray, regs: np.ndarray, zeros: np.ndarray, ones: np.ndarray,
                         component: int, costs: np.ndarray, charge: int) -> int:
    base = CTX_MV + component * 10
    if not _decode_symbol(data, regs, zeros, ones, base, costs, COST_MV, charge):
        return 0
    negative = _decode_symbol(data, regs, zeros, ones, base + 1, costs, COST_MV, charge)
    magnitude, limit = 1, 2 * SEARCH_RANGE
    while magnitude < limit and _decode_symbol(data, regs, zeros, ones, base + 2 + min(magnitude - 1, 7), costs,
                                               COST_MV, charge):
        magnitude += 1
    return -magnitude if negative else magnitude


@njit(cache=True)
def _decode_frame(data: np.ndarray, regs: np.ndarray, cur: np.ndarray, prev: np.ndarray, stride: int,
                  border: int, modes: np.ndarray, previous_modes: np.ndarray, mvs: np.ndarray, has_mv: np.ndarray,
                  zeros: np.ndarray, ones: np.ndarray, counts: np.ndarray, inter: int, box: np.ndarray,
                  predict_box: int, costs: np.ndarray, pixel_hist: np.ndarray, mv_blocks: np.ndarray,
                  charge: int, crs: np.ndarray, cr_counts: np.ndarray, use_cr: int) -> int:
    """decode_frame; with charge also account_frame's statistics."""
    blocks_y, blocks_x = modes.shape
    flagged = predict_box != 0 and inter != 0 and box[0] == 1
    box[0] = 0
    present = _decode_symbol(data, regs, zeros, ones, CTX_PRESENT, costs, COST_HEADER, charge)
    if regs[STATUS] != OK or not present:
        return regs[STATUS]
    if flagged and _decode_symbol(data, regs, zeros, ones, CTX_SAME_BOX, costs, COST_HEADER, charge):
        by0, by1, bx0, bx1 = box[1], box[2], box[3], box[4]
    else:
        nby, nbx = _bits_for(blocks_y), _bits_for(blocks_x)
        by0 = decode_raw(data, regs, nby)
        by1 = decode_raw(data, regs, nby)
        bx0 = decode_raw(data, regs, nbx)
        bx1 = decode_raw(data, regs, nbx)
        costs[COST_HEADER] += 2 * (nby + nbx)
    if regs[STATUS] != OK:
        return regs[STATUS]
    if not (by0 <= by1 < blocks_y and bx0 <= bx1 < blocks_x):
        return BAD_BOX
    box[0], box[1], box[2], box[3], box[4] = 1, by0, by1, bx0, bx1
    order = _mode_order(inter)
    no_frame = np.zeros((1, 1), np.uint8)
    small = np.zeros((BAB // 2, BAB // 2), np.int64)
    half = np.zeros((BAB // 2, BAB // 2), np.int64)
    grid = np.zeros((BAB // 2 + 4, BAB // 2 + 4), np.int64)
    pred = np.zeros((BAB // 2 + 2, BAB // 2 + 2), np.int64)
    up = np.zeros((BAB, BAB), np.int64)
    for by in range(by0, by1 + 1):
        for bx in range(bx0, bx1 + 1):
            y0, x0 = by * BAB, bx * BAB
            start = (y0 + border) * stride + x0 + border
            ctx0 = _mode_context(modes, previous_modes, by, bx, inter)
            mode = order[order.size - 1]
            for position in range(order.size - 1):
                if _decode_symbol(data, regs, zeros, ones, ctx0 + position, costs, COST_MODE, charge):
                    mode = order[position]
                    break
            mv_x, mv_y = 0, 0
            if mode == COPY or mode == INTER_CAE:
                pred_x, pred_y = _mv_predictor(mvs, has_mv, by, bx)
                dx = _decode_mv_component(data, regs, zeros, ones, 0, costs, charge)
                dy = _decode_mv_component(data, regs, zeros, ones, 1, costs, charge)
                mv_x, mv_y = pred_x + dx, pred_y + dy
                if regs[STATUS] != OK:
                    return regs[STATUS]
                if abs(mv_x) > SEARCH_RANGE or abs(mv_y) > SEARCH_RANGE:
                    return BAD_MV
                mvs[by, bx, 0], mvs[by, bx, 1], has_mv[by, bx] = mv_x, mv_y, 1
                mv_blocks[0] += 1
                if dx != 0 or dy != 0:
                    mv_blocks[1] += 1
            if regs[STATUS] != OK:
                return regs[STATUS]
            modes[by, bx] = mode
            counts[mode] += 1
            shift = mv_y * stride + mv_x
            cr = CR_FULL
            if use_cr and (mode == INTRA_CAE or mode == INTER_CAE):
                ctx = _cr_context(crs, by, bx, mode)
                if _decode_symbol(data, regs, zeros, ones, ctx, costs, COST_CR, charge):
                    cr = CR_QUARTER if _decode_symbol(data, regs, zeros, ones, ctx + 1, costs, COST_CR, charge) \
                        else CR_HALF
                if regs[STATUS] != OK:
                    return regs[STATUS]
                crs[by, bx] = cr
                cr_counts[cr] += 1
            if cr != CR_FULL:
                f = CR_FACTOR[cr]
                _cae_reduced(no_frame[0], data, regs, zeros, ones, cur, prev, stride, border, y0, x0, mv_x, mv_y, f,
                             mode, 0, small, grid, pred, costs, pixel_hist, charge)
                if regs[STATUS] != OK:
                    return regs[STATUS]
                _upsample(cur, stride, border, y0, x0, f, small, grid, half, up)
                _write_block(cur, stride, start, up)
            elif mode == INTRA_CAE or mode == INTER_CAE:
                _cae_pixels(no_frame[0], data, regs, zeros, ones, cur, prev, stride, start, shift, mode, 0, no_frame, 0,
                            0, costs, pixel_hist, charge)
                if regs[STATUS] != OK:
                    return regs[STATUS]
            else:
                _fill_block(cur, prev, stride, start, mode, shift)
    return OK


@njit(cache=True)
def decode_frame(data: np.ndarray, regs: np.ndarray, cur: np.ndarray, prev: np.ndarray, stride: int,
                 border: int, modes: np.ndarray, previous_modes: np.ndarray, mvs: np.ndarray, has_mv: np.ndarray,
                 zeros: np.ndarray, ones: np.ndarray, counts: np.ndarray, inter: int, box: np.ndarray,
                 predict_box: int, crs: np.ndarray, cr_counts: np.ndarray, use_cr: int) -> int:
    """Decode one frame from the payload into cur (flat canvas), modes, mvs, has_mv, box, crs (as encode_frame's);
    counts (5,) gets the modes, cr_counts (3,) the conversion ratios. Returns OK, or the first error met: PAYLOAD_ENDS, BAD_BOX, BAD_MV (nothing is
    read or written outside the canvas after an error)."""
    return _decode_frame(data, regs, cur, prev, stride, border, modes, previous_modes, mvs, has_mv, zeros, ones,
                         counts, inter, box, predict_box, np.zeros(N_COSTS), np.zeros((2, 1), np.int64),
                         np.zeros(2, np.int64), 0, crs, cr_counts, use_cr)


# ------------------------------------------------------------------------------------- accounting (statistics only)
# Where a stream's bits go (benchmarks/shape_coding.py): decode_frame again, charging each decoded symbol its
# information, -log2 of the probability the model gave it, to a COST_* category. Nothing here writes a stream.

@njit(cache=True)
def account_frame(data: np.ndarray, regs: np.ndarray, cur: np.ndarray, prev: np.ndarray, stride: int,
                  border: int, modes: np.ndarray, previous_modes: np.ndarray, mvs: np.ndarray, has_mv: np.ndarray,
                  zeros: np.ndarray, ones: np.ndarray, counts: np.ndarray, inter: int, box: np.ndarray,
                  predict_box: int, costs: np.ndarray, pixel_hist: np.ndarray, mv_blocks: np.ndarray,
                  crs: np.ndarray, cr_counts: np.ndarray, use_cr: int) -> int:
    """decode_frame, and: costs (N_COSTS,) float64 gets each symbol's information in bits by category (the box's
    raw bits count 1 each); pixel_hist (2, N_CONTEXTS) int64 counts the decoded pixel values per context (for
    the cost of a model that had known the statistics: the learning cost); mv_blocks (2,) int64 counts the
    blocks with a motion vector and those whose vector differs from its prediction."""
    return _decode_frame(data, regs, cur, prev, stride, border, modes, previous_modes, mvs, has_mv, zeros, ones,
                         counts, inter, box, predict_box, costs, pixel_hist, mv_blocks, 1, crs, cr_counts, use_cr)

"""Coding machinery shared by the FBA and BBA streams: quantisation, range fields, predictive
frames with adaptive arithmetic coding, and 16-frame DCT segments with fixed VLC tables.

Parameters are integer time series (T, P) (BAP units, or BBA values in the same units), each
with an integer base quantisation step; the global Q (1..31) multiplies it (seed 004 "BAP
Coding": Quantum(i) x Global_Quantization_Value).

Predictive (seed 000 §2.1 Fig. 2.8; mpeg4-facts.md §2.3-2.5): an intra frame codes each masked
value's level quant(v, step) with that parameter's intra model; a P frame codes
quant(v - previous decoded value, step) with its P model. Levels are arithmetic-coded as
symbol = level - range_min over the alphabet [range_min, range_max], which an intra frame sends
as `ceil(|bound| / 60)` fields in base-step units (RANGE_DELTA 60, visage FBAEncoder.cpp).
Chosen here: 7-bit range fields instead of the standard's 5 bits, so every angle in (-pi, pi]
fits at every Q (5 bits cap |level x Q| at 1860 base steps: +-68 degrees for step 64). Levels are
never clipped: a P residual beyond `level_limit` (an angle crossing +-pi is a 2 pi jump, more than
a step-64 BAP's 7620 levels at Q = 1) ends the intra period there, and the coder starts a new
intra plane at that frame (`fitting_frames`); an intra level beyond it cannot be sent at all.

DCT (seed 000 §2.1 Fig. 2.9, §2.4.2): per parameter, segments of 16 frames, orthonormal DCT-II;
DC step = base step x Q, AC step = base step x Q / 3; the DC level of an inter segment is
predicted from the previous segment's; JPEG-style size categories (category = bit length of
|level|, then sign and the low bits) coded with Huffman tables designed offline from training
data (tools/train_param_vlc.py) and shipped in comparisons/tables/param_vlc.json.

Speed: LevelFrames codes every frame of an intra period (and its plane headers) in one kernel call
(comparisons/params/frames.py), the same bits as one write_levels call per track per frame; range fields and
closed-loop levels are kernels too.
"""
from __future__ import annotations

import functools
import json
from pathlib import Path

import numpy as np

from comparisons.params.bits import BitReader, BitWriter
from comparisons.params.entropy import (
    MAX_TOTAL,
    CanonicalHuffman,
    ModelBank,
    decode_frame,
    encode_frame,
)
from comparisons.params import arithmetic as kc
from comparisons.params import frames as pf
from media.domain import check_q  # noqa: F401  (the FBA/BBA coders call pc.check_q)
from media.errors import SigncastError

RANGE_DELTA = 60
RANGE_BITS = 7
MAX_RANGE_FIELD = (1 << RANGE_BITS) - 1
DEFAULT_RANGE_FIELD = 31                     # visage default +-1859 (FBACodingParameters.h)
SEGMENT = 16
N_CATEGORIES = 21                            # categories 0..20
MAX_RUN = SEGMENT - 2                        # runs of zero AC coefficients 0..14
AC_EOB = 0
TABLE_PATH = Path(__file__).resolve().parents[1] / "tables" / "param_vlc.json"


def quantize(values: np.ndarray, step: np.ndarray) -> np.ndarray:
    """Level 0 if |v| <= step/2, else sign(v) (|v| + step//2) // step (visage quant())."""
    values = np.asarray(values, dtype=np.int64)
    step = np.asarray(step, dtype=np.int64)
    magnitude = (np.abs(values) + step // 2) // step
    magnitude = np.where(2 * np.abs(values) <= step, 0, magnitude)
    return np.sign(values) * magnitude


# --------------------------------------------------------------------------- predictive frames

def level_limit(q: int) -> int:
    """Largest |level| a 7-bit range field can announce at this Q."""
    return MAX_RANGE_FIELD * RANGE_DELTA // q


def predictive_levels(values: np.ndarray, held: np.ndarray, steps: np.ndarray, q: int):
    """Levels of one intra period of masked parameters, closed loop, unclipped.

    values: (T >= 1, P) int64; held: (P,) decoder values before the period (unused here: intra levels
    are absolute); steps: (P,) effective steps. Returns intra (P,), p_levels (T-1, P) and the
    decoder's reconstruction (T, P). Levels may exceed level_limit(q): callers send only the
    first `fitting_frames` frames in this period."""
    values = np.asarray(values, dtype=np.int64)
    steps = np.ascontiguousarray(np.broadcast_to(np.asarray(steps, dtype=np.int64), values.shape[1:]))
    return pf.predictive_levels(values, steps)


def fitting_frames(p_levels: np.ndarray, q: int) -> int:
    """Frames of an intra period the range fields can carry: the intra frame and the P frames
    before the first one with a residual level beyond level_limit(q). p_levels: (T-1, P)."""
    too_large = np.flatnonzero(np.any(np.abs(p_levels) > level_limit(q), axis=1))
    return 1 + (int(too_large[0]) if len(too_large) else len(p_levels))


def range_fields(levels: np.ndarray, q: int) -> tuple[np.ndarray, np.ndarray]:
    """(max_field, min_field) per parameter: smallest fields whose alphabet holds the levels (N, P)."""
    if len(levels) == 0:
        zero = np.zeros(levels.shape[1], dtype=np.int64)
        return zero, zero
    top = np.maximum(levels.max(axis=0), 0)
    bottom = np.maximum(-levels.min(axis=0), 0)
    return -(-top * q // RANGE_DELTA), -(-bottom * q // RANGE_DELTA)


def alphabet(max_field: np.ndarray, min_field: np.ndarray, q: int) -> tuple[np.ndarray, np.ndarray]:
    """(range_min, range_max) levels announced by the fields."""
    return -(np.asarray(min_field) * RANGE_DELTA // q), np.asarray(max_field) * RANGE_DELTA // q


def write_range_fields(writer: BitWriter, fields: np.ndarray) -> None:
    """fields: (4, P) I max, I min, P max, P min; a marker bit before every 4 parameters."""
    fields = np.ascontiguousarray(fields, dtype=np.int64).reshape(4, -1)
    bad = np.flatnonzero((fields < 0) | (fields > MAX_RANGE_FIELD))
    if len(bad):
        raise SigncastError(f"value {int(fields.flat[bad[0]])} does not fit in {RANGE_BITS} bits")
    writer.reserve(fields.size * (RANGE_BITS + 1))
    pf.write_range_fields(writer.buffer, writer.state, fields, RANGE_BITS)


def read_range_fields(reader: BitReader, n: int) -> np.ndarray:
    """(4, n) int64 fields of write_range_fields; SigncastError on truncated data or a missing marker."""
    fields = np.zeros((4, n), dtype=np.int64)
    status = pf.read_range_fields(reader.array, reader.end_bit, reader.registers, fields, RANGE_BITS)
    if status == pf.END_OF_DATA:
        raise SigncastError("truncated stream: it ends inside a field")
    if status:
        raise SigncastError("corrupt stream: missing marker bit in the range fields")
    return fields


def make_models(low: np.ndarray, high: np.ndarray) -> ModelBank:
    """One adaptive model per parameter over its alphabet [low, high] (levels)."""
    return ModelBank(np.asarray(high, dtype=np.int64) - np.asarray(low, dtype=np.int64) + 1)


def write_levels(writer: BitWriter, levels: np.ndarray, models: ModelBank, low: np.ndarray) -> None:
    """One frame's levels, arithmetic-coded and flushed. Nothing is written when every alphabet
    has a single symbol (the decoder knows the levels already)."""
    if np.all(models.member_sizes() == 1):
        return
    encode_frame(writer, models, np.asarray(levels, dtype=np.int64) - low)


def read_levels(reader: BitReader, models: ModelBank, low: np.ndarray) -> np.ndarray:
    if np.all(models.member_sizes() == 1):
        return np.asarray(low, dtype=np.int64).copy()
    return decode_frame(reader, models) + low


class LevelFrames:
    """Adaptive models (one per coded parameter, as make_models: all counts 1, +1 per coded symbol,
    halved above entropy.MAX_TOTAL) of one or more tracks of levels whose frames are coded together:
    per frame, each track's levels from a fresh arithmetic coder, so the bits are those of one
    write_levels call per track per frame (the kernels do them all in one call).

    low, high: (P,) alphabets of the tracks' parameters, concatenated; track_starts: (K + 1,) int64,
    track k's columns track_starts[k]:track_starts[k + 1]. The models are comparisons/params/frames.py
    banks (excess form, allocated zeroed). once: the models code a single frame (an intra frame), so
    they are never updated and need no arrays of counts."""

    def __init__(self, low: np.ndarray, high: np.ndarray, track_starts, once: bool = False) -> None:
        self.low = np.ascontiguousarray(low, dtype=np.int64)
        self.high = np.ascontiguousarray(high, dtype=np.int64)
        self.track_starts = np.ascontiguousarray(track_starts, dtype=np.int64)
        sizes = self.high - self.low + 1
        if np.any(sizes < 1):
            raise SigncastError(f"an alphabet needs at least one symbol, got {int(sizes.min())}")
        if np.any(sizes > MAX_TOTAL // 2):
            raise SigncastError(f"alphabet of {int(sizes.max())} symbols is too large for a frequency "
                                f"limit of {MAX_TOTAL}")
        offsets, scalars = pf.new_scalars(sizes, MAX_TOTAL)
        total = 0 if once else int(offsets[-1])
        self.once = once
        self.used = False
        self.arrays = (sizes, offsets, np.zeros(total, dtype=np.int64), np.zeros(total + len(sizes), dtype=np.int64),
                       scalars, np.arange(len(sizes), dtype=np.int64))

    def track(self, k: int) -> LevelFrames:
        """Track k alone, sharing its models (coding through either updates both)."""
        a, b = int(self.track_starts[k]), int(self.track_starts[k + 1])
        view = LevelFrames.__new__(LevelFrames)
        view.low, view.high = self.low[a:b], self.high[a:b]
        view.track_starts = np.array([0, b - a], dtype=np.int64)
        view.arrays = (*self.arrays[:5], self.arrays[5][a:b])
        view.once, view.used = self.once, self.used
        return view

    def bank_arrays(self) -> tuple:
        """The kernels' view: sizes (M,), offsets, counts, tree, scalars (M, 5), members (P,) (model of each column)."""
        return self.arrays

    def write(self, writer: BitWriter, levels: np.ndarray, header: int = 0, header_bits: int = 0) -> None:
        """levels (F, P): per frame `header` in `header_bits` bits, then each track's coded levels."""
        levels = np.ascontiguousarray(levels, dtype=np.int64)
        if levels.ndim != 2 or levels.shape[1] != len(self.low):
            raise SigncastError(f"levels must be (F, {len(self.low)}), got {levels.shape}")
        self._use(len(levels))
        bad = pf.check_symbols(levels, self.low, self.high)
        if bad >= 0:
            p = bad % len(self.low)
            raise SigncastError(f"symbol {int(levels.flat[bad] - self.low[p])} outside the model's alphabet "
                                f"0..{int(self.high[p] - self.low[p])}")
        writer.reserve(len(levels) * (header_bits + 4 * kc.PRECISION * (len(self.low) + len(self.track_starts))))
        pf.write_level_frames(writer.buffer, writer.state, header, header_bits, levels, self.low, self.track_starts,
                              *self.arrays, self.once)

    def read(self, reader: BitReader) -> np.ndarray:
        """(P,) int64 levels of one frame (its header already read)."""
        self._use(1)
        out = np.empty(len(self.low), dtype=np.int64)
        check_level_status(pf.read_level_frame(reader.array, reader.end_bit, reader.registers, self.low,
                                               self.track_starts, *self.arrays, out, self.once))
        return out

    def _use(self, n_frames: int) -> None:
        if self.once and (self.used or n_frames > 1):
            raise SigncastError("these models code a single frame")
        self.used = self.used or n_frames > 0


def check_level_status(status: int) -> None:
    """SigncastError for a level-frame kernel's status (comparisons/params/frames.py)."""
    if status == pf.CORRUPT_CODE:
        raise SigncastError("corrupt arithmetic-coded data")
    if status == pf.CODE_ENDS_EARLY:
        raise SigncastError("truncated stream: arithmetic-coded data ends early")


# --------------------------------------------------------------------------- DCT segments

@functools.lru_cache(maxsize=SEGMENT)
def dct_matrix(size: int = SEGMENT) -> np.ndarray:
    """(size, size) orthonormal DCT-II: coefficients = D @ samples. A stream's last segment may
    be shorter than 16 frames; it is transformed at its own length (chosen here: padding it
    would make decode -> re-encode differ, and the XML round trip must be exact)."""
    n = np.arange(size)
    k = n[:, None]
    d = np.sqrt(2.0 / size) * np.cos((2 * n[None, :] + 1) * k * np.pi / (2 * size))
    d[0] /= np.sqrt(2.0)
    return d


def dct_steps(steps: np.ndarray, q: int) -> tuple[np.ndarray, np.ndarray]:
    """(DC step, AC step) per parameter: base x Q and base x Q / 3."""
    steps = np.asarray(steps, dtype=np.float64)
    return steps * q, steps * q / 3.0


def dct_levels(segment: np.ndarray, dc_step: np.ndarray, ac_step: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """segment: (n <= 16, P) values -> DC levels (P,), AC levels (n - 1, P) (round half away from zero)."""
    coefficients = np.matmul(dct_matrix(len(segment)), segment)
    dc = np.sign(coefficients[0]) * np.floor(np.abs(coefficients[0]) / dc_step + 0.5)
    ac = np.sign(coefficients[1:]) * np.floor(np.abs(coefficients[1:]) / ac_step + 0.5)
    return dc.astype(np.int64), ac.astype(np.int64)


def dct_reconstruct(dc: np.ndarray, ac: np.ndarray, dc_step: np.ndarray, ac_step: np.ndarray) -> np.ndarray:
    """(n, P) int64 values from levels (n = 1 + number of AC rows)."""
    coefficients = np.concatenate([(dc * dc_step)[None], ac * ac_step], axis=0)
    return np.round(np.matmul(dct_matrix(len(coefficients)).T, coefficients)).astype(np.int64)


def category(value: int) -> int:
    return min(abs(int(value)).bit_length(), N_CATEGORIES - 1)


def ac_symbols(ac: np.ndarray) -> list[tuple[int, int]]:
    """(symbol, level) pairs of one parameter's AC levels (up to 15): run/category symbols, then
    EOB unless the last coefficient is nonzero."""
    out = []
    run = 0
    last = int(np.max(np.flatnonzero(ac))) if np.any(ac) else -1
    for k in range(last + 1):
        if ac[k] == 0:
            run += 1
            continue
        out.append((1 + run * (N_CATEGORIES - 1) + category(ac[k]) - 1, int(ac[k])))
        run = 0
    if last < len(ac) - 1:
        out.append((AC_EOB, 0))
    return out


N_AC_SYMBOLS = 1 + (MAX_RUN + 1) * (N_CATEGORIES - 1)


@functools.lru_cache(maxsize=2)
def vlc_tables(path: str = str(TABLE_PATH)) -> dict[str, CanonicalHuffman]:
    """The fixed VLC tables: 'dc_intra', 'dc_inter', 'ac' (designed by tools/train_param_vlc.py)."""
    try:
        data = json.loads(Path(path).read_text())
        return {name: CanonicalHuffman(data["code_lengths"][name]) for name in ("dc_intra", "dc_inter", "ac")}
    except FileNotFoundError:
        raise SigncastError(f"VLC tables not found at {path}: run tools/train_param_vlc.py") from None
    except (KeyError, ValueError) as error:
        raise SigncastError(f"bad VLC table file {path}: {error}") from None


def write_dct_blocks(writer: BitWriter, tables: dict, dc_values: np.ndarray, intra: bool, ac: np.ndarray) -> None:
    """Every parameter's block of a segment, in order: dc_values (P,) (DC level, or difference from
    the previous DC), ac (n - 1, P) AC levels; each block is the DC category and bits, then the AC
    run/category symbols with their bits."""
    dc_values = np.ascontiguousarray(dc_values, dtype=np.int64).reshape(-1)
    ac = np.ascontiguousarray(ac, dtype=np.int64).reshape(np.shape(ac)[0], len(dc_values))
    dc_codes, dc_lengths = tables["dc_intra" if intra else "dc_inter"].arrays()[:2]
    ac_codes, ac_lengths = tables["ac"].arrays()[:2]
    writer.reserve(int(len(dc_values) * (ac.shape[0] + 1) * 72))
    status, detail = kc.write_dct_blocks(writer.buffer, writer.state, dc_values, ac, dc_codes, dc_lengths,
                                         ac_codes, ac_lengths, N_CATEGORIES)
    if status == 1:
        raise SigncastError(f"DCT level {detail} exceeds the largest category")
    if status == 2:
        raise SigncastError(f"symbol {detail} has no code in this Huffman table")


def read_dct_blocks(reader: BitReader, tables: dict, intra: bool, size: int, n_params: int) -> tuple[np.ndarray, np.ndarray]:
    """The blocks of `n_params` parameters of a segment of `size` frames: (DC values as coded (P,),
    AC levels (size - 1, P)) int64."""
    dc = np.zeros(n_params, dtype=np.int64)
    ac = np.zeros((size - 1, n_params), dtype=np.int64)
    dc_table = tables["dc_intra" if intra else "dc_inter"].arrays()[2:]
    status = kc.read_dct_blocks(reader.array, reader.end_bit, reader.registers, *dc_table, *tables["ac"].arrays()[2:],
                                N_CATEGORIES, dc, ac)
    if status == -1:
        raise SigncastError("truncated stream: it ends inside a field")
    if status == -2:
        raise SigncastError("corrupt stream: bits match no Huffman code")
    if status == -3:
        raise SigncastError("corrupt stream: AC run past the end of the segment")
    return dc, ac


def write_dct_block(writer: BitWriter, tables: dict, dc_value: int, intra: bool, ac: np.ndarray) -> None:
    """One parameter's segment: DC (level, or difference from the previous DC) then AC run/levels."""
    write_dct_blocks(writer, tables, np.array([dc_value]), intra, np.asarray(ac).reshape(-1, 1))


def read_dct_block(reader: BitReader, tables: dict, intra: bool, size: int = SEGMENT) -> tuple[int, np.ndarray]:
    """One parameter's block of a segment of `size` frames: (DC value as coded, AC levels (size - 1,))."""
    dc, ac = read_dct_blocks(reader, tables, intra, size, 1)
    return int(dc[0]), ac[:, 0]


def dct_symbol_counts(segments: list[tuple[np.ndarray, np.ndarray, bool]]) -> dict[str, np.ndarray]:
    """Symbol counts for table design. segments: (dc values (P,), AC levels (15, P), intra)."""
    counts = {"dc_intra": np.zeros(N_CATEGORIES, np.int64), "dc_inter": np.zeros(N_CATEGORIES, np.int64),
              "ac": np.zeros(N_AC_SYMBOLS, np.int64)}
    for dc_values, ac, intra in segments:
        for p, dc in enumerate(dc_values):
            counts["dc_intra" if intra else "dc_inter"][category(dc)] += 1
            for symbol, _ in ac_symbols(ac[:, p]):
                counts["ac"][symbol] += 1
    return counts


def frame_rate_fields(fps: float) -> tuple[int, int, int]:
    """(frame_rate 8 bits, seconds 4 bits, frequency_offset) with fps = (rate + seconds/16) [x 1000/1001].

    `fps` in frames per second, exact (30000/1001) or as a camera states it (29.97, 23.976, 59.94): the nearest
    sixteenth of a frame is taken, with or without the 1000/1001 offset, where it lies within 0.005 fps.
    Raises SigncastError for a rate that neither form can signal (above 255 15/16 fps, under 1 fps, or not
    near a sixteenth).
    """
    candidates = []
    for offset in (0, 1):
        nominal = fps * (1001 / 1000 if offset else 1)
        sixteenths = int(round(nominal * 16))
        rate, seconds = divmod(sixteenths, 16)
        error = abs(fps_from_fields(rate, seconds, offset) - fps) if rate >= 1 else np.inf
        if rate <= 255 and error < 5e-3:
            candidates.append((error, offset, (rate, seconds, offset)))
    if candidates:
        return min(candidates)[2]
    raise SigncastError(f"frame rate {fps:g} fps cannot be signalled (rate + n/16 fps, optionally x 1000/1001)")


def fps_from_fields(rate: int, seconds: int, offset: int) -> float:
    """The frame rate in fps that the header fields signal: (rate + seconds/16) x 1000/1001 where offset is 1,
    exactly (30, 0, 1) is 30000/1001. Raises SigncastError for rate 0."""
    if rate == 0:
        raise SigncastError("corrupt stream: frame rate 0")
    fps = rate + seconds / 16
    return fps * 1000 / 1001 if offset else fps

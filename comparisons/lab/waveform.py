"""Waveform coders of DOF trajectories (seed 002 ch. 7): each DOF coded on its own, no model of the action.

Contract of every coder (DofCoder; the vector-quantising and model-based coders of comparisons/lab/vq.py and
model.py share it):
- built from per-DOF ranges `lower`, `upper` (D,) radians, finite, upper >= lower (the quantiser limits, the role
  of seed 002's joint limits: known to both ends, never sent), and an entropy stage name (streams.STAGE_NAMES);
- `encode(dofs, fps, q) -> (bytes, reconstruction (T, D) float64 radians)`: dofs (T >= min_frames, D) float64
  radians, finite; fps > 0 Hz (0.001 .. streams.MAX_FPS); q an int indexing the coder's `settings`
  (0 = coarsest, lowest rate); T x D within streams.MAX_VALUES;
- `read_levels(bytes) -> ({name: int64 array}, StreamInfo)`: the integers the stream carries, before
  dequantisation (each coder's `_read` names them and their shapes); exact on every CPU, and what the
  conformance streams pin (tests/data/conformance/lab/, tests/test_lab_conformance.py);
- `decode(bytes) -> (T, D)` / `decode_with_fps(bytes) -> ((T, D), fps)`: read_levels, then the coder's
  dequantisation (`_rebuild`); the decoder returns exactly the reconstruction the encoder returned on the same
  machine (both run the same code);
- errors: SigncastError for bad input (shape, NaN, fps, q) and for any damaged, truncated or foreign stream
  (the container's CRC, lengths and layout checks, comparisons/lab/streams.py), never another exception.

Error bounds the coders guarantee (tests/test_lab_conformance.py checks them on real letters):
- quant: |x - x^| <= (upper - lower) / (2 N) for x clamped to its range (N levels);
- deadreck: |x - x^| <= E after the first frame (threshold E);
- wavelet, wavelet-cx: |x - x^| <= 2 step (each of a block's 16 orthonormal coefficients within step / 2).
The others have no worst-case bound; their error on the conformance letters is held within 5 % of the stored figure.

Choices the seed leaves open (digest §7.4) and the values used here:
- quantiser ranges: the DOF ranges; first frames of predictive coders: 16-bit uniform in the range;
- difference limits of DPCM/ADPCM: forward adaptive, the clip's largest frame difference per DOF rounded
  up on a 1/8-octave grid (1 byte per DOF of side information);
- non-uniform quantiser: mu-law with mu = 16 (values, about the range centre) and mu = 32 (differences);
  N levels (a power of two) become N - 1 symmetric mid-tread levels so that a still DOF costs ~0 bits;
- ADPCM: order 2, autocorrelation method on the last round(fps) decoded samples (Hamming window,
  mean removed, 1e-3 white-noise correction), used per DOF only while its recent error on decoded
  samples (forgetting factor 0.8) is below that of the previous-value predictor; mu-law difference
  quantiser (as DPCM) whose scale adapts with Jayant multipliers beta(k) = 0.9 + 1.6 (k/M)^4 within
  [limit/2, 2 limit];
- dead reckoning: constant velocity, 7-sample least-squares slope (3 frames sender delay, compensated),
  value step E/2, velocity step E/8 per frame;
- DCT: N = 16, orthonormal DCT-II, Appendix III bit allocations (non-adaptive, no edge smoothing),
  DC predicted from the previous block, AC ranges = largest |coefficient| in the clip (float32 header);
- wavelet: orthonormal Haar (the seed names no family), full dyadic decomposition of 16-sample blocks,
  uniform step 0.32 / 2^k rad, k = 0..10 (dead zone of rounding = the thresholding that keeps the largest
  coefficients), approximation predicted.

The closed loops of DPCM, ADPCM and dead reckoning run frame by frame in comparisons/lab/predictive.py (Numba).
"""
from __future__ import annotations

import functools
import struct
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.fft import dct, idct

from comparisons.lab import streams as coded_streams
from comparisons.lab.streams import StreamInfo, StreamReader, StreamWriter, check_size
from comparisons.lab import context as lab_context
from comparisons.lab import predictive as lab_predictive
from media.errors import SigncastError

FIRST_FRAME_BITS = 16
DIFF_LIMIT_BASE = 1e-5  # radians per frame, bottom of the 1/8-octave grid


class DofCoder:
    """Base of every motion coder: checks, container, exact decode."""

    name = "base"
    coder_id = 0
    settings: tuple = ()
    unit = ""  # what a setting is: "levels", "degrees", ...
    quality_measure = "psnr"  # waveform coders are scored with PSNR, model-based ones with VPSNR
    min_frames = 1

    def __init__(self, lower: np.ndarray, upper: np.ndarray, *, stage: str | None = None):
        self.lower = np.asarray(lower, dtype=np.float64).ravel()
        self.upper = np.asarray(upper, dtype=np.float64).ravel()
        if self.lower.shape != self.upper.shape or not np.all(np.isfinite(self.lower)) \
                or not np.all(np.isfinite(self.upper)) or np.any(self.upper < self.lower):
            raise SigncastError("DOF ranges must be finite (D,) arrays with upper >= lower")
        self.width = np.maximum(self.upper - self.lower, 1e-9)
        self.stage = stage

    @property
    def n_dofs(self) -> int:
        return len(self.lower)

    def check(self, dofs: np.ndarray, fps: float, q: int) -> np.ndarray:
        dofs = np.asarray(dofs, dtype=np.float64)
        if dofs.ndim != 2 or dofs.shape[1] != self.n_dofs or len(dofs) < self.min_frames:
            raise SigncastError(f"{self.name}: DOF trajectories must be (T >= {self.min_frames}, {self.n_dofs}), "
                                f"got {dofs.shape}")
        if not np.all(np.isfinite(dofs)):
            raise SigncastError(f"{self.name}: DOF trajectories hold NaN or infinite values")
        if not (np.isfinite(fps) and fps > 0):
            raise SigncastError(f"{self.name}: bad frame rate {fps}")
        if not (isinstance(q, (int, np.integer)) and 0 <= q < len(self.settings)):
            raise SigncastError(f"{self.name}: q must be an integer 0..{len(self.settings) - 1} "
                                f"({self.unit}: {', '.join(map(str, self.settings))}), got {q!r}")
        return dofs

    def encode(self, dofs: np.ndarray, fps: float, q: int) -> tuple[bytes, np.ndarray]:
        """(T, D) radians -> (stream bytes, the reconstruction the decoder will produce (T, D))."""
        dofs = self.check(dofs, fps, q)
        writer = StreamWriter(self.coder_id, int(q), len(dofs), self.n_dofs, fps, self.stage)
        recon = self._encode(writer, dofs, fps, self.settings[q])
        return writer.finish(), recon

    def decode(self, data: bytes) -> np.ndarray:
        return self.decode_with_fps(data)[0]

    def read_levels(self, data: bytes) -> tuple[dict[str, np.ndarray], StreamInfo]:
        """Bytes -> (the integers the stream carries, before dequantisation: {name: int64 array}, the header).
        This is the decoder's exact part, what conformance streams pin (tests/test_lab_conformance.py); each
        coder's `_read` documents its names and shapes. Raises SigncastError on damaged input."""
        reader = StreamReader(data, self.coder_id, self.name)
        info = reader.info
        if info.n_dofs != self.n_dofs or info.q >= len(self.settings):
            raise SigncastError(f"corrupt {self.name} stream: layout does not match this coder")
        try:
            levels = self._read(reader, info.n_frames, self.settings[info.q])
        except (IndexError, ValueError, OverflowError, struct.error) as error:
            raise SigncastError(f"corrupt {self.name} stream: {error}") from None
        reader.finish()
        return levels, info

    def decode_with_fps(self, data: bytes) -> tuple[np.ndarray, float]:
        """Bytes -> ((T, D) radians, fps): read_levels, then the coder's dequantisation. Raises SigncastError on
        damaged input."""
        levels, info = self.read_levels(data)
        try:
            recon = self._rebuild(levels, info.n_frames, info.fps, self.settings[info.q])
        except (IndexError, ValueError, OverflowError) as error:
            raise SigncastError(f"corrupt {self.name} stream: {error}") from None
        return recon, info.fps

    def _encode(self, writer: StreamWriter, dofs: np.ndarray, fps: float, setting) -> np.ndarray:
        raise NotImplementedError

    def _read(self, reader: StreamReader, n_frames: int, setting) -> dict[str, np.ndarray]:
        """The stream's integers, in the order the encoder wrote them (checked against the header's layout)."""
        raise NotImplementedError

    def _rebuild(self, levels: dict[str, np.ndarray], n_frames: int, fps: float, setting) -> np.ndarray:
        """The integers of `_read` -> (T, D) radians."""
        raise NotImplementedError


# ---------------------------------------------------------------- shared quantisers

def uniform_index(x: np.ndarray, lower: np.ndarray, width: np.ndarray, levels: int) -> np.ndarray:
    """Cell index of x in `levels` equal cells over [lower, lower + width] (input clamped)."""
    return np.clip(np.floor((x - lower) / width * levels), 0, levels - 1).astype(np.int64)


def uniform_value(index: np.ndarray, lower: np.ndarray, width: np.ndarray, levels: int) -> np.ndarray:
    """Cell midpoints (seed 002 eq. 7-3)."""
    return lower + (index + 0.5) * (width / levels)


def mu_compress(u: np.ndarray, mu: float) -> np.ndarray:
    """Bipolar mu-law on u in [-1, 1] (seed 002 eq. 7-5, expander form)."""
    return np.sign(u) * np.log1p(mu * np.abs(u)) / np.log1p(mu)


def mu_expand(c: np.ndarray, mu: float) -> np.ndarray:
    return np.sign(c) * np.expm1(np.abs(c) * np.log1p(mu)) / mu


def write_first_frame(writer: StreamWriter, coder: DofCoder, first: np.ndarray) -> np.ndarray:
    levels = 1 << FIRST_FRAME_BITS
    index = uniform_index(first, coder.lower, coder.width, levels)
    writer.raw(index, np.full(len(index), FIRST_FRAME_BITS))
    return uniform_value(index, coder.lower, coder.width, levels)


def read_first_frame(reader: StreamReader, coder: DofCoder) -> np.ndarray:
    """The first frame's cell indices (D,) int64 (FIRST_FRAME_BITS each)."""
    return reader.raw(np.full(coder.n_dofs, FIRST_FRAME_BITS))


def first_frame_value(index: np.ndarray, coder: DofCoder) -> np.ndarray:
    return uniform_value(index, coder.lower, coder.width, 1 << FIRST_FRAME_BITS)


def _diff_limit_codes(dofs: np.ndarray) -> np.ndarray:
    largest = np.abs(np.diff(dofs, axis=0)).max(axis=0) if len(dofs) > 1 else np.zeros(dofs.shape[1])
    codes = np.ceil(8 * np.log2(np.maximum(largest, DIFF_LIMIT_BASE) / DIFF_LIMIT_BASE))
    return np.clip(codes, 0, 255).astype(np.int64)


def _diff_limits(codes: np.ndarray) -> np.ndarray:
    return DIFF_LIMIT_BASE * np.exp2(codes / 8.0)


def _write_diff_limits(writer: StreamWriter, dofs: np.ndarray) -> np.ndarray:
    codes = _diff_limit_codes(dofs)
    writer.header(codes.astype(np.uint8).tobytes())
    return _diff_limits(codes)


def _read_diff_limit_codes(reader: StreamReader, n_dofs: int) -> np.ndarray:
    payload = reader.header()
    if len(payload) != n_dofs:
        raise SigncastError("corrupt stream: difference-limit header has the wrong size")
    return np.frombuffer(payload, dtype=np.uint8).astype(np.int64)


def _loop_input(dofs: np.ndarray | None, n_dofs: int) -> np.ndarray:
    """The encoder's (T, D) input for a compiled loop, or an empty (0, D) array when decoding."""
    return np.zeros((0, n_dofs)) if dofs is None else np.ascontiguousarray(dofs, dtype=np.float64)


def _loop_symbols(symbols: np.ndarray, n_dofs: int) -> np.ndarray:
    return np.ascontiguousarray(symbols, dtype=np.int64).reshape(-1, n_dofs)


# ---------------------------------------------------------------- direct quantisation

class UniformQuantizer(DofCoder):
    """Direct uniform quantisation of each DOF within its range, N levels (seed 002 §7.2.1)."""

    name, coder_id, unit = "quant", 1, "levels"
    settings = (8, 16, 32, 64, 128, 256)

    def _encode(self, writer, dofs, fps, levels):
        index = uniform_index(dofs, self.lower, self.width, levels)
        writer.symbol_rows(index.T, levels)  # one section, and adaptive context, per DOF
        return uniform_value(index, self.lower, self.width, levels)

    def _read(self, reader, n_frames, levels):
        """{"index": (T, D) cells 0 .. levels - 1}."""
        return {"index": reader.symbol_rows(levels, self.n_dofs, n_frames).T}

    def _rebuild(self, read, n_frames, fps, levels):
        return uniform_value(read["index"], self.lower, self.width, levels)


class CompandedQuantizer(DofCoder):
    """Non-uniform (mu-law companded) quantisation of each DOF about its range centre (§7.2.2)."""

    name, coder_id, unit = "nuquant", 2, "levels"
    settings = (8, 16, 32, 64, 128, 256)
    mu = 16.0

    def _table(self, levels: int) -> np.ndarray:
        half = (levels - 2) // 2  # N - 1 mid-tread levels: -half..half
        c = np.arange(-half, half + 1) / half
        centre, radius = (self.upper + self.lower) / 2, self.width / 2
        return centre[None, :] + mu_expand(c, self.mu)[:, None] * radius[None, :]  # (levels-1, D)

    def _encode(self, writer, dofs, fps, levels):
        half = (levels - 2) // 2
        centre, radius = (self.upper + self.lower) / 2, self.width / 2
        u = np.clip((dofs - centre) / radius, -1.0, 1.0)
        index = np.rint(mu_compress(u, self.mu) * half).astype(np.int64) + half
        writer.symbol_rows(index.T, 2 * half + 1)
        return np.take_along_axis(self._table(levels), index, axis=0)

    def _read(self, reader, n_frames, levels):
        """{"index": (T, D) levels 0 .. 2 half (half = (levels - 2) // 2; half is the range centre)}."""
        half = (levels - 2) // 2
        return {"index": reader.symbol_rows(2 * half + 1, self.n_dofs, n_frames).T}

    def _rebuild(self, read, n_frames, fps, levels):
        return np.take_along_axis(self._table(levels), read["index"], axis=0)


# ---------------------------------------------------------------- predictive coders

class ResidualCoder(DofCoder):
    """The stream both predictive coders share: first frame, per-DOF difference limits, then one quantised
    residual symbol per DOF and frame (2 half + 1 symbols, half = (levels - 2) // 2). Subclasses give
    `_predict(first, limits, levels, n_frames, fps, dofs=None, symbols=None) -> (reconstruction, symbols)`,
    the closed loop both ends run (encoding when dofs are given, decoding from symbols)."""

    def _encode(self, writer, dofs, fps, levels):
        first = write_first_frame(writer, self, dofs[0])
        limits = _write_diff_limits(writer, dofs)
        recon, symbols = self._predict(first, limits, levels, len(dofs), fps, dofs=dofs)
        writer.symbols(symbols, 2 * ((levels - 2) // 2) + 1)
        return recon

    def _read(self, reader, n_frames, levels):
        """{"first": (D,) first-frame cells, "limits": (D,) difference-limit codes 0..255, "symbols": (T - 1, D)
        residual levels 0 .. 2 half}."""
        first = read_first_frame(reader, self)
        codes = _read_diff_limit_codes(reader, self.n_dofs)
        alphabet = 2 * ((levels - 2) // 2) + 1
        symbols = reader.symbols(alphabet, (n_frames - 1) * self.n_dofs).reshape(n_frames - 1, self.n_dofs)
        return {"first": first, "limits": codes, "symbols": symbols}

    def _rebuild(self, read, n_frames, fps, levels):
        return self._predict(first_frame_value(read["first"], self), _diff_limits(read["limits"]), levels, n_frames,
                             fps, symbols=read["symbols"])[0]


class DpcmCoder(ResidualCoder):
    """First-order DPCM from the decoded previous value, mu-law difference quantiser (§7.5)."""

    name, coder_id, unit = "dpcm", 3, "levels"
    settings = (4, 8, 16, 32, 64, 128, 256)
    mu = 32.0

    def _steps(self, levels: int, limits: np.ndarray) -> np.ndarray:
        half = (levels - 2) // 2
        c = np.arange(-half, half + 1) / half
        return mu_expand(c, self.mu)[None, :] * limits[:, None]  # (D, 2 half + 1)

    def _run(self, first, steps, n_frames, half, dofs=None, symbols=None):
        """The loop both ends run: closed-loop prediction; encodes (dofs given) or decodes (symbols)."""
        recon = np.empty((n_frames, self.n_dofs))
        recon[0] = first
        encoding = dofs is not None
        if encoding:
            symbols = np.empty((n_frames - 1, self.n_dofs), dtype=np.int64)
        lab_predictive.dpcm_loop(np.ascontiguousarray(steps), self.lower, self.upper, encoding,
                                 _loop_input(dofs, self.n_dofs), _loop_symbols(symbols, self.n_dofs), recon)
        return recon, symbols

    def _predict(self, first, limits, levels, n_frames, fps, dofs=None, symbols=None):
        return self._run(first, self._steps(levels, limits), n_frames, (levels - 2) // 2, dofs=dofs, symbols=symbols)


class AdpcmCoder(ResidualCoder):
    """Adaptive predictive coding (§7.6): order-2 predictor adapted on decoded samples, Jayant-adapted quantiser."""

    name, coder_id, unit = "adpcm", 4, "levels"
    settings = (4, 8, 16, 32, 64, 128, 256)

    def _run(self, first, limits, n_frames, fps, half, dofs=None, symbols=None):
        """Per DOF and frame: once 3 frames are decoded, the order-2 predictor from the autocorrelation
        (r0, r1, r2) of the last `window` decoded samples (mean removed, Hamming taper, r0 (1 + 1e-3) + 1e-18),
        used while its forgetting sum of squared errors (0.8) is below the previous-value predictor's;
        the quantiser's offsets scale x grid adapt by Jayant's multiplier within [limit / 2, 2 limit].
        The loop is comparisons/lab/predictive.adpcm_loop."""
        window = max(int(round(fps)), 8)
        recon = np.empty((n_frames, self.n_dofs))
        recon[0] = first
        encoding = dofs is not None
        if encoding:
            symbols = np.empty((n_frames - 1, self.n_dofs), dtype=np.int64)
        grid = mu_expand(np.arange(-half, half + 1) / half, DpcmCoder.mu)  # (K,) in [-1, 1]
        lab_predictive.adpcm_loop(np.asarray(limits, dtype=np.float64), grid, np.hamming(window), half, self.lower,
                                  self.upper, encoding, _loop_input(dofs, self.n_dofs),
                                  _loop_symbols(symbols, self.n_dofs), recon)
        return recon, symbols

    def _predict(self, first, limits, levels, n_frames, fps, dofs=None, symbols=None):
        return self._run(first, limits, n_frames, fps, (levels - 2) // 2, dofs=dofs, symbols=symbols)


# ---------------------------------------------------------------- dead reckoning

def least_squares_slope(dofs: np.ndarray, half_window: int = 3) -> np.ndarray:
    """Centred least-squares slope (per frame) over 2*half_window+1 samples, edges padded. (T, D)."""
    padded = np.pad(dofs, ((half_window, half_window), (0, 0)), mode="edge")
    lags = np.arange(-half_window, half_window + 1)
    n = len(dofs)
    slope = sum(k * padded[half_window + k:half_window + k + n] for k in lags)
    return slope / float(np.sum(lags ** 2))


class DeadReckoningCoder(DofCoder):
    """Dead reckoning (§7.7): the receiver extrapolates at constant velocity; the sender sends a value
    and velocity correction only when the receiver's error exceeds the threshold E."""

    name, coder_id, unit = "deadreck", 5, "degrees"
    settings = (16.0, 8.0, 4.0, 2.0, 1.0, 0.5, 0.25, 0.125)

    def _encode(self, writer, dofs, fps, threshold_deg):
        threshold = np.radians(threshold_deg)
        value_step, velocity_step = threshold / 2.0, threshold / 8.0
        slopes = least_squares_slope(dofs)
        n_frames = len(dofs)
        recon = np.empty_like(dofs)
        recon[0] = write_first_frame(writer, self, dofs[0])
        flags = np.empty((n_frames - 1, self.n_dofs), dtype=np.int64)
        value_codes = np.empty(flags.size, dtype=np.int64)
        velocity_codes = np.empty(flags.size, dtype=np.int64)
        used = lab_predictive.deadreck_loop(True, np.ascontiguousarray(dofs), slopes, threshold, value_step,
                                            velocity_step, flags, value_codes, velocity_codes, recon)
        writer.symbols(flags, 2)
        writer.signed(value_codes[:used])
        writer.signed(velocity_codes[:used])
        return recon

    def _read(self, reader, n_frames, threshold_deg):
        """{"first": (D,) first-frame cells, "flags": (T - 1, D) 0/1 (a correction sent), "value", "velocity":
        (number of corrections,) signed corrections in steps E/2 and E/8, in frame then DOF order}."""
        first = read_first_frame(reader, self)
        flags = reader.symbols(2, (n_frames - 1) * self.n_dofs).reshape(n_frames - 1, self.n_dofs)
        n_updates = int(flags.sum())
        value_codes = reader.signed(n_updates)
        velocity_codes = reader.signed(n_updates)
        return {"first": first, "flags": flags, "value": value_codes, "velocity": velocity_codes}

    def _rebuild(self, read, n_frames, fps, threshold_deg):
        threshold = np.radians(threshold_deg)
        value_step, velocity_step = threshold / 2.0, threshold / 8.0
        recon = np.empty((n_frames, self.n_dofs))
        recon[0] = first_frame_value(read["first"], self)
        flags = np.ascontiguousarray(read["flags"], dtype=np.int64)
        empty = np.zeros((0, self.n_dofs))
        used = lab_predictive.deadreck_loop(False, empty, empty, threshold, value_step, velocity_step, flags,
                                            read["value"], read["velocity"], recon)
        if used != len(read["value"]):
            raise SigncastError("corrupt deadreck stream: corrections do not match the flags")
        return recon


# ---------------------------------------------------------------- transform coders

BLOCK = 16

# Appendix III "Transform": bits per DCT coefficient 0..15, from the coarsest (q = 0) to the finest.
DCT_ALLOCATIONS = (
    (5, 4, 3, 3, 2, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0),
    (6, 5, 4, 4, 3, 3, 2, 2, 0, 0, 0, 0, 0, 0, 0, 0),
    (7, 6, 5, 4, 4, 3, 3, 3, 2, 2, 0, 0, 0, 0, 0, 0),
    (8, 7, 6, 5, 5, 4, 4, 3, 3, 2, 2, 0, 0, 0, 0, 0),
    (8, 7, 7, 6, 6, 5, 4, 4, 3, 3, 2, 2, 0, 0, 0, 0),
    (10, 9, 9, 8, 8, 7, 6, 6, 5, 5, 4, 4, 3, 3, 2, 2),  # finer than the seed's rows, to reach high PSNR
)


def to_blocks(dofs: np.ndarray, block: int = BLOCK) -> np.ndarray:
    """(T, D) -> (D, n_blocks, block), the last block padded by repeating the last frame."""
    n_blocks = -(-len(dofs) // block)
    padded = np.pad(dofs, ((0, n_blocks * block - len(dofs)), (0, 0)), mode="edge")
    return padded.T.reshape(dofs.shape[1], n_blocks, block)


def from_blocks(blocks: np.ndarray, n_frames: int) -> np.ndarray:
    return blocks.reshape(blocks.shape[0], -1).T[:n_frames].copy()


class DctCoder(DofCoder):
    """DCT block coding, N = 16, per-coefficient bit allocation (§7.8.1)."""

    name, coder_id, unit = "dct", 6, "allocation row"
    settings = tuple(range(len(DCT_ALLOCATIONS)))

    def _dc_grid(self):
        return self.lower * np.sqrt(BLOCK), self.width * np.sqrt(BLOCK)

    @staticmethod
    def _ac_levels(bits: int) -> int:
        return max((1 << bits) - 1, 1)

    def _reconstruct(self, dc_index, ac_index, ranges, allocation, n_frames):
        n_dofs, n_blocks = dc_index.shape
        coeffs = np.zeros((n_dofs, n_blocks, BLOCK))
        lower, width = self._dc_grid()
        coeffs[:, :, 0] = uniform_value(dc_index, lower[:, None], width[:, None], 1 << allocation[0])
        for k in range(1, BLOCK):
            levels = self._ac_levels(allocation[k])
            if levels > 1:
                half = (levels - 1) // 2
                coeffs[:, :, k] = ac_index[k] * (ranges[k] / half)
        return from_blocks(idct(coeffs, type=2, norm="ortho", axis=-1), n_frames)

    def _encode(self, writer, dofs, fps, row):
        allocation = DCT_ALLOCATIONS[row]
        coeffs = dct(to_blocks(dofs), type=2, norm="ortho", axis=-1)
        ranges = np.abs(coeffs).max(axis=(0, 1)).astype(np.float32).astype(np.float64)
        ranges = np.maximum(ranges, 1e-9).astype(np.float32)
        writer.header(ranges.tobytes())
        ranges = ranges.astype(np.float64)
        lower, width = self._dc_grid()
        dc_index = uniform_index(coeffs[:, :, 0], lower[:, None], width[:, None], 1 << allocation[0])
        writer.signed(np.diff(dc_index, axis=1, prepend=0))
        ac_index = {}
        for k in range(1, BLOCK):
            levels = self._ac_levels(allocation[k])
            if levels > 1:
                half = (levels - 1) // 2
                ac_index[k] = np.clip(np.rint(coeffs[:, :, k] / (ranges[k] / half)), -half, half).astype(np.int64)
                writer.symbols(ac_index[k] + half, levels)
        return self._reconstruct(dc_index, ac_index, ranges, allocation, len(dofs))

    def _read(self, reader, n_frames, row):
        """{"ranges": (16,) the AC ranges' float32 bit patterns (little-endian, as int64), "dc": (D, n_blocks) DC
        cells, "ac": (D, n_blocks, 16) signed AC levels (0 where the allocation codes none; column 0 unused)}."""
        allocation = DCT_ALLOCATIONS[row]
        payload = reader.header()
        if len(payload) != 4 * BLOCK:
            raise SigncastError("corrupt dct stream: coefficient-range header has the wrong size")
        with np.errstate(invalid="ignore"):  # a damaged range may be a signalling NaN: rejected just below
            ranges = np.frombuffer(payload, dtype="<f4").astype(np.float64)
        if not np.all(np.isfinite(ranges)) or np.any(ranges <= 0):
            raise SigncastError("corrupt dct stream: bad coefficient ranges")
        n_blocks = -(-n_frames // BLOCK)
        dc_index = np.cumsum(reader.signed(self.n_dofs * n_blocks).reshape(self.n_dofs, n_blocks), axis=1)
        if dc_index.min() < 0 or dc_index.max() >= 1 << allocation[0]:
            raise SigncastError("corrupt dct stream: DC index out of range")
        ac = np.zeros((self.n_dofs, n_blocks, BLOCK), dtype=np.int64)
        for k in range(1, BLOCK):
            levels = self._ac_levels(allocation[k])
            if levels > 1:
                half = (levels - 1) // 2
                ac[:, :, k] = reader.symbols(levels, self.n_dofs * n_blocks).reshape(self.n_dofs, n_blocks) - half
        return {"ranges": np.frombuffer(payload, dtype="<u4").astype(np.int64), "dc": dc_index, "ac": ac}

    def _rebuild(self, read, n_frames, fps, row):
        allocation = DCT_ALLOCATIONS[row]
        ranges = read["ranges"].astype("<u4").view("<f4").astype(np.float64)
        ac_index = {k: read["ac"][:, :, k] for k in range(1, BLOCK) if self._ac_levels(allocation[k]) > 1}
        return self._reconstruct(read["dc"], ac_index, ranges, allocation, n_frames)


def haar_forward(blocks: np.ndarray) -> list[np.ndarray]:
    """Orthonormal Haar, full dyadic decomposition along the last axis (length a power of two).
    Returns [approximation, coarsest detail, ..., finest detail]."""
    details = []
    approx = blocks
    while approx.shape[-1] > 1:
        even, odd = approx[..., 0::2], approx[..., 1::2]
        details.append((even - odd) / np.sqrt(2.0))
        approx = (even + odd) / np.sqrt(2.0)
    return [approx] + details[::-1]


def haar_inverse(bands: list[np.ndarray]) -> np.ndarray:
    approx = bands[0]
    for detail in bands[1:]:
        even = (approx + detail) / np.sqrt(2.0)
        odd = (approx - detail) / np.sqrt(2.0)
        approx = np.stack([even, odd], axis=-1).reshape(*approx.shape[:-1], -1)
    return approx


class WaveletCoder(DofCoder):
    """Time-frequency coder (§7.8.2): Haar wavelet of 16-sample blocks, uniform step per q."""

    name, coder_id, unit = "wavelet", 7, "step (rad)"
    # 0.32 rad (coarsest) down to 0.3 mrad (docs/motion-lab.md: what the finest steps reach)
    settings = tuple(0.32 / 2 ** k for k in range(11))

    def _encode(self, writer, dofs, fps, step):
        bands = haar_forward(to_blocks(dofs))
        indices = [np.rint(band / step).astype(np.int64) for band in bands]
        writer.signed(np.diff(indices[0][..., 0], axis=1, prepend=0))
        for index in indices[1:]:
            writer.signed(index)
        return from_blocks(haar_inverse([index * step for index in indices]), len(dofs))

    def _read(self, reader, n_frames, step):
        """{"indices": (D, n_blocks, 16) coefficient indices (multiples of the step) in the dyadic layout
        [approximation, level 1 (1), level 2 (2), level 3 (4), level 4 (8)]}."""
        n_blocks = -(-n_frames // BLOCK)
        approx = np.cumsum(reader.signed(self.n_dofs * n_blocks).reshape(self.n_dofs, n_blocks), axis=1)
        indices = [approx[..., None]]
        width = 1
        while width < BLOCK:
            indices.append(reader.signed(self.n_dofs * n_blocks * width).reshape(self.n_dofs, n_blocks, width))
            width *= 2
        return {"indices": np.concatenate(indices, axis=-1)}

    def _rebuild(self, read, n_frames, fps, step):
        return ContextWaveletCoder._reconstruct(read["indices"], step, n_frames)


PRIORS_PATH = Path(__file__).resolve().parents[1] / "tables" / "context_priors.npz"
PREDICTION_SHIFT = 6            # inter-DOF prediction weights in 1/64
MAX_PREDICTION_WEIGHT = 3 << PREDICTION_SHIFT


@dataclass(frozen=True)
class ContextPriors:
    """Initial model states of the compact wavelet-cx stream (comparisons/lab/context.py): per operating point q,
    coeff_probs / coeff_counts (n_settings, N_CONTEXTS) int64 (P(bit = 0) x 65536, bits already seen), and of
    the active-DOF mask mask_probs / mask_counts (2 D,) for the D DOFs of the signing layout; the inter-DOF
    prediction predictor (D,) int64 (the layout DOF that predicts DOF d, always < d; -1: none) and weight (D,) int64
    (its multiplier x 2^PREDICTION_SHIFT)."""
    coeff_probs: np.ndarray
    coeff_counts: np.ndarray
    mask_probs: np.ndarray
    mask_counts: np.ndarray
    predictor: np.ndarray
    weight: np.ndarray

    @functools.cached_property
    def tag(self) -> int:
        """CRC-32 of every table (int64 bytes, in field order): the compact stream's model tag
        (coded_streams.write_compact), so a decoder with other priors rejects the stream."""
        tag = 0
        for table in (self.coeff_probs, self.coeff_counts, self.mask_probs, self.mask_counts, self.predictor,
                      self.weight):
            tag = zlib.crc32(np.ascontiguousarray(table, dtype="<i8").tobytes(), tag)
        return tag

    @property
    def n_layout(self) -> int:
        return len(self.mask_probs) // 2


@functools.lru_cache(maxsize=1)
def context_priors(path: Path = PRIORS_PATH) -> ContextPriors:
    """The shipped trained model states (tools/train_context_priors.py), checked against the kernel's layout."""
    try:
        with np.load(path, allow_pickle=False) as table:
            arrays = [table[k].astype(np.int64) for k in ("coeff_probs", "coeff_counts", "mask_probs", "mask_counts",
                                                          "predictor", "weight")]
    except (OSError, KeyError):
        raise SigncastError(f"context priors missing ({path}): run tools/train_context_priors.py") from None
    priors = ContextPriors(*arrays)
    n_settings = len(ContextWaveletCoder.settings)
    if priors.coeff_probs.shape != (n_settings, lab_context.N_CONTEXTS) or \
            priors.coeff_counts.shape != priors.coeff_probs.shape or priors.mask_counts.shape != priors.mask_probs.shape \
            or priors.predictor.shape != (priors.n_layout,) or priors.weight.shape != priors.predictor.shape:
        raise SigncastError("the shipped context priors do not match the context coder: retrain them")
    if np.any((priors.predictor < -1) | (priors.predictor >= np.arange(priors.n_layout))) or \
            np.any(np.abs(priors.weight) > MAX_PREDICTION_WEIGHT):
        raise SigncastError("the shipped inter-DOF predictors are not causal or too large: retrain them")
    for probs in (priors.coeff_probs, priors.mask_probs):
        if probs.min() < lab_context.PROB_MIN or probs.max() > lab_context.PROB_ONE - lab_context.PROB_MIN:
            raise SigncastError("the shipped context priors hold impossible probabilities: retrain them")
    return priors


def prediction_pairs(active: np.ndarray, predictor: np.ndarray, weight: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The inter-DOF predictions (ContextPriors.predictor, .weight (D,)) among the active DOFs (bool (D,) of the
    layout): (targets, sources, weights) int64 (P,), targets and sources as positions among the active DOFs, by
    rising target (a source precedes its target, so it is complete before its target is rebuilt)."""
    position = np.cumsum(active) - 1
    targets = np.flatnonzero(active & (predictor >= 0))
    targets = targets[active[predictor[targets]]]
    return position[targets], position[predictor[targets]], weight[targets]


def weighted_prediction(weight, source: np.ndarray) -> np.ndarray:
    """round(weight / 2^PREDICTION_SHIFT x source) in integers (halves up), weight an int or an int array that
    broadcasts with source: both ends (and tools/train_context_priors.py) compute it bit for bit."""
    return (weight * source + (1 << (PREDICTION_SHIFT - 1))) >> PREDICTION_SHIFT


def predict_dofs(coded: np.ndarray, pairs: tuple[np.ndarray, np.ndarray, np.ndarray]) -> np.ndarray:
    """Coded coefficients (n_active, n_blocks, 16) int64 -> the residuals the compact stream carries: a
    predicted DOF's coefficients less its weighted source DOF's (the source's own values, not its residual)."""
    residual = coded.copy()
    for target, source, weight in zip(*pairs):
        residual[target] -= weighted_prediction(weight, coded[source])
    return residual


def unpredict_dofs(residual: np.ndarray, pairs: tuple[np.ndarray, np.ndarray, np.ndarray]) -> np.ndarray:
    """The inverse of predict_dofs, in place: targets by rising position, so every source is complete first."""
    for target, source, weight in zip(*pairs):
        residual[target] += weighted_prediction(weight, residual[source])
    return residual


class ContextWaveletCoder(DofCoder):
    """The wavelet coder (§7.8.2) with context-modelled entropy coding, chosen here: the seed names a wavelet
    coder but not how its coefficients are entropy coded. As H.264's CABAC and JPEG 2000's EBCOT do, each
    coefficient is binarised (magnitude class in unary, sign, top two mantissa bits, remaining bits) and every bin is
    coded by a binary range coder with an adaptive probability chosen by its context: the band, and the
    magnitude of the same DOF's previous coefficient of that band in time and of its parent in the coarser band
    (comparisons/lab/context.py). A still DOF then costs a fraction of a bit per coefficient. Transform, blocks,
    steps and the approximation's prediction (from the previous block; the first from 0) are `wavelet`'s;
    the indices are the coefficients rounded to the nearest step multiple (halves away from zero).

    Two stream layouts:
    - `encode` / `decode`: the SCM1 container (comparisons/lab/streams.py), one b"C" section holding every
      coefficient, models starting at P = 1/2;
    - `encode_compact` / `decode_compact` (`framing = "compact"`: what comparisons/lab/codecs.LabCodec sends):
      the compact layout of comparisons/lab/streams.write_compact, whose payload is one range-coded run of the
      active-DOF mask of the signing layout (one bin per DOF, comparisons/lab/context.code_mask) and then the
      coefficients of
      the active DOFs, every model starting from the state trained offline on other sign languages' clips
      (comparisons/tables/context_priors.npz, tools/train_context_priors.py; per q): on a one-second clip the
      models otherwise spend a good part of the stream learning what every clip looks like. Joints of a finger
      and of neighbouring fingers, and the spine's and neck's joints, move together, so in this layout a DOF may be
      predicted from one earlier DOF of the layout (a fixed table trained with the priors: the source and a weight
      in 1/64): when both are active, the stream carries the DOF's coded coefficients less round(weight x the
      source's), in integers (predict_dofs). The indices, and so the reconstruction, are those of `encode`."""

    name, coder_id, unit = "wavelet-cx", 13, "step (rad)"
    settings = WaveletCoder.settings
    rounding = 0.5  # index = sign(c) floor(|c| / step + rounding)
    framing = "compact"

    def _coded(self, dofs: np.ndarray, step: float) -> tuple[np.ndarray, np.ndarray]:
        """(T, D) radians -> (indices (D, n_blocks, 16), the coded values: approximation differenced)."""
        coeffs = np.concatenate(haar_forward(to_blocks(dofs)), axis=-1) / step
        if not np.all(np.abs(coeffs) < 2.0 ** (lab_context.MAX_CLASS - 1)):
            raise SigncastError(f"{self.name}: DOF values too large for step {step} rad")
        indices = (np.sign(coeffs) * np.floor(np.abs(coeffs) + self.rounding)).astype(np.int64)
        coded = indices.copy()
        coded[..., 0] = np.diff(indices[..., 0], axis=1, prepend=0)
        return indices, coded

    def _encode(self, writer, dofs, fps, step):
        indices, coded = self._coded(dofs, step)
        writer.context_coded(coded)
        return self._reconstruct(indices, step, len(dofs))

    @staticmethod
    def _reconstruct(indices: np.ndarray, step: float, n_frames: int) -> np.ndarray:
        bands, start, width = [indices[..., :1]], 1, 1
        while start < BLOCK:
            bands.append(indices[..., start:start + width])
            start, width = start + width, 2 * width
        return from_blocks(haar_inverse([band * step for band in bands]), n_frames)

    def _read(self, reader, n_frames, step):
        """{"indices": (D, n_blocks, 16)}, as `wavelet`'s."""
        indices = reader.context_coded(self.n_dofs, -(-n_frames // BLOCK))
        indices[..., 0] = np.cumsum(indices[..., 0], axis=1)
        return {"indices": indices}

    def _rebuild(self, read, n_frames, fps, step):
        return self._reconstruct(read["indices"], step, n_frames)

    # ------------------------------------------------------------ compact layout

    def encode_compact(self, dofs: np.ndarray, fps: float, q: int, active: np.ndarray) -> tuple[bytes, np.ndarray]:
        """(T, D) radians of the active DOFs, `active` the (n_layout,) bool mask of the signing layout they are
        (D = its count, the coder's DOFs) -> (compact stream, reconstruction (T, D))."""
        dofs = self.check(dofs, fps, q)
        active = np.asarray(active, dtype=bool)
        priors = context_priors()
        if active.shape != (priors.n_layout,) or int(active.sum()) != self.n_dofs:
            raise SigncastError(f"{self.name}: the active mask must be ({priors.n_layout},) with {self.n_dofs} set")
        indices, coded = self._coded(dofs, self.settings[q])
        coded = predict_dofs(coded, prediction_pairs(active, priors.predictor, priors.weight))
        mask = active.astype(np.int64)
        size = lab_context.payload_capacity(coded.size) + len(mask)
        while True:
            out = np.zeros(size, dtype=np.uint8)
            n_bytes = lab_context.encode_payload(mask, coded, priors.mask_probs.copy(), priors.mask_counts.copy(),
                                                 priors.coeff_probs[q].copy(), priors.coeff_counts[q].copy(), out)
            if n_bytes <= len(out):  # else a noise-like input: code again into the size this pass measured
                break
            size = n_bytes
        if n_bytes < 0:
            raise SigncastError(f"{self.name}: coefficient too large for the context coder")
        stream = coded_streams.write_compact(self.coder_id, int(q), len(dofs), fps, out[:n_bytes].tobytes(),
                                             priors.tag)
        return stream, self._reconstruct(indices, self.settings[q], len(dofs))

    @classmethod
    def decode_compact(cls, data: bytes, n_layout: int) -> tuple[np.ndarray, np.ndarray, float]:
        """Compact stream -> (reconstruction (T, D) radians of the active DOFs, active mask (n_layout,) bool, fps).
        Every size is bounded before allocation (T by the header, D <= n_layout); SigncastError on any damage."""
        indices, active, stream = cls.read_compact_levels(data, n_layout)
        return cls._reconstruct(indices, cls.settings[stream.q], stream.n_frames), active, stream.fps

    @classmethod
    def read_compact_levels(cls, data: bytes, n_layout: int
                            ) -> tuple[np.ndarray, np.ndarray, coded_streams.CompactStream]:
        """Compact stream -> (indices (D, n_blocks, 16) int64 of the D active DOFs, as `_read`'s, prediction and
        approximation differencing undone; active mask (n_layout,) bool; the header): the decoder's exact part."""
        priors = context_priors()
        stream = coded_streams.read_compact(data, cls.coder_id, cls.name, priors.tag)
        if n_layout != priors.n_layout:
            raise SigncastError(f"{cls.name}: the context priors are for {priors.n_layout} DOFs, not {n_layout}")
        q = stream.q
        if q >= len(cls.settings):
            raise SigncastError(f"corrupt {cls.name} stream: operating point {q} out of range")
        check_size(stream.n_frames, n_layout, f"corrupt {cls.name} stream")
        payload = np.frombuffer(stream.payload, dtype=np.uint8).copy()  # the kernel's buffer is writable
        state = lab_context.decoder_state(payload)
        mask = np.zeros(n_layout, dtype=np.int64)
        lab_context.decode_mask(state, payload, mask, priors.mask_probs.copy(), priors.mask_counts.copy())
        n_active = int(mask.sum())
        if n_active == 0:
            raise SigncastError(f"corrupt {cls.name} stream: no active DOF")
        coeffs = np.zeros((n_active, -(-stream.n_frames // BLOCK), BLOCK), dtype=np.int64)
        lab_context.decode_coefficients(state, payload, coeffs, priors.coeff_probs[q].copy(), priors.coeff_counts[q].copy())
        if lab_context.finish_decoder(state, payload) != 0:
            raise SigncastError(f"corrupt {cls.name} stream: payload undecodable (damaged or truncated)")
        unpredict_dofs(coeffs, prediction_pairs(mask.astype(bool), priors.predictor, priors.weight))
        coeffs[..., 0] = np.cumsum(coeffs[..., 0], axis=1)
        return coeffs, mask.astype(bool), stream


WAVEFORM_CODERS = {cls.name: cls for cls in (UniformQuantizer, CompandedQuantizer, DpcmCoder, AdpcmCoder,
                                             DeadReckoningCoder, DctCoder, WaveletCoder, ContextWaveletCoder)}

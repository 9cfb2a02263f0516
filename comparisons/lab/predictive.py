"""Numba kernels of the seed-002 predictive waveform coders' closed loops (comparisons/lab/waveform.py
documents the coders: DPCM, ADPCM, dead reckoning).

Each loop runs frame by frame (a frame's prediction needs the previous decoded frame) over all DOFs,
one call per clip instead of a dozen NumPy calls per frame, and serves both ends: the encoder chooses the
symbols (ties of the nearest-level search go to the lower index, rint rounds half to even) and both ends rebuild
the same reconstruction from them, since they run the same loop on the same machine. The symbols are what the
stream carries; the reconstruction is floating point and may differ between machines by rounding.

Arrays: dofs (T, D) float64 radians (the encoder's input, or an empty (0, D) array when decoding);
symbols (T - 1, D) int64 (filled when encoding, read when decoding); recon (T, D) float64 with row 0
(the first frame) filled by the caller.
"""
import math

import numpy as np
from numba import njit


@njit(cache=True, inline="always")
def _nearest(offsets: np.ndarray, error: float) -> int:
    """Index of the offset nearest `error` (the first on ties, as argmin)."""
    best, best_distance = 0, abs(offsets[0] - error)
    for k in range(1, len(offsets)):
        distance = abs(offsets[k] - error)
        if distance < best_distance:
            best, best_distance = k, distance
    return best


@njit(cache=True, inline="always")
def _clip(value: float, low: float, high: float) -> float:
    """np.clip: min(max(value, low), high)."""
    return min(max(value, low), high)


@njit(cache=True)
def dpcm_loop(steps: np.ndarray, lower: np.ndarray, upper: np.ndarray, encoding: bool, dofs: np.ndarray,
              symbols: np.ndarray, recon: np.ndarray) -> None:
    """First-order DPCM: prediction = previous decoded frame, offsets steps (D, K) ascending."""
    n_frames, n_dofs = recon.shape
    for t in range(1, n_frames):
        for d in range(n_dofs):
            prediction = recon[t - 1, d]
            if encoding:
                symbols[t - 1, d] = _nearest(steps[d], dofs[t, d] - prediction)
            recon[t, d] = _clip(prediction + steps[d, symbols[t - 1, d]], lower[d], upper[d])


@njit(cache=True)
def adpcm_loop(limits: np.ndarray, grid: np.ndarray, taper: np.ndarray, half: int, lower: np.ndarray,
               upper: np.ndarray, encoding: bool, dofs: np.ndarray, symbols: np.ndarray, recon: np.ndarray) -> None:
    """Order-2 backward-adaptive prediction with a Jayant-adapted mu-law quantiser (grid (K,) in [-1, 1]);
    taper: the Hamming window (W,) of the autocorrelation."""
    n_frames, n_dofs = recon.shape
    window = len(taper)
    for d in range(n_dofs):
        scale = limits[d]
        scale_min, scale_max = limits[d] / 2.0, limits[d] * 2.0
        error_order1 = 0.0
        error_order2 = 0.0
        have_order2 = False
        order2 = 0.0
        for t in range(1, n_frames):
            if t < 3:
                prediction = recon[t - 1, d]
            else:
                start = max(0, t - window)
                count = t - start
                total = 0.0
                for s in range(start, t):
                    total += recon[s, d]
                mean = total / count
                first = window - count
                r0 = 0.0
                r1 = 0.0
                r2 = 0.0
                for s in range(count):
                    seg = (recon[start + s, d] - mean) * taper[first + s]
                    r0 += seg * seg
                for s in range(1, count):
                    r1 += ((recon[start + s, d] - mean) * taper[first + s]) * \
                          ((recon[start + s - 1, d] - mean) * taper[first + s - 1])
                for s in range(2, count):
                    r2 += ((recon[start + s, d] - mean) * taper[first + s]) * \
                          ((recon[start + s - 2, d] - mean) * taper[first + s - 2])
                r0 = r0 * (1.0 + 1e-3) + 1e-18
                det = r0 * r0 - r1 * r1
                a1 = r1 * (r0 - r2) / det
                a2 = (r0 * r2 - r1 * r1) / det
                order2 = mean + a1 * (recon[t - 1, d] - mean) + a2 * (recon[t - 2, d] - mean)
                have_order2 = True
                prediction = order2 if error_order2 < error_order1 else recon[t - 1, d]
            if encoding:
                error = dofs[t, d] - prediction
                best, best_distance = 0, abs(scale * grid[0] - error)
                for k in range(1, len(grid)):
                    distance = abs(scale * grid[k] - error)
                    if distance < best_distance:
                        best, best_distance = k, distance
                symbols[t - 1, d] = best
            symbol = symbols[t - 1, d]
            k = symbol - half
            recon[t, d] = _clip(prediction + scale * grid[symbol], lower[d], upper[d])
            scale = _clip(scale * (0.9 + 1.6 * math.pow(k / half, 4.0)), scale_min, scale_max)
            if have_order2:
                difference = recon[t, d] - recon[t - 1, d]
                error_order1 = 0.8 * error_order1 + difference * difference
                miss = recon[t, d] - order2
                error_order2 = 0.8 * error_order2 + miss * miss


@njit(cache=True)
def deadreck_loop(encoding: bool, dofs: np.ndarray, slopes: np.ndarray, threshold: float, value_step: float,
                  velocity_step: float, flags: np.ndarray, value_codes: np.ndarray, velocity_codes: np.ndarray,
                  recon: np.ndarray) -> int:
    """Constant-velocity extrapolation, the loop both ends run. Encoding (dofs (T, D), slopes (T, D) given): where
    the receiver's error exceeds `threshold`, sends a value and a velocity correction, setting flags (T - 1, D)
    int64 and writing the codes in frame then DOF order into value_codes, velocity_codes ((T - 1) D,). Decoding
    (dofs, slopes empty): applies the given flags and codes. Returns how many corrections were used."""
    n_frames, n_dofs = recon.shape
    velocity = np.zeros(n_dofs)
    used = 0
    for t in range(1, n_frames):
        for d in range(n_dofs):
            guess = recon[t - 1, d] + velocity[d]
            if encoding:
                flags[t - 1, d] = 1 if abs(dofs[t, d] - guess) > threshold else 0
                if flags[t - 1, d]:
                    value_codes[used] = np.int64(np.rint((dofs[t, d] - guess) / value_step))
                    velocity_codes[used] = np.int64(np.rint((slopes[t, d] - velocity[d]) / velocity_step))
            if flags[t - 1, d]:
                guess = guess + value_codes[used] * value_step
                velocity[d] = velocity[d] + velocity_codes[used] * velocity_step
                used += 1
            recon[t, d] = guess
    return used

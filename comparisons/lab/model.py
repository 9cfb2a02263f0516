"""Model-based coders of DOF trajectories (seed 002 ch. 8): posture-based, gesture-based and hybrid.

All three work per joint group (the groups of the shipped tables, e.g. a hand's finger DOFs) on
DOF trajectories (T, D) radians at `fps`, and write the container of comparisons/lab/streams.py.
They are scored with VPSNR (motion is re-synthesised, not waveform-matched).

- posture (§8.2.1, §8.4.1, §8.4.3): a key frame each time the group's accumulated posture change
  s(n) = sum ||theta(m) - theta(m-1)|| (radians) crosses a multiple of d; each key posture is sent
  as the index of the nearest entry of the group's posture table (1024 LBG-clustered postures of the
  training split, the clustering alternative the seed names to its greedy d-spacing; joint angles: the
  seed found joint positions better, angles keep the decoder free of forward kinematics); lags between keys are sent; the receiver Hermite-interpolates with
  the slopes of eqs. 8-7/8-8 (zero slope at the first and last key). q picks d.
- gesture (§8.2.2, §8.4.2, §8.4.4): boundaries at the group's speed minima below an adaptive
  threshold tau = beta * (moving average of the speed over nWin); segments longer than nMax are
  re-searched with beta raised by 0.25 (cap 3) and split evenly when that fails. Each segment,
  time-warped to nNorm = 16 samples, is matched to the group's gesture table with the end-weighted
  distance of eqs. 8-12/8-13 (a = 1, b = 0.5, RMS radians); if the best match is farther than E,
  it falls back to posture interpolation toward the nearest posture-table entry of its end frame.
  Segments are joined with the raised cosine of eq. 8-9 over nBlend frames. q picks (nMin, nMax,
  beta): the seed does not say what its six operating points vary; here the segmentation density.
- hybrid (§8.5): the same gesture segmentation, then per DOF a DCT of each segment keeping the
  first 3 coefficients (mean and two cosine amplitudes) quantised with the Appendix III bit
  allocations (4,3,2) ... (7,7,5) = q 0..7; ranges: mean in the DOF range, amplitudes within
  +-1/2 and +-1/4 of it; the first frames of a segment are blended with the previous one.
Frame counts of the seed (30 Hz) are scaled to `fps`.

Contract: the DofCoder interface of comparisons/lab/waveform.py (encode, read_levels, decode, SigncastError on
bad input or damaged streams), with dofs of at least 2 frames; the coders are built from the shipped tables
(comparisons/tables/model_tables.npz) cut to the active DOFs (posture_coder, gesture_coder, hybrid_coder). What
the streams carry (key frames, table indices, segment flags, DCT cells) is listed in each coder's `_read`.

Speed: the speed fits are scipy.signal.savgol_filter's (its coefficients, savgol_coeffs, applied to all groups in
one pass: `savgol_slope`, `group_speeds`); the time warp runs on all columns at once, and the gesture coder warps
all segments in one compiled call (comparisons/lab/gesture.py); Hermite fills and the hybrid coder's quantisers
work on all frames or segments at once; table entries are screened with one matrix product, computing the exact
distance only for the entries that can win (GestureMatcher, PostureMatcher: the bounds are in their docstrings).
"""
from __future__ import annotations

import functools
from pathlib import Path

import numpy as np
from scipy.fft import dct
from scipy.ndimage import convolve1d
from scipy.signal import savgol_coeffs

from comparisons.lab.streams import StreamReader, StreamWriter
from comparisons.lab.vq import TABLES_DIR, group_layout, load_table_file, nearest
from comparisons.lab.waveform import DofCoder, uniform_index, uniform_value
from comparisons.lab.gesture import warp_rows
from media.errors import SigncastError

MODEL_TABLE_PATH = TABLES_DIR / "model_tables.npz"
N_NORM = 16
SEED_FPS = 30.0


def _frames(count_at_30: float, fps: float) -> int:
    return max(int(round(count_at_30 * fps / SEED_FPS)), 1)


# ---------------------------------------------------------------- segmentation

def posture_keys(group: np.ndarray, distance: float) -> np.ndarray:
    """Key frames (sorted, first and last included) where the accumulated change crosses k * distance."""
    steps = np.linalg.norm(np.diff(group, axis=0), axis=1)
    travelled = np.concatenate([[0.0], np.cumsum(steps)])
    level = np.floor(travelled / distance)
    keys = np.flatnonzero(np.diff(level) > 0) + 1
    return np.unique(np.concatenate([[0], keys, [len(group) - 1]])).astype(np.int64)


def group_speed(group: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Scalar speed omega (8-2, per frame) and its derivative alpha (8-3), from 7-sample cubic fits."""
    return group_speeds(group, [np.arange(group.shape[1])])[0]


def group_speeds(dofs: np.ndarray, groups: list[np.ndarray]) -> list[tuple[np.ndarray, np.ndarray]]:
    """group_speed of dofs[:, group] for each group: (omega, alpha) (T,) each, all groups' fits in one
    pass (a column's fit does not depend on its neighbours)."""
    dofs = np.asarray(dofs, dtype=np.float64)
    if len(dofs) < SAVGOL_WINDOW:
        return [_short_speed(dofs[:, group]) for group in groups]
    velocity = savgol_slope(dofs[:, np.concatenate(groups)] if len(groups) > 1 else dofs[:, groups[0]])
    ends = np.cumsum([len(group) for group in groups])
    omega = np.stack([np.linalg.norm(velocity[:, end - len(group):end], axis=1)
                      for group, end in zip(groups, ends)], axis=1)
    alpha = savgol_slope(omega)
    return [(omega[:, g], alpha[:, g]) for g in range(len(groups))]


def _short_speed(group: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    omega = np.linalg.norm(np.gradient(group, axis=0), axis=1) if len(group) > 1 else np.zeros(len(group))
    alpha = np.gradient(omega) if len(group) > 1 else np.zeros(len(group))
    return omega, alpha


SAVGOL_WINDOW, SAVGOL_ORDER = 7, 3


@functools.lru_cache(maxsize=1)
def _savgol_weights() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """scipy.signal.savgol_coeffs of the 7-sample cubic fit's slope: the interior convolution kernel, and the dot
    weights (3, 7) of the slope at the first three and the last three samples of an edge window (savgol_filter's
    mode "interp" fits the polynomial to those 7 samples; its slope there is this dot product), read-only."""
    half = SAVGOL_WINDOW // 2
    interior = savgol_coeffs(SAVGOL_WINDOW, SAVGOL_ORDER, deriv=1)
    first = np.stack([savgol_coeffs(SAVGOL_WINDOW, SAVGOL_ORDER, deriv=1, pos=k, use="dot") for k in range(half)])
    last = np.stack([savgol_coeffs(SAVGOL_WINDOW, SAVGOL_ORDER, deriv=1, pos=k, use="dot")
                     for k in range(SAVGOL_WINDOW - half, SAVGOL_WINDOW)])
    for array in (interior, first, last):
        array.setflags(write=False)
    return interior, first, last


def savgol_slope(x: np.ndarray) -> np.ndarray:
    """scipy.signal.savgol_filter(x, 7, 3, deriv=1, axis=0) (mode "interp"), to rounding (~1e-15 relative):
    x (T >= 7, ...) -> (T, ...) per-frame slopes (units of x per frame). The coefficients are scipy's
    (savgol_coeffs, computed once); the convolution and the two edge fits are applied here, without
    savgol_filter's per-call set-up, which costs 5-10x the arithmetic on these short clips."""
    interior, first, last = _savgol_weights()
    x = np.asarray(x, dtype=np.float64)
    if len(x) < SAVGOL_WINDOW:
        raise SigncastError(f"speed estimate needs at least {SAVGOL_WINDOW} frames, got {len(x)}")
    half = SAVGOL_WINDOW // 2
    slopes = convolve1d(x, interior, axis=0, mode="constant")
    flat = x.reshape(len(x), -1)
    slopes[:half] = (first @ flat[:SAVGOL_WINDOW]).reshape((half,) + x.shape[1:])
    slopes[len(x) - half:] = (last @ flat[len(x) - SAVGOL_WINDOW:]).reshape((half,) + x.shape[1:])
    return slopes


def gesture_boundaries(group: np.ndarray, fps: float, n_min: int, n_max: int, beta: float = 0.75,
                       window_s: float = 20 / SEED_FPS, speed: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """Segment boundaries (frames, first and last included) at speed minima (§8.2.2).
    speed: group_speed(group) when the caller has it (group_speeds of several groups at once)."""
    n = len(group)
    if n < 2:
        return np.array([0], dtype=np.int64)
    omega, alpha = speed if speed is not None else group_speed(group)
    n_win = max(int(round(window_s * fps)), 1)
    padded = np.concatenate([np.full(n_win - 1, omega[0]), omega])
    average = np.convolve(padded, np.ones(n_win) / n_win, mode="valid")
    minimum = np.zeros(n, dtype=bool)
    minimum[1:] = (alpha[:-1] < 0) & (alpha[1:] >= 0)

    def search(start: int, stop: int, scale: float) -> list[int]:
        picked, last = [], start
        low, high = start + n_min, stop - n_min + 1
        if high <= low:
            return picked
        below = minimum[low:high] & (omega[low:high] < scale * average[low:high])
        for frame in (np.flatnonzero(below) + low).tolist():
            if frame - last >= n_min:
                picked.append(frame)
                last = frame
        return picked

    bounds = [0] + search(0, n - 1, beta) + [n - 1]
    result = [0]
    for start, stop in zip(bounds[:-1], bounds[1:]):
        inner, scale = [], beta
        while stop - start > n_max and not inner and scale < 3.0:
            scale += 0.25
            inner = search(start, stop, scale)
        pieces = [start] + inner + [stop]
        for a, b in zip(pieces[:-1], pieces[1:]):
            count = -(-(b - a) // n_max)
            result += [int(round(a + (b - a) * k / count)) for k in range(1, count + 1)]
    return np.unique(np.asarray(result, dtype=np.int64))


# ---------------------------------------------------------------- interpolation

def hermite_fill(keys: np.ndarray, values: np.ndarray, n_frames: int) -> np.ndarray:
    """Cubic Hermite through key frames (8-5, 8-6) with decoder-estimated slopes (8-7, 8-8). (T, K)."""
    out = np.empty((n_frames, values.shape[1]))
    if len(keys) == 1:
        out[:] = values[0]
        return out
    lags = np.diff(keys).astype(np.float64)  # r(m)
    secants = np.diff(values, axis=0) / lags[:, None]  # per frame
    slopes = np.zeros_like(values)
    s = lags[1:] / (lags[:-1] + lags[1:])
    slopes[1:-1] = s[:, None] * secants[:-1] + (1.0 - s)[:, None] * secants[1:]
    # every frame at once, each in the last key interval [a, b] that holds it (a key frame starts the next one)
    frames = np.arange(n_frames)
    m = np.minimum(np.searchsorted(keys, frames, side="right") - 1, len(keys) - 2)
    a, r = keys[m], keys[m + 1] - keys[m]
    t = (frames - a) / r
    cube = t * t * t
    h00, h10 = 2 * cube - 3 * t ** 2 + 1, cube - 2 * t ** 2 + t
    h01, h11 = -2 * cube + 3 * t ** 2, cube - t ** 2
    out[:] = (h00[:, None] * values[m] + h10[:, None] * r[:, None] * slopes[m]
              + h01[:, None] * values[m + 1] + h11[:, None] * r[:, None] * slopes[m + 1])
    return out


@functools.lru_cache(maxsize=512)
def raised_cosine(n: int) -> np.ndarray:
    """w(t) = (1 + cos(pi t)) / 2 at t = 0, 1/(n-1), ..., 1 (eq. 8-9): 1 -> 0. (n,), read-only (shared)."""
    w = np.ones(1) if n == 1 else (1.0 + np.cos(np.pi * np.arange(n) / (n - 1))) / 2.0
    w.setflags(write=False)
    return w


@functools.lru_cache(maxsize=1024)
def _warp_plan(n_source: int, length: int) -> tuple[np.ndarray, ...]:
    """For warping n_source >= 2 samples to `length`: the interval j (length,) of each target time t
    (source[j] <= t < source[j + 1], the last interval for t = 1), t - source[j] and source[j + 1] - source[j]
    (length, 1), where t is a source sample, and which sample."""
    source = np.linspace(0.0, 1.0, n_source)
    target = np.linspace(0.0, 1.0, length)
    j = np.minimum(np.searchsorted(source, target, side="right") - 1, n_source - 2)
    last = target == source[-1]
    exact = (target == source[j]) | last
    exact_at = np.where(last, n_source - 1, j)[exact]
    plan = (j, (target - source[j])[:, None], (source[j + 1] - source[j])[:, None], exact, exact_at)
    for array in plan:
        array.setflags(write=False)
    return plan


def warp(segment: np.ndarray, length: int) -> np.ndarray:
    """Linear time warp of (L, K) to (length, K)."""
    if len(segment) == 1:
        return np.repeat(segment, length, axis=0)
    # np.interp on a uniform grid of every column at once, with its arithmetic: slope (y[j+1] - y[j]) / (x[j+1] -
    # x[j]) on the interval x[j] <= t < x[j+1], then slope (t - x[j]) + y[j]; the sample itself where t hits one
    j, offset, spacing, exact, exact_at = _warp_plan(len(segment), length)
    out = (segment[j + 1] - segment[j]) / spacing * offset + segment[j]
    out[exact] = segment[exact_at]
    return out


def warp_segments(source: np.ndarray, starts, counts, lengths) -> np.ndarray:
    """warp(source[start:start + count], length) of every (start, count, length), concatenated:
    (sum(lengths), K): comparisons/lab/gesture.warp_rows does warp's element-wise arithmetic for all segments in
    one call."""
    starts, counts, lengths = (np.asarray(v, dtype=np.int64) for v in (starts, counts, lengths))
    if np.any(counts < 2):
        return np.concatenate([warp(source[a:a + n], m) for a, n, m in zip(starts, counts, lengths)])
    out = np.empty((int(lengths.sum()), source.shape[1]))
    warp_rows(np.ascontiguousarray(source, dtype=np.float64), starts, counts, lengths, out)
    return out


def gesture_weights(n_norm: int = N_NORM, a: float = 1.0, b: float = 0.5) -> np.ndarray:
    """End-emphasising weights of eq. 8-13 for samples n = 1..N."""
    n = np.arange(1, n_norm + 1, dtype=np.float64)
    return np.where(n <= n_norm / 2, b + (a - b) / n, b + (a - b) / (n_norm - n + 1))


def gesture_distance(warped: np.ndarray, table: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Weighted RMS distance (radians) of warped (N, K) to each table entry (M, N, K), eq. 8-12."""
    squared = np.subtract(table, warped[None])
    np.square(squared, out=squared)
    squared = np.einsum("mnk,n->m", squared, weights)
    return np.sqrt(squared / (weights.sum() * warped.shape[1]))


_EPS = np.finfo(np.float64).eps


class GestureMatcher:
    """The best gesture_distance match of many warped segments against one table (M, N, K), bitwise as
    gesture_distance + argmin per segment, without computing every exact distance.

    Screening: the weighted squared distance s = a_m - 2 p + b (a_m = sum w T^2, p = sum w T x, b = sum w x^2)
    of all segments and entries comes from one matrix product. Any summation order of such sums of N K
    terms is within (N K + 4) eps (a_m + b) of the exact value, so bound = 8 (N K + 16) eps (max a + b)
    covers both the screened value's error and gesture_distance's own: an entry screened above the
    segment's minimum by more than 3 bounds (plus a relative margin for the rounding of the division and
    square root) can be neither the argmin nor tie with it. The remaining candidates (usually one per
    segment) get gesture_distance's exact arithmetic: the same subtraction, square and einsum on
    (candidates, N, K) rows, which computes each row as for the whole table (einsum reduces each row over
    n and k alone), and argmin picks the first of equal distances as before."""

    def __init__(self, table: np.ndarray, weights: np.ndarray):
        self.table = table
        self.weights = weights
        m, n, k = table.shape
        self.denominator = weights.sum() * k
        weighted = table * weights[None, :, None]
        self.weighted_flat = np.ascontiguousarray(weighted.reshape(m, n * k).T)  # (N K, M)
        self.energy = np.einsum("mnk,mnk->m", weighted, table)  # a_m
        self.column_weights = np.repeat(weights, k)  # (N K,) w of each flattened column
        self.tolerance = 8.0 * (n * k + 16) * _EPS
        self.largest = float(self.energy.max(initial=0.0))

    def match(self, warped: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """warped (S, N, K) -> (index of the nearest entry (S,) int64, its distance (S,) as gesture_distance)."""
        s, n, k = warped.shape
        flat = warped.reshape(s, n * k)
        energy = (flat * flat) @ self.column_weights  # b
        screened = self.energy - 2.0 * (flat @ self.weighted_flat)
        lowest = screened.min(axis=1) + energy
        ceiling = lowest + self.tolerance * (np.abs(lowest) + 3.0 * (self.largest + energy)) - energy
        segment, entry = np.nonzero(screened <= ceiling[:, None])  # segment-major, entries ascending
        squared = np.empty((len(entry), n, k))
        np.subtract(self.table[entry], warped[segment], out=squared)
        np.square(squared, out=squared)
        distance = np.sqrt(np.einsum("mnk,n->m", squared, self.weights) / self.denominator)
        if len(entry) == s:  # one candidate per segment
            return entry, distance
        best, best_distance = np.empty(s, dtype=np.int64), np.empty(s)
        first = np.searchsorted(segment, np.arange(s + 1))
        for g in range(s):
            pick = first[g] + int(distance[first[g]:first[g + 1]].argmin())
            best[g], best_distance[g] = entry[pick], distance[pick]
        return best, best_distance


class PostureMatcher:
    """comparisons/lab/vq.nearest(row[None], codebook) of many rows, bitwise, one matrix product for all.
    nearest's value norms_m - 2 v.c_m is within (K + 2) eps (norms_m + 2 |v| |c_m|) of exact whatever the
    summation order of the dot product, so a row whose screened values leave a single entry within twice
    that bound (4 (K + 16) eps (max norms + 2 |v| max |c|)) of its minimum has nearest's answer; rows with
    several entries in reach, and single rows, go to nearest itself."""

    def __init__(self, codebook: np.ndarray):
        self.codebook = codebook
        self.codebook_t = np.ascontiguousarray(codebook.T)
        self.norms = np.einsum("mk,mk->m", codebook, codebook)
        self.largest = float(self.norms.max(initial=0.0))
        self.tolerance = 4.0 * (codebook.shape[1] + 16) * _EPS

    def nearest(self, rows: np.ndarray) -> np.ndarray:
        """rows (F, K) -> (F,) int64 indices into the codebook."""
        if len(rows) == 1:
            return nearest(rows, self.codebook)
        screened = self.norms - 2.0 * (rows @ self.codebook_t)
        lengths = np.sqrt(np.einsum("fk,fk->f", rows, rows))
        bound = self.tolerance * (self.largest + 2.0 * np.sqrt(self.largest) * lengths)
        out = screened.argmin(axis=1)
        ceiling = screened[np.arange(len(rows)), out] + 2.0 * bound
        for f in np.flatnonzero((screened <= ceiling[:, None]).sum(axis=1) > 1):
            out[f] = nearest(rows[f:f + 1], self.codebook)[0]
        return out


# ---------------------------------------------------------------- tables

def load_model_tables(path: Path = MODEL_TABLE_PATH) -> dict[str, np.ndarray]:
    return load_table_file(path, "posture/gesture tables")


# ---------------------------------------------------------------- coders

class _GroupCoder(DofCoder):
    quality_measure = "vpsnr"
    min_frames = 2

    def __init__(self, lower, upper, groups: list[np.ndarray], postures: list[np.ndarray],
                 gestures: list[np.ndarray] | None = None, *, stage: str | None = None):
        super().__init__(lower, upper, stage=stage)
        self.groups = [np.asarray(g, dtype=np.int64) for g in groups]
        self.postures = [np.asarray(p, dtype=np.float64) for p in postures]
        self.gestures = [np.asarray(g, dtype=np.float64) for g in gestures] if gestures is not None else None

    def _write_keys(self, writer: StreamWriter, keys: np.ndarray) -> None:
        writer.signed(np.diff(keys) - 1)

    def _read_keys(self, reader: StreamReader, n_frames: int) -> np.ndarray:
        """Key frames (K,) int64 from 0 to n_frames - 1: at most n_frames - 1 lags follow the first."""
        keys = np.concatenate([[0], np.cumsum(reader.signed(n_frames - 1, at_most=True) + 1)]).astype(np.int64)
        if np.any(np.diff(keys) < 1) or keys[-1] != n_frames - 1:
            raise SigncastError(f"corrupt {self.name} stream: key frames do not span the clip")
        return keys


class PostureCoder(_GroupCoder):
    """Posture-based coding: key postures by posture distance, posture-table indices, Hermite."""

    name, coder_id, unit = "posture", 10, "posture distance d (rad)"
    settings = tuple(6.4 / k for k in (1, 2, 3, 4, 6, 8, 12, 16, 24, 32))  # seed: 80 / k, k = 1..8

    def _encode(self, writer, dofs, fps, distance):
        recon = np.empty_like(dofs)
        for group, table in zip(self.groups, self.postures):
            keys = posture_keys(dofs[:, group], distance)
            index = nearest(dofs[keys][:, group], table)
            self._write_keys(writer, keys)
            writer.symbols(index, len(table))
            recon[:, group] = hermite_fill(keys, table[index], len(dofs))
        return recon

    def _read(self, reader, n_frames, distance):
        """Per group g: {"keys.g": (K,) key frames (0 first, T - 1 last), "index.g": (K,) posture-table indices}."""
        read = {}
        for g, table in enumerate(self.postures):
            read[f"keys.{g}"] = keys = self._read_keys(reader, n_frames)
            read[f"index.{g}"] = reader.symbols(len(table), len(keys))
        return read

    def _rebuild(self, read, n_frames, fps, distance):
        recon = np.empty((n_frames, self.n_dofs))
        for g, (group, table) in enumerate(zip(self.groups, self.postures)):
            recon[:, group] = hermite_fill(read[f"keys.{g}"], table[read[f"index.{g}"]], n_frames)
        return recon


class GestureCoder(_GroupCoder):
    """Gesture-based coding: speed-minimum segments matched to a gesture table, posture fallback."""

    name, coder_id, unit = "gesture", 11, "(nMin, nMax at 30 Hz, beta)"
    settings = ((12, 90, 0.5), (9, 75, 0.75), (7, 60, 1.0), (5, 45, 1.5), (4, 30, 2.0), (3, 20, 3.0))
    fit_threshold = 0.12  # E: weighted RMS radians per DOF
    blend_at_30 = 10

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        weights = gesture_weights()
        self.matchers = [(GestureMatcher(table, weights), PostureMatcher(postures))
                         for table, postures in zip(self.gestures, self.postures)]

    def _synthesise(self, table, postures, start_value, lengths, flags, indices, fallbacks, n_blend):
        """The receiver: segments of `lengths` (frames incl. both ends) from gesture entries or posture
        fallbacks, raised-cosine joined to the previous segment's last frame. The gesture entries are
        warped all at once (warp_segments), then joined in order."""
        lengths = np.asarray(lengths, dtype=np.int64)
        flags = np.asarray(flags, dtype=np.int64)
        out = np.empty((int(lengths.sum()) + 1, len(start_value)))
        out[0] = start_value
        gesture_lengths = lengths[flags != 0] + 1
        if len(gesture_lengths):
            entries = table[np.asarray(indices, dtype=np.int64)]
            warped = warp_segments(entries.reshape(-1, entries.shape[2]), N_NORM * np.arange(len(entries)),
                                   np.full(len(entries), N_NORM), gesture_lengths)
        previous, row, g_at, p_used = start_value, 1, 0, 0
        for length, is_gesture in zip(lengths.tolist(), flags.tolist()):
            if is_gesture:
                segment = warped[g_at:g_at + length + 1]
                g_at += length + 1
                blend = min(n_blend, length + 1)
                w = raised_cosine(blend)[:, None]
                segment[:blend] = w * previous + (1.0 - w) * segment[:blend]
            else:
                target = postures[fallbacks[p_used]]
                p_used += 1
                w = raised_cosine(length + 1)[:, None]
                segment = w * previous + (1.0 - w) * target
            out[row:row + length] = segment[1:]
            row += length
            previous = segment[-1]
        return out

    def _encode(self, writer, dofs, fps, setting):
        n_min, n_max = (_frames(v, fps) for v in setting[:2])
        n_blend = _frames(self.blend_at_30, fps)
        recon = np.empty_like(dofs)
        speeds = group_speeds(dofs, self.groups)
        for group, postures, table, speed, (gestures, nearest_posture) in zip(
                self.groups, self.postures, self.gestures, speeds, self.matchers):
            x = dofs[:, group]
            bounds = gesture_boundaries(x, fps, n_min, n_max, beta=setting[2], speed=speed)
            n_segments = len(bounds) - 1
            warped = warp_segments(x, bounds[:-1], np.diff(bounds) + 1, np.full(n_segments, N_NORM))
            best, distance = gestures.match(warped.reshape(n_segments, N_NORM, len(group)))
            fits = distance <= self.fit_threshold
            flags = fits.astype(np.int64)
            indices = best[fits]
            chosen = nearest_posture.nearest(np.concatenate([x[:1], x[bounds[1:][~fits]]]))
            start, fallbacks = int(chosen[0]), chosen[1:]
            self._write_keys(writer, bounds)
            writer.symbols(flags, 2)
            writer.symbols(indices, len(table))
            writer.symbols(chosen, len(postures))
            recon[:, group] = self._synthesise(table, postures, postures[start], np.diff(bounds), flags,
                                               indices, fallbacks, n_blend)
        return recon

    def _read(self, reader, n_frames, setting):
        """Per group g: {"bounds.g": (S + 1,) segment boundaries (0 first, T - 1 last), "flags.g": (S,) 1 = gesture
        entry, 0 = posture fallback, "gestures.g": (flags.sum(),) gesture-table indices, "postures.g":
        (1 + fallbacks,) posture-table indices (the start posture, then each fallback's target)}."""
        read = {}
        for g, (postures, table) in enumerate(zip(self.postures, self.gestures)):
            read[f"bounds.{g}"] = bounds = self._read_keys(reader, n_frames)
            read[f"flags.{g}"] = flags = reader.symbols(2, len(bounds) - 1)
            read[f"gestures.{g}"] = reader.symbols(len(table), int(flags.sum()))
            read[f"postures.{g}"] = reader.symbols(len(postures), 1 + int((flags == 0).sum()))
        return read

    def _rebuild(self, read, n_frames, fps, setting):
        n_blend = _frames(self.blend_at_30, fps)
        recon = np.empty((n_frames, self.n_dofs))
        for g, (group, postures, table) in enumerate(zip(self.groups, self.postures, self.gestures)):
            posture_index = read[f"postures.{g}"]
            recon[:, group] = self._synthesise(table, postures, postures[posture_index[0]], np.diff(read[f"bounds.{g}"]),
                                               read[f"flags.{g}"], read[f"gestures.{g}"], posture_index[1:], n_blend)
        return recon


HYBRID_ALLOCATIONS = ((4, 3, 2), (4, 4, 2), (5, 4, 3), (5, 5, 3), (6, 5, 4), (6, 6, 4), (7, 6, 5), (7, 7, 5))


class HybridCoder(_GroupCoder):
    """Hybrid: gesture segmentation, then per DOF the first 3 DCT coefficients of each segment."""

    name, coder_id, unit = "hybrid", 12, "bits for DCT coefficients 0, 1, 2"
    settings = HYBRID_ALLOCATIONS
    segmentation_at_30 = (5, 60)
    blend_at_30 = 3

    def _quantisers(self, bits):
        """(lower, width, levels) per coefficient: mean over the range, amplitudes symmetric."""
        return [(self.lower, self.width, 1 << bits[0]),
                (-self.width / 2, self.width, (1 << bits[1]) - 1),
                (-self.width / 4, self.width / 2, (1 << bits[2]) - 1)]

    def _segment_values(self, coefficients: np.ndarray, length: int) -> np.ndarray:
        """(3, K) mean and cosine amplitudes -> (length, K)."""
        return _cosine_basis(length).T @ coefficients

    def _synthesise(self, group, bounds, index, quantisers, n_blend):
        """Receiver: segments [a, b) (the last one includes the final frame) from quantised coefficients
        index: 3 arrays (segments, K)."""
        n_frames = bounds[-1] + 1
        ends = list(bounds[1:-1]) + [n_frames]
        out = np.empty((n_frames, len(group)))
        previous = None
        coefficients = np.stack([uniform_value(index[k], lo[group], width[group], levels)
                                 for k, (lo, width, levels) in enumerate(quantisers)], axis=1)  # (segments, 3, K)
        for s, (a, b) in enumerate(zip(bounds[:-1], ends)):
            values = self._segment_values(coefficients[s], b - a)
            if previous is not None:
                blend = min(n_blend, b - a)
                w = raised_cosine(blend + 2)[1:-1, None]
                values[:blend] = w * previous + (1.0 - w) * values[:blend]
            out[a:b] = values
            previous = values[-1]
        return out

    def _encode(self, writer, dofs, fps, bits):
        quantisers = self._quantisers(bits)
        n_min, n_max = (_frames(v, fps) for v in self.segmentation_at_30)
        n_blend = _frames(self.blend_at_30, fps)
        recon = np.empty_like(dofs)
        for group, speed in zip(self.groups, group_speeds(dofs, self.groups)):
            x = dofs[:, group]
            bounds = gesture_boundaries(x, fps, n_min, n_max, speed=speed)
            ends = np.array(list(bounds[1:-1]) + [len(dofs)], dtype=np.int64)
            lengths = ends - bounds[:-1]
            c = np.zeros((len(lengths), 3, len(group)))  # the first 3 DCT coefficients of each segment
            for s, (a, b) in enumerate(zip(bounds[:-1], ends)):
                head = dct(x[a:b], type=2, norm="ortho", axis=0)[:3]
                c[s, :len(head)] = head
            values = [c[:, 0] / np.sqrt(lengths)[:, None], c[:, 1] * np.sqrt(2.0 / lengths)[:, None],
                      c[:, 2] * np.sqrt(2.0 / lengths)[:, None]]
            index = [uniform_index(values[k], lo[group], width[group], levels)
                     for k, (lo, width, levels) in enumerate(quantisers)]
            self._write_keys(writer, bounds)
            writer.signed(np.diff(index[0], axis=0, prepend=0))
            for k in (1, 2):
                writer.symbols(index[k], quantisers[k][2])
            recon[:, group] = self._synthesise(group, bounds, index, quantisers, n_blend)
        return recon

    def _read(self, reader, n_frames, bits):
        """Per group g of K DOFs: {"bounds.g": (S + 1,) segment boundaries (0 first, T - 1 last), "coeffs.g":
        (S, 3, K) cells of each segment's mean and two cosine amplitudes (0 .. 2^bits - 1, 2^bits - 2, ...)}."""
        quantisers = self._quantisers(bits)
        read = {}
        for g, group in enumerate(self.groups):
            read[f"bounds.{g}"] = bounds = self._read_keys(reader, n_frames)
            n_segments = len(bounds) - 1
            index = [np.cumsum(reader.signed(n_segments * len(group)).reshape(n_segments, len(group)), axis=0)]
            if index[0].min() < 0 or index[0].max() >= quantisers[0][2]:
                raise SigncastError("corrupt hybrid stream: segment mean out of range")
            for k in (1, 2):
                index.append(reader.symbols(quantisers[k][2], n_segments * len(group)).reshape(n_segments, len(group)))
            read[f"coeffs.{g}"] = np.stack(index, axis=1)
        return read

    def _rebuild(self, read, n_frames, fps, bits):
        quantisers = self._quantisers(bits)
        n_blend = _frames(self.blend_at_30, fps)
        recon = np.empty((n_frames, self.n_dofs))
        for g, group in enumerate(self.groups):
            coeffs = read[f"coeffs.{g}"]
            index = [coeffs[:, k] for k in range(3)]
            recon[:, group] = self._synthesise(group, read[f"bounds.{g}"], index, quantisers, n_blend)
        return recon


@functools.lru_cache(maxsize=512)
def _cosine_basis(length: int) -> np.ndarray:
    """(3, length): 1, cos(pi k (2n + 1) / (2 length)) for k = 1, 2 (the hybrid coder's DCT basis), read-only."""
    n = np.arange(length)
    basis = np.stack([np.ones(length)] + [np.cos(np.pi * k * (2 * n + 1) / (2 * length)) for k in (1, 2)])
    basis.setflags(write=False)
    return basis


def _load(dof_names, tables):
    tables = tables if tables is not None else load_model_tables()
    layout = group_layout(tables, list(dof_names), prefix="model")
    groups = [idx for _, idx, _ in layout]
    postures = [tables[f"posture_{g}"][:, columns] for g, _, columns in layout]
    gestures = [tables[f"gesture_{g}"][:, :, columns] for g, _, columns in layout]
    return groups, postures, gestures


def posture_coder(lower, upper, dof_names, tables=None, stage=None) -> PostureCoder:
    groups, postures, _ = _load(dof_names, tables)
    return PostureCoder(lower, upper, groups, postures, stage=stage)


def gesture_coder(lower, upper, dof_names, tables=None, stage=None) -> GestureCoder:
    groups, postures, gestures = _load(dof_names, tables)
    return GestureCoder(lower, upper, groups, postures, gestures, stage=stage)


def hybrid_coder(lower, upper, dof_names, tables=None, stage=None) -> HybridCoder:
    groups, postures, _ = _load(dof_names, tables)
    return HybridCoder(lower, upper, groups, postures, stage=stage)

"""Numba-compiled closed loop of the predictive BBA coder's levels (comparisons/params/bba.py `_levels`).

For a stream whose units all carry the same values (P of them), unit by unit: a predicted unit codes
the quantised change from the decoder's previous values (angles folded into (-pi, pi], and near +-pi
the equivalent a full turn away where it quantises closer); a predicted unit with a level beyond the
range fields' limit is sent intra instead; an intra unit codes the quantised values (an angle whose
level does not fit is folded first); the decoder's values follow. Integer arithmetic only, the same
operations as comparisons/param_coding.quantize and comparisons/bba_codec.fold_angles / _p_levels /
_intra_levels, so the levels are those of the NumPy loop. Imports nothing of signcast.
"""
import numpy as np
from numba import njit


@njit(cache=True)
def _quantize(value, step):
    """Level 0 if |v| <= step / 2, else sign(v) (|v| + step // 2) // step."""
    magnitude = abs(value)
    if 2 * magnitude <= step:
        return 0
    level = (magnitude + step // 2) // step
    return level if value > 0 else -level


@njit(cache=True)
def _fold(value, period):
    """value folded into (-period / 2, period / 2]: half - (half - value) mod period (a value already there is
    returned as it is without the division, the same number)."""
    half = period // 2
    if half - period < value <= half:
        return value
    rest = (half - value) % period
    if rest < 0:
        rest += period
    return half - rest


@njit(cache=True)
def predictive_levels(values: np.ndarray, base_steps: np.ndarray, is_angle: np.ndarray, q: int, limit: int,
                      period: int, intra: np.ndarray, levels: np.ndarray) -> int:
    """values: (U, P) int64, one row per unit; base_steps: (P,) int64; is_angle: (P,) bool; intra: (U,)
    bool, in: units sent intra by rule, out: also those whose P levels do not fit. Fills levels (U, P).
    Returns -1, or U * p + u for the first intra level (unit u, value p) beyond the limit (nothing
    after that unit is valid)."""
    n_units, n_values = values.shape
    held = np.zeros(n_values, dtype=np.int64)
    for u in range(n_units):
        if not intra[u]:
            for p in range(n_values):
                step = base_steps[p] * q
                change = values[u, p] - held[p]
                folded = _fold(change, period) if is_angle[p] else change
                level = _quantize(folded, step)
                if is_angle[p] and abs(folded) > period // 2 - step:
                    sign = 1 if folded > 0 else (-1 if folded < 0 else 0)
                    other = folded - sign * period
                    other_level = _quantize(other, step)
                    if abs(other_level * step - other) < abs(level * step - folded):
                        level = other_level
                levels[u, p] = level
                if abs(level) > limit:
                    intra[u] = True
        if intra[u]:
            for p in range(n_values):
                step = base_steps[p] * q
                level = _quantize(values[u, p], step)
                if abs(level) > limit and is_angle[p]:
                    level = _quantize(_fold(values[u, p], period), step)
                if abs(level) > limit:
                    return n_units * p + u
                levels[u, p] = level
                held[p] = level * step
        else:
            for p in range(n_values):
                step = base_steps[p] * q
                recon = held[p] + levels[u, p] * step
                held[p] = _fold(recon, period) if is_angle[p] else recon
    return -1

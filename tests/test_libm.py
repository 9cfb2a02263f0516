"""comparisons/params/libm.py gives the C library's results, element for element, whatever NumPy's SIMD dispatch does
on this CPU, in every shape the coders call it with."""
import ctypes
import ctypes.util
import math

import numpy as np
import pytest

from comparisons.params import libm

_C = ctypes.CDLL(ctypes.util.find_library("m"))
for _name, _arity in {"acos": 1, "sin": 1, "cos": 1, "atan2": 2, "log1p": 1, "expm1": 1, "log2": 1, "exp2": 1,
                      "pow": 2}.items():
    getattr(_C, _name).restype = ctypes.c_double
    getattr(_C, _name).argtypes = [ctypes.c_double] * _arity


def _arguments(low, high, n=4000, seed=0):
    rng = np.random.default_rng(seed)
    return np.concatenate([rng.uniform(low, high, n), [low, high, 0.0 if low <= 0 <= high else low]])


@pytest.mark.parametrize("ours, theirs, low, high", [
    (libm.arccos, "acos", -1.0, 1.0), (libm.sin, "sin", -10.0, 10.0), (libm.cos, "cos", -10.0, 10.0),
    (libm.log1p, "log1p", -0.999, 50.0), (libm.expm1, "expm1", -20.0, 20.0), (libm.log2, "log2", 1e-9, 1e6),
    (libm.exp2, "exp2", -30.0, 30.0)])
def test_unary_functions_are_the_c_librarys_bit_for_bit(ours, theirs, low, high):
    x = _arguments(low, high)
    expected = np.array([getattr(_C, theirs)(v) for v in x])
    assert np.array_equal(ours(x).view(np.int64), expected.view(np.int64))


def test_two_argument_functions_broadcast_and_are_the_c_librarys():
    y, x = _arguments(-3.0, 3.0, 300, 1)[:, None], _arguments(-3.0, 3.0, 7, 2)[None, :]
    angles = libm.arctan2(y, x)
    assert angles.shape == (y.size, x.size)
    assert np.array_equal(angles, [[_C.atan2(a, b) for b in x[0]] for a in y[:, 0]])
    t = _arguments(0.0, 1.0, 500, 3)
    assert np.array_equal(libm.power(t, 3.0), [_C.pow(v, 3.0) for v in t])


def test_shapes_scalars_and_non_contiguous_inputs():
    grid = np.arange(24.0).reshape(4, 6)[:, ::2] / 24.0        # a strided view
    assert libm.arccos(grid).shape == (4, 3) and np.array_equal(libm.arccos(grid), np.vectorize(math.acos)(grid))
    assert isinstance(libm.log2(8.0), float) and libm.log2(8.0) == 3.0
    assert libm.log2(np.float64(0.5)) == -1.0
    assert np.isnan(libm.arccos(1.5)) and libm.sin(np.empty((0, 3))).shape == (0, 3)


def _fma_chain(row, column) -> float:
    """fma(row[K-1], column[K-1], ... fma(row[0], column[0], 0)), each step rounded once (exact rationals)."""
    from fractions import Fraction
    total = 0.0
    for x, y in zip(row, column):
        total = float(Fraction(x) * Fraction(y) + Fraction(total))
    return total


def test_ordered_matmul_is_a_chain_of_fused_multiply_adds_in_order():
    from comparisons.params import ordered_products
    rng = np.random.default_rng(5)
    a, b = rng.normal(size=(7, 17)), rng.normal(size=(17, 5)) * 10.0 ** rng.integers(-8, 8, size=(17, 5))
    expected = np.array([[_fma_chain(a[i], b[:, j]) for j in range(5)] for i in range(7)])
    assert np.array_equal(ordered_products.matmul(a, b), expected)
    assert np.array_equal(ordered_products.matmul(np.asfortranarray(a), np.asfortranarray(b)), expected)
    plain = np.array([[sum((a[i, k] * b[k, j] for k in range(17)), 0.0) for j in range(5)] for i in range(7)])
    assert not np.array_equal(plain, expected)          # the inputs tell a fused chain from plain sums
    with pytest.raises(ValueError, match=r"\(M, K\) and \(K, N\)"):
        ordered_products.matmul(a, b.T)

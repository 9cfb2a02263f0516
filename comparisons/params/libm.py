"""Transcendental functions of float64 arrays that give the same bits on every x86-64 CPU: the C library's
(glibc's libm), one call per element, compiled by Numba.

NumPy's own ufuncs (np.arccos, np.log1p, np.expm1, np.log2, np.exp2, np.power, ...) dispatch on the CPU: on
one with AVX-512 they run SIMD code (derived from Intel's SVML) whose last bits differ from libm's, while on an
AVX2 CPU the same call is libm's. Measured on 200,000 random arguments on an AVX-512 machine: arccos differed
in 9 %, expm1 in 10 %, log1p in 7 %. What a stream carries, or a decoder gives, must not depend on which CPU
ran it, so the coders' and decoders' transcendental arithmetic goes through here. These are libm's results,
bitwise what NumPy gives on a CPU without AVX-512 (tests/test_libm.py).

Numba lowers each math call to libm, never to a vector library here: the llvmlite it ships is not linked
with SVML (`numba -s`: "llvmlite Using SVML Patched LLVM: False"). Imports nothing of signcast.
"""
import math

import numpy as np
from numba import njit


ARCCOS, SIN, COS, ARCTAN2, LOG1P, EXPM1, LOG2, EXP2, POWER = range(9)


@njit(cache=True)
def _evaluate(function, x, y, out):
    """out[i] = libm's `function` (one of the codes above) of x[i] (and y[i]); all (N,) float64."""
    for i in range(out.size):
        if function == ARCCOS:
            out[i] = math.acos(x[i])
        elif function == SIN:
            out[i] = math.sin(x[i])
        elif function == COS:
            out[i] = math.cos(x[i])
        elif function == ARCTAN2:
            out[i] = math.atan2(x[i], y[i])
        elif function == LOG1P:
            out[i] = math.log1p(x[i])
        elif function == EXPM1:
            out[i] = math.expm1(x[i])
        elif function == LOG2:
            out[i] = math.log2(x[i])
        elif function == EXP2:
            out[i] = np.exp2(x[i])
        else:
            out[i] = math.pow(x[i], y[i])


def _apply(function, *arguments):
    """`function` over the arguments broadcast together as float64 arrays; the result has their broadcast
    shape (a Python float for scalars)."""
    values = [np.asarray(a, dtype=np.float64) for a in arguments]
    if len(values) > 1 and any(v.shape != values[0].shape for v in values[1:]):
        values = np.broadcast_arrays(*values)
    out = np.empty(values[0].shape)
    x = values[0].ravel()
    _evaluate(function, x, values[1].ravel() if len(values) > 1 else x, out.ravel())
    return out if out.ndim else float(out)


def arccos(x):
    """arccos of x, radians in [0, pi]; x in [-1, 1] (NaN outside)."""
    return _apply(ARCCOS, x)


def sin(x):
    """sin of x (radians)."""
    return _apply(SIN, x)


def cos(x):
    """cos of x (radians)."""
    return _apply(COS, x)


def arctan2(y, x):
    """The angle of (x, y), radians in [-pi, pi]; y and x broadcast together."""
    return _apply(ARCTAN2, y, x)


def log1p(x):
    """log(1 + x)."""
    return _apply(LOG1P, x)


def expm1(x):
    """exp(x) - 1."""
    return _apply(EXPM1, x)


def log2(x):
    """Base-2 logarithm."""
    return _apply(LOG2, x)


def exp2(x):
    """2 ** x."""
    return _apply(EXP2, x)


def power(x, exponent):
    """x ** exponent; x and exponent broadcast together."""
    return _apply(POWER, x, exponent)

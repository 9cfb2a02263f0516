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


@njit(cache=True)
def _arccos(x, out):
    for i in range(x.size):
        out[i] = math.acos(x[i])


@njit(cache=True)
def _sin(x, out):
    for i in range(x.size):
        out[i] = math.sin(x[i])


@njit(cache=True)
def _log1p(x, out):
    for i in range(x.size):
        out[i] = math.log1p(x[i])


@njit(cache=True)
def _expm1(x, out):
    for i in range(x.size):
        out[i] = math.expm1(x[i])


@njit(cache=True)
def _log2(x, out):
    for i in range(x.size):
        out[i] = math.log2(x[i])


@njit(cache=True)
def _exp2(x, out):
    for i in range(x.size):
        out[i] = np.exp2(x[i])


@njit(cache=True)
def _cos(x, out):
    for i in range(x.size):
        out[i] = math.cos(x[i])


@njit(cache=True)
def _arctan2(y, x, out):
    for i in range(y.size):
        out[i] = math.atan2(y[i], x[i])


@njit(cache=True)
def _power(x, exponent, out):
    for i in range(x.size):
        out[i] = math.pow(x[i], exponent[i])


def _apply(loop, *arguments):
    """loop over the arguments broadcast together as contiguous float64 arrays; the result has their
    broadcast shape (a Python float for scalars)."""
    values = [np.asarray(a, dtype=np.float64) for a in arguments]
    if len(values) > 1 and any(v.shape != values[0].shape for v in values[1:]):
        values = np.broadcast_arrays(*values)
    out = np.empty(values[0].shape)
    if len(values) == 1:
        loop(values[0].ravel(), out.ravel())
    else:
        loop(values[0].ravel(), values[1].ravel(), out.ravel())
    return out if out.ndim else float(out)


def arccos(x):
    """arccos of x, radians in [0, pi]; x in [-1, 1] (NaN outside)."""
    return _apply(_arccos, x)


def sin(x):
    """sin of x (radians)."""
    return _apply(_sin, x)


def cos(x):
    """cos of x (radians)."""
    return _apply(_cos, x)


def arctan2(y, x):
    """The angle of (x, y), radians in [-pi, pi]; y and x broadcast together."""
    return _apply(_arctan2, y, x)


def log1p(x):
    """log(1 + x)."""
    return _apply(_log1p, x)


def expm1(x):
    """exp(x) - 1."""
    return _apply(_expm1, x)


def log2(x):
    """Base-2 logarithm."""
    return _apply(_log2, x)


def exp2(x):
    """2 ** x."""
    return _apply(_exp2, x)


def power(x, exponent):
    """x ** exponent; x and exponent broadcast together."""
    return _apply(_power, x, exponent)

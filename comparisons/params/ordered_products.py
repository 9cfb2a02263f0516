"""Matrix products with one rounding order on every CPU: each entry a chain of fused multiply-adds over k
in order from 0, what OpenBLAS's GEMM micro-kernels compute on CPUs with FMA (AVX2, AVX-512).

The DCT coders' products (comparisons/params/coding.py, fba_codec.py) and the hybrid coder's cosine synthesis
(model_coders.py) went through NumPy's matmul, i.e. OpenBLAS, whose kernel is chosen for the CPU: on one
without FMA (OpenBLAS's Nehalem and Sandybridge kernels) the FBA DCT stream of ASL HELLO at Q 1 came out
different, on AVX2 and AVX-512 machines the same. Here LLVM's fma intrinsic is exactly rounded wherever it
runs (an instruction, or the C library's fma where the CPU has none), so these products give the AVX2 and
AVX-512 machines' bits everywhere (tests/test_cpu_independence.py). Imports nothing of signcast.
"""
import numpy as np
from numba import njit, types
from numba.extending import intrinsic


@intrinsic
def fused_multiply_add(typingctx, a, b, c):
    """a * b + c with one rounding (float64)."""
    signature = types.float64(types.float64, types.float64, types.float64)

    def codegen(context, builder, sig, args):
        return builder.fma(*args)
    return signature, codegen


@njit(cache=True)
def _matmul(a, b, out):
    # k outside j: each entry is still its chain over k in order, and the inner loop runs along b's rows
    n = b.shape[1]
    row = np.empty(n)
    for i in range(a.shape[0]):
        row[:] = 0.0
        for k in range(a.shape[1]):
            factor = a[i, k]
            b_row = b[k]
            for j in range(n):
                row[j] = fused_multiply_add(factor, b_row[j], row[j])
        out[i] = row


def matmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a (M, K) @ b (K, N) -> (M, N) float64, each entry fma(a[i, K-1], b[K-1, j], ... fma(a[i, 0], b[0, j], 0))."""
    a = np.asarray(a, dtype=np.float64)
    b = np.ascontiguousarray(b, dtype=np.float64)
    if a.ndim != 2 or b.ndim != 2 or a.shape[1] != b.shape[0]:
        raise ValueError(f"matmul takes (M, K) and (K, N) arrays, got {a.shape} and {b.shape}")
    out = np.empty((a.shape[0], b.shape[1]))
    _matmul(a, b, out)
    return out

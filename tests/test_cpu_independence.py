"""The decoders' integers hold on another CPU: the conformance tests (tests/test_conformance.py, and the motion
lab's tests/test_lab_conformance.py) run again in a fresh interpreter with NumPy's SIMD dispatch held to its
baseline (no AVX2, no AVX-512: other code paths for its transcendental functions) and OpenBLAS's kernels for a CPU
without FMA (Nehalem). Integer decoding is exact by construction; the DCT decoders round an inverse DCT (a
product of a cosine matrix and the levels) to integers, which this checks too. Encoders may write other bytes
on another CPU (as real encoders do); they are tested by round trip and rate."""
import os
import platform
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
CONFORMANCE_TESTS = tuple(str(path.relative_to(ROOT))
                          for path in sorted((ROOT / "tests").glob("test_*conformance.py")))


def _dispatched_simd() -> list[str]:
    """NumPy's runtime-dispatched SIMD targets this CPU has (e.g. X86_V3, X86_V4, AVX512_ICL)."""
    from numpy._core import _multiarray_umath as umath
    return [name for name in umath.__cpu_dispatch__ if umath.__cpu_features__.get(name)]


@pytest.mark.skipif(platform.machine() not in ("x86_64", "AMD64"), reason="OpenBLAS's core types named here are x86's")
def test_conformance_holds_with_baseline_simd_and_blas_kernels_without_fma():
    env = dict(os.environ, OPENBLAS_CORETYPE="Nehalem", NPY_DISABLE_CPU_FEATURES=" ".join(_dispatched_simd()))
    run = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-n", "0",
                          *CONFORMANCE_TESTS],
                         cwd=ROOT, env=env, capture_output=True, text=True, timeout=900)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-2000:]
    assert " passed" in run.stdout.splitlines()[-1]


def test_the_alternative_is_another_code_path_here():
    """The check above means something only if the alternate settings change NumPy's or OpenBLAS's bits on
    this machine: OpenBLAS's Nehalem kernel has no FMA, so a 17-term dot product's rounding differs."""
    script = ("import numpy as np; r = np.random.default_rng(0); a, b = r.normal(size=(64, 17)), r.normal(size=(17, 1)); "
              "print((a @ b).tobytes().hex())")
    runs = [subprocess.run([sys.executable, "-c", script], env=dict(os.environ, **extra), capture_output=True,
                           text=True, timeout=120).stdout for extra in ({}, {"OPENBLAS_CORETYPE": "Nehalem"})]
    if runs[0] == runs[1]:
        pytest.skip("this CPU's OpenBLAS kernel rounds as the Nehalem one does (no FMA here)")
    assert np.frombuffer(bytes.fromhex(runs[0].strip())).shape == (64,)

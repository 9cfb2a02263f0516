"""Backends the kernel tests compare with the NumPy oracle: Warp (CPU here) and OpenCL when a device compiles."""
import pytest

from kernels import backends

OPENCL = pytest.param("opencl", marks=pytest.mark.skipif(
    not backends.opencl_available(),
    reason="no OpenCL device can build kernels (install Debian's pocl-opencl-icd; pyopencl's bundled PoCL "
           "uses LLVM 14, which cannot target some newer CPUs)"))
ACCELERATED = ["warp", OPENCL]

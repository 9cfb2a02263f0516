"""Backend choice for every kernel: Warp (CUDA when present, else CPU), OpenCL, or the NumPy oracle.

The device is chosen once per process: `warp_device()` and `opencl_queue()` are cached. Warp is
imported lazily and kept quiet (no banner on stdout). For OpenCL, a GPU is preferred; otherwise the
first CPU device whose compiler actually builds a program is used (the PoCL bundled in the pyopencl
wheel uses LLVM 14, which cannot target some newer CPUs; Debian's pocl-opencl-icd can).

`describe(backend)` says where a backend choice runs (and fails in one line if it cannot), so that
a command can tell the user what "auto" chose; library code itself never prints.
"""
from __future__ import annotations

import contextlib
import functools
import os
import sys
import types

import numpy as np

from kernels.errors import KernelError

BACKENDS = ("warp", "opencl", "numpy")
CHOICES = BACKENDS + ("auto",)


def resolve(backend: str) -> str:
    """'auto' -> 'warp' (Warp picks CUDA when a GPU exists, else its CPU device); others are checked."""
    if backend == "auto":
        return "warp"
    if backend not in BACKENDS:
        raise KernelError(f"unknown backend {backend!r}: choose one of {', '.join(CHOICES)}")
    return backend


def describe(backend: str) -> str:
    """Where `backend` runs here: 'warp (cpu)', 'warp (cuda:0)', 'opencl (DEVICE NAME)' or 'numpy'.

    Starts the backend (once per process), so a backend that cannot run here raises its one-line
    KernelError now rather than at the first kernel call.
    """
    chosen = resolve(backend)
    if chosen == "warp":
        return f"warp ({warp_device()})"
    if chosen == "opencl":
        context, _ = opencl_queue()
        return f"opencl ({context.devices[0].name.strip()})"
    return chosen


@contextlib.contextmanager
def _silenced_native_output():
    """Send file descriptors 1 and 2 to /dev/null for the duration (C-level prints included)."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(1), os.dup(2)]
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        os.dup2(devnull, 2)
        yield
    finally:
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for fd in (*saved, devnull):
            os.close(fd)


@functools.cache
def warp():
    """The warp module, initialised quietly."""
    try:
        import warp as wp
    except ImportError as error:  # pragma: no cover - warp-lang is a dependency
        raise KernelError(f"backend 'warp' needs warp-lang: {error}") from None
    wp.config.quiet = True
    wp.config.verbose = False
    if hasattr(wp, "LOG_WARNING"):
        wp.config.log_level = wp.LOG_WARNING
    with _silenced_native_output():  # the native library prints a CUDA-driver notice on machines without a GPU
        wp.init()
    return wp


@functools.cache
def warp_device() -> str:
    """'cuda:0' when Warp sees a CUDA device, else 'cpu'."""
    wp = warp()
    return "cuda:0" if wp.is_cuda_available() else "cpu"


_PROBE_SOURCE = "__kernel void probe(__global long *a) { atom_min(a, (long)get_global_id(0)); }"


@functools.cache
def opencl_queue():
    """One (context, queue) for the process: a GPU if present, else the first CPU device that compiles."""
    try:
        import pyopencl as cl
    except ImportError as error:  # pragma: no cover - pyopencl is a dependency
        raise KernelError(f"backend 'opencl' needs pyopencl: {error}") from None
    os.environ.setdefault("PYOPENCL_COMPILER_OUTPUT", "0")
    try:
        platforms = cl.get_platforms()
    except cl.Error as error:
        raise KernelError(f"backend 'opencl': no OpenCL platform ({error})") from None
    devices = [d for p in platforms for d in p.get_devices()]
    devices.sort(key=lambda d: 0 if d.type & cl.device_type.GPU else 1)
    failures = []
    for device in devices:
        context = cl.Context([device])
        try:
            cl.Program(context, _PROBE_SOURCE).build()
        except cl.Error as error:
            failures.append(f"{device.name}: {_build_failure(str(error))}")
            continue
        return context, cl.CommandQueue(context)
    detail = "; ".join(failures) or "no devices"
    raise KernelError(f"backend 'opencl': no OpenCL device can build kernels ({detail}); the PoCL of the "
                      "pocl-binary-distribution wheel rejects some newer CPUs ('unknown target CPU'): "
                      "on Debian/Ubuntu install pocl-opencl-icd") from None


def _build_failure(message: str) -> str:
    """The telling line of an OpenCL build error (the compiler's complaint, not pyopencl's framing), shortened."""
    lines = [line.strip() for line in message.splitlines() if line.strip()]
    telling = [line for line in lines if not line.startswith(("clBuildProgram failed", "Build on", "(options"))]
    return (telling or lines or ["build failed"])[0][:100]


def opencl_available() -> bool:
    try:
        opencl_queue()
    except KernelError:
        return False
    return True


@functools.cache
def opencl_kernels(source: str) -> types.SimpleNamespace:
    """Build (once) an OpenCL program for the chosen device; its kernels by name (`kernels.raster`)."""
    import pyopencl as cl
    context, _ = opencl_queue()
    program = cl.Program(context, source).build(options=["-cl-std=CL1.2"])
    return types.SimpleNamespace(**{kernel.function_name: kernel for kernel in program.all_kernels()})


def opencl_defines(constants: dict) -> str:
    """`#define NAME value` lines that hand Python constants to an OpenCL program, so each is written once.

    Integers become 64-bit literals (`256L`), floating-point values float literals that round to the
    same float32 (`32768.0f`).
    """
    lines = []
    for name, value in constants.items():
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
            raise KernelError(f"OpenCL constant {name}: expected a number, got {value!r}")
        literal = f"{int(value)}L" if isinstance(value, (int, np.integer)) else f"{float(np.float32(value))!r}f"
        lines.append(f"#define {name} {literal}")
    return "\n".join(lines) + "\n"

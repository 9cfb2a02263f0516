"""The one error type for expected failures (bad input, missing data); the CLI prints it as one line.

It is defined in kernels.errors, the bottom layer, so that kernel errors (KernelError) are
SigncastErrors too; `from media.errors import SigncastError` is the usual way to reach it.
"""
from kernels.errors import SigncastError

__all__ = ["SigncastError"]

"""Errors raised by the kernels for bad arguments (kernels import nothing of signcast's)."""


class KernelError(ValueError):
    """Bad kernel input: wrong shape or dtype, unknown backend, backend unavailable."""

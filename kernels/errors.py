"""The one error type for expected failures, and the kernels' narrower kind of it.

SigncastError lives here, in the bottom layer, so that the kernels (which import nothing of
signcast's outside kernels/) and everything above them raise the same type; media.errors
re-exports it and the command line catches it alone.
"""


class SigncastError(Exception):
    """An expected failure the user can fix: unknown sign, missing file, corrupt stream, bad parameter."""


class KernelError(SigncastError, ValueError):
    """Bad kernel input: wrong shape or dtype, unknown backend, backend unavailable."""

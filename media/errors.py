"""The one error type for expected failures (bad input, missing data); the CLI prints it as one line."""


class SigncastError(Exception):
    """An expected failure the user can fix: unknown sign, missing file, corrupt stream, bad parameter."""

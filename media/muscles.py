"""The default avatar's muscles (filled in by the kernels work: biceps and forearm on each arm)."""
from __future__ import annotations


def default_muscles(avatar) -> tuple:
    return ()

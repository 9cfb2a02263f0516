"""Wall-time bookkeeping for the stages of a run, kept as records so reports can show them."""
from __future__ import annotations

import time
from contextlib import contextmanager


class StageClock:
    """Times named stages; `records()` gives {kind: "stage", stage, wall_s} dicts in the order run."""

    def __init__(self) -> None:
        self._stages: list[tuple[str, float]] = []

    @contextmanager
    def stage(self, name: str):
        start = time.perf_counter()
        try:
            yield
        finally:
            self._stages.append((name, time.perf_counter() - start))

    def records(self) -> list[dict]:
        return [{"kind": "stage", "stage": name, "wall_s": round(seconds, 3)} for name, seconds in self._stages]

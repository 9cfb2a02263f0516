"""The vendored MediaPipe `.tflite` models, checked against their sha256 and run with ai-edge-litert.

`load(name)` returns one cached `Model` per file name (e.g. "pose_landmark_full"); `Model.run(image)`
takes one float32 image (H, W, 3) already scaled to the model's input range and returns the outputs
as float32 arrays with the batch axis removed, in the model's output order.
"""
from __future__ import annotations

import contextlib
import functools
import hashlib
import os
import sys
from pathlib import Path

import numpy as np

from media.errors import SigncastError

ASSETS = Path(__file__).resolve().parent.parent / "assets" / "mediapipe"
THREADS = max(1, min(2, os.cpu_count() or 1))


@functools.lru_cache(maxsize=None)
def _checksums() -> dict[str, str]:
    try:
        lines = (ASSETS / "models.sha256").read_text().splitlines()
    except OSError as error:
        raise SigncastError(f"landmark models missing: cannot read {ASSETS / 'models.sha256'} ({error.strerror})") from None
    return {name: digest for digest, name in (line.split() for line in lines if line.strip())}


class Model:
    """One TFLite model. input_size: (height, width) pixels of its one image input."""

    def __init__(self, name: str):
        from ai_edge_litert.interpreter import Interpreter  # heavy import, only when landmarks are needed

        path = ASSETS / f"{name}.tflite"
        expected = _checksums().get(path.name)
        try:
            data = path.read_bytes()
        except OSError as error:
            raise SigncastError(f"landmark model missing: cannot read {path} ({error.strerror})") from None
        if expected is None or hashlib.sha256(data).hexdigest() != expected:
            raise SigncastError(f"landmark model {path.name} does not match models.sha256: "
                                "re-run tools/extract_mediapipe_models.py")
        self.name = name
        with _quiet_native_stderr():
            self._interpreter = Interpreter(model_content=data, num_threads=THREADS)
            self._interpreter.allocate_tensors()
        detail = self._interpreter.get_input_details()[0]
        self._input = detail["index"]
        self.input_size = (int(detail["shape"][1]), int(detail["shape"][2]))
        self._outputs = [d["index"] for d in self._interpreter.get_output_details()]

    def run(self, image: np.ndarray) -> list[np.ndarray]:
        """Outputs for one image (H, W, 3) float32 of the model's input size."""
        self._interpreter.set_tensor(self._input, np.ascontiguousarray(image, dtype=np.float32)[None])
        self._interpreter.invoke()
        return [self._interpreter.get_tensor(index)[0].copy() for index in self._outputs]


@contextlib.contextmanager
def _quiet_native_stderr():
    """LiteRT's C++ side prints an INFO line per model ("Created TensorFlow Lite XNNPACK delegate") straight
    to file descriptor 2, past Python's sys.stderr; the user would see it between progress bars."""
    try:
        fd = sys.stderr.fileno()
    except (AttributeError, OSError, ValueError):   # stderr replaced (pytest capture, notebooks)
        fd = 2
    sys.stderr.flush()
    saved = os.dup(fd)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), fd)
        yield
    finally:
        os.dup2(saved, fd)
        os.close(saved)


@functools.lru_cache(maxsize=None)
def load(name: str) -> Model:
    """The cached model `name` (file media/assets/mediapipe/NAME.tflite)."""
    return Model(name)

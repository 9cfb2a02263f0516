"""Argument checks and a small cache of device buffers shared by the kernels.

Static inputs (mesh topology, part labels, skin weights) come back unchanged every frame, so their
costlier checks (index ranges, monotone row starts) run once per distinct array object and content
(`checked_once`), the way UploadCache uploads them once; per-frame inputs keep their checks.

Knowing that the content is unchanged costs a comparison with a snapshot every frame, unless the array
is immutable: `immutable` copies an array into memory backed by a Python `bytes` object, which NumPy
will not make writeable again, so the same object always holds the same content and a check or an
upload is reused on identity alone. The loaded avatar's arrays are made this way.
"""
from __future__ import annotations

import numpy as np

from kernels import backends
from kernels.errors import KernelError


def as_array(name: str, value, dtype, shape: tuple) -> np.ndarray:
    """C-contiguous array of `dtype`; `shape` uses None for free sizes. Raises KernelError if it does not fit."""
    if type(value) is np.ndarray and value.dtype == dtype and value.flags.c_contiguous:
        array = value                          # the common case, without a conversion call
    else:
        try:
            array = np.ascontiguousarray(value, dtype=dtype)
        except (TypeError, ValueError) as error:
            raise KernelError(f"{name}: cannot convert to {np.dtype(dtype).name} array ({error})") from None
    if array.ndim != len(shape) or any(s is not None and s != a for s, a in zip(shape, array.shape)):
        wanted = "(" + ", ".join("N" if s is None else str(s) for s in shape) + ")"
        raise KernelError(f"{name}: expected shape {wanted}, got {array.shape}")
    return array


def immutable(array) -> np.ndarray:
    """A read-only copy of `array` (same dtype and shape, C order) over a `bytes` buffer: its content
    can never change, so checks and uploads of it are reused without comparing it again."""
    array = np.asarray(array)
    return np.frombuffer(array.tobytes(order="C"), dtype=array.dtype).reshape(array.shape)


def is_immutable(array: np.ndarray) -> bool:
    """True if `array` and every array it views are read-only over a `bytes` buffer (see `immutable`)."""
    while isinstance(array, np.ndarray):
        if array.flags.writeable:
            return False
        array = array.base
    return isinstance(array, bytes)


def _unchanged(snapshot, array: np.ndarray) -> bool:
    """Whether `array` (the object a snapshot was taken of) still holds the snapshot's content;
    snapshot is None for an immutable array."""
    return snapshot is None or np.array_equal(snapshot, array)


def check_indices(name: str, indices: np.ndarray, upper: int) -> None:
    """Raises KernelError unless every entry of `indices` lies in [0, upper)."""
    if indices.size and (indices.min() < 0 or indices.max() >= upper):
        raise KernelError(f"{name}: indices must lie in [0, {upper}), got [{indices.min()}, {indices.max()}]")


class _Passed:
    """Inputs that passed a check: per key, the array objects and a host snapshot of their content."""

    def __init__(self, size: int = 32):
        self._size = size
        self._entries: dict[tuple, tuple] = {}

    def seen(self, key: tuple, arrays: tuple) -> bool:
        hit = self._entries.get(key)
        return (hit is not None and all(a is b for a, b in zip(hit[0], arrays))
                and all(_unchanged(copy, a) for copy, a in zip(hit[1], arrays)))

    def add(self, key: tuple, arrays: tuple) -> None:
        if key not in self._entries and len(self._entries) >= self._size:
            self._entries.pop(next(iter(self._entries)))
        self._entries[key] = (arrays, tuple(None if is_immutable(a) else a.copy() for a in arrays))


_PASSED = _Passed()


def checked_once(key: tuple, arrays: tuple, check) -> None:
    """Calls `check()` (which raises KernelError on bad input) unless the same array objects with the same
    content passed it under `key` before; `key` names the check and every bound it depends on."""
    if not _PASSED.seen(key, arrays):
        check()
        _PASSED.add(key, arrays)


def check_indices_once(name: str, indices: np.ndarray, upper: int) -> None:
    """check_indices for a static input: the range is checked once per array object and content."""
    checked_once(("indices", name, upper), (indices,), lambda: check_indices(name, indices, upper))


class UploadCache:
    """Device copies of inputs that rarely change (rest mesh, weights, triangles).

    An entry is reused only while the caller passes the same array object with the same content
    (a comparison against a host snapshot, much cheaper than an upload to a GPU; none for an
    immutable array, see `immutable`). With
    `snapshot=False` the upload must alias the caller's memory (a Warp-CPU array made with copy=False):
    content changes then show through by themselves, and an entry is reused for the same array object
    without a comparison (the entry keeps the object, hence its memory, alive).
    """

    def __init__(self, upload, size: int = 16, *, snapshot: bool = True):
        self._upload = upload
        self._size = size
        self._snapshot = snapshot
        self._entries: dict[tuple, tuple] = {}

    def get(self, key: str, array: np.ndarray):
        slot = (key, id(array), array.shape, array.dtype.str)
        hit = self._entries.get(slot)
        if hit is not None and hit[0] is array and _unchanged(hit[1], array):
            return hit[2]
        device_array = self._upload(array)
        if len(self._entries) >= self._size:
            self._entries.pop(next(iter(self._entries)))
        snapshot = array.copy() if self._snapshot and not is_immutable(array) else None
        self._entries[slot] = (array, snapshot, device_array)
        return device_array


class OpenCLBuffers:
    """Read-write OpenCL device buffers kept by name; a buffer is reallocated only when its size changes."""

    def __init__(self) -> None:
        self._buffers: dict[str, tuple[object, int]] = {}

    def get(self, name: str, nbytes: int):
        """The buffer called `name`, of `nbytes` bytes, on the process's OpenCL context."""
        import pyopencl as cl
        context, _ = backends.opencl_queue()
        if self._buffers.get(name, (None, -1))[1] != nbytes:
            self._buffers[name] = (cl.Buffer(context, cl.mem_flags.READ_WRITE, nbytes), nbytes)
        return self._buffers[name][0]

"""Shared fixtures: the kernels' backends (each skipped with the reason it cannot run here, and a
failure instead under CI), the avatar, a short real fingerspelling with its bone matrices and posed
skins, built once per session, and a check that a written plot is a real, non-blank PNG.

Under pytest-xdist each worker keeps its own Numba cache (NUMBA_CACHE_DIR, set below before Numba is
imported): Numba's cache index is not safe when two processes compile different signatures of one
function at the same moment (each picks data file 1, and the index of one may end up naming the
other's machine code). Warp (a build folder per process, renamed into its cache) and PyOpenCL (a
locked cache) are safe as they are."""
import os
import tempfile
from pathlib import Path

if os.environ.get("PYTEST_XDIST_WORKER") and not os.environ.get("NUMBA_CACHE_DIR"):
    os.environ["NUMBA_CACHE_DIR"] = str(Path(tempfile.gettempdir()) / f"signcast-numba-{os.getuid()}"
                                        / os.environ["PYTEST_XDIST_WORKER"])
    import sys
    if "numba" in sys.modules:                       # a plugin imported it first: read the variable again
        from numba.core import config as _numba_config
        _numba_config.reload_config()

import numpy as np
import pytest

from kernels import backends
from kernels.errors import KernelError

REQUIRED_IN_CI = ("warp", "opencl")     # kernel backends whose parity checks must run in CI, never skip there
_backend_problems: dict[str, str] = {}


def in_ci() -> bool:
    """True where the environment says CI (CI=true, as GitHub Actions, GitLab and .ci/run set it)."""
    return os.environ.get("CI", "").strip().lower() in ("true", "1", "yes")


def _skip_unless_available(request, backend: str) -> str:
    """The backend name, or a skip carrying the backend's own one-line reason (e.g. the PoCL advice).
    Under CI a required backend that cannot run fails the test instead: its parity checks must not
    vanish from CI unnoticed. Either way the reason rides on the report (to the summary, across xdist)."""
    try:
        backends.describe(backend)
    except KernelError as error:
        request.node.user_properties.append(("kernel_backend_missing", (backend, str(error))))
        if backend in REQUIRED_IN_CI and in_ci():
            pytest.fail(f"CI needs the {backend} kernel backend, which cannot run here: {error}", pytrace=False)
        pytest.skip(str(error))
    return backend


def pytest_xdist_auto_num_workers(config):
    """-n auto (pytest-xdist, a test extra; use it with --dist loadfile so that a file's module fixtures are built
    once): one worker per core, at most 4 (each worker loads the landmark models and compiles its own Numba
    functions; the test files are few and uneven, so more workers gain little)."""
    return max(1, min(4, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1))


def pytest_runtest_logreport(report):
    """Collect the backends that could not run (in the controller too, where xdist replays the reports)."""
    for name, value in report.user_properties:
        if name == "kernel_backend_missing":
            _backend_problems[value[0]] = value[1]


def pytest_terminal_summary(terminalreporter, exitstatus, config):
    """Name each kernel backend that could not run, so that a skip is seen (under CI it also failed)."""
    for backend, problem in sorted(_backend_problems.items()):
        verdict = "FAILED under CI" if backend in REQUIRED_IN_CI and in_ci() else "skipped"
        terminalreporter.write_line(f"kernel backend {backend} {verdict}: {problem}", yellow=True)


@pytest.fixture(params=["warp", "opencl"])
def accelerated_backend(request) -> str:
    """Each backend the NumPy oracle is checked against: Warp (CUDA if present, else CPU) and OpenCL."""
    return _skip_unless_available(request, request.param)


@pytest.fixture(params=["numpy", "warp", "opencl"])
def any_backend(request) -> str:
    """Every backend, the NumPy oracle included."""
    return _skip_unless_available(request, request.param)


@pytest.fixture(scope="session")
def avatar():
    """The vendored MakeHuman avatar."""
    from media.avatar import load_avatar
    return load_avatar()


@pytest.fixture(scope="session")
def fingerspelling_ab():
    """Real fingerspelling: ASL 'AB' at 25 fps (a Motion)."""
    from media.fingerspelling import fingerspell
    return fingerspell("ase", "AB", 25.0)


@pytest.fixture(scope="session")
def signing_matrices(avatar, fingerspelling_ab):
    """(3, B, 4, 4) float32 bone matrices of the first, middle and last frames of 'AB'."""
    from media.kinematics import bone_matrices
    frames = np.linspace(0, fingerspelling_ab.n_frames - 1, 3).astype(int)
    return bone_matrices(avatar.skeleton, fingerspelling_ab)[frames].astype(np.float32)


@pytest.fixture(scope="session")
def signing_poses(avatar, signing_matrices):
    """(3, V, 3) float32 skin of those frames, posed by the NumPy oracle, metres."""
    from kernels.skinning import skin
    return np.stack([skin(avatar.vertices, avatar.weights, matrices, backend="numpy") for matrices in signing_matrices])


def _shared_edge_pixels(triangle_id: np.ndarray) -> np.ndarray:
    """(H, W) bool: covered pixels with a covered 8-neighbour of another triangle (a shared edge runs there)."""
    height, width = triangle_id.shape
    padded = np.pad(triangle_id, 1, constant_values=-1)
    shared = np.zeros(triangle_id.shape, dtype=bool)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            neighbour = padded[1 + dy:1 + dy + height, 1 + dx:1 + dx + width]
            shared |= (neighbour >= 0) & (neighbour != triangle_id)
    return shared & (triangle_id >= 0)


@pytest.fixture(scope="session")
def shared_edge_pixels():
    """A function: (H, W) int32 triangle ids (-1 empty) -> (H, W) bool, True where a covered pixel touches
    another triangle's covered pixel, the only place where backends may pick a different triangle."""
    return _shared_edge_pixels


def _check_png(path, size: tuple[int, int] | tuple[tuple[int, int], tuple[int, int]], min_std: float = 5.0,
               min_ink: float = 0.01) -> np.ndarray:
    """Decode `path` as PNG and require a plot that is there: size (width, height) exact, or
    ((min_w, max_w), (min_h, max_h)) for a tight bounding box; grey levels with a standard deviation of at
    least `min_std`; at least `min_ink` of the pixels away from the background (the most common colour).
    Returns the (H, W, C) uint8 pixels."""
    from PIL import Image
    with Image.open(path) as image:
        assert image.format == "PNG", f"{path} is {image.format}, not PNG"
        pixels = np.asarray(image.convert("RGB"))
    height, width = pixels.shape[:2]
    if isinstance(size[0], tuple):
        (low_w, high_w), (low_h, high_h) = size
        assert low_w <= width <= high_w and low_h <= height <= high_h, f"{path}: {width}x{height}, expected {size}"
    else:
        assert (width, height) == tuple(size), f"{path}: {width}x{height}, expected {size[0]}x{size[1]}"
    assert pixels.std() >= min_std, f"{path} is blank (grey-level sd {pixels.std():.2f})"
    flat = pixels.reshape(-1, 3)
    colours, counts = np.unique(flat, axis=0, return_counts=True)
    background = colours[np.argmax(counts)]
    ink = np.mean(np.any(flat != background, axis=1))
    assert ink >= min_ink, f"{path}: only {ink:.2%} of the pixels differ from the background"
    return pixels


@pytest.fixture(scope="session")
def check_png():
    """A function: check_png(path, (width, height) or ((min_w, max_w), (min_h, max_h)), min_std=5, min_ink=0.01)
    asserts that path is a real PNG of that pixel size and not blank, and returns its (H, W, 3) pixels."""
    return _check_png

"""Shared fixtures: the kernels' backends (each skipped with the reason it cannot run here), the
avatar, and a short real fingerspelling with its bone matrices and posed skins, built once per session."""
import numpy as np
import pytest

from kernels import backends
from kernels.errors import KernelError


def _skip_unless_available(backend: str) -> str:
    """The backend name, or a skip carrying the backend's own one-line reason (e.g. the PoCL advice)."""
    try:
        backends.describe(backend)
    except KernelError as error:
        pytest.skip(str(error))
    return backend


@pytest.fixture(params=["warp", "opencl"])
def accelerated_backend(request) -> str:
    """Each backend the NumPy oracle is checked against: Warp (CUDA if present, else CPU) and OpenCL."""
    return _skip_unless_available(request.param)


@pytest.fixture(params=["numpy", "warp", "opencl"])
def any_backend(request) -> str:
    """Every backend, the NumPy oracle included."""
    return _skip_unless_available(request.param)


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

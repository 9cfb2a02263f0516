"""Skinning kernels: linear blend skinning (seamless SMS skin) and rigid segments (FBA-style body).

Entry points `skin` and `skin_rigid` take explicit arrays and a backend ("warp", "opencl",
"numpy", "auto"). Bone matrices map rest-pose world points to posed world points (metres), so
no inverse bind matrix is involved: v' = sum_b w_b M_b v.
"""

import types
from dataclasses import dataclass

import numpy as np

from kernels import backends
from kernels._arrays import (
    OpenCLBuffers,
    UploadCache,
    as_array,
    check_indices,
    check_indices_once,
    checked_once,
)
from kernels.errors import KernelError


@dataclass(frozen=True)
class SkinWeights:
    """Per-vertex bone weights in CSR form (SMS skinCoordIndex / skinCoordWeight).

    indptr: (V+1,) int32 row starts; bones: (nnz,) int32 bone indices; values: (nnz,) float32
    weights, each row summing to 1.
    """
    indptr: np.ndarray
    bones: np.ndarray
    values: np.ndarray

    @property
    def n_vertices(self) -> int:
        return len(self.indptr) - 1

    def dense(self, n_bones: int) -> np.ndarray:
        """(V, n_bones) float32 weight matrix."""
        matrix = np.zeros((self.n_vertices, n_bones), dtype=np.float32)
        rows = np.repeat(np.arange(self.n_vertices), np.diff(self.indptr))
        np.add.at(matrix, (rows, self.bones), self.values)
        return matrix

    def dominant_bone(self) -> np.ndarray:
        """(V,) int32: the bone with the largest weight on each vertex."""
        rows = np.repeat(np.arange(self.n_vertices), np.diff(self.indptr))
        order = np.lexsort((-self.values, rows))
        return self.bones[order[self.indptr[:-1]]].astype(np.int32)

    @classmethod
    def from_dense(cls, matrix: np.ndarray, threshold: float = 1e-6) -> "SkinWeights":
        """From a (V, B) matrix; entries <= threshold are dropped and rows renormalised."""
        matrix = np.where(matrix > threshold, matrix, 0.0)
        sums = matrix.sum(axis=1, keepdims=True)
        if np.any(sums <= 0):
            raise KernelError(f"{int(np.sum(sums <= 0))} vertices have no bone weight")
        matrix = matrix / sums
        rows, bones = np.nonzero(matrix)
        indptr = np.concatenate([[0], np.cumsum(np.bincount(rows, minlength=len(matrix)))]).astype(np.int32)
        return cls(indptr, bones.astype(np.int32), matrix[rows, bones].astype(np.float32))


def _checked(rest, bone_matrices) -> tuple[np.ndarray, np.ndarray]:
    rest = as_array("rest", rest, np.float32, (None, 3))
    bone_matrices = as_array("bone_matrices", bone_matrices, np.float32, (None, 4, 4))
    return rest, bone_matrices


def _checked_weights(weights, n_vertices: int, n_bones: int) -> SkinWeights:
    try:
        indptr, bones, values = weights.indptr, weights.bones, weights.values
    except AttributeError:
        raise KernelError("weights: expected CSR weights with indptr, bones and values") from None
    indptr = as_array("weights.indptr", indptr, np.int32, (n_vertices + 1,))
    bones = as_array("weights.bones", bones, np.int32, (None,))
    values = as_array("weights.values", values, np.float32, (len(bones),))


    def check():
        if indptr[0] != 0 or indptr[-1] != len(bones) or np.any(np.diff(indptr) < 0):
            raise KernelError("weights.indptr: must rise from 0 to the number of entries")
        check_indices("weights.bones", bones, n_bones)

    checked_once(("weights", n_vertices, n_bones), (indptr, bones), check)   # static: once per content
    return SkinWeights(indptr, bones, values)


def checked_inputs(rest, weights, bone_matrices) -> tuple[np.ndarray, SkinWeights, np.ndarray]:
    """skin's arguments checked (raises KernelError): rest (V, 3) float32, CSR weights, matrices (B, 4, 4) float32."""
    rest, bone_matrices = _checked(rest, bone_matrices)
    return rest, _checked_weights(weights, len(rest), len(bone_matrices)), bone_matrices


def skin(rest, weights, bone_matrices, *, backend: str = "auto") -> np.ndarray:
    """Linear blend skinning.

    rest: (V, 3) float32 rest-pose positions, metres.
    weights: SkinWeights (or anything with indptr, bones, values): CSR rows per vertex, each summing to 1.
    bone_matrices: (B, 4, 4) float32, rest-to-posed world transform of each bone.
    Returns (V, 3) float32 posed positions, metres.
    """
    rest, weights, bone_matrices = checked_inputs(rest, weights, bone_matrices)
    return _IMPLEMENTATIONS[backends.resolve(backend)].skin(rest, weights, bone_matrices)


def enqueue_opencl(rest, weights, bone_matrices, posed_buffer) -> None:
    """OpenCL skinning of `checked_inputs` into a device buffer of (V, 3) float32, enqueued on the process's
    queue without waiting (kernels/skinned_raster.py passes the rasterizer's position buffer)."""
    _IMPLEMENTATIONS["opencl"].enqueue(rest, weights, bone_matrices, posed_buffer)


def skin_rigid(rest, dominant_bone, bone_matrices, *, backend: str = "auto") -> np.ndarray:
    """Segmented body: every vertex follows one bone rigidly (seams open at the joints).

    rest: (V, 3) float32 metres; dominant_bone: (V,) int32 bone of each vertex;
    bone_matrices: (B, 4, 4) float32. Returns (V, 3) float32 posed positions.
    """
    rest, bone_matrices = _checked(rest, bone_matrices)
    dominant_bone = as_array("dominant_bone", dominant_bone, np.int32, (len(rest),))
    check_indices_once("dominant_bone", dominant_bone, len(bone_matrices))
    return _IMPLEMENTATIONS[backends.resolve(backend)].skin_rigid(rest, dominant_bone, bone_matrices)


def _weight_arguments(weights: SkinWeights) -> list[tuple[str, np.ndarray]]:
    """The CSR weights as the accelerated bodies upload them: (cache key, array) in kernel argument order."""
    return [("indptr", weights.indptr), ("bones", weights.bones), ("values", weights.values)]


# --- NumPy: the oracle ----------------------------------------------------------------------------

class _NumpySkinning:
    @staticmethod
    def skin(rest, weights, bone_matrices):
        rows = np.repeat(np.arange(len(rest)), np.diff(weights.indptr))
        matrices = bone_matrices.astype(np.float64)[weights.bones]                     # (nnz, 4, 4)
        points = rest.astype(np.float64)[rows]                                          # (nnz, 3)
        moved = np.einsum("nij,nj->ni", matrices[:, :3, :3], points) + matrices[:, :3, 3]
        weighted = moved * weights.values.astype(np.float64)[:, None]
        posed = np.zeros((len(rest), 3))
        np.add.at(posed, rows, weighted)
        return posed.astype(np.float32)

    @staticmethod
    def skin_rigid(rest, dominant_bone, bone_matrices):
        matrices = bone_matrices.astype(np.float64)[dominant_bone]
        posed = np.einsum("vij,vj->vi", matrices[:, :3, :3], rest.astype(np.float64)) + matrices[:, :3, 3]
        return posed.astype(np.float32)


# --- Warp (bodies in kernels/skinning_warp.py, imported on first use) ----------------------------

class _WarpSkinning:
    """Device buffers and recorded launches live as long as the process, one set per kernel, vertex count
    and bone count; the rest mesh and weights upload once (UploadCache), the bone matrices go into a kept
    buffer (on the CPU device through its NumPy view, made once), so a frame packs no kernel arguments
    again. Warp and its device are looked up once (cached in kernels.backends; the look-ups add up per frame)."""

    CPU_CHUNK = 256          # vertices per thread on the CPU device (kernels/skinning_warp.py says why)

    def __init__(self):
        self._uploads = None
        self._launches = {}

    def _launch(self, name, rest, arguments, bone_matrices):
        if self._uploads is None:
            wp, device = backends.warp(), backends.warp_device()
            self._wp, self._device = wp, device
            # CPU: the kernels read the caller's arrays in place (no copy, no comparison, see UploadCache)
            alias = {"copy": False} if device == "cpu" else {}
            self._uploads = UploadCache(lambda a: wp.array(a, device=device, **alias), snapshot=not alias)
            self._points = UploadCache(lambda a: wp.array(a, dtype=wp.vec3, device=device, **alias),
                                       snapshot=not alias)
        inputs = [self._points.get("rest", rest), *(self._uploads.get(key, a) for key, a in arguments)]
        slot = (name, len(rest), len(bone_matrices))
        job = self._launches.get(slot)
        if job is None:
            job = self._launches[slot] = self._job(name, inputs, len(rest), len(bone_matrices))
        for index, (new, old) in enumerate(zip(inputs, job.inputs)):
            if new is not old:               # the rest mesh or the weights changed: uploaded again
                job.command.set_param_at_index(index, new)
                job.inputs[index] = new
        if job.on_cpu:
            job.matrices_host[:] = bone_matrices
        else:
            job.matrices.assign(bone_matrices)
        job.command.launch()
        # CPU: a copy of the buffer's NumPy view (the next frame overwrites it); CUDA: .numpy() copies already
        return job.posed_host.copy() if job.on_cpu else job.posed.numpy()

    def _job(self, name, inputs, n, n_bones):
        """Output and matrix buffers and the recorded launch of kernel `name` for n vertices and n_bones."""
        from kernels import skinning_warp
        wp, device = self._wp, self._device
        on_cpu = device == "cpu"
        chunk = self.CPU_CHUNK if on_cpu else 1
        matrices = wp.empty(n_bones, dtype=wp.mat44, device=device)
        posed = wp.empty(n, dtype=wp.vec3, device=device)
        command = wp.launch(getattr(skinning_warp, name), dim=-(-n // chunk), device=device, record_cmd=True,
                            inputs=[*inputs, matrices, chunk, posed])
        job = types.SimpleNamespace(command=command, inputs=list(inputs), matrices=matrices, posed=posed, on_cpu=on_cpu)
        if on_cpu:
            job.matrices_host, job.posed_host = matrices.numpy(), posed.numpy()
        return job

    def skin(self, rest, weights, bone_matrices):
        return self._launch("linear_blend", rest, _weight_arguments(weights), bone_matrices)

    def skin_rigid(self, rest, dominant_bone, bone_matrices):
        return self._launch("rigid", rest, [("dominant", dominant_bone)], bone_matrices)


# --- OpenCL ---------------------------------------------------------------------------------------

_OPENCL_SOURCE = r"""
#pragma OPENCL FP_CONTRACT OFF
float3 transform_point(__global const float *m, float3 p) {
    return (float3)(m[0] * p.x + m[1] * p.y + m[2] * p.z + m[3],
                    m[4] * p.x + m[5] * p.y + m[6] * p.z + m[7],
                    m[8] * p.x + m[9] * p.y + m[10] * p.z + m[11]);
}

__kernel void linear_blend(__global const float *rest, __global const int *indptr,
                           __global const int *bones, __global const float *values,
                           __global const float *matrices, __global float *posed) {
    int v = get_global_id(0);
    float3 p = vload3(v, rest);
    float3 total = (float3)(0.0f);
    for (int k = indptr[v]; k < indptr[v + 1]; ++k)
        total += values[k] * transform_point(matrices + 16 * bones[k], p);
    vstore3(total, v, posed);
}

__kernel void rigid(__global const float *rest, __global const int *dominant_bone,
                    __global const float *matrices, __global float *posed) {
    int v = get_global_id(0);
    vstore3(transform_point(matrices + 16 * dominant_bone[v], vload3(v, rest)), v, posed);
}
"""


class _OpenCLSkinning:
    """Read-only inputs upload once; the bone matrices and the output reuse one buffer each."""

    def __init__(self):
        self._uploads = None
        self._buffer = OpenCLBuffers().get

    def enqueue(self, rest, weights, bone_matrices, posed_buffer) -> None:
        """Enqueue linear blend skinning of checked inputs into a device buffer of (V, 3) float32 (no wait):
        kernels/skinned_raster.py hands it the rasterizer's position buffer."""
        self._enqueue(backends.opencl_kernels(_OPENCL_SOURCE).linear_blend, rest, _weight_arguments(weights),
                      bone_matrices, posed_buffer)

    def _enqueue(self, kernel, rest, arguments, bone_matrices, posed_buffer) -> None:
        import pyopencl as cl
        context, queue = backends.opencl_queue()
        if self._uploads is None:
            flags = cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR
            self._uploads = UploadCache(lambda a: cl.Buffer(context, flags, hostbuf=a))
        matrices = self._buffer("matrices", bone_matrices.nbytes)
        cl.enqueue_copy(queue, matrices, bone_matrices, is_blocking=False)
        inputs = [self._uploads.get("rest", rest), *(self._uploads.get(name, a) for name, a in arguments)]
        kernel(queue, (len(rest),), None, *inputs, matrices, posed_buffer)

    def _run(self, kernel, rest, arguments, bone_matrices):
        import pyopencl as cl
        _, queue = backends.opencl_queue()
        posed = np.empty((len(rest), 3), dtype=np.float32)
        posed_d = self._buffer("posed", posed.nbytes)
        self._enqueue(kernel, rest, arguments, bone_matrices, posed_d)
        cl.enqueue_copy(queue, posed, posed_d, is_blocking=True)
        return posed

    def skin(self, rest, weights, bone_matrices):
        return self._run(backends.opencl_kernels(_OPENCL_SOURCE).linear_blend, rest, _weight_arguments(weights),
                         bone_matrices)

    def skin_rigid(self, rest, dominant_bone, bone_matrices):
        return self._run(backends.opencl_kernels(_OPENCL_SOURCE).rigid, rest, [("dominant", dominant_bone)],
                         bone_matrices)


_IMPLEMENTATIONS = {"numpy": _NumpySkinning(), "warp": _WarpSkinning(), "opencl": _OpenCLSkinning()}

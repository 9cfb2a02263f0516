"""Muscle deformation (seed 000 §3.2.3): NURBS curves that displace the skin inside a tube (eq. 3.6).

A muscle is a NURBS curve C(u) = sum N_i(u) w_i P_i / sum N_i(u) w_i of degree p <= 3 with a tube
radius r and a falloff code. At bind time each vertex v gets its closest curve parameter u_v and
its affectedness mu(v) = f((r - d(v, C(u_v))) / r) (0 outside the tube). When the control points or
their weights change to P'_i, w'_i, the vertex moves by mu(v) (C'(u_v) - C(u_v)) (eq. 3.2); the
displacements of several muscles add up (superposition, §3.1).

The B-spline basis values N_i(u_v) depend only on the knots and u_v, so `bind` stores them (the
p+1 non-zero values and the first control point index); `displace` then needs only the rest and
current control points with their weights. Changing the knots means binding again.
"""
from typing import NamedTuple

import numpy as np

from kernels import backends
from kernels._arrays import UploadCache, as_array
from kernels.errors import KernelError

MAX_DEGREE = 3
BASIS_SIZE = MAX_DEGREE + 1            # basis values stored per bound vertex (zero-padded past degree + 1)
FALLOFF_CODES = (-1, 0, 1, 2, 3, 4)


def falloff(code: int, x: np.ndarray) -> np.ndarray:
    """The fall-off functions of eq. 3.3/3.6 on x in [0, 1]: -1 x^3, 0 x^2, 1 x, 2 sin(pi x / 2), 3 sqrt, 4 cbrt."""
    x = np.clip(np.asarray(x, dtype=np.float64), 0.0, 1.0)
    functions = {-1: lambda t: t ** 3, 0: lambda t: t ** 2, 1: lambda t: t, 2: lambda t: np.sin(np.pi * t / 2),
                 3: np.sqrt, 4: np.cbrt}
    if code not in functions:
        raise KernelError(f"unknown falloff code {code}: choose one of {FALLOFF_CODES}")
    return functions[code](x)


def _check_curve(control_points, knots, degree):
    control_points = as_array("control_points", control_points, np.float64, (None, 4))
    knots = as_array("knots", knots, np.float64, (len(control_points) + degree + 1,))
    if not 1 <= degree <= MAX_DEGREE:
        raise KernelError(f"NURBS degree must be 1..{MAX_DEGREE}, got {degree}")
    if len(control_points) <= degree:
        raise KernelError(f"a degree-{degree} NURBS needs more than {degree} control points")
    if np.any(np.diff(knots) < 0) or knots[degree] >= knots[len(control_points)]:
        raise KernelError("knots must not decrease and must span a non-empty parameter range")
    if np.any(control_points[:, 3] <= 0):
        raise KernelError("NURBS weights must be positive")
    return control_points, knots


def basis(knots: np.ndarray, degree: int, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """B-spline basis at parameters u (N,): first control index (N,) int32 and the degree+1
    non-zero values (N, degree+1) (Cox-de Boor, The NURBS Book A2.2)."""
    knots = np.asarray(knots, dtype=np.float64)
    u = np.asarray(u, dtype=np.float64)
    n_control = len(knots) - degree - 1
    u = np.clip(u, knots[degree], knots[n_control])
    span = np.searchsorted(knots, u, side="right") - 1
    span = np.clip(span, degree, n_control - 1)
    values = np.zeros((len(u), degree + 1))
    values[:, 0] = 1.0
    left = np.zeros((len(u), degree + 1))
    right = np.zeros((len(u), degree + 1))
    for j in range(1, degree + 1):
        left[:, j] = u - knots[span + 1 - j]
        right[:, j] = knots[span + j] - u
        saved = np.zeros(len(u))
        for r in range(j):
            denominator = right[:, r + 1] + left[:, j - r]
            temp = np.divide(values[:, r], denominator, out=np.zeros(len(u)), where=denominator != 0)
            values[:, r] = saved + right[:, r + 1] * temp
            saved = left[:, j - r] * temp
        values[:, j] = saved
    return (span - degree).astype(np.int32), values


def evaluate(control_points, knots, degree: int, u) -> np.ndarray:
    """Points C(u) (N, 3) of a NURBS curve. control_points: (K, 4) rows (x, y, z, w), metres."""
    control_points, knots = _check_curve(control_points, knots, degree)
    first, values = basis(knots, degree, np.atleast_1d(u))
    indices = first[:, None] + np.arange(degree + 1)
    homogeneous = control_points[indices]                              # (N, p+1, 4)
    weighted = values * homogeneous[..., 3]
    return np.einsum("nk,nkj->nj", weighted, homogeneous[..., :3]) / weighted.sum(axis=1, keepdims=True)


class MuscleBinding(NamedTuple):
    """One muscle's hold on the skin: vertices (N,) int32, u (N,) curve parameters, first_control (N,)
    int32, basis (N, degree+1) float64, weight (N,) float64 affectedness mu(v) in (0, 1]."""
    vertices: np.ndarray
    u: np.ndarray
    first_control: np.ndarray
    basis: np.ndarray
    weight: np.ndarray


def bind(rest, control_points, knots, degree: int, radius: float, falloff_code: int = 1,
         samples: int = 512) -> MuscleBinding:
    """Find the skin vertices inside a muscle's tube and their closest curve points (eq. 3.6).

    rest: (V, 3) bind-pose positions, metres; control_points (K, 4) (x, y, z, w) in the same pose;
    radius: tube radius, metres. The closest point is searched on `samples` points of the curve,
    then refined by golden-section search on the neighbouring interval.
    """
    rest = as_array("rest", rest, np.float64, (None, 3))
    control_points, knots = _check_curve(control_points, knots, degree)
    if not radius > 0:
        raise KernelError(f"muscle radius must be positive, got {radius}")
    falloff(falloff_code, 0.0)
    lo, hi = knots[degree], knots[len(control_points)]
    grid = np.linspace(lo, hi, samples)
    curve = evaluate(control_points, knots, degree, grid)
    spacing = np.max(np.linalg.norm(np.diff(curve, axis=0), axis=1))
    reach = radius + spacing
    near_box = np.all((rest >= curve.min(axis=0) - reach) & (rest <= curve.max(axis=0) + reach), axis=1)
    candidates = np.flatnonzero(near_box)
    nearest = np.empty(len(candidates), dtype=np.int64)
    for start in range(0, len(candidates), 1024):  # blocks keep the distance matrix small
        block = rest[candidates[start:start + 1024]]
        squared = ((block[:, None, :] - curve[None, :, :]) ** 2).sum(axis=2)
        nearest[start:start + 1024] = np.argmin(squared, axis=1)
    step = grid[1] - grid[0]
    a = np.maximum(grid[nearest] - step, lo)
    b = np.minimum(grid[nearest] + step, hi)
    points = rest[candidates]
    golden = (np.sqrt(5) - 1) / 2
    for _ in range(30):
        c, d = b - golden * (b - a), a + golden * (b - a)
        fc = np.linalg.norm(evaluate(control_points, knots, degree, c) - points, axis=1)
        fd = np.linalg.norm(evaluate(control_points, knots, degree, d) - points, axis=1)
        closer_c = fc < fd
        b = np.where(closer_c, d, b)
        a = np.where(closer_c, a, c)
    u = (a + b) / 2
    delta = np.linalg.norm(evaluate(control_points, knots, degree, u) - points, axis=1)
    inside = delta <= radius
    weight = falloff(falloff_code, (radius - delta[inside]) / radius)
    keep = weight > 0
    vertices, u = candidates[inside][keep].astype(np.int32), u[inside][keep]
    first, values = basis(knots, degree, u)
    return MuscleBinding(vertices, u, first, values, weight[keep])


class MuscleInfluence(NamedTuple):
    """All muscles' bindings as CSR rows per skin vertex (the kernels' input).

    indptr: (V+1,) int32; first_control: (nnz,) int32 index into the stacked control points of all
    muscles; basis: (nnz, BASIS_SIZE) float32 (zero-padded past degree+1); weight: (nnz,) float32 mu(v).
    """
    indptr: np.ndarray
    first_control: np.ndarray
    basis: np.ndarray
    weight: np.ndarray


def combine(bindings: list[MuscleBinding], control_counts: list[int], n_vertices: int) -> MuscleInfluence:
    """Stack several muscles' bindings (their control points stacked in the same order) per vertex."""
    if len(bindings) != len(control_counts):
        raise KernelError("one control-point count per binding is needed")
    offsets = np.concatenate([[0], np.cumsum(control_counts)[:-1]]).astype(np.int32)
    vertices = np.concatenate([b.vertices for b in bindings] or [np.zeros(0, np.int32)])
    first = np.concatenate([b.first_control + o for b, o in zip(bindings, offsets)] or [np.zeros(0, np.int32)])
    padded = [np.pad(b.basis, ((0, 0), (0, BASIS_SIZE - b.basis.shape[1]))) for b in bindings]
    values = np.concatenate(padded or [np.zeros((0, BASIS_SIZE))])
    weight = np.concatenate([b.weight for b in bindings] or [np.zeros(0)])
    if len(vertices) and (vertices.min() < 0 or vertices.max() >= n_vertices):
        raise KernelError("binding vertices outside the mesh")
    order = np.argsort(vertices, kind="stable")
    indptr = np.concatenate([[0], np.cumsum(np.bincount(vertices, minlength=n_vertices))]).astype(np.int32)
    return MuscleInfluence(indptr, first[order].astype(np.int32), values[order].astype(np.float32),
                           weight[order].astype(np.float32))


def displace(positions, influence: MuscleInfluence, control_rest, control_posed, *, backend: str = "auto") -> np.ndarray:
    """Move the skin by the muscles (eq. 3.2 with eq. 3.6 weights, superposed).

    positions: (V, 3) float32 metres, the pose the muscles were bound in; influence: MuscleInfluence;
    control_rest, control_posed: (C, 4) float32 stacked control points (x, y, z, w) of all muscles
    at bind time and now. Returns (V, 3) float32 positions + sum mu(v) (C'(u_v) - C(u_v)).
    """
    positions = as_array("positions", positions, np.float32, (None, 3))
    control_rest = as_array("control_rest", control_rest, np.float32, (None, 4))
    control_posed = as_array("control_posed", control_posed, np.float32, (len(control_rest), 4))
    indptr = as_array("influence.indptr", influence.indptr, np.int32, (len(positions) + 1,))
    nnz = int(indptr[-1])
    first = as_array("influence.first_control", influence.first_control, np.int32, (nnz,))
    values = as_array("influence.basis", influence.basis, np.float32, (nnz, BASIS_SIZE))
    weight = as_array("influence.weight", influence.weight, np.float32, (nnz,))
    if nnz and (first.min() < 0 or first.max() >= len(control_rest)):
        raise KernelError("influence.first_control outside the control points")
    if np.any(control_posed[:, 3] <= 0) or np.any(control_rest[:, 3] <= 0):
        raise KernelError("NURBS weights must be positive")
    # padding so that first + BASIS_SIZE - 1 stays inside for every degree (padded basis values are zero)
    pad = np.tile(np.array([[0, 0, 0, 1]], np.float32), (BASIS_SIZE - 1, 1))
    rest_padded = np.concatenate([control_rest, pad])
    posed_padded = np.concatenate([control_posed, pad])
    influence = MuscleInfluence(indptr, first, values, weight)
    return _IMPLEMENTATIONS[backends.resolve(backend)].displace(positions, influence, rest_padded, posed_padded)


# --- NumPy: the oracle ----------------------------------------------------------------------------

class _NumpyMuscles:
    @staticmethod
    def displace(positions, influence, control_rest, control_posed):
        rows = np.repeat(np.arange(len(positions)), np.diff(influence.indptr))
        indices = influence.first_control[:, None] + np.arange(BASIS_SIZE)
        values = influence.basis.astype(np.float64)

        def curve_points(control):
            homogeneous = control.astype(np.float64)[indices]          # (nnz, 4, 4)
            weighted = values * homogeneous[..., 3]
            return np.einsum("nk,nkj->nj", weighted, homogeneous[..., :3]) / weighted.sum(axis=1, keepdims=True)

        moved = (curve_points(control_posed) - curve_points(control_rest)) * influence.weight[:, None]
        displaced = positions.astype(np.float64)
        np.add.at(displaced, rows, moved)
        return displaced.astype(np.float32)


# --- Warp (bodies in kernels/muscles_warp.py, imported on first use) -----------------------------

class _WarpMuscles:
    """The influence rows upload once; positions and control points upload per call."""

    def __init__(self):
        self._uploads = None

    def displace(self, positions, influence, control_rest, control_posed):
        from kernels import muscles_warp
        wp, device = backends.warp(), backends.warp_device()
        if self._uploads is None:
            self._uploads = UploadCache(lambda a: wp.array(a, device=device))
            self._basis = UploadCache(lambda a: wp.array(a, dtype=muscles_warp.basis_values, device=device))
        displaced = wp.empty(len(positions), dtype=wp.vec3, device=device)
        wp.launch(muscles_warp.displace, dim=len(positions), device=device,
                  inputs=[wp.array(positions, dtype=wp.vec3, device=device), self._uploads.get("indptr", influence.indptr),
                          self._uploads.get("first", influence.first_control), self._basis.get("basis", influence.basis),
                          self._uploads.get("weight", influence.weight), wp.array(control_rest, dtype=wp.vec4, device=device),
                          wp.array(control_posed, dtype=wp.vec4, device=device), displaced])
        return displaced.numpy().copy()


# --- OpenCL ---------------------------------------------------------------------------------------

_OPENCL_SOURCE = backends.opencl_defines({"BASIS_SIZE": BASIS_SIZE}) + r"""
#pragma OPENCL FP_CONTRACT OFF
float3 curve_point(__global const float4 *control, int first, __global const float *b) {
    float3 numerator = (float3)(0.0f);
    float denominator = 0.0f;
    for (int i = 0; i < BASIS_SIZE; ++i) {
        float4 c = control[first + i];
        float nw = b[i] * c.w;
        numerator += nw * c.xyz;
        denominator += nw;
    }
    return numerator / denominator;
}

__kernel void displace(__global const float *positions, __global const int *indptr,
                       __global const int *first_control, __global const float *basis,
                       __global const float *weight, __global const float4 *control_rest,
                       __global const float4 *control_posed, __global float *displaced) {
    int v = get_global_id(0);
    float3 total = (float3)(0.0f);
    for (int k = indptr[v]; k < indptr[v + 1]; ++k) {
        __global const float *b = basis + BASIS_SIZE * k;
        total += weight[k] * (curve_point(control_posed, first_control[k], b)
                              - curve_point(control_rest, first_control[k], b));
    }
    vstore3(vload3(v, positions) + total, v, displaced);
}
"""


class _OpenCLMuscles:
    """The influence rows upload once; positions and control points upload per call."""

    def __init__(self):
        self._uploads = None

    def displace(self, positions, influence, control_rest, control_posed):
        import pyopencl as cl
        context, queue = backends.opencl_queue()
        flags = cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR
        if self._uploads is None:
            self._uploads = UploadCache(lambda a: cl.Buffer(context, flags, hostbuf=a))
        displaced = np.empty_like(positions)
        displaced_d = cl.Buffer(context, cl.mem_flags.WRITE_ONLY, displaced.nbytes)
        backends.opencl_kernels(_OPENCL_SOURCE).displace(
            queue, (len(positions),), None, cl.Buffer(context, flags, hostbuf=positions),
            self._uploads.get("indptr", influence.indptr), self._uploads.get("first", influence.first_control),
            self._uploads.get("basis", influence.basis), self._uploads.get("weight", influence.weight),
            cl.Buffer(context, flags, hostbuf=control_rest), cl.Buffer(context, flags, hostbuf=control_posed), displaced_d)
        cl.enqueue_copy(queue, displaced, displaced_d, is_blocking=True)
        return displaced


_IMPLEMENTATIONS = {"numpy": _NumpyMuscles(), "warp": _WarpMuscles(), "opencl": _OpenCLMuscles()}

"""Warp bodies of kernels/skinning.py: each thread poses a run of `chunk` vertices.

Warp-CPU runs the threads of a launch one after another, so one thread per vertex would pay the
per-thread cost (argument copy, call) 13,524 times for a few multiply-adds each; the host layer
passes runs of 256 vertices on the CPU device and chunk = 1 on CUDA (chosen here, as in
kernels/raster_warp.py).

Imported by the host layer in kernels/skinning.py on first use, so that `import kernels` does not
start Warp; Warp is initialised quietly through kernels.backends.warp().
"""
import warp as wp

from kernels import backends

backends.warp()   # initialise Warp quietly (no banner on stdout) before building kernels


@wp.kernel
def linear_blend(rest: wp.array(dtype=wp.vec3), indptr: wp.array(dtype=wp.int32), bones: wp.array(dtype=wp.int32),
                 values: wp.array(dtype=wp.float32), matrices: wp.array(dtype=wp.mat44), chunk: wp.int32,
                 posed: wp.array(dtype=wp.vec3)):
    """posed[v] = sum over the CSR row of v of values[k] * matrices[bones[k]] . rest[v], for the vertices
    v in [tid * chunk, (tid + 1) * chunk)."""
    first = wp.tid() * chunk
    for v in range(first, wp.min(first + chunk, rest.shape[0])):
        p = rest[v]
        total = wp.vec3(0.0, 0.0, 0.0)
        k = indptr[v]
        end = indptr[v + 1]
        while k < end:           # not range(): its step may be negative, and the test for that costs (17%)
            total += values[k] * wp.transform_point(matrices[bones[k]], p)
            k += 1
        posed[v] = total


@wp.kernel
def rigid(rest: wp.array(dtype=wp.vec3), dominant_bone: wp.array(dtype=wp.int32), matrices: wp.array(dtype=wp.mat44),
          chunk: wp.int32, posed: wp.array(dtype=wp.vec3)):
    """posed[v] = matrices[dominant_bone[v]] . rest[v], for v in [tid * chunk, (tid + 1) * chunk)."""
    first = wp.tid() * chunk
    for v in range(first, wp.min(first + chunk, rest.shape[0])):
        posed[v] = wp.transform_point(matrices[dominant_bone[v]], rest[v])

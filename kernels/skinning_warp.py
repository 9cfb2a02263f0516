"""Warp bodies of kernels/skinning.py, one thread per vertex (`v = wp.tid()`).

Imported by the host layer in kernels/skinning.py on first use, so that `import kernels` does not
start Warp; Warp is initialised quietly through kernels.backends.warp().
"""
import warp as wp

from kernels import backends

backends.warp()   # initialise Warp quietly (no banner on stdout) before building kernels


@wp.kernel
def linear_blend(rest: wp.array(dtype=wp.vec3), indptr: wp.array(dtype=wp.int32), bones: wp.array(dtype=wp.int32),
                 values: wp.array(dtype=wp.float32), matrices: wp.array(dtype=wp.mat44),
                 posed: wp.array(dtype=wp.vec3)):
    """posed[v] = sum over the CSR row of v of values[k] * matrices[bones[k]] . rest[v]."""
    v = wp.tid()
    p = rest[v]
    total = wp.vec3(0.0, 0.0, 0.0)
    for k in range(indptr[v], indptr[v + 1]):
        total += values[k] * wp.transform_point(matrices[bones[k]], p)
    posed[v] = total


@wp.kernel
def rigid(rest: wp.array(dtype=wp.vec3), dominant_bone: wp.array(dtype=wp.int32), matrices: wp.array(dtype=wp.mat44),
          posed: wp.array(dtype=wp.vec3)):
    """posed[v] = matrices[dominant_bone[v]] . rest[v]."""
    v = wp.tid()
    posed[v] = wp.transform_point(matrices[dominant_bone[v]], rest[v])

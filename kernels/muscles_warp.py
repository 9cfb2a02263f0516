"""Warp bodies of kernels/muscles.py, one thread per skin vertex (`v = wp.tid()`).

Imported by the host layer in kernels/muscles.py on first use, so that `import kernels` does not
start Warp; Warp is initialised quietly through kernels.backends.warp().
"""
import warp as wp

from kernels import backends
from kernels.muscles import BASIS_SIZE

backends.warp()   # initialise Warp quietly (no banner on stdout) before building kernels

BASIS = wp.constant(BASIS_SIZE)
basis_values = wp.types.vector(length=BASIS_SIZE, dtype=wp.float32)   # one bound vertex's basis row


@wp.func
def curve_point(control: wp.array(dtype=wp.vec4), first: wp.int32, b: basis_values):
    """C(u) = sum_i N_i w_i P_i / sum_i N_i w_i over the BASIS_SIZE control points from `first`."""
    numerator = wp.vec3(0.0, 0.0, 0.0)
    denominator = float(0.0)
    for i in range(BASIS):
        c = control[first + i]
        nw = b[i] * c[3]
        numerator += nw * wp.vec3(c[0], c[1], c[2])
        denominator += nw
    return numerator / denominator


@wp.kernel
def displace(positions: wp.array(dtype=wp.vec3), indptr: wp.array(dtype=wp.int32),
             first_control: wp.array(dtype=wp.int32), basis: wp.array(dtype=basis_values),
             weight: wp.array(dtype=wp.float32), control_rest: wp.array(dtype=wp.vec4),
             control_posed: wp.array(dtype=wp.vec4), displaced: wp.array(dtype=wp.vec3)):
    """displaced[v] = positions[v] + sum over the CSR row of v of mu (C'(u) - C(u)) (eq. 3.2 with eq. 3.6)."""
    v = wp.tid()
    total = wp.vec3(0.0, 0.0, 0.0)
    for k in range(indptr[v], indptr[v + 1]):
        b = basis[k]
        total += weight[k] * (curve_point(control_posed, first_control[k], b)
                              - curve_point(control_rest, first_control[k], b))
    displaced[v] = positions[v] + total

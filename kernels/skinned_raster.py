"""Skinning and rasterization of one frame in one call, the way a renderer draws a skinned mesh.

`skin_and_rasterize` is `rasterize(skin(rest, weights, bone_matrices), ...)`, with the same checks and
the same outputs. On OpenCL the posed positions never leave the device: the skinning kernel writes the
rasterizer's position buffer, and the frame makes one read-back instead of a read-back of the positions
and their upload again (with a wait between). On the other backends it is the two calls: NumPy is the
oracle, and Warp on the CPU device reads the posed array in place already.
"""
from __future__ import annotations

from kernels import backends, raster, skinning


def skin_and_rasterize(rest, weights, bone_matrices, triangles, triangle_part, camera, width: int, height: int, *,
                       look: str = "shaded", triangle_colour=None, palette=None, background=None,
                       cull_back_faces: bool = True, backend: str = "auto"):
    """Linear blend skinning, then rasterization of the posed mesh.

    rest (V, 3) float32 metres, weights (CSR, see kernels.skinning.SkinWeights), bone_matrices (B, 4, 4)
    float32: as kernels.skinning.skin. triangles, triangle_part, camera, width, height and the keywords: as
    kernels.raster.rasterize. Returns rasterize's rgb (H, W, 3) uint8, labels (H, W) uint8, triangle_id
    (H, W) int32 and depth (H, W) float32. Raises KernelError on bad input, including posed positions that
    are not finite.
    """
    name = backends.resolve(backend)
    options = dict(look=look, triangle_colour=triangle_colour, palette=palette, background=background,
                   cull_back_faces=cull_back_faces)
    if name != "opencl":
        posed = skinning.skin(rest, weights, bone_matrices, backend=name)
        return raster.rasterize(posed, triangles, triangle_part, camera, width, height, backend=name, **options)
    rest, weights, bone_matrices = skinning.checked_inputs(rest, weights, bone_matrices)
    scene = raster.checked_scene(rest, triangles, triangle_part, camera, width, height, **options)
    return raster.render_scene(scene, name, lambda queue, buffer: skinning.enqueue_opencl(rest, weights,
                                                                                          bone_matrices, buffer))

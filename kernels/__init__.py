"""Compute kernels (deform, rasterize) with Warp, OpenCL and NumPy-reference backends.

Entry points (explicit arrays, `backend="warp" | "opencl" | "numpy" | "auto"`):
  kernels.skinning.skin, kernels.skinning.skin_rigid   linear blend skinning (SkinWeights), rigid segments
  kernels.muscles.displace (with bind, combine)          NURBS muscle tubes (seed 000 eq. 3.6)
  kernels.raster.rasterize                               z-buffer, labels, triangle ids, two looks
  kernels.skinned_raster.skin_and_rasterize              both in one call (on OpenCL the skin stays on the device)
  kernels.camera.view_projection                         the camera matrix rasterize takes
  kernels.immutable                                      a static input (mesh, weights, colours) made immutable:
                                                         checked and uploaded once, not compared every frame
"auto" is Warp on CUDA when a GPU exists, else Warp on the CPU; kernels.backends.describe says where a
choice runs. Each entry point's module holds the NumPy oracle, the OpenCL source (its constants come
as generated #defines) and the host code; the Warp kernels live in kernels/*_warp.py, imported on
first use. Errors are KernelError, a SigncastError. Kernels import nothing of media or pipeline.
"""

from kernels._arrays import immutable as immutable  # re-exported: see above

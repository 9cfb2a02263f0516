"""Compute kernels (deform, rasterize) with Warp, OpenCL and NumPy-reference backends.

Entry points (explicit arrays, `backend="warp" | "opencl" | "numpy" | "auto"`):
  kernels.skinning.skin, kernels.skinning.skin_rigid   linear blend skinning, rigid segments
  kernels.muscles.displace (with bind, combine)          NURBS muscle tubes (seed 000 eq. 3.6)
  kernels.raster.rasterize                               z-buffer, labels, triangle ids, two looks
  kernels.camera.view_projection                         the camera matrix rasterize takes
"auto" is Warp on CUDA when a GPU exists, else Warp on the CPU. Kernels import nothing of media or pipeline.
"""

"""Compute kernels (deform, rasterize) with Warp, OpenCL and NumPy-reference backends."""

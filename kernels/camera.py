"""Pinhole camera matrices (OpenGL conventions: right-handed eye space looking down -Z, clip z in [-w, w])."""
from __future__ import annotations

import numpy as np

from kernels.errors import KernelError


def look_at(eye, target, up=(0.0, 1.0, 0.0)) -> np.ndarray:
    """(4, 4) float64 view matrix: world (metres) -> eye space, camera at `eye` looking at `target`."""
    eye, target, up = (np.asarray(x, dtype=np.float64) for x in (eye, target, up))
    forward = target - eye
    if np.linalg.norm(forward) == 0:
        raise KernelError("look_at: eye and target coincide")
    forward /= np.linalg.norm(forward)
    side = np.cross(forward, up)
    if np.linalg.norm(side) < 1e-9:
        raise KernelError("look_at: up is parallel to the viewing direction")
    side /= np.linalg.norm(side)
    true_up = np.cross(side, forward)
    view = np.eye(4)
    view[0, :3], view[1, :3], view[2, :3] = side, true_up, -forward
    view[:3, 3] = -view[:3, :3] @ eye
    return view


def perspective(fovy_deg: float, aspect: float, near: float, far: float) -> np.ndarray:
    """(4, 4) float64 projection: vertical field of view in degrees, width/height, near/far in metres."""
    if not (0 < fovy_deg < 180 and aspect > 0 and 0 < near < far):
        raise KernelError(f"perspective: bad parameters fovy={fovy_deg} aspect={aspect} near={near} far={far}")
    f = 1.0 / np.tan(np.radians(fovy_deg) / 2)
    projection = np.zeros((4, 4))
    projection[0, 0] = f / aspect
    projection[1, 1] = f
    projection[2, 2] = (far + near) / (near - far)
    projection[2, 3] = 2 * far * near / (near - far)
    projection[3, 2] = -1.0
    return projection


def view_projection(eye, target, fovy_deg: float, aspect: float, near: float, far: float, up=(0.0, 1.0, 0.0)) -> np.ndarray:
    """(4, 4) float32 world -> clip matrix, the `camera` argument of kernels.raster.rasterize."""
    return (perspective(fovy_deg, aspect, near, far) @ look_at(eye, target, up)).astype(np.float32)



def image_affine(camera: np.ndarray, linear, offset=(0.0, 0.0)) -> np.ndarray:
    """(4, 4) float32 world -> clip matrix: `camera` followed by the map n -> linear n + offset of its image, in
    normalised device coordinates (x right, y up; 2 is the image's width or height): linear (2, 2) with a positive
    determinant (a zoom, a turn; a mirror would turn front faces into back faces), offset (2,).

    A longer focal length, a roll and a lens shift, not a warp of the picture: the image is rasterized at full
    resolution. Depth and w are untouched, so clipping and depth order stay as they were."""
    linear = np.asarray(linear, np.float64)
    offset = np.asarray(offset, np.float64)
    if linear.shape != (2, 2) or offset.shape != (2,) or not (np.all(np.isfinite(linear)) and np.all(np.isfinite(offset))
                                                                 and np.linalg.det(linear) > 0):
        raise KernelError(f"image_affine: need a finite (2, 2) map with a positive determinant and a (2,) offset, "
                          f"got {linear.tolist()} and {offset.tolist()}")
    image = np.eye(4)
    image[:2, :2] = linear
    image[:2, 3] = offset                # added as offset * w before the divide: offset after it
    return (image @ np.asarray(camera, np.float64)).astype(np.float32)

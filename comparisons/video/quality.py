"""Image quality of decoded frames against reference frames: PSNR and SSIM on luma, whole frame or inside a mask.

Frames are (T, H, W, 3) uint8 RGB; luma is BT.601 (Y = 0.299 R + 0.587 G + 0.114 B, full range 0..255).
Masked figures pool the selected pixels of all frames: PSNR from their mean squared error, SSIM as the
mean of the local SSIM map over them.

The SSIM map is scikit-image's `structural_similarity(full=True)` map (7x7 uniform window, sample covariance,
K1 0.01, K2 0.03, data range 255, borders reflected), computed with OpenCV's box filter in float32: 20-30x
faster, within 1e-3 of scikit-image's map at every pixel (tests/test_image_quality.py). PSNR's luma difference is
taken from the integer RGB difference in float32 (within 1e-4 luma levels) and averaged in float64.
"""
from __future__ import annotations

import math

import cv2
import numpy as np

from media.errors import SigncastError

_LUMA = np.array([0.299, 0.587, 0.114], np.float64)
_LUMA_ROW = _LUMA[None].astype(np.float32)          # (1, 3): cv2.transform's matrix
SSIM_WINDOW = 7
_C1, _C2 = (0.01 * 255.0) ** 2, (0.03 * 255.0) ** 2
_COVARIANCE_NORM = SSIM_WINDOW ** 2 / (SSIM_WINDOW ** 2 - 1)   # sample covariance, as scikit-image's default


def luma(frames: np.ndarray) -> np.ndarray:
    """(T, H, W, 3) uint8 RGB -> (T, H, W) float64 BT.601 luma in 0..255."""
    return np.asarray(frames, np.float64) @ _LUMA


def luma32(frames: np.ndarray) -> np.ndarray:
    """(..., H, W, 3) uint8 RGB -> (..., H, W) float32 BT.601 luma in 0..255 (within 3e-5 of `luma`)."""
    frames = np.asarray(frames)
    rows = frames.reshape(-1, frames.shape[-2], 3).astype(np.float32)
    return cv2.transform(rows, _LUMA_ROW).reshape(frames.shape[:-1])


def squared_error(reference: np.ndarray, decoded: np.ndarray) -> np.ndarray:
    """(T, H, W, 3) uint8 RGB twice -> (T, H, W) float32 squared luma difference, luma levels squared."""
    return frame_measures(reference, decoded, ssim=False)[0]


def _box(image: np.ndarray) -> np.ndarray:
    return cv2.boxFilter(image, -1, (SSIM_WINDOW, SSIM_WINDOW), borderType=cv2.BORDER_REFLECT)


def ssim_map(reference_y: np.ndarray, decoded_y: np.ndarray) -> np.ndarray:
    """Local SSIM of two luma images (H, W) float32 in 0..255 -> (H, W) float32 (see the module's description)."""
    x, y = np.asarray(reference_y, np.float32), np.asarray(decoded_y, np.float32)
    ux, uy = _box(x), _box(y)
    uxx, uyy, uxy = _box(x * x), _box(y * y), _box(x * y)
    uxuy, ux2uy2 = ux * uy, ux * ux + uy * uy
    vx_vy = _COVARIANCE_NORM * (uxx + uyy - ux2uy2)
    vxy = _COVARIANCE_NORM * (uxy - uxuy)
    return ((2 * uxuy + _C1) * (2 * vxy + _C2)) / ((ux2uy2 + _C1) * (vx_vy + _C2))


def ssim_maps(reference: np.ndarray, decoded: np.ndarray) -> np.ndarray:
    """(T, H, W, 3) uint8 RGB twice -> (T, H, W) float32 local luma SSIM of every frame (`ssim_map`)."""
    return frame_measures(reference, decoded, error=False)[1]


def frame_measures(reference: np.ndarray, decoded: np.ndarray, *, error: bool = True, ssim: bool = True
                   ) -> tuple[np.ndarray | None, np.ndarray | None]:
    """(squared luma difference, local SSIM), each (T, H, W) float32 (None where not asked for), of two
    (T, H, W, 3) uint8 RGB arrays, frame by frame."""
    shape = reference.shape[:3]
    errors = np.empty(shape, np.float32) if error else None
    maps = np.empty(shape, np.float32) if ssim else None
    for t in range(shape[0]):
        if error:
            difference = cv2.transform(cv2.subtract(reference[t], decoded[t], dtype=cv2.CV_32F), _LUMA_ROW)
            np.square(difference, out=errors[t])
        if ssim:
            maps[t] = ssim_map(luma32(reference[t]), luma32(decoded[t]))
    return errors, maps


def _check(reference: np.ndarray, decoded: np.ndarray, mask: np.ndarray | None):
    reference, decoded = np.asarray(reference), np.asarray(decoded)
    if reference.shape != decoded.shape or reference.ndim != 4 or reference.shape[-1] != 3:
        raise SigncastError(f"quality needs two (T, H, W, 3) arrays of one shape, got {reference.shape} and {decoded.shape}")
    if mask is not None:
        mask = np.asarray(mask, bool)
        if mask.shape != reference.shape[:3]:
            raise SigncastError(f"quality mask {mask.shape} does not match frames {reference.shape[:3]}")
    return reference, decoded, mask


def _check_ssim_size(reference: np.ndarray) -> None:
    if min(reference.shape[1:3]) < SSIM_WINDOW:
        raise SigncastError(f"frames of {reference.shape[2]}x{reference.shape[1]} are too small for SSIM "
                            f"({SSIM_WINDOW}x{SSIM_WINDOW} window)")


def _db(mse: float) -> float:
    return math.inf if mse == 0 else 10.0 * math.log10(255.0 ** 2 / mse)


def psnr(reference: np.ndarray, decoded: np.ndarray, mask: np.ndarray | None = None) -> float:
    """Luma PSNR in dB over all frames (inside mask when given); inf when identical, NaN for an empty mask."""
    reference, decoded, mask = _check(reference, decoded, mask)
    if mask is not None and not mask.any():
        return float("nan")
    error = squared_error(reference, decoded)
    return _db(float(error.mean(dtype=np.float64) if mask is None else error[mask].mean(dtype=np.float64)))


def ssim(reference: np.ndarray, decoded: np.ndarray, mask: np.ndarray | None = None) -> float:
    """Mean luma SSIM (7x7 window; see the module's description) over all frames (inside mask when given); NaN for
    an empty mask."""
    reference, decoded, mask = _check(reference, decoded, mask)
    _check_ssim_size(reference)
    if mask is not None and not mask.any():
        return float("nan")
    maps = ssim_maps(reference, decoded)
    return float(maps.mean(dtype=np.float64) if mask is None else maps[mask].mean(dtype=np.float64))


def quality_fields(reference: np.ndarray, decoded: np.ndarray, skin: np.ndarray | None,
                   region: np.ndarray | None = None) -> dict[str, float]:
    """Record fields (dB, SSIM in [0, 1]): image_psnr / ssim over the frame, skin_psnr / skin_ssim inside the skin
    mask, and object_psnr / object_ssim inside the transmitted region when given (objects that leave parts of the
    frame unsent).

    Computes the squared error and the SSIM map once per frame and pools them per region.
    """
    reference, decoded, skin = _check(reference, decoded, skin)
    if region is not None:
        _, _, region = _check(reference, decoded, region)
    _check_ssim_size(reference)
    error, maps = frame_measures(reference, decoded)
    regions = (("image_psnr", "ssim", None), ("skin_psnr", "skin_ssim", skin), ("object_psnr", "object_ssim", region))
    fields = {}
    for k, (psnr_name, ssim_name, mask) in enumerate(regions):
        if k and mask is None:
            continue
        if mask is not None and not mask.any():
            fields[psnr_name] = fields[ssim_name] = float("nan")
            continue
        fields[psnr_name] = _db(float(error.mean(dtype=np.float64) if mask is None
                                      else error[mask].mean(dtype=np.float64)))
        fields[ssim_name] = float(maps.mean(dtype=np.float64) if mask is None else maps[mask].mean(dtype=np.float64))
    return fields

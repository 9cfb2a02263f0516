"""Image quality of decoded frames against reference frames: PSNR and SSIM on luma, whole frame or inside a mask.

Frames are (T, H, W, 3) uint8 RGB; luma is BT.601 (Y = 0.299 R + 0.587 G + 0.114 B, full range 0..255).
Masked figures pool the selected pixels of all frames: PSNR from their mean squared error, SSIM as the
mean of scikit-image's local SSIM map over them.
"""
from __future__ import annotations

import math

import numpy as np
from skimage.metrics import structural_similarity

from media.errors import SigncastError

_LUMA = np.array([0.299, 0.587, 0.114], np.float64)


def luma(frames: np.ndarray) -> np.ndarray:
    """(T, H, W, 3) uint8 RGB -> (T, H, W) float64 BT.601 luma in 0..255."""
    return np.asarray(frames, np.float64) @ _LUMA


def _check(reference: np.ndarray, decoded: np.ndarray, mask: np.ndarray | None):
    reference, decoded = np.asarray(reference), np.asarray(decoded)
    if reference.shape != decoded.shape or reference.ndim != 4 or reference.shape[-1] != 3:
        raise SigncastError(f"quality needs two (T, H, W, 3) arrays of one shape, got {reference.shape} and {decoded.shape}")
    if mask is not None:
        mask = np.asarray(mask, bool)
        if mask.shape != reference.shape[:3]:
            raise SigncastError(f"quality mask {mask.shape} does not match frames {reference.shape[:3]}")
    return reference, decoded, mask


def psnr(reference: np.ndarray, decoded: np.ndarray, mask: np.ndarray | None = None) -> float:
    """Luma PSNR in dB over all frames (inside mask when given); inf when identical, NaN for an empty mask."""
    reference, decoded, mask = _check(reference, decoded, mask)
    error = (luma(reference) - luma(decoded)) ** 2
    if mask is not None:
        if not mask.any():
            return float("nan")
        error = error[mask]
    mse = float(error.mean())
    return math.inf if mse == 0 else 10.0 * math.log10(255.0 ** 2 / mse)


def ssim(reference: np.ndarray, decoded: np.ndarray, mask: np.ndarray | None = None) -> float:
    """Mean luma SSIM (scikit-image, 7x7 window) over all frames (inside mask when given); NaN for an empty mask."""
    reference, decoded, mask = _check(reference, decoded, mask)
    if min(reference.shape[1:3]) < 7:
        raise SigncastError(f"frames of {reference.shape[2]}x{reference.shape[1]} are too small for SSIM (7x7 window)")
    if mask is not None and not mask.any():
        return float("nan")
    ref_y, dec_y = luma(reference), luma(decoded)
    total, count = 0.0, 0
    for t in range(len(ref_y)):
        if mask is not None and not mask[t].any():
            continue
        _, local = structural_similarity(ref_y[t], dec_y[t], data_range=255.0, full=True)
        selected = local[mask[t]] if mask is not None else local
        total += float(selected.sum())
        count += selected.size
    return total / count


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
    if min(reference.shape[1:3]) < 7:
        raise SigncastError(f"frames of {reference.shape[2]}x{reference.shape[1]} are too small for SSIM (7x7 window)")
    ref_y, dec_y = luma(reference), luma(decoded)
    error = (ref_y - dec_y) ** 2
    ssim_map = np.stack([structural_similarity(ref_y[t], dec_y[t], data_range=255.0, full=True)[1]
                         for t in range(len(ref_y))])
    regions = (("image_psnr", "ssim", None), ("skin_psnr", "skin_ssim", skin), ("object_psnr", "object_ssim", region))
    fields = {}
    for k, (psnr_name, ssim_name, mask) in enumerate(regions):
        if k and mask is None:
            continue
        if mask is not None and not mask.any():
            fields[psnr_name] = fields[ssim_name] = float("nan")
            continue
        mse = float(error.mean() if mask is None else error[mask].mean())
        fields[psnr_name] = math.inf if mse == 0 else 10.0 * math.log10(255.0 ** 2 / mse)
        fields[ssim_name] = float(ssim_map.mean() if mask is None else ssim_map[mask].mean())
    return fields

"""Error measures for coded animation parameters.

- seed 000 eq. 2.6: D = (1/N) sum_i ||BAP_i(orig) - BAP_i(dec)||^2, the mean over frames of the
  squared norm of the parameter-vector error (the printed sum's off-by-one is not reproduced).
- seed 002 chapter 6 (vanderelst-digest.md §3), per DOF over a sequence of N samples, R the range
  (max - min) of the original: MSE (6-1), RMSE (6-2), NMSE (6-3), PMSE = MSE / R^2 (6-4),
  NSNR = -10 log10 NMSE (6-5), PSNR = -10 log10 PMSE (6-6); the normalised weighted vector error of
  a joint group w(n) = (1/K) sum_j a_j (e_j(n))^2 / b_j^2 (6-9) and its maximum form
  m(n) = max_j a_j |e_j(n)| / b_j (6-10); joint position error via forward kinematics (6-12 with
  a = b = 1, square root: metres, reported in mm); VMSE = (1/N) sum_n (sum_m a_m e_m(n))^2 with bands
  0-1, 1-3, 3-7, 7-15 Hz and weights 0.25, 0.5, 1, 2.25 (6-15), VPMSE = VMSE / R^2 (6-16),
  VPSNR = -10 log10 VPMSE (6-17).

Chosen here: the filter bank (not specified by the thesis) splits the error's spectrum into the
four bands with an FFT over the whole sequence (ideal, complementary filters, so with all weights 1
VMSE equals MSE); frequencies above 15 Hz go to the last band. DOFs whose original is constant
(R = 0) are left out of averaged PSNR/VPSNR.
"""
from __future__ import annotations

import numpy as np

from media.avatar import Skeleton
from media.errors import SigncastError
from media.kinematics import bone_matrices, joint_positions
from media.motion import Motion

VISUAL_BANDS_HZ = ((0.0, 1.0), (1.0, 3.0), (3.0, 7.0), (7.0, 15.0))
VISUAL_WEIGHTS = (0.25, 0.5, 1.0, 2.25)


def _pair(original, decoded) -> tuple[np.ndarray, np.ndarray]:
    original = np.asarray(original, dtype=np.float64)
    decoded = np.asarray(decoded, dtype=np.float64)
    if original.shape != decoded.shape or original.ndim < 1 or len(original) == 0:
        raise SigncastError(f"original and decoded must have the same non-empty shape, got {original.shape} and {decoded.shape}")
    return original, decoded


def distortion(original, decoded) -> float:
    """Eq. 2.6 over (N, P) parameter vectors: mean over frames of the squared error norm."""
    original, decoded = _pair(original, decoded)
    return float(np.mean(np.sum((original - decoded).reshape(len(original), -1) ** 2, axis=1)))


def mse(original, decoded) -> np.ndarray:
    """(P,) per-DOF mean squared error of (N, P) sequences (6-1)."""
    original, decoded = _pair(original, decoded)
    return np.mean((original - decoded) ** 2, axis=0)


def rmse(original, decoded) -> np.ndarray:
    return np.sqrt(mse(original, decoded))


def nmse(original, decoded) -> np.ndarray:
    """(6-3) sum e^2 / sum theta^2 (inf where the original is all zero)."""
    original, decoded = _pair(original, decoded)
    energy = np.sum(original ** 2, axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(energy > 0, np.sum((original - decoded) ** 2, axis=0) / np.where(energy > 0, energy, 1), np.inf)


def value_range(original) -> np.ndarray:
    original = np.asarray(original, dtype=np.float64)
    return original.max(axis=0) - original.min(axis=0)


def pmse(original, decoded) -> np.ndarray:
    """(6-4) MSE / R^2 (nan where R = 0)."""
    r = value_range(original)
    return np.where(r > 0, mse(original, decoded) / np.where(r > 0, r, 1) ** 2, np.nan)


def _db(ratio: np.ndarray) -> np.ndarray:
    with np.errstate(divide="ignore", invalid="ignore"):
        return -10.0 * np.log10(ratio)


def nsnr(original, decoded) -> np.ndarray:
    return _db(nmse(original, decoded))


def psnr(original, decoded) -> np.ndarray:
    """(6-6) per DOF, dB (inf for a perfect DOF, nan for a constant original)."""
    return _db(pmse(original, decoded))


def mean_db(values: np.ndarray, cap_db: float = 100.0) -> float:
    """Average of per-DOF dB values over DOFs that have one (nan skipped), inf capped at cap_db."""
    values = np.asarray(values, dtype=np.float64)
    values = values[~np.isnan(values)]
    if not len(values):
        return float("nan")
    return float(np.mean(np.minimum(values, cap_db)))


def weighted_vector_error(original, decoded, a, b) -> np.ndarray:
    """(N,) w(n) = (1/K) sum_j a_j e_j(n)^2 / b_j^2 over a group's K DOFs (6-9)."""
    original, decoded = _pair(original, decoded)
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    return np.mean(a * (original - decoded) ** 2 / b ** 2, axis=1)


def max_weighted_error(original, decoded, a, b) -> np.ndarray:
    """(N,) m(n) = max_j a_j |e_j(n)| / b_j (6-10)."""
    original, decoded = _pair(original, decoded)
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    return np.max(a * np.abs(original - decoded) / b, axis=1)


def joint_position_error_mm(skeleton: Skeleton, original: Motion, decoded: Motion) -> np.ndarray:
    """(N, B) distance in mm between every joint of the two motions (forward kinematics)."""
    if original.n_frames != decoded.n_frames:
        raise SigncastError(f"motions differ in length: {original.n_frames} and {decoded.n_frames} frames")
    return 1000.0 * np.linalg.norm(joint_positions(skeleton, original) - joint_positions(skeleton, decoded), axis=-1)


def face_joint_error_mm(skeleton: Skeleton, original: Motion, decoded: Motion, face_bones, anchor: str = "head"
                        ) -> np.ndarray:
    """(N, F) distance in mm between the tails of the face bones (the chin, the lid margins, the lip points, the
    brows, ...; F = len(face_bones), names) of the two motions, each measured in its own motion's posed anchor
    bone's frame: the face's own movement, with the head's pose taken out (`joint_position_error_mm` counts the
    head's pose error on every face joint, which hides a face left at rest)."""
    if original.n_frames != decoded.n_frames:
        raise SigncastError(f"motions differ in length: {original.n_frames} and {decoded.n_frames} frames")
    face = np.array([skeleton.index(name) for name in face_bones], dtype=np.int64)
    anchor_index = skeleton.index(anchor)
    local = []
    for motion in (original, decoded):
        world = bone_matrices(skeleton, motion)
        posed = world[:, face]
        tails = np.einsum("tfij,fj->tfi", posed[..., :3, :3], skeleton.tails[face]) + posed[..., :3, 3]
        turn, shift = world[:, anchor_index, :3, :3], world[:, anchor_index, :3, 3]
        local.append(np.einsum("tji,tfj->tfi", turn, tails - shift[:, None]))       # R^T (p - t)
    return 1000.0 * np.linalg.norm(local[0] - local[1], axis=-1)


def band_split(error, fps: float, bands=VISUAL_BANDS_HZ) -> np.ndarray:
    """(M, N, ...) the error sequence (N, ...) split into complementary frequency bands."""
    error = np.asarray(error, dtype=np.float64)
    spectrum = np.fft.rfft(error, axis=0)
    frequencies = np.fft.rfftfreq(len(error), d=1.0 / fps)
    edges = [low for low, _ in bands][1:]
    band_of = np.searchsorted(edges, frequencies, side="right")
    parts = []
    for m in range(len(bands)):
        keep = (band_of == m).reshape((-1,) + (1,) * (error.ndim - 1))
        parts.append(np.fft.irfft(spectrum * keep, n=len(error), axis=0))
    return np.stack(parts)


def vmse(original, decoded, fps: float, weights=VISUAL_WEIGHTS, bands=VISUAL_BANDS_HZ) -> np.ndarray:
    """(P,) VMSE per DOF (6-15)."""
    original, decoded = _pair(original, decoded)
    parts = band_split(original - decoded, fps, bands)
    weighted = np.tensordot(np.asarray(weights, dtype=np.float64), parts, axes=1)
    return np.mean(weighted ** 2, axis=0)


def vpsnr(original, decoded, fps: float, weights=VISUAL_WEIGHTS, bands=VISUAL_BANDS_HZ) -> np.ndarray:
    """(P,) VPSNR per DOF in dB (6-17), nan where the original is constant."""
    r = value_range(original)
    vpmse = np.where(r > 0, vmse(original, decoded, fps, weights, bands) / np.where(r > 0, r, 1) ** 2, np.nan)
    return _db(vpmse)


def bap_group_errors(original, decoded) -> dict[str, tuple[float, float]]:
    """Per BAP group (comparisons/bap_table.GROUP_MEMBERS, the seed-002 joint groups' counterpart):
    (mean of w(n), max of m(n)) with a = 1 and b = the range of each moving BAP in the original;
    groups with no moving BAP are left out. original, decoded: (N, 296) BAP values."""
    from comparisons.params import bap_table

    original, decoded = _pair(original, decoded)
    out = {}
    r = value_range(original)
    for label, members in zip(bap_table.GROUP_LABELS, bap_table.GROUP_MEMBERS):
        columns = [i - 1 for i in members if r[i - 1] > 0]
        if columns:
            a, b = np.ones(len(columns)), r[columns]
            out[label] = (float(weighted_vector_error(original[:, columns], decoded[:, columns], a, b).mean()),
                          float(max_weighted_error(original[:, columns], decoded[:, columns], a, b).max()))
    return out

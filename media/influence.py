"""Skin weights from bone influence volumes (seed 000 §3.2.2.1, eq. 3.3, Fig. 3.1).

Each bone is a segment from head to tail (length l). On the plane perpendicular to the bone at
distance d in [0, l] two circles of radii r_d < R_d split the plane: inside r_d the affectedness
is 1, outside R_d it is 0, and between them it is f((R_d - rho) / (R_d - r_d)), rho being the
distance from the bone axis. Before the head and past the tail the same rule holds on half
spheres of radii (r_0, R_0) and (r_l, R_l). Radii are linear in d between the sections.
Weights are the affectedness normalised over bones.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from kernels.skinning import SkinWeights
from media.avatar import Skeleton
from media.errors import SigncastError

FALLOFFS = {
    -1: lambda x: x ** 3,
    0: lambda x: x ** 2,
    1: lambda x: x,
    2: lambda x: np.sin(np.pi * x / 2),
    3: np.sqrt,
    4: np.cbrt,
}
FALLOFF_NAMES = {-1: "x^3", 0: "x^2", 1: "x", 2: "sin(pi x/2)", 3: "sqrt(x)", 4: "cbrt(x)"}


def falloff(code: int, x: np.ndarray) -> np.ndarray:
    """Evaluate falloff function `code` (-1..4, the SBBone/SBMuscle falloff field) on x in [0, 1]."""
    if code not in FALLOFFS:
        raise SigncastError(f"unknown falloff code {code}: choose one of {sorted(FALLOFFS)}")
    return FALLOFFS[code](np.clip(x, 0.0, 1.0))


@dataclass(frozen=True)
class InfluenceVolume:
    """One bone's volume: sections at relative positions (S,) in [0, 1] along the bone with inner
    and outer radii (S,) in metres (inner < outer), and a falloff code."""
    positions: np.ndarray
    inner: np.ndarray
    outer: np.ndarray
    falloff: int = 1


def affectedness(points: np.ndarray, head: np.ndarray, tail: np.ndarray, volume: InfluenceVolume) -> np.ndarray:
    """mu (eq. 3.3) of a bone's influence volume at points (N, 3) metres; returns (N,) in [0, 1]."""
    axis = tail - head
    length = float(np.linalg.norm(axis))
    if length <= 0:
        raise SigncastError("a bone with zero length has no influence volume")
    axis = axis / length
    rel = points - head
    d = rel @ axis
    rho = np.linalg.norm(rel - d[:, None] * axis, axis=1)
    s = np.clip(d / length, 0.0, 1.0)
    inner = np.interp(s, volume.positions, volume.inner)
    outer = np.interp(s, volume.positions, volume.outer)
    # Half-sphere caps: beyond an end, distance to that end point replaces the radial distance.
    distance = np.where(d < 0, np.linalg.norm(rel, axis=1),
                        np.where(d > length, np.linalg.norm(points - tail, axis=1), rho))
    x = (outer - distance) / np.maximum(outer - inner, 1e-12)
    return np.where(distance <= inner, 1.0, np.where(distance >= outer, 0.0, falloff(volume.falloff, x)))


def fit_volumes(vertices: np.ndarray, skeleton: Skeleton, bones: np.ndarray, *, inner_scale: float = 0.6,
                outer_scale: float = 1.6, falloff_code: int = 2, n_sections: int = 3) -> list[InfluenceVolume]:
    """Influence volumes sized from the mesh around each bone (what an artist would set by eye).

    Each vertex is assigned to its nearest bone segment; at each section the local limb radius is the
    median distance from the axis of the vertices assigned to that part of the bone. Inner and outer
    radii are that radius times inner_scale and outer_scale.
    """
    distances = np.stack([_segment_distance(vertices, skeleton.heads[b], skeleton.tails[b])[0] for b in bones])
    nearest = np.argmin(distances, axis=0)
    volumes = []
    for k, b in enumerate(bones):
        _, s = _segment_distance(vertices, skeleton.heads[b], skeleton.tails[b])
        mine = nearest == k
        positions = np.linspace(0.0, 1.0, n_sections)
        radius = np.full(n_sections, np.nan)
        for i, p in enumerate(positions):
            near = mine & (np.abs(s - p) <= 0.5 / (n_sections - 1))
            if np.count_nonzero(near) >= 3:
                radius[i] = np.median(distances[k][near])
        fallback = np.nanmedian(radius) if np.any(np.isfinite(radius)) else 0.5 * np.linalg.norm(skeleton.tails[b] - skeleton.heads[b])
        radius = np.where(np.isfinite(radius), radius, fallback)
        radius = np.maximum(radius, 0.004)
        volumes.append(InfluenceVolume(positions, radius * inner_scale, radius * outer_scale, falloff_code))
    return volumes


def influence_weights(vertices: np.ndarray, skeleton: Skeleton, bones: np.ndarray,
                      volumes: list[InfluenceVolume]) -> SkinWeights:
    """SkinWeights over all skeleton bones from the volumes of `bones` (indices into skeleton).

    A vertex outside every volume takes its nearest bone with weight 1.
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    mu = np.stack([affectedness(vertices, skeleton.heads[b], skeleton.tails[b], v) for b, v in zip(bones, volumes)], axis=1)
    uncovered = mu.sum(axis=1) <= 0
    if np.any(uncovered):
        distances = np.stack([_segment_distance(vertices[uncovered], skeleton.heads[b], skeleton.tails[b])[0] for b in bones], axis=1)
        mu[np.flatnonzero(uncovered), np.argmin(distances, axis=1)] = 1.0
    full = np.zeros((len(vertices), len(skeleton)))
    full[:, bones] = mu
    return SkinWeights.from_dense(full, threshold=1e-4)


def dominant_agreement(computed: SkinWeights, reference: SkinWeights, mask: np.ndarray | None = None) -> float:
    """Share (0..1) of vertices (optionally within mask) whose dominant bone is the same in both."""
    same = computed.dominant_bone() == reference.dominant_bone()
    return float(np.mean(same[mask] if mask is not None else same))


def _segment_distance(points: np.ndarray, head: np.ndarray, tail: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distance (N,) from points to segment head-tail and the relative position (N,) of the foot in [0, 1]."""
    axis = tail - head
    length2 = max(float(axis @ axis), 1e-18)
    s = np.clip((points - head) @ axis / length2, 0.0, 1.0)
    return np.linalg.norm(points - (head + s[:, None] * axis), axis=1), s

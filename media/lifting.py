"""Lifting 2D keypoints to 3D with known bone lengths (the lexicon's depth is flattened).

Conventions: image points are pixels (x right, y down). `to_plane` turns them into the avatar's
frontal plane, metres (X = avatar's left, Y up); depth Z points from the signer towards the
viewer (the avatar faces +Z). Under orthographic projection a bone of true length L whose image
has length l < L leaves the image plane by |dz| = sqrt(L^2 - l^2) (zero when l >= L); only the
sign of dz is unknown, and the callers choose it with anatomical priors.
"""
from __future__ import annotations

import numpy as np

from media import rotations


def to_plane(points_px: np.ndarray, pixels_per_metre: float | np.ndarray, origin_px: np.ndarray | None = None) -> np.ndarray:
    """Image points (..., >=2) pixels -> frontal-plane points (..., 2) metres (X right of image = +X, Y up)."""
    xy = np.asarray(points_px, dtype=np.float64)[..., :2]
    if origin_px is not None:
        xy = xy - np.asarray(origin_px, dtype=np.float64)[..., :2]
    scale = np.asarray(pixels_per_metre, dtype=np.float64)
    return np.stack([xy[..., 0], -xy[..., 1]], axis=-1) / scale[..., None] if scale.ndim else \
        np.stack([xy[..., 0], -xy[..., 1]], axis=-1) / float(scale)


def out_of_plane(projected: np.ndarray, length: float | np.ndarray) -> np.ndarray:
    """|dz| (...) metres of a bone of true `length` whose frontal-plane vector is `projected` (..., 2)."""
    l2 = np.sum(np.asarray(projected, dtype=np.float64) ** 2, axis=-1)
    return np.sqrt(np.maximum(np.asarray(length, dtype=np.float64) ** 2 - l2, 0.0))


def lift_directions(projected: np.ndarray, length: float | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Both 3D unit directions (..., 3) consistent with a projected bone: (dz >= 0, dz <= 0).

    projected: (..., 2) metres in the frontal plane; length: true bone length, metres.
    A bone whose image is longer than `length` lies in the plane (dz = 0).
    """
    projected = np.asarray(projected, dtype=np.float64)
    dz = out_of_plane(projected, length)
    towards = np.concatenate([projected, dz[..., None]], axis=-1)
    away = np.concatenate([projected, -dz[..., None]], axis=-1)
    norm = np.maximum(np.linalg.norm(towards, axis=-1, keepdims=True), 1e-12)
    return towards / norm, away / norm


def true_lengths(projected: np.ndarray, model_length: float, valid: np.ndarray | None = None,
                 percentile: float = 90.0) -> float:
    """Length (metres) to lift with: the model's, or longer when the clip shows the bone longer.

    projected: (T, 2) frontal-plane vectors of one bone over a clip. A signer whose bone is
    longer (relative to the scale) than the avatar's would otherwise be forced flat.
    """
    lengths = np.linalg.norm(np.asarray(projected, dtype=np.float64), axis=-1)
    if valid is not None:
        lengths = lengths[np.asarray(valid, dtype=bool)]
    if not len(lengths):
        return float(model_length)
    return float(max(model_length, np.percentile(lengths, percentile)))


def fit_triangle(observed: np.ndarray, template: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Weak-perspective pose of a rigid triangle from its image (exact for 3 points).

    observed: (T, 3, 2) frontal-plane positions of the triangle's corners (any unit, e.g. pixels with
    Y up); template: (3, 3) the corners in the avatar's rest pose, metres.
    Returns (rotation_a, rotation_b, scale): two (T, 3, 3) rotation matrices mapping rest-pose
    vectors to posed world vectors, the two mirror-in-depth solutions (same image, opposite tilt),
    and (T,) the scale in observed units per metre. The solution a has the first edge towards
    the viewer (z >= 0 of the rotated first template edge).
    """
    observed = np.asarray(observed, dtype=np.float64)
    template = np.asarray(template, dtype=np.float64)
    edges_rest = np.stack([template[1] - template[0], template[2] - template[0]], axis=1)      # (3, 2)
    q, r = np.linalg.qr(edges_rest)                                                            # (3,2), (2,2)
    normal = rotations.cross(q[:, 0], q[:, 1])
    edges_seen = np.stack([observed[:, 1] - observed[:, 0], observed[:, 2] - observed[:, 0]], axis=-1)  # (T, 2 rows xy, 2 edges)
    # s * rows(R)[:2] @ edges_rest = edges_seen  ->  s * (Q^T r_i) = R^-T m_i =: c_i
    c = np.einsum("ij,tkj->tki", np.linalg.inv(r).T, edges_seen)                               # (T, 2, 2): c_1, c_2
    a = np.sum(c[:, 0] ** 2, axis=-1)
    b = np.sum(c[:, 1] ** 2, axis=-1)
    cc = np.sum(c[:, 0] * c[:, 1], axis=-1)
    quad = np.maximum(a * b - cc ** 2, 0.0)
    lin = a + b
    disc = np.sqrt(np.maximum(lin ** 2 - 4 * quad, 0.0))
    # smaller root of 1 - u (a + b) + u^2 (ab - c^2) = 0, written stably; u = 1 / s^2
    u = 2.0 / np.maximum(lin + disc, 1e-300)
    z1 = np.sqrt(np.maximum(1.0 - u * a, 0.0))
    z2 = np.sqrt(np.maximum(1.0 - u * b, 0.0))
    z2 = np.where(cc > 0, -z2, z2)
    root_u = np.sqrt(u)
    row1 = root_u[:, None] * (c[:, 0] @ q.T)
    row2 = root_u[:, None] * (c[:, 1] @ q.T)
    solutions = []
    for sign in (1.0, -1.0):
        r1 = row1 + sign * z1[:, None] * normal
        r2 = row2 + sign * z2[:, None] * normal
        solutions.append(_orthonormal_rows(r1, r2))
    scale = 1.0 / np.maximum(root_u, 1e-300)
    first_edge_z = np.einsum("tj,j->t", solutions[0][:, 2], edges_rest[:, 0])
    swap = first_edge_z < 0
    rotation_a = np.where(swap[:, None, None], solutions[1], solutions[0])
    rotation_b = np.where(swap[:, None, None], solutions[0], solutions[1])
    return rotation_a, rotation_b, scale


def _orthonormal_rows(r1: np.ndarray, r2: np.ndarray) -> np.ndarray:
    """Nearest rotation (T, 3, 3) whose first two rows are close to r1, r2 (T, 3): symmetric
    Gram-Schmidt (split the error between the two rows), third row their cross product."""
    r1 = r1 / np.maximum(np.linalg.norm(r1, axis=-1, keepdims=True), 1e-12)
    r2 = r2 / np.maximum(np.linalg.norm(r2, axis=-1, keepdims=True), 1e-12)
    half_error = 0.5 * np.sum(r1 * r2, axis=-1, keepdims=True)
    x = r1 - half_error * r2
    y = r2 - half_error * r1
    x /= np.maximum(np.linalg.norm(x, axis=-1, keepdims=True), 1e-12)
    y = y - np.sum(x * y, axis=-1, keepdims=True) * x
    y /= np.maximum(np.linalg.norm(y, axis=-1, keepdims=True), 1e-12)
    return np.stack([x, y, rotations.cross(x, y)], axis=1)


def open_hinge(projected: np.ndarray, depth: np.ndarray, towards_parent: np.ndarray, min_angle: float,
               max_ratio: float = 4.0) -> np.ndarray:
    """Unit directions (T, 3) of a bone past a hinge, coming out of the plane as far as its limit needs.

    projected: (T, 2) frontal-plane vector of the bone; depth: (T,) dz >= 0 from its length;
    towards_parent: (T, 3) unit vector from the hinge back along the parent bone; min_angle: the
    smallest interior angle (radians) the hinge allows (180 deg - maximum flexion). A bone whose
    image folds back onto its parent more than the hinge can bend must leave the image plane
    (towards the viewer): dz grows from `depth` to the smallest value meeting the limit (at most
    max_ratio times the image length).
    """
    projected = np.asarray(projected, dtype=np.float64)
    image_length = np.maximum(np.linalg.norm(projected, axis=-1), 1e-9)
    factors = np.linspace(0.0, max_ratio, 81)
    depths = np.maximum(np.asarray(depth, dtype=np.float64)[:, None], factors[None, :] * image_length[:, None])  # (T, S)
    vectors = np.concatenate([np.broadcast_to(projected[:, None, :], depths.shape + (2,)), depths[..., None]], axis=-1)
    vectors /= np.linalg.norm(vectors, axis=-1, keepdims=True)
    cosine = np.einsum("tsd,td->ts", vectors, towards_parent)
    allowed = cosine <= np.cos(min_angle)
    first = np.where(allowed.any(axis=1), np.argmax(allowed, axis=1), np.argmin(cosine, axis=1))
    return vectors[np.arange(len(vectors)), first]

"""Forward kinematics: Motion -> bone world transforms (skinning matrices) and joint positions."""
from __future__ import annotations

import numpy as np

from media import rotations
from media.avatar import Skeleton
from media.errors import SigncastError
from media.motion import Motion


def align_to_skeleton(motion: Motion, skeleton: Skeleton) -> np.ndarray:
    """(T, B, 4) rotations in skeleton order; bones the motion lacks stay at rest."""
    q = np.zeros((motion.n_frames, len(skeleton), 4))
    q[..., 0] = 1.0
    known = [(skeleton.index(name), k) for k, name in enumerate(motion.bone_names) if name in skeleton._index]
    if len(known) < len(motion.bone_names):
        missing = sorted(set(motion.bone_names) - set(skeleton.names))
        raise SigncastError(f"motion drives bones the avatar lacks: {', '.join(missing[:5])}")
    if known:
        dst, src = zip(*known)
        q[:, list(dst)] = motion.rotations[:, list(src)]
    return q


def bone_matrices(skeleton: Skeleton, motion: Motion) -> np.ndarray:
    """(T, B, 4, 4) float64 world transform of every bone, mapping rest-pose world points (metres)
    to posed ones: the skinning matrices. M_b = M_parent . T_b with T_b = TR . C . R . C^-1 (eq. 3.5,
    no scale), C the bone's rest head, TR the root translation for the root bone."""
    q = align_to_skeleton(motion, skeleton)
    T, B = q.shape[:2]
    local = np.zeros((T, B, 4, 4))
    local[..., 3, 3] = 1.0
    r = rotations.to_matrix(q)
    local[..., :3, :3] = r
    heads = skeleton.heads
    local[..., :3, 3] = heads - np.einsum("tbij,bj->tbi", r, heads)
    for root in np.flatnonzero(skeleton.parents < 0):
        local[:, root, :3, 3] += motion.root_translation
    world = np.empty_like(local)
    for level in skeleton.depth_levels():
        parents = skeleton.parents[level]
        is_root = parents < 0
        if np.all(is_root):
            world[:, level] = local[:, level]
        else:
            world[:, level] = np.einsum("tbij,tbjk->tbik", world[:, parents], local[:, level])
    return world


def joint_positions(skeleton: Skeleton, motion: Motion, *, tails: bool = False) -> np.ndarray:
    """(T, B, 3) float64 world position in metres of every bone's head (or tail)."""
    world = bone_matrices(skeleton, motion)
    points = skeleton.tails if tails else skeleton.heads
    return np.einsum("tbij,bj->tbi", world[..., :3, :3], points) + world[..., :3, 3]


def world_rotations(skeleton: Skeleton, motion: Motion) -> np.ndarray:
    """(T, B, 4) world orientation of every bone's frame (rest = identity)."""
    q = align_to_skeleton(motion, skeleton)
    world = np.empty_like(q)
    for level in skeleton.depth_levels():
        parents = skeleton.parents[level]
        if np.all(parents < 0):
            world[:, level] = q[:, level]
        else:
            world[:, level] = rotations.multiply(world[:, parents], q[:, level])
    return world

"""Cyclic-coordinate-descent inverse kinematics with joint limits (seed 000 §2.3.2, eqs. 2.1-2.5).

A chain is a list of joints from the root outwards; each joint rotates about its rest-pose pivot
(a point in the avatar's rest world, metres) through one to three degrees of freedom: angles
about unit axes given in the joint's rest frame and applied in order in the moving frame,
R_joint = R(a_1, q_1) R(a_2, q_2) R(a_3, q_3), each angle clamped to [lower, upper] (radians).

Goal (eq. 2.3): E = E_p + E_o with E_p = sum_i w_i ||P_d,i - P_c,i||^2 over position effectors
(eq. 2.4; a point of the rest pose carried by some joint: several effectors, e.g. elbow and
wrist, pin the redundant swivel of an arm) and E_o = sum_j ((u_jd . u_jc) - 1)^2 over the three
axes of an orientation effector (eq. 2.5). One pass walks from the most distal joint to the root
and optimises one angle at a time: rotating by delta about the DOF's world axis a through the
pivot, the goal sum_i w_i d_i.R(delta)c_i + w_o sum_j u_jd.R(delta)u_jc (c, d: current and desired
effector vectors from the pivot; its maximum is E's minimum) equals const + B cos(delta) +
C sin(delta), so delta = atan2(C, B), and the new angle is clamped to its limits. Passes repeat
until the goal stops improving or a pass cap returns the best effort. All frames are solved at
once (arrays carry a leading time axis T).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from media import rotation_loops, rotations


@dataclass(frozen=True)
class ChainJoint:
    """pivot: (3,) rest position of the joint, metres; axes: (K, 3) unit axes in the rest frame;
    lower, upper: (K,) angle limits, radians."""
    name: str
    pivot: np.ndarray
    axes: np.ndarray
    lower: np.ndarray
    upper: np.ndarray


@dataclass
class IKTargets:
    """points: list of (joint index, rest point (3,), desired world positions (T, 3), weight);
    orientation: None or (joint index, desired world rotation (T, 3, 3) of that joint's frame, weight
    in m^2: the lever arm squared at which an orientation error counts like a position error)."""
    points: list[tuple[int, np.ndarray, np.ndarray, float]] = field(default_factory=list)
    orientation: tuple[int, np.ndarray, float] | None = None


def _axis_matrices(axes: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """(T, K, 3, 3) rotation about each unit axis (K, 3) by each angle (T, K) (Rodrigues; compiled,
    media/rotation_loops.py; `_axis_matrices_numpy` is the NumPy form)."""
    return rotation_loops.axis_matrices(np.ascontiguousarray(axes, dtype=np.float64),
                                        np.ascontiguousarray(angles, dtype=np.float64))


def _axis_matrices_numpy(axes: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """`_axis_matrices` in NumPy."""
    axes = np.asarray(axes, dtype=np.float64)
    cross = np.zeros(axes.shape[:-1] + (3, 3))
    cross[..., 0, 1], cross[..., 0, 2], cross[..., 1, 2] = -axes[..., 2], axes[..., 1], -axes[..., 0]
    cross[..., 1, 0], cross[..., 2, 0], cross[..., 2, 1] = axes[..., 2], -axes[..., 1], axes[..., 0]
    outer = axes[..., :, None] * axes[..., None, :]
    sin = np.sin(angles)[..., None, None]
    cos = np.cos(angles)[..., None, None]
    return cos * np.eye(3) + sin * cross + (1.0 - cos) * outer


def joint_rotations(chain: list[ChainJoint], angles: list[np.ndarray]) -> list[np.ndarray]:
    """Local rotation matrices (T, 3, 3) of every joint from its angles (T, K)."""
    local = []
    for joint, q in zip(chain, angles):
        per_axis = _axis_matrices(joint.axes, q)
        m = per_axis[:, 0]
        for k in range(1, len(joint.axes)):
            m = m @ per_axis[:, k]
        local.append(m)
    return local


def chain_transforms(chain: list[ChainJoint], angles: list[np.ndarray], base: np.ndarray) -> list[np.ndarray]:
    """World transforms (T, 4, 4) of every joint, base: (T, 4, 4) world transform of the chain's parent.

    A joint's transform maps rest-pose world points of its subtree to posed world points.
    """
    transforms = []
    current = base
    for joint, rotation in zip(chain, joint_rotations(chain, angles)):
        local = np.zeros(rotation.shape[:-2] + (4, 4))
        local[..., :3, :3] = rotation
        local[..., :3, 3] = joint.pivot - rotation @ joint.pivot
        local[..., 3, 3] = 1.0
        current = current @ local
        transforms.append(current)
    return transforms


def _apply(transform: np.ndarray, point: np.ndarray) -> np.ndarray:
    return np.einsum("tij,j->ti", transform[:, :3, :3], point) + transform[:, :3, 3]


def goal(chain: list[ChainJoint], angles: list[np.ndarray], base: np.ndarray, targets: IKTargets) -> np.ndarray:
    """E (eq. 2.3) per frame (T,): weighted squared position errors plus weighted E_o (eq. 2.5)."""
    transforms = chain_transforms(chain, angles, base)
    energy = np.zeros(len(base))
    for joint, rest_point, desired, weight in targets.points:
        energy += weight * np.sum((_apply(transforms[joint], rest_point) - desired) ** 2, axis=-1)
    if targets.orientation is not None:
        joint, desired, weight = targets.orientation
        current = transforms[joint][:, :3, :3]
        energy += weight * np.sum((np.sum(current * desired, axis=-2) - 1.0) ** 2, axis=-1)
    return energy


def solve_ccd(chain: list[ChainJoint], base: np.ndarray, targets: IKTargets,
              initial: list[np.ndarray] | None = None, max_passes: int = 30, tolerance: float = 1e-9) -> list[np.ndarray]:
    """CCD with clamped joint limits; returns the angles (list of (T, K) radians, one per joint).

    base: (T, 4, 4) world transform of the chain's parent; initial: starting angles (rest if None);
    passes stop when no frame's E improves by more than `tolerance` (m^2) or after max_passes.
    """
    n_frames = len(base)
    angles = [np.zeros((n_frames, len(j.axes))) if initial is None else np.clip(initial[i], j.lower, j.upper).copy()
              for i, j in enumerate(chain)]
    previous = goal(chain, angles, base, targets)
    for _ in range(max_passes):
        for j in range(len(chain) - 1, -1, -1):
            joint = chain[j]
            for k in range(len(joint.axes) - 1, -1, -1):
                _optimise_angle(chain, angles, base, targets, j, k)
        energy = goal(chain, angles, base, targets)
        if np.all(previous - energy <= tolerance):
            break
        previous = energy
    return angles


def _optimise_angle(chain, angles, base, targets, j: int, k: int) -> None:
    """One CCD step: the analytic optimum of angle k of joint j, clamped (in place)."""
    joint = chain[j]
    transforms = chain_transforms(chain, angles, base)
    parent = base if j == 0 else transforms[j - 1]
    pivot = _apply(parent, joint.pivot)
    # world axis of DOF k: parent rotation . R(a_1, q_1) ... R(a_{k-1}, q_{k-1}) . a_k
    frame = parent[:, :3, :3]
    if k:
        before = _axis_matrices(joint.axes[:k], angles[j][:, :k])
        for m in range(k):
            frame = frame @ before[:, m]
    axis = frame @ joint.axes[k]
    b_term = np.zeros(len(base))
    c_term = np.zeros(len(base))

    def accumulate(current: np.ndarray, desired: np.ndarray, weight: float) -> None:
        nonlocal b_term, c_term
        along_c = np.sum(axis * current, axis=-1)
        along_d = np.sum(axis * desired, axis=-1)
        b_term = b_term + weight * (np.sum(desired * current, axis=-1) - along_c * along_d)
        c_term = c_term + weight * np.sum(axis * rotations.cross(current, desired), axis=-1)

    for owner, rest_point, desired, weight in targets.points:
        if owner >= j:
            accumulate(_apply(transforms[owner], rest_point) - pivot, desired - pivot, weight)
    if targets.orientation is not None and targets.orientation[0] >= j:
        owner, desired, weight = targets.orientation
        current = transforms[owner][:, :3, :3]
        for column in range(3):
            accumulate(current[:, :, column], desired[:, :, column], weight)
    delta = np.arctan2(c_term, b_term)
    angles[j][:, k] = np.clip(angles[j][:, k] + delta, joint.lower[k], joint.upper[k])


def local_quaternions(chain: list[ChainJoint], angles: list[np.ndarray]) -> list[np.ndarray]:
    """Local rotations (T, 4) of every joint from its angles."""
    result = []
    for joint, q in zip(chain, angles):
        per_axis = rotations.from_axis_angle(np.broadcast_to(joint.axes, q.shape + (3,)), q)
        quaternion = per_axis[:, 0]
        for k in range(1, len(joint.axes)):
            quaternion = rotations.multiply(quaternion, per_axis[:, k])
        result.append(rotations.normalize(quaternion))
    return result

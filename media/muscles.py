"""The default avatar's muscles: a biceps and a forearm muscle (brachioradialis) on each arm.

Each is an SBMuscle (seed 000 §3.2.3, §3.3.2): a cubic NURBS curve lying inside the limb in the rest
pose, a tube radius and a falloff. Elbow flexion contracts it: the middle control points move
towards the skin (bulge_direction) and their weights grow, so the curve bulges, and eq. 3.6 moves
the skin inside the tube with it. Activation is 0 at the rest pose's elbow angle and 1 at
MAX_FLEXION_DEG of flexion.

The displacement is applied in the rest pose (the pose the muscles are bound in) before skinning:
the muscle's bone then carries the displaced skin, which is the curve-attached-to-bone reading of
§3.2.3.
"""
from __future__ import annotations

import numpy as np

from kernels.muscles import MuscleInfluence, bind, combine

MAX_FLEXION_DEG = 145.0

# name, (from bone head, to bone head), span along the segment, offset towards the front (m),
# tube radius (m), falloff code, max bulge (m), bone the curve is attached to
_DESIGNS = (
    ("biceps", ("upperarm01", "lowerarm01"), (0.12, 0.92), 0.020, 0.045, 2, 0.016, "upperarm02"),
    ("forearm", ("lowerarm01", "wrist"), (-0.02, 0.60), 0.012, 0.034, 2, 0.009, "lowerarm01"),
)
_PROFILE = np.array([0.0, 0.45, 1.0, 1.0, 0.45, 0.0])      # six control points, ends anchored
_BULGE_WEIGHT = 2.0


def _clamped_uniform_knots(n_control: int, degree: int) -> np.ndarray:
    inner = np.linspace(0.0, 1.0, n_control - degree + 1)
    return np.concatenate([np.zeros(degree), inner, np.ones(degree)])


def default_muscles(avatar) -> tuple:
    """Biceps and forearm muscles of both arms for an avatar with the MakeHuman default rig
    (bones upperarm01/02, lowerarm01, wrist .L/.R); () for a skeleton without them."""
    from media.avatar import Muscle
    skeleton = avatar.skeleton
    names = set(skeleton.names)
    muscles = []
    for side in ("L", "R"):
        arm = (f"upperarm01.{side}", f"lowerarm01.{side}", f"wrist.{side}")
        if not set(arm) <= names or f"upperarm02.{side}" not in names:
            return ()
        flexion_bones = tuple(skeleton.index(n) for n in arm)
        for name, (start, end), (t0, t1), offset, radius, falloff, bulge, bone in _DESIGNS:
            head = skeleton.heads[skeleton.index(f"{start}.{side}")]
            tail = skeleton.heads[skeleton.index(f"{end}.{side}")]
            axis = (tail - head) / np.linalg.norm(tail - head)
            front = np.array([0.0, 0.0, 1.0]) - axis[2] * axis     # the avatar faces +Z
            front /= np.linalg.norm(front)
            along = np.linspace(t0, t1, len(_PROFILE))
            control = head + np.outer(along, tail - head) + offset * front
            muscles.append(Muscle(
                name=f"{name}.{side}", bone=skeleton.index(f"{bone}.{side}"), control_points=control,
                weights=np.ones(len(_PROFILE)), knots=_clamped_uniform_knots(len(_PROFILE), 3), degree=3,
                radius=radius, falloff=falloff, driver_bone=skeleton.index(f"lowerarm01.{side}"), max_bulge=bulge,
                bulge_direction=front, bulge_profile=_PROFILE.copy(), bulge_weight=_BULGE_WEIGHT,
                flexion_bones=flexion_bones))
    return tuple(muscles)


def homogeneous_control_points(muscle, activation: float = 0.0) -> np.ndarray:
    """(K, 4) float32 control points (x, y, z, w) of a muscle contracted by activation in [0, 1]."""
    activation = float(np.clip(activation, 0.0, 1.0))
    profile = muscle.bulge_profile if muscle.bulge_profile is not None else np.zeros(len(muscle.weights))
    direction = muscle.bulge_direction if muscle.bulge_direction is not None else np.zeros(3)
    points = muscle.control_points + activation * muscle.max_bulge * np.outer(profile, direction)
    weights = muscle.weights * (1.0 + activation * (muscle.bulge_weight - 1.0) * profile)
    return np.column_stack([points, weights]).astype(np.float32)


def flexion_deg(joints: np.ndarray, flexion_bones: tuple[int, ...]) -> np.ndarray:
    """(T,) bend angle in degrees at the middle joint (0 = straight limb) from joint heads (T, B, 3)."""
    proximal, joint, distal = (joints[:, b] for b in flexion_bones)
    upper, lower = joint - proximal, distal - joint
    cosine = np.sum(upper * lower, axis=-1) / (np.linalg.norm(upper, axis=-1) * np.linalg.norm(lower, axis=-1))
    return np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0)))


def activations(skeleton, muscles, joints: np.ndarray) -> np.ndarray:
    """(T, M) contraction of each muscle in [0, 1] from posed joint heads (T, B, 3), metres."""
    result = np.zeros((len(joints), len(muscles)))
    for m, muscle in enumerate(muscles):
        if not muscle.flexion_bones:
            continue
        rest = flexion_deg(skeleton.heads[None], muscle.flexion_bones)[0]
        bend = flexion_deg(joints, muscle.flexion_bones)
        result[:, m] = np.clip((bend - rest) / max(MAX_FLEXION_DEG - rest, 1e-6), 0.0, 1.0)
    return result


_INFLUENCES: dict[int, tuple] = {}


def muscle_influence(avatar) -> MuscleInfluence:
    """The avatar's muscles bound to its rest-pose skin (computed once per avatar object)."""
    cached = _INFLUENCES.get(id(avatar))
    if cached is not None and cached[0] is avatar:
        return cached[1]
    bindings = [bind(avatar.vertices, homogeneous_control_points(m), m.knots, m.degree, m.radius, m.falloff)
                for m in avatar.muscles]
    influence = combine(bindings, [len(m.weights) for m in avatar.muscles], len(avatar.vertices))
    if len(_INFLUENCES) >= 4:
        _INFLUENCES.pop(next(iter(_INFLUENCES)))
    _INFLUENCES[id(avatar)] = (avatar, influence)
    return influence


def stacked_control_points(muscles, activation: np.ndarray) -> np.ndarray:
    """(C, 4) float32 control points of all muscles, stacked, at per-muscle activation (M,)."""
    if not muscles:
        return np.zeros((0, 4), np.float32)
    return np.concatenate([homogeneous_control_points(m, a) for m, a in zip(muscles, activation)])

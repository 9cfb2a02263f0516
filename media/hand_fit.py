"""The arm and hand's joint angles fitted to landmarks: one bounded least-squares problem per frame.

`ArmHandModel(skeleton, side)` is the avatar's arm (upperarm01 with 3 DOF, the elbow hinge lowerarm01, the forearm
twist lowerarm02, the wrist's flexion and deviation) and hand (each finger's knuckle: flexion then spread, no twist;
PIP and DIP: hinges; the thumb's base: flexion, abduction and its own twist (opposition); the thumb's MCP and IP:
hinges), every DOF a rotation about one of the joint's anatomical axes (media.retarget.joint_axes) through its rest
pivot, bounded by the anatomical limits (media.retarget's FINGER_LIMITS, THUMB_LIMITS, THUMB_TWIST_MAX, the arm
chain's limits). Metacarpals stay at rest. The parameterisation is the one media.retarget's local rotations and
the MPEG-4 BAP mapping use, so a fitted angle is one BAP.

`fit_clip` solves, frame by frame, warm-started from the previous frame's angles,

    min_theta  sum_s w_s^2 |r_s(theta)|^2  +  w_t^2 |theta - theta_prev|^2  +  w_0^2 |theta|^2  +  crossing penalty
    subject to lower <= theta <= upper                                        (scipy.optimize.least_squares, TRF)

where each segment s is a pair of landmarks (shoulder -> elbow, elbow -> wrist, wrist -> each knuckle and the thumb's
base, index knuckle -> little knuckle, and every phalanx) and r_s compares the model's segment direction with the
landmarks':
- 3D (world landmarks exist: the hand model's 21 world points, the pose's world points): r_s = u_s(theta) - t_s,
  both unit vectors, so the fit does not depend on the signer's bone lengths;
- 2D (image landmarks only, e.g. the lexicon, whose depth is flat): r_s = P u_s(theta) - t_s / l_s, the model's
  unit direction projected orthographically on the frontal plane against the segment's image vector over its true
  length (the signer's), so a segment whose image is shorter than its length must leave the plane, and the joint
  limits, not a per-bone sign prior, decide towards which side.
The temporal term (w_t) keeps the solution on the branch of the previous frame; the prior (w_0, tiny) holds a DOF the
landmarks do not determine at rest; the crossing penalty keeps neighbouring fingers' spreads from crossing. Residuals
and the Jacobian are analytic and vectorised (the geometric Jacobian: d p / d theta_k = a_k x (p - c_k) for points
below DOF k, a_k its world axis, c_k its pivot).

Units: angles radians; positions metres in the avatar's world (X the avatar's left, Y up, Z towards the viewer).
MediaPipe's world landmarks (x right, y down, z away from the camera) map to it by `from_mediapipe_world`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from media import rotations

# (bone, head landmark, tail landmark) per finger, proximal first (media.retarget.FINGER_CHAINS)
FINGERS = {
    "thumb": (("finger1-1", 1, 2), ("finger1-2", 2, 3), ("finger1-3", 3, 4)),
    "index": (("finger2-1", 5, 6), ("finger2-2", 6, 7), ("finger2-3", 7, 8)),
    "middle": (("finger3-1", 9, 10), ("finger3-2", 10, 11), ("finger3-3", 11, 12)),
    "ring": (("finger4-1", 13, 14), ("finger4-2", 14, 15), ("finger4-3", 15, 16)),
    "little": (("finger5-1", 17, 18), ("finger5-2", 18, 19), ("finger5-3", 19, 20)),
}
ARM_JOINTS = ("upperarm01", "lowerarm01", "lowerarm02", "wrist")
# model points: 0 shoulder, 1 elbow, 2.. the 21 hand landmarks (2 + MediaPipe's index)
SHOULDER, ELBOW, HAND0 = 0, 1, 2
ARM_SEGMENTS = ((SHOULDER, ELBOW), (ELBOW, HAND0))
PALM_SEGMENTS = ((0, 1), (0, 5), (0, 9), (0, 13), (0, 17), (5, 17))          # hand landmark indices
PHALANX_SEGMENTS = tuple((head, tail) for chain in FINGERS.values() for _, head, tail in chain)
HAND_SEGMENTS = PALM_SEGMENTS + PHALANX_SEGMENTS

# weights (per unit of direction error, i.e. per radian for small errors)
ARM_WEIGHT = 1.0
PALM_WEIGHT = 2.0
PHALANX_WEIGHT = 1.0
TEMPORAL_WEIGHT = 0.15       # per radian of change from the previous frame
PRIOR_WEIGHT = 0.02          # per radian away from the rest angle
CROSSING_WEIGHT = 3.0        # per radian of neighbouring fingers' spreads crossing
CROSSING_MARGIN = np.radians(2.0)
# a frame whose warm-started cost exceeds RESTART_COST is also solved from these starts; the best is kept
RESTART_COST = 0.05
CURLED_START = 45.0          # degrees of flexion at every finger joint in the curled starts


def from_mediapipe_world(points: np.ndarray) -> np.ndarray:
    """MediaPipe world points (..., 3) (x right, y down, z away from the camera; metres) -> the avatar's world axes
    (X right in the image = the avatar's left, Y up, Z towards the viewer): (x, -y, -z)."""
    points = np.asarray(points, dtype=np.float64)
    return points * np.array([1.0, -1.0, -1.0])


@dataclass(frozen=True)
class Joint:
    """One joint: name (side-suffixed bone), parent (index into the model's joints, -1: the arm's base), pivot (3,)
    rest position, axes (K, 3) unit rest-world axes applied in order (R = R(a_1, q_1) ... R(a_K, q_K)), lower and
    upper (K,) radians."""
    name: str
    parent: int
    pivot: np.ndarray
    axes: np.ndarray
    lower: np.ndarray
    upper: np.ndarray


class ArmHandModel:
    """The arm and hand of side 'L' or 'R' as a kinematic tree with bounded DOFs (module docstring).

    joints: Joint list, parents first; n_dofs; lower, upper: (n_dofs,) bounds; points: (23, 3) rest positions of
    the model points (shoulder, elbow, the 21 hand landmarks); point_owner: (23,) joint carrying each point (-1:
    the base); lengths: (23, 23)-indexed rest lengths via `segment_length`.
    """

    def __init__(self, skeleton, side: str):
        from media import retarget   # the anatomical axes and limits live there

        self.side = side
        head = lambda bone: skeleton.heads[skeleton.index(f"{bone}.{side}")]
        tail = lambda bone: skeleton.tails[skeleton.index(f"{bone}.{side}")]
        joints: list[Joint] = []
        for chain_joint in retarget._arm_chain(skeleton, side):
            joints.append(Joint(chain_joint.name, len(joints) - 1, np.asarray(chain_joint.pivot, np.float64),
                                np.asarray(chain_joint.axes, np.float64), np.asarray(chain_joint.lower, np.float64),
                                np.asarray(chain_joint.upper, np.float64)))
        wrist = len(joints) - 1
        owner_of_landmark = {0: wrist}
        point_rest = {0: head("wrist")}
        self.finger_joints: dict[str, list[int]] = {}
        for finger, chain in FINGERS.items():
            parent = wrist
            table = retarget.THUMB_LIMITS if finger == "thumb" else retarget.FINGER_LIMITS
            self.finger_joints[finger] = []
            for level, (bone, head_lm, tail_lm) in enumerate(chain, start=1):
                name = f"{bone}.{side}"
                flexion_axis, long_axis, abduction_axis = retarget.joint_axes(skeleton, name)
                (flex_lo, flex_hi), (abd_lo, abd_hi) = np.radians(table[level])
                axes, lower, upper = [flexion_axis], [flex_lo], [flex_hi]
                if abd_lo != abd_hi:                       # R(F, flexion) R(A, -abduction): axis -A, angle abduction
                    axes.append(-abduction_axis)
                    lower.append(abd_lo)
                    upper.append(abd_hi)
                if finger == "thumb" and level == 1:       # the base's own twist (opposition), after both
                    twist = np.radians(retarget.THUMB_TWIST_MAX)
                    axes.append(long_axis)
                    lower.append(-twist)
                    upper.append(twist)
                owner_of_landmark.setdefault(head_lm, parent)
                point_rest.setdefault(head_lm, head(bone))
                joints.append(Joint(name, parent, head(bone), np.array(axes), np.array(lower), np.array(upper)))
                parent = len(joints) - 1
                self.finger_joints[finger].append(parent)
            owner_of_landmark[chain[-1][2]] = parent
            point_rest[chain[-1][2]] = tail(chain[-1][0])
        self.joints = joints
        self.dof_joint = np.concatenate([np.full(len(j.axes), i) for i, j in enumerate(joints)])
        self.dof_start = np.cumsum([0] + [len(j.axes) for j in joints])
        self.n_dofs = int(self.dof_start[-1])
        self.lower = np.concatenate([j.lower for j in joints])
        self.upper = np.concatenate([j.upper for j in joints])
        self.axes = np.concatenate([j.axes for j in joints])              # (D, 3) rest axes
        self.points = np.concatenate([[head("upperarm01"), head("lowerarm01")],
                                      [point_rest[k] for k in range(21)]])
        self.point_owner = np.array([-1, 0] + [owner_of_landmark[k] for k in range(21)])
        # below[d, p]: DOF d moves point p (its joint is the point's owner or an ancestor of it)
        ancestors = []
        for i, joint in enumerate(joints):
            chain = {i}
            parent = joint.parent
            while parent >= 0:
                chain.add(parent)
                parent = joints[parent].parent
            ancestors.append(chain)
        self.below = np.array([[owner >= 0 and self.dof_joint[d] in ancestors[owner] for owner in self.point_owner]
                               for d in range(self.n_dofs)])
        self.rest = np.clip(np.zeros(self.n_dofs), self.lower, self.upper)
        self._crossing = self._crossing_pairs()

    # ------------------------------------------------------------------ kinematics

    def dof_slice(self, joint_name: str) -> slice:
        """The DOFs of one joint (side-suffixed bone name) in the parameter vector."""
        i = [j.name for j in self.joints].index(joint_name)
        return slice(int(self.dof_start[i]), int(self.dof_start[i + 1]))

    def forward(self, theta: np.ndarray, base_rotation: np.ndarray, base_translation: np.ndarray):
        """Posed model points (23, 3), world DOF axes (D, 3) and DOF pivots (D, 3) for angles theta (D,), the arm's
        base (shoulder01's world transform: rotation (3, 3), translation (3,))."""
        per_dof = _axis_matrices(self.axes, theta)                       # (D, 3, 3)
        rot = np.empty((len(self.joints), 3, 3))
        trans = np.empty((len(self.joints), 3))
        world_axes = np.empty((self.n_dofs, 3))
        pivots = np.empty((self.n_dofs, 3))
        for i, joint in enumerate(self.joints):
            if joint.parent < 0:
                parent_rot, parent_trans = base_rotation, base_translation
            else:
                parent_rot, parent_trans = rot[joint.parent], trans[joint.parent]
            centre = parent_rot @ joint.pivot + parent_trans
            frame = parent_rot
            for d in range(self.dof_start[i], self.dof_start[i + 1]):
                world_axes[d] = frame @ self.axes[d]
                pivots[d] = centre
                frame = frame @ per_dof[d]
            rot[i] = frame
            trans[i] = centre - frame @ joint.pivot
        owners = self.point_owner
        points = np.empty((len(owners), 3))
        carried = owners >= 0
        points[carried] = np.einsum("pij,pj->pi", rot[owners[carried]], self.points[carried]) + trans[owners[carried]]
        points[~carried] = self.points[~carried] @ base_rotation.T + base_translation
        return points, world_axes, pivots

    def point_jacobian(self, points: np.ndarray, world_axes: np.ndarray, pivots: np.ndarray) -> np.ndarray:
        """(23, 3, D): d point / d theta_d = a_d x (p - c_d) where DOF d moves the point, else 0."""
        lever = points[None, :, :] - pivots[:, None, :]                  # (D, P, 3)
        jac = np.cross(world_axes[:, None, :], lever) * self.below[..., None]
        return np.transpose(jac, (1, 2, 0))

    def local_quaternions(self, theta: np.ndarray) -> dict[str, np.ndarray]:
        """Joint name -> local rotation (..., 4) for angles theta (..., D) (a product of one turn per DOF)."""
        theta = np.asarray(theta, dtype=np.float64)
        result = {}
        for i, joint in enumerate(self.joints):
            start, stop = self.dof_start[i], self.dof_start[i + 1]
            q = None
            for d in range(start, stop):
                turn = rotations.from_axis_angle(np.broadcast_to(self.axes[d], theta.shape[:-1] + (3,)), theta[..., d])
                q = turn if q is None else rotations.multiply(q, turn)
            result[joint.name] = rotations.normalize(q)
        return result

    # ------------------------------------------------------------------ constraints

    def _crossing_pairs(self) -> list[tuple[int, int, float, float, float]]:
        """Neighbouring fingers (index-middle, middle-ring, ring-little): (spread DOF a, spread DOF b, s_a, s_b, gap)
        with s the sign of a spread that moves the finger towards its neighbour (in the palm's plane) and gap the
        rest angle between them: the fingers cross where s_a q_a - s_b q_b > gap."""
        pairs = []
        order = ("index", "middle", "ring", "little")
        for a, b in zip(order[:-1], order[1:]):
            ja, jb = self.finger_joints[a][0], self.finger_joints[b][0]
            da, db = int(self.dof_start[ja]) + 1, int(self.dof_start[jb]) + 1        # the spread DOFs
            knuckle_a, knuckle_b = self.joints[ja].pivot, self.joints[jb].pivot
            dir_a = self.points[HAND0 + FINGERS[a][0][2]] - knuckle_a
            dir_b = self.points[HAND0 + FINGERS[b][0][2]] - knuckle_b
            across = knuckle_b - knuckle_a
            normal = np.cross(dir_a + dir_b, across)
            normal /= np.linalg.norm(normal)
            towards = across - (across @ normal) * normal
            s_a = float(np.sign(np.cross(self.axes[da], dir_a) @ towards))
            s_b = float(np.sign(np.cross(self.axes[db], dir_b) @ towards))
            flat_a = dir_a - (dir_a @ normal) * normal
            flat_b = dir_b - (dir_b @ normal) * normal
            gap = float(np.arctan2(np.cross(flat_a, flat_b) @ normal, flat_a @ flat_b))
            gap = abs(gap) if s_a > 0 else abs(gap)
            pairs.append((da, db, s_a, s_b, abs(gap)))
        return pairs

    def crossing(self, theta: np.ndarray) -> np.ndarray:
        """(3,) radians by which neighbouring fingers' spreads cross (0 where they do not)."""
        return np.array([max(0.0, s_a * theta[a] - s_b * theta[b] - gap - CROSSING_MARGIN)
                         for a, b, s_a, s_b, gap in self._crossing])


def _axis_matrices(axes: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """(D, 3, 3) rotations about unit axes (D, 3) by angles (D,) (Rodrigues)."""
    x, y, z = axes[:, 0], axes[:, 1], axes[:, 2]
    c, s = np.cos(angles), np.sin(angles)
    t = 1.0 - c
    return np.stack([np.stack([c + t * x * x, t * x * y - s * z, t * x * z + s * y], -1),
                     np.stack([t * x * y + s * z, c + t * y * y, t * y * z - s * x], -1),
                     np.stack([t * x * z - s * y, t * y * z + s * x, c + t * z * z], -1)], axis=1)


@dataclass
class Targets:
    """One clip's targets for one side, per segment (ARM_SEGMENTS then HAND_SEGMENTS, S = 2 + 21):
    world (T, S, 3) unit directions in the avatar's axes, NaN where not known; image (T, S, 2) frontal-plane vectors
    over the segment's true length (dimensionless; NaN where not known), used where world is NaN."""
    world: np.ndarray
    image: np.ndarray


SEGMENTS = tuple(ARM_SEGMENTS) + tuple((HAND0 + a, HAND0 + b) for a, b in HAND_SEGMENTS)
SEGMENT_WEIGHTS = np.array([ARM_WEIGHT] * len(ARM_SEGMENTS) + [PALM_WEIGHT] * len(PALM_SEGMENTS)
                           + [PHALANX_WEIGHT] * len(PHALANX_SEGMENTS))


class _Problem:
    """Residuals and Jacobian of one frame (module docstring), evaluated once per parameter vector."""

    def __init__(self, model: ArmHandModel, base_rotation, base_translation, world, image, previous):
        self.model = model
        self.temporal = 0.0 if previous is None else TEMPORAL_WEIGHT
        previous = model.rest if previous is None else previous
        self.base = (base_rotation, base_translation)
        self.use_world = np.all(np.isfinite(world), axis=-1)
        self.use_image = ~self.use_world & np.all(np.isfinite(image), axis=-1)
        self.world = np.where(self.use_world[:, None], world, 0.0)
        self.image = np.where(self.use_image[:, None], image, 0.0)
        self.weights = SEGMENT_WEIGHTS * (self.use_world | self.use_image)
        self.previous = previous
        self.heads = np.array([a for a, _ in SEGMENTS])
        self.tails = np.array([b for _, b in SEGMENTS])
        self._cache_x = None

    def _evaluate(self, theta):
        if self._cache_x is not None and np.array_equal(theta, self._cache_x):
            return self._cache
        model = self.model
        points, axes, pivots = model.forward(theta, *self.base)
        vectors = points[self.tails] - points[self.heads]                 # (S, 3)
        norms = np.linalg.norm(vectors, axis=-1)
        units = vectors / norms[:, None]
        direction_error = np.where(self.use_world[:, None], units - self.world, 0.0)
        image_error = np.where(self.use_image[:, None], units[:, :2] - self.image, 0.0)
        segment_residuals = np.concatenate([direction_error, image_error], axis=1) * self.weights[:, None]   # (S, 5)
        point_jac = model.point_jacobian(points, axes, pivots)             # (P, 3, D)
        vector_jac = point_jac[self.tails] - point_jac[self.heads]         # (S, 3, D)
        projector = (np.eye(3)[None] - units[:, :, None] * units[:, None, :]) / norms[:, None, None]
        unit_jac = projector @ vector_jac                                  # (S, 3, D)
        segment_jac = np.concatenate([unit_jac * self.use_world[:, None, None],
                                      unit_jac[:, :2] * self.use_image[:, None, None]], axis=1) \
            * self.weights[:, None, None]
        n = model.n_dofs
        crossing = model.crossing(theta)
        crossing_jac = np.zeros((len(crossing), n))
        for row, ((a, b, s_a, s_b, _), value) in enumerate(zip(model._crossing, crossing)):
            if value > 0:
                crossing_jac[row, a], crossing_jac[row, b] = s_a, -s_b
        residuals = np.concatenate([segment_residuals.ravel(), self.temporal * (theta - self.previous),
                                    PRIOR_WEIGHT * (theta - model.rest), CROSSING_WEIGHT * crossing])
        jacobian = np.concatenate([segment_jac.reshape(-1, n), self.temporal * np.eye(n), PRIOR_WEIGHT * np.eye(n),
                                   CROSSING_WEIGHT * crossing_jac])
        self._cache_x, self._cache = theta.copy(), (residuals, jacobian)
        return residuals, jacobian

    def residuals(self, theta):
        return self._evaluate(theta)[0]

    def jacobian(self, theta):
        return self._evaluate(theta)[1]


def solve_frame(model: ArmHandModel, base_rotation: np.ndarray, base_translation: np.ndarray, world: np.ndarray,
                image: np.ndarray, start: np.ndarray, previous: np.ndarray | None = None,
                max_nfev: int = 60) -> tuple[np.ndarray, float]:
    """One frame's angles (D,) radians within the model's bounds, and the cost (half the squared residual sum).

    world (S, 3), image (S, 2): the frame's targets (Targets); start: the initial angles; previous: the angles the
    temporal term pulls towards (None: no temporal term, the first frame)."""
    problem = _Problem(model, base_rotation, base_translation, world, image, previous)
    x0 = np.clip(start, model.lower + 1e-9, model.upper - 1e-9)
    result = least_squares(problem.residuals, x0, jac=problem.jacobian, bounds=(model.lower, model.upper),
                           method="trf", max_nfev=max_nfev, xtol=1e-6, ftol=1e-6, gtol=1e-8)
    return result.x, float(result.cost)


def fit_clip(model: ArmHandModel, base_rotations: np.ndarray, base_translations: np.ndarray, targets: Targets,
             starts: list[np.ndarray] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Angles (T, D) radians and per-frame costs (T,) for a clip, frame by frame, each frame warm-started from the
    previous one's angles (the first frame, and any frame whose cost exceeds RESTART_COST, also from `starts`, by
    default the rest and a forward-reaching arm; the lowest cost wins).

    base_rotations (T, 3, 3), base_translations (T, 3): shoulder01's world transform per frame."""
    n_frames = len(base_rotations)
    starts = starts if starts is not None else default_starts(model)
    angles = np.empty((n_frames, model.n_dofs))
    costs = np.empty(n_frames)
    previous = None
    for t in range(n_frames):
        args = (model, base_rotations[t], base_translations[t], targets.world[t], targets.image[t])
        if previous is None:
            candidates = [solve_frame(*args, start) for start in starts]
        else:
            candidates = [solve_frame(*args, previous, previous)]
            if candidates[0][1] > RESTART_COST:
                candidates += [solve_frame(*args, start, previous) for start in starts]
        angles[t], costs[t] = min(candidates, key=lambda pair: pair[1])
        previous = angles[t]
    return angles, costs


def default_starts(model: ArmHandModel) -> list[np.ndarray]:
    """Starting angles for a frame solved afresh: the rest (the rig's A-pose, fingers straight), the arm raised
    forward with the elbow bent (the signing space), the same with the palm turned back."""
    rest = model.rest.copy()
    forward = rest.copy()
    upper, elbow, twist = (model.dof_slice(f"{bone}.{model.side}") for bone in ("upperarm01", "lowerarm01", "lowerarm02"))
    forward[upper.start] = -np.radians(60.0)          # flex the shoulder forward
    forward[elbow.start] = np.radians(45.0)
    turned = forward.copy()
    turned[twist.start] = np.radians(60.0 if model.side == "R" else -60.0)
    starts = [rest, forward, turned]
    for arm in (forward, turned):
        curled = arm.copy()
        for joints in model.finger_joints.values():
            for joint in joints:
                curled[model.dof_start[joint]] = np.radians(CURLED_START)
        starts.append(curled)
    return [np.clip(s, model.lower, model.upper) for s in starts]

"""The face rig: MPEG-4 FAPs -> local rotations of the avatar's face bones (MakeHuman default rig).

FAP values are in the FAPU of the face they were measured on (comparisons/params/fap_table.py); they play
on this avatar in its own FAPU, measured on its rest mesh (`avatar_fapu`). A displacement of d metres
is value * FAPU in the FAP's positive direction; "left" is the avatar's own left (+X), up is +Y,
forward +Z. Bones turn about their heads (media/avatar.py), so every displacement is made by turns:

- Turned bones. open_jaw and shift_jaw turn the jaw about its head so that its tail (the chin, FP 2.1)
  moves by d along the displacement: the axis is perpendicular to (tail - head) and the displacement,
  and the angle is solved exactly for the tail's component along it (the chin also swings back, as a
  jaw does). The eyelids turn the same way about the eye centre (orbicularis03 upper, 04 lower, heads at
  the eye centre). Their control points are the lid margins, taken on the lid bones' axes (whose tails
  point through the margins of the open eye) at the radius where the two margins are IRISD0 apart, so
  close_t_*_eyelid = 1024 brings the upper margin down onto the lower one. The eyeballs turn by the FAP
  angles themselves (1e-5 rad): yaw about +Y (positive looks to the avatar's left), then pitch about +X
  (positive looks down).
- Carried bones. The lips (oris05 upper middle, oris03 upper sides, oris01 lower middle, oris07 lower
  sides), the mouth corners (levator05), the cheeks (risorius03), the nose wings (levator06) and the
  brows (oculi01) are skinned to short bones that point along the lip or brow, so their own turn cannot
  move them along most FAP directions (the upper-lip bone points down: turning it cannot lower the lip).
  Their unskinned ancestors carry them: special01 (with oris04, oris06) the upper lip, special04 (with
  oris02, oris06.L/R) the lower lip, levator02..04 each corner, temporalis02 and risorius02 each cheek,
  special03 the nose, temporalis01 and oculi02 each brow. The carriers turn so that every skinned bone's
  head moves by its displacement (damped least squares with the smallest turns, iterated on the exact
  kinematics; a target beyond the chain's reach ends at the nearest reachable point), then the skinned
  bone turns so that its tail moves by its own displacement: a translation when both are equal, which
  is how the lips, corners and cheeks move. A brow's bone runs from the middle of the brow to its inner
  end, so its head takes the middle brow FAP and its tail the inner one; a nose wing's tail adds the
  wing's stretch to the nose's lift.
- Inner and outer lip FAPs (groups 2 and 8) drive the same bones: each lip point takes the mean of its
  inner and outer value. The lower lip hangs from the jaw and moves in the jaw's frame: its FAPs add to
  the jaw's opening. The corners hang from the head. A lip's side follows its corner's raise by the
  share of the way it sits from the middle to the corner (a lip is held at the middle and pulled at the
  corner); not its stretch, which would fold the skin near the middle over itself. A lip's middle and
  sides share one vertical carrier, so a middle that rises alone rises only in part.
- Skin blends bones: a vertex weighted half to a face bone and half to the head moves half as far as
  the bone. The FAP displacements are met by the bones (at their heads and tails); the skin near a
  bone follows by its weight (about 0.8 at the chin and the lip middles, 0.5 at the corners,
  0.4..0.85 across the brows).

Not applied: head rotation (FAPs 48..50: the neck and head bones carry it as BAPs), thrust_jaw and
depress_chin (a turning jaw cannot slide forward), the outer brows (the brow skin follows one bone,
whose ends are the inner and middle brow points), eyeball thrust and pupil size, bend_nose, the tongue
and the ears (no skin weights on those bones).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from media import face_rig_solve as face_kernel
from media import face_bones as bones_kernel
from media import rotations
from media.avatar import Avatar, Skeleton, load_avatar
from media.errors import SigncastError
from media.motion import N_FAPS, Motion

FAPU_DIVISOR = 1024
ANGLE_UNIT_RAD = 1e-5

# The carry solve (`_carry`): at most CARRY_ITERATIONS damped Gauss-Newton iterations per frame, damping in metres,
# no carrier turning more than CARRY_MAX_TURN radians a step, and a frame stops after the iteration whose largest
# carrier turn is below CARRY_TOLERANCE radians (most frames of real letters after 6-8 iterations). Stated face
# error against the full solve (FULL_SOLVE: every frame all 10 iterations, what the rig did before), tested on real
# letters of four sign languages, synthetic tracks and FAPs beyond reach (tests/test_face_rig.py): every face bone's
# turn within FACE_TURN_ERROR_RAD (measured 4e-5 rad), the skinned bones' posed heads, which the skin follows,
# within FACE_HEAD_ERROR_M (measured 2.5e-7 m) and their posed rotations equal to rounding (they come from the
# targets alone, `bone_turns`). A smaller damping converges in fewer iterations but, far from the rig's reach, to
# other least-squares points (0.7 mm off on synthetic FAPs), so the damping stays.
CARRY_ITERATIONS, CARRY_DAMPING, CARRY_MAX_TURN, CARRY_TOLERANCE = 10, 3e-3, 0.3, 1e-4
FULL_SOLVE = {"iterations": 10, "damping": 3e-3, "max_turn": 0.3, "tolerance": 0.0}
FACE_HEAD_ERROR_M, FACE_TURN_ERROR_RAD = 1e-6, 1e-4

# The FAPs this rig plays: MPEG-4 name -> id (comparisons/params/fap_table.py; index in Motion.faps = id - 1).
FAP_IDS = {
    "open_jaw": 3, "lower_t_midlip": 4, "raise_b_midlip": 5, "stretch_l_cornerlip": 6, "stretch_r_cornerlip": 7,
    "lower_t_lip_lm": 8, "lower_t_lip_rm": 9, "raise_b_lip_lm": 10, "raise_b_lip_rm": 11,
    "raise_l_cornerlip": 12, "raise_r_cornerlip": 13, "shift_jaw": 15, "push_b_lip": 16, "push_t_lip": 17,
    "close_t_l_eyelid": 19, "close_t_r_eyelid": 20, "close_b_l_eyelid": 21, "close_b_r_eyelid": 22,
    "yaw_l_eyeball": 23, "yaw_r_eyeball": 24, "pitch_l_eyeball": 25, "pitch_r_eyeball": 26,
    "raise_l_i_eyebrow": 31, "raise_r_i_eyebrow": 32, "raise_l_m_eyebrow": 33, "raise_r_m_eyebrow": 34,
    "squeeze_l_eyebrow": 37, "squeeze_r_eyebrow": 38,
    "puff_l_cheek": 39, "puff_r_cheek": 40, "lift_l_cheek": 41, "lift_r_cheek": 42,
    "lower_t_midlip_o": 51, "raise_b_midlip_o": 52, "stretch_l_cornerlip_o": 53, "stretch_r_cornerlip_o": 54,
    "lower_t_lip_lm_o": 55, "lower_t_lip_rm_o": 56, "raise_b_lip_lm_o": 57, "raise_b_lip_rm_o": 58,
    "raise_l_cornerlip_o": 59, "raise_r_cornerlip_o": 60,
    "stretch_l_nose": 61, "stretch_r_nose": 62, "raise_nose": 63,
}
# Played by the body (BAPs on the neck and head bones), never by the face rig.
HEAD_ROTATION_FAP_IDS = {"head_pitch": 48, "head_yaw": 49, "head_roll": 50}

MOUTH_BONES = ("oris01", "oris03.L", "oris03.R", "oris05", "oris07.L", "oris07.R", "levator05.L", "levator05.R")
UPPER_LIP_BONE, LOWER_LIP_BONE = "oris05", "oris01"
SIDES = {"L": "l", "R": "r"}     # bone suffix -> MPEG-4 side letter
OUTWARD = {"L": 1.0, "R": -1.0}  # +X is the avatar's left


@dataclass(frozen=True)
class Fapu:
    """The avatar's face animation parameter units, metres per FAP unit (a neutral-face distance / 1024).

    irisd: upper to lower eyelid margin of the open eye at the pupil; es: between the pupils;
    ens: the pupils' height above the nose tip; mns: the nose tip's height above the lips' meeting
    line at the midline; mw: mouth corner to mouth corner.
    """
    irisd: float
    es: float
    ens: float
    mns: float
    mw: float


def face_landmarks(avatar: Avatar | None = None) -> dict[str, np.ndarray]:
    """The neutral face's feature points on the rest mesh, (3,) metres each.

    pupil.L / pupil.R: the front of each eyeball (its mesh's centre, moved forward by its radius).
    upper_lid.* / lower_lid.*: the lid margins above and below the pupil: of the vertices the lid bone
    (orbicularis03 upper, 04 lower) dominates within 2.5 mm of the pupil's x, outside the eyeball and in
    front of its centre, the lowest (upper lid) or highest (lower lid).
    nose_tip: the most forward vertex within 3 mm of the midline between the chin and the eyes.
    mouth_middle: halfway between the lowest midline vertex of the upper lip (dominated by oris05) and the
    highest of the lower lip (oris01), of those less than 1 cm behind the upper-lip bone's head (the
    lips, not the mouth's inside).
    mouth_corner.L / .R: the outermost lip-contact vertices: dominated by a lip or corner bone, within
    4 mm of the mouth middle's height, with a vertical normal (|n_y| > 0.85: the faces the lips press
    together).
    """
    avatar = avatar or load_avatar()
    sk, vertices = avatar.skeleton, avatar.vertices.astype(np.float64)
    dominant = avatar.weights.dominant_bone()
    names = set(sk.names)
    needed = {"jaw", UPPER_LIP_BONE, LOWER_LIP_BONE, *MOUTH_BONES} | {f"orbicularis0{k}.{s}" for k in (3, 4) for s in SIDES}
    if not needed <= names or not {"left_eye", "right_eye"} <= set(avatar.shape_names):
        raise SigncastError(f"avatar {avatar.name!r} has no MakeHuman face rig (eyes, lids, jaw and lip bones)")
    points = {}
    for side, shape_name in (("L", "left_eye"), ("R", "right_eye")):
        eye = np.unique(avatar.triangles[avatar.triangle_shape == avatar.shape_names.index(shape_name)])
        centre = vertices[eye].mean(axis=0)
        radius = np.linalg.norm(vertices[eye] - centre, axis=1).max()
        pupil = centre + np.array([0.0, 0.0, radius])
        near = ((np.abs(vertices[:, 0] - pupil[0]) < 0.0025) & (vertices[:, 2] > centre[2])
                & (np.linalg.norm(vertices - centre, axis=1) > radius))
        upper = near & (dominant == sk.index(f"orbicularis03.{side}"))
        lower = near & (dominant == sk.index(f"orbicularis04.{side}"))
        if not (upper.any() and lower.any()):
            raise SigncastError(f"avatar {avatar.name!r}: no eyelid margin found at the {shape_name}")
        points[f"pupil.{side}"] = pupil
        points[f"upper_lid.{side}"] = vertices[np.flatnonzero(upper)[np.argmin(vertices[upper, 1])]]
        points[f"lower_lid.{side}"] = vertices[np.flatnonzero(lower)[np.argmax(vertices[lower, 1])]]
    eye_height = (points["pupil.L"][1] + points["pupil.R"][1]) / 2
    chin_height = sk.tails[sk.index("jaw"), 1]
    midline = np.abs(vertices[:, 0]) < 0.003
    face_front = midline & (vertices[:, 1] > chin_height) & (vertices[:, 1] < eye_height)
    points["nose_tip"] = vertices[np.flatnonzero(face_front)[np.argmax(vertices[face_front, 2])]]
    on_midline = np.abs(vertices[:, 0]) < 1e-4
    lip_front = vertices[:, 2] > sk.heads[sk.index(UPPER_LIP_BONE), 2] - 0.01
    upper_lip = on_midline & lip_front & (dominant == sk.index(UPPER_LIP_BONE))
    lower_lip = on_midline & lip_front & (dominant == sk.index(LOWER_LIP_BONE))
    upper_lip_bottom = vertices[np.flatnonzero(upper_lip)[np.argmin(vertices[upper_lip, 1])]]
    lower_lip_top = vertices[np.flatnonzero(lower_lip)[np.argmax(vertices[lower_lip, 1])]]
    points["mouth_middle"] = (upper_lip_bottom + lower_lip_top) / 2
    normals = _vertex_normals(vertices, avatar.triangles)
    contact = (np.isin(dominant, [sk.index(n) for n in MOUTH_BONES])
               & (np.abs(vertices[:, 1] - points["mouth_middle"][1]) < 0.004) & (np.abs(normals[:, 1]) > 0.85))
    if not contact.any():
        raise SigncastError(f"avatar {avatar.name!r}: no lip contact found")
    points["mouth_corner.L"] = vertices[np.flatnonzero(contact)[np.argmax(vertices[contact, 0])]]
    points["mouth_corner.R"] = vertices[np.flatnonzero(contact)[np.argmin(vertices[contact, 0])]]
    return points


_FAPU: dict[int, tuple[Avatar, Fapu]] = {}      # id(avatar) -> (avatar, its FAPU): measured once per avatar


def avatar_fapu(avatar: Avatar | None = None) -> Fapu:
    """The avatar's FAPU (metres per unit) measured at its feature points (`face_landmarks`):
    IRISD0 the lid aperture at the pupil (both eyes' mean), ES0 the pupils' x distance, ENS0 the pupils'
    height above the nose tip, MNS0 the nose tip's height above the mouth middle, MW0 the corners' distance.
    Measured once per avatar object (the rest mesh does not change)."""
    avatar = avatar or load_avatar()
    cached = _FAPU.get(id(avatar))
    if cached is not None and cached[0] is avatar:
        return cached[1]
    p = face_landmarks(avatar)
    irisd = np.mean([p[f"upper_lid.{s}"][1] - p[f"lower_lid.{s}"][1] for s in SIDES])
    es = abs(p["pupil.L"][0] - p["pupil.R"][0])
    ens = (p["pupil.L"][1] + p["pupil.R"][1]) / 2 - p["nose_tip"][1]
    mns = p["nose_tip"][1] - p["mouth_middle"][1]
    mw = float(_length(p["mouth_corner.L"] - p["mouth_corner.R"]))
    fapu = Fapu(*(float(distance) / FAPU_DIVISOR for distance in (irisd, es, ens, mns, mw)))
    _FAPU[id(avatar)] = (avatar, fapu)
    return fapu


def face_bone_names(avatar: Avatar | None = None) -> tuple[str, ...]:
    """The names of the bones the face rig turns on this avatar (default: the vendored one): the jaw, lids and
    eyes, the carriers and the skinned lip, cheek, brow and nose bones."""
    avatar = avatar or load_avatar()
    return _face_rig(avatar.skeleton, avatar_fapu(avatar)).names


def face_bone_rotations(faps: np.ndarray, skeleton: Skeleton, fapu: Fapu) -> dict[str, np.ndarray]:
    """Local rotations of the face bones that play the FAPs (see the module's docstring).

    faps: (T, 68) integers, index = FAP id - 1, in FAPU (or 1e-5 rad). skeleton: the MakeHuman rig at rest.
    fapu: this face's units (`avatar_fapu`). Returns bone name -> (T, 4) float64 unit quaternions (w, x, y, z);
    all-zero FAPs give identity rotations. The displacements, turns and eyes are compiled (media/face_bones.py);
    `_face_bone_rotations_numpy` is the NumPy form.
    """
    names, quaternions = _face_bone_quaternions(faps, skeleton, fapu)
    return {name: quaternions[:, k] for k, name in enumerate(names)}


def _face_bone_quaternions(faps: np.ndarray, skeleton: Skeleton, fapu: Fapu) -> tuple[tuple[str, ...], np.ndarray]:
    """`face_bone_rotations` as one array: (the bone names, (T, F, 4) float64 their quaternions in that order)."""
    faps = np.asarray(faps)
    if faps.ndim != 2 or faps.shape[1] != N_FAPS or faps.dtype.kind not in "iu":
        raise SigncastError(f"FAPs must be (T, {N_FAPS}) integers, got {faps.shape} {faps.dtype}")
    rig = _face_rig(skeleton, fapu)
    values = np.ascontiguousarray(faps, dtype=np.float64)          # integers: exact
    turned, eye_angles, head, tail, jaw = bones_kernel.face_targets(
        values, _TARGET_COLUMNS, rig.units, rig.shares, ANGLE_UNIT_RAD)
    lids = bones_kernel.turns(rig.arms, rig.reach, turned)
    quaternions = np.empty((len(faps), len(rig.names), 4))
    quaternions[:, _LID_COLUMNS] = lids.swapaxes(0, 1)
    quaternions[:, _EYE_COLUMNS] = bones_kernel.eye_rotations(eye_angles).swapaxes(0, 1)
    _carry_into(rig.head, head, tail, quaternions, len(_TURNED_NAMES))
    _carry_into(rig.jaw, jaw, jaw, quaternions, len(_TURNED_NAMES) + len(rig.head.names))
    return rig.names, quaternions


# The turned bones' columns in `_face_bone_quaternions`: the jaw, then per side (L, R) the lids and the eye.
_TURNED_NAMES = ("jaw",) + tuple(f"{bone}.{side}" for side in SIDES for bone in ("orbicularis03", "orbicularis04", "eye"))
_LID_COLUMNS = np.array([0, 1, 2, 4, 5])          # media/face_bones.py turns' order
_EYE_COLUMNS = np.array([3, 6])


@dataclass(frozen=True)
class _FaceRig:
    """What the face rig needs of a skeleton and FAPU, made once: the turned bones' arms and reach
    (`_turned_arms`), the FAPU and corner shares as the kernels take them, the carry plans of the head and the
    jaw, and all face bones' names in `_face_bone_quaternions`' order."""
    arms: np.ndarray         # (5, 3) metres
    reach: np.ndarray        # (5,) metres
    units: np.ndarray        # (5,) irisd, es, ens, mns, mw, metres
    shares: np.ndarray       # (4,) oris03.L/R, oris07.L/R
    head: _CarryPlan
    jaw: _CarryPlan
    names: tuple[str, ...]


_RIGS: dict[tuple[int, Fapu], tuple[Skeleton, _FaceRig]] = {}


def _face_rig(skeleton: Skeleton, fapu: Fapu) -> _FaceRig:
    """The `_FaceRig` of a skeleton object and FAPU (cached)."""
    cached = _RIGS.get((id(skeleton), fapu))
    if cached is not None and cached[0] is skeleton:
        return cached[1]
    shares = _corner_shares(skeleton)
    arms = _turned_arms(skeleton, fapu)
    head, jaw = _carry_plan(skeleton, "head", _HEAD_CARRIED), _carry_plan(skeleton, "jaw", _JAW_CARRIED)
    rig = _FaceRig(arms, _REACH[(id(skeleton), fapu)], np.array([fapu.irisd, fapu.es, fapu.ens, fapu.mns, fapu.mw]),
                   np.array([shares[f"oris0{k}.{side}"] for k in (3, 7) for side in SIDES]), head, jaw,
                   _TURNED_NAMES + head.names + jaw.names)
    _RIGS[(id(skeleton), fapu)] = (skeleton, rig)
    return rig


def _carry_into(plan: _CarryPlan, head_moved: np.ndarray, tail_moved: np.ndarray, quaternions: np.ndarray,
                column: int, iterations: int = CARRY_ITERATIONS, damping: float = CARRY_DAMPING,
                max_turn: float = CARRY_MAX_TURN, tolerance: float = CARRY_TOLERANCE) -> None:
    """The carry of a plan (`_carry`) written to quaternions[:, column:column + C + S] ((T, F, 4)): frames held
    bit for bit solved once, the solve, the carriers' quaternions and the skinned bones' parent^T turned as
    quaternions in one compiled call (media/face_rig_solve.carry_into)."""
    face_kernel.carry_into(
        head_moved, tail_moved, plan.carrier_heads, plan.carrier_parents, plan.skinned_heads, plan.skinned_parents,
        plan.group_members, plan.group_start, *plan.tables, plan.arms, iterations, damping, max_turn, tolerance,
        quaternions, column)


def _face_bone_rotations_numpy(faps: np.ndarray, skeleton: Skeleton, fapu: Fapu) -> dict[str, np.ndarray]:
    """`face_bone_rotations` with the displacements and the eyes in NumPy (`_turned_bones`, `_carried_bones`):
    the readable reference of media/face_bones.py `face_targets` and `eye_rotations`; tests compare the two."""
    face = _Displacements(np.asarray(faps), fapu)
    return _turned_bones(face, skeleton) | _carried_bones(face, skeleton)


# The FAPs media/face_bones.py `face_targets` reads, in its order; {s}: the side (L then R; one-sided names repeat).
_TARGET_FAPS = (
    "open_jaw", "shift_jaw", "close_t_{s}_eyelid", "close_b_{s}_eyelid", "yaw_{s}_eyeball", "pitch_{s}_eyeball",
    "squeeze_{s}_eyebrow", "puff_{s}_cheek", "lift_{s}_cheek", "raise_{s}_m_eyebrow", "push_t_lip", "push_b_lip",
    "raise_nose", "stretch_{s}_cornerlip", "stretch_{s}_cornerlip_o", "raise_{s}_cornerlip", "raise_{s}_cornerlip_o",
    "lower_t_midlip", "lower_t_midlip_o", "lower_t_lip_{s}m", "lower_t_lip_{s}m_o", "raise_{s}_i_eyebrow",
    "stretch_{s}_nose", "raise_b_lip_{s}m", "raise_b_lip_{s}m_o", "raise_b_midlip", "raise_b_midlip_o")
_TARGET_COLUMNS = np.array([[FAP_IDS[name.format(s=s)] - 1 for s in SIDES.values()] for name in _TARGET_FAPS],
                           dtype=np.int64)
_TARGET_COLUMNS.flags.writeable = False


class _Displacements:
    """FAP values of T frames read as this face's displacements: (T,) values, (T, 3) vectors in metres."""

    def __init__(self, faps: np.ndarray, fapu: Fapu):
        self.faps, self.fapu = faps, fapu
        self.values = faps.astype(np.float64)          # (T, 68), converted once (integers: exact)

    def value(self, name: str) -> np.ndarray:
        """(T,) float64 value of a FAP, in its unit (a view: read only by the callers)."""
        return self.values[:, FAP_IDS[name] - 1]

    def lip(self, name: str) -> np.ndarray:
        """(T,) the mean of an inner-lip FAP and its outer-lip twin (one bone plays both)."""
        return (self.value(name) + self.value(name + "_o")) / 2

    def vector(self, x=0.0, y=0.0, z=0.0) -> np.ndarray:
        """(T, 3) metres from per-axis (T,) or scalar components."""
        displacement = np.zeros((len(self.faps), 3))
        displacement[:, 0], displacement[:, 1], displacement[:, 2] = x, y, z
        return displacement


def _turned_bones(face: _Displacements, skeleton: Skeleton) -> dict[str, np.ndarray]:
    """(T, 4) rotations of the jaw, the eyelids and the eyeballs, each turned about its own head."""
    fapu = face.fapu
    opening = np.maximum(face.value("open_jaw"), 0.0)      # unidirectional: the jaw does not close past rest
    names, displacements = ["jaw"], [face.vector(x=-face.value("shift_jaw") * fapu.mw, y=-opening * fapu.mns)]
    eye_angles = []
    for side, s in SIDES.items():
        names += [f"orbicularis03.{side}", f"orbicularis04.{side}"]
        displacements += [face.vector(y=-face.value(f"close_t_{s}_eyelid") * fapu.irisd),
                          face.vector(y=face.value(f"close_b_{s}_eyelid") * fapu.irisd)]
        eye_angles += [face.value(f"yaw_{s}_eyeball") * ANGLE_UNIT_RAD, face.value(f"pitch_{s}_eyeball") * ANGLE_UNIT_RAD]
    turned = dict(zip(names, _turns(_turned_arms(skeleton, fapu), np.stack(displacements))))
    # Per eye: yaw about +Y, then pitch about +X; all four turns in one call, then both products.
    axes = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0]] * len(SIDES))[:, None]           # (4, 1, 3)
    turns = rotations.from_axis_angle(axes, np.stack(eye_angles))             # (4, T, 4)
    eyes = rotations.multiply(turns[0::2], turns[1::2])
    result = {"jaw": turned["jaw"]}
    for k, side in enumerate(SIDES):
        result |= {f"orbicularis03.{side}": turned[f"orbicularis03.{side}"],
                   f"orbicularis04.{side}": turned[f"orbicularis04.{side}"], f"eye.{side}": eyes[k]}
    return result


def _carried_bones(face: _Displacements, skeleton: Skeleton) -> dict[str, np.ndarray]:
    """(T, 4) rotations of the lips, mouth corners, cheeks, nose wings and brows and of their carriers.

    The targets of both sides are made together, (T, 2) arrays (L, R), each entry by the same operations
    in the same order as one side alone (`_carried_bones_by_side`, the readable form; elementwise IEEE
    operations: the same numbers), and written straight into the (T, S, 3) arrays the carry takes."""
    fapu, values = face.fapu, face.values
    n_frames = len(values)

    def pair(name: str) -> np.ndarray:                 # (T, 2) a FAP's values, name with {s} for the side
        return values[:, [FAP_IDS[name.format(s=s)] - 1 for s in SIDES.values()]]

    def lip_pair(name: str) -> np.ndarray:
        return (pair(name) + pair(name + "_o")) / 2

    outward = np.array([OUTWARD[side] for side in SIDES])
    shares = _corner_shares(skeleton)
    share_upper = np.array([shares[f"oris03.{side}"] for side in SIDES])
    share_lower = np.array([shares[f"oris07.{side}"] for side in SIDES])
    corner_x = outward * lip_pair("stretch_{s}_cornerlip") * fapu.mw
    corner_y = lip_pair("raise_{s}_cornerlip") * fapu.mns
    lift_x, lift_y, lift_z = corner_x * 0.0, corner_y * 1.0, 0.0 * 0.0      # corner * [0, 1, 0]
    push_t = face.value("push_t_lip") * fapu.mns
    push_b = face.value("push_b_lip") * fapu.mns
    squeeze = -outward * pair("squeeze_{s}_eyebrow") * fapu.es
    nose_lift = face.value("raise_nose") * fapu.ens
    # head: per side levator05, risorius03, oculi01, levator06 (L at 0..3, R at 4..7); oris05, oris03.L/R
    head = np.zeros((n_frames, 11, 3))
    tail = np.zeros((n_frames, 11, 3))
    sides = np.array([0, 4])
    for moved in (head, tail):
        moved[:, sides, 0], moved[:, sides, 1] = corner_x, corner_y
        moved[:, sides + 1, 0] = outward * pair("puff_{s}_cheek") * fapu.es
        moved[:, sides + 1, 1] = np.maximum(pair("lift_{s}_cheek"), 0.0) * fapu.ens
        moved[:, sides + 2, 0] = squeeze
        moved[:, 8, 1], moved[:, 8, 2] = -face.lip("lower_t_midlip") * fapu.mns, push_t
        moved[:, 9:11, 0] = 0.0 + share_upper * lift_x
        moved[:, 9:11, 1] = -lip_pair("lower_t_lip_{s}m") * fapu.mns + share_upper * lift_y
        moved[:, 9:11, 2] = push_t[:, None] + share_upper * lift_z
    head[:, sides + 2, 1] = pair("raise_{s}_m_eyebrow") * fapu.ens
    tail[:, sides + 2, 1] = pair("raise_{s}_i_eyebrow") * fapu.ens
    head[:, sides + 3, 1] = nose_lift[:, None]
    tail[:, sides + 3, 0] = 0.0 + outward * pair("stretch_{s}_nose") * fapu.ens
    tail[:, sides + 3, 1] = nose_lift[:, None] + 0.0
    tail[:, sides + 3, 2] = 0.0 + 0.0
    # jaw: oris01, oris07.L/R
    jaw = np.zeros((n_frames, 3, 3))
    jaw[:, 0, 1], jaw[:, 0, 2] = face.lip("raise_b_midlip") * fapu.mns, push_b
    jaw[:, 1:3, 0] = 0.0 + share_lower * lift_x
    jaw[:, 1:3, 1] = lip_pair("raise_b_lip_{s}m") * fapu.mns + share_lower * lift_y
    jaw[:, 1:3, 2] = push_b[:, None] + share_lower * lift_z
    return (_carry_arrays(skeleton, "head", _HEAD_CARRIED, head, tail)
            | _carry_arrays(skeleton, "jaw", _JAW_CARRIED, jaw, jaw))


_HEAD_CARRIED = tuple(f"{bone}.{side}" for side in SIDES for bone in ("levator05", "risorius03", "oculi01", "levator06")
                      ) + ("oris05", "oris03.L", "oris03.R")
_JAW_CARRIED = ("oris01", "oris07.L", "oris07.R")


def _carried_bones_by_side(face: _Displacements, skeleton: Skeleton) -> dict[str, np.ndarray]:
    """`_carried_bones` side by side and bone by bone (its reference; tests compare the two): (T, 4) rotations of the lips, mouth corners, cheeks, nose wings and brows and of their carriers."""
    fapu, value, lip, vector = face.fapu, face.value, face.lip, face.vector
    upper_lip = {"oris05": vector(y=-lip("lower_t_midlip") * fapu.mns, z=value("push_t_lip") * fapu.mns)}
    lower_lip = {"oris01": vector(y=lip("raise_b_midlip") * fapu.mns, z=value("push_b_lip") * fapu.mns)}
    on_head = {}        # skinned bone -> (head displacement, tail displacement)
    shares = _corner_shares(skeleton)
    for side, s in SIDES.items():
        outward = OUTWARD[side]
        corner = vector(x=outward * lip(f"stretch_{s}_cornerlip") * fapu.mw, y=lip(f"raise_{s}_cornerlip") * fapu.mns)
        corner_lift = corner * [0.0, 1.0, 0.0]
        upper_lip[f"oris03.{side}"] = (vector(y=-lip(f"lower_t_lip_{s}m") * fapu.mns, z=value("push_t_lip") * fapu.mns)
                                       + shares[f"oris03.{side}"] * corner_lift)
        lower_lip[f"oris07.{side}"] = (vector(y=lip(f"raise_b_lip_{s}m") * fapu.mns, z=value("push_b_lip") * fapu.mns)
                                       + shares[f"oris07.{side}"] * corner_lift)
        cheek = vector(x=outward * value(f"puff_{s}_cheek") * fapu.es,
                       y=np.maximum(value(f"lift_{s}_cheek"), 0.0) * fapu.ens)
        squeeze = -outward * value(f"squeeze_{s}_eyebrow") * fapu.es       # positive: towards the midline
        brow_middle = vector(x=squeeze, y=value(f"raise_{s}_m_eyebrow") * fapu.ens)
        brow_inner = vector(x=squeeze, y=value(f"raise_{s}_i_eyebrow") * fapu.ens)
        nose_lift = vector(y=value("raise_nose") * fapu.ens)
        nose_wing = nose_lift + vector(x=outward * value(f"stretch_{s}_nose") * fapu.ens)
        on_head |= {f"levator05.{side}": (corner, corner), f"risorius03.{side}": (cheek, cheek),
                    f"oculi01.{side}": (brow_middle, brow_inner), f"levator06.{side}": (nose_lift, nose_wing)}
    on_head |= {name: (moved, moved) for name, moved in upper_lip.items()}
    on_jaw = {name: (moved, moved) for name, moved in lower_lip.items()}
    return _carry(skeleton, "head", on_head) | _carry(skeleton, "jaw", on_jaw)


def with_face_bones(motion: Motion, avatar: Avatar | None = None, *, keep_faps: bool = True) -> Motion:
    """The motion with its face played on the avatar's face bones (default: the vendored avatar).

    A motion without FAPs is returned as it is. Otherwise the face bones' rotations (from the FAPs, in
    this avatar's FAPU) replace the motion's own entries for those bones or are appended; the FAPs are
    kept, so applying this twice gives the same motion, unless keep_faps is False (what a coder of bones
    sends: `with_face_bones(motion).without_face()`, built once).
    """
    if motion.faps is None:
        return motion
    avatar = avatar or load_avatar()
    face_names, face = _face_bone_quaternions(motion.faps, avatar.skeleton, avatar_fapu(avatar))
    names, position = _bone_plan(tuple(motion.bone_names), face_names)
    q = np.empty((motion.n_frames, len(names), 4))
    q[:, :len(motion.bone_names)] = motion.rotations          # the appended columns are all face bones
    q[:, position] = face
    return Motion(motion.fps, names, q, motion.root_translation.copy(),                 # Motion copies the FAPs
                  motion.faps if keep_faps else None)


_BONE_PLANS: dict[tuple[tuple[str, ...], tuple[str, ...]], tuple[tuple[str, ...], np.ndarray]] = {}


def _bone_plan(bone_names: tuple[str, ...], face_names: tuple[str, ...]) -> tuple[tuple[str, ...], np.ndarray]:
    """with_face_bones' layout for a motion's bones and the face bones (names only, cached): the names
    (the motion's, then the face bones it lacks) and each face bone's column (the first of its name; (F,) int64,
    distinct)."""
    plan = _BONE_PLANS.get((bone_names, face_names))
    if plan is None:
        names = list(bone_names) + [name for name in face_names if name not in bone_names]
        first = {name: k for k, name in reversed(list(enumerate(names)))}     # first of each name, as list.index
        plan = (tuple(names), np.array([first[name] for name in face_names], dtype=np.int64))
        if len(_BONE_PLANS) >= 64:
            _BONE_PLANS.clear()
        _BONE_PLANS[(bone_names, face_names)] = plan
    return plan


def _turn(arm: np.ndarray, displacement: np.ndarray) -> np.ndarray:
    """(T, 4) turns about a pivot that move the point at `arm` (3,) from the pivot by `displacement` (T, 3)
    metres, measured along the displacement: the axis is perpendicular to both, the angle exact (the
    point stops at its farthest reach when the displacement is beyond it)."""
    distance = np.linalg.norm(displacement, axis=-1)
    direction = displacement / np.maximum(distance, 1e-300)[:, None]
    along = _dot(direction, arm)
    across = np.linalg.norm(arm - along[:, None] * direction, axis=-1)
    reach = _length(arm)
    angle = np.arctan2(across, along) - np.arccos(np.clip((distance + along) / reach, -1.0, 1.0))
    return rotations.from_axis_angle(rotations.cross(arm, direction), angle)


def _turns(arms: np.ndarray, displacements: np.ndarray) -> np.ndarray:
    """`_turn` of several arms (N, 3) and their displacements (N, T, 3) -> (N, T, 4), with each arm's
    operations as `_turn` does them (the same values) but one call per NumPy function."""
    distance = np.linalg.norm(displacements, axis=-1)                                  # (N, T)
    direction = displacements / np.maximum(distance, 1e-300)[..., None]
    along = _dot(direction, arms[:, None])                                            # (N, T)
    across = np.linalg.norm(arms[:, None] - along[..., None] * direction, axis=-1)
    reach = _length(arms)[:, None]
    angle = np.arctan2(across, along) - np.arccos(np.clip((distance + along) / reach, -1.0, 1.0))
    return rotations.from_axis_angle(rotations.cross(arms[:, None], direction), angle)


_ARMS: dict[tuple[int, Fapu], tuple[Skeleton, np.ndarray]] = {}
_SHARES: dict[int, tuple[Skeleton, dict[str, float]]] = {}
_REACH: dict[tuple[int, Fapu], np.ndarray] = {}      # _ARMS' lengths, (5,), made with them


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(a0 b0 + a1 b1) + a2 b2 of 3-vectors (..., 3) broadcast together: an order fixed on every CPU (BLAS's
    dot and matmul sum in CPU-dependent orders, with fused multiply-adds where the CPU has them)."""
    return (a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1]) + a[..., 2] * b[..., 2]


def _length(v: np.ndarray) -> np.ndarray:
    """|v| of 3-vectors (..., 3) as `_dot`, sqrt of (x x + y y) + z z."""
    return np.sqrt(_dot(v, v))


def _turned_arms(skeleton: Skeleton, fapu: Fapu) -> np.ndarray:
    """(5, 3) the turned bones' arms from their pivots, metres: the jaw's (head -> tail), then per side
    (L, R) the upper and lower lid margins' (`_lid_arms`). Made once per skeleton object and FAPU."""
    cached = _ARMS.get((id(skeleton), fapu))
    if cached is not None and cached[0] is skeleton:
        return cached[1]
    jaw = skeleton.index("jaw")
    arms = [skeleton.tails[jaw] - skeleton.heads[jaw]]
    for side in SIDES:
        arms += _lid_arms(skeleton, side, fapu.irisd * FAPU_DIVISOR)
    result = np.array(arms)
    result.flags.writeable = False
    _ARMS[(id(skeleton), fapu)] = (skeleton, result)
    _REACH[(id(skeleton), fapu)] = _length(result)                                      # as `_turns`
    return result


def _corner_shares(skeleton: Skeleton) -> dict[str, float]:
    """Lip side bone -> `_share_of_corner`, for the four lip sides; made once per skeleton object."""
    cached = _SHARES.get(id(skeleton))
    if cached is not None and cached[0] is skeleton:
        return cached[1]
    shares = {f"oris0{k}.{side}": _share_of_corner(skeleton, f"oris0{k}.{side}") for k in (3, 7) for side in SIDES}
    _SHARES[id(skeleton)] = (skeleton, shares)
    return shares


def _share_of_corner(skeleton: Skeleton, lip_bone: str) -> float:
    """How much of its corner's displacement a lip side follows: its tail's distance from the midline over
    the corner bone's (the lip is held at the middle and pulled at the corner)."""
    corner = "levator05." + lip_bone[-1]
    return float(skeleton.tails[skeleton.index(lip_bone), 0] / skeleton.tails[skeleton.index(corner), 0])


def _lid_arms(skeleton: Skeleton, side: str, aperture: float) -> tuple[np.ndarray, np.ndarray]:
    """(3,) each: eye centre -> upper and lower lid margin, on the lid bones' axes at the radius where the
    margins are `aperture` metres apart vertically."""
    upper, lower = (skeleton.tails[skeleton.index(f"orbicularis0{k}.{side}")]
                    - skeleton.heads[skeleton.index(f"orbicularis0{k}.{side}")] for k in (3, 4))
    upper, lower = upper / _length(upper), lower / _length(lower)
    radius = aperture / (upper[1] - lower[1])
    return radius * upper, radius * lower


def _ancestors_between(skeleton: Skeleton, anchor: str, bone: str) -> list[int]:
    """Indices of the bones strictly between `anchor` and `bone` in the hierarchy, root side first."""
    stop, chain = skeleton.index(anchor), []
    parent = int(skeleton.parents[skeleton.index(bone)])
    while parent != stop:
        if parent < 0:
            raise SigncastError(f"bone {bone!r} does not hang from {anchor!r}")
        chain.append(parent)
        parent = int(skeleton.parents[parent])
    return chain[::-1]


def _skew(r: np.ndarray) -> np.ndarray:
    """(..., 3, 3) matrices of the cross product with r (..., 3): _skew(r) @ v = r x v."""
    x, y, z = np.moveaxis(r, -1, 0)
    zero = np.zeros_like(x)
    return np.stack([np.stack([zero, -z, y], -1), np.stack([z, zero, -x], -1), np.stack([-y, x, zero], -1)], -2)


@dataclass(frozen=True)
class _CarryPlan:
    """The skeleton's part of a carry, the same for every motion: carriers (bone indices, parents first)
    and skinned bones with the kernel's arrays (media/face_rig_solve.carry_into)."""
    carriers: list[int]
    skinned: list[int]
    carrier_heads: np.ndarray      # (C, 3)
    carrier_parents: np.ndarray    # (C,) index among the carriers, -1: the anchor
    skinned_heads: np.ndarray      # (S, 3)
    skinned_parents: np.ndarray    # (S,)
    on_chain: np.ndarray           # (S, C) bool
    group_members: np.ndarray      # (S,) skinned bones grouped by shared carriers ...
    group_start: np.ndarray        # (G + 1,) ... group g: group_members[group_start[g]:group_start[g + 1]]
    arms: np.ndarray               # (S, 3) head -> tail of each skinned bone
    names: tuple[str, ...]         # the carriers' then the skinned bones' names, as _carry returns them
    tables: tuple[np.ndarray, ...]  # media/face_rig_solve.carry_tables of on_chain and the groups


_PLANS: dict[tuple[int, str, tuple[str, ...]], tuple[Skeleton, _CarryPlan]] = {}


def _carry_plan(skeleton: Skeleton, anchor: str, names: tuple[str, ...]) -> _CarryPlan:
    """The plan of carrying the skinned bones `names` below `anchor`; made once per skeleton object."""
    key = (id(skeleton), anchor, names)
    cached = _PLANS.get(key)
    if cached is not None and cached[0] is skeleton:
        return cached[1]
    skinned = [skeleton.index(name) for name in names]
    chains = [_ancestors_between(skeleton, anchor, name) for name in names]
    carriers = sorted({bone for chain in chains for bone in chain})
    position = {bone: j for j, bone in enumerate(carriers)}
    on_chain = np.zeros((len(skinned), len(carriers)), dtype=bool)
    for i, chain in enumerate(chains):
        on_chain[i, [position[bone] for bone in chain]] = True
    groups: list[set[int]] = []                   # skinned bones linked by shared carriers
    for i in range(len(skinned)):
        linked = [g for g in groups if any((on_chain[i] & on_chain[k]).any() for k in g)]
        groups = [g for g in groups if g not in linked] + [set().union({i}, *linked)]
    members = [i for g in groups for i in sorted(g)]
    starts = np.cumsum([0] + [len(g) for g in groups])
    plan = _CarryPlan(
        carriers, skinned, np.ascontiguousarray(skeleton.heads[carriers], dtype=np.float64),
        np.array([position.get(int(skeleton.parents[bone]), -1) for bone in carriers], dtype=np.int64),
        np.ascontiguousarray(skeleton.heads[skinned], dtype=np.float64),
        np.array([position.get(int(skeleton.parents[bone]), -1) for bone in skinned], dtype=np.int64),
        on_chain, np.array(members, dtype=np.int64), starts.astype(np.int64),
        np.ascontiguousarray(skeleton.tails[skinned] - skeleton.heads[skinned], dtype=np.float64),
        tuple(skeleton.names[bone] for bone in carriers + skinned),
        face_kernel.carry_tables(on_chain, np.array(members, dtype=np.int64), starts.astype(np.int64)))
    _PLANS[key] = (skeleton, plan)
    return plan


def _carry(skeleton: Skeleton, anchor: str, targets: dict[str, tuple[np.ndarray, np.ndarray]],
           iterations: int = CARRY_ITERATIONS, damping: float = CARRY_DAMPING, max_turn: float = CARRY_MAX_TURN,
           tolerance: float = CARRY_TOLERANCE) -> dict[str, np.ndarray]:
    """Local rotations (T, 4) carrying skinned bones by their unskinned ancestors below `anchor`.

    targets: skinned bone -> (head displacement, tail displacement), (T, 3) metres each in the anchor's
    rest frame. The carriers turn so that each skinned bone's head moves by its displacement: damped
    Gauss-Newton steps (damping in metres; no carrier turns more than max_turn radians a step), each
    the smallest turns that meet the linearised targets at the current pose; unreachable targets end
    at the nearest reachable pose (media/face_rig_solve.carry_into, each frame alone; `_carry_numpy` is the
    same solve in NumPy; a frame equal to the one before it is not solved again; a frame stops after the
    iteration whose largest carrier turn is below `tolerance` radians, 0: every frame runs `iterations`). Each
    skinned bone then turns so that its tail moves by its own displacement relative to its head.
    """
    head_moved = np.stack([head for head, _ in targets.values()], axis=1)          # (T, S, 3)
    tail_moved = np.stack([tail for _, tail in targets.values()], axis=1)
    return _carry_arrays(skeleton, anchor, tuple(targets), head_moved, tail_moved, iterations, damping, max_turn,
                         tolerance)


def _carry_arrays(skeleton: Skeleton, anchor: str, names: tuple[str, ...], head_moved: np.ndarray,
                  tail_moved: np.ndarray, iterations: int = CARRY_ITERATIONS, damping: float = CARRY_DAMPING,
                  max_turn: float = CARRY_MAX_TURN, tolerance: float = CARRY_TOLERANCE) -> dict[str, np.ndarray]:
    """`_carry` of the skinned bones `names` with their head and tail displacements as (T, S, 3) arrays."""
    plan = _carry_plan(skeleton, anchor, names)
    quaternions = np.empty((len(head_moved), len(plan.names), 4))
    _carry_into(plan, np.ascontiguousarray(head_moved, dtype=np.float64),
                np.ascontiguousarray(tail_moved, dtype=np.float64), quaternions, 0, iterations, damping, max_turn,
                tolerance)
    return {name: quaternions[:, k] for k, name in enumerate(plan.names)}


def _carry_numpy(skeleton: Skeleton, anchor: str, targets: dict[str, tuple[np.ndarray, np.ndarray]],
                 iterations: int = CARRY_ITERATIONS, damping: float = CARRY_DAMPING, max_turn: float = CARRY_MAX_TURN,
                 tolerance: float = CARRY_TOLERANCE) -> dict[str, np.ndarray]:
    """`_carry` in NumPy, all frames at once: the readable reference of the compiled kernel
    (media/face_rig_solve.py); tests compare the two.

    Local rotations (T, 4) carrying skinned bones by their unskinned ancestors below `anchor`.

    targets: skinned bone -> (head displacement, tail displacement), (T, 3) metres each in the anchor's
    rest frame. The carriers turn so that each skinned bone's head moves by its displacement: damped
    Gauss-Newton steps (damping in metres; no carrier turns more than max_turn radians a step), each
    the smallest turns that meet the linearised targets at the current pose; unreachable targets end
    at the nearest reachable pose; a frame stops after the iteration whose largest carrier turn is below
    `tolerance` radians (its later steps are computed and dropped). Each skinned bone then turns so that its
    tail moves by its own displacement relative to its head.
    """
    skinned = [skeleton.index(name) for name in targets]
    chains = [_ancestors_between(skeleton, anchor, skeleton.names[bone]) for bone in skinned]
    carriers = sorted({bone for chain in chains for bone in chain})
    rest_heads = skeleton.heads[skinned]                                                        # (S, 3)
    wanted = np.stack([head_moved for head_moved, _ in targets.values()], axis=1)              # (T, S, 3)
    n_frames, n_skinned, n_carriers = len(wanted), len(skinned), len(carriers)
    local = np.broadcast_to(np.eye(3), (n_frames, n_carriers, 3, 3)).copy()
    active = np.ones(n_frames, dtype=bool)
    for _ in range(iterations):
        world = _carrier_poses(skeleton, anchor, carriers, local)
        heads = np.stack([_transform(world[int(skeleton.parents[bone])], skeleton.heads[bone]) for bone in skinned], axis=1)
        residual = (wanted - (heads - rest_heads)).reshape(n_frames, 3 * n_skinned)
        jacobian = np.zeros((n_frames, 3 * n_skinned, 3 * n_carriers))   # head motion per turn about each carrier
        for i, chain in enumerate(chains):
            for bone in chain:
                j = carriers.index(bone)
                pivot = _transform(world[bone], skeleton.heads[bone])
                jacobian[:, 3 * i:3 * i + 3, 3 * j:3 * j + 3] = -_skew(heads[:, i] - pivot)
        transposed = np.swapaxes(jacobian, 1, 2)
        normal = jacobian @ transposed + damping ** 2 * np.eye(3 * n_skinned)
        step = (transposed @ np.linalg.solve(normal, residual[..., None]))[..., 0].reshape(n_frames, n_carriers, 3)
        largest = np.linalg.norm(step, axis=-1).max(axis=1)
        step *= np.minimum(1.0, max_turn / np.maximum(largest, 1e-300))[:, None, None]
        turn = _rotation_matrices(step)                  # about each carrier's posed head, anchor frame
        for j, bone in enumerate(carriers):
            parent = world[int(skeleton.parents[bone])][0]
            turned = np.swapaxes(parent, 1, 2) @ turn[:, j] @ parent @ local[:, j]
            local[active, j] = turned[active]
        if tolerance > 0:
            active &= largest >= tolerance
    world = _carrier_poses(skeleton, anchor, carriers, local)
    result = {skeleton.names[bone]: rotations.from_matrix(local[:, j]) for j, bone in enumerate(carriers)}
    for bone, (head_moved, tail_moved) in zip(skinned, targets.values()):
        arm = skeleton.tails[bone] - skeleton.heads[bone]
        turned = rotations.to_matrix(rotations.between(np.broadcast_to(arm, tail_moved.shape), arm + tail_moved - head_moved))
        parent = world[int(skeleton.parents[bone])][0]
        result[skeleton.names[bone]] = rotations.from_matrix(np.swapaxes(parent, 1, 2) @ turned)
    return result


def _carrier_poses(skeleton: Skeleton, anchor: str, carriers: list[int], local: np.ndarray
                   ) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """bone -> (rotation (T, 3, 3), offset (T, 3)): x -> R x + t from rest to posed, relative to the anchor,
    for the anchor (identity) and the carriers (parents first) given their local rotations (T, C, 3, 3)."""
    n_frames = len(local)
    world = {skeleton.index(anchor): (np.broadcast_to(np.eye(3), (n_frames, 3, 3)), np.zeros((n_frames, 3)))}
    for j, bone in enumerate(carriers):
        parent_rotation, parent_offset = world[int(skeleton.parents[bone])]
        rotation = parent_rotation @ local[:, j]
        head = skeleton.heads[bone]
        world[bone] = (rotation, parent_offset + parent_rotation @ head - rotation @ head)
    return world


def _transform(pose: tuple[np.ndarray, np.ndarray], point: np.ndarray) -> np.ndarray:
    """(T, 3) where a pose (rotation (T, 3, 3), offset (T, 3)) puts a rest point (3,)."""
    rotation, offset = pose
    return rotation @ point + offset


def _rotation_matrices(rotation_vectors: np.ndarray) -> np.ndarray:
    """(..., 3, 3) rotation matrices of rotation vectors (..., 3) (axis times angle in radians; Rodrigues)."""
    angle = np.linalg.norm(rotation_vectors, axis=-1)[..., None, None]
    cross = _skew(rotation_vectors / np.maximum(angle[..., 0], 1e-300))
    return np.eye(3) + np.sin(angle) * cross + (1.0 - np.cos(angle)) * cross @ cross


def _vertex_normals(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """(V, 3) unit area-weighted vertex normals (triangles counter-clockwise from outside)."""
    corners = vertices[triangles]
    face_normals = rotations.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    normals = np.zeros_like(vertices)
    for k in range(3):
        np.add.at(normals, triangles[:, k], face_normals)
    return normals / np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-300)

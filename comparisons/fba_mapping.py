"""Motion <-> MPEG-4 BAP values for the signcast avatar.

Each avatar bone that can carry body motion is assigned an H-Anim joint and its BAPs
(comparisons/bap_table.py). A joint's local rotation is split into the standard's three
anatomical angles, flexion (flexion/tilt), abduction (abduct/roll/pivot) and twisting
(twisting/torsion/rotate/turn), composed "twisting o abduction o flexion" (seed 000 §2.1, seed
004 "Body Animation Parameters"): flexion first, then abduction about the moved abduction axis,
then twist about the segment's own long axis, i.e. q = R_F(f) R_A(a) R_L(t) in moving axes.

Anatomical axes come from the avatar's rest skeleton (the standard defines them by anatomical
planes; Greta and visage disagree on literal X/Y/Z, mpeg4-facts.md §1.5):
- long axis L: the bone's head -> tail direction (for the wrist: wrist -> middle-finger knuckle);
- flexion axis F: the lateral direction (world +X for body and limbs, the knuckle line of the hand
  for hand bones), made orthogonal to L;
- abduction axis A = F x L.
Bones whose long axis is itself lateral (clavicles, shoulder blades, pelvis bones) use the world
axes (F = X, L = Y, A = Z), matching Greta's clavicle BAPs (abduct Z, rotate Y). Right-side
angles about L and A are negated so mirror-symmetric poses give equal BAPs on both sides.

Chosen here (no source): BAP value 0 is the avatar's rest pose (an A-pose), not the standard's
neutral pose (arms hanging, seed 000 Fig. 2.10); a rotation the standard has no BAP for (e.g. the
avatar's elbow abduction, its forearm twist bone, finger twist) is carried by an extension BAP
(187..296), allocated in the order of AVATAR_JOINTS. Root translation is in mm (BAPs 181..183).
"""
from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from comparisons import bap_table
from media import rotations
from media.avatar import Skeleton, load_avatar
from media.errors import SigncastError
from media.motion import Motion

EULER_ORDER = "XZYr"     # in anatomical coordinates (x = F, y = L, z = A): flexion, abduction, twist

# avatar bone (without side suffix) -> H-Anim joint (without l_/r_), or None for extension-only bones.
AVATAR_JOINTS: tuple[tuple[str, str | None], ...] = (
    ("root", "HumanoidRoot"),
    ("spine05", "vl5"), ("spine04", "vl3"), ("spine03", "vt10"), ("spine02", "vt6"), ("spine01", "vt1"),
    ("neck01", "vc7"), ("neck02", "vc4"), ("neck03", "vc2"), ("head", "skullbase"),
    ("clavicle", "sternoclavicular"), ("shoulder01", "acromioclavicular"),
    ("upperarm01", "shoulder"), ("upperarm02", None), ("lowerarm01", "elbow"), ("lowerarm02", None),
    ("wrist", "wrist"),
    ("finger1-1", "thumb1"), ("finger1-2", "thumb2"), ("finger1-3", "thumb3"),
    ("metacarpal1", "index0"), ("finger2-1", "index1"), ("finger2-2", "index2"), ("finger2-3", "index3"),
    ("metacarpal2", "middle0"), ("finger3-1", "middle1"), ("finger3-2", "middle2"), ("finger3-3", "middle3"),
    ("metacarpal3", "ring0"), ("finger4-1", "ring1"), ("finger4-2", "ring2"), ("finger4-3", "ring3"),
    ("metacarpal4", "pinky0"), ("finger5-1", "pinky1"), ("finger5-2", "pinky2"), ("finger5-3", "pinky3"),
    ("pelvis", None), ("upperleg01", "hip"), ("upperleg02", None), ("lowerleg01", "knee"),
    ("lowerleg02", None), ("foot", "ankle"), ("toe1-1", "metatarsal"),
)
# Extra standard BAPs borrowed by a bone for an axis its own joint lacks: the foot's third axis
# is the subtalar joint's (BAPs 18/19).
_BORROWED = {("foot", "A"): "subtalar_flexion"}
_FLEXION = ("flexion", "tilt")
_ABDUCTION = ("abduct", "roll", "pivot")
_TWIST = ("twisting", "torsion", "rotate", "turn")
_WORLD_FRAME = {"clavicle", "shoulder01", "pelvis"}
_HAND = {"wrist", "metacarpal1", "metacarpal2", "metacarpal3", "metacarpal4"} | {
    f"finger{f}-{s}" for f in range(1, 6) for s in range(1, 4)}


@dataclass(frozen=True)
class BoneBaps:
    """BAP ids carrying one avatar bone's rotation: (flexion, abduction, twist), 1-based ids;
    `frame`: (4,) quaternion of the anatomical frame (columns F, L, A) in rest/world axes;
    `mirror`: True for right-side bones (abduction and twist negated)."""
    bone: str
    joint: str
    baps: tuple[int, int, int]
    frame: np.ndarray
    mirror: bool


@dataclass(frozen=True)
class AvatarBapMap:
    """The avatar's BAP assignment. bones: BoneBaps per mapped bone, in AVATAR_JOINTS order."""
    skeleton: Skeleton
    bones: tuple[BoneBaps, ...]

    @functools.cached_property
    def used_baps(self) -> np.ndarray:
        """Sorted 1-based ids of every BAP the avatar expresses (including 181..183)."""
        ids = {i for b in self.bones for i in b.baps} | set(bap_table.TRANSLATION_BAPS)
        return np.array(sorted(ids))

    def unexpressible_baps(self) -> list[int]:
        """Standard BAP ids (1..186) that no avatar bone carries."""
        used = set(self.used_baps.tolist())
        return [i for i in range(1, bap_table.N_STANDARD_BAPS + 1) if i not in used]

    def unmapped_bones(self) -> list[str]:
        """Avatar bones no BAP drives (face, tongue, most toe bones)."""
        mapped = {b.bone for b in self.bones}
        return [name for name in self.skeleton.names if name not in mapped]

    @functools.cached_property
    def bone_of_bap(self) -> dict[int, tuple[str, int]]:
        """BAP id -> (bone name, angle index 0 flexion / 1 abduction / 2 twist)."""
        return {i: (b.bone, k) for b in self.bones for k, i in enumerate(b.baps)}


def _joint_bap(joint: str, kinds: tuple[str, ...]) -> int | None:
    for bap in bap_table.BAPS[:bap_table.N_STANDARD_BAPS]:
        if bap.joint == joint and not bap.is_translation and bap.name.rsplit("_", 1)[-1] in kinds:
            return bap.id
        if bap.joint == joint and joint.startswith(("vl", "vt", "vc")) and any(bap.name.endswith(k) for k in kinds):
            return bap.id
    return None


def _frame(skeleton: Skeleton, bone: str, base: str, side: str) -> np.ndarray:
    """Rotation matrix whose columns are the anatomical axes F, L, A in world coordinates."""
    i = skeleton.index(bone)
    if base in _WORLD_FRAME:
        return np.eye(3)
    if base == "wrist":
        long_axis = skeleton.heads[skeleton.index(f"finger3-1{side}")] - skeleton.heads[i]
    else:
        long_axis = skeleton.tails[i] - skeleton.heads[i]
    long_axis = long_axis / np.linalg.norm(long_axis)
    if base in _HAND:
        lateral = skeleton.heads[skeleton.index(f"finger5-1{side}")] - skeleton.heads[skeleton.index(f"finger2-1{side}")]
        lateral = lateral if lateral[0] >= 0 else -lateral
    else:
        lateral = np.array([1.0, 0.0, 0.0])
    flexion = lateral - np.dot(lateral, long_axis) * long_axis
    if np.linalg.norm(flexion) < 0.3:
        return np.eye(3)
    flexion /= np.linalg.norm(flexion)
    abduction = np.cross(flexion, long_axis)
    return np.stack([flexion, long_axis, abduction], axis=1)


_MAPS: dict[int, AvatarBapMap] = {}


def avatar_bap_map(skeleton: Skeleton | None = None) -> AvatarBapMap:
    """The BAP assignment for `skeleton` (default: the signcast avatar's); cached per skeleton."""
    skeleton = skeleton or load_avatar().skeleton
    cached = _MAPS.get(id(skeleton))
    if cached is None or cached.skeleton is not skeleton:
        cached = _MAPS[id(skeleton)] = _build_map(skeleton)
    return cached


def _build_map(skeleton: Skeleton) -> AvatarBapMap:
    next_extension = bap_table.N_STANDARD_BAPS + 1
    bones = []
    for base, joint in AVATAR_JOINTS:
        sides = [("", "")] if base == "root" or base.startswith(("spine", "neck", "head")) else [(".L", "l_"), (".R", "r_")]
        for suffix, prefix in sides:
            name = base + suffix
            if name not in skeleton.names:
                continue
            hanim = (prefix + joint) if joint else None
            ids = []
            for axis, kinds in (("F", _FLEXION), ("A", _ABDUCTION), ("L", _TWIST)):
                found = _joint_bap(hanim, kinds) if hanim else None
                if found is None and (base, axis) in _BORROWED:
                    found = bap_table.BY_NAME[prefix + _BORROWED[(base, axis)]].id
                if found is None:
                    if next_extension > bap_table.N_BAPS:
                        raise SigncastError("the avatar needs more extension BAPs than the 110 the standard has")
                    found = next_extension
                    next_extension += 1
                ids.append(found)
            frame = _frame(skeleton, name, base, suffix)
            bones.append(BoneBaps(name, hanim or "-", tuple(ids), rotations.from_matrix(frame), suffix == ".R"))
    return AvatarBapMap(skeleton, tuple(bones))


def motion_to_baps(motion: Motion, bap_map: AvatarBapMap | None = None, *, strict: bool = True) -> np.ndarray:
    """(T, 296) int64 BAP values (index = id - 1; 1e-5 rad, mm) of a Motion on the avatar.

    strict: raise SigncastError when the motion rotates a bone that no BAP carries (more than
    1e-4 rad), since that motion would be lost.
    """
    bap_map = bap_map or avatar_bap_map()
    names = {n: k for k, n in enumerate(motion.bone_names)}
    if strict:
        lost = [n for n in bap_map.unmapped_bones() if n in names and
                np.max(rotations.angle_between(motion.rotations[:, names[n]], rotations.IDENTITY)) > 1e-4]
        if lost:
            raise SigncastError(f"motion rotates bones that no BAP carries: {', '.join(lost[:6])}")
    values = np.zeros((motion.n_frames, bap_table.N_BAPS), dtype=np.int64)
    for bone in bap_map.bones:
        if bone.bone not in names:
            continue
        q = motion.rotations[:, names[bone.bone]]
        anatomical = rotations.multiply(rotations.multiply(rotations.conjugate(bone.frame), q), bone.frame)
        angles = rotations.to_euler(anatomical, EULER_ORDER)      # (T, 3): F, A, L
        if bone.mirror:
            angles[:, 1:] *= -1
        values[:, np.array(bone.baps) - 1] = np.round(angles / bap_table.ROTATION_UNIT_RAD).astype(np.int64)
    translation_mm = np.round(motion.root_translation / bap_table.TRANSLATION_UNIT_M).astype(np.int64)
    values[:, 181 - 1] = translation_mm[:, 1]   # vertical
    values[:, 182 - 1] = translation_mm[:, 0]   # lateral
    values[:, 183 - 1] = translation_mm[:, 2]   # frontal
    return values


def baps_to_motion(values: np.ndarray, fps: float, bap_map: AvatarBapMap | None = None) -> Motion:
    """Motion of all mapped avatar bones from (T, 296) BAP values (inverse of motion_to_baps)."""
    bap_map = bap_map or avatar_bap_map()
    values = np.asarray(values)
    if values.ndim != 2 or values.shape[1] != bap_table.N_BAPS:
        raise SigncastError(f"BAP values must be (T, {bap_table.N_BAPS}), got {values.shape}")
    names = tuple(b.bone for b in bap_map.bones)
    q = np.empty((len(values), len(names), 4))
    for k, bone in enumerate(bap_map.bones):
        angles = values[:, np.array(bone.baps) - 1].astype(np.float64) * bap_table.ROTATION_UNIT_RAD
        if bone.mirror:
            angles[:, 1:] *= -1
        anatomical = rotations.from_euler(angles, EULER_ORDER)
        q[:, k] = rotations.multiply(rotations.multiply(bone.frame, anatomical), rotations.conjugate(bone.frame))
    translation = np.stack([values[:, 182 - 1], values[:, 181 - 1], values[:, 183 - 1]], axis=1) * bap_table.TRANSLATION_UNIT_M
    return Motion(fps, names, rotations.canonical(q), translation.astype(np.float64))

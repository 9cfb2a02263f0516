"""Motion <-> MPEG-4 BAP values for the signcast avatar.

Each avatar bone that can carry body motion is assigned an H-Anim joint and its BAPs
(comparisons/params/bap_table.py). A joint's rotation is split into the standard's three anatomical
angles, flexion (flexion/tilt), abduction (abduct/roll/pivot) and twisting (twisting/torsion/
rotate/turn), composed "twisting o abduction o flexion" (seed 000 §2.1, seed 004 "Body Animation
Parameters"): flexion first, then abduction about the moved abduction axis, then twist about the
segment's own long axis, i.e. r = R_F(f) R_A(a) R_L(t) in moving axes.

BAP value 0 is the MPEG-4 neutral body posture (seed 000 Fig. 2.10a, H-Anim's default pose):
standing, arms hanging at the sides, elbows straight, palms facing the thighs, wrists and fingers
straight (media.retarget.neutral_pose; on this body the hanging arm is turned
NEUTRAL_ARM_ABDUCTION out of the vertical so the hand clears the hip). The rig's rest is an A-pose;
each bone's map entry holds its neutral local rotation n (identity where the rig's rest already is
neutral: spine, neck, head, legs, clavicles), and the BAPs describe the rotation relative to it:
a motion's local rotation q gives r = n^-1 q, and the BAPs turn back into q = n r. An arm hanging
in the neutral (the natural rest of an unseen arm) therefore costs no BAP at all.

Anatomical axes (F flexion, L long, A = F x L abduction, as columns of the bone's `frame`, in the
rig's rest coordinates and carried into the neutral by n; the standard defines them by anatomical
planes, Greta and visage disagree on literal X/Y/Z, mpeg4-facts.md §1.5):
- arm and hand bones (upper arm, elbow, forearm twist, wrist, metacarpals, fingers, thumb): the
  axes the retargeting turns the joints about (media.retarget.joint_axes): a finger's F is its
  hinge axis, A the direction it flexes towards, L the bone; the elbow's F is its hinge, shared by
  the upper arm's and forearm's bones; the wrist's F and A are its flexion and deviation axes. So a
  hinge turn in the retargeting is exactly one flexion BAP (the other two round to 0), a knuckle
  turns flexion then abduction (its twisting BAP stays 0), and the forearm twist bone only twists.
  In the neutral the arm's F is horizontal and lateral: positive shoulder and elbow flexion raise
  forward, positive finger and wrist flexion bend towards the palm.
- other bones: L the bone's head -> tail direction, F the world lateral axis (+X) made orthogonal
  to L; bones whose long axis is itself lateral (clavicles, shoulder blades, pelvis bones) use the
  world axes (F = X, L = Y, A = Z), matching Greta's clavicle BAPs (abduct Z, rotate Y).
Right-side angles about L and A are negated so mirror-symmetric poses give equal BAPs on both sides.

Standard BAPs first: every axis the standard has a BAP for carries that BAP, also across bones:
the avatar splits the forearm into an elbow bone (lowerarm01, hinge: elbow_flexion) and a twist
bone (lowerarm02, where the retargeting puts the forearm's twist: elbow_twisting); the foot's third
axis is the subtalar joint's (BAPs 18/19). Every remaining axis of a mapped bone (one the standard
has no BAP for: a PIP joint's twist, the avatar's second upper-arm bone, ...) is carried by an
extension BAP (187..296), allocated in the order of AVATAR_JOINTS, so that any motion of the avatar
round-trips; `extension_report` lists them with the reason and, for given motions, only those
that move. Retargeted signing moves none of them. Root translation is in mm (BAPs 181..183).
"""
from __future__ import annotations

import functools
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from comparisons.params import bap_table
from media import bap_rotations as bap_loops
from media import rotations
from media.avatar import Skeleton, load_avatar
from media.errors import SigncastError
from media.motion import Motion
from media.retarget import joint_axes, neutral_pose

EULER_ORDER = "XZYr"     # in anatomical coordinates (x = F, y = L, z = A): flexion, abduction, twist
AXIS_NAMES = ("flexion", "abduction", "twist")

# avatar bone (without side suffix) -> H-Anim joint (without l_/r_), or None for bones H-Anim lacks.
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
# Axes whose standard BAP is not their own joint's (name without side prefix), or None: the joint's own
# BAP for that axis goes to another bone. The forearm's twist is its twist bone's (the retargeting turns
# lowerarm02 about its long axis, never lowerarm01); the foot's third axis is the subtalar joint's.
_AXIS_BAPS: dict[tuple[str, str], str | None] = {
    ("lowerarm02", "L"): "elbow_twisting",
    ("lowerarm01", "L"): None,
    ("foot", "A"): "subtalar_flexion",
}
_FLEXION = ("flexion", "tilt")
_ABDUCTION = ("abduct", "roll", "pivot")
_TWIST = ("twisting", "torsion", "rotate", "turn")
_WORLD_FRAME = {"clavicle", "shoulder01", "pelvis"}
_ANATOMICAL_AXES = {"upperarm01", "upperarm02", "lowerarm01", "lowerarm02", "wrist"} | {
    f"metacarpal{m}" for m in range(1, 5)} | {f"finger{f}-{s}" for f in range(1, 6) for s in range(1, 4)}


@dataclass(frozen=True)
class BoneBaps:
    """BAP ids carrying one avatar bone's rotation: (flexion, abduction, twist), 1-based ids;
    `frame`: (4,) quaternion of the anatomical frame (columns F, L, A) in the rig's rest axes;
    `neutral`: (4,) local rotation of the bone in the MPEG-4 neutral posture (BAP 0), relative to the
    rig's rest; `mirror`: True for right-side bones (abduction and twist negated)."""
    bone: str
    joint: str
    baps: tuple[int, int, int]
    frame: np.ndarray
    neutral: np.ndarray
    mirror: bool


@dataclass(frozen=True)
class ExtensionAxis:
    """One bone axis an extension BAP carries. bap: its id (187..296); bone; axis: 'flexion',
    'abduction' or 'twist'; reason: why no standard BAP carries it; max_abs, spread: largest |value|
    and max - min over the motions reported on (BAP units, 1e-5 rad; 0 without motions)."""
    bap: int
    bone: str
    axis: str
    reason: str
    max_abs: int = 0
    spread: int = 0


@dataclass(frozen=True)
class AvatarBapMap:
    """The avatar's BAP assignment. bones: BoneBaps per mapped bone, in AVATAR_JOINTS order;
    extension_reasons: extension BAP id -> why the standard has no BAP for that bone axis."""
    skeleton: Skeleton
    bones: tuple[BoneBaps, ...]
    extension_reasons: dict[int, str]

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
        return list(self._unmapped)

    @functools.cached_property
    def _unmapped(self) -> tuple[str, ...]:
        mapped = {b.bone for b in self.bones}
        return tuple(name for name in self.skeleton.names if name not in mapped)

    @functools.cached_property
    def bone_names(self) -> tuple[str, ...]:
        """Names of the mapped bones, in `bones` order."""
        return tuple(b.bone for b in self.bones)

    @functools.cached_property
    def bone_of_bap(self) -> dict[int, tuple[str, int]]:
        """BAP id -> (bone name, angle index 0 flexion / 1 abduction / 2 twist)."""
        return {i: (b.bone, k) for b in self.bones for k, i in enumerate(b.baps)}

    @functools.cached_property
    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Per mapped bone, stacked: frames (B, 4), neutrals (B, 4), BAP columns (B, 3) (id - 1) and
        angle signs (B, 3) (-1 for a right-side bone's abduction and twist)."""
        frames = np.stack([b.frame for b in self.bones])
        neutrals = np.stack([b.neutral for b in self.bones])
        columns = np.array([b.baps for b in self.bones], dtype=np.int64) - 1
        signs = np.where(np.array([b.mirror for b in self.bones])[:, None], np.array([1.0, -1.0, -1.0]), 1.0)
        return frames, neutrals, columns, signs

    @functools.cached_property
    def extension_baps(self) -> np.ndarray:
        """Sorted ids (187..296) of the extension BAPs the map allocates."""
        return np.array(sorted(self.extension_reasons), dtype=np.int64)


def _joint_bap(joint: str, kinds: tuple[str, ...]) -> int | None:
    for bap in bap_table.BAPS[:bap_table.N_STANDARD_BAPS]:
        if bap.joint == joint and not bap.is_translation and bap.name.rsplit("_", 1)[-1] in kinds:
            return bap.id
        if bap.joint == joint and joint.startswith(("vl", "vt", "vc")) and any(bap.name.endswith(k) for k in kinds):
            return bap.id
    return None


def _frame(skeleton: Skeleton, bone: str, base: str) -> np.ndarray:
    """Rotation matrix whose columns are the anatomical axes F, L, A in the rig's rest coordinates."""
    if base in _ANATOMICAL_AXES:
        return joint_axes(skeleton, bone).T
    if base in _WORLD_FRAME:
        return np.eye(3)
    i = skeleton.index(bone)
    long_axis = skeleton.tails[i] - skeleton.heads[i]
    long_axis = long_axis / np.linalg.norm(long_axis)
    lateral = np.array([1.0, 0.0, 0.0])
    flexion = lateral - np.dot(lateral, long_axis) * long_axis
    if np.linalg.norm(flexion) < 0.3:
        return np.eye(3)
    flexion /= np.linalg.norm(flexion)
    return np.stack([flexion, long_axis, rotations.cross(flexion, long_axis)], axis=1)


_EXTRA_BONES = {
    "upperarm02": "the upper arm's second bone",
    "lowerarm02": "the forearm's twist bone, which carries elbow_twisting",
    "pelvis": "the hip bone between the root and the thigh",
    "upperleg02": "the thigh's second bone",
    "lowerleg02": "the shin's second bone",
}


def _extension_reason(base: str, hanim: str | None, axis: str) -> str:
    """Why no standard BAP carries this bone axis ('F', 'A' or 'L'), in one line."""
    if hanim is None:
        return f"{base} ({_EXTRA_BONES.get(base, 'an extra bone')}) is no H-Anim joint: the standard has no BAP for its {AXIS_NAMES['FAL'.index(axis)]}"
    if _AXIS_BAPS.get((base, axis), "") is None:
        return f"{hanim}_twisting carries the forearm's twist bone (lowerarm02), where the retargeting twists the forearm"
    return f"the standard's {hanim} has no {AXIS_NAMES['FAL'.index(axis)]} BAP"


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
    neutral = {}
    for side in ("L", "R"):
        if all(f"{bone}.{side}" in skeleton.names for bone in ("upperarm01", "lowerarm01", "lowerarm02", "wrist")):
            neutral.update(neutral_pose(skeleton, side))
    bones, reasons = [], {}
    for base, joint in AVATAR_JOINTS:
        sides = [("", "")] if base == "root" or base.startswith(("spine", "neck", "head")) else [(".L", "l_"), (".R", "r_")]
        for suffix, prefix in sides:
            name = base + suffix
            if name not in skeleton.names:
                continue
            hanim = (prefix + joint) if joint else None
            ids = []
            for axis, kinds in (("F", _FLEXION), ("A", _ABDUCTION), ("L", _TWIST)):
                if (base, axis) in _AXIS_BAPS:
                    other = _AXIS_BAPS[(base, axis)]
                    found = bap_table.BY_NAME[prefix + other].id if other else None
                else:
                    found = _joint_bap(hanim, kinds) if hanim else None
                if found is None:
                    if next_extension > bap_table.N_BAPS:
                        raise SigncastError("the avatar needs more extension BAPs than the 110 the standard has")
                    found = next_extension
                    reasons[found] = _extension_reason(base, hanim, axis)
                    next_extension += 1
                ids.append(found)
            frame = rotations.from_matrix(_frame(skeleton, name, base))
            bones.append(BoneBaps(name, hanim or "-", tuple(ids), frame,
                                  neutral.get(name, rotations.IDENTITY.copy()), suffix == ".R"))
    return AvatarBapMap(skeleton, tuple(bones), reasons)


def _bone_rotations(motion: Motion, bap_map: AvatarBapMap) -> np.ndarray:
    """(T, B, 4) local rotation of every mapped bone (B = len(bap_map.bones)); bones the motion lacks
    are at the rig's rest (identity)."""
    mapped, source = _bone_sources(motion.bone_names, bap_map.bone_names)
    q = np.zeros((motion.n_frames, len(bap_map.bones), 4))
    q[..., 0] = 1.0
    q[:, mapped] = motion.rotations[:, source]
    return q


@functools.lru_cache(maxsize=64)
def _bone_sources(motion_bones: tuple[str, ...], mapped_bones: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray]:
    """(indices into mapped_bones, indices into motion_bones) of the mapped_bones a motion has, in mapped_bones
    order."""
    names = {n: k for k, n in enumerate(motion_bones)}
    pairs = [(k, names[bone]) for k, bone in enumerate(mapped_bones) if bone in names]
    mapped, source = (np.array(v, dtype=np.int64) for v in zip(*pairs)) if pairs else (np.zeros(0, np.int64),) * 2
    return mapped, source


def motion_to_baps(motion: Motion, bap_map: AvatarBapMap | None = None, *, strict: bool = True) -> np.ndarray:
    """(T, 296) int64 BAP values (index = id - 1; 1e-5 rad, mm) of a Motion on the avatar, relative to
    the MPEG-4 neutral posture (bones the motion lacks are at the rig's rest, which is not neutral for
    the arms and hands).

    strict: raise SigncastError when the motion rotates a bone that no BAP carries (more than
    1e-4 rad), since that motion would be lost.
    """
    bap_map = bap_map or avatar_bap_map()
    if strict:
        _, present = _bone_sources(motion.bone_names, bap_map._unmapped)
    if strict and len(present):
        # rotations.angle_between(q, IDENTITY) is 2 acos(|w|), largest where |w| is smallest
        smallest_w = np.abs(motion.rotations[:, present, 0]).min(axis=0, initial=1.0)
        turned = 2.0 * np.arccos(np.clip(smallest_w, 0.0, 1.0)) > 1e-4
        lost = [motion.bone_names[i] for i in present[turned]]
        if lost:
            raise SigncastError(f"motion rotates bones that no BAP carries: {', '.join(lost[:6])}")
    frames, neutrals, columns, signs = bap_map.arrays
    mapped, source = _bone_sources(motion.bone_names, bap_map.bone_names)
    values = np.zeros((motion.n_frames, bap_table.N_BAPS), dtype=np.int64)
    # np.round(rotations.to_euler(F^-1 (N^-1 q) F, EULER_ORDER) * signs / unit) in one compiled pass
    # (media/bap_rotations.py)
    bap_loops.anatomical_bap_levels(motion.rotations, mapped, source, frames, neutrals, columns, signs,
                                    bap_table.ROTATION_UNIT_RAD, values)
    translation_mm = np.round(motion.root_translation / bap_table.TRANSLATION_UNIT_M)
    if not np.all(np.abs(translation_mm) < 2.0 ** 62):     # the int64 cast would wrap (and warn)
        raise SigncastError(f"root translation of {np.abs(motion.root_translation).max():.3g} m cannot be sent as BAPs")
    translation_mm = translation_mm.astype(np.int64)
    values[:, 181 - 1] = translation_mm[:, 1]   # vertical
    values[:, 182 - 1] = translation_mm[:, 0]   # lateral
    values[:, 183 - 1] = translation_mm[:, 2]   # frontal
    return values


def baps_to_motion(values: np.ndarray, fps: float, bap_map: AvatarBapMap | None = None, *,
                   faps: np.ndarray | None = None) -> Motion:
    """Motion of all mapped avatar bones from (T, 296) BAP values (inverse of motion_to_baps): all
    zero is the MPEG-4 neutral posture. faps: the Motion's (T, 68) FAP values, or None."""
    bap_map = bap_map or avatar_bap_map()
    values = np.asarray(values)
    if values.ndim != 2 or values.shape[1] != bap_table.N_BAPS:
        raise SigncastError(f"BAP values must be (T, {bap_table.N_BAPS}), got {values.shape}")
    frames, neutrals, columns, signs = bap_map.arrays
    # N (F E F^-1) with E = rotations.from_euler(angles, EULER_ORDER), normalised, w >= 0, of the angles
    # values[:, columns] x unit x signs, in one compiled pass (media/bap_rotations.py; within 1e-12 of those
    # NumPy/scipy calls)
    if np.issubdtype(values.dtype, np.integer):
        q = bap_loops.bap_value_rotations(values.astype(np.int64, copy=False), columns, signs,
                                              bap_table.ROTATION_UNIT_RAD, frames, neutrals)
    else:
        angles = values[:, columns].astype(np.float64) * bap_table.ROTATION_UNIT_RAD * signs
        q = bap_loops.bap_rotations(np.ascontiguousarray(angles), frames, neutrals)
    names = bap_map.bone_names
    translation = np.stack([values[:, 182 - 1], values[:, 181 - 1], values[:, 183 - 1]], axis=1) * bap_table.TRANSLATION_UNIT_M
    return Motion(fps, names, q, translation.astype(np.float64), faps)


def extension_report(motions: Iterable[Motion | np.ndarray] | None = None,
                     bap_map: AvatarBapMap | None = None) -> list[ExtensionAxis]:
    """The avatar bone axes that extension BAPs carry, and why the standard cannot.

    motions: None lists every allocated extension BAP (what the standard cannot express on this
    avatar); otherwise Motions or (T, 296) BAP value arrays, and only the extension BAPs they move
    are listed: those whose largest |value| exceeds half the BAP's quantisation step (a smaller value
    is 0 at every Q), with that largest value and the spread (max - min) over all the motions.
    """
    bap_map = bap_map or avatar_bap_map()
    ids = bap_map.extension_baps
    if motions is None:
        return [ExtensionAxis(int(i), *_bone_axis(bap_map, int(i)), bap_map.extension_reasons[int(i)]) for i in ids]
    arrays = [motion_to_baps(m, bap_map) if isinstance(m, Motion) else np.asarray(m) for m in motions]
    if not arrays:
        return []
    values = np.concatenate(arrays)[:, ids - 1]
    steps = bap_table.steps()[ids - 1]
    largest = np.abs(values).max(axis=0)
    spread = values.max(axis=0) - values.min(axis=0)
    return [ExtensionAxis(int(i), *_bone_axis(bap_map, int(i)), bap_map.extension_reasons[int(i)], int(m), int(s))
            for i, m, s, step in zip(ids, largest, spread, steps) if m > step // 2]


def _bone_axis(bap_map: AvatarBapMap, bap_id: int) -> tuple[str, str]:
    bone, k = bap_map.bone_of_bap[bap_id]
    return bone, AXIS_NAMES[k]

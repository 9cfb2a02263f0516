"""The avatar: a seamless skinned model in the SMS sense (seed 000 §3.2-3.3).

One skin coordinate list shared by all shapes (body skin, eyes), triangles with a part label
each (DESIGN.md: 1 body/clothes, 2 head, 3 left hand, 4 right hand), a bone hierarchy, skin
weights, and the muscles that deform the skin on top of the bones. Units are metres, Y up,
the avatar faces +Z, so its left side is +X. "Left" and "right" are the avatar's own.

Bone frames: at rest every joint frame is aligned with the world axes and sits at the bone's
head. A bone's local transform (class SBBone) maps rest-pose world coordinates of its subtree
to where the parent's frame puts them, so the world transform of a bone is directly its
skinning matrix (no inverse bind matrix): M_b = M_parent(b) . T_b.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from kernels import immutable
from kernels.skinning import SkinWeights
from media import rotations
from media.errors import SigncastError

ASSET_DIR = Path(__file__).resolve().parent / "assets"
DEFAULT_AVATAR = ASSET_DIR / "makehuman_base.npz"


@dataclass(frozen=True)
class Skeleton:
    """Bone hierarchy at rest, parents before children.

    names: B bone names; parents: (B,) int32, -1 for the root;
    heads, tails: (B, 3) float64 rest-pose joint positions in metres.
    """
    names: tuple[str, ...]
    parents: np.ndarray
    heads: np.ndarray
    tails: np.ndarray

    def __len__(self) -> int:
        return len(self.names)

    @functools.cached_property
    def _index(self) -> dict[str, int]:
        return {name: i for i, name in enumerate(self.names)}

    def index(self, name: str) -> int:
        try:
            return self._index[name]
        except KeyError:
            raise SigncastError(f"unknown bone {name!r}") from None

    def children(self, bone: int) -> list[int]:
        return [int(i) for i in np.flatnonzero(self.parents == bone)]

    def offsets(self) -> np.ndarray:
        """(B, 3) rest offset of each joint from its parent's joint, metres (the root's: its head)."""
        parent_heads = np.where(self.parents[:, None] >= 0, self.heads[np.maximum(self.parents, 0)], 0.0)
        return self.heads - parent_heads

    def depth_levels(self) -> list[np.ndarray]:
        """Bone indices grouped by depth in the hierarchy (level 0 holds the root)."""
        depth = np.zeros(len(self), dtype=np.int64)
        for b in range(len(self)):
            if self.parents[b] >= 0:
                depth[b] = depth[self.parents[b]] + 1
        return [np.flatnonzero(depth == d) for d in range(depth.max() + 1)]

    def subtree(self, bone: int) -> np.ndarray:
        """(B,) bool: the bone and every descendant."""
        inside = np.zeros(len(self), dtype=bool)
        inside[bone] = True
        for b in range(len(self)):  # parents come first, so one pass suffices
            if self.parents[b] >= 0 and inside[self.parents[b]]:
                inside[b] = True
        return inside


@dataclass(frozen=True)
class BoneTransform:
    """The SBBone transform fields (seed 000 §3.2.2.2, §3.3.1), composed as eq. 3.5.

    center: (3,) metres, the point the rotation and scale act about (C_b);
    rotation: (4,) quaternion (R_b); translation: (3,) metres (TR_b);
    scale: (3,) factors along the scale axes (S_b; 1 1 1 is no scale);
    scale_orientation: (4,) quaternion orienting the scale axes (SR_b).
    """
    center: np.ndarray
    rotation: np.ndarray = field(default_factory=lambda: rotations.IDENTITY.copy())
    translation: np.ndarray = field(default_factory=lambda: np.zeros(3))
    scale: np.ndarray = field(default_factory=lambda: np.ones(3))
    scale_orientation: np.ndarray = field(default_factory=lambda: rotations.IDENTITY.copy())

    def matrix(self) -> np.ndarray:
        """(4, 4) T = TR . C . R . SR . S . SR^-1 . C^-1 (eq. 3.5)."""
        def affine(linear=np.eye(3), offset=np.zeros(3)):
            m = np.eye(4)
            m[:3, :3] = linear
            m[:3, 3] = offset
            return m
        sr = rotations.to_matrix(self.scale_orientation)
        return (affine(offset=self.translation) @ affine(offset=self.center)
                @ affine(rotations.to_matrix(self.rotation)) @ affine(sr) @ affine(np.diag(self.scale))
                @ affine(sr.T) @ affine(offset=-np.asarray(self.center)))


@dataclass(frozen=True)
class Muscle:
    """An SBMuscle (seed 000 §3.2.3): a NURBS curve attached to a bone, with a tube of influence.

    bone: index of the bone the curve follows; control_points: (K, 3) metres in the rest pose;
    weights: (K,) NURBS weights; knots: (K + degree + 1,) knot vector; degree: curve degree;
    radius: tube radius in metres; falloff: code of eq. 3.3/3.6 (-1 x^3, 0 x^2, 1 x, 2 sin, 3 sqrt, 4 cbrt);
    driver: (bone index, max bulge in metres) — the joint whose flexion swells the muscle.
    bulge_direction: (3,) unit vector (rest pose) along which control points move when the muscle
    contracts; bulge_profile: (K,) share of max_bulge for each control point; bulge_weight: NURBS
    weight factor the profiled control points reach at full contraction; flexion_bones: (proximal,
    joint, distal) bones whose heads give the driving joint's flexion angle.
    """
    name: str
    bone: int
    control_points: np.ndarray
    weights: np.ndarray
    knots: np.ndarray
    degree: int
    radius: float
    falloff: int
    driver_bone: int
    max_bulge: float
    bulge_direction: np.ndarray | None = None
    bulge_profile: np.ndarray | None = None
    bulge_weight: float = 1.0
    flexion_bones: tuple[int, ...] = ()


@dataclass(frozen=True)
class Avatar:
    """A skinned avatar.

    vertices: (V, 3) float32 rest positions, metres; triangles: (F, 3) int32;
    triangle_part: (F,) uint8 part label; triangle_shape: (F,) uint8 index into shape_names;
    skeleton; weights: kernels.skinning.SkinWeights (given by the asset); muscles.
    """
    name: str
    vertices: np.ndarray
    triangles: np.ndarray
    triangle_part: np.ndarray
    triangle_shape: np.ndarray
    shape_names: tuple[str, ...]
    skeleton: Skeleton
    weights: SkinWeights
    muscles: tuple[Muscle, ...] = ()

    def vertex_part(self) -> np.ndarray:
        """(V,) uint8 part of each vertex (from the triangles that use it; the last one wins)."""
        part = np.zeros(len(self.vertices), dtype=np.uint8)
        part[self.triangles.reshape(-1)] = np.repeat(self.triangle_part, 3)
        return part


def load_avatar(path: str | Path | None = None) -> Avatar:
    """Load an avatar .npz (default: the vendored MakeHuman base mesh). Cached per path."""
    return _load_avatar(str(Path(path) if path else DEFAULT_AVATAR))


@functools.lru_cache(maxsize=4)
def _load_avatar(path: str) -> Avatar:
    if not Path(path).is_file():
        raise SigncastError(f"avatar file not found: {path}")
    try:
        data = np.load(path, allow_pickle=False)
        # Immutable (bytes-backed) arrays: the avatar is cached and shared, and the kernels reuse their
        # checks and uploads of immutable inputs without comparing them again every frame.
        skeleton = Skeleton(
            names=tuple(str(n) for n in data["bone_names"]),
            parents=immutable(data["bone_parents"].astype(np.int32)),
            heads=immutable(data["bone_heads"].astype(np.float64)),
            tails=immutable(data["bone_tails"].astype(np.float64)),
        )
        avatar = Avatar(
            name=Path(path).stem,
            vertices=immutable(data["vertices"].astype(np.float32)),
            triangles=immutable(data["triangles"].astype(np.int32)),
            triangle_part=immutable(data["triangle_part"].astype(np.uint8)),
            triangle_shape=immutable(data["triangle_shape"].astype(np.uint8)),
            shape_names=tuple(str(n) for n in data["shape_names"]),
            skeleton=skeleton,
            weights=SkinWeights(immutable(data["weight_indptr"].astype(np.int32)),
                                immutable(data["weight_bones"].astype(np.int32)),
                                immutable(data["weight_values"].astype(np.float32))),
        )
    except (KeyError, ValueError, OSError) as error:
        raise SigncastError(f"not a signcast avatar file: {path} ({error})") from None
    from media.muscles import default_muscles   # muscles are defined on top of the loaded skeleton
    return Avatar(**{**avatar.__dict__, "muscles": default_muscles(avatar)})

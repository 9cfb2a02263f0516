"""BVH (Biovision hierarchy) export and import of a Motion.

Units in the file are centimetres and degrees. Every joint has a world-aligned rest frame, so a
joint's OFFSET is its rest head minus its parent's; the root's OFFSET is its rest head and its
position channels hold its absolute position (rest head + root translation), which parsers that
replace or that ignore the offset read the same. Rotation channels are Zrotation Xrotation
Yrotation: the local rotation is Rz . Rx . Ry (intrinsic Z, then X, then Y), as most tools expect.
Leaf bones end with an End Site at their tail.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from media import rotations
from media.avatar import Skeleton
from media.errors import SigncastError
from media.kinematics import align_to_skeleton
from media.motion import Motion

CM_PER_M = 100.0
ROTATION_CHANNELS = ("Zrotation", "Xrotation", "Yrotation")
_EULER_ORDER = "ZXYr"


@dataclass(frozen=True)
class BvhHierarchy:
    """What a BVH file says of the skeleton: names, parents (-1 root), offsets (B, 3) metres, end sites (B, 3) or NaN."""
    names: tuple[str, ...]
    parents: np.ndarray
    offsets: np.ndarray
    end_sites: np.ndarray

    def to_skeleton(self) -> Skeleton:
        heads = np.zeros((len(self.names), 3))
        for b, parent in enumerate(self.parents):
            heads[b] = self.offsets[b] + (heads[parent] if parent >= 0 else 0.0)
        tails = np.where(np.isnan(self.end_sites), heads, heads + np.nan_to_num(self.end_sites))
        return Skeleton(self.names, np.asarray(self.parents, dtype=np.int32), heads, tails)


def write_bvh(path: str | Path, motion: Motion, skeleton: Skeleton) -> None:
    """Write motion (on skeleton's bones; bones the motion lacks stay at rest) as a BVH file."""
    q = align_to_skeleton(motion, skeleton)
    euler_deg = np.degrees(rotations.to_euler(q, _EULER_ORDER))            # (T, B, 3)
    offsets = skeleton.offsets() * CM_PER_M
    lines = ["HIERARCHY"]

    def emit(bone: int, depth: int) -> None:
        pad = "  " * depth
        kind = "ROOT" if skeleton.parents[bone] < 0 else "JOINT"
        lines.append(f"{pad}{kind} {skeleton.names[bone]}")
        lines.append(f"{pad}{{")
        lines.append(f"{pad}  OFFSET {offsets[bone][0]:.6f} {offsets[bone][1]:.6f} {offsets[bone][2]:.6f}")
        if skeleton.parents[bone] < 0:
            lines.append(f"{pad}  CHANNELS 6 Xposition Yposition Zposition {' '.join(ROTATION_CHANNELS)}")
        else:
            lines.append(f"{pad}  CHANNELS 3 {' '.join(ROTATION_CHANNELS)}")
        children = skeleton.children(bone)
        for child in children:
            emit(child, depth + 1)
        if not children:
            end = (skeleton.tails[bone] - skeleton.heads[bone]) * CM_PER_M
            lines.append(f"{pad}  End Site")
            lines.append(f"{pad}  {{")
            lines.append(f"{pad}    OFFSET {end[0]:.6f} {end[1]:.6f} {end[2]:.6f}")
            lines.append(f"{pad}  }}")
        lines.append(f"{pad}}}")

    roots = np.flatnonzero(skeleton.parents < 0)
    if len(roots) != 1:
        raise SigncastError(f"BVH needs exactly one root bone, the skeleton has {len(roots)}")
    emit(int(roots[0]), 0)
    order = _depth_first(skeleton, int(roots[0]))
    lines.append("MOTION")
    lines.append(f"Frames: {motion.n_frames}")
    lines.append(f"Frame Time: {1.0 / motion.fps:.10f}")
    root_position = (skeleton.heads[roots[0]] + motion.root_translation) * CM_PER_M
    for t in range(motion.n_frames):
        values = [f"{v:.9f}" for v in root_position[t]]
        for bone in order:
            values.extend(f"{v:.9f}" for v in euler_deg[t, bone])
        lines.append(" ".join(values))
    Path(path).write_text("\n".join(lines) + "\n")


def _depth_first(skeleton: Skeleton, root: int) -> list[int]:
    order, stack = [], [root]
    while stack:
        bone = stack.pop()
        order.append(bone)
        stack.extend(reversed(skeleton.children(bone)))
    return order


def read_bvh(path: str | Path) -> tuple[Motion, BvhHierarchy]:
    """Read a BVH file into (Motion, hierarchy). Any rotation channel order is accepted."""
    path = Path(path)
    if not path.is_file():
        raise SigncastError(f"BVH file not found: {path}")
    tokens = path.read_text().split()
    try:
        return _parse(tokens)
    except (IndexError, ValueError) as error:
        raise SigncastError(f"not a valid BVH file: {path} ({error})") from None


def _parse(tokens: list[str]) -> tuple[Motion, BvhHierarchy]:
    position = 0

    def take() -> str:
        nonlocal position
        position += 1
        return tokens[position - 1]

    if take() != "HIERARCHY":
        raise ValueError("missing HIERARCHY")
    names, parents, offsets, end_sites, channels = [], [], [], [], []
    stack: list[int] = []
    while True:
        token = take()
        if token in ("ROOT", "JOINT"):
            names.append(take())
            parents.append(stack[-1] if stack else -1)
            end_sites.append([np.nan] * 3)
            if take() != "{":
                raise ValueError("expected '{'")
            stack.append(len(names) - 1)
        elif token == "OFFSET":
            offsets.append([float(take()) for _ in range(3)])
        elif token == "CHANNELS":
            channels.append((stack[-1], [take() for _ in range(int(take()))]))
        elif token == "End":
            take()  # "Site"
            if take() != "{" or take() != "OFFSET":
                raise ValueError("bad End Site")
            end_sites[stack[-1]] = [float(take()) for _ in range(3)]
            if take() != "}":
                raise ValueError("bad End Site")
        elif token == "}":
            stack.pop()
        elif token == "MOTION":
            break
        else:
            raise ValueError(f"unexpected token {token!r}")
    if stack or len(offsets) != len(names):
        raise ValueError("unbalanced hierarchy")
    if take() != "Frames:":
        raise ValueError("missing Frames:")
    n_frames = int(take())
    if take() != "Frame" or take() != "Time:":
        raise ValueError("missing Frame Time:")
    frame_time = float(take())
    n_channels = sum(len(c) for _, c in channels)
    values = np.array(tokens[position:position + n_frames * n_channels], dtype=np.float64)
    if len(values) != n_frames * n_channels or frame_time <= 0:
        raise ValueError(f"expected {n_frames} frames of {n_channels} values")
    values = values.reshape(n_frames, n_channels)

    B = len(names)
    q = np.zeros((n_frames, B, 4))
    q[..., 0] = 1.0
    root_position = np.zeros((n_frames, 3))
    column = 0
    offsets_m = np.asarray(offsets) / CM_PER_M
    for bone, names_of_channels in channels:
        rotation = np.tile(rotations.IDENTITY, (n_frames, 1))
        for name in names_of_channels:
            data = values[:, column]
            column += 1
            axis = name[0].upper()
            if name.endswith("position"):
                root_position[:, "XYZ".index(axis)] = data / CM_PER_M
            elif name.endswith("rotation"):
                unit = np.zeros(3)
                unit["XYZ".index(axis)] = 1.0
                rotation = rotations.multiply(rotation, rotations.from_axis_angle(np.tile(unit, (n_frames, 1)), np.radians(data)))
            else:
                raise ValueError(f"unknown channel {name}")
        q[:, bone] = rotations.canonical(rotation)
    root = parents.index(-1)
    hierarchy = BvhHierarchy(tuple(names), np.asarray(parents, dtype=np.int32), offsets_m,
                             np.asarray(end_sites, dtype=np.float64) / CM_PER_M)
    motion = Motion(1.0 / frame_time, tuple(names), q, root_position - offsets_m[root])
    return motion, hierarchy

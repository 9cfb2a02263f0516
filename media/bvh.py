"""BVH (Biovision hierarchy) export and import of a Motion.

Units in the file are centimetres and degrees. Every joint has a world-aligned rest frame, so a
joint's OFFSET is its rest head minus its parent's; the root's OFFSET is its rest head and its
position channels hold its absolute position (rest head + root translation), which parsers that
replace or that ignore the offset read the same. Rotation channels are Zrotation Xrotation
Yrotation: the local rotation is Rz . Rx . Ry (intrinsic Z, then X, then Y), as most tools expect.
Leaf bones end with an End Site at their tail.

Reading: a Motion carries rotations of every joint but a translation of the root only, so a file
with position channels on another joint is rejected (never folded into the root). BVH has no
checksum: a damaged digit decodes to another angle without any sign. The reader rejects what it can
see: a frame line whose value count differs from the hierarchy's channel count, a frame count that
differs from the frame lines present, values that are not finite, a frame rate outside
media/text_files.py's range, a joint named twice, more than MAX_JOINTS joints, and more than
media/text_files.MAX_VALUES decoded values (frames x (channels + 4 per joint)), checked before allocating.
"""
from __future__ import annotations

import reprlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from media import rotations, text_files
from media.avatar import Skeleton
from media.errors import SigncastError
from media.kinematics import align_to_skeleton
from media.motion import Motion

CM_PER_M = 100.0
ROTATION_CHANNELS = ("Zrotation", "Xrotation", "Yrotation")
_EULER_ORDER = "ZXYr"
CHANNEL_NAMES = ("Xposition", "Yposition", "Zposition", "Xrotation", "Yrotation", "Zrotation")
MAX_JOINTS = 4096


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


def write_bvh(path: str | Path, motion: Motion, skeleton: Skeleton, avatar=None) -> None:
    """Write motion (on skeleton's bones; bones the motion lacks stay at rest) as a BVH file.

    A motion with FAPs has its face played on the face bones first (media.face_rig.with_face_bones, on `avatar`,
    default the vendored one, whose FAPU scale them), so the file's face joints move as the renderer's do; BVH
    has no FAP channels, so the FAPs themselves are not written."""
    if motion.faps is not None:
        from media.face_rig import with_face_bones        # the face rig loads the avatar: imported when needed
        motion = with_face_bones(motion, avatar)
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
    tokens = _Tokens(text_files.read_lines(path, "BVH file"))
    try:
        return _parse(tokens, f"BVH file {path}")
    except ValueError as error:
        raise SigncastError(f"not a valid BVH file: {path} (line {tokens.line}: {error})") from None


def _finite(token: str) -> float:
    try:
        value = float(token)
    except ValueError:
        raise ValueError(f"expected a number, got {reprlib.repr(token)}") from None
    if not np.isfinite(value):
        raise ValueError(f"values must be finite numbers, got {reprlib.repr(token)}")
    return value


class _Tokens:
    """Whitespace-separated tokens of numbered lines, with the line of the last token taken."""

    def __init__(self, lines):
        self.lines = enumerate(lines, start=1)
        self.line = 0
        self.pending: list[str] = []

    def take(self) -> str:
        while not self.pending:
            self.line, text = next(self.lines, (self.line, None))
            if text is None:
                raise ValueError("unexpected end of file")
            self.pending = text.split()[::-1]
        return self.pending.pop()

    def expect(self, word: str) -> None:
        token = self.take()
        if token != word:
            raise ValueError(f"expected {word!r}, got {reprlib.repr(token)}")

    def numbers(self, count: int) -> list[float]:
        return [_finite(self.take()) for _ in range(count)]


def _parse(tokens: _Tokens, what: str) -> tuple[Motion, BvhHierarchy]:
    """The hierarchy (offsets and end sites in cm), then one line of channel values per frame."""
    names, parents, offsets, end_sites, channels = [], [], [], [], []
    stack: list[int] = []

    def open_joint(parent: int) -> None:
        name = tokens.take()
        if name in names:
            raise ValueError(f"joint {reprlib.repr(name)} is defined twice")
        if len(names) == MAX_JOINTS:
            raise ValueError(f"more than {MAX_JOINTS} joints")
        tokens.expect("{")
        tokens.expect("OFFSET")
        names.append(name)
        parents.append(parent)
        offsets.append(tokens.numbers(3))
        end_sites.append([np.nan] * 3)
        tokens.expect("CHANNELS")
        count = tokens.take()
        if count not in ("0", "1", "2", "3", "4", "5", "6"):
            raise ValueError(f"joint {reprlib.repr(name)} has {reprlib.repr(count)} channels, expected 0 to 6")
        joint_channels = [tokens.take() for _ in range(int(count))]
        if any(c not in CHANNEL_NAMES for c in joint_channels) or len(set(joint_channels)) != len(joint_channels):
            raise ValueError(f"joint {reprlib.repr(name)} has channels {reprlib.repr(' '.join(joint_channels))}; "
                             f"expected distinct ones of {', '.join(CHANNEL_NAMES)}")
        if parent >= 0 and any(c.endswith("position") for c in joint_channels):
            raise SigncastError(f"{what}: joint {reprlib.repr(name)} has position channels; "
                                "non-root translations are not supported")
        channels.append(joint_channels)
        stack.append(len(names) - 1)

    tokens.expect("HIERARCHY")
    tokens.expect("ROOT")
    open_joint(-1)
    while stack:
        token = tokens.take()
        if token == "JOINT":
            open_joint(stack[-1])
        elif token == "End":
            for word in ("Site", "{", "OFFSET"):
                tokens.expect(word)
            end_sites[stack[-1]] = tokens.numbers(3)
            tokens.expect("}")
        elif token == "}":
            stack.pop()
        else:
            raise ValueError(f"unexpected {reprlib.repr(token)} in the hierarchy")
    for word in ("MOTION", "Frames:"):
        tokens.expect(word)
    frames_text = tokens.take()
    if not (frames_text.isascii() and frames_text.isdigit() and len(frames_text) <= 18):
        raise ValueError(f"bad frame count {reprlib.repr(frames_text)}")
    n_frames = int(frames_text)
    tokens.expect("Frame")
    tokens.expect("Time:")
    frame_time = _finite(tokens.take())
    if tokens.pending:
        raise ValueError("values on the Frame Time line")
    text_files.check_fps(1.0 / frame_time if frame_time > 0 else 0.0, what)
    n_channels = sum(len(c) for c in channels)
    if n_channels == 0:
        raise ValueError("no channels")
    text_files.check_size(n_frames, n_channels + 4 * len(names), what)

    values = np.empty((n_frames, n_channels))                  # degrees and cm
    t = 0
    for number, text in tokens.lines:
        tokens.line, row = number, text.split()
        if not row:
            continue
        if t == n_frames:
            raise ValueError(f"more than the {n_frames} frames announced")
        if len(row) != n_channels:
            raise ValueError(f"{len(row)} values in a frame of {n_channels} channels")
        try:
            values[t] = row
        except ValueError:
            raise ValueError("a frame holds a value that is not a number") from None
        if not np.all(np.isfinite(values[t])):
            raise ValueError("values must be finite numbers")
        t += 1
    if t != n_frames:
        raise ValueError(f"{t} frames of the {n_frames} announced")

    offsets_m = np.asarray(offsets) / CM_PER_M
    q = np.zeros((n_frames, len(names), 4))
    root_position = np.tile(offsets_m[0], (n_frames, 1))       # a root without position channels stays at its offset
    column = 0
    for bone, names_of_channels in enumerate(channels):
        rotation = np.tile(rotations.IDENTITY, (n_frames, 1))
        for name in names_of_channels:
            data = values[:, column]
            column += 1
            axis = "XYZ".index(name[0])
            if name.endswith("position"):
                root_position[:, axis] = data / CM_PER_M
            else:
                unit = np.zeros(3)
                unit[axis] = 1.0
                rotation = rotations.multiply(rotation, rotations.from_axis_angle(np.tile(unit, (n_frames, 1)), np.radians(data)))
        q[:, bone] = rotations.canonical(rotation)
    hierarchy = BvhHierarchy(tuple(names), np.asarray(parents, dtype=np.int32), offsets_m,
                             np.asarray(end_sites, dtype=np.float64) / CM_PER_M)
    motion = Motion(1.0 / frame_time, tuple(names), q, root_position - offsets_m[0])
    return motion, hierarchy

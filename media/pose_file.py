"""Reading a `.pose` file (pose-format) of MediaPipe Holistic keypoints, checked like any decoder's input.

pose-format's reader trusts its input: a damaged file raises whatever struct, numpy or Python raises,
and a header may announce a body of any size. `read_pose` reads the header with pose-format, then
checks, before the body is read, that the layout is the lexicon's (the components and point names
of `HOLISTIC_LAYOUT`, format XYZC) or the lexicon's followed by the two hands' world landmarks
(`WORLD_LAYOUT`: what `signcast pose` writes) and that the body the header announces (frames x people x points
x 4 float32) is exactly the bytes that follow, so nothing is allocated that the file does not hold.
Every failure is a SigncastError.

`write_pose` writes a SignClip in the lexicon's layout, or in WORLD_LAYOUT when the clip carries the hands'
world landmarks (pose-format version 0.2, one person; pose-format allows further components), masked where the
confidence is 0, so that `read_pose` and pose-format's own `Pose.read` read it back.
"""
from __future__ import annotations

import struct
from pathlib import Path

import numpy as np

from media.errors import SigncastError
from media.lexicon import SignClip

_POSE = ("NOSE", "LEFT_EYE_INNER", "LEFT_EYE", "LEFT_EYE_OUTER", "RIGHT_EYE_INNER", "RIGHT_EYE",
         "RIGHT_EYE_OUTER", "LEFT_EAR", "RIGHT_EAR", "MOUTH_LEFT", "MOUTH_RIGHT", "LEFT_SHOULDER",
         "RIGHT_SHOULDER", "LEFT_ELBOW", "RIGHT_ELBOW", "LEFT_WRIST", "RIGHT_WRIST", "LEFT_PINKY",
         "RIGHT_PINKY", "LEFT_INDEX", "RIGHT_INDEX", "LEFT_THUMB", "RIGHT_THUMB", "LEFT_HIP", "RIGHT_HIP",
         "LEFT_KNEE", "RIGHT_KNEE", "LEFT_ANKLE", "RIGHT_ANKLE", "LEFT_HEEL", "RIGHT_HEEL", "LEFT_FOOT_INDEX",
         "RIGHT_FOOT_INDEX")
_HAND = ("WRIST", "THUMB_CMC", "THUMB_MCP", "THUMB_IP", "THUMB_TIP", "INDEX_FINGER_MCP", "INDEX_FINGER_PIP",
         "INDEX_FINGER_DIP", "INDEX_FINGER_TIP", "MIDDLE_FINGER_MCP", "MIDDLE_FINGER_PIP", "MIDDLE_FINGER_DIP",
         "MIDDLE_FINGER_TIP", "RING_FINGER_MCP", "RING_FINGER_PIP", "RING_FINGER_DIP", "RING_FINGER_TIP",
         "PINKY_MCP", "PINKY_PIP", "PINKY_DIP", "PINKY_TIP")
# component name -> point names, in file order: the layout of every lexicon clip (MediaPipe Holistic)
HOLISTIC_LAYOUT = (("POSE_LANDMARKS", _POSE), ("FACE_LANDMARKS", tuple(str(i) for i in range(478))),
                   ("LEFT_HAND_LANDMARKS", _HAND), ("RIGHT_HAND_LANDMARKS", _HAND), ("POSE_WORLD_LANDMARKS", _POSE))
# The hand landmark model's 21 world landmarks per hand (metres, origin the hand's geometric centre, axes the
# image's: x right, y down, z away from the camera), as further components after the lexicon's five.
HAND_WORLD_COMPONENTS = ("LEFT_HAND_WORLD_LANDMARKS", "RIGHT_HAND_WORLD_LANDMARKS")
WORLD_LAYOUT = HOLISTIC_LAYOUT + tuple((name, _HAND) for name in HAND_WORLD_COMPONENTS)
LAYOUTS = (HOLISTIC_LAYOUT, WORLD_LAYOUT)
POINT_FORMAT = "XYZC"
# body header per version: (struct, whether it carries the frame count)
_BODY_HEADERS = {0.1: (struct.Struct("<HHH"), False), 0.2: (struct.Struct("<fIH"), True)}


def read_pose(source: str | Path | bytes) -> SignClip:
    """Keypoints of a `.pose` file (a path, or the file's bytes) in the lexicon's layout (HOLISTIC_LAYOUT) or in
    the lexicon's plus the hands' world landmarks (WORLD_LAYOUT).

    Returns a SignClip without lexicon entry: fps; points: component -> (T, N, 3) float64 (x, y
    pixels right/down, z depth; world components metres) of the first person; confidence: component -> (T, N) float64 in
    [0, 1], 0 where a point is masked or not finite (its coordinates are then 0).
    """
    from pose_format.numpy import NumPyPoseBody  # heavy import, only when a file is read
    from pose_format.pose_header import PoseHeader
    from pose_format.utils.reader import BufferReader

    where = "pose data" if isinstance(source, (bytes, bytearray, memoryview)) else f"pose file {source}"
    if isinstance(source, (bytes, bytearray, memoryview)):
        data = bytes(source)
    else:
        try:
            data = Path(source).read_bytes()
        except OSError as error:
            raise SigncastError(f"cannot read {where}: {error.strerror}") from None
    reader = BufferReader(data)
    try:
        header = PoseHeader.read(reader)
    except Exception as error:  # pose-format raises struct, numpy, unicode and value errors on damage
        raise SigncastError(f"damaged {where}: unreadable header ({type(error).__name__}: {error})") from None
    layout = _check_layout(header, where)
    version = round(float(header.version), 3)
    if version not in _BODY_HEADERS:
        raise SigncastError(f"{where}: unsupported .pose version {header.version}")
    body_header, counts_frames = _BODY_HEADERS[version]
    left = len(data) - reader.read_offset - body_header.size
    if left < 0:
        raise SigncastError(f"damaged {where}: truncated before the body")
    fps, frames, people = body_header.unpack_from(data, reader.read_offset)
    frame_bytes = people * sum(len(points) for _, points in layout) * len(POINT_FORMAT) * 4
    if not counts_frames:                       # version 0.1 infers the frame count from the size
        frames = left // frame_bytes if frame_bytes else 0
    if people < 1 or frames < 1 or frames * frame_bytes != left:
        raise SigncastError(f"damaged {where}: the header announces {frames} frames of {people} people "
                            f"({frames * frame_bytes} bytes), the file holds {left} bytes of body")
    if not (np.isfinite(fps) and fps > 0):
        raise SigncastError(f"damaged {where}: bad frame rate {fps}")
    try:
        body = NumPyPoseBody.read(header, reader)
    except Exception as error:
        raise SigncastError(f"damaged {where}: unreadable body ({type(error).__name__}: {error})") from None
    return _clip(float(fps), body.data, body.confidence, layout)


def _check_layout(header, where: str) -> tuple:
    """The layout (HOLISTIC_LAYOUT or WORLD_LAYOUT) the header has; SigncastError naming what it has otherwise."""
    layout = tuple((c.name, tuple(c.points)) for c in header.components)
    if layout not in LAYOUTS or any(c.format != POINT_FORMAT for c in header.components):
        found = ", ".join(f"{c.name} ({len(c.points)} points, {c.format})" for c in header.components)
        raise SigncastError(f"{where} is not in the MediaPipe Holistic layout of the lexicon "
                            f"({', '.join(f'{name} {len(points)}' for name, points in HOLISTIC_LAYOUT)}; "
                            f"optionally followed by {' 21, '.join(HAND_WORLD_COMPONENTS)} 21); "
                            f"it has: {found or 'no components'}")
    return layout


def _clip(fps: float, data: np.ma.MaskedArray, confidence: np.ndarray, layout: tuple = HOLISTIC_LAYOUT) -> SignClip:
    """SignClip of the first person of a body: data (T, P, N, 3) masked float32, confidence (T, P, N)."""
    values = np.ma.getdata(data)[:, 0].astype(np.float64)
    mask = np.ma.getmaskarray(data)[:, 0].any(axis=-1)
    confidence = np.asarray(confidence)[:, 0].astype(np.float64)
    confidence = np.where(mask | ~np.isfinite(confidence), 0.0, np.clip(confidence, 0.0, 1.0))
    values = np.where(np.isfinite(values) & (confidence[..., None] > 0), values, 0.0)
    points, confidences = {}, {}
    start = 0
    for name, names in layout:
        stop = start + len(names)
        points[name] = values[:, start:stop]
        confidences[name] = confidence[:, start:stop]
        start = stop
    return SignClip(fps, points, confidences)


def write_pose(path: str | Path, clip: SignClip, width: int, height: int) -> int:
    """Write clip (the five HOLISTIC_LAYOUT components, x y pixels of a width x height frame; and the hands' world
    landmarks, metres, when the clip has both HAND_WORLD_COMPONENTS: WORLD_LAYOUT) as a `.pose` file (format XYZC,
    one person, points masked where their confidence is 0). Returns the file size in bytes."""
    from pose_format import Pose  # heavy import, only when a file is written
    from pose_format.numpy import NumPyPoseBody
    from pose_format.pose_header import PoseHeader, PoseHeaderComponent, PoseHeaderDimensions

    missing = [name for name, _ in HOLISTIC_LAYOUT if name not in clip.points or name not in clip.confidence]
    has_world = all(name in clip.points and name in clip.confidence for name in HAND_WORLD_COMPONENTS)
    layout = WORLD_LAYOUT if has_world else HOLISTIC_LAYOUT
    if missing:
        raise SigncastError(f"cannot write {path}: the clip lacks {', '.join(missing)}")
    frames = clip.n_frames
    for name, names in layout:
        if clip.points[name].shape != (frames, len(names), 3) or clip.confidence[name].shape != (frames, len(names)):
            raise SigncastError(f"cannot write {path}: {name} has shape {clip.points[name].shape}, "
                                f"expected ({frames}, {len(names)}, 3)")
    if frames < 1 or not (np.isfinite(clip.fps) and clip.fps > 0):
        raise SigncastError(f"cannot write {path}: {frames} frames at {clip.fps} fps")
    components = [PoseHeaderComponent(name, list(names), [], [], POINT_FORMAT) for name, names in layout]
    header = PoseHeader(0.2, PoseHeaderDimensions(int(width), int(height), 0), components)
    confidence = np.concatenate([clip.confidence[name] for name, _ in layout], axis=1)
    points = np.concatenate([clip.points[name] for name, _ in layout], axis=1)
    seen = np.isfinite(confidence) & (confidence > 0) & np.all(np.isfinite(points), axis=-1)
    confidence = np.where(seen, np.clip(confidence, 0.0, 1.0), 0.0).astype(np.float32)[:, None]
    values = np.where(seen[..., None], points, 0.0).astype(np.float32)[:, None]
    mask = np.repeat(~seen[:, None, :, None], 3, axis=3)
    body = NumPyPoseBody(float(clip.fps), np.ma.masked_array(values, mask=mask), confidence)
    path = Path(path)
    try:
        with path.open("wb") as handle:
            Pose(header, body).write(handle)
    except OSError as error:
        raise SigncastError(f"cannot write pose file {path}: {error.strerror or error}") from None
    return path.stat().st_size


def frame_size(source: str | Path | bytes) -> tuple[int, int] | None:
    """(width, height) in pixels of the frame a `.pose` file's x, y refer to (its header's dimensions); None where
    the header gives none (0). Reads only the header; SigncastError when it is unreadable."""
    from pose_format.pose_header import PoseHeader
    from pose_format.utils.reader import BufferReader
    where = "pose data" if isinstance(source, (bytes, bytearray, memoryview)) else f"pose file {source}"
    try:
        data = bytes(source) if isinstance(source, (bytes, bytearray, memoryview)) else Path(source).read_bytes()
        header = PoseHeader.read(BufferReader(data))
        width, height = int(header.dimensions.width), int(header.dimensions.height)
    except OSError as error:
        raise SigncastError(f"cannot read {where}: {error.strerror}") from None
    except Exception as error:  # pose-format raises struct, numpy, unicode and value errors on damage
        raise SigncastError(f"damaged {where}: unreadable header ({type(error).__name__}: {error})") from None
    return (width, height) if width > 0 and height > 0 else None

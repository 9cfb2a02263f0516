"""signcast's parameter codecs against the glTF animation pipeline (gltfpack + meshoptimizer).

What an engineer would pick today instead of MPEG-4 FBA/BBA is a glTF 2.0 animation packed by gltfpack:
rotations quantised to N bits with meshoptimizer's QUATERNION filter (smallest three components) and the
buffers byte-compressed (EXT_meshopt_compression). This benchmark puts both on the same real motion:

1. glTF side. The motion becomes a glTF 2.0 file (JSON + one .bin): one node per avatar bone, children as in
   the skeleton, each node's rest translation its joint's offset from its parent's joint and its rest rotation
   the identity (media/avatar.py: every rest joint frame is world-aligned, so a Motion's local rotation is the
   node's rotation as it is; glTF 2.0 section 3.5.3 composes T * R * S parent to child like
   media/kinematics.py does). One animation: a rotation channel for each moving bone (a bone whose rotation
   changes in the clip), converted from signcast's (w, x, y, z) to glTF's (x, y, z, w) (glTF 2.0 section
   3.11), and the root's translation channel (its rest head plus the motion's root translation), LINEAR
   samplers at the frame times t = k / fps. `gltfpack -i in.gltf -o out.glb -cc -kn -af FPS -ar BITS` packs
   it (-kn keeps the named nodes, which carry no mesh). Animation bytes are the compressed lengths
   (EXT_meshopt_compression byteLength) of the bufferViews behind the animation samplers' accessors, each
   counted once; the whole .glb size is reported too. The .glb is decoded with meshoptimizer's own decoder
   (Python package `meshopt`), the quaternion filter undone, normalised int16 read as c / 32767 (glTF 2.0
   section 3.11, "Animations"), and the animation evaluated at the original frame times (glTF LINEAR: slerp
   for rotations, lerp for translations). gltfpack is lossy beyond -ar: a track whose keys all lie close to its
   first key becomes that one key, and is dropped when that key is as close to the node's rest rotation
   (meshoptimizer gltf/animation.cpp, isTrackEqual; no option turns this off). Measured here on gltfpack 0.18:
   "close" is a rotation of up to 0.2 deg (0.00349 rad), so nearly still bones (the spine while fingerspelling)
   carry errors up to ~0.4 deg at every bit depth. Those errors are counted: it is what a gltfpack user gets.
   The report says how many moving tracks stay keyed.
2. signcast side. The same motion through every parameter codec of `comparisons.params.codecs`: the MPEG-4
   fba-pred, fba-dct, bba-pred, bba-dct at Q 1, 2, 4, 8, 16, 31, and the seed-002 coders (quant ... hybrid)
   at each of their operating points; size = len() of the stream the decoder read back. By default the motion is sent
   without its face (FAPs): the glTF animation carries only bones, so both sides carry the same body (chosen
   here; --with-face codes the face too, as the MPEG-4 streams can). Decoded bones are mapped to the
   original's by name; a moving bone a stream does not carry counts as at rest (the param_codecs contract).
3. Error, the same on both sides: the angle of q_decoded^-1 q_original in degrees for every moving bone and
   frame, mean and max. kbps = 8 * bytes / (n_frames / fps) / 1000.
4. The ratio at equal mean error: each side's curve (its Pareto front: cheapest kbps for an error at most e,
   the best codec at each error on signcast's side) is interpolated linearly in (log error, log kbps), and
   signcast's kbps over gltfpack's is printed at error levels spread over the range both curves cover.
   Target (issue 17): <= 0.5.

Clip sets: ASL "HELLO" fingerspelled (media.fingerspelling.fingerspell); the ASL alphabet, each letter A..Z
its own clip (letter_motion; bytes, durations and errors pooled over the 26 clips); the word "ABCDEFGHIJ".
At 25 fps and at 10 fps (media.motion.resample of the 25 fps motion).

    python benchmarks/vs_gltf.py [--sets hello,alphabet,abcdefghij] [--fps 25,10] [--with-face] [--chart out.png]

Needs gltfpack (Debian/Ubuntu: `apt-get install gltfpack`, or a release from github.com/zeux/meshoptimizer)
and the `meshopt` Python package (`pip install "meshopt>=0.1,<0.2"`, or `pip install signcast[bench]`).
"""
from __future__ import annotations

import argparse
import json
import shutil
import string
import struct
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from media import rotations
from media.avatar import Skeleton, load_avatar
from media.errors import SigncastError
from media.motion import Motion, resample

MPEG_CODECS = ("fba-pred", "fba-dct", "bba-pred", "bba-dct")
QS = (1, 2, 4, 8, 16, 31)
ROTATION_BITS = tuple(range(8, 17))
TARGET_RATIO = 0.5
GLTFPACK_STILL_RAD = 0.00349   # gltfpack 0.18 keeps a rotation track keyed only if it moves more (measured)
MOVING_TOLERANCE = 1e-9          # a bone moves if any quaternion component changes by more than this

_FLOAT, _COMPONENT_TYPES = 5126, {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16,
                                  5125: np.uint32, 5126: np.float32}
_NORMALIZED_SCALE = {5120: 127.0, 5121: 255.0, 5122: 32767.0, 5123: 65535.0}
_WIDTHS = {"SCALAR": 1, "VEC3": 3, "VEC4": 4}
_GLB_MAGIC, _GLB_JSON, _GLB_BIN = 0x46546C67, 0x4E4F534A, 0x004E4942


# ---------------------------------------------------------------- tools

def missing_tools() -> str | None:
    """None when gltfpack and meshopt are usable, else one line saying what is missing and how to install it."""
    problems = []
    if shutil.which("gltfpack") is None:
        problems.append("gltfpack is not on PATH (apt-get install gltfpack, or a meshoptimizer release)")
    try:
        import meshopt  # noqa: F401
    except ImportError:
        problems.append('the meshopt package is missing (pip install "meshopt>=0.1,<0.2")')
    return "; ".join(problems) or None


def gltfpack(source: Path, target: Path, fps: float, rotation_bits: int, *, translation_bits: int | None = None) -> None:
    """Pack source (.gltf) into target (.glb) with meshopt compression (-cc), named nodes kept (-kn), animation
    resampled at fps Hz (-af, whole numbers only) and rotations quantised to rotation_bits (-ar, 4..16)."""
    if not 4 <= rotation_bits <= 16:
        raise SigncastError(f"gltfpack rotation bits must be 4..16, got {rotation_bits}")
    if abs(fps - round(fps)) > 1e-9:
        raise SigncastError(f"gltfpack resamples at whole frame rates only, got {fps}")
    command = ["gltfpack", "-i", str(source), "-o", str(target), "-cc", "-kn",
               "-af", str(round(fps)), "-ar", str(rotation_bits)]
    if translation_bits is not None:
        command += ["-at", str(translation_bits)]
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    if done.returncode != 0 or not target.exists():
        raise SigncastError(f"gltfpack failed ({done.returncode}): {done.stderr.strip() or done.stdout.strip()}")


# ---------------------------------------------------------------- writing glTF

def moving_bones(motion: Motion, tolerance: float = MOVING_TOLERANCE) -> list[str]:
    """Names of the bones whose rotation changes during the motion (in the motion's order)."""
    if motion.n_frames < 2:
        return []
    spread = np.ptp(rotations.canonical(motion.rotations), axis=0).max(axis=-1)
    return [name for name, change in zip(motion.bone_names, spread) if change > tolerance]


def to_xyzw(q: np.ndarray) -> np.ndarray:
    """(..., 4) signcast (w, x, y, z) -> glTF (x, y, z, w)."""
    return np.asarray(q)[..., [1, 2, 3, 0]]


def from_xyzw(q: np.ndarray) -> np.ndarray:
    """(..., 4) glTF (x, y, z, w) -> signcast (w, x, y, z)."""
    return np.asarray(q)[..., [3, 0, 1, 2]]


def motion_to_gltf(motion: Motion, skeleton: Skeleton, bones: list[str] | None = None) -> tuple[dict, bytes]:
    """The glTF 2.0 document (JSON as a dict, its buffer 0 to be stored as 'motion.bin') and the buffer bytes.

    bones: the bones given a rotation channel (default: the moving ones); every skeleton bone is a node.
    Times are float32 seconds k / fps; rotations float32 (x, y, z, w); the root translation float32 metres.
    """
    bones = moving_bones(motion) if bones is None else bones
    offsets = skeleton.offsets()
    nodes = []
    for b, name in enumerate(skeleton.names):
        node: dict = {"name": name, "translation": [float(v) for v in offsets[b]]}
        children = skeleton.children(b)
        if children:
            node["children"] = children
        nodes.append(node)
    roots = [int(b) for b in np.flatnonzero(skeleton.parents < 0)]
    by_name = {name: k for k, name in enumerate(motion.bone_names)}
    missing = [name for name in bones if name not in by_name or name not in skeleton.names]
    if missing:
        raise SigncastError(f"bones missing from the motion or the skeleton: {', '.join(missing[:5])}")

    blob = bytearray()
    views: list[dict] = []
    accessors: list[dict] = []

    def add(values: np.ndarray, kind: str, *, bounds: bool = False) -> int:
        values = np.ascontiguousarray(values, dtype=np.float32)
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": values.nbytes})
        blob.extend(values.tobytes())
        accessor = {"bufferView": len(views) - 1, "componentType": _FLOAT, "count": len(values), "type": kind}
        if bounds:
            accessor["min"] = [float(v) for v in np.atleast_2d(values.reshape(len(values), -1)).min(axis=0)]
            accessor["max"] = [float(v) for v in np.atleast_2d(values.reshape(len(values), -1)).max(axis=0)]
        accessors.append(accessor)
        return len(accessors) - 1

    times = add(np.arange(motion.n_frames) / motion.fps, "SCALAR", bounds=True)
    samplers, channels = [], []
    for name in bones:
        output = add(to_xyzw(rotations.normalize(motion.rotations[:, by_name[name]])), "VEC4")
        samplers.append({"input": times, "output": output, "interpolation": "LINEAR"})
        channels.append({"sampler": len(samplers) - 1, "target": {"node": skeleton.index(name), "path": "rotation"}})
    for root in roots:
        output = add(offsets[root] + motion.root_translation, "VEC3")
        samplers.append({"input": times, "output": output, "interpolation": "LINEAR"})
        channels.append({"sampler": len(samplers) - 1, "target": {"node": root, "path": "translation"}})
    document = {
        "asset": {"version": "2.0", "generator": "signcast benchmarks/vs_gltf.py"},
        "scene": 0, "scenes": [{"nodes": roots}], "nodes": nodes,
        "buffers": [{"uri": "motion.bin", "byteLength": len(blob)}],
        "bufferViews": views, "accessors": accessors,
        "animations": [{"name": "motion", "samplers": samplers, "channels": channels}],
    }
    return document, bytes(blob)


def write_gltf(motion: Motion, skeleton: Skeleton, folder: Path, bones: list[str] | None = None) -> Path:
    """folder/motion.gltf + folder/motion.bin of motion_to_gltf; returns the .gltf path."""
    document, blob = motion_to_gltf(motion, skeleton, bones)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "motion.bin").write_bytes(blob)
    path = folder / "motion.gltf"
    path.write_text(json.dumps(document))
    return path


# ---------------------------------------------------------------- reading glTF / GLB

@dataclass(frozen=True)
class Track:
    """One animation channel: times (K,) seconds, values (K, C) float64, interpolation 'LINEAR' or 'STEP'."""
    times: np.ndarray
    values: np.ndarray
    interpolation: str


@dataclass(frozen=True)
class GltfAnimation:
    """A glTF file's first animation: tracks[(node name, path)], each node's static rotation (x, y, z, w) and
    translation, the bytes of the bufferViews the animation reads (compressed size where meshopt-compressed)
    and the file's total size."""
    tracks: dict[tuple[str, str], Track]
    node_rotations: dict[str, np.ndarray]
    node_translations: dict[str, np.ndarray]
    animation_bytes: int
    file_bytes: int


def _read_container(path: Path) -> tuple[dict, list[bytes]]:
    """The JSON and the bytes of each buffer of a .gltf (external .bin files) or .glb (GLB BIN chunk)."""
    raw = path.read_bytes()
    if path.suffix.lower() == ".glb":
        if len(raw) < 20:
            raise SigncastError(f"{path}: too short for a GLB")
        magic, version, length = struct.unpack_from("<III", raw, 0)
        if magic != _GLB_MAGIC or version != 2 or length > len(raw):
            raise SigncastError(f"{path}: not a glTF 2.0 binary")
        offset, document, binary = 12, None, b""
        while offset + 8 <= length:
            chunk_length, chunk_type = struct.unpack_from("<II", raw, offset)
            chunk = raw[offset + 8:offset + 8 + chunk_length]
            if len(chunk) != chunk_length:
                raise SigncastError(f"{path}: truncated GLB chunk")
            if chunk_type == _GLB_JSON:
                document = json.loads(chunk.decode("utf-8"))
            elif chunk_type == _GLB_BIN and not binary:
                binary = bytes(chunk)
            offset += 8 + chunk_length
        if document is None:
            raise SigncastError(f"{path}: GLB without a JSON chunk")
        buffers = []
        for k, buffer in enumerate(document.get("buffers", [])):
            if "uri" in buffer:
                buffers.append((path.parent / buffer["uri"]).read_bytes())
            else:   # the GLB BIN chunk is buffer 0; a meshopt fallback buffer has no bytes at all
                buffers.append(binary if k == 0 else b"")
        return document, buffers
    document = json.loads(raw.decode("utf-8"))
    return document, [(path.parent / buffer["uri"]).read_bytes() for buffer in document.get("buffers", [])]


def _view_bytes(document: dict, buffers: list[bytes], view: int) -> tuple[bytes, int]:
    """A bufferView's plain bytes (meshopt-decoded where compressed) and its stored (compressed) size."""
    spec = document["bufferViews"][view]
    compressed = spec.get("extensions", {}).get("EXT_meshopt_compression")
    if compressed is None:
        start = spec.get("byteOffset", 0)
        return buffers[spec["buffer"]][start:start + spec["byteLength"]], spec["byteLength"]
    import meshopt
    start = compressed.get("byteOffset", 0)
    data = buffers[compressed["buffer"]][start:start + compressed["byteLength"]]
    filter_name = compressed.get("filter", "NONE")
    plain = meshopt.decode_gltf_buffer(data, compressed["count"], compressed["byteStride"], compressed["mode"],
                                       None if filter_name == "NONE" else filter_name)
    return np.ascontiguousarray(plain).tobytes(), compressed["byteLength"]


def _accessor_values(document: dict, buffers: list[bytes], index: int, cache: dict) -> np.ndarray:
    """(count, width) float64 values of an accessor (normalised integers mapped to [-1, 1] or [0, 1])."""
    accessor = document["accessors"][index]
    view = accessor["bufferView"]
    if view not in cache:
        cache[view] = _view_bytes(document, buffers, view)[0]
    data = cache[view]
    dtype = np.dtype(_COMPONENT_TYPES[accessor["componentType"]])
    width = _WIDTHS[accessor["type"]]
    count = accessor["count"]
    stride = document["bufferViews"][view].get("byteStride") or width * dtype.itemsize
    start = accessor.get("byteOffset", 0)
    rows = np.frombuffer(data, dtype=np.uint8, count=(count - 1) * stride + width * dtype.itemsize, offset=start)
    rows = np.lib.stride_tricks.as_strided(rows, shape=(count, width * dtype.itemsize), strides=(stride, 1))
    values = np.ascontiguousarray(rows).view(dtype).reshape(count, width).astype(np.float64)
    if accessor.get("normalized") and accessor["componentType"] in _NORMALIZED_SCALE:
        values = np.maximum(values / _NORMALIZED_SCALE[accessor["componentType"]], -1.0)
    return values


def read_animation(path: Path) -> GltfAnimation:
    """The first animation of a .gltf or .glb, decoded (meshopt-compressed bufferViews included); a file this
    reader cannot follow raises SigncastError."""
    try:
        return _read_animation(path)
    except SigncastError:
        raise
    except (KeyError, IndexError, TypeError, ValueError, struct.error, OSError) as error:
        raise SigncastError(f"{path}: unreadable glTF animation ({type(error).__name__}: {error})") from None


def _read_animation(path: Path) -> GltfAnimation:
    document, buffers = _read_container(path)
    nodes = document.get("nodes", [])
    names = [node.get("name", f"node{k}") for k, node in enumerate(nodes)]
    animation = (document.get("animations") or [{"samplers": [], "channels": []}])[0]
    cache: dict = {}
    tracks: dict[tuple[str, str], Track] = {}
    used_views: set[int] = set()
    for channel in animation["channels"]:
        target = channel["target"]
        if "node" not in target:
            continue
        sampler = animation["samplers"][channel["sampler"]]
        interpolation = sampler.get("interpolation", "LINEAR")
        if interpolation not in ("LINEAR", "STEP"):
            raise SigncastError(f"{path}: {interpolation} samplers are not read here")
        times = _accessor_values(document, buffers, sampler["input"], cache)[:, 0]
        values = _accessor_values(document, buffers, sampler["output"], cache)
        tracks[(names[target["node"]], target["path"])] = Track(times, values, interpolation)
    for sampler in animation["samplers"]:
        for key in ("input", "output"):
            used_views.add(document["accessors"][sampler[key]]["bufferView"])
    animation_bytes = sum(_stored_size(document, view) for view in used_views)
    node_rotations = {names[k]: np.asarray(node.get("rotation", [0.0, 0.0, 0.0, 1.0]), float)
                      for k, node in enumerate(nodes)}
    node_translations = {names[k]: np.asarray(node.get("translation", [0.0, 0.0, 0.0]), float)
                         for k, node in enumerate(nodes)}
    return GltfAnimation(tracks, node_rotations, node_translations, animation_bytes, path.stat().st_size)


def _stored_size(document: dict, view: int) -> int:
    spec = document["bufferViews"][view]
    compressed = spec.get("extensions", {}).get("EXT_meshopt_compression")
    return int(compressed["byteLength"] if compressed else spec["byteLength"])


def sample_track(track: Track, times_s: np.ndarray, *, rotation: bool) -> np.ndarray:
    """(N, C) values of a track at times_s (N,) seconds, clamped to its first/last key (glTF 2.0 section 3.11):
    LINEAR is slerp for rotations ((x, y, z, w), returned normalised) and lerp otherwise; STEP holds the left key."""
    keys, values = track.times, track.values
    if len(keys) == 1:
        out = np.repeat(values[:1], len(times_s), axis=0)
        return rotations.normalize(out) if rotation else out
    left = np.clip(np.searchsorted(keys, times_s, side="right") - 1, 0, len(keys) - 2)
    span = np.maximum(keys[left + 1] - keys[left], 1e-12)
    u = np.clip((times_s - keys[left]) / span, 0.0, 1.0)
    if track.interpolation == "STEP":
        u = np.where(u >= 1.0, 1.0, 0.0)
    if rotation:
        a, b = from_xyzw(rotations.normalize(values[left])), from_xyzw(rotations.normalize(values[left + 1]))
        return to_xyzw(rotations.slerp(a, b, u))
    return (1 - u)[:, None] * values[left] + u[:, None] * values[left + 1]


def animation_rotations(animation: GltfAnimation, bones: list[str], times_s: np.ndarray) -> np.ndarray:
    """(N, len(bones), 4) local rotations (w, x, y, z) of the named nodes at times_s: their track where there is
    one, else the node's static rotation."""
    out = np.empty((len(times_s), len(bones), 4))
    for k, name in enumerate(bones):
        track = animation.tracks.get((name, "rotation"))
        if track is not None:
            out[:, k] = from_xyzw(sample_track(track, times_s, rotation=True))
        elif name in animation.node_rotations:
            out[:, k] = from_xyzw(rotations.normalize(animation.node_rotations[name]))
        else:
            raise SigncastError(f"the glTF has no node {name!r}")
    return out


# ---------------------------------------------------------------- measuring

@dataclass(frozen=True)
class Point:
    """One coded operating point over a clip set: side 'gltfpack' or a codec name, its setting (bits or Q),
    bytes (animation bytes / stream bytes, summed over clips), duration_s (summed), errors in degrees
    (mean and max over moving bones x frames of all clips), file_bytes (.glb total for gltfpack, else bytes)."""
    codec: str
    setting: int
    bytes: int
    duration_s: float
    mean_deg: float
    max_deg: float
    file_bytes: int

    @property
    def kbps(self) -> float:
        return 8.0 * self.bytes / self.duration_s / 1000.0


def rotation_errors_deg(reference: np.ndarray, decoded: np.ndarray) -> np.ndarray:
    """Angle of q_decoded^-1 q_reference in degrees; (..., 4) each (w, x, y, z) -> (...)."""
    return np.degrees(rotations.angle_between(rotations.normalize(decoded), rotations.normalize(reference)))


def gltf_errors(motion: Motion, skeleton: Skeleton, rotation_bits: int, folder: Path
                ) -> tuple[np.ndarray, int, int, int]:
    """Pack the motion with gltfpack at rotation_bits and decode it: (T, M) errors in degrees of its M moving
    bones, the animation bytes, the .glb bytes, and how many of the M bones keep a keyed track (gltfpack makes a
    track constant when every key is within GLTFPACK_STILL_RAD of its first key, and drops it when that constant
    is as close to the node's rest rotation: meshoptimizer gltf/animation.cpp, isTrackEqual)."""
    bones = moving_bones(motion)
    source = write_gltf(motion, skeleton, folder, bones)
    packed = folder / f"motion-{rotation_bits}.glb"
    gltfpack(source, packed, motion.fps, rotation_bits)
    animation = read_animation(packed)
    times = np.arange(motion.n_frames) / motion.fps
    decoded = animation_rotations(animation, bones, times)
    reference = motion.rotations[:, [motion.bone(name) for name in bones]]
    keyed = sum(len(animation.tracks[(name, "rotation")].times) > 1 for name in bones
                if (name, "rotation") in animation.tracks)
    return rotation_errors_deg(reference, decoded), animation.animation_bytes, animation.file_bytes, keyed


def signcast_codecs() -> tuple[str, ...]:
    """Every registered parameter codec but bba-key (bba-pred with key frames: the same stream family)."""
    from comparisons.params.codecs import codec_names
    return tuple(name for name in codec_names() if name != "bba-key")


def operating_points(name: str) -> tuple[int, ...]:
    """The settings a codec is measured at: Q 1, 2, 4, 8, 16, 31 for MPEG-4; every operating point of a seed-002
    coder (1 = its lowest rate)."""
    if name in MPEG_CODECS:
        return QS
    from comparisons.params.codecs import get_codec
    return tuple(range(1, len(get_codec(name).settings()) + 1))


def codec_errors(motion: Motion, codec_name: str, q: int) -> tuple[np.ndarray, int, int]:
    """Code the motion with a signcast parameter codec at Q: (T, M) errors in degrees of its M moving bones
    (a bone the decoded motion lacks counts as at rest), the stream's bytes, and how many moving bones the
    decoded motion carries."""
    from comparisons.params.codecs import get_codec
    codec = get_codec(codec_name)
    data = codec.encode(motion, q)
    decoded = codec.decode(data)
    if decoded.n_frames != motion.n_frames:
        raise SigncastError(f"{codec_name} decoded {decoded.n_frames} frames of {motion.n_frames}")
    bones = moving_bones(motion)
    carried = {name: k for k, name in enumerate(decoded.bone_names)}
    got = np.zeros((motion.n_frames, len(bones), 4))
    got[..., 0] = 1.0
    for k, name in enumerate(bones):
        if name in carried:
            got[:, k] = decoded.rotations[:, carried[name]]
    reference = motion.rotations[:, [motion.bone(name) for name in bones]]
    return rotation_errors_deg(reference, got), len(data), sum(name in carried for name in bones)


def pooled(codec: str, setting: int, errors: list[np.ndarray], sizes: list[int], file_sizes: list[int],
           durations: list[float]) -> Point:
    """One Point from per-clip errors (any shape, degrees), sizes and durations (seconds)."""
    flat = np.concatenate([e.reshape(-1) for e in errors])
    return Point(codec, setting, sum(sizes), sum(durations), float(flat.mean()), float(flat.max()), sum(file_sizes))


def clip_set(name: str, fps: float) -> list[Motion]:
    """The clips of a set at fps (10 fps: resampled from the 25 fps motion): 'hello' (ASL HELLO),
    'alphabet' (ASL A..Z, one clip each), 'abcdefghij' (the word)."""
    from media.fingerspelling import fingerspell, letter_motion
    if name == "hello":
        clips = [fingerspell("ase", "HELLO", 25.0)]
    elif name == "alphabet":
        clips = [letter_motion("ase", letter, 25.0) for letter in string.ascii_uppercase]
    elif name == "abcdefghij":
        clips = [fingerspell("ase", "ABCDEFGHIJ", 25.0)]
    else:
        raise SigncastError(f"unknown clip set {name!r}: hello, alphabet or abcdefghij")
    return [clip if abs(fps - 25.0) < 1e-9 else resample(clip, fps) for clip in clips]


def measure_set(clips: list[Motion], skeleton: Skeleton, *, bits: tuple[int, ...] = ROTATION_BITS,
                codecs: tuple[str, ...] | None = None
                ) -> tuple[list[Point], dict[str, tuple[int, int]]]:
    """Every gltfpack bit depth and every codec x Q on the clips: the points, and per side the fewest and the
    most moving-bone tracks (summed over clips, over its settings) its decoded animation still moves: for
    gltfpack the tracks left keyed, for a codec the moving bones its stream carries (a stream may leave out a bone
    whose quantised rotation never leaves rest); 'moving' holds all moving bones, as (n, n)."""
    durations = [clip.duration_s for clip in clips]
    moving = sum(len(moving_bones(clip)) for clip in clips)
    points, tracks = [], {"moving": (moving, moving)}
    with tempfile.TemporaryDirectory(prefix="signcast-gltf-") as tmp:
        counts = []
        for n_bits in bits:
            results = [gltf_errors(clip, skeleton, n_bits, Path(tmp) / f"clip{k}") for k, clip in enumerate(clips)]
            points.append(pooled("gltfpack", n_bits, [r[0] for r in results], [r[1] for r in results],
                                 [r[2] for r in results], durations))
            counts.append(sum(r[3] for r in results))
        tracks["gltfpack"] = (min(counts), max(counts))
    for name in codecs or signcast_codecs():
        counts = []
        for q in operating_points(name):
            results = [codec_errors(clip, name, q) for clip in clips]
            sizes = [r[1] for r in results]
            points.append(pooled(name, q, [r[0] for r in results], sizes, sizes, durations))
            counts.append(sum(r[2] for r in results))
        tracks[name] = (min(counts), max(counts))
    return points, tracks


# ---------------------------------------------------------------- curves

def pareto(points: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """(error, kbps) points kept where no other point has both lower error and lower kbps, by rising error."""
    front: list[tuple[float, float]] = []
    for error, kbps in sorted(points):
        if error > 0 and kbps > 0 and (not front or kbps < front[-1][1]):
            front.append((error, kbps))
    return front


def kbps_at(front: list[tuple[float, float]], error: float) -> float:
    """kbps of a Pareto front at a mean error, interpolated linearly in (log error, log kbps); nan outside it."""
    if not front or error < front[0][0] or error > front[-1][0]:
        return float("nan")
    errors = np.log([e for e, _ in front])
    rates = np.log([k for _, k in front])
    return float(np.exp(np.interp(np.log(error), errors, rates)))


def ratios_at_equal_error(points: list[Point], levels: int = 5) -> list[tuple[float, str, float, float, float]]:
    """At `levels` mean errors spread (geometrically) over the range covered by gltfpack's curve and by at
    least one signcast codec: (error_deg, best codec, its kbps, gltfpack's kbps, ratio)."""
    gltf = pareto([(p.mean_deg, p.kbps) for p in points if p.codec == "gltfpack"])
    fronts = {name: pareto([(p.mean_deg, p.kbps) for p in points if p.codec == name])
              for name in dict.fromkeys(p.codec for p in points if p.codec != "gltfpack")}
    fronts = {name: front for name, front in fronts.items() if front}
    if not gltf or not fronts:
        return []
    low = max(gltf[0][0], min(front[0][0] for front in fronts.values()))
    high = min(gltf[-1][0], max(front[-1][0] for front in fronts.values()))
    if not low < high:
        return []
    rows = []
    for error in np.geomspace(low, high, levels):
        best = min(((kbps_at(front, error), name) for name, front in fronts.items()),
                   key=lambda pair: np.inf if np.isnan(pair[0]) else pair[0])
        reference = kbps_at(gltf, error)
        rows.append((float(error), best[1], best[0], reference, best[0] / reference))
    return rows


# ---------------------------------------------------------------- report

def table(points: list[Point]) -> str:
    lines = [f"{'codec':10s} {'set':>4s} {'bytes':>7s} {'kbps':>8s} {'mean deg':>9s} {'max deg':>9s} {'file B':>7s}"]
    for p in points:
        lines.append(f"{p.codec:10s} {p.setting:4d} {p.bytes:7d} {p.kbps:8.2f} {p.mean_deg:9.4f} {p.max_deg:9.4f} "
                     f"{p.file_bytes:7d}")
    return "\n".join(lines)


def ratio_table(rows: list[tuple[float, str, float, float, float]]) -> str:
    if not rows:
        return "  (the curves do not overlap in mean error)"
    lines = [f"  {'mean deg':>9s} {'best signcast':>14s} {'kbps':>8s} {'gltfpack kbps':>14s} {'ratio':>6s}"]
    for error, name, kbps, reference, ratio in rows:
        lines.append(f"  {error:9.4f} {name:>14s} {kbps:8.2f} {reference:14.2f} {ratio:6.2f}")
    return "\n".join(lines)


def chart(results: dict[tuple[str, float], list[Point]], path: Path) -> None:
    """kbps against mean rotation error (log-log), one panel per (set, fps): gltfpack, the MPEG-4 codecs and each
    seed-002 coder that is signcast's cheapest somewhere on the curve."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    keys = list(results)
    columns = min(2, len(keys))
    rows = -(-len(keys) // columns)
    figure, axes = plt.subplots(rows, columns, figsize=(5.5 * columns, 4 * rows), squeeze=False)
    for axis in axes.reshape(-1)[len(keys):]:
        axis.set_visible(False)
    for axis, key in zip(axes.reshape(-1), keys):
        shown = {"gltfpack", *MPEG_CODECS} | {row[1] for row in ratios_at_equal_error(results[key], levels=24)}
        for name in (name for name in dict.fromkeys(p.codec for p in results[key]) if name in shown):
            curve = sorted((p.mean_deg, p.kbps) for p in results[key] if p.codec == name)
            axis.plot(*zip(*curve), marker="o", label=name, linewidth=2.5 if name == "gltfpack" else 1.2)
            if name == "gltfpack":
                axis.plot([e for e, _ in curve], [TARGET_RATIO * k for _, k in curve], color="black", linestyle="--",
                          linewidth=1, label=f"target: {TARGET_RATIO:g} x gltfpack")
        axis.set_xscale("log")
        axis.set_yscale("log")
        axis.set_xlabel("mean rotation error (deg)")
        axis.set_ylabel("kbps")
        axis.set_title(f"{key[0]} @ {key[1]:g} fps")
        axis.grid(True, which="both", alpha=0.3)
        axis.legend(fontsize=8)
    figure.suptitle("Animation bitrate against mean rotation error of the moving bones, measured against the original "
                    "motion\n(gltfpack: compressed animation buffers only; signcast: whole decodable streams)", fontsize=10)
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sets", default="hello,alphabet,abcdefghij", help="clip sets: hello, alphabet, abcdefghij")
    parser.add_argument("--fps", default="25,10", help="frame rates, comma-separated")
    parser.add_argument("--with-face", action="store_true", help="signcast codecs also carry the face (FAPs)")
    parser.add_argument("--codecs", help="signcast codecs, comma-separated (default: every registered one)")
    parser.add_argument("--chart", type=Path, help="write a PNG chart here")
    args = parser.parse_args(argv)
    problem = missing_tools()
    if args.codecs:
        from comparisons.params.codecs import codec_names
        unknown = sorted(set(args.codecs.split(",")) - set(codec_names()))
        if unknown:
            problem = f"unknown codec(s) {', '.join(unknown)}; known: {', '.join(codec_names())}"
    if problem:
        print(f"vs_gltf: {problem}", file=sys.stderr)
        return 2
    version = subprocess.run(["gltfpack", "-v"], capture_output=True, text=True, check=False)
    import meshopt
    print(f"gltfpack: {(version.stdout or version.stderr).strip().splitlines()[0]}; meshopt "
          f"{getattr(meshopt, '__version__', '(installed)')}")
    skeleton = load_avatar().skeleton
    results: dict[tuple[str, float], list[Point]] = {}
    for set_name in args.sets.split(","):
        for fps in (float(f) for f in args.fps.split(",")):
            clips = clip_set(set_name, fps)
            if not args.with_face:
                clips = [clip.without_face() for clip in clips]
            points, carried = measure_set(clips, skeleton, codecs=tuple(args.codecs.split(",")) if args.codecs else None)
            results[(set_name, fps)] = points
            frames = sum(c.n_frames for c in clips)
            print(f"\n== {set_name} at {fps:g} fps: {len(clips)} clip(s), {frames} frames, "
                  f"{sum(c.duration_s for c in clips):.2f} s, {carried['moving'][0]} moving bone tracks "
                  f"({'with' if args.with_face else 'without'} face)")
            print("   moving-bone tracks still moving after decoding (fewest..most over the settings): "
                  + ", ".join(f"{name} {low}..{high}" for name, (low, high) in carried.items() if name != "moving"))
            print(table(points))
            print(f"  signcast best / gltfpack kbps at equal mean error (target <= {TARGET_RATIO}):")
            print(ratio_table(ratios_at_equal_error(points)))
    if args.chart:
        chart(results, args.chart)
        print(f"\nchart: {args.chart}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

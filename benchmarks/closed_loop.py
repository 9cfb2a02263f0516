"""Closed loop with known ground truth: render known motion, extract its landmarks, retarget them, compare.

The known motion is a fingerspelled word (media.fingerspelling, lexicon retargeting). It is rendered with the
shaded look (media.render, the signing-space camera), MediaPipe Holistic landmarks are extracted from the frames
(media.landmarks.holistic), and the extracted clip is retargeted to the avatar (media.retarget, as any `.pose`).
Compared with the original:

- image-plane hand keypoint error, pixels: the hand joints of both motions (avatar forward kinematics) projected
  with the render's own camera ("retargeted"), and the extracted hand landmarks against the original's projected
  joints where they correspond ("extracted": landmark 0 the wrist's head, each finger landmark the head of its
  phalanx, a fingertip the last phalanx's tail), over the frames the hand was found;
- joint-angle error per bone group, degrees: the geodesic angle between the two motions' local rotations of the
  torso (spine, neck, head), arm (upperarm01, lowerarm01, lowerarm02, wrist) and finger bones of the signing
  side, mean and 90th percentile over bones and frames;
- the extractor's own direction error per phalanx, degrees (the floor a retargeting that follows the landmarks
  inherits): the 15 finger phalanges' directions from the hand model's world landmarks (3D, in the avatar's axes)
  and from the image landmarks (2D, in the image plane) against the original's (`landmark_errors`).

The render is the full figure (the signing-space camera), or with --zoom a head-and-torso shot as a person's
clip is framed (media.framing.Framing: the full-figure camera zoomed about the shoulders' midpoint, placed at
55 % of the frame's height, as benchmarks/framing.py makes its close shot), which makes the hands bigger in the
same frame; --size renders larger frames.

    python benchmarks/closed_loop.py [--language ase] [--word HI] [--size 352x288] [--zoom 1.7]
        [--filters one-euro,binomial,off] [--methods fit,fit-2d,lifting]
"""
from __future__ import annotations

import argparse
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from media import rotations  # noqa: E402
from media.retarget import FINGER_CHAINS, TORSO_BONES  # noqa: E402

ARM_JOINTS = ("upperarm01", "lowerarm01", "lowerarm02", "wrist")
HAND_PREFIX = {"L": "LEFT", "R": "RIGHT"}


@dataclass
class Loop:
    """One closed loop's material: the original Motion, the rendered frames (T, H, W, 3) uint8, the extracted
    SignClip, the camera (4, 4) world -> clip, the frame size (width, height) and the seconds each step took."""
    original: object
    frames: np.ndarray
    clip: object
    camera: np.ndarray
    size: tuple[int, int]
    seconds: dict[str, float] = field(default_factory=dict)


def close_framing(avatar, motion, size: tuple[int, int], zoom: float):
    """media.framing.Framing of a head-and-torso shot: the full-figure picture zoomed by `zoom` (e.g. 1.7) about the
    shoulders' midpoint of the motion's first frame, which it places at the frame's horizontal centre and 55 % of
    its height (benchmarks/framing.py's close shot)."""
    from media.framing import Framing, anchor_track
    from media.render import signing_space_camera

    width, height = size
    shoulders = anchor_track(avatar, motion.frames(0, 1), signing_space_camera(avatar, width, height),
                             width, height)[0, 7:].mean(axis=0)
    return Framing(zoom, ((width / 2 - zoom * shoulders[0]) / width,
                          (0.55 * height - zoom * shoulders[1]) / height))


def run_loop(language: str = "ase", word: str = "HI", size: tuple[int, int] = (352, 288), fps: float = 25.0,
             backend: str = "auto", zoom: float | None = None) -> Loop:
    """Render the fingerspelled word shaded (full figure, or a head-and-torso shot zoomed by `zoom`:
    close_framing) at size (width, height) pixels and extract its landmarks."""
    from media.avatar import load_avatar
    from media.fingerspelling import fingerspell
    from media.landmarks.holistic import extract_landmarks
    from media.render import RenderSettings, render_motion, signing_space_camera

    avatar = load_avatar()
    seconds = {}
    started = time.perf_counter()
    original = fingerspell(language, word, fps=fps)
    framing = close_framing(avatar, original, size, zoom) if zoom else None
    frames, _ = render_motion(avatar, original, RenderSettings(size[0], size[1], look="shaded", backend=backend,
                                                               framing=framing))
    seconds["render"] = time.perf_counter() - started
    started = time.perf_counter()
    clip = extract_landmarks(iter(frames), fps, n_frames=len(frames))
    seconds["extract"] = time.perf_counter() - started
    camera = signing_space_camera(avatar, *size)
    if framing is not None:
        camera = framing.camera(camera, *size)
    return Loop(original, frames, clip, np.asarray(camera, np.float64), size, seconds)


def project(camera: np.ndarray, points: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """World points (..., 3) metres -> image (..., 2) pixels (x right, y down), as the rasterizer places them."""
    homogeneous = np.concatenate([points, np.ones(points.shape[:-1] + (1,))], axis=-1) @ camera.T
    ndc = homogeneous[..., :2] / homogeneous[..., 3:4]
    return np.stack([(ndc[..., 0] * 0.5 + 0.5) * size[0], (0.5 - ndc[..., 1] * 0.5) * size[1]], axis=-1)


def hand_joints(skeleton, motion, side: str) -> np.ndarray:
    """(T, 21, 3) world positions (metres) of hand `side` ('L'/'R') in MediaPipe's hand landmark order."""
    from media.kinematics import joint_positions

    heads = joint_positions(skeleton, motion)
    tails = joint_positions(skeleton, motion, tails=True)
    points = np.zeros((motion.n_frames, 21, 3))
    points[:, 0] = heads[:, skeleton.index(f"wrist.{side}")]
    for chain in FINGER_CHAINS.values():
        for bone, head_landmark, tail_landmark in chain:
            points[:, head_landmark] = heads[:, skeleton.index(f"{bone}.{side}")]
        bone, _, tail_landmark = chain[-1]
        points[:, tail_landmark] = tails[:, skeleton.index(f"{bone}.{side}")]
    return points


def _summary(values: np.ndarray) -> dict[str, float]:
    values = np.asarray(values, dtype=np.float64).ravel()
    if not len(values):
        return {"mean": float("nan"), "p90": float("nan"), "n": 0}
    return {"mean": float(np.mean(values)), "p90": float(np.percentile(values, 90)), "n": int(len(values))}


def angle_errors(original, retargeted, side: str = "R") -> dict[str, dict[str, float]]:
    """Geodesic angle (degrees) between local rotations per bone group: torso, arm, fingers (mean, p90, n)."""
    groups = {
        "torso": TORSO_BONES,
        "arm": tuple(f"{bone}.{side}" for bone in ARM_JOINTS),
        "fingers": tuple(f"{bone}.{side}" for chain in FINGER_CHAINS.values() for bone, _, _ in chain),
    }
    result = {}
    for group, bones in groups.items():
        angles = [np.degrees(rotations.angle_between(original.rotations[:, original.bone(bone)],
                                                     retargeted.rotations[:, retargeted.bone(bone)]))
                  for bone in bones]
        result[group] = _summary(np.concatenate(angles))
    return result


def _angles_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angle in degrees between vectors a and b (..., D), per leading index."""
    a = a / np.linalg.norm(a, axis=-1, keepdims=True)
    b = b / np.linalg.norm(b, axis=-1, keepdims=True)
    return np.degrees(np.arccos(np.clip(np.sum(a * b, axis=-1), -1.0, 1.0)))


PHALANGES = tuple((head, tail) for chain in FINGER_CHAINS.values() for _, head, tail in chain)


def landmark_errors(loop: Loop, side: str = "R") -> dict[str, dict[str, float]]:
    """The extractor's own error, the floor of a retargeting that follows the landmarks: per finger phalanx (15,
    MediaPipe landmark head -> tail) the angle in degrees between the original's direction and the extracted
    landmarks', over the frames the hand was found. "world": the hand model's world landmarks (turned into the
    avatar's axes, media.hand_fit.from_mediapipe_world) against the original's 3D joints (the camera looks along
    -Z, so the two share axes up to the view ray's few degrees); "image": the image landmarks' x, y against the
    original's projected joints (2D). Mean, p90, n."""
    from media.avatar import load_avatar
    from media.hand_fit import from_mediapipe_world

    skeleton = load_avatar().skeleton
    component = f"{HAND_PREFIX[side]}_HAND_LANDMARKS"
    found = np.all(loop.clip.confidence[component] > 0, axis=1)
    truth = hand_joints(skeleton, loop.original, side)[found]                       # (F, 21, 3)
    truth_px = project(loop.camera, truth, loop.size)
    heads, tails = (np.array(ends) for ends in zip(*PHALANGES))
    result = {"image": _summary(_angles_deg(loop.clip.points[component][found][:, tails, :2]
                                            - loop.clip.points[component][found][:, heads, :2],
                                            truth_px[:, tails] - truth_px[:, heads]))}
    world_name = f"{HAND_PREFIX[side]}_HAND_WORLD_LANDMARKS"
    if world_name in loop.clip.points:
        world = from_mediapipe_world(loop.clip.points[world_name][found][..., :3])
        result["world"] = _summary(_angles_deg(world[:, tails] - world[:, heads], truth[:, tails] - truth[:, heads]))
        result["world aligned"] = _summary(_angles_deg(*(p[:, tails] - p[:, heads]
                                                         for p in (_rotated_onto(world, truth), truth))))
        result["world depth sign"] = {"share": depth_sign_share(world, truth)}
    return result


def _rotated_onto(points: np.ndarray, target: np.ndarray) -> np.ndarray:
    """points (T, N, 3) centred and turned per frame by the rotation that best maps them onto target (T, N, 3)
    (Kabsch, no reflection, no scale)."""
    a = points - points.mean(axis=1, keepdims=True)
    b = target - target.mean(axis=1, keepdims=True)
    u, _, vt = np.linalg.svd(np.einsum("tni,tnj->tij", b, a))
    d = np.sign(np.linalg.det(u @ vt))
    u[..., :, 2] *= d[:, None]
    return np.einsum("tij,tnj->tni", u @ vt, a)


OUT_OF_PLANE = 0.3     # a phalanx whose unit direction has |z| above this points > 17 deg out of the image plane


def depth_sign_share(points: np.ndarray, truth: np.ndarray) -> float:
    """Share of the finger phalanges pointing more than 17 deg out of the image plane in truth (T, 21, 3) whose
    depth sign (towards or away from the camera, z) points (T, 21, 3) get right; hand landmark order, metres."""
    heads, tails = (np.array(ends) for ends in zip(*PHALANGES))
    dz = [(p[:, tails, 2] - p[:, heads, 2]) / np.linalg.norm(p[:, tails] - p[:, heads], axis=-1)
          for p in (points, truth)]
    out = np.abs(dz[1]) > OUT_OF_PLANE
    return float(np.mean(np.sign(dz[0][out]) == np.sign(dz[1][out]))) if out.any() else float("nan")


def image_only(clip):
    """The clip without its world components (as the lexicon: image landmarks only)."""
    from media.lexicon import SignClip
    from media.pose_file import HAND_WORLD_COMPONENTS

    dropped = set(HAND_WORLD_COMPONENTS)
    return SignClip(clip.fps, {k: v for k, v in clip.points.items() if k not in dropped},
                    {k: v for k, v in clip.confidence.items() if k not in dropped})


def measure(loop: Loop, jitter_filter: str | None = None, side: str = "R", method: str | None = None,
            world: bool = True) -> dict:
    """Retarget the loop's extracted clip (jitter_filter, method: media.retarget's; world: keep the hands' world
    landmarks, else only the image landmarks, as the lexicon has) and compare with the original."""
    from media.avatar import load_avatar
    from media.retarget import retarget

    skeleton = load_avatar().skeleton
    clip = loop.clip if world else image_only(loop.clip)
    started = time.perf_counter()
    result = retarget(clip, skeleton, jitter_filter=jitter_filter, method=method)
    seconds = time.perf_counter() - started
    motion = result.motion
    original = loop.original
    if motion.n_frames != original.n_frames:
        raise ValueError(f"{motion.n_frames} retargeted frames for {original.n_frames} rendered")
    component = f"{HAND_PREFIX[side]}_HAND_LANDMARKS"
    found = np.all(clip.confidence[component] > 0, axis=1)
    truth_3d, retargeted_3d = hand_joints(skeleton, original, side), hand_joints(skeleton, motion, side)
    truth_px = project(loop.camera, truth_3d, loop.size)
    retargeted_px = project(loop.camera, retargeted_3d, loop.size)
    extracted_px = clip.points[component][..., :2]
    retargeted_error = np.linalg.norm(retargeted_px - truth_px, axis=-1)            # (T, 21)
    extracted_error = np.linalg.norm(extracted_px - truth_px, axis=-1)[found]       # (F, 21)
    palm_px = np.median(np.linalg.norm(truth_px[:, 9] - truth_px[:, 0], axis=-1))
    return {
        "filter": jitter_filter or "default",
        "method": (method or "default") + ("" if world else " 2D"),
        "seconds": seconds,
        "frames": int(original.n_frames),
        "hands": list(result.hands),
        "found_share": float(np.mean(found)),
        "palm_px": float(palm_px),
        "wrist_px": {"retargeted": _summary(retargeted_error[:, 0]), "extracted": _summary(extracted_error[:, 0])},
        "hand_px": {"retargeted": _summary(retargeted_error), "extracted": _summary(extracted_error)},
        "angles_deg": angle_errors(original, motion, side),
        "depth_sign": depth_sign_share(retargeted_3d[found], truth_3d[found]),
    }


def format_table(rows: list[dict]) -> str:
    lines = [f"{'method':12} {'filter':9} {'found':>5} {'palm':>5} | {'wrist px':>13} {'hand px':>13} {'landmark px':>13} | "
             f"{'torso deg':>11} {'arm deg':>11} {'finger deg':>11}",
             f"{'':12} {'':9} {'':>5} {'px':>5} | {'retarget':>13} {'retarget':>13} {'extracted':>13} | "
             f"{'mean/p90':>11} {'mean/p90':>11} {'mean/p90':>11}"]
    for row in rows:
        pair = lambda d: f"{d['mean']:5.1f}/{d['p90']:5.1f}"
        lines.append(f"{row['method']:12} {row['filter']:9} {row['found_share']:5.2f} {row['palm_px']:5.1f} | "
                     f"{pair(row['wrist_px']['retargeted']):>13} {pair(row['hand_px']['retargeted']):>13} "
                     f"{pair(row['hand_px']['extracted']):>13} | {pair(row['angles_deg']['torso']):>11} "
                     f"{pair(row['angles_deg']['arm']):>11} {pair(row['angles_deg']['fingers']):>11}")
    return "\n".join(lines)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--language", default="ase")
    parser.add_argument("--word", default="HI")
    parser.add_argument("--size", default="352x288", help="WxH")
    parser.add_argument("--zoom", type=float, default=None,
                        help="frame a head-and-torso shot, the full figure zoomed by this (e.g. 1.7); default: full figure")
    parser.add_argument("--filters", default="one-euro,binomial,off")
    parser.add_argument("--methods", default="fit,fit-2d,lifting",
                        help="fit (world landmarks), fit-2d (image landmarks only), lifting (the former method)")
    parser.add_argument("--save-pose", type=Path, help="also write the extracted clip's arrays to this .npz")
    args = parser.parse_args()
    width, height = (int(v) for v in args.size.lower().split("x"))
    loop = run_loop(args.language, args.word, (width, height), zoom=args.zoom)
    print(f"{args.language} {args.word!r} {width}x{height} {f'zoom {args.zoom}' if args.zoom else 'full figure'}: "
          f"{loop.original.n_frames} frames, render {loop.seconds['render']:.1f} s, "
          f"extract {loop.seconds['extract']:.1f} s")
    floor = landmark_errors(loop)
    print("extractor's phalanx direction error (deg mean/p90): "
          + ", ".join(f"{name} {d['mean']:.1f}/{d['p90']:.1f}" for name, d in floor.items() if "mean" in d)
          + "".join(f"; world landmarks' depth sign right on {d['share']:.0%} of the out-of-plane phalanges"
                    for name, d in floor.items() if "share" in d), flush=True)
    if args.save_pose:
        np.savez_compressed(args.save_pose, fps=loop.clip.fps,
                            **{f"points_{k}": v for k, v in loop.clip.points.items()},
                            **{f"confidence_{k}": v for k, v in loop.clip.confidence.items()})
    rows = []
    for method in args.methods.split(","):
        for name in args.filters.split(","):
            rows.append(measure(loop, name, method="fit" if method.startswith("fit") else method,
                                world=method != "fit-2d"))
            print(f"{rows[-1]['method']} {name}: retargeting {rows[-1]['seconds']:.2f} s "
                  f"({1000 * rows[-1]['seconds'] / rows[-1]['frames']:.1f} ms a frame), depth sign right on "
                  f"{rows[-1]['depth_sign']:.0%} of the out-of-plane phalanges", flush=True)
    print(format_table(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())

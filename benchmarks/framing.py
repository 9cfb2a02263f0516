"""The avatar framed like the person (issue 34, section 2): hands found and wrist location, full figure vs framed.

For each source clip (a person's video), as `compare --video` does it:
1. the source's landmarks are extracted (media.landmarks, the extractor `signcast pose` uses), retargeted to the
   avatar (media.retarget) and cut or held to the clip's frames;
2. the avatar is rendered at the clip's size three times: with the signing-space camera ("full-figure"), framed
   like the person by the geometric fit alone ("geometric fit", media.framing.fit_framing: one zoom and shift of
   the camera per clip) and as compare and render do it ("source": the geometric fit corrected by reading back a
   dozen framed frames, pipeline.studies.shared.source_framing);
3. each render's landmarks are extracted and compared with the source's (comparisons.judging.fidelity): per hand
   found (percent of the frames where the source shows it), wrist location (shoulder widths after the clip-wide
   similarity); the hand size ratio render / source (median over frames both show the hand); and how well the
   render lines up with the source without any similarity: the mean distance of the pose's anchor points (nose,
   eyes, ears, mouth, shoulders) in the source's shoulder widths, and the similarity (scale, shift) that would still
   map the render's anchors onto the source's (1 and 0 when they line up).

Sources: carphone (the clip compare --video uses by default: head and shoulders, no hands in view), and the
avatar itself used as the "person": Czech fingerspelling (two-handed) rendered at --size as the full figure, and
the same clip shot closer (a head-and-torso picture, zoom 1.7), each then treated as any person's video.

    .venv/bin/python benchmarks/framing.py [--word HRAD] [--language cse] [--frames 60] [--size 352x288]
        [--no-carphone] [--out results.json] [--picture docs/framing-carphone.png]
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

CLOSE_ZOOM = 1.7     # the head-and-torso shot of the avatar-as-person clip


def avatar_person(language: str, word: str, n_frames: int, size: tuple[int, int], zoom: float | None):
    """(frames (T, H, W, 3) uint8, fps) of the avatar fingerspelling word, full figure, or zoomed by `zoom` about
    its shoulders' midpoint placed at 55 % of the height (a head-and-torso picture)."""
    from media.avatar import load_avatar
    from media.fingerspelling import fingerspell
    from media.framing import Framing, anchor_track
    from media.render import RenderSettings, render_motion, signing_space_camera
    avatar = load_avatar()
    motion = fingerspell(language, word, fps=25.0)
    motion = motion.frames(0, min(n_frames, motion.n_frames))
    framing = None
    if zoom is not None:
        width, height = size
        shoulders = anchor_track(avatar, motion.frames(0, 1), signing_space_camera(avatar, width, height),
                                 width, height)[0, 7:].mean(axis=0)
        framing = Framing(zoom, ((width / 2 - zoom * shoulders[0]) / width, (0.55 * height - zoom * shoulders[1]) / height))
    frames, _ = render_motion(avatar, motion, RenderSettings(*size, look="shaded", framing=framing))
    return frames, motion.fps


def lined_up(source, render) -> dict:
    """Anchor distance (source shoulder widths, no similarity) and the residual similarity render -> source."""
    from comparisons.judging.fidelity import ANCHOR_POINTS, clip_similarity, shoulder_width
    shown = lambda clip: np.all(clip.confidence["POSE_LANDMARKS"][:, ANCHOR_POINTS] > 0, axis=1)
    both = shown(source) & shown(render)
    if not both.any():
        return {"anchor_distance": None, "residual_scale": None, "residual_shift": None}
    a = source.points["POSE_LANDMARKS"][both][:, ANCHOR_POINTS, :2]
    b = render.points["POSE_LANDMARKS"][both][:, ANCHOR_POINTS, :2]
    width = shoulder_width(source.points["POSE_LANDMARKS"], shown(source))
    scale, rotation, shift = clip_similarity(source.points["POSE_LANDMARKS"], render.points["POSE_LANDMARKS"], both)
    centre = b.reshape(-1, 2).mean(axis=0)     # the shift the similarity adds at the render's anchors' centre
    moved = scale * centre @ rotation.T + shift - centre
    return {"anchor_distance": float(np.mean(np.linalg.norm(a - b, axis=-1)) / width),
            "residual_scale": float(scale), "residual_shift": float(np.linalg.norm(moved) / width),
            "residual_rotation_deg": float(np.degrees(np.arctan2(rotation[1, 0], rotation[0, 0])))}


def hand_size_ratio(source, render, component: str) -> float | None:
    from comparisons.judging.intelligibility import hand_sizes
    both = np.all(source.confidence[component] > 0, axis=1) & np.all(render.confidence[component] > 0, axis=1)
    if not both.any():
        return None
    return float(np.median(hand_sizes(render.points[component][both]) / hand_sizes(source.points[component][both])))


def measure(name: str, frames: np.ndarray, fps: float, picture: Path | None = None, picture_frame: int = 20) -> dict:
    """One source's row (see the module docstring); picture: also write frame picture_frame of the source, the full
    figure and the framed render side by side, each with the landmarks found on it, as a PNG."""
    from comparisons.judging.fidelity import message_fidelity
    from media.avatar import load_avatar
    from media.render import AvatarRenderer, RenderSettings
    from media.retarget import retarget
    from pipeline.studies.shared import draw_landmarks, extract_landmarks, fit_length, render_frames, source_framing
    height, width = frames.shape[1:3]
    source = extract_landmarks(frames, fps, f"{name}: source", progress=False)
    avatar = load_avatar()
    motion = fit_length(retarget(source, avatar.skeleton).motion, len(frames))
    notify = lambda line: print(line, file=sys.stderr)
    geometric = source_framing(motion, source, (width, height), (width, height), name, notify, read_back=False)
    framing = source_framing(motion, source, (width, height), (width, height), name, notify)
    described = lambda f: None if f is None else {"scale": f.scale, "shift": list(f.shift), "turn_deg": f.turn}
    row = {"source": name, "frames": len(frames), "size": [width, height], "fps": fps,
           "framing": described(framing), "geometric_framing": described(geometric)}
    tiles = [(draw_landmarks(frames[picture_frame:picture_frame + 1], _frame(source, picture_frame)), name)]
    for label, chosen in (("full-figure", None), ("geometric fit", geometric), ("source", framing)):
        renderer = AvatarRenderer(avatar, RenderSettings(width, height, look="shaded", framing=chosen))
        render, _ = render_frames(renderer, motion, f"{name}: {label}", progress=False)
        observed = extract_landmarks(render, fps, f"{name}: {label} landmarks", progress=False)
        fidelity = message_fidelity(source, observed)
        if label != "geometric fit":
            tiles.append((draw_landmarks(render[picture_frame:picture_frame + 1], _frame(observed, picture_frame)),
                          "avatar, full figure" if chosen is None else "avatar, framed like the person"))
        row[label] = {"left_found": fidelity["left_found"], "right_found": fidelity["right_found"],
                      "left_location": fidelity["left_location"], "right_location": fidelity["right_location"],
                      "source_left_frames": int(np.all(source.confidence["LEFT_HAND_LANDMARKS"] > 0, axis=1).sum()),
                      "source_right_frames": int(np.all(source.confidence["RIGHT_HAND_LANDMARKS"] > 0, axis=1).sum()),
                      "left_size_ratio": hand_size_ratio(source, observed, "LEFT_HAND_LANDMARKS"),
                      "right_size_ratio": hand_size_ratio(source, observed, "RIGHT_HAND_LANDMARKS"),
                      **lined_up(source, observed)}
    if picture is not None:
        import cv2
        from media.tiling import tile_videos
        cv2.imwrite(str(picture), tile_videos(tiles, (352, 288), 3)[0][..., ::-1])
    return row


def _frame(clip, t: int):
    from media.lexicon import SignClip
    return SignClip(clip.fps, {k: v[t:t + 1] for k, v in clip.points.items()},
                    {k: v[t:t + 1] for k, v in clip.confidence.items()})


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--language", default="cse")
    parser.add_argument("--word", default="HRAD")
    parser.add_argument("--frames", type=int, default=60, help="frames of the avatar-as-person clip")
    parser.add_argument("--size", default="352x288", help="frame size of the avatar-as-person clips (WxH)")
    parser.add_argument("--no-carphone", action="store_true", help="only the avatar-as-person clips")
    parser.add_argument("--out", type=Path, help="also write the rows as JSON")
    parser.add_argument("--picture", type=Path, help="also write carphone's frame 20 beside the avatar's renders (PNG)")
    args = parser.parse_args()
    from pipeline.studies.shared import read_natural_clip
    started = time.perf_counter()
    from media.domain import parse_size
    size = parse_size(args.size)
    rows = []
    if not args.no_carphone:
        clip, _ = read_natural_clip("carphone", None, (352, 288), progress=False)
        rows.append(measure("carphone", clip.frames, clip.fps, args.picture))
    for label, zoom in (("avatar full figure", None), (f"avatar head-and-torso (zoom {CLOSE_ZOOM})", CLOSE_ZOOM)):
        frames, fps = avatar_person(args.language, args.word, args.frames, size, zoom)
        rows.append(measure(f"{label}, {args.language} {args.word}, {size[0]}x{size[1]}", frames, fps))
    for row in rows:
        print(json.dumps(row))
    print(f"wall {time.perf_counter() - started:.0f} s", file=sys.stderr)
    if args.out:
        args.out.write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())

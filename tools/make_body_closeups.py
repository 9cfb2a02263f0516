"""Close-ups of the avatar's body while it signs real lexicon letters and words, captioned (docs/).

- docs/body-idle-arm.png: a one-handed letter (ASL B by default) framed head to feet, the arm whose hand the
  clip never shows resting beside the body (media.retarget natural rest), with a zoom on the resting hand.
- docs/body-torso-turn.png: the letter (of a language's lexicon) whose retargeting moves a clavicle most: its
  neutral frame (clavicles and spine roll nearest 0) beside the frame of the largest clavicle elevation, the
  shoulder joints and clavicles of both frames drawn over the second, and their difference.
- docs/body-transitions.png: a fingerspelled word (DGS WASSER by default), one frame per held letter and one
  in the middle of each transition, over a plot of both wrists' heights through the word: the arm stays up
  between letters; for comparison the same letter clips played whole one after another (each rises and drops).

    python tools/make_body_closeups.py [--only idle,torso,transitions] [--letter ase:B]
        [--torso-language ase] [--word gsg:WASSER] [--out-dir docs]
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

WHITE, BLACK = (255, 255, 255), (0, 0, 0)
NEUTRAL_COLOUR, MOVED_COLOUR = (40, 160, 255), (255, 80, 40)     # RGB: the neutral frame, the moved frame


def caption(image: np.ndarray, lines: list[str], scale: float = 0.8, top: int = 30) -> np.ndarray:
    """The image (RGB) with lines of white-on-black text at its top left."""
    image = np.ascontiguousarray(image)
    for k, line in enumerate(lines):
        origin = (12, top + k * int(36 * scale))
        cv2.putText(image, line, origin, cv2.FONT_HERSHEY_SIMPLEX, scale, BLACK, 5, cv2.LINE_AA)
        cv2.putText(image, line, origin, cv2.FONT_HERSHEY_SIMPLEX, scale, WHITE, 2, cv2.LINE_AA)
    return image


def project(camera: np.ndarray, points: np.ndarray, width: int, height: int) -> np.ndarray:
    """World points (..., 3) metres -> pixels (..., 2) (x right, y down), as the rasterizer places them."""
    homogeneous = np.concatenate([points, np.ones(points.shape[:-1] + (1,))], axis=-1) @ np.asarray(camera, np.float64).T
    ndc = homogeneous[..., :2] / homogeneous[..., 3:4]
    return np.stack([(ndc[..., 0] * 0.5 + 0.5) * width, (0.5 - ndc[..., 1] * 0.5) * height], axis=-1)


def crop(image: np.ndarray, centre: np.ndarray, half: tuple[int, int], size: tuple[int, int]) -> np.ndarray:
    """A (2 half_x, 2 half_y) crop of the image around centre (x, y) pixels, edge-padded, resized to size (w, h)."""
    hx, hy = half
    padded = np.pad(image, ((hy, hy), (hx, hx), (0, 0)), mode="edge")
    x, y = int(round(centre[0])), int(round(centre[1]))
    return cv2.resize(np.ascontiguousarray(padded[y:y + 2 * hy, x:x + 2 * hx]), size, interpolation=cv2.INTER_AREA)


def renderer_for(avatar, width: int, height: int, camera: np.ndarray | None = None):
    from media.render import AvatarRenderer, RenderSettings

    renderer = AvatarRenderer(avatar, RenderSettings(width=width, height=height))
    if camera is not None:
        renderer.camera = camera
    return renderer


def render(renderer, motion) -> np.ndarray:
    """(T, H, W, 3) uint8 RGB frames of the motion."""
    return np.stack([rgb for rgb, _ in renderer.frames(motion)])


def full_body_half_height(avatar, width: int, height: int) -> float:
    """Half the height (metres) that frames the whole avatar, head to feet, at this aspect ratio."""
    low, high = float(avatar.vertices[:, 1].min()) - 0.04, float(avatar.vertices[:, 1].max()) + 0.04
    return max((high - low) / 2, float(np.abs(avatar.vertices[:, 0]).max() + 0.1) * height / width)


def full_body_camera(avatar, width: int, height: int) -> np.ndarray:
    """World -> clip matrix framing the whole avatar (head to feet) from 3 m in front."""
    from kernels import camera

    centre = (float(avatar.vertices[:, 1].min()) + float(avatar.vertices[:, 1].max())) / 2
    fovy = 2 * np.degrees(np.arctan(full_body_half_height(avatar, width, height) / 3.0))
    return camera.view_projection((0.0, centre, 3.0), (0.0, centre, 0.0), fovy, width / height, 1.5, 4.5)


def held_letter(language: str, unit: str):
    """The retargeted letter (natural rest for an unseen arm) and its held span's middle frame."""
    from media import lexicon
    from media.fingerspelling import held_span
    from media.retarget import retarget

    clip = lexicon.read_clip(lexicon.lookup(language, unit))
    result = retarget(clip, unseen_arm="natural")
    start, stop = held_span(clip)
    return result, (start + stop) // 2


def idle_arm(avatar, language: str, unit: str, out: Path) -> None:
    from kernels import camera
    from media.kinematics import joint_positions
    from media.lexicon import lookup
    from media.retarget import SIDES

    result, middle = held_letter(language, unit)
    motion = result.motion.frames(middle, middle + 1)
    width, height = 720, 1280
    renderer = renderer_for(avatar, width, height, full_body_camera(avatar, width, height))
    frame = render(renderer, motion)[0]
    signing = {SIDES[hand] for hand in result.hands}
    side = next((s for s in ("L", "R") if s not in signing), "L")
    # the resting arm again, rendered close: a camera in front of it framing shoulder to fingertips
    skeleton = avatar.skeleton
    joints = joint_positions(skeleton, motion)[0]
    tips = joint_positions(skeleton, motion, tails=True)[0, skeleton.index(f"finger3-3.{side}")]
    shoulder = joints[skeleton.index(f"upperarm01.{side}")]
    centre = (shoulder + tips) / 2
    half_height = 0.58 * (shoulder[1] - tips[1])
    zoom_width = 480
    close = camera.view_projection((centre[0], centre[1], 3.0), (centre[0], centre[1], 0.0),
                                   2 * np.degrees(np.arctan(half_height / 3.0)), zoom_width / height, 1.5, 4.5)
    zoom = render(renderer_for(avatar, zoom_width, height, close), motion)[0]
    scale = (height / (2 * half_height)) / (height / (2 * full_body_half_height(avatar, width, height)))
    unit = lookup(language, unit).unit
    hands = " and ".join(result.hands) or "no"
    rest = "left" if side == "L" else "right"
    left = caption(frame.copy(), [f"{language} {unit}, held: the {hands} hand signs,",
                                  f"the {rest} arm (never seen) rests"])
    right = caption(zoom, [f"the resting {rest} arm, x{scale:.1f}", "(retarget natural rest)"], 0.8)
    write(out, np.concatenate([left, right], axis=1))


def signed_elevations(motion) -> np.ndarray:
    """(T, 2) degrees: the clavicles' elevation (left, right), + raising the shoulder (see media.retarget)."""
    from media import rotations

    result = []
    for side, outwards in (("L", 1.0), ("R", -1.0)):
        axis, angle = rotations.to_axis_angle(motion.rotations[:, motion.bone(f"clavicle.{side}")])
        result.append(np.degrees(angle) * np.sign(axis[:, 2]) * outwards)
    return np.stack(result, axis=1)


def torso_turn(avatar, language: str, out: Path) -> None:
    from media import lexicon, rotations
    from media.fingerspelling import held_span
    from media.kinematics import joint_positions
    from media.motion import Motion
    from media.retarget import retarget

    best = None
    for entry in lexicon.entries(language):
        clip = lexicon.read_clip(entry)
        motion = retarget(clip, unseen_arm="natural").motion
        elevation = signed_elevations(motion)
        start, stop = held_span(clip)
        shrug = elevation[start:stop].max(axis=1)
        if best is None or shrug.max() > best[3]:
            best = (entry, motion, elevation, float(shrug.max()), start + int(np.argmax(shrug)))
    entry, motion, elevation, _, moved = best
    roll = sum(np.degrees(rotations.to_axis_angle(motion.rotations[:, motion.bone(b)])[1])
               * np.sign(rotations.to_axis_angle(motion.rotations[:, motion.bone(b)])[0][:, 2])
               for b in ("spine01", "spine02", "spine03"))
    neutral = int(np.argmin(np.abs(elevation).sum(axis=1) + np.abs(roll) + 100.0 * (np.arange(motion.n_frames) == moved)))
    width, height = 1280, 1024
    renderer = renderer_for(avatar, width, height)
    pair = Motion(motion.fps, motion.bone_names, motion.rotations[[neutral, moved]], motion.root_translation[[neutral, moved]])
    frames = dict(zip((neutral, moved), render(renderer, pair)))
    skeleton = avatar.skeleton
    joints = joint_positions(skeleton, motion)
    bones = [(f"clavicle.{s}", f"shoulder01.{s}") for s in ("L", "R")]
    marks = {t: {name: project(renderer.camera, joints[t, skeleton.index(name)], width, height)
                 for pair in bones for name in pair} for t in (neutral, moved)}
    centre = (marks[neutral]["clavicle.L"] + marks[neutral]["clavicle.R"]) / 2 + np.array([0.0, 40.0])
    half = (int(abs(marks[neutral]["shoulder01.L"][0] - centre[0]) * 2.6), 0)
    half = (half[0], int(half[0] * 0.8))
    tile = (600, 480)
    overlay = frames[moved].copy()
    for t, colour in ((neutral, NEUTRAL_COLOUR), (moved, MOVED_COLOUR)):
        for head, tail in bones:
            a, b = marks[t][head], marks[t][tail]
            cv2.line(overlay, tuple(int(v) for v in a), tuple(int(v) for v in b), colour, 3, cv2.LINE_AA)
            cv2.circle(overlay, tuple(int(v) for v in b), 6, colour, -1, cv2.LINE_AA)
    # the two frames as one: red where the moved frame's body is, cyan where the neutral one's is
    brightness = lambda frame: frame.astype(np.float64).mean(axis=-1)
    onion = np.stack([brightness(frames[neutral]), brightness(frames[moved]), brightness(frames[moved])], axis=-1)
    onion = np.clip(onion, 0, 255).astype(np.uint8)
    describe = lambda t: f"clavicles L {elevation[t, 0]:+.1f}, R {elevation[t, 1]:+.1f} deg, spine roll {roll[t]:+.1f}"
    panels = [
        caption(crop(frames[neutral], centre, half, tile), [f"{language} {entry.unit}, frame {neutral}: neutral",
                                                           describe(neutral)], 0.6),
        caption(crop(overlay, centre, half, tile), [f"frame {moved}: largest shrug while held", describe(moved),
                                                    "clavicles: blue neutral, red this frame"], 0.6),
        caption(crop(onion, centre, half, tile), ["both frames: red where only the neutral", "body is, cyan where only this one"], 0.6),
    ]
    write(out, np.concatenate(panels, axis=1))


def height_plot(series: np.ndarray, spans, picks, width: int, title: str, colour) -> np.ndarray:
    """A (240, width, 3) plot of one height series (T,) metres over its frames, letter spans shaded and named."""
    plot = np.full((240, width, 3), 255, np.uint8)
    left, right, top, bottom = 80, width - 20, 60, 220
    low, high = float(series.min()) - 0.02, float(series.max()) + 0.02
    n = len(series)
    to_px = lambda t, y: (int(left + t / max(n - 1, 1) * (right - left)), int(bottom - (y - low) / (high - low) * (bottom - top)))
    for unit, start, end in spans:
        cv2.rectangle(plot, to_px(start, high), to_px(end - 1, low), (225, 235, 250), -1)
        cv2.putText(plot, unit, (to_px((start + end) / 2, high)[0] - 8, top - 8), cv2.FONT_HERSHEY_SIMPLEX, 0.7, BLACK, 2, cv2.LINE_AA)
    for t in picks:
        cv2.line(plot, to_px(t, low), to_px(t, high), (190, 190, 190), 1)
    for y in np.arange(np.ceil(low * 10) / 10, high, 0.1):
        cv2.line(plot, to_px(0, y), to_px(n - 1, y), (235, 235, 235), 1)
        cv2.putText(plot, f"{y * 100:+.0f}", (20, to_px(0, y)[1] + 6), cv2.FONT_HERSHEY_SIMPLEX, 0.5, BLACK, 1, cv2.LINE_AA)
    points = np.array([to_px(t, y) for t, y in enumerate(series)], np.int32)
    cv2.polylines(plot, [points], False, colour, 3, cv2.LINE_AA)
    cv2.putText(plot, title, (left, 24), cv2.FONT_HERSHEY_SIMPLEX, 0.7, BLACK, 2, cv2.LINE_AA)
    return plot


def transitions(avatar, language: str, word: str, out: Path) -> None:
    from media import fingerspelling
    from media.kinematics import joint_positions
    from media.motion import Motion, concatenate

    motion = fingerspelling.fingerspell(language, word)
    spans = fingerspelling.letter_spans(language, word)
    drops = fingerspelling.interletter_drops(motion, spans, avatar.skeleton)
    picks = []                                           # (frame, label)
    for k, (unit, start, end) in enumerate(spans):
        picks.append(((start + end) // 2, unit))
        if k + 1 < len(spans):
            picks.append(((end + spans[k + 1][1]) // 2, f"{unit} > {spans[k + 1][0]}"))
    width, height = 640, 512
    renderer = renderer_for(avatar, width, height)
    chosen = [t for t, _ in picks]
    frames = render(renderer, Motion(motion.fps, motion.bone_names, motion.rotations[chosen], motion.root_translation[chosen]))
    tiles = [caption(cv2.resize(np.ascontiguousarray(f[0:400, 150:490]), (306, 360), interpolation=cv2.INTER_AREA),
                     [label, f"frame {t}"], 0.7) for f, (t, label) in zip(frames, picks)]
    strip = np.concatenate(tiles, axis=1)
    skeleton = avatar.skeleton
    wrist = [skeleton.index("wrist.L"), skeleton.index("wrist.R")]
    shoulder = float(skeleton.heads[skeleton.index("upperarm01.R"), 1])
    palm = float(np.linalg.norm(skeleton.heads[skeleton.index("finger3-1.R")] - skeleton.heads[skeleton.index("wrist.R")]))
    spelled = joint_positions(skeleton, motion)[:, wrist, 1].max(axis=1) - shoulder
    # the same clips played whole, one after another: each rises into place and drops away
    letters = [fingerspelling.letter_motion(language, unit, motion.fps) for unit, _, _ in spans]
    whole = joint_positions(skeleton, concatenate(letters))[:, wrist, 1].max(axis=1) - shoulder
    bounds = np.cumsum([0] + [m.n_frames for m in letters])
    whole_spans = [(unit, int(a), int(b)) for (unit, _, _), a, b in zip(spans, bounds[:-1], bounds[1:])]
    top = height_plot(spelled, spans, chosen, strip.shape[1],
                      f"{language} {word} spelled: the higher wrist's height above the shoulder joint, cm, per frame "
                      f"(grey lines: the frames above); largest dip between letters {drops.max() * 100:.1f} cm "
                      f"({drops.max() / palm:.2f} palm lengths)", (200, 40, 40))
    bottom = height_plot(whole, whole_spans, [], strip.shape[1],
                         "for comparison, the same letter clips played whole one after another: each rises into place "
                         "and drops away", (150, 150, 150))
    write(out, np.concatenate([strip, top, bottom], axis=0))


def write(out: Path, image: np.ndarray) -> None:
    out.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(out), cv2.cvtColor(image, cv2.COLOR_RGB2BGR))
    print(out)


def main() -> int:
    from media.avatar import load_avatar

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", default="idle,torso,transitions", help="comma-separated: idle, torso, transitions")
    parser.add_argument("--letter", default="ase:B", help="LANGUAGE:UNIT of the idle-arm letter")
    parser.add_argument("--torso-language", default="ase", help="language whose letters are searched for the torso figure")
    parser.add_argument("--word", default="gsg:WASSER", help="LANGUAGE:WORD of the transitions figure")
    parser.add_argument("--out-dir", default=str(ROOT / "docs"))
    args = parser.parse_args()
    out_dir = Path(args.out_dir)
    avatar = load_avatar()
    chosen = {name.strip() for name in args.only.split(",")}
    if "idle" in chosen:
        idle_arm(avatar, *args.letter.split(":", 1), out_dir / "body-idle-arm.png")
    if "torso" in chosen:
        torso_turn(avatar, args.torso_language, out_dir / "body-torso-turn.png")
    if "transitions" in chosen:
        transitions(avatar, *args.word.split(":", 1), out_dir / "body-transitions.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())

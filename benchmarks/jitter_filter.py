"""What the keypoint jitter filter (media.jitter_filter, through media.retarget) does to the motion and its cost.

For lexicon clips (real signers' MediaPipe keypoints, e.g. ASL A-J and Czech two-handed letters) and, when given,
a closed loop's extracted clip (benchmarks/closed_loop.py --save-pose), each clip is retargeted with each filter
(off, binomial, one-euro), resampled to 25 fps and coded with the project's FBA and BBA coders at a couple of Q
(real coded bytes). Reported per filter, pooled over the clips:

- kbps: 8 x coded bytes / clip duration / 1000, summed over the clips' durations, per codec and Q;
- jitter: the mean angular acceleration (deg/s^2) of the local rotations, per bone group (arm, fingers): the
  norm of the frame-to-frame change of the angular velocity log(q_t^-1 q_t+1) x fps, times fps;
- change: the mean geodesic angle (deg) between each bone's local rotation with this filter and without one
  (what the filter moves the pose: smoothing and lag);
- for the closed loop only, the error (deg, mean) against the known original motion per bone group.

    python benchmarks/jitter_filter.py [--clips ase:ABCDEFGHIJ,cse:ABCDE] [--loop loop.npz] [--q 4,16]
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from media.domain import kbps  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from media import rotations  # noqa: E402
from media.retarget import FINGER_CHAINS, SIDES  # noqa: E402

FILTERS = ("off", "binomial", "one-euro")
CODECS = ("fba-pred", "bba-pred")
GROUPS = {
    "arm": ("upperarm01", "lowerarm01", "lowerarm02", "wrist"),
    "fingers": tuple(bone for chain in FINGER_CHAINS.values() for bone, _, _ in chain),
}


def group_columns(motion, hands) -> dict[str, list[int]]:
    """Motion columns of each bone group over the hands the clip shows."""
    sides = [SIDES[hand] for hand in hands]
    return {group: [motion.bone(f"{bone}.{side}") for side in sides for bone in bones]
            for group, bones in GROUPS.items()}


def angular_acceleration(q: np.ndarray, fps: float) -> np.ndarray:
    """(T-2, B) angular acceleration magnitude (deg/s^2) of local rotations q (T, B, 4)."""
    step = rotations.multiply(rotations.conjugate(q[:-1]), q[1:])
    axis, angle = rotations.to_axis_angle(rotations.canonical(step))
    velocity = axis * angle[..., None] * fps                                  # (T-1, B, 3) rad/s
    return np.degrees(np.linalg.norm(np.diff(velocity, axis=0), axis=-1) * fps)


def coded_kbps(motion, codec: str, q: int) -> float:
    from comparisons.params.codecs import get_codec
    return kbps(8 * len(get_codec(codec).encode(motion, q)), motion.duration_s)


def lexicon_clips(spec: str):
    """'ase:ABC,cse:AB' -> [(name, SignClip)]."""
    from media import lexicon
    clips = []
    for part in spec.split(","):
        language, letters = part.split(":")
        for letter in letters:
            clips.append((f"{language}:{letter}", lexicon.read_clip(lexicon.lookup(language, letter))))
    return clips


def loop_clip(path: Path):
    """The extracted clip a closed loop saved (benchmarks/closed_loop.py --save-pose)."""
    from media.lexicon import SignClip
    data = np.load(path)
    points = {key[len("points_"):]: data[key] for key in data if key.startswith("points_")}
    confidence = {key[len("confidence_"):]: data[key] for key in data if key.startswith("confidence_")}
    return SignClip(float(data["fps"]), points, confidence)


def measure(clips, qs, truth=None) -> dict[str, dict]:
    """Per filter: kbps per (codec, q), jitter and change per group (and error per group against `truth`, a
    Motion with the clips' one clip's frames)."""
    from media.avatar import load_avatar
    from media.motion import resample
    from media.retarget import retarget

    skeleton = load_avatar().skeleton
    table = {name: {"bits": {}, "seconds": 0.0, "jitter": {g: [] for g in GROUPS}, "change": {g: [] for g in GROUPS},
                    "error": {g: [] for g in GROUPS}} for name in FILTERS}
    for _, clip in clips:
        motions = {name: retarget(clip, skeleton, jitter_filter=name) for name in FILTERS}
        hands = motions["off"].hands
        for name, result in motions.items():
            motion = result.motion
            columns = group_columns(motion, hands)
            row = table[name]
            coded = resample(motion, 25.0)
            row["seconds"] += coded.duration_s
            for codec in CODECS:
                for q in qs:
                    row["bits"][(codec, q)] = row["bits"].get((codec, q), 0.0) + coded_kbps(coded, codec, q) * coded.duration_s
            acceleration = angular_acceleration(motion.rotations, motion.fps)
            raw = motions["off"].motion.rotations
            for group, cols in columns.items():
                if not cols:
                    continue
                row["jitter"][group].extend(acceleration[:, cols].ravel().tolist())
                row["change"][group].extend(np.degrees(rotations.angle_between(motion.rotations[:, cols], raw[:, cols])).ravel().tolist())
                if truth is not None:
                    truth_cols = [truth.bone(motion.bone_names[c]) for c in cols]
                    row["error"][group].extend(np.degrees(rotations.angle_between(
                        motion.rotations[:, cols], truth.rotations[:, truth_cols])).ravel().tolist())
    report = {}
    for name, row in table.items():
        report[name] = {
            "kbps": {key: bits / row["seconds"] for key, bits in row["bits"].items()},
            "jitter": {g: float(np.mean(v)) if v else float("nan") for g, v in row["jitter"].items()},
            "change": {g: float(np.mean(v)) if v else float("nan") for g, v in row["change"].items()},
            "error": {g: float(np.mean(v)) if v else float("nan") for g, v in row["error"].items()},
        }
    return report


def format_report(title: str, report: dict, qs) -> str:
    keys = [(codec, q) for codec in CODECS for q in qs]
    head = " ".join(f"{codec[:3]}Q{q:<3}" for codec, q in keys)
    lines = [title, f"{'filter':9} {head} | {'jitter arm':>10} {'fingers':>8} | {'change arm':>10} {'fingers':>8}"
             f" | {'error arm':>9} {'fingers':>8}"]
    for name, row in report.items():
        rates = " ".join(f"{row['kbps'][key]:7.2f}" for key in keys)
        lines.append(f"{name:9} {rates} | {row['jitter']['arm']:10.0f} {row['jitter']['fingers']:8.0f} | "
                     f"{row['change']['arm']:10.2f} {row['change']['fingers']:8.2f} | "
                     f"{row['error']['arm']:9.2f} {row['error']['fingers']:8.2f}")
    return "\n".join(lines)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--clips", default="ase:ABCDEFGHIJ,cse:ABCDE")
    parser.add_argument("--loop", type=Path, help="a closed loop's extracted clip (.npz, closed_loop.py --save-pose)")
    parser.add_argument("--loop-word", default="ase:HI", help="LANGUAGE:WORD the loop rendered (its ground truth)")
    parser.add_argument("--q", default="4,16")
    args = parser.parse_args()
    qs = [int(q) for q in args.q.split(",")]
    print(format_report(f"lexicon clips {args.clips} (kbps at 25 fps; jitter deg/s^2; change, error deg)",
                        measure(lexicon_clips(args.clips), qs), qs))
    if args.loop:
        from media.fingerspelling import fingerspell
        language, word = args.loop_word.split(":")
        clip = loop_clip(args.loop)
        truth = fingerspell(language, word, fps=clip.fps)
        print()
        print(format_report(f"closed loop {args.loop_word} (rendered, extracted; error against the original)",
                            measure([("loop", clip)], qs, truth), qs))
    return 0


if __name__ == "__main__":
    sys.exit(main())

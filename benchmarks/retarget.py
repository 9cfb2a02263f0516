"""Retargeting speed and accuracy over the fingerspelling lexicon.

For each chosen sign language: seconds per clip to retarget (median over its letters, after a
warm-up), the hands found, and the mean angle (degrees) between each retargeted bone's direction
(forward kinematics) and the keypoint direction it follows, per bone group (arm, thumb, fingers):
"3d" against the lifted keypoint direction, "2d" in the image plane against the raw keypoints,
both over the frames the keypoints set; "prior%": the share of finger-bone frames a closed-hand
prior set instead (left out of the means; see media.retarget.overridden_share), and "all 3d": the
fingers' 3d mean over every frame, those included.

    python benchmarks/retarget.py [--languages ase,ise,cse]   (all languages if omitted)
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def main() -> int:
    from media import lexicon, retarget
    from media.avatar import load_avatar

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--languages", default=None, help="comma-separated codes (default: all)")
    args = parser.parse_args()
    codes = args.languages.split(",") if args.languages else lexicon.languages()
    skeleton = load_avatar().skeleton
    retarget.retarget(lexicon.read_clip(lexicon.entries("ase")[0]), skeleton)          # warm-up
    print(f"{'lang':5} {'clips':>5} {'s/clip':>7} {'hands':20} "
          f"{'3d arm':>7} {'thumb':>6} {'fingers':>7} {'2d arm':>7} {'thumb':>6} {'fingers':>7} {'prior%':>6} {'all 3d':>6}")
    for code in codes:
        seconds, hands, shares, everything = [], {}, [], []
        pooled = {kind: {group: [] for group in retarget.BONE_GROUPS} for kind in ("3d", "2d")}
        for entry in lexicon.entries(code):
            clip = lexicon.read_clip(entry)
            start = time.perf_counter()
            result = retarget.retarget(clip, skeleton)
            seconds.append(time.perf_counter() - start)
            key = "+".join(result.hands) or "none"
            hands[key] = hands.get(key, 0) + 1
            for kind, groups in retarget.direction_errors(result, skeleton).items():
                for group, angles in groups.items():
                    pooled[kind][group].extend(angles)
            shares.append(retarget.overridden_share(result))
            unmasked = retarget.Retargeted(result.motion, result.followed, result.projected, result.hands)
            everything.extend(retarget.direction_errors(unmasked, skeleton)["3d"]["fingers"])
        mean = {kind: {g: statistics.fmean(a) if a else float("nan") for g, a in groups.items()}
                for kind, groups in pooled.items()}
        hand_text = " ".join(f"{k}:{v}" for k, v in sorted(hands.items()))
        print(f"{code:5} {len(seconds):5d} {statistics.median(seconds):7.3f} {hand_text:20} "
              f"{mean['3d']['arm']:7.1f} {mean['3d']['thumb']:6.1f} {mean['3d']['fingers']:7.1f} "
              f"{mean['2d']['arm']:7.1f} {mean['2d']['thumb']:6.1f} {mean['2d']['fingers']:7.1f} "
              f"{100 * statistics.fmean(shares):6.1f} {statistics.fmean(everything) if everything else float('nan'):6.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

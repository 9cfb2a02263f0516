"""The letter recogniser's ceiling (comparisons/judging/letters.py): top-1 / top-3 on uncoded material.

1. Lexicon clips (the real signers' keypoints, uncoded) of three languages, each scored letter by letter.
   Scored frames: one half of the clip's held span (fingerspelling.held_span), both halves in turn (each
   clip counts twice). Template settings (templates never hold a scored frame):
   - own other half: the scored language's own clips, the OTHER half of each held span (the same signer
     and take as the scored frames: the most favourable setting);
   - other languages: every other language's clips, whole held spans; the scored language's clips are
     all left out (by file: the lexicon's fsl clips are its ase clips). Other signers, and a letter of the
     same name need not share the handshape;
   - own other half + other languages: both pools together.
   Every setting is run with the hand's image orientation kept and with hands rotated upright.
2. The avatar (domain gap of the avatar solutions): fingerspell('ase', the alphabet) rendered at 352x288
   shaded (media.render), landmarks extracted from the frames (media.landmarks.holistic), each letter
   scored over its held frames in the word (fingerspelling.letter_spans). Templates: the lexicon, as
   'ase clips' (all ASL held frames: the very takes the avatar was retargeted from), 'other languages'
   (ASL's clips left out) and both, each with image orientation kept and with hands rotated upright.

    .venv/bin/python benchmarks/letter_recognition.py [--languages ase gsg ssp] [--skip-avatar]
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path


sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from comparisons.judging.letters import Recogniser, recognise_spans, top_k  # noqa: E402
from media import lexicon  # noqa: E402
from media.fingerspelling import held_span  # noqa: E402

LEXICON_SETTINGS = ("own other half", "other languages", "own other half + other languages")


def half_of_held_span(clip: lexicon.SignClip, half: int) -> tuple[int, int]:
    """Frames [start, stop) of the first (0) or second (1) half of a clip's held span, as from_lexicon splits it."""
    start, stop = held_span(clip)
    middle = start + (stop - start) // 2
    return (start, middle) if half == 0 else (middle, stop)


def lexicon_ceiling(language: str, orientation: str) -> dict[str, tuple[float, float, int]]:
    """setting -> (top-1 %, top-3 %, spans scored) on the language's uncoded lexicon clips."""
    others = [code for code in lexicon.languages() if code != language]
    own_out = {(language, unit) for unit in lexicon.units(language)}
    other_pool = Recogniser.from_lexicon(others, exclude=own_out, orientation=orientation)
    results = {}
    for setting in LEXICON_SETTINGS:
        rankings, truths = [], []
        for half in (0, 1):
            own = Recogniser.from_lexicon([language], half=1 - half, orientation=orientation)
            recogniser = {"own other half": own, "other languages": other_pool}.get(setting) \
                or Recogniser.joined([own, other_pool])
            for entry in lexicon.entries(language):
                clip = lexicon.read_clip(entry)
                start, stop = half_of_held_span(clip, half)
                if stop > start:
                    rankings += recognise_spans(recogniser, clip, language, [(entry.unit, start, stop)])
                    truths.append(entry.unit)
        results[setting] = (top_k(rankings, truths, 1), top_k(rankings, truths, 3), len(truths))
    return results


def avatar_accuracy(word: str) -> tuple[dict[str, tuple[float, float, int]], float, list[tuple[str, list[str]]]]:
    """'setting, orientation' -> (top-1 %, top-3 %, spans) on landmarks extracted from the avatar fingerspelling `word` in
    ASL; the share (percent) of frames in which the right hand was found; (truth, ranking) per letter for
    the 'ase clips' setting."""
    from media.avatar import load_avatar
    from media.fingerspelling import fingerspell, letter_spans
    from media.landmarks.holistic import extract_landmarks
    from media.render import RenderSettings, render_motion

    motion = fingerspell("ase", word)
    frames, _ = render_motion(load_avatar(), motion, RenderSettings(352, 288, look="shaded"))
    clip = extract_landmarks(frames, motion.fps)
    spans = letter_spans("ase", word, motion.fps)
    truths = [unit for unit, _, _ in spans]
    others = [code for code in lexicon.languages() if code != "ase"]
    results, examples = {}, []
    for orientation in ("image", "upright"):
        own = Recogniser.from_lexicon(["ase"], orientation=orientation)
        other_pool = Recogniser.from_lexicon(others, exclude={("ase", unit) for unit in lexicon.units("ase")},
                                             orientation=orientation)
        for setting, recogniser in (("ase clips", own), ("other languages", other_pool),
                                    ("ase clips + other languages", Recogniser.joined([own, other_pool]))):
            rankings = recognise_spans(recogniser, clip, "ase", spans)
            results[f"{setting}, {orientation}"] = (top_k(rankings, truths, 1), top_k(rankings, truths, 3),
                                                    len(truths))
            if setting == "ase clips" and orientation == "image":
                examples = list(zip(truths, [ranking[:3] for ranking in rankings]))
    return results, 100.0 * clip.hand_visibility("right"), examples


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--languages", nargs="+", default=["ase", "gsg", "ssp"])
    parser.add_argument("--word", default="ABCDEFGHIJKLMNOPQRSTUVWXYZ")
    parser.add_argument("--skip-avatar", action="store_true")
    args = parser.parse_args(argv)

    print("Lexicon clips, uncoded: top-1 / top-3 % (letter spans scored)")
    print(f"{'language':9} {'orientation':12} " + " ".join(f"{setting:>34}" for setting in LEXICON_SETTINGS))
    for language in args.languages:
        for orientation in ("image", "upright"):
            results = lexicon_ceiling(language, orientation)
            cells = [f"{top1:5.1f} / {top3:5.1f} ({n})" for top1, top3, n in results.values()]
            print(f"{language:9} {orientation:12} " + " ".join(f"{cell:>34}" for cell in cells))
    if args.skip_avatar:
        return 0
    started = time.perf_counter()
    results, found, examples = avatar_accuracy(args.word)
    print(f"\nAvatar fingerspelling ASL {args.word!r}, 352x288 shaded, landmarks extracted "
          f"(right hand found in {found:.0f} % of frames; {time.perf_counter() - started:.0f} s)")
    for setting, (top1, top3, n) in results.items():
        print(f"  templates {setting:40} top-1 {top1:5.1f} %  top-3 {top3:5.1f} %  ({n} letters)")
    print("  misses with 'ase clips, image' templates (truth: top 3): "
          + ", ".join(f"{truth}: {''.join(ranking)}" for truth, ranking in examples if ranking[:1] != [truth]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

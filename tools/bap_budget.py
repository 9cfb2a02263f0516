"""Measure the FBA bit budget per BAP group and the rates against seed 000 Tables 2.1 / 3.1; print the
tables and write them into docs/parameters.md between its `bap-budget` markers.

- (a) ASL "HELLO" fingerspelled at 25 fps (media.fingerspelling.fingerspell): kbit/s per BAP group of
  fba-pred and fba-dct at Q4, and the bba-pred / bba-dct totals;
- (b) ASL A-J at 10 fps, one lexicon clip per letter (media.fingerspelling.letter_motion, as
  `signcast params` codes them): mean kbit/s per letter per BAP group, fba-pred and fba-dct at Q4;
- (c) the same letters' FBA P and DCT rates at Q = 1 ... 31 next to Table 2.1's, and BBA / FBA
  next to Table 3.1 / 2.1.
All streams are the body's only (BAPs, bones): a motion's face parameters are left out, as the
thesis's letters had none. Method of the per-group attribution: comparisons/params/bap_budget.py.

    .venv/bin/python tools/bap_budget.py [--no-write]
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from comparisons.params.bap_budget import group_label, motion_group_budget, stream_bits  # noqa: E402
from comparisons.params.fba_mapping import motion_to_baps  # noqa: E402
from comparisons.params.codecs import get_codec  # noqa: E402
from media import lexicon  # noqa: E402
from media.fingerspelling import fingerspell, letter_motion  # noqa: E402
from media.motion import Motion, resample  # noqa: E402
from media.retarget import retarget_clip  # noqa: E402

DOC = ROOT / "docs" / "parameters.md"
START, END = "<!-- bap-budget:start -->", "<!-- bap-budget:end -->"
LETTERS = "ABCDEFGHIJ"
QS = (1, 2, 4, 8, 16, 31)
BUDGET_Q = 4
# seed 000 Table 2.1 (FBA) and Table 3.1 (SMS = BBA), kbit/s, ASL letters at 10 fps: per letter, (P, DCT) at
# each of QS (../shared/notes/preda-digest.md §4.5, §2.7, transcribed from the thesis).
TABLE_2_1 = {
    "A": (1.32, 2.80, 1.30, 2.42, 1.25, 1.83, 1.22, 1.54, 1.18, 1.14, 1.14, 0.86),
    "B": (1.41, 2.61, 1.35, 2.22, 1.34, 1.64, 1.32, 1.36, 1.32, 1.08, 1.29, 0.81),
    "C": (1.80, 3.65, 1.78, 3.15, 1.71, 2.24, 1.68, 1.87, 1.63, 1.41, 1.58, 1.10),
    "D": (1.45, 2.66, 1.42, 2.30, 1.38, 1.69, 1.35, 1.40, 1.32, 1.01, 1.31, 0.74),
    "E": (1.75, 3.23, 1.71, 2.85, 1.65, 2.13, 1.62, 1.74, 1.57, 1.30, 1.53, 1.00),
    "F": (1.37, 2.04, 1.33, 1.83, 1.31, 1.36, 1.28, 1.12, 1.26, 0.88, 1.25, 0.67),
    "G": (1.81, 2.83, 1.75, 2.43, 1.72, 1.76, 1.67, 1.47, 1.63, 1.12, 1.57, 0.84),
    "H": (1.78, 2.83, 1.74, 2.39, 1.70, 1.70, 1.65, 1.40, 1.63, 1.08, 1.58, 0.76),
    "I": (1.53, 2.70, 1.49, 2.39, 1.46, 1.73, 1.41, 1.45, 1.39, 1.10, 1.38, 0.81),
    "J": (1.37, 2.20, 1.33, 1.89, 1.31, 1.34, 1.27, 1.11, 1.24, 0.82, 1.21, 0.59),
}
TABLE_3_1 = {
    "A": (1.45, 3.01, 1.46, 2.66, 1.38, 1.94, 1.30, 1.62, 1.24, 1.22, 1.21, 0.94),
    "B": (1.51, 2.87, 1.41, 2.41, 1.42, 1.73, 1.42, 1.45, 1.45, 1.19, 1.34, 0.85),
    "C": (1.93, 3.92, 1.98, 3.47, 1.84, 2.45, 1.83, 2.04, 1.77, 1.53, 1.73, 1.15),
    "D": (1.55, 2.89, 1.52, 2.42, 1.44, 1.83, 1.42, 1.53, 1.42, 1.05, 1.45, 0.82),
    "E": (1.86, 3.42, 1.80, 3.15, 1.78, 2.31, 1.74, 1.89, 1.73, 1.44, 1.67, 1.09),
    "F": (1.42, 2.24, 1.41, 2.12, 1.43, 1.43, 1.36, 1.24, 1.32, 0.93, 1.33, 0.74),
    "G": (1.97, 3.09, 1.86, 2.65, 1.85, 1.94, 1.82, 1.57, 1.72, 1.24, 1.72, 0.94),
    "H": (1.90, 3.01, 1.82, 2.52, 1.88, 1.82, 1.77, 1.52, 1.71, 1.14, 1.75, 0.85),
    "I": (1.62, 2.99, 1.68, 2.56, 1.53, 1.83, 1.53, 1.56, 1.54, 1.17, 1.45, 0.82),
    "J": (1.43, 2.34, 1.42, 2.07, 1.45, 1.42, 1.38, 1.23, 1.37, 0.82, 1.32, 0.66),
}


def body(motion: Motion) -> Motion:
    """The motion without its face parameters."""
    return Motion(motion.fps, motion.bone_names, motion.rotations, motion.root_translation)


def a_pose_letter(letter: str, fps: float) -> Motion:
    """letter_motion's clip with the unseen arm in the rig's rest (the A-pose, BBA's zero), body only."""
    motion = retarget_clip(lexicon.read_clip(lexicon.lookup("ase", letter)), unseen_arm="a-pose")
    return body(resample(motion, fps))


def held_first_frame(values: np.ndarray) -> np.ndarray:
    """(T, 296) BAP values of the first frame held still over the clip's length."""
    return np.repeat(values[:1], len(values), axis=0)


def bba_kbps(motion: Motion, q: int, coding: str) -> float:
    return 8 * len(get_codec(f"bba-{coding}").encode(motion, q)) / motion.duration_s / 1000.0


def fba_kbps(values: np.ndarray, fps: float, q: int, coding: str) -> float:
    return stream_bits(values, fps, q, coding) / (len(values) / fps) / 1000.0


def budget_table(budgets: dict[str, list]) -> list[str]:
    """Markdown rows: mean kbit/s per group over each column's budgets (one per clip)."""
    names = list(budgets)
    groups = sorted({g for column in budgets.values() for b in column for g in b.group_bits})
    mean = lambda column, pick: float(np.mean([pick(b) for b in column]))
    lines = ["| BAP group | " + " | ".join(names) + " |", "|---|" + "---|" * len(names)]
    lines.append("| overhead (no group: headers, masks, CRC) | "
                 + " | ".join(f"{mean(budgets[n], lambda b: b.kbps(b.overhead_bits)):.2f}" for n in names) + " |")
    for group in groups:
        cells = [np.mean([b.kbps(b.group_bits.get(group, 0)) for b in budgets[n]]) for n in names]
        lines.append(f"| {group} {group_label(group)} | " + " | ".join(f"{c:.2f}" for c in cells) + " |")
    lines.append("| interaction (total - overhead - groups) | "
                 + " | ".join(f"{mean(budgets[n], lambda b: b.kbps(b.interaction_bits)):+.2f}" for n in names) + " |")
    lines.append("| **total** | " + " | ".join(f"**{mean(budgets[n], lambda b: b.kbps(b.total_bits)):.2f}**"
                                               for n in names) + " |")
    return lines


def measure() -> str:
    out = []
    # (a) HELLO at 25 fps
    hello = body(fingerspell("ase", "HELLO", 25.0))
    values = motion_to_baps(hello)
    budgets = {f"fba-{c} Q{BUDGET_Q}": [motion_group_budget(hello, BUDGET_Q, c)] for c in ("pred", "dct")}
    out.append(f"**(a) ASL \"HELLO\" fingerspelled, 25 fps, {hello.n_frames} frames ({hello.duration_s:.2f} s)**, "
               f"kbit/s. {np.count_nonzero(np.any(values != 0, axis=0))} BAPs are non-zero, "
               f"{np.count_nonzero(np.any(values[:, 186:] != 0, axis=0))} of them extension BAPs.")
    out.append("")
    out += budget_table(budgets)
    out.append("")
    out.append(f"The same motion's BBA streams at Q{BUDGET_Q}: bba-pred {bba_kbps(hello, BUDGET_Q, 'pred'):.2f}, "
               f"bba-dct {bba_kbps(hello, BUDGET_Q, 'dct'):.2f} kbit/s.")
    out.append("")

    # (b) A-J at 10 fps, per group
    letters = {letter: body(letter_motion("ase", letter, 10.0)) for letter in LETTERS}
    budgets = {f"fba-{c} Q{BUDGET_Q}": [motion_group_budget(m, BUDGET_Q, c) for m in letters.values()]
               for c in ("pred", "dct")}
    frames = [m.n_frames for m in letters.values()]
    out.append(f"**(b) ASL A-J, 10 fps, one lexicon clip per letter ({min(frames)}-{max(frames)} frames)**: "
               "mean kbit/s per letter.")
    out.append("")
    out += budget_table(budgets)
    out.append("")
    for coding in ("pred", "dct"):
        held = np.mean([fba_kbps(held_first_frame(motion_to_baps(m)), m.fps, BUDGET_Q, coding) for m in letters.values()])
        total = np.mean([b.kbps(b.total_bits) for b in budgets[f"fba-{coding} Q{BUDGET_Q}"]])
        out.append(f"- fba-{coding} Q{BUDGET_Q}: the letter's first frame held still for the clip's length costs "
                   f"{held:.2f} kbit/s (overhead and one intra plane), its motion the other {total - held:.2f}.")
    out.append("")

    # (c) against Tables 2.1 and 3.1
    ours = {letter: {} for letter in LETTERS}
    for letter, motion in letters.items():
        values = motion_to_baps(motion)
        for q in QS:
            for coding in ("pred", "dct"):
                ours[letter][("fba", coding, q)] = fba_kbps(values, motion.fps, q, coding)
                ours[letter][("bba", coding, q)] = bba_kbps(motion, q, coding)
    out.append("**(c) Against seed 000 Table 2.1**: FBA kbit/s per letter, ours (thesis).")
    out.append("")
    for coding, label, offset in (("pred", "P", 0), ("dct", "DCT", 1)):
        out.append("| sign | " + " | ".join(f"{label} Q={q}" for q in QS) + " |")
        out.append("|---|" + "---|" * len(QS))
        for letter in LETTERS:
            out.append(f"| {letter} | " + " | ".join(
                f"{ours[letter][('fba', coding, q)]:.2f} ({TABLE_2_1[letter][2 * k + offset]:.2f})"
                for k, q in enumerate(QS)) + " |")
        out.append("| mean | " + " | ".join(
            f"{np.mean([ours[x][('fba', coding, q)] for x in LETTERS]):.2f} "
            f"({np.mean([TABLE_2_1[x][2 * k + offset] for x in LETTERS]):.2f})" for k, q in enumerate(QS)) + " |")
        out.append("")
    ratio = {coding: [ours[x][("bba", coding, q)] / ours[x][("fba", coding, q)] for x in LETTERS for q in QS]
             for coding in ("pred", "dct")}
    thesis = {offset: [TABLE_3_1[x][2 * k + offset] / TABLE_2_1[x][2 * k + offset] for x in LETTERS
                       for k in range(len(QS))] for offset in (0, 1)}
    out.append("BBA / FBA, per letter and Q (thesis: Table 3.1 / Table 2.1):")
    out.append("")
    a_pose = {letter: a_pose_letter(letter, 10.0) for letter in LETTERS}
    own_zero = {coding: [bba_kbps(a_pose[x], q, coding) / ours[x][("fba", coding, q)] for x in LETTERS for q in QS]
                for coding in ("pred", "dct")}
    span = lambda r: f"{np.mean(r):.2f} ({min(r):.2f}-{max(r):.2f})"
    out.append("| coder | ours: mean (range) | ours, BBA's idle arm in the rig's rest | thesis: mean (range) |")
    out.append("|---|---|---|---|")
    for coding, label, offset in (("pred", "P", 0), ("dct", "DCT", 1)):
        out.append(f"| {label} | {span(ratio[coding])} | {span(own_zero[coding])} | {span(thesis[offset])} |")
    return "\n".join(out)


def write(text: str, path: Path = DOC) -> None:
    doc = path.read_text()
    if doc.count(START) != 1 or doc.count(END) != 1 or doc.index(START) > doc.index(END):
        raise SystemExit(f"{path}: needs one {START} ... {END} pair")
    head, rest = doc.split(START)
    _, tail = rest.split(END)
    path.write_text(f"{head}{START}\n{text}\n{END}{tail}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0].replace("\n", " "))
    parser.add_argument("--no-write", action="store_true", help="print only; leave docs/parameters.md alone")
    args = parser.parse_args()
    text = measure()
    print(text)
    if not args.no_write:
        write(text)
        print(f"\nwritten to {DOC.relative_to(ROOT)}")


if __name__ == "__main__":
    main()

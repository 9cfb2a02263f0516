"""benchmarks/params.py's speed table runs and fills its columns as it says: the Motion codec, the stream coding
alone (FBA's arrays, the seed-002 coders' DOFs, BBA's motions with the face already on its bones), and the MPEG-4
codecs on the motions without their FAPs. Timings are measured there, not checked here."""
from __future__ import annotations

import math
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmarks import params as params_benchmark
from media.fingerspelling import letter_motion


def test_speed_table_columns(capsys):
    motions = [letter_motion("ase", "A", params_benchmark.FPS)]
    assert motions[0].faps is not None                  # the face is part of what is timed
    worst = params_benchmark.speed(motions, 1, ["fba-dct", "bba-key", "quant"])
    printed = capsys.readouterr().out
    assert set(worst) == {"fba-dct", "bba-key", "quant"} and all(len(row) == 6 for row in worst.values())
    finite = {name: [not math.isnan(value) for value in row] for name, row in worst.items()}
    assert finite["fba-dct"] == [True] * 6
    assert finite["bba-key"] == [True] * 6
    assert finite["quant"] == [True, True, True, True, False, False]
    assert all(value > 0 for row in worst.values() for value in row if not math.isnan(value))
    verdicts = [line.split() for line in printed.splitlines() if line.split()[:1] == ["bba-key"] and len(line.split()) >= 10]
    assert verdicts and all(word in ("yes", "NO") for word in verdicts[-1][-3:])

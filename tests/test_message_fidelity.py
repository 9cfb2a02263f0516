"""benchmarks/message_fidelity.py: one real lexicon clip (ASL A, 21 frames) retargeted, rendered at 352x288 (the
full-figure camera) and its landmarks extracted, measured against the signer's own landmarks; and the table code on
rows it computed.

Bounds are the figures measured on this clip (right hand found in all 21 frames, oriented PCK 81 %, wrist 0.12
shoulder widths, letter A recognised from other signers' templates on both) with a margin; they fail if the render
loses the hand, turns it, or the letter scoring takes the clip's own recording as a template."""
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


@pytest.fixture(scope="module")
def row():
    from benchmarks import message_fidelity
    measured = message_fidelity.measure_clip(("ase", "A", (352, 288), "full-figure"))
    measured.update(message_fidelity.letter_result(measured))
    return measured


def test_the_avatar_keeps_most_of_the_signers_letter_a(row):
    assert row["hands"] == ["right"] and row["frames"] == 21
    assert row["found"] >= 90.0
    assert 60.0 <= row["pck"] <= 100.0 and row["shape_pck"] >= row["pck"] - 5.0
    assert 0.0 < row["location"] < 0.3
    assert row["left_pck"] is None                      # ASL signs with the right hand only: the left is not scored
    assert row["real_top1"] and row["avatar_top1"]


def test_the_letter_templates_leave_out_every_file_of_the_language(row):
    from benchmarks import message_fidelity
    from media import lexicon
    recogniser = message_fidelity._RECOGNISERS["ase"]            # made by letter_result for the clip above
    ase_files = {entry.path for entry in lexicon.entries("ase")}
    assert recogniser.sources() and not recogniser.sources() & ase_files


def test_the_table_takes_medians_over_clips_and_the_penalty_in_points(row):
    from benchmarks import message_fidelity
    worse = dict(row, unit="B", file="other.pose", pck=40.0, location=0.5, avatar_top1=False)
    lines = message_fidelity.table([row, worse])
    language, summary = lines[0]
    assert language == "ase" and lines[-1][0] == "all" and summary["clips"] == 2
    assert summary["pck"] == pytest.approx((row["pck"] + 40.0) / 2)
    assert summary["location"] == pytest.approx((row["location"] + 0.5) / 2)
    assert summary["pck85"] == pytest.approx(50.0 if row["pck"] >= 85.0 else 0.0)
    assert summary["real_top1"] == 100.0 and summary["avatar_top1"] == 50.0 and summary["penalty"] == 50.0
    assert "ase B" in message_fidelity.worst([row, worse]).splitlines()[2]

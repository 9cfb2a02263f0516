"""`signcast lexicon` and `signcast motion`: output, BVH file, one-line errors with exit 2."""
import numpy as np
import pytest

from media.bvh import read_bvh
from media.fingerspelling import fingerspell
from pipeline.cli import main


def test_lexicon_lists_languages_and_letters(capsys):
    assert main(["lexicon"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 20
    assert lines[0].startswith("ase (en, 26 letters): A B C")
    assert main(["lexicon", "--language", "ssp"]) == 0
    out = capsys.readouterr().out
    assert " LL " in out and " RR " in out and out.count("\n") == 1


def test_motion_writes_a_bvh_of_the_fingerspelled_word(tmp_path, capsys):
    path = tmp_path / "abc.bvh"
    assert main(["motion", "ase", "ABC", "-o", str(path), "--fps", "20"]) == 0
    assert "abc.bvh" in capsys.readouterr().out
    motion, hierarchy = read_bvh(path)
    expected = fingerspell("ase", "ABC", fps=20)
    assert motion.fps == pytest.approx(20.0)
    assert motion.n_frames == expected.n_frames
    assert "finger2-3.R" in hierarchy.names
    column = motion.bone_names.index("finger2-2.R")
    source = expected.bone_names.index("finger2-2.R")
    dots = np.abs(np.sum(motion.rotations[:, column] * expected.rotations[:, source], axis=-1))
    assert dots.min() > 1 - 1e-9


@pytest.mark.parametrize("argv, message", [
    (["motion", "xx", "ABC"], "unknown sign language 'xx'"),
    (["motion", "ase", "AB3"], "no letter '3'"),
    (["motion", "ase", "ABC", "--fps", "-5"], "bad --fps"),
    (["lexicon", "--language", "zz"], "unknown sign language 'zz'"),
])
def test_bad_input_prints_one_line_and_exits_2(tmp_path, capsys, argv, message):
    if argv[0] == "motion":
        argv = argv + ["-o", str(tmp_path / "x.bvh")]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and "\n" not in err
    assert not (tmp_path / "x.bvh").exists()


def test_unwritable_output_is_a_clear_error(tmp_path, capsys):
    assert main(["motion", "ase", "AB", "-o", str(tmp_path / "missing" / "x.bvh")]) == 2
    assert "does not exist" in capsys.readouterr().err
    folder = tmp_path / "taken.bvh"
    folder.mkdir()                                                   # a folder where the file should go
    assert main(["motion", "ase", "AB", "-o", str(folder)]) == 2
    err = capsys.readouterr().err.strip()
    assert "cannot write" in err and "\n" not in err

"""The spoken-to-signed fingerspelling lexicon: index, clips, hands, frame rates, unit splitting."""
import dataclasses

import numpy as np
import pytest

from media import lexicon
from media.errors import SigncastError


def test_index_has_626_clips_in_20_sign_languages_and_asl_a_to_z():
    assert len(lexicon.load_index()) == 626
    assert len(lexicon.languages()) == 20
    assert lexicon.units("ase") == [chr(c) for c in range(ord("A"), ord("Z") + 1)]


def test_asl_clip_is_right_handed_with_masked_left_hand_and_flat_depth():
    clip = lexicon.read_clip(lexicon.lookup("ase", "A"))
    assert clip.fps == 25.0
    assert set(lexicon.HAND_COMPONENTS.values()) | {"POSE_LANDMARKS"} <= set(clip.points)
    assert clip.hand_visibility("right") == 1.0
    assert clip.hand_visibility("left") == 0.0
    for points in clip.points.values():
        assert np.all(np.isfinite(points))
    right = clip.points["RIGHT_HAND_LANDMARKS"]
    assert np.std(right[..., 2], axis=0).max() < 0.05          # depth flattened by the preprocessing
    assert np.ptp(right[..., 1]) > 20                            # while x, y span pixels


def test_italian_signs_with_the_left_hand_only():
    clip = lexicon.read_clip(lexicon.lookup("ise", "A"))
    assert clip.hand_visibility("left") > 0.9
    assert clip.hand_visibility("right") == 0.0


def test_clips_come_at_25_and_29_97_and_30_fps():
    rates = {round(lexicon.read_clip(lexicon.entries(code)[0]).fps, 2) for code in ("ase", "bzs", "gsg")}
    assert rates == {25.0, 29.97, 30.0}


def test_index_end_times_lie_past_the_clips_so_nothing_is_cut():
    entry = lexicon.lookup("ase", "B")
    clip = lexicon.read_clip(entry)
    assert entry.start_ms == 0 and entry.end_ms > clip.n_frames / clip.fps * 1000
    from pose_format import Pose
    raw = Pose.read(entry.path.read_bytes())
    assert clip.n_frames == raw.body.data.shape[0]


def test_read_clip_cuts_to_start_and_end_ms():
    entry = dataclasses.replace(lexicon.lookup("ase", "B"), start_ms=200.0, end_ms=600.0)
    clip = lexicon.read_clip(entry)
    assert clip.n_frames == 10                                   # frames at 200, 240, ..., 560 ms at 25 fps
    full = lexicon.read_clip(lexicon.lookup("ase", "B"))
    np.testing.assert_array_equal(clip.points["POSE_LANDMARKS"], full.points["POSE_LANDMARKS"][5:15])


@pytest.mark.parametrize("language, word, units", [
    ("ssp", "llamarr", ["LL", "A", "M", "A", "RR"]),
    ("sgg", "Schöne", ["SCH", "Ö", "N", "E"]),
    ("svk", "chata", ["CH", "A", "T", "A"]),
    ("ise", "Pizza", ["P", "I", "zz", "A"]),
    ("csq", "LJUBLJANA", ["Lj", "U", "B", "Lj", "A", "N", "A"]),
    ("ukl", "Київ", ["К", "И", "Ї", "В"]),
    ("jos", "السلام", ["ال", "س", "لا", "م"]),
    ("gss", "Οδός", ["Ο", "Δ", "Ο", "Σ"]),                      # tonos dropped, final sigma is sigma
    ("ase", "hi you", ["H", "I", " ", "Y", "O", "U"]),
])
def test_split_word_takes_longest_units_case_insensitively(language, word, units):
    assert lexicon.split_word(language, word) == units


def test_unknown_letter_names_the_letters_that_exist():
    with pytest.raises(SigncastError, match=r"no letter '1'.*A B C D"):
        lexicon.split_word("ase", "A1")
    with pytest.raises(SigncastError, match="SCH"):
        lexicon.lookup("asq", "Q!")


def test_unknown_language_names_the_languages_that_exist():
    with pytest.raises(SigncastError, match=r"unknown sign language 'xyz'.*ase, asq"):
        lexicon.units("xyz")
    assert lexicon.check_language("ASE") == "ase"

"""Fingerspelling words from retargeted lexicon clips: units, frame rates, smooth joins, errors."""
import numpy as np
import pytest

from media import fingerspelling, lexicon, rotations
from media.avatar import load_avatar
from media.errors import SigncastError
from media.kinematics import joint_positions


@pytest.fixture(scope="module")
def skeleton():
    return load_avatar().skeleton


def _max_step(motion, start, stop):
    q = motion.rotations[start:stop]
    return rotations.angle_between(q[1:], q[:-1]).max()


def test_word_is_its_letters_joined_by_cross_fades():
    a = fingerspelling.letter_motion("ase", "A", keep_drop=False)
    b = fingerspelling.letter_motion("ase", "B", keep_rise=False, keep_drop=False)
    c = fingerspelling.letter_motion("ase", "C", keep_rise=False)
    word = fingerspelling.fingerspell("ase", "abc")
    overlap = round(fingerspelling.TRANSITION_S * 25)
    assert word.fps == 25.0
    assert word.n_frames == a.n_frames + b.n_frames + c.n_frames - 2 * overlap
    np.testing.assert_allclose(word.rotations[: a.n_frames - overlap], a.rotations[: a.n_frames - overlap])
    np.testing.assert_allclose(word.rotations[-(c.n_frames - overlap):], c.rotations[overlap:])


def test_hand_stays_up_between_letters(skeleton):
    """Clips rise into place and drop away; inside a word only the first rises and the last drops."""
    from media.lexicon import lookup, read_clip
    start, stop = fingerspelling.held_span(read_clip(lookup("ase", "A")))
    assert start >= 1 and stop <= 20                                  # ASL A: 21 frames, rise and drop cut
    word = fingerspelling.fingerspell("ase", "ABBA")
    wrist = joint_positions(skeleton, word)[:, skeleton.index("wrist.R"), 1]
    shoulder = joint_positions(skeleton, word)[0, skeleton.index("upperarm01.R"), 1]
    inner = wrist[5:-5]
    assert inner.min() > shoulder - 0.1                               # no dip between letters
    full = fingerspelling.letter_motion("ase", "A")
    assert joint_positions(skeleton, full)[-1, skeleton.index("wrist.R"), 1] < inner.min()   # a lone letter drops


def test_join_between_letters_is_smoother_than_a_cut():
    a = fingerspelling.letter_motion("ase", "A", keep_drop=False)
    b = fingerspelling.letter_motion("ase", "B", keep_rise=False)
    word = fingerspelling.fingerspell("ase", "AB")
    overlap = round(fingerspelling.TRANSITION_S * 25)
    cut = rotations.angle_between(a.rotations[-1], b.rotations[0]).max()
    join = _max_step(word, a.n_frames - overlap - 1, a.n_frames + 1)
    assert join < 0.75 * cut


def test_multi_letter_units_are_spelled_as_one_clip():
    word = fingerspelling.fingerspell("ssp", "LLAMA")
    overlap = round(fingerspelling.TRANSITION_S * 25)
    units = ("LL", "A", "M", "A")
    parts = [fingerspelling.letter_motion("ssp", u, keep_rise=k == 0, keep_drop=k == 3) for k, u in enumerate(units)]
    assert word.n_frames == sum(p.n_frames for p in parts) - 3 * overlap


def test_clips_at_29_97_and_30_fps_are_resampled_to_the_requested_rate():
    native = lexicon.read_clip(lexicon.lookup("gsg", "A"))
    assert native.fps == 30.0
    motion = fingerspelling.letter_motion("gsg", "A", fps=10.0)
    assert motion.fps == 10.0
    assert motion.n_frames == int(np.floor((native.n_frames - 1) / 30.0 * 10.0 + 1e-9)) + 1
    word = fingerspelling.fingerspell("bzs", "ÇA", fps=15)
    assert word.fps == 15.0 and np.all(np.isfinite(word.rotations))


def test_space_holds_a_pause_between_words():
    joined = fingerspelling.fingerspell("ase", "AB")
    spaced = fingerspelling.fingerspell("ase", "A B")
    assert spaced.n_frames == joined.n_frames + round(fingerspelling.PAUSE_S * 25)
    a = fingerspelling.letter_motion("ase", "A", keep_drop=False)
    hold = round(fingerspelling.PAUSE_S * 25) - round(fingerspelling.TRANSITION_S * 25)
    held = spaced.rotations[a.n_frames - 1: a.n_frames + hold]
    np.testing.assert_allclose(held, np.broadcast_to(a.rotations[-1], held.shape))   # the pose is held


def test_letter_cache_returns_independent_copies():
    first = fingerspelling.letter_motion("ase", "Q")
    first.rotations[:] = 0.0
    second = fingerspelling.letter_motion("ase", "Q")
    np.testing.assert_allclose(np.linalg.norm(second.rotations, axis=-1), 1.0)


@pytest.mark.parametrize("language, word, fps, message", [
    ("xx", "A", 25, "unknown sign language 'xx'.*ase"),
    ("ase", "A7", 25, r"no letter '7'.*A B C"),
    ("ase", "  ", 25, "empty"),
    ("ase", "A", 0, "bad frame rate"),
    ("ase", "A", float("nan"), "bad frame rate"),
])
def test_bad_requests_raise_one_clear_error(language, word, fps, message):
    with pytest.raises(SigncastError, match=message):
        fingerspelling.fingerspell(language, word, fps=fps)


def test_a_word_carries_its_letters_faces():
    from media.fingerspelling import fingerspell, letter_motion
    word = fingerspell("ase", "AB", 25.0)
    first = letter_motion("ase", "A", 25.0, keep_rise=True, keep_drop=False)
    assert word.faps is not None and word.faps.shape == (word.n_frames, 68)
    assert np.array_equal(word.faps[:5], first.faps[:5])
    spaced = fingerspell("ase", "A B", 25.0)
    assert spaced.faps.shape == (spaced.n_frames, 68)

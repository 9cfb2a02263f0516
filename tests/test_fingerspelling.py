"""Fingerspelling words from retargeted lexicon clips: units, frame rates, smooth joins, errors."""
import numpy as np
import pytest

from media import fingerspelling, lexicon, rotations
from media.errors import SigncastError


def _max_step(motion, start, stop):
    q = motion.rotations[start:stop]
    return rotations.angle_between(q[1:], q[:-1]).max()


def test_word_is_its_letters_joined_by_cross_fades():
    a = fingerspelling.letter_motion("ase", "A")
    b = fingerspelling.letter_motion("ase", "B")
    c = fingerspelling.letter_motion("ase", "C")
    word = fingerspelling.fingerspell("ase", "abc")
    overlap = round(fingerspelling.TRANSITION_S * 25)
    assert word.fps == 25.0
    assert word.n_frames == a.n_frames + b.n_frames + c.n_frames - 2 * overlap
    np.testing.assert_allclose(word.rotations[: a.n_frames - overlap], a.rotations[: a.n_frames - overlap])
    np.testing.assert_allclose(word.rotations[-(c.n_frames - overlap):], c.rotations[overlap:])


def test_join_between_letters_is_smoother_than_a_cut():
    a = fingerspelling.letter_motion("ase", "A")
    b = fingerspelling.letter_motion("ase", "B")
    word = fingerspelling.fingerspell("ase", "AB")
    overlap = round(fingerspelling.TRANSITION_S * 25)
    cut = rotations.angle_between(a.rotations[-1], b.rotations[0]).max()
    join = _max_step(word, a.n_frames - overlap - 1, a.n_frames + 1)
    assert join < 0.75 * cut


def test_multi_letter_units_are_spelled_as_one_clip():
    word = fingerspelling.fingerspell("ssp", "LLAMA")
    overlap = round(fingerspelling.TRANSITION_S * 25)
    parts = [fingerspelling.letter_motion("ssp", u) for u in ("LL", "A", "M", "A")]
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

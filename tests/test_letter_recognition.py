"""Letter recognition on normalised hand landmarks, and where each letter is held in a fingerspelt word."""
import numpy as np
import pytest

from comparisons.judging.letters import Recogniser, normalise_hand, recognise_spans, top_k
from media import fingerspelling, lexicon
from media.errors import SigncastError


def _first_half(clip):
    start, stop = fingerspelling.held_span(clip)
    return start, start + (stop - start) // 2


def test_each_asl_letter_is_recognised_from_other_frames_of_its_clip():
    """Templates: second halves of the held spans; scored: first halves (measured 24 of 26 top-1: J and Z move)."""
    recogniser = Recogniser.from_lexicon(["ase"], half=1)
    rankings, truths = [], []
    for entry in lexicon.entries("ase"):
        clip = lexicon.read_clip(entry)
        start, stop = _first_half(clip)
        assert not set(range(start, stop)) & {f for (_, letter), f in zip(recogniser.keys, recogniser.frames)
                                                if letter == lexicon.normalize_unit(entry.unit)}
        rankings += recognise_spans(recogniser, clip, "ase", [(entry.unit, start, stop)])
        truths.append(entry.unit)
    assert all(sorted(ranking) == sorted(lexicon.units("ase")) for ranking in rankings)
    assert top_k(rankings, truths, 1) >= 85
    assert top_k(rankings, truths, 3) >= top_k(rankings, truths, 1)


def test_left_out_clips_leave_no_templates_even_under_another_language():
    """The lexicon's fsl clips are its ase clips: leaving out ase A leaves out fsl A too."""
    recogniser = Recogniser.from_lexicon(["ase", "fsl"], exclude={("ase", "A")})
    assert "a" not in {letter for _, letter in recogniser.keys}
    assert len(recogniser.keys) == len(Recogniser.from_lexicon(["ase"], exclude={("ase", "a")}).keys)


def test_features_are_a_right_hand_in_hand_sizes():
    hand = lexicon.read_clip(lexicon.lookup("ase", "L")).points["RIGHT_HAND_LANDMARKS"][10]
    right = normalise_hand(hand, "right")
    np.testing.assert_allclose(right[0], 0)
    np.testing.assert_allclose(normalise_hand(3 * hand + 40, "right"), right, atol=1e-12)
    mirrored = hand * np.array([-1.0, 1.0, 1.0])
    np.testing.assert_allclose(normalise_hand(mirrored, "left"), right, atol=1e-12)
    upright = normalise_hand(hand, "right", "upright")
    assert upright[9, 0] == pytest.approx(0, abs=1e-12) and upright[9, 1] < 0


def test_a_span_without_the_hand_is_a_miss():
    recogniser = Recogniser.from_lexicon(["ase"], letters=["A", "B"])
    clip = lexicon.read_clip(lexicon.lookup("ase", "A"))
    clip.confidence["RIGHT_HAND_LANDMARKS"][:5] = 0
    rankings = recognise_spans(recogniser, clip, "ase", [("A", 0, 5), ("A", 5, 15)])
    assert rankings[0] == [] and rankings[1][0] == "A" and sorted(rankings[1]) == ["A", "B"]
    assert top_k(rankings, ["A", "a"], 1) == 50
    with pytest.raises(SigncastError):
        recognise_spans(recogniser, clip, "ase", [("A", 0, clip.n_frames + 1)])


@pytest.mark.parametrize("language, word, fps", [("ase", "ABC", 25.0), ("ase", "HI YOU", 25.0),
                                                 ("ssp", "LLAMA", 15.0), ("gsg", "AB", 25.0)])
def test_letter_spans_cover_each_letter_in_order_inside_the_motion(language, word, fps):
    motion = fingerspelling.fingerspell(language, word, fps)
    spans = fingerspelling.letter_spans(language, word, fps)
    assert [unit for unit, _, _ in spans] == [u for u in lexicon.split_word(language, word) if u != " "]
    assert all(0 <= start < stop <= motion.n_frames for _, start, stop in spans)
    assert all(previous[2] <= following[1] for previous, following in zip(spans, spans[1:]))


def test_letter_spans_hold_the_letters_own_unblended_frames():
    word = fingerspelling.fingerspell("ase", "ABC")
    a = fingerspelling.letter_motion("ase", "A", keep_drop=False)
    b = fingerspelling.letter_motion("ase", "B", keep_rise=False, keep_drop=False)
    c = fingerspelling.letter_motion("ase", "C", keep_rise=False)
    overlap = round(fingerspelling.TRANSITION_S * 25)
    (_, a0, a1), (_, b0, b1), (_, c0, c1) = fingerspelling.letter_spans("ase", "ABC")
    b_offset = a.n_frames - overlap
    c_offset = b_offset + b.n_frames - overlap
    assert (b0, b1) == (b_offset + overlap, c_offset)               # all of B between the cross-fades
    np.testing.assert_allclose(word.rotations[b0:b1], b.rotations[overlap:b1 - b_offset])
    np.testing.assert_allclose(word.rotations[c0:c1], c.rotations[c0 - c_offset:c1 - c_offset])
    rise, _ = fingerspelling.held_span(lexicon.read_clip(lexicon.lookup("ase", "A")))
    assert a0 == rise and a1 == b_offset                            # A's rise is left out
    _, drop = fingerspelling.held_span(lexicon.read_clip(lexicon.lookup("ase", "C")))
    assert c1 < word.n_frames                                       # C's drop is left out

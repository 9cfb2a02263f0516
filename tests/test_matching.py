"""comparisons.judging.matching: the cheapest rate reaching an intelligibility threshold, and the frame rate it holds to."""
import math

import pytest

from comparisons.judging.matching import Criterion, cheapest_rate, fields_at, lowest_fps_holding, threshold_text
from media.errors import SigncastError

PCK = Criterion("hand_pck_20", 98.0, label="hand PCK@0.2")


def point(kbps, pck, q=None, fps=25.0):
    return {"kbps": kbps, "hand_pck_20": pck, "q": q, "fps": fps}


def test_rate_is_interpolated_in_log_rate_between_the_bracketing_points():
    points = [point(10, 90, 31), point(40, 99, 12), point(100, 100, 2)]
    match = cheapest_rate(points, [PCK])
    assert match.reached and match.upper["q"] == 12 and match.lower["q"] == 31
    assert match.fraction == pytest.approx(8 / 9)
    assert match.kbps == pytest.approx(math.exp(math.log(10) + 8 / 9 * math.log(4)))
    assert 10 < match.kbps < 40
    assert fields_at(match, ("hand_pck_20",))["hand_pck_20"] == pytest.approx(98.0)


def test_a_lucky_cheap_point_below_a_missing_one_does_not_count():
    points = [point(5, 99, 31), point(10, 90, 24), point(40, 99, 12)]
    match = cheapest_rate(points, [PCK])
    assert match.upper["q"] == 12 and match.lower["q"] == 24


def test_cheapest_point_meeting_the_threshold_gives_its_own_rate():
    match = cheapest_rate([point(5, 99), point(20, 100)], [PCK])
    assert match.reached and match.lower is None and match.kbps == 5


def test_unreached_threshold_gives_the_best_point():
    match = cheapest_rate([point(5, 50), point(20, 90), point(30, 80)], [PCK])
    assert not match.reached and match.kbps == 20


def test_every_criterion_must_hold_and_missing_values_never_do():
    letters = Criterion("letter_top1", 100.0, label="letter top-1")
    points = [dict(point(10, 99), letter_top1=50.0), dict(point(20, 99), letter_top1=100.0)]
    match = cheapest_rate(points, [PCK, letters])
    assert match.upper["kbps"] == 20 and match.fraction == pytest.approx(1.0)
    assert not cheapest_rate([point(10, None)], [PCK]).reached
    face = Criterion("face_error", 0.02, higher_is_better=False, label="face error")
    assert cheapest_rate([{"kbps": 3, "face_error": 0.01}], [face]).reached
    assert threshold_text([PCK, face]) == "hand PCK@0.2 >= 98 and face error <= 0.02"


def test_lowest_frame_rate_holding_stops_at_the_first_miss():
    points = [point(10, 99, fps=25), point(8, 98.5, fps=15), point(6, 90, fps=10), point(5, 99, fps=5)]
    assert lowest_fps_holding(points, [PCK]) == 15
    assert lowest_fps_holding([point(10, 50, fps=25)], [PCK]) is None


def test_no_points_is_refused():
    with pytest.raises(SigncastError):
        cheapest_rate([], [PCK])


def test_the_monotone_fit_pools_adjacent_violators():
    from comparisons.judging.matching import monotone_fit
    assert monotone_fit([1.0, 3.0, 2.0, 4.0]) == [1.0, 2.5, 2.5, 4.0]
    assert monotone_fit([5.0, 1.0, 1.0, 6.0]) == pytest.approx([7 / 3, 7 / 3, 7 / 3, 6.0])
    assert monotone_fit([0.1, 0.3, 0.2], increasing=False) == pytest.approx([0.2, 0.2, 0.2])
    assert monotone_fit([2.0, None, 1.0, 3.0]) == [1.5, None, 1.5, 3.0]
    assert monotone_fit([]) == [] and monotone_fit([None]) == [None]


def test_monotone_matching_pools_the_extractors_noise_across_q():
    """The demo's BBA row (hand PCK@0.2 means of four extractions, threshold 97.25): Q 1 reads 0.24 points under Q 4,
    which alone makes 'every dearer point meets' fail at the dearest point; intelligibility does not fall when bits
    are added, so the fit pools Q 1 and Q 4 (97.31) and the match lies between Q 31 and Q 4."""
    threshold = Criterion("hand_pck_20", 97.25, label="hand PCK@0.2")
    points = [point(7.0, 95.94, 31), point(14.5, 97.43, 4), point(19.9, 97.19, 1)]
    assert not cheapest_rate(points, [threshold]).reached
    match = cheapest_rate(points, [threshold], monotone=True)
    assert match.reached and (match.upper["q"], match.lower["q"]) == (4, 31)
    pooled = (97.43 + 97.19) / 2
    assert match.fraction == pytest.approx((97.25 - 95.94) / (pooled - 95.94))
    assert match.fitted["hand_pck_20"] == pytest.approx(97.25)
    assert fields_at(match, ("hand_pck_20",))["hand_pck_20"] != pytest.approx(97.25)    # the measured values
    # a real fall is not pooled away: the dearer points' mean must still reach the threshold
    assert not cheapest_rate([point(7.0, 95.0, 31), point(14.5, 97.3, 4), point(19.9, 96.0, 1)], [threshold],
                             monotone=True).reached
    # over frame rates likewise: 15 fps reads under 10 fps, pooled they hold
    rates = [point(10, 97.5, fps=25), point(8, 97.0, fps=15), point(6, 97.6, fps=10), point(5, 90.0, fps=5)]
    assert lowest_fps_holding(rates, [threshold]) == 25
    assert lowest_fps_holding(rates, [threshold], monotone=True) == 10

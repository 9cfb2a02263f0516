"""comparisons.matching: the cheapest rate reaching an intelligibility threshold, and the frame rate it holds to."""
import math

import pytest

from comparisons.matching import Criterion, cheapest_rate, fields_at, lowest_fps_holding, threshold_text
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

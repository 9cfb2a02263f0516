"""One person check, the landmark extractor's own (media.faces): a real face with landmark dots and lines drawn
over it is a person, as the extractor finds its body and face; a plain background or noise is not, and `signcast
pose` refuses it with one line and exit 2 before extracting anything."""
import cv2
import numpy as np
import pytest

from media import faces
from media.errors import SigncastError
from media.video_io import read_video, resolve_video, write_video
from pipeline.cli import main

FACE_STEP = 3     # every 3rd face-mesh point drawn as a dot, and the shoulders, arms and neck as lines


@pytest.fixture(scope="module")
def drawn_frames():
    """carphone frames 4..7 with the extractor's own landmarks drawn over them, as a landmark preview does:
    one-pixel green dots on the face (every FACE_STEP-th mesh point) and white lines on the upper body. The former
    check (an LBP face cascade with a skin-colour test) found no face in any of these four frames."""
    from media.landmarks.holistic import extract_landmarks

    frames, _ = read_video(resolve_video("carphone"), max_frames=8)
    frames = np.ascontiguousarray(frames[4:8])
    clip = extract_landmarks(frames, 25.0)
    drawn = frames.copy()
    for t, frame in enumerate(drawn):
        for x, y in clip.points["FACE_LANDMARKS"][t, :468:FACE_STEP, :2]:
            cv2.circle(frame, (int(round(x)), int(round(y))), 0, (0, 255, 0), -1)
        pose = clip.points["POSE_LANDMARKS"][t, :, :2].round().astype(int)
        for a, b in ((11, 12), (11, 13), (12, 14), (0, 11), (0, 12)):
            cv2.line(frame, tuple(map(int, pose[a])), tuple(map(int, pose[b])), (255, 255, 255), 1)
    assert np.mean(np.any(drawn != frames, axis=-1)) > 0.01     # a visible drawing
    return drawn


def test_a_face_with_landmarks_drawn_over_it_is_a_person(drawn_frames):
    for frame in drawn_frames:
        assert faces.person_in_frame(frame)
    assert faces.check_person(drawn_frames, "drawn") in range(len(drawn_frames))


def test_the_check_agrees_with_the_extractor(drawn_frames):
    from media.landmarks.holistic import extract_landmarks, found_shares

    shares = found_shares(extract_landmarks(drawn_frames, 25.0))
    assert shares["pose"] == 1.0 and shares["face"] == 1.0


@pytest.mark.parametrize("kind", ["background", "noise"])
def test_no_person_is_refused(kind):
    rng = np.random.default_rng(0)
    frames = (np.full((4, 144, 176, 3), (96, 140, 180), np.uint8) if kind == "background"
              else rng.integers(0, 256, (4, 144, 176, 3), dtype=np.uint8))
    assert not any(faces.person_in_frame(frame) for frame in frames)
    with pytest.raises(SigncastError, match="no person found in clip"):
        faces.check_person(frames, "clip")


def test_pose_accepts_the_drawn_face(tmp_path, capsys, drawn_frames):
    video = tmp_path / "drawn.mkv"
    write_video(video, drawn_frames, 25)
    output = tmp_path / "drawn.pose"
    assert main(["pose", str(video), "-o", str(output), "--no-progress"]) == 0, capsys.readouterr().err
    assert output.exists()


def test_pose_refuses_noise_in_one_line(tmp_path, capsys):
    video = tmp_path / "noise.mkv"
    write_video(video, np.random.default_rng(1).integers(0, 256, (4, 144, 176, 3), dtype=np.uint8), 25)
    output = tmp_path / "noise.pose"
    assert main(["pose", str(video), "-o", str(output), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no person found in noise.mkv" in err and "Traceback" not in err
    assert not output.exists()

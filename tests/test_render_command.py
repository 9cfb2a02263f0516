import numpy as np
import pytest

from media.avatar import load_avatar
from media.fingerspelling import fingerspell
from media.render import RenderSettings, render_motion
from media.video_io import read_video
from pipeline.cli import main


@pytest.mark.slow
@pytest.mark.parametrize("backend", ["auto", "numpy"])
def test_render_command_writes_a_lossless_video_labels_and_preview(tmp_path, backend):
    video, labels_path, preview = tmp_path / "ab.mkv", tmp_path / "ab.npz", tmp_path / "ab.png"
    code = main(["render", "ase", "AB", "-o", str(video), "--labels", str(labels_path), "--size", "176x144",
                 "--backend", backend, "--look", "flat", "--preview", str(preview), "--preview-frame", "7"])
    assert code == 0
    decoded, fps = read_video(video)
    expected, expected_labels = render_motion(load_avatar(), fingerspell("ase", "AB", 25.0),
                                              RenderSettings(176, 144, look="flat", backend=backend))
    assert fps == 25 and decoded.shape == expected.shape
    assert np.array_equal(decoded, expected)                 # FFV1 is lossless
    stored = np.load(labels_path)
    assert np.array_equal(stored["labels"], expected_labels) and float(stored["fps"]) == 25.0
    import cv2
    assert np.array_equal(cv2.imread(str(preview))[..., ::-1], expected[7])


@pytest.mark.parametrize("arguments, message", [
    (["--size", "352by288"], "bad size"),
    (["--backend", "cuda"], "unknown backend"),
    (["--look", "toon"], "unknown look"),
    (["--fps", "0"], "bad --fps"),
    (["--labels", "labels.txt"], ".npz"),
])
def test_render_command_rejects_bad_options_with_one_line(tmp_path, capsys, arguments, message):
    code = main(["render", "ase", "AB", "-o", str(tmp_path / "x.mkv"), *arguments])
    error = capsys.readouterr().err.strip()
    assert code == 2 and message in error and len(error.splitlines()) == 1
    assert not (tmp_path / "x.mkv").exists()

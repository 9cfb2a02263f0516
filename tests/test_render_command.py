import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from kernels import backends
from media.render import RenderSettings, render_motion
from media.video_io import read_video
from pipeline.cli import main


@pytest.mark.slow
@pytest.mark.parametrize("backend", ["auto", "numpy"])
def test_render_command_writes_a_lossless_video_labels_and_preview(tmp_path, capsys, avatar, fingerspelling_ab, backend):
    video, labels_path, preview = tmp_path / "ab.mkv", tmp_path / "ab.npz", tmp_path / "ab.png"
    code = main(["render", "ase", "AB", "-o", str(video), "--labels", str(labels_path), "--size", "176x144",
                 "--backend", backend, "--look", "flat", "--preview", str(preview), "--preview-frame", "7"])
    assert code == 0
    told = [line for line in capsys.readouterr().err.splitlines() if line.startswith("backend auto")]
    assert told == ([f"backend auto chose {backends.describe('warp')}"] if backend == "auto" else [])
    decoded, fps = read_video(video)
    expected, expected_labels = render_motion(avatar, fingerspelling_ab,
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


def test_render_command_says_in_one_line_how_to_get_opencl_when_no_device_can_run_it(tmp_path):
    # A machine whose only OpenCL platform is the PoCL of the pyopencl wheel, with no usable device.
    vendors = tmp_path / "no-system-icds"
    vendors.mkdir()
    environment = {**os.environ, "OCL_ICD_VENDORS": str(vendors), "POCL_DEVICES": "none-here"}
    video = tmp_path / "x.mkv"
    command = [sys.executable, "-m", "pipeline.cli", "render", "ase", "AB", "-o", str(video), "--backend", "opencl"]
    finished = subprocess.run(command, capture_output=True, text=True, env=environment, timeout=300,
                              cwd=Path(__file__).resolve().parents[1])
    error = finished.stderr.strip()
    assert finished.returncode == 2 and len(error.splitlines()) == 1, error
    assert error.startswith("signcast render: error: backend 'opencl': no OpenCL device can build kernels")
    assert "pocl-binary-distribution" in error and "install pocl-opencl-icd" in error
    assert not video.exists()

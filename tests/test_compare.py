"""`signcast compare` end to end on a small sweep: records, report, side-by-side video, re-made report."""
import json
import shutil
import subprocess

import numpy as np
import pytest

from media.video_io import read_video
from pipeline.cli import main
from pipeline.studies.compare import CompareSettings, run as run_compare
from pipeline.studies.video import VideoSweep

SMALL = CompareSettings(word="AB", video=VideoSweep(qs=(12, 31), frame_rates=(25.0, 10.0), other_codecs=()),
                        param_codecs=("fba-pred", "bba-key"), param_qs=(2, 31), size=(176, 144), max_clip_frames=48)


@pytest.fixture(scope="module")
def result(tmp_path_factory):
    return run_compare(SMALL, tmp_path_factory.mktemp("compare"), progress=False)


@pytest.mark.slow
def test_compare_measures_every_solution_at_its_operating_point(result):
    operating = {r["solution"]: r for r in result.operating}
    assert set(operating) == {"NSV", "NSV2O", "NSV3O", "NSV3O+C", "SSV", "FBA", "BBA"}
    for record in result.operating:
        assert record["bits"] > 0 and record["kbps"] == pytest.approx(record["bits"] / record["duration_s"] / 1000)
    assert operating["FBA"]["kbps"] < operating["SSV"]["kbps"] / 3          # parameters cost far less than pixels
    assert operating["NSV3O"]["kbps"] < operating["NSV"]["kbps"]           # dropping background and clothes saves bits
    assert operating["NSV3O+C"]["kbps"] > operating["NSV3O"]["kbps"]
    # FBA/BBA quality is measured on the frames the terminal re-renders, against the same reference as SSV.
    assert 10 < operating["FBA"]["skin_psnr"] < 60 and 0 < operating["BBA"]["ssim"] <= 1
    stages = [r for r in result.records if r.get("kind") == "stage"]
    assert len(stages) >= 5 and all(s["wall_s"] >= 0 for s in stages)


@pytest.mark.slow
def test_lower_frame_rate_costs_fewer_bits(result):
    nsv = {r["fps"]: r["kbps"] for r in result.records if r.get("solution") == "NSV" and r.get("q") == 12
           and r.get("codec") == "mpeg4" and r.get("full_resolution")}
    assert nsv[10.0] < nsv[25.0]


@pytest.mark.slow
def test_side_by_side_video_tiles_every_solution(result):
    frames, fps = read_video(result.side_by_side)
    assert fps == pytest.approx(25.0)
    assert frames.shape[1] == 2 * (288 + 18) and frames.shape[2] == 4 * 352      # 8 tiles, 4 columns
    assert frames.std() > 20


@pytest.mark.slow
def test_report_command_remakes_the_report_from_records(result, tmp_path):
    remade = tmp_path / "again.html"
    assert main(["report", str(result.out_dir / "records.jsonl"), "-o", str(remade)]) == 0
    assert remade.read_text() == result.report.read_text()


@pytest.mark.slow
def test_compare_report_renders_in_headless_chromium(result):
    browser = shutil.which("chromium") or shutil.which("chromium-browser")
    if browser is None:
        pytest.skip("Chromium is not installed (Debian: apt-get install chromium); .ci/run installs it")
    dom = subprocess.run([browser, "--headless", "--no-sandbox", "--disable-gpu", "--virtual-time-budget=5000",
                          "--dump-dom", result.report.as_uri()], capture_output=True, text=True, timeout=120).stdout
    assert "all ok" in dom and "rendered 0/" not in dom


def test_report_command_rejects_missing_and_corrupt_records(tmp_path, capsys):
    assert main(["report", str(tmp_path / "none.jsonl")]) == 2
    assert "not found" in capsys.readouterr().err
    bad = tmp_path / "bad.jsonl"
    bad.write_text(json.dumps({"solution": "NSV", "fps": 25.0}) + "\n{broken\n")
    assert main(["report", str(bad)]) == 2
    assert "bad.jsonl:2:" in capsys.readouterr().err


def test_compare_rejects_bad_settings(tmp_path, capsys):
    assert main(["compare", "ase", "AB", "--video-q", "6,31", "--out", str(tmp_path)]) == 2
    assert "operating Q" in capsys.readouterr().err
    assert main(["compare", "ase", "AB", "--codecs", "fba-zip", "--out", str(tmp_path)]) == 2
    assert "unknown parameter codec" in capsys.readouterr().err
    assert main(["compare", "xyz", "AB", "--out", str(tmp_path)]) == 2
    assert np.char.find(capsys.readouterr().err, "xyz") >= 0

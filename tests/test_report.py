"""The HTML report: made from records only, self-contained, and rendered by a real browser."""
import shutil
import subprocess

import numpy as np
import pytest

from comparisons.criteria import bandwidth_scores, criteria_table
from comparisons.report import build_report, linear_fits


def _records():
    """A small sweep shaped like `signcast compare` output (rates follow kbps ~ Q^-0.8, linear in fps)."""
    records = [{"kind": "run", "versions": {"numpy": np.__version__}, "backend": "warp-cpu"},
               {"kind": "stage", "stage": "video", "wall_s": 1.5}]
    for solution, base in (("NSV", 300.0), ("NSV3O", 130.0), ("SSV", 100.0)):
        for q in (2, 12, 31):
            records.append({"solution": solution, "codec": "mpeg4", "q": q, "fps": 25.0, "kbps": (3.0 + base) * (12 / q) ** 0.8,
                            "psnr": 45 - 0.5 * q, "psnr_skin": 44 - 0.5 * q, "ssim": 0.99 - 0.005 * q,
                            "ssim_skin": 0.98 - 0.005 * q, "sweep": "q", "operating_point": q == 12})
        for fps in (10.0, 15.0, 20.0):
            records.append({"solution": solution, "codec": "mpeg4", "q": 12, "fps": fps, "kbps": 3.0 + base * fps / 25, "sweep": "fps"})
    for q, kbps in ((1, 20.0), (8, 6.0)):
        records.append({"solution": "FBA", "codec": "fba-pred", "q": q, "fps": 25.0, "kbps": kbps, "psnr": 40.0 - q,
                        "sweep": "q", "operating_point": q == 8})
    return records


def test_linear_fit_recovers_rate_per_frame_rate():
    fits = {f["solution"]: f for f in linear_fits(_records())}
    assert fits["NSV"]["slope_kbps_per_fps"] == pytest.approx(300 / 25)
    assert fits["NSV"]["intercept_kbps"] == pytest.approx(3.0, abs=1e-6)
    assert len(fits["NSV"]["fps"]) == 4                 # 10, 15, 20 plus the 25 fps point of the Q sweep


def test_bandwidth_row_ranks_measured_rates():
    scores = bandwidth_scores({"NSV": 294.0, "NSV2O": 186.0, "NSV3O": 129.0, "SSV": 102.0, "FBA": 9.0, "BBA": 9.0})
    assert scores == {"NSV": 1, "NSV2O": 2, "NSV3O": 3, "SSV": 4, "FBA": 6, "BBA": 6}
    rows = criteria_table({"NSV": 294.0, "FBA": 9.0})
    assert rows[-2]["NSV"] == 5 and rows[-2]["FBA"] == 6 and rows[-2]["SSV"] is None


def test_report_is_self_contained(tmp_path):
    page = build_report(_records(), tmp_path / "report.html").read_text()
    assert "http://" not in page and "https://" not in page
    assert page.count('class="chart"') == 4 and page.count("data-table=") == 7


@pytest.mark.slow
def test_report_renders_in_headless_chromium(tmp_path):
    browser = shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")
    if browser is None:
        pytest.skip("Chromium is not installed (Debian: apt-get install chromium); .ci/run installs it")
    report = build_report(_records(), tmp_path / "report.html")
    flags = [browser, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars"]
    dom = subprocess.run([*flags, "--virtual-time-budget=5000", "--dump-dom", report.as_uri()],
                         capture_output=True, text=True, timeout=120).stdout
    assert "rendered 4/4 charts, 7/7 tables; all ok" in dom
    screenshot = tmp_path / "report.png"
    subprocess.run([*flags, "--window-size=1280,2400", f"--screenshot={screenshot}", report.as_uri()],
                   capture_output=True, timeout=120, cwd=tmp_path)
    import cv2
    image = cv2.imread(str(screenshot))
    assert image is not None and image.shape[:2] == (2400, 1280)
    assert image.std() > 20                              # charts and tables drew something, not a blank page

"""The HTML report: made from records only, self-contained, and rendered by a real browser."""
import json
import shutil
import subprocess
from pathlib import Path

import cv2
import matplotlib.pyplot as plt
import numpy as np
import pytest

from comparisons.judging.criteria import bandwidth_scores, criteria_table
from comparisons.reports.comparison import chart_kbps_vs_q, chart_rate_quality, linear_fits, quantiser
from comparisons.reports.records import as_records
from pipeline.outputs import build_report
from report_page import ReportPage


def _records():
    """A small sweep shaped like `signcast compare` output (rates follow kbps ~ Q^-0.8, linear in fps)."""
    records = [{"kind": "run", "versions": {"numpy": np.__version__}, "backend": "warp-cpu"},
               {"kind": "stage", "stage": "video", "wall_s": 1.5}]
    for solution, base in (("NSV", 300.0), ("NSV3O", 130.0), ("SSV", 100.0)):
        clip, width, height = ("ase-HELLO", 352, 288) if solution == "SSV" else ("carphone", 176, 144)
        picture = {"clip": clip, "width": width, "height": height}
        for q in (2, 12, 31):
            records.append({"solution": solution, "codec": "mpeg4", "q": q, "fps": 25.0, "kbps": (3.0 + base) * (12 / q) ** 0.8,
                            "image_psnr": 45 - 0.5 * q, "skin_psnr": 44 - 0.5 * q, "ssim": 0.99 - 0.005 * q,
                            "skin_ssim": 0.98 - 0.005 * q, "sweep": "q", "operating_point": q == 12, **picture})
            if solution != "NSV":                        # object solutions: the background is not sent
                records[-1].update(image_psnr=8.0, object_psnr=42 - 0.5 * q, ssim=0.1)
        for fps in (10.0, 15.0, 20.0):
            records.append({"solution": solution, "codec": "mpeg4", "q": 12, "fps": fps, "kbps": 3.0 + base * fps / 25,
                            "sweep": "fps", **picture})
    for q, kbps in ((1, 20.0), (8, 6.0)):
        records.append({"solution": "FBA", "codec": "fba-pred", "q": q, "fps": 25.0, "kbps": kbps, "image_psnr": 40.0 - q,
                        "sweep": "q", "operating_point": q == 8, "clip": "ase-HELLO", "width": 352, "height": 288})
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


def _assert_nothing_empty_or_broken(page: ReportPage) -> None:
    """What the page's footer reports as broken: a table without rows, a chart that does not decode."""
    assert page.tables and all(page.tables.values()), {name: len(rows) for name, rows in page.tables.items()}
    assert all(image is not None and image.std() > 10 for image in page.charts.values())


def test_report_is_self_contained(tmp_path):
    page = build_report(as_records(_records()), tmp_path / "report.html").read_text()
    assert "http://" not in page and "https://" not in page
    parsed = ReportPage(page)
    assert set(parsed.charts) == {"kbps_vs_q", "kbps_vs_fps", "psnr_vs_kbps", "ssim_vs_kbps"}
    assert set(parsed.tables) == {"summary", "linear_fits", "requirements", "points", "versions", "stages"}
    _assert_nothing_empty_or_broken(parsed)


def test_summary_names_each_rows_reference_and_marks_whole_frame_figures_of_object_solutions(tmp_path):
    text = build_report(as_records(_records()), tmp_path / "report.html").read_text()
    page = ReportPage(text)
    summary = page.tables["summary"]
    assert [row[0] for row in summary] == ["NSV", "NSV3O", "SSV", "FBA"]
    # solution, codec, quantiser, fps, kbps, measured against, PSNR face+hands, SSIM face+hands, PSNR whole frame, ...
    assert [row[5] for row in summary] == ["source frames of carphone, 176×144", "source frames of carphone, 176×144",
                                           "lossless render of ase-HELLO, 352×288", "lossless render of ase-HELLO, 352×288"]
    assert [row[6] for row in summary] == ["38.00", "38.00", "38.00", "–"]      # face and hands first
    assert [row[8] for row in summary] == ["39.00", "8.00 *", "8.00 *", "32.00"]
    assert "NSV3O, SSV send no background" in text


def test_quantiser_cells_keep_h264_and_av1_scales_apart_from_mpeg4_q():
    point = {"solution": "NSV3O+C", "q": 12, "objects": [{"name": "skin", "q": 12}, {"name": "clothes", "q": 31}]}
    assert quantiser({**point, "codec": "mpeg4"}) == "Q 12 (+31 clothes)"
    assert quantiser({"solution": "NSV", "codec": "libx264", "q": 37}) == "H.264 QP 37 (0-51)"
    assert quantiser({"solution": "NSV", "codec": "libsvtav1", "q": 55}) == "AV1 QP 55 (1-63)"
    assert quantiser({"solution": "motion coder", "codec": "dpcm", "q": 3, "setting": "16"}) == "setting 3 (16)"


def test_every_codec_gets_its_own_colour_in_the_charts():
    records = _records()
    for codec in ("fba-dct", "bba-pred", "bba-dct", "bba-key"):
        for q, kbps in ((1, 18.0), (8, 7.0)):
            records.append({"solution": "BBA" if codec.startswith("bba") else "FBA", "codec": codec, "q": q, "fps": 25.0,
                            "kbps": kbps, "image_psnr": 40.0 - q, "skin_psnr": 30.0 - q, "sweep": "q", "clip": "ase-HELLO",
                            "width": 352, "height": 288})
    records.append({**records[3], "codec": "libx264", "q": 30, "sweep": "codec", "operating_point": False})
    figure = chart_kbps_vs_q(records)
    lines = figure.axes[0].lines
    assert len(lines) == 8 and len({line.get_color() for line in lines}) == 8
    figure = chart_rate_quality(as_records(records), "psnr")
    legend = figure.legends[0]
    colours = {text.get_text(): line.get_color() for line, text in zip(legend.legend_handles, legend.get_texts())}
    assert len(colours) == 9 and len(set(colours.values())) == 9        # 8 swept series and NSV's H.264 point
    plt.close("all")


def test_report_refuses_records_without_a_measured_point_in_one_line(tmp_path, capsys):
    from pipeline.cli import main
    path = tmp_path / "records.jsonl"
    path.write_text(json.dumps({"kind": "run", "backend": "cpu"}) + "\n")
    assert main(["report", str(path), "-o", str(tmp_path / "report.html")]) == 2
    error = capsys.readouterr().err.strip()
    assert "\n" not in error and "no measured points" in error
    assert not (tmp_path / "report.html").exists()


@pytest.fixture(scope="module")
def command_records(tmp_path_factory):
    """records.jsonl written by a real command, per kind, with small settings; made once per kind."""
    from pipeline.cli import main
    made = {}

    def make(kind: str) -> Path:
        if kind not in made:
            out = tmp_path_factory.mktemp(kind)
            args = {"params": ["params", "ase", "AB", "--codecs", "fba-pred,bba-dct", "--param-q", "4,16", "--fps", "10"],
                    "lab": ["lab", "ase", "--codecs", "dpcm,fba-pred", "--param-q", "4,16"],
                    "video": ["video", "--video", "carphone", "--frames", "12", "--video-q", "12,31", "--video-codecs", "libx264",
                              "--no-progress"]}[kind]
            assert main([*args, "--out", str(out)]) == 0
            made[kind] = out / "records.jsonl"
        return made[kind]
    return make


def _report_of(records_path: Path) -> ReportPage:
    from pipeline.cli import main
    output = records_path.with_name("report.html")
    assert main(["report", str(records_path), "-o", str(output), "--force"]) == 0
    return ReportPage(output.read_text())


def test_report_on_params_records_summarises_parameter_coding_without_image_charts(command_records):
    page = _report_of(command_records("params"))
    _assert_nothing_empty_or_broken(page)
    summary = page.tables["parameter_summary"]
    # solution, codec, quantiser, fps, clips, measured against, kbps, parameter PSNR, VPSNR, joint error
    assert [(row[1], row[2]) for row in summary] == [("fba-pred", "Q 4"), ("fba-pred", "Q 16"), ("bba-dct", "Q 4"),
                                                     ("bba-dct", "Q 16")]
    assert all(row[4] == "ase:A, ase:B" for row in summary)               # each row is the mean of both letters
    assert all(row[5] == "motion before coding (full-precision BAPs)" and float(row[7]) > 10 for row in summary)
    assert set(page.charts) == {"kbps_vs_q", "parameter_quality"}
    assert "summary" not in page.tables and "stages" not in page.tables


@pytest.mark.slow
def test_report_on_lab_records_keeps_coder_settings_apart_from_quantisers(command_records):
    page = _report_of(command_records("lab"))
    _assert_nothing_empty_or_broken(page)
    summary = page.tables["parameter_summary"]
    assert {row[1] for row in summary} == {"dpcm", "fba-pred"}
    # FBA's rows first, then the motion coder's (media.domain.SOLUTION_ORDER)
    assert [row[0] for row in summary] == ["FBA"] * 2 + ["motion coder"] * (len(summary) - 2)
    assert all(row[2].startswith("setting ") for row in summary if row[1] == "dpcm")
    assert [row[2] for row in summary if row[1] == "fba-pred"] == ["Q 4", "Q 16"]
    assert set(page.charts) == {"kbps_vs_q", "parameter_quality"}


@pytest.mark.slow
def test_report_on_video_records_fills_every_table_and_names_the_codec_scales(command_records):
    page = _report_of(command_records("video"))
    _assert_nothing_empty_or_broken(page)
    summary = page.tables["summary"]
    assert [row[0] for row in summary] == ["NSV", "NSV2O", "NSV3O", "NSV3O+C"]
    assert all(row[5].startswith("source frames of carphone") for row in summary)
    assert set(page.charts) == {"kbps_vs_q", "kbps_vs_fps", "psnr_vs_kbps", "ssim_vs_kbps"}
    assert {"linear_fits", "requirements", "points", "versions"} <= set(page.tables) and "stages" not in page.tables
    h264 = [cell for cell in page.column("points", 3) if "H.264" in cell]
    # the four object solutions at matched quality (constant QP) and NSV-ROI (x264's CRF: addroi needs CRF mode)
    assert sorted(cell.split()[1] for cell in h264) == ["CRF"] + ["QP"] * 4, h264


def _chromium() -> list[str]:
    browser = shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")
    if browser is None:
        pytest.skip("Chromium is not installed (Debian: apt-get install chromium); .ci/run installs it")
    return [browser, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars"]


def _footer(flags: list[str], report: Path) -> str:
    """The page's own render check, as Chromium runs it."""
    dom = subprocess.run([*flags, "--virtual-time-budget=5000", "--dump-dom", report.as_uri()],
                         capture_output=True, text=True, timeout=120).stdout
    return dom.split('id="render-check">', 1)[1].split("<", 1)[0] if 'id="render-check">' in dom else dom[-200:]


@pytest.mark.slow
def test_report_renders_in_headless_chromium(tmp_path):
    flags = _chromium()
    report = build_report(as_records(_records()), tmp_path / "report.html")
    assert _footer(flags, report) == "rendered 4/4 charts, 6/6 tables; all ok"
    screenshot = tmp_path / "report.png"
    subprocess.run([*flags, "--window-size=1280,2400", f"--screenshot={screenshot}", report.as_uri()],
                   capture_output=True, timeout=120, cwd=tmp_path)
    image = cv2.imread(str(screenshot))
    assert image is not None and image.shape[:2] == (2400, 1280)
    assert image.std() > 20                              # charts and tables drew something, not a blank page


@pytest.mark.slow
def test_the_render_check_flags_a_table_wider_than_the_page(tmp_path):
    """The page's own check also measures the tables against the body's max-width: a clip name of 300 characters
    without a space makes the table of every point too wide, and the footer says which."""
    flags = _chromium()
    records = [dict(r, clip="x" * 300) if r.get("kind", "point") == "point" else r for r in _records()]
    footer = _footer(flags, build_report(as_records(records), tmp_path / "report.html"))
    assert footer.startswith("rendered 4/4 charts, 6/6 tables; broken: ") and "points (too wide)" in footer, footer


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["params", "lab", "video"])
def test_report_on_each_command_s_records_renders_in_headless_chromium(command_records, kind):
    flags = _chromium()
    page = _report_of(command_records(kind))
    charts, tables = len(page.charts), len(page.tables)
    assert charts >= 2 and tables >= 2
    footer = _footer(flags, command_records(kind).with_name("report.html"))
    assert footer == f"rendered {charts}/{charts} charts, {tables}/{tables} tables; all ok"


@pytest.mark.parametrize("field, value", [("kbps", '"fast"'), ("fps", '"x"')])
def test_report_command_rejects_a_record_of_the_wrong_type_in_one_line(tmp_path, capsys, field, value):
    import json
    from pipeline.cli import main
    lines = [json.dumps(r) for r in _records()]
    lines[3] = lines[3].replace(f'"{field}": {json.loads(lines[3])[field]}', f'"{field}": {value}')
    path = tmp_path / "records.jsonl"
    path.write_text("\n".join(lines) + "\n")
    assert main(["report", str(path), "-o", str(tmp_path / "report.html")]) == 2
    error = capsys.readouterr().err.strip()
    assert "\n" not in error and "records.jsonl:4:" in error and field in error
    assert not (tmp_path / "report.html").exists()

"""`signcast video`: end to end on a few frames of the real carphone clip and of the rendered signer."""
import csv

import numpy as np
import pytest

from comparisons.reports.records import read_records
from pipeline.cli import main


@pytest.mark.slow
def test_video_command_on_carphone_writes_records_tables_plots_and_overlays(tmp_path, capsys, check_png):
    out = tmp_path / "carphone"
    code = main(["video", "--video", "carphone", "--frames", "12", "--video-q", "12,31", "--video-codecs", "libx264",
                 "--out", str(out), "--no-progress"])
    assert code == 0
    records = read_records(out / "records.jsonl")
    points = [r for r in records if r.get("kind") == "point"]
    # 4 solutions x (2 Q at carphone's own 29.97 fps + 4 lower frame rates + half resolution + x264), and NSV-ROI
    assert len(points) == 4 * 8 + 1
    roi = [r for r in points if r["solution"] == "NSV-ROI"]
    assert len(roi) == 1 and roi[0]["codec"] == "libx264" and roi[0]["sweep"] == "codec" and roi[0]["shape_bits"] == 0
    native = 29.97
    by_key = {(r["solution"], r["codec"], r["q"], round(r["fps"], 2), r["width"]): r for r in points}
    nsv = by_key[("NSV", "mpeg4", 12, native, 176)]
    nsv3o = by_key[("NSV3O", "mpeg4", 12, native, 176)]
    assert nsv["kbps"] == pytest.approx(nsv["bits"] / nsv["duration_s"] / 1000)
    assert nsv3o["kbps"] < nsv["kbps"] and nsv3o["shape_bits"] > 0
    assert by_key[("NSV", "mpeg4", 31, native, 176)]["kbps"] < nsv["kbps"]
    assert by_key[("NSV", "mpeg4", 12, 10.0, 176)]["kbps"] < nsv["kbps"]
    assert by_key[("NSV", "mpeg4", 12, native, 88)]["kbps"] < nsv["kbps"]
    assert 25 < nsv["skin_psnr"] < 40 and 0.5 < nsv3o["skin_ssim"] <= 1
    plus = by_key[("NSV3O+C", "mpeg4", 12, native, 176)]
    assert plus["kbps"] == pytest.approx(nsv3o["kbps"] + plus["clothes_overload_kbps"])
    assert all(r["versions"]["av"] for r in points)
    for name in ("table_rate_vs_q.csv", "table_rate_vs_fps.csv", "table_rate_vs_resolution.csv", "table_codecs.csv",
                 "fits_rate_vs_fps.csv", "table_clothes_overload.csv", "table_shape_coding.csv"):
        with (out / name).open() as handle:
            rows = list(csv.reader(handle))
        assert len(rows) >= 2 and all(len(row) == len(rows[0]) for row in rows), name     # a header and data
    # 110 dpi, tight: 7.5 x 4.5 in and 12 x 4.8 in figures with their legends outside (962x473, 1484x532 px here)
    for name in ("kbps_vs_q.png", "kbps_vs_fps.png"):
        check_png(out / name, ((800, 1200), (400, 560)))
    for name in ("psnr_vs_kbps.png", "ssim_vs_kbps.png"):
        check_png(out / name, ((1300, 1700), (450, 620)))
    overlay = check_png(out / "masks_overlay.png", (4 * 176, 144))     # four frames side by side, parts tinted
    assert all(overlay[:, k * 176:(k + 1) * 176].std() > 20 for k in range(4))
    with (out / "fits_rate_vs_fps.csv").open() as handle:
        fits = list(csv.DictReader(handle))
    assert {row["series"] for row in fits} == {"NSV · mpeg4", "NSV2O · mpeg4", "NSV3O · mpeg4", "NSV3O+C · mpeg4"}
    assert all(float(row["slope kbps per fps"]) > 0 for row in fits)
    printed = capsys.readouterr().out
    assert "NSV3O+C" in printed and "Q=12" in printed


@pytest.mark.slow
def test_video_command_on_the_rendered_signer_reports_segmentation_iou(tmp_path, capsys, check_png):
    out = tmp_path / "ssv"
    code = main(["video", "--ssv", "ase", "HI", "--frames", "8", "--size", "160x136", "--video-q", "12",
                 "--video-codecs", "none", "--out", str(out), "--no-progress"])
    assert code == 0
    records = read_records(out / "records.jsonl")
    segmentation = {r["method"]: r for r in records if r.get("kind") == "segmentation"}
    flat = segmentation["flat-colour rendering"]
    assert flat["iou_signer"] > 0.97 and flat["iou_head"] > 0.9
    assert segmentation["colour segmentation of the shaded rendering"]["iou_signer"] > 0.8
    ssv = [r for r in records if r.get("kind") == "point" and r["solution"] == "SSV" and r["fps"] == 25.0
           and r["width"] == 160]
    assert ssv and ssv[0]["shape_bits"] > 0 and np.isfinite(ssv[0]["skin_psnr"])
    check_png(out / "colour_segmentation_overlay.png", (4 * 160, 136))


def test_video_command_rejects_bad_arguments(tmp_path, capsys):
    assert main(["video", "--video", "carphone", "--video-q", "6", "--out", str(tmp_path)]) == 2
    assert main(["video", "--video", "carphone", "--video-q", "12,40", "--out", str(tmp_path)]) == 2
    assert main(["video", "--video", "no/such/file.mp4", "--out", str(tmp_path)]) == 2
    assert main(["video", "--video", "carphone", "--video-codecs", "h263", "--out", str(tmp_path)]) == 2
    assert "error:" in capsys.readouterr().err

"""`signcast lab`: seed-002 coders and FBA/BBA on a whole-alphabet sequence, records, ranges and charts."""
import json

import pytest

from comparisons.reports.lab import operating_ranges
from pipeline.studies import lab
from pipeline.cli import main


@pytest.mark.slow
def test_lab_measures_every_operating_point_and_writes_charts(tmp_path, check_png):
    records = lab.run(lab.LabSettings(("ase",), ("dct", "posture", "fba-pred"), mpeg4_q=(8, 31)), tmp_path)
    by_codec = {}
    for r in records:
        by_codec.setdefault(r["codec"], []).append(r)
    assert len(by_codec["dct"]) == 6 and len(by_codec["posture"]) == 10 and len(by_codec["fba-pred"]) == 2
    assert {(r["codec"], r["solution"]) for r in records} == {("dct", "motion coder"), ("posture", "motion coder"),
                                                              ("fba-pred", "FBA")}
    for r in records:
        assert r["clip"] == "ase:alphabet" and r["bits"] > 0 and r["frames"] > 300
        assert r["kbps"] == pytest.approx(r["bits"] / r["duration_s"] / 1000)
    dct = sorted(by_codec["dct"], key=lambda r: r["q"])
    assert dct[-1]["kbps"] > dct[0]["kbps"] and dct[-1]["param_psnr"] > dct[0]["param_psnr"]
    # model-based coding works at a fraction of the waveform coders' rate
    assert max(r["kbps"] for r in by_codec["posture"]) < min(r["kbps"] for r in by_codec["dct"])
    ranges = {row["codec"]: row for row in operating_ranges(records)}
    assert ranges["dct"]["kbps_min"] == pytest.approx(dct[0]["kbps"])
    lines = (tmp_path / "records.jsonl").read_text().splitlines()
    assert len(lines) == len(records) and json.loads(lines[0])["codec"] == "dct"
    for name in ("lab_points.csv", "lab_ranges.csv"):
        lines = (tmp_path / name).read_text().splitlines()
        assert len(lines) >= 2 and "codec" in lines[0], name                       # a header and data
    for name in ("lab_waveform_psnr.png", "lab_model_vpsnr.png"):
        check_png(tmp_path / name, (572, 506))                                     # one clip: 5.2 x 4.6 in at 110 dpi


def test_lab_command_rejects_unknown_codecs_and_languages(tmp_path, capsys):
    assert main(["lab", "ase", "--codecs", "mp3", "--out", str(tmp_path)]) == 2
    assert main(["lab", "xx", "--codecs", "dct", "--out", str(tmp_path)]) == 2
    assert main(["lab", "ase", "--codecs", "dct", "--param-q", "0", "--out", str(tmp_path)]) == 2
    assert capsys.readouterr().err.count("error") == 3

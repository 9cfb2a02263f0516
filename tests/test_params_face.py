"""The parameter study with the face: FBA streams carry the letters' FAPs, records say what the face adds, .fap
files are written and read back."""
import numpy as np
import pytest

from comparisons.fap_file import read_fap
from media.fingerspelling import letter_motion
from pipeline.studies import params


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    out = tmp_path_factory.mktemp("params_face")
    settings = params.ParamsSettings("ase", "A", ("fba-dct", "fba-pred"), (4, 31), 10.0, face=True)
    return out, params.run(settings, out)


def test_records_say_what_the_face_adds_and_how_well_it_decodes(study):
    _, records = study
    assert len(records) == 4
    for record in records:
        assert 0 < record["face_kbps"] < record["kbps"]
        assert record["fap_error"] >= 0
    by_q = {(r["codec"], r["q"]): r for r in records}
    for codec in ("fba-dct", "fba-pred"):
        assert by_q[(codec, 31)]["face_kbps"] < by_q[(codec, 4)]["face_kbps"]
        assert by_q[(codec, 31)]["fap_error"] > by_q[(codec, 4)]["fap_error"]


def test_the_letters_faps_are_written_as_fap_files(study):
    out, _ = study
    faps, fps, name = read_fap(out / "fap" / "ase_A.fap")
    motion = letter_motion("ase", "A", 10.0)
    assert fps == 10.0 and name == "ase_A"
    assert np.array_equal(faps, motion.faps)


def test_without_the_face_the_body_is_coded_alone(tmp_path):
    records = params.run(params.ParamsSettings("ase", "A", ("fba-dct",), (4,), 10.0), tmp_path)
    assert "face_kbps" not in records[0] and not (tmp_path / "fap").exists()


def test_a_coder_that_sends_no_face_says_so(tmp_path):
    """seed 002's coders carry the signing joints only: their records say the face was not sent (no face_kbps of 0
    that would read as a free face), the table says so, and a sweep's report names them."""
    from comparisons import sweep_report
    settings = params.ParamsSettings("ase", "A", ("quant", "fba-dct"), (1,), 10.0, face=True)
    records = params.run(settings, tmp_path)
    by_codec = {r["codec"]: r for r in records}
    assert by_codec["quant"]["face_sent"] is False and "face_kbps" not in by_codec["quant"]
    assert by_codec["fba-dct"]["face_sent"] is True and by_codec["fba-dct"]["face_kbps"] > 0
    table = params.main_table(settings, records)
    assert table.count("face not sent") == 1 and "kbps the face adds" in table
    points = [dict(r, kind="point") for r in records]
    note = sweep_report.face_note(points)
    assert note is not None and "quant" in note and "fba-dct" not in note
    assert sweep_report.face_note([r for r in points if r["codec"] == "fba-dct"]) is None

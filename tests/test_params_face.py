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

"""The parameter study with the face: FBA streams carry the letters' FAPs, records say what the face adds, .fap
files are written and read back."""
import numpy as np
import pytest

from comparisons.params.fap_file import read_fap
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
    from comparisons.reports import sweep as sweep_report
    settings = params.ParamsSettings("ase", "A", ("quant", "fba-dct"), (1,), 10.0, face=True)
    records = params.run(settings, tmp_path)
    by_codec = {r["codec"]: r for r in records}
    assert by_codec["quant"]["face_sent"] is False and "face_kbps" not in by_codec["quant"]
    assert by_codec["fba-dct"]["face_sent"] is True and by_codec["fba-dct"]["face_kbps"] > 0
    table = params.main_table(settings, records)
    assert table.count("face not sent") == 1 and "kbps the face adds" in table
    assert table.count("the face bones' mean error in the head's frame") == 2
    points = [dict(r, kind="point") for r in records]
    note = sweep_report.face_note(points)
    assert note is not None and "quant" in note and "fba-dct" not in note
    assert sweep_report.face_note([r for r in points if r["codec"] == "fba-dct"]) is None


def test_face_joint_error_takes_the_heads_pose_out_and_sees_a_face_at_rest():
    """metrics.face_joint_error_mm measures the face bones in the head's frame: a head turned by 5 degrees with the
    same face gives ~0 there (but millimetres of whole-body joint error); the same face left at rest does not."""
    from scipy.spatial.transform import Rotation

    from comparisons.judging import metrics
    from media.avatar import load_avatar
    from media.face_rig import face_bone_names, with_face_bones
    from media.motion import Motion
    skeleton = load_avatar().skeleton
    motion = letter_motion("ase", "B", 10.0)
    played, names = with_face_bones(motion), face_bone_names()
    assert len(names) == 44 and not metrics.face_joint_error_mm(skeleton, played, played, names).any()
    head = played.bone_names.index("head")
    turned = played.rotations.copy()
    nod = Rotation.from_euler("x", 5, degrees=True)
    xyzw = (nod * Rotation.from_quat(turned[:, head], scalar_first=True)).as_quat(scalar_first=True)
    turned[:, head] = xyzw
    nodded = Motion(played.fps, played.bone_names, turned, played.root_translation, played.faps)
    assert metrics.joint_position_error_mm(skeleton, played, nodded)[:, [skeleton.index(n) for n in names]].mean() > 2.0
    assert metrics.face_joint_error_mm(skeleton, played, nodded, names).max() < 1e-9
    at_rest = with_face_bones(motion.without_face())
    face_mm = metrics.face_joint_error_mm(skeleton, played, at_rest, names)
    assert face_mm.shape == (motion.n_frames, 44) and face_mm.max() > 2.0


def test_records_carry_the_face_joint_error():
    from comparisons.params.study import measure_point
    motion = letter_motion("ase", "C", 10.0)
    sent, dropped = measure_point(motion, "fba-dct", 4), measure_point(motion, "quant", 6)
    assert 0 < sent["face_joint_error_mm"] <= sent["face_joint_error_mm_max"]
    assert dropped["face_joint_error_mm"] > 5 * sent["face_joint_error_mm"]
    # each frame's worst face point, 90th percentile over frames: the sweep's face threshold (2 mm) tells them apart
    assert sent["face_joint_error_mm"] < sent["face_joint_error_mm_p90"] <= sent["face_joint_error_mm_max"]
    assert sent["face_joint_error_mm_p90"] < 1.0 < 2.0 < dropped["face_joint_error_mm_p90"]
    assert "face_joint_error_mm" not in measure_point(motion.without_face(), "fba-dct", 4)

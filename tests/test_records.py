"""records.jsonl: one typed Record per line, schema-versioned, image and parameter quality in separate fields,
legacy lines (no "schema") renamed or rejected in one line."""
import json

import pytest

from comparisons.reports.records import (SCHEMA_VERSION, Record, as_records, make_record, normalize_records, read_records,
                                         read_typed_records, report_rows)

from pipeline.outputs import write_records
from media.errors import SigncastError


def _every_kind() -> list[Record]:
    video = make_record("NSV3O", "carphone", "mpeg4", 12, 29.97, 176, 144, 480_000, 4.0, sweep="q",
                        operating_point=True, skin_area_percent=12.5, shape_bits=9000,
                        objects=[{"name": "head", "q": 12}])
    params = make_record("FBA", "ase:A", "fba-pred", 8, 25.0, 0, 0, 7304, 0.9, pose_kbps=41.0, frames=23)
    return [
        Record(**{k: v for k, v in video.items() if k not in ("kind", "sweep", "operating_point", "skin_area_percent",
                                                                "shape_bits")},
               sweep="q", image_psnr=31.5, skin_psnr=33.25, object_psnr=34.0, ssim=0.91, skin_ssim=0.93,
               object_ssim=0.95, extra={"operating_point": True, "skin_area_percent": 12.5, "shape_bits": 9000}),
        Record(**{k: v for k, v in params.items() if k not in ("kind", "pose_kbps", "frames")},
               param_psnr=38.5, vpsnr=21.0, joint_error_mm_mean=1.25, joint_error_mm_max=4.5,
               group_errors={"right hand": [0.01, 0.05]}, extra={"pose_kbps": 41.0, "frames": 23}),
        Record(kind="run", backend="numpy", versions={"numpy": "2.0", "av": "14.0"}, clip="carphone",
               extra={"shape_streams": [{"object": "head", "bytes": 120}]}),
        Record(kind="stage", stage="natural video", wall_s=2.5),
        Record(kind="segmentation", clip="ssv-ase-HI", extra={"method": "flat-colour rendering", "iou_head": 0.95}),
        Record(kind="motion_statistics", clip="ase:alphabet", fps=25.0,
               extra={"level": "group", "group": "right hand", "range_deg": 80.5}),
    ]


def test_every_record_kind_survives_a_round_trip(tmp_path):
    records = _every_kind()
    path = write_records(tmp_path / "records.jsonl", records[:3])
    write_records(path, records[3:], append=True)
    assert read_typed_records(path) == records
    lines = [json.loads(line) for line in path.read_text().splitlines()]
    assert [line["schema"] for line in lines] == [SCHEMA_VERSION] * 6
    assert [line["kind"] for line in lines] == ["point", "point", "run", "stage", "segmentation", "motion_statistics"]
    assert lines[0]["image_psnr"] == 31.5 and lines[0]["shape_bits"] == 9000 and "param_psnr" not in lines[0]
    assert lines[1]["param_psnr"] == 38.5 and lines[1]["group_errors"] == {"right hand": [0.01, 0.05]}
    assert "image_psnr" not in lines[1] and "psnr" not in lines[1]
    # the dicts read back are the lines as written
    assert read_records(path) == lines


def test_a_legacy_video_record_loads_with_image_psnr(tmp_path):
    path = tmp_path / "records.jsonl"
    legacy = make_record("NSV", "carphone", "mpeg4", 12, 29.97, 176, 144, 480_000, 4.0, psnr=31.5, psnr_skin=33.0,
                         ssim=0.91, ssim_skin=0.93, psnr_object=34.0, ssim_object=0.95, sweep="q")
    path.write_text(json.dumps(legacy) + "\n")
    (record,) = read_typed_records(path)
    assert (record.image_psnr, record.skin_psnr, record.object_psnr) == (31.5, 33.0, 34.0)
    assert (record.ssim, record.skin_ssim, record.object_ssim) == (0.91, 0.93, 0.95)
    assert record.param_psnr is None and record.extra == {}
    assert record.kbps == pytest.approx(120.0)


def test_a_legacy_params_record_loads_with_param_psnr(tmp_path):
    path = tmp_path / "records.jsonl"
    legacy = make_record("FBA", "ase:A", "fba-pred", 8, 25.0, 0, 0, 7304, 0.9, psnr=38.5, vpsnr=21.0,
                         joint_error_mm_mean=1.25, group_errors={"right hand": [0.01, 0.05]})
    path.write_text('{"kind": "run", "versions": {"numpy": "2"}}\n' + json.dumps(legacy) + "\n")
    run, point = read_records(path)
    assert run == {"schema": SCHEMA_VERSION, "kind": "run", "versions": {"numpy": "2"}}
    assert point["param_psnr"] == 38.5 and point["vpsnr"] == 21.0 and "psnr" not in point and "image_psnr" not in point


def test_legacy_records_in_memory_read_like_renamed_ones():
    legacy = make_record("SSV", "ase-HELLO", "mpeg4", 12, 25.0, 352, 288, 80_000, 2.0, psnr=30.0, psnr_skin=28.0)
    renamed = make_record("SSV", "ase-HELLO", "mpeg4", 12, 25.0, 352, 288, 80_000, 2.0, image_psnr=30.0, skin_psnr=28.0)
    assert normalize_records([legacy]) == normalize_records([renamed])
    assert normalize_records([legacy])[0]["skin_psnr"] == 28.0


def test_a_legacy_psnr_that_cannot_be_placed_is_rejected_in_one_line(tmp_path):
    path = tmp_path / "records.jsonl"
    path.write_text('{"kind": "stage", "stage": "x", "wall_s": 1.0}\n{"solution": "FBA", "fps": 25, "psnr": 30.5}\n')
    with pytest.raises(SigncastError, match=r"records.jsonl:2: legacy record .*'psnr'.*width None, height None") as error:
        read_records(path)
    assert "\n" not in str(error.value)


def test_a_record_with_a_wrong_type_is_rejected_with_its_line_number(tmp_path):
    path = tmp_path / "records.jsonl"
    good = json.dumps(make_record("NSV", "carphone", "mpeg4", 12, 25.0, 176, 144, 8000, 1.0))
    bad = make_record("NSV", "carphone", "mpeg4", 12, 25.0, 176, 144, 8000, 1.0, image_psnr="high")
    path.write_text(good + "\n" + json.dumps({"schema": SCHEMA_VERSION, **bad}) + "\n")
    with pytest.raises(SigncastError, match=r"records.jsonl:2: field 'image_psnr' must be a finite number, got 'high'"):
        read_records(path)


@pytest.mark.parametrize("schema", ['3', '"2"', 'true', '1'])
def test_an_unknown_schema_version_is_rejected_with_a_clear_message(tmp_path, schema):
    path = tmp_path / "records.jsonl"
    path.write_text('{"schema": ' + schema + ', "kind": "stage", "stage": "x", "wall_s": 1.0}\n')
    with pytest.raises(SigncastError, match=rf"records.jsonl:1: unknown records schema {schema}: this signcast reads "
                                            rf"schema {SCHEMA_VERSION} and legacy records"):
        read_records(path)


def test_a_schema_record_with_a_legacy_name_is_rejected(tmp_path):
    path = tmp_path / "records.jsonl"
    path.write_text(json.dumps({"schema": SCHEMA_VERSION, "solution": "NSV", "fps": 25.0, "width": 176,
                                "height": 144, "psnr": 30.0}) + "\n")
    with pytest.raises(SigncastError, match=r"records.jsonl:1: field 'psnr' is not in records schema 2 "
                                            r"\(use 'image_psnr' or 'param_psnr'\)"):
        read_records(path)


def test_image_quality_on_a_point_without_a_picture_is_rejected(tmp_path):
    record = make_record("FBA", "ase:A", "fba-pred", 8, 25.0, 0, 0, 7304, 0.9, image_psnr=30.0)
    with pytest.raises(SigncastError, match="record 1 of 1 .*without a picture .*'image_psnr'"):
        write_records(tmp_path / "records.jsonl", [record])
    assert not (tmp_path / "records.jsonl").exists()


def test_a_report_takes_records_and_names_a_dict_handed_in():
    records = as_records([make_record("FBA", "ase:A", "fba-pred", 8, 25.0, 0, 0, 7304, 0.9)])
    assert isinstance(records[0], Record) and report_rows(records)[0]["kbps"] == pytest.approx(7304 / 0.9 / 1000)
    with pytest.raises(TypeError, match="got dict as item 2 of 2"):
        report_rows([records[0], records[0].to_json()])


def test_a_point_read_without_its_codec_is_written_back_the_same(tmp_path):
    """Record.to_json writes a point's own fields as null where they are missing; reading accepts that null."""
    path = tmp_path / "records.jsonl"
    point = make_record("NSV", "carphone", "mpeg4", 8, 25.0, 176, 144, 8000, 1.0)
    del point["codec"]
    path.write_text(json.dumps(point) + "\n")
    once = read_typed_records(path)
    assert once[0].codec is None
    again = read_typed_records(write_records(tmp_path / "again.jsonl", once))
    assert again == once
    with pytest.raises(SigncastError, match="'codec' must be a string"):
        Record.from_json({**point, "codec": 8})

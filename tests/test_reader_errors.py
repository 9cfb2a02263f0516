"""Readers of user files (.bap, BVH, records.jsonl, video) turn bad input into one SigncastError, never a traceback."""
import numpy as np
import pytest

from comparisons.params import bap_table
from comparisons.params.bap_file import format_bap, read_bap
from comparisons.reports.records import read_records
from media.bvh import read_bvh
from media.errors import SigncastError
from media.text_files import MAX_VALUES
from media.video_io import read_video, write_video

BVH_ONE_JOINT = """HIERARCHY
ROOT hips
{
  OFFSET 0 90 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT spine
  {
    OFFSET 0 10 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    End Site
    {
      OFFSET 0 20 0
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.04
"""


def _bap_text(values: list[int], fps: str = "25") -> str:
    """A one-frame version 3.2 .bap setting BAPs 1..len(values)."""
    mask = ["1"] * len(values) + ["0"] * (bap_table.N_BAPS - len(values))
    return f"3.2 test {fps} 1\n" + " ".join(mask) + "\n" + " ".join(["0", *map(str, values)]) + "\n"


def test_bap_reader_rejects_a_20_digit_value_naming_its_line(tmp_path):
    path = tmp_path / "big.bap"
    path.write_text(_bap_text([10, 9 * 10 ** 19]))
    with pytest.raises(SigncastError, match="line 3"):
        read_bap(path)


@pytest.mark.parametrize("value", [bap_table.ROTATION_RANGE + 1, -bap_table.ROTATION_RANGE - 1])
def test_bap_reader_rejects_a_rotation_outside_plus_minus_pi(tmp_path, value):
    path = tmp_path / "range.bap"
    path.write_text(_bap_text([0, value]))
    with pytest.raises(SigncastError, match="BAP 2 .*outside"):
        read_bap(path)


def test_bap_reader_accepts_translations_up_to_their_own_range(tmp_path):
    values = [0] * 183
    values[180] = bap_table.TRANSLATION_RANGE              # BAP 181, mm: beyond the rotation range, legal
    path = tmp_path / "translation.bap"
    path.write_text(_bap_text(values))
    decoded, fps, name = read_bap(path)
    assert decoded[0, 180] == bap_table.TRANSLATION_RANGE and fps == 25 and name == "test"


@pytest.mark.parametrize("fps", ["inf", "nan", "1e9", "0.001"])
def test_bap_reader_rejects_frame_rates_outside_the_sane_range(tmp_path, fps):
    path = tmp_path / "fps.bap"
    path.write_text(_bap_text([1], fps=fps))
    with pytest.raises(SigncastError, match="frame rate"):
        read_bap(path)


def test_bap_reader_rejects_frame_numbers_out_of_sequence(tmp_path):
    text = format_bap(np.arange(3 * 296).reshape(3, 296) % 100, 25)
    lines = text.splitlines()
    lines[-1] = "7" + lines[-1][1:]                        # frame 2 renumbered 7
    path = tmp_path / "renumbered.bap"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(SigncastError, match="frame number"):
        read_bap(path)


def test_bap_reader_refuses_a_file_announcing_more_values_than_the_cap(tmp_path):
    frames = MAX_VALUES // bap_table.N_BAPS + 1
    path = tmp_path / "huge.bap"
    path.write_text(f"3.2 huge 25 {frames}\n")
    with pytest.raises(SigncastError, match="at most"):
        read_bap(path)


@pytest.mark.parametrize("reader, name", [(read_bap, "x.bap"), (read_bvh, "x.bvh"), (read_records, "records.jsonl")])
def test_readers_reject_non_utf8_bytes(tmp_path, reader, name):
    path = tmp_path / name
    path.write_bytes(b"3.2 \xff\xfe 25 0\n")
    with pytest.raises(SigncastError, match="UTF-8"):
        reader(path)


def test_records_reader_rejects_a_5000_digit_integer_naming_its_line(tmp_path):
    path = tmp_path / "records.jsonl"
    path.write_text('{"kind": "run"}\n{"solution": "NSV", "fps": 25, "bits": ' + "9" * 5000 + "}\n")
    with pytest.raises(SigncastError, match="records.jsonl:2"):
        read_records(path)


@pytest.mark.parametrize("line, field", [('"kbps": "fast"', "kbps"), ('"fps": "x"', "fps"), ('"fps": NaN', "fps"),
                                         ('"kbps": 1e400', "kbps"), ('"solution": 3', "solution"),
                                         ('"versions": [1]', "versions")])
def test_records_reader_rejects_fields_of_the_wrong_type_naming_line_and_field(tmp_path, line, field):
    fields = {"solution": '"NSV"', "codec": '"mpeg4"', "q": "12", "fps": "25.0", "kbps": "100.5"}
    name = line.split(":")[0].strip('"')
    fields[name] = line.split(":", 1)[1].strip()
    path = tmp_path / "records.jsonl"
    path.write_text('{"kind": "run", "versions": {"numpy": "2"}}\n\n'
                    + "{" + ", ".join(f'"{k}": {v}' for k, v in fields.items()) + "}\n")
    with pytest.raises(SigncastError, match=f"records.jsonl:3: .*{field}"):
        read_records(path)


def test_records_reader_keeps_nulls_and_open_fields(tmp_path):
    path = tmp_path / "records.jsonl"
    path.write_text('{"solution": "FBA", "codec": "fba-pred", "q": null, "fps": 25, "kbps": 6.5, "psnr": null, '
                    '"group_errors": {"hand": 1.5}, "objects": [{"name": "head", "q": 12}]}\n')
    (record,) = read_records(path)
    assert record["q"] is None and record["kbps"] == 6.5 and record["objects"][0]["q"] == 12


def test_records_reader_rejects_a_point_without_a_frame_rate(tmp_path):
    path = tmp_path / "records.jsonl"
    path.write_text('{"solution": "NSV", "kbps": 100.0}\n')
    with pytest.raises(SigncastError, match="records.jsonl:1: .*fps"):
        read_records(path)


def _write_bvh(tmp_path, frames: list[str], hierarchy: str = BVH_ONE_JOINT):
    path = tmp_path / "m.bvh"
    path.write_text(hierarchy + "".join(line + "\n" for line in frames))
    return path


def test_bvh_reader_rejects_a_frame_line_with_the_wrong_channel_count(tmp_path):
    # 9 channels per frame; the 18 values are all there, but one line holds 10 and the next 8.
    path = _write_bvh(tmp_path, ["0 90 0 0 0 0 0 0 0 5", "90 0 0 0 0 0 0 0"])
    with pytest.raises(SigncastError, match="9 channels"):
        read_bvh(path)


@pytest.mark.parametrize("text, message", [
    (BVH_ONE_JOINT.replace("OFFSET 0 10 0", "OFFSET 0 nan 0"), "finite"),
    (BVH_ONE_JOINT.replace("Frame Time: 0.04", "Frame Time: 0.000000001"), "frame rate"),
    (BVH_ONE_JOINT.replace("Frame Time: 0.04", "Frame Time: inf"), "finite"),
    (BVH_ONE_JOINT.replace("JOINT spine", "JOINT hips"), "twice"),
    (BVH_ONE_JOINT.replace("Frames: 2", f"Frames: {MAX_VALUES}"), "at most"),
])
def test_bvh_reader_rejects_values_it_would_otherwise_decode_silently(tmp_path, text, message):
    path = _write_bvh(tmp_path, ["0 90 0 0 0 0 0 0 0", "0 90 0 0 0 0 0 0 0"], hierarchy=text)
    with pytest.raises(SigncastError, match=message):
        read_bvh(path)


def test_bvh_reader_rejects_infinite_channel_values(tmp_path):
    path = _write_bvh(tmp_path, ["0 90 0 0 0 0 0 0 0", "0 90 0 0 0 0 0 inf 0"])
    with pytest.raises(SigncastError, match="finite"):
        read_bvh(path)


def _small_mkv(tmp_path):
    frames = np.random.default_rng(0).integers(0, 256, (3, 16, 16, 3), dtype=np.uint8)
    path = tmp_path / "clip.mkv"
    write_video(path, frames, 25)
    return path


def test_video_reader_rejects_a_file_with_damaged_metadata(tmp_path):
    path = _small_mkv(tmp_path)
    data = bytearray(path.read_bytes())
    tag = data.index(b"DURATION")                          # the stream's DURATION tag, a UTF-8 string
    value = data.index(b"00:00:", tag)
    data[value:value + 4] = b"\xff\xfe\xfd\xfc"
    damaged = tmp_path / "damaged.mkv"
    damaged.write_bytes(bytes(data))
    assert read_video(path)[0].shape == (3, 16, 16, 3)    # the undamaged file decodes
    with pytest.raises(SigncastError, match="damaged.mkv"):
        read_video(damaged)


def test_video_reader_rejects_a_file_that_is_not_video(tmp_path):
    path = tmp_path / "notes.mkv"
    path.write_bytes(b"\x1aE\xdf\xa3" + bytes(range(256)) * 4)
    with pytest.raises(SigncastError, match="notes.mkv"):
        read_video(path)



def test_video_reader_rejects_a_stream_whose_codec_id_is_damaged(tmp_path):
    damaged = tmp_path / "codec.mkv"
    damaged.write_bytes(_small_mkv(tmp_path).read_bytes().replace(b"V_FFV1", b"V_QQQQ"))
    with pytest.raises(SigncastError, match="codec.mkv: no decoder"):
        read_video(damaged)

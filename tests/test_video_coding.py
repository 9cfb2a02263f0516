"""Video codecs, padding, object-based coding, quality and records."""
import json
import math

import numpy as np
import pytest

from comparisons.video import quality as image_quality
from comparisons.video import codecs as video_codecs
from comparisons.video import objects as video_objects
from comparisons.reports.records import SCHEMA_VERSION, make_record, read_records, versions
from pipeline.outputs import write_records
from media.errors import SigncastError
from media.video_io import read_video, resolve_video


@pytest.fixture(scope="module")
def carphone():
    frames, _ = read_video(resolve_video("carphone"), max_frames=24)
    return frames


def test_mpeg4_fixed_quantiser_lowers_the_rate_as_q_grows_with_ibbp_gop(carphone):
    sizes = {}
    for q in (2, 12, 31):
        coded = video_codecs.code_video(carphone[:13], 25, "mpeg4", q)
        sizes[q] = coded.bits
        assert coded.decoded.shape == carphone[:13].shape
    assert sizes[2] > 3 * sizes[12] > 3 * sizes[31] * 1.1
    assert "".join(t[0] for t in coded.picture_types) == "IBBPBBPBBPBBI"


def test_today_codecs_round_trip_small_frames(carphone):
    for codec, qp in (("libx264", 30), ("libsvtav1", 40)):
        coded = video_codecs.code_video(carphone[:4, :32, :48], 25, codec, qp)
        assert coded.decoded.shape == (4, 32, 48, 3)
        assert image_quality.psnr(carphone[:4, :32, :48], coded.decoded) > 28


def test_frame_dropping_keeps_the_duration():
    kept = video_codecs.kept_frame_indices(100, 25, 10)
    assert len(kept) == 40 and kept[0] == 0 and kept[1] == 2 and kept[-1] == 97
    assert len(video_codecs.kept_frame_indices(120, 25, 15)) == 72
    with pytest.raises(SigncastError):
        video_codecs.kept_frame_indices(10, 25, 30)


def test_half_resolution_is_even_and_keeps_labels_discrete(carphone):
    labels = np.zeros(carphone.shape[:3], np.uint8)
    labels[:, 40:80, 60:100] = 2
    small, small_labels = video_codecs.half_resolution(carphone[:2], labels[:2])
    assert small.shape == (2, 72, 88, 3) and small_labels.shape == (2, 72, 88)
    assert set(np.unique(small_labels)) == {0, 2}


def test_codec_arguments_are_checked(carphone):
    with pytest.raises(SigncastError):
        video_codecs.code_video(carphone[:2], 25, "mpeg4", 40)
    with pytest.raises(SigncastError):
        video_codecs.code_video(carphone[:2, :31], 25, "mpeg4", 12)
    with pytest.raises(SigncastError):
        video_codecs.decode_video(b"\x00\x01garbage" * 10, "mpeg4")


def test_repetitive_padding_fills_runs_from_their_borders():
    image = np.zeros((3, 6, 3), np.uint8)
    mask = np.zeros((3, 6), bool)
    image[0, 0], image[0, 5] = 10, 21
    mask[0, 0] = mask[0, 5] = True
    image[2, 2] = 50
    mask[2, 2] = True
    padded = video_objects.repetitive_padding(image, mask)
    assert (padded[0, 1:5] == 16).all()            # (10 + 21 + 1) // 2
    assert (padded[2] == 50).all()                 # one opaque pixel fills its row
    assert (padded[1] == (padded[0].astype(int) + padded[2] + 1) // 2).all()  # an empty row: mean of neighbours
    assert (video_objects.repetitive_padding(image, np.zeros_like(mask)) == 128).all()


def test_padding_holds_pixels_outside_the_shape_in_predicted_frames():
    rng = np.random.default_rng(0)
    frames = rng.integers(0, 255, (3, 16, 16, 3), dtype=np.uint8)
    masks = np.zeros((3, 16, 16), bool)
    masks[:, 4:10, 4:10] = True
    masks[2, 4:10, 10:12] = True
    padded = video_objects.pad_object(frames, masks, gop=12)
    outside = ~masks[1] & ~masks[0]
    assert (padded[1][outside] == padded[0][outside]).all()
    assert (padded[2][masks[2]] == frames[2][masks[2]]).all()


def test_object_coding_reproduces_shapes_and_counts_texture_plus_shape(carphone):
    frames = carphone[:12]
    labels = np.zeros(frames.shape[:3], np.uint8)
    yy, xx = np.mgrid[:144, :176]
    for t in range(12):
        labels[t][((yy - 60) / 30.0) ** 2 + ((xx - 80 - t) / 22.0) ** 2 <= 1] = 2
        labels[t][(yy > 110) & (np.abs(xx - 88) < 60)] = 1
    nsv = video_objects.code_solution("NSV", frames, labels, 25, "mpeg4", 12)
    nsv3o = video_objects.code_solution("NSV3O", frames, labels, 25, "mpeg4", 12)
    head = nsv3o.objects[0]
    assert head.name == "head" and len(nsv3o.objects) == 1
    assert np.array_equal(head.decoded_masks, labels == 2)
    assert head.bits == 8 * (head.texture_bytes + head.shape_bytes) and head.shape_bytes > 0
    assert nsv3o.bits < nsv.bits
    skin = labels == 2
    assert image_quality.psnr(frames, nsv3o.picture, skin) > 27
    assert (nsv3o.picture[~nsv3o.region] == 0).all()
    plus_clothes = video_objects.code_solution("NSV3O+C", frames, labels, 25, "mpeg4", 12)
    assert [o.q for o in plus_clothes.objects] == [12, 31]


def test_matched_quality_reaches_the_reference_psnr(carphone):
    frames = carphone[:6, :64, :64]
    labels = np.zeros(frames.shape[:3], np.uint8)
    labels[:, 8:40, 8:48] = 2
    reference = video_objects.code_solution("NSV3O", frames, labels, 25, "mpeg4", 12)
    target = video_objects.object_psnr(reference.objects[0], frames)
    matched = video_objects.code_solution_matched(reference, frames, labels, 25, "libx264")
    assert video_objects.object_psnr(matched.objects[0], frames) >= target


def test_psnr_and_ssim_values():
    rng = np.random.default_rng(2)
    reference = rng.integers(20, 230, (2, 24, 24, 3), dtype=np.uint8)
    assert image_quality.psnr(reference, reference) == math.inf
    assert image_quality.ssim(reference, reference) == pytest.approx(1.0)
    shifted = reference + np.uint8(4)                 # luma error exactly 4 everywhere
    assert image_quality.psnr(reference, shifted) == pytest.approx(10 * math.log10(255 ** 2 / 16), abs=1e-6)
    mask = np.zeros((2, 24, 24), bool)
    assert math.isnan(image_quality.psnr(reference, shifted, mask))
    fields = image_quality.quality_fields(reference, shifted, ~mask)
    assert fields["skin_psnr"] == pytest.approx(fields["image_psnr"])


def test_records_round_trip_with_kbps_and_nan_as_null(tmp_path):
    record = make_record("NSV", "carphone", "mpeg4", 12, 25, 176, 144, 480_000, 4.8, image_psnr=float("nan"), ssim=0.9)
    assert record["kbps"] == pytest.approx(100.0)
    path = write_records(tmp_path / "records.jsonl", [record, {"kind": "run", "versions": versions()}])
    back = read_records(path)
    assert back[0]["kbps"] == pytest.approx(100.0) and back[1]["versions"]["av"]
    # NaN is written as null, and a null quality field is left out: .get reads None
    assert back[0].get("image_psnr") is None and back[0]["ssim"] == 0.9 and back[0]["schema"] == SCHEMA_VERSION
    (tmp_path / "bad.jsonl").write_text(json.dumps(record) + "\n{oops\n")
    with pytest.raises(SigncastError, match="bad.jsonl:2"):
        read_records(tmp_path / "bad.jsonl")

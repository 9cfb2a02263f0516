"""Colour segmentation into DESIGN.md labels: signer vs background, clothes vs skin, head and hands."""
import numpy as np
import pytest

from media import segmentation as seg
from media.errors import SigncastError

BACKGROUND_RGB = (150, 160, 150)
CLOTHES_RGB = (30, 40, 90)
SKIN_RGB = (215, 160, 130)


def synthetic_signer(frames=4, height=96, width=128, seed=0):
    """A studio-like signer: grey-green background, dark-blue torso at the bottom, a skin head, two skin hands.

    The signer's left hand sits on the image's right. Returns (frames (T, H, W, 3) uint8, true labels (T, H, W)).
    """
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[:height, :width]
    images = np.zeros((frames, height, width, 3), np.uint8)
    labels = np.zeros((frames, height, width), np.uint8)
    for t in range(frames):
        label = np.zeros((height, width), np.uint8)
        label[(yy >= 58) & (np.abs(xx - 64) <= 34)] = seg.BODY
        label[((yy - 34) / 16.0) ** 2 + ((xx - 64 - t) / 12.0) ** 2 <= 1] = seg.HEAD
        label[((yy - 62 + 2 * t) / 7.0) ** 2 + ((xx - 100) / 6.0) ** 2 <= 1] = seg.LEFT_HAND
        label[((yy - 66) / 7.0) ** 2 + ((xx - 24) / 6.0) ** 2 <= 1] = seg.RIGHT_HAND
        picture = np.empty((height, width, 3), np.float64)
        picture[:] = BACKGROUND_RGB
        picture[label == seg.BODY] = CLOTHES_RGB
        picture[np.isin(label, seg.SKIN_PARTS)] = SKIN_RGB
        picture += rng.normal(0, 3, picture.shape)
        images[t] = np.clip(picture, 0, 255).astype(np.uint8)
        labels[t] = label
    return images, labels


def test_signer_mask_matches_the_drawn_signer():
    frames, truth = synthetic_signer()
    signer = seg.segment_signer(frames)
    iou = np.count_nonzero(signer & (truth > 0)) / np.count_nonzero(signer | (truth > 0))
    assert iou > 0.95


def test_parts_are_labelled_head_left_and_right_hand_by_the_signers_side():
    frames, truth = synthetic_signer()
    labels = seg.segment_parts(frames)
    iou = seg.iou_per_label(labels, truth)
    assert iou["head"] > 0.85
    assert iou["left_hand"] > 0.7 and iou["right_hand"] > 0.7   # left hand is on the image's right
    assert iou["clothes"] > 0.85
    assert set(np.unique(labels)) <= {0, 1, 2, 3, 4}


def test_single_hand_side_follows_the_head_position():
    skin = np.zeros((60, 80), bool)
    skin[5:30, 30:50] = True          # head
    skin[40:52, 8:18] = True          # a hand on the image's left: the signer's right hand
    labels = seg.label_skin_components(skin, min_area=20)
    assert labels[10, 40] == seg.HEAD and labels[45, 12] == seg.RIGHT_HAND
    labels = seg.label_skin_components(skin[:, ::-1], min_area=20)
    assert labels[45, 80 - 13] == seg.LEFT_HAND


def test_labels_from_flat_rendering_read_the_palette_back():
    truth = np.zeros((2, 20, 24), np.uint8)
    truth[:, 10:, 4:20] = seg.BODY
    truth[:, 2:9, 8:16] = seg.HEAD
    truth[:, 12:16, 0:4] = seg.RIGHT_HAND
    palette = {0: (0, 0, 0), 1: (0, 0, 255), 2: (255, 0, 0), 3: (0, 255, 0), 4: (255, 255, 0)}
    frames = np.array([[[palette[v] for v in row] for row in frame] for frame in truth], np.uint8)
    frames[:, 0, 0] = (10, 5, 20)  # a slightly off pixel still reads as background
    labels = seg.labels_from_flat(frames, palette)
    assert np.array_equal(labels, truth)
    with pytest.raises(SigncastError):
        seg.labels_from_flat(np.full((1, 20, 24, 3), 128, np.uint8), palette)


def test_iou_of_an_absent_part_is_undefined_not_perfect():
    labels = np.zeros((1, 4, 4), np.uint8)
    labels[0, :2] = seg.HEAD
    iou = seg.iou_per_label(labels, labels)
    assert iou["head"] == 1.0 and np.isnan(iou["left_hand"])


def test_segmentation_of_the_real_carphone_clip_finds_a_head_in_the_upper_half():
    from media.video_io import read_video, resolve_video
    frames, _ = read_video(resolve_video("carphone"), max_frames=6)
    labels = seg.segment_parts(frames)
    areas = seg.area_percent(labels)
    assert 25 < areas["signer"] < 60 and 5 < areas["skin"] < 25
    head_rows = np.nonzero(labels[0] == seg.HEAD)[0]
    assert head_rows.mean() < frames.shape[1] * 0.6
    overlay = seg.overlay(frames[0], labels[0])
    assert overlay.shape == frames[0].shape and overlay.dtype == np.uint8


def test_bad_frames_are_rejected():
    with pytest.raises(SigncastError):
        seg.segment_signer(np.zeros((2, 8, 8, 3), np.uint8))
    with pytest.raises(SigncastError):
        seg.segment_parts(np.zeros((2, 32, 32), np.uint8))

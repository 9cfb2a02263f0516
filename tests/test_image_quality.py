"""Image quality (comparisons.video.quality): the fast SSIM map and PSNR against scikit-image's, on real frames
coded by a real codec."""
import math

import numpy as np
import pytest
from skimage.metrics import peak_signal_noise_ratio, structural_similarity

from comparisons.video import codecs as video_codecs
from comparisons.video import quality as image_quality
from media.errors import SigncastError
from media.video_io import read_video, resolve_video

SSIM_TOLERANCE = 1e-3       # per pixel of the map, float32 against scikit-image's float64


@pytest.fixture(scope="module")
def coded_carphone():
    """Six carphone frames (144, 176, 3) and their MPEG-4 Part 2 decodes at Q 4 and Q 31."""
    frames, _ = read_video(resolve_video("carphone"), max_frames=6)
    return frames, {q: video_codecs.code_video(frames, 25, "mpeg4", q).decoded for q in (4, 31)}


def _skimage_maps(reference, decoded):
    ref_y, dec_y = image_quality.luma(reference), image_quality.luma(decoded)
    return np.stack([structural_similarity(ref_y[t], dec_y[t], data_range=255.0, full=True)[1]
                     for t in range(len(ref_y))])


@pytest.mark.parametrize("q", [4, 31])
def test_ssim_map_agrees_with_scikit_image_on_every_pixel(coded_carphone, q):
    frames, decoded = coded_carphone
    ours = image_quality.ssim_maps(frames, decoded[q])
    theirs = _skimage_maps(frames, decoded[q])
    assert ours.dtype == np.float32 and ours.shape == frames.shape[:3]
    assert np.abs(ours - theirs).max() < SSIM_TOLERANCE
    assert image_quality.ssim(frames, decoded[q]) == pytest.approx(theirs.mean(), abs=1e-5)
    assert theirs.mean() < (0.99 if q == 31 else 1.0)          # the decode is not the reference


def test_quality_fields_agree_with_scikit_image_inside_masks(coded_carphone):
    frames, decoded = coded_carphone
    decoded = decoded[31]
    skin = np.zeros(frames.shape[:3], bool)
    skin[:, 20:90, 60:120] = True
    skin[2] = False                                             # a frame without skin
    fields = image_quality.quality_fields(frames, decoded, skin)
    maps = _skimage_maps(frames, decoded)
    ref_y, dec_y = image_quality.luma(frames), image_quality.luma(decoded)
    assert fields["image_psnr"] == pytest.approx(peak_signal_noise_ratio(ref_y, dec_y, data_range=255.0), abs=1e-5)
    skin_mse = float(np.mean((ref_y[skin] - dec_y[skin]) ** 2))
    assert fields["skin_psnr"] == pytest.approx(10 * math.log10(255 ** 2 / skin_mse), abs=1e-5)
    assert fields["ssim"] == pytest.approx(maps.mean(), abs=1e-5)
    assert fields["skin_ssim"] == pytest.approx(maps[skin].mean(), abs=1e-5)
    assert fields["skin_ssim"] != pytest.approx(fields["ssim"], abs=1e-4)


def test_identical_frames_score_one_and_tiny_frames_are_refused():
    frames = np.random.default_rng(3).integers(0, 256, (2, 16, 20, 3), dtype=np.uint8)
    assert image_quality.ssim(frames, frames) == pytest.approx(1.0, abs=1e-6)
    assert image_quality.psnr(frames, frames) == math.inf
    with pytest.raises(SigncastError, match="too small for SSIM"):
        image_quality.ssim(frames[:, :6], frames[:, :6])

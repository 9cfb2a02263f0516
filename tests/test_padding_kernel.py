"""The compiled repetitive padding (comparisons/video/padding.py) gives the NumPy oracle's bytes on real object masks and on
random ones, odd sizes and empty / full masks included."""
import numpy as np
import pytest

from comparisons.video.objects import repetitive_padding, repetitive_padding_numpy


@pytest.mark.parametrize("height, width, density", [(144, 176, 0.02), (37, 53, 0.3), (16, 16, 0.0), (9, 7, 1.0),
                                                    (288, 352, 0.001), (1, 40, 0.1), (40, 1, 0.1)])
def test_compiled_padding_matches_the_numpy_oracle(height, width, density):
    rng = np.random.default_rng(height * 1000 + width)
    image = rng.integers(0, 256, (height, width, 3), dtype=np.uint8)
    for _ in range(5):
        mask = rng.random((height, width)) < density
        assert np.array_equal(repetitive_padding(image, mask), repetitive_padding_numpy(image, mask))


def test_compiled_padding_matches_on_a_real_signer():
    from media import segmentation
    from media.avatar import load_avatar
    from media.fingerspelling import fingerspell
    from media.render import AvatarRenderer, RenderSettings
    renderer = AvatarRenderer(load_avatar(), RenderSettings(width=176, height=144))
    for rgb, labels in renderer.frames(fingerspell("ase", "A").frames(0, 3)):
        for name, mask in segmentation.object_masks(labels[None]).items():
            assert np.array_equal(repetitive_padding(rgb, mask[0]), repetitive_padding_numpy(rgb, mask[0])), name

"""Video objects with lossy binary shape (ShapeCache.shape_error): the texture is padded and composed with the
decoder's masks, the solution reports its shape error, and `signcast video` refuses an impossible setting."""
import numpy as np

from comparisons.video import objects as video_objects
from media.video_io import read_video, resolve_video
from pipeline.cli import main


def ragged_head_labels(frames: int, height: int = 144, width: int = 176) -> np.ndarray:
    """(T, H, W) uint8 labels: a drifting head ellipse (2) with a ragged edge over clothes (1)."""
    rng = np.random.default_rng(5)
    yy, xx = np.mgrid[:height, :width]
    labels = np.zeros((frames, height, width), np.uint8)
    for t in range(frames):
        radius = ((yy - 60) / 30.0) ** 2 + ((xx - 80 - t) / 22.0) ** 2
        labels[t][(yy > 110) & (np.abs(xx - 88) < 60)] = 1
        labels[t][(radius <= 1) ^ ((np.abs(radius - 1) < 0.15) & (rng.random((height, width)) < 0.3))] = 2
    return labels


def test_lossy_shape_objects_compose_with_the_decoders_masks_within_the_stated_error():
    frames, _ = read_video(resolve_video("carphone"), max_frames=12)
    labels = ragged_head_labels(12)
    lossless = video_objects.code_solution("NSV3O", frames, labels, 25, "mpeg4", 12)
    shapes = video_objects.ShapeCache(shape_error=1.0)
    lossy = video_objects.code_solution("NSV3O", frames, labels, 25, "mpeg4", 12, shapes)
    head = lossy.objects[0]
    truth = labels == 2
    wrong = int(np.count_nonzero(head.decoded_masks != truth))
    assert head.shape_errors == (wrong, int(truth.sum())) and wrong > 0
    assert 0 < lossy.shape_error <= 1.0 and lossless.shape_error == 0.0
    assert head.shape_bytes < lossless.objects[0].shape_bytes
    assert np.array_equal(lossy.region, head.decoded_masks)
    assert (lossy.picture[~lossy.region] == 0).all()


def test_video_command_refuses_a_shape_error_out_of_range(tmp_path, capsys):
    assert main(["video", "--video", "carphone", "--shape-error", "12", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "--shape-error" in err and "Traceback" not in err

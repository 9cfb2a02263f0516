"""Reading .pose files: the lexicon's layout, and damaged or foreign files rejected with SigncastError."""
import io
import struct

import numpy as np
import pytest

from media import lexicon
from media.errors import SigncastError
from media.pose_file import HOLISTIC_LAYOUT, read_pose


def _pose_bytes(frames: int = 2, language: str = "ase", letter: str = "A", components=None) -> bytes:
    from pose_format import Pose
    pose = Pose.read(lexicon.lookup(language, letter).path.read_bytes())
    pose.body = pose.body[:frames]
    if components is not None:
        pose = pose.get_components(components)
    buffer = io.BytesIO()
    pose.write(buffer)
    return buffer.getvalue()


def _body_offset(data: bytes) -> int:
    from pose_format.pose_header import PoseHeader, PoseHeaderCache
    from pose_format.utils.reader import BufferReader
    PoseHeaderCache.clear_cache()
    reader = BufferReader(data)
    PoseHeader.read(reader)
    return reader.read_offset


def test_lexicon_clip_reads_as_holistic_layout_with_masked_left_hand():
    entry = lexicon.lookup("ase", "A")
    clip = read_pose(entry.path)
    assert clip.fps == 25.0
    assert list(clip.points) == [name for name, _ in HOLISTIC_LAYOUT]
    assert clip.points["FACE_LANDMARKS"].shape == (clip.n_frames, 478, 3)
    assert clip.points["RIGHT_HAND_LANDMARKS"].shape == (clip.n_frames, 21, 3)
    assert clip.hand_visibility("right") == 1.0 and clip.hand_visibility("left") == 0.0
    assert np.array_equal(clip.points["LEFT_HAND_LANDMARKS"], np.zeros_like(clip.points["LEFT_HAND_LANDMARKS"]))


def test_bytes_and_path_read_the_same_keypoints(tmp_path):
    data = _pose_bytes(frames=3)
    path = tmp_path / "three.pose"
    path.write_bytes(data)
    from_bytes, from_path = read_pose(data), read_pose(path)
    assert from_bytes.n_frames == 3
    for name, _ in HOLISTIC_LAYOUT:
        assert np.array_equal(from_bytes.points[name], from_path.points[name])
        assert np.array_equal(from_bytes.confidence[name], from_path.confidence[name])


def test_truncated_and_padded_files_are_rejected():
    data = _pose_bytes(frames=2)
    for damaged in (data[:-1], data[: len(data) // 2], data[:40], data + b"\0" * 16, b""):
        with pytest.raises(SigncastError, match="damaged pose data"):
            read_pose(damaged)


def test_frame_count_beyond_the_file_is_rejected_before_allocating():
    data = bytearray(_pose_bytes(frames=1))
    offset = _body_offset(bytes(data))
    struct.pack_into("<I", data, offset + 4, 0xFFFFFFFF)        # frames u32, after fps f32
    with pytest.raises(SigncastError, match=r"announces 4294967295 frames"):
        read_pose(bytes(data))


def test_bad_frame_rate_is_rejected():
    data = bytearray(_pose_bytes(frames=1))
    struct.pack_into("<f", data, _body_offset(bytes(data)), float("nan"))
    with pytest.raises(SigncastError, match="bad frame rate"):
        read_pose(bytes(data))


def test_file_without_the_holistic_layout_is_rejected_naming_its_components():
    data = _pose_bytes(frames=1, components=["POSE_LANDMARKS", "RIGHT_HAND_LANDMARKS"])
    with pytest.raises(SigncastError, match=r"not in the MediaPipe Holistic layout.*RIGHT_HAND_LANDMARKS \(21 points"):
        read_pose(data)


def test_missing_file_and_garbage_are_rejected(tmp_path):
    with pytest.raises(SigncastError, match="cannot read pose file"):
        read_pose(tmp_path / "missing.pose")
    with pytest.raises(SigncastError):
        read_pose(bytes(range(256)) * 4)


def _clip_with_world(frames: int = 3):
    from media.pose_file import HAND_WORLD_COMPONENTS
    clip = read_pose(_pose_bytes(frames=frames))
    rng = np.random.default_rng(7)
    for name in HAND_WORLD_COMPONENTS:
        clip.points[name] = rng.normal(0.0, 0.05, (frames, 21, 3))          # metres
        clip.confidence[name] = np.full((frames, 21), 0.9)
    clip.confidence[HAND_WORLD_COMPONENTS[0]][1] = 0.0                       # one frame without the left hand
    clip.points[HAND_WORLD_COMPONENTS[0]][1] = 0.0
    return clip


def test_hand_world_landmarks_survive_the_pose_round_trip(tmp_path):
    """signcast pose keeps the hand model's world landmarks: the lexicon's five components, then the two hands'
    world points (WORLD_LAYOUT); read_pose reads both layouts, and pose-format itself reads the file."""
    from pose_format import Pose

    from media.pose_file import HAND_WORLD_COMPONENTS, WORLD_LAYOUT, write_pose
    clip = _clip_with_world()
    path = tmp_path / "world.pose"
    write_pose(path, clip, 352, 288)
    back = read_pose(path)
    assert list(back.points) == [name for name, _ in WORLD_LAYOUT]
    for name in HAND_WORLD_COMPONENTS:
        seen = clip.confidence[name] > 0
        assert np.allclose(back.points[name], clip.points[name], atol=1e-7)          # float32 in the file
        assert np.array_equal(back.confidence[name] > 0, seen)
    for name, _ in HOLISTIC_LAYOUT:
        assert np.allclose(back.points[name], clip.points[name], atol=1e-3)
    pose = Pose.read(path.read_bytes())
    assert [c.name for c in pose.header.components] == [name for name, _ in WORLD_LAYOUT]


def test_lexicon_layout_is_still_written_without_world_landmarks(tmp_path):
    from media.pose_file import write_pose
    clip = read_pose(_pose_bytes(frames=2))
    path = tmp_path / "plain.pose"
    write_pose(path, clip, 352, 288)
    assert list(read_pose(path).points) == [name for name, _ in HOLISTIC_LAYOUT]


def test_other_extra_components_are_still_rejected(tmp_path):
    from pose_format import Pose
    from pose_format.pose_header import PoseHeaderComponent

    from media.pose_file import write_pose
    path = tmp_path / "world.pose"
    write_pose(path, _clip_with_world(), 352, 288)
    pose = Pose.read(path.read_bytes())
    pose.header.components[-1] = PoseHeaderComponent("RIGHT_HAND_EXTRA", pose.header.components[-1].points, [], [],
                                                     "XYZC")
    buffer = io.BytesIO()
    pose.write(buffer)
    with pytest.raises(SigncastError, match=r"optionally followed by.*it has: .*RIGHT_HAND_EXTRA \(21 points, XYZC\)"):
        read_pose(buffer.getvalue())

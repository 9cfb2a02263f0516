"""The pure pieces of benchmarks/vs_gltf.py: the glTF written from a Motion, gltfpack's output read back through
meshoptimizer's decoder, the track sampling and the equal-error ratio. Tests that need gltfpack or the meshopt
package skip with the reason (and how to install them) where those are absent."""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmarks import vs_gltf
from media import rotations
from media.kinematics import joint_positions


@pytest.fixture(scope="module")
def body(fingerspelling_ab):
    """Real ASL 'AB' at 25 fps, body only (the glTF carries no face)."""
    return fingerspelling_ab.without_face()


@pytest.fixture(scope="module")
def tools() -> None:
    problem = vs_gltf.missing_tools()
    if problem:
        pytest.skip(problem)


def _node_world_positions(document: dict, animation: vs_gltf.GltfAnimation, times: np.ndarray) -> dict[str, np.ndarray]:
    """(N, 3) world position of every node's origin, composing T * R parent to child (glTF 2.0 section 3.5.3)."""
    nodes = document["nodes"]
    positions: dict[str, np.ndarray] = {}

    def visit(index: int, parent_rotation: np.ndarray, parent_position: np.ndarray) -> None:
        name = nodes[index]["name"]
        track = animation.tracks.get((name, "translation"))
        translation = (vs_gltf.sample_track(track, times, rotation=False) if track is not None
                       else np.broadcast_to(animation.node_translations[name], (len(times), 3)))
        local = vs_gltf.animation_rotations(animation, [name], times)[:, 0]
        position = parent_position + rotations.rotate(parent_rotation, translation)
        positions[name] = position
        for child in nodes[index].get("children", []):
            visit(child, rotations.multiply(parent_rotation, local), position)

    for root in document["scenes"][0]["nodes"]:
        visit(root, np.tile([1.0, 0.0, 0.0, 0.0], (len(times), 1)), np.zeros((len(times), 3)))
    return positions


def test_written_gltf_round_trips_rotations_and_poses_the_avatar_like_kinematics(body, avatar, tmp_path):
    skeleton = avatar.skeleton
    bones = vs_gltf.moving_bones(body)
    assert bones and len(bones) < len(body.bone_names)
    path = vs_gltf.write_gltf(body, skeleton, tmp_path, bones)
    animation = vs_gltf.read_animation(path)
    times = np.arange(body.n_frames) / body.fps
    read = vs_gltf.animation_rotations(animation, bones, times)
    original = body.rotations[:, [body.bone(name) for name in bones]]
    np.testing.assert_allclose(rotations.canonical(read), rotations.canonical(original), atol=2e-7)
    assert {name for name, kind in animation.tracks if kind == "rotation"} == set(bones)
    # glTF stores (x, y, z, w), w last (glTF 2.0 section 3.11): read the first rotation track's floats raw.
    document = json.loads(path.read_text())
    accessor = document["accessors"][document["animations"][0]["samplers"][0]["output"]]
    view = document["bufferViews"][accessor["bufferView"]]
    raw = np.frombuffer((tmp_path / "motion.bin").read_bytes(), np.float32, accessor["count"] * 4, view["byteOffset"])
    first = body.rotations[:, body.bone(bones[0])]
    np.testing.assert_allclose(raw.reshape(-1, 4)[:, 3], first[:, 0], atol=1e-7)
    np.testing.assert_allclose(raw.reshape(-1, 4)[:, :3], first[:, 1:], atol=1e-7)
    # The node hierarchy and rest offsets put every joint where media/kinematics.py does.
    frames = np.array([0, body.n_frames // 2, body.n_frames - 1])
    world = _node_world_positions(document, animation, times[frames])
    expected = joint_positions(skeleton, body)[frames]
    for name in ("wrist.R", "finger2-3.R", "head"):
        np.testing.assert_allclose(world[name], expected[:, skeleton.index(name)], atol=1e-5)


def test_gltfpack_output_parses_with_meshopt_compressed_quaternion_tracks(body, avatar, tmp_path, tools):
    source = vs_gltf.write_gltf(body, avatar.skeleton, tmp_path)
    packed = tmp_path / "packed.glb"
    vs_gltf.gltfpack(source, packed, body.fps, 12)
    animation = vs_gltf.read_animation(packed)
    document, _ = vs_gltf._read_container(packed)
    filters = {view["extensions"]["EXT_meshopt_compression"].get("filter", "NONE")
               for view in document["bufferViews"] if "EXT_meshopt_compression" in view.get("extensions", {})}
    assert "QUATERNION" in filters
    assert 0 < animation.animation_bytes < animation.file_bytes
    rotation_tracks = [track for (name, kind), track in animation.tracks.items() if kind == "rotation"]
    assert rotation_tracks and all(np.all(np.diff(track.times) > 0) for track in rotation_tracks)
    assert {name for name, _ in animation.tracks} <= set(vs_gltf.moving_bones(body)) | {"root"}


def test_meshopt_decoded_rotations_at_16_bits_are_within_a_hundredth_of_a_degree(body, avatar, tmp_path, tools):
    bones = vs_gltf.moving_bones(body)
    errors, animation_bytes, file_bytes, keyed = vs_gltf.gltf_errors(body, avatar.skeleton, 16, tmp_path)
    assert errors.shape == (body.n_frames, len(bones)) and keyed > len(bones) // 2
    animation = vs_gltf.read_animation(tmp_path / "motion-16.glb")
    still = []
    for k, name in enumerate(bones):
        track = animation.tracks.get((name, "rotation"))
        if track is not None and len(track.times) > 1:
            assert errors[:, k].max() < 0.01, name
        else:
            still.append(k)
    # gltfpack makes a track constant only when all keys lie within ~0.2 deg of the first one, and drops it when
    # that key is as close to rest: the error it leaves is bounded by both.
    for k in still:
        q = body.rotations[:, body.bone(bones[k])]
        assert np.all(rotations.angle_between(q, q[:1]) <= 1.01 * vs_gltf.GLTFPACK_STILL_RAD)
        assert errors[:, k].max() < np.degrees(2 * 1.01 * vs_gltf.GLTFPACK_STILL_RAD) + 0.01
    assert len(still) == len(bones) - keyed
    coarse, coarse_bytes, _, _ = vs_gltf.gltf_errors(body, avatar.skeleton, 8, tmp_path)
    assert coarse.mean() > errors.mean() and coarse_bytes < animation_bytes < file_bytes


def test_codec_errors_compare_the_moving_bones_by_name(body):
    errors, size, carried = vs_gltf.codec_errors(body, "fba-dct", 1)
    assert errors.shape == (body.n_frames, len(vs_gltf.moving_bones(body)))
    assert carried == len(vs_gltf.moving_bones(body)) and size > 0
    assert 0 < errors.mean() < 0.1


def test_linear_rotation_track_is_slerp_between_keys_and_clamps_outside():
    a = rotations.from_axis_angle(np.array([0.0, 0.0, 1.0]), 0.0)
    b = rotations.from_axis_angle(np.array([0.0, 0.0, 1.0]), np.pi / 2)
    track = vs_gltf.Track(np.array([0.0, 1.0]), vs_gltf.to_xyzw(np.stack([a, b])), "LINEAR")
    got = vs_gltf.from_xyzw(vs_gltf.sample_track(track, np.array([-1.0, 0.25, 2.0]), rotation=True))
    expected = np.stack([a, rotations.from_axis_angle(np.array([0.0, 0.0, 1.0]), np.pi / 8), b])
    np.testing.assert_allclose(rotations.canonical(got), rotations.canonical(expected), atol=1e-12)


def test_ratio_at_equal_error_reads_each_curve_at_the_same_error():
    points = []
    for k, error in enumerate([0.01, 0.03, 0.1, 0.3]):
        points.append(vs_gltf.Point("gltfpack", 16 - k, int(1000 / error ** 0.5), 1.0, error, 2 * error, 0))
        points.append(vs_gltf.Point("fba-dct", 2 ** k, int(400 / error ** 0.5), 1.0, error, 2 * error, 0))
        points.append(vs_gltf.Point("bba-dct", 2 ** k, int(900 / error ** 0.5), 1.0, error, 2 * error, 0))
    rows = vs_gltf.ratios_at_equal_error(points, levels=4)
    assert len(rows) == 4 and rows[0][0] == pytest.approx(0.01) and rows[-1][0] == pytest.approx(0.3)
    for _, best, _, _, ratio in rows:
        assert best == "fba-dct" and ratio == pytest.approx(0.4, abs=0.01)
    # A dominated point (more kbps at more error) does not bend the curve.
    front = vs_gltf.pareto([(0.1, 5.0), (0.2, 6.0), (0.4, 2.0)])
    assert front == [(0.1, 5.0), (0.4, 2.0)] and np.isnan(vs_gltf.kbps_at(front, 0.05))

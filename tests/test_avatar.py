"""The vendored MakeHuman avatar: asset contents, SMS bone transform, skin weights, influence volumes."""
import numpy as np
import pytest

from media import rotations
from kernels.skinning import SkinWeights
from media.avatar import BoneTransform, load_avatar
from media.domain import BODY, HEAD, LEFT_HAND, RIGHT_HAND
from media.errors import SigncastError
from media.influence import InfluenceVolume, affectedness, dominant_agreement, falloff, fit_volumes, influence_weights


def test_avatar_keeps_body_skin_eyes_brows_lashes_and_hair_in_metres(avatar):
    assert avatar.shape_names == ("body", "left_eye", "right_eye", "brows", "eyelashes", "hair")
    assert set(np.unique(avatar.triangle_shape)) == set(range(6))
    # the body group (26,756 triangles from its quads), plus the pieces of the triangles cut at the neckline,
    # cuffs and hairline (each cut triangle becomes three), less the brows' triangles
    body_and_brows = np.isin(avatar.triangle_shape, (0, 3))
    assert 26756 < np.count_nonzero(body_and_brows) < 26756 + 2 * 2000
    assert np.count_nonzero(avatar.triangle_shape == 4) == 2 * (44 + 48) * 2     # the four eyelash helpers' quads
    height = avatar.vertices[:, 1].max() - avatar.vertices[:, 1].min()
    assert 1.55 < height < 1.80                                            # a person, in metres
    assert avatar.triangles.max() < len(avatar.vertices)


def test_hair_brows_and_lashes_are_head_and_follow_head_bones(avatar):
    names = avatar.skeleton.names
    dominant = avatar.weights.dominant_bone()
    for shape in ("brows", "eyelashes", "hair"):
        faces = avatar.triangle_shape == avatar.shape_names.index(shape)
        assert np.all(avatar.triangle_part[faces] == HEAD)
        bones = {names[b] for b in dominant[np.unique(avatar.triangles[faces])]}
        assert "head" in bones or shape == "eyelashes"
        assert not any(b.startswith(("spine", "clavicle", "shoulder", "upperarm")) for b in bones), bones
    hair = np.unique(avatar.triangles[avatar.triangle_shape == 5])
    assert avatar.vertices[hair, 1].min() > 0.63 and avatar.vertices[hair, 1].max() > 0.85     # a cap on the skull


def test_borders_between_skin_and_clothes_are_cut_lines(avatar):
    """The neckline and the cuffs run along cut planes: every vertex of a head triangle at the neckline lies on or
    above the plane (no triangle zigzags across it)."""
    sk = avatar.skeleton
    neck = sk.heads[sk.index("neck01")]
    body = avatar.triangle_shape == 0
    head_faces = body & (avatar.triangle_part == HEAD)
    p = avatar.vertices[avatar.triangles[head_faces]].astype(np.float64)
    level = p[..., 1] - (neck[1] - 0.004 - 0.25 * (p[..., 2] - neck[2]))
    assert level.min() > -1e-5


def test_avatar_parts_follow_the_body(avatar):
    centroid = avatar.vertices[avatar.triangles].mean(axis=1)
    part = avatar.triangle_part
    assert set(np.unique(part)) == {BODY, HEAD, LEFT_HAND, RIGHT_HAND}
    assert centroid[part == HEAD, 1].mean() > 0.6                      # the head is on top
    assert centroid[part == LEFT_HAND, 0].mean() > 0.35               # the avatar's left is +X
    assert centroid[part == RIGHT_HAND, 0].mean() < -0.35
    assert np.count_nonzero(part == LEFT_HAND) == np.count_nonzero(part == RIGHT_HAND)


def test_skeleton_is_ordered_parents_first_with_joints_on_the_mesh(avatar):
    skeleton = avatar.skeleton
    assert len(skeleton) == 163
    assert all(p < b for b, p in enumerate(skeleton.parents))
    lo, hi = avatar.vertices.min(axis=0) - 0.01, avatar.vertices.max(axis=0) + 0.01
    assert np.all((skeleton.heads >= lo) & (skeleton.heads <= hi))
    wrist = skeleton.heads[skeleton.index("wrist.L")]
    elbow = skeleton.heads[skeleton.index("lowerarm01.L")]
    assert 0.2 < np.linalg.norm(wrist - elbow) < 0.32                      # a forearm
    with pytest.raises(SigncastError, match=r"^unknown bone 'tail'$"):
        skeleton.index("tail")


def test_skin_weights_are_normalised_rows(avatar):
    weights = avatar.weights
    assert isinstance(weights, SkinWeights)                                 # the type the kernels take
    assert (weights.indptr.dtype, weights.bones.dtype, weights.values.dtype) == (np.int32, np.int32, np.float32)
    sums = np.add.reduceat(weights.values, weights.indptr[:-1])
    assert np.allclose(sums, 1.0, atol=1e-5)
    assert weights.n_vertices == len(avatar.vertices)
    dominant = weights.dominant_bone()
    assert avatar.skeleton.names[dominant[avatar.triangles[avatar.triangle_part == LEFT_HAND][0, 0]]].endswith(".L")


def test_bone_transform_composes_eq_3_5():
    center = np.array([1.0, 2.0, 3.0])
    rotation = rotations.from_axis_angle([0, 0, 1], np.pi / 2)
    transform = BoneTransform(center=center, rotation=rotation, translation=np.array([0.0, 0.0, 1.0]),
                              scale=np.array([2.0, 1.0, 1.0]))
    m = transform.matrix()
    assert np.allclose(m @ np.append(center, 1), np.append(center + [0, 0, 1], 1))   # the centre stays, then translates
    # A point one unit along +X from the centre is scaled to 2 units, then rotated onto +Y.
    assert np.allclose(m @ np.append(center + [1, 0, 0], 1), np.append(center + [0, 2, 1], 1))
    oriented = BoneTransform(center=np.zeros(3), scale=np.array([2.0, 1.0, 1.0]), scale_orientation=rotation)
    assert np.allclose(oriented.matrix()[:3, :3], np.diag([1.0, 2.0, 1.0]))            # the scale axis turned onto Y


@pytest.mark.parametrize("code,expected", [(-1, 0.125), (0, 0.25), (1, 0.5), (2, np.sin(np.pi / 4)), (3, np.sqrt(0.5)), (4, np.cbrt(0.5))])
def test_six_falloff_functions(code, expected):
    assert falloff(code, np.array([0.5]))[0] == pytest.approx(expected)
    assert falloff(code, np.array([0.0, 1.0])).tolist() == [0.0, 1.0]


def test_influence_volume_zones_and_half_sphere_caps():
    head, tail = np.zeros(3), np.array([0.0, 1.0, 0.0])
    volume = InfluenceVolume(np.array([0.0, 1.0]), np.array([0.1, 0.1]), np.array([0.3, 0.3]), falloff=1)
    points = np.array([[0.05, 0.5, 0], [0.2, 0.5, 0], [0.4, 0.5, 0], [0, -0.2, 0], [0, 1.35, 0], [0.2, -0.2, 0]])
    mu = affectedness(points, head, tail, volume)
    assert mu[0] == 1.0 and mu[2] == 0.0
    assert mu[1] == pytest.approx(0.5)                  # halfway through the ring, linear falloff
    assert mu[3] == pytest.approx(0.5)                  # 0.2 before the head, on the cap
    assert mu[4] == 0.0                                 # 0.35 past the tail: outside the cap
    assert mu[5] == pytest.approx((0.3 - np.hypot(0.2, 0.2)) / 0.2)


def test_influence_volume_weights_agree_with_makehuman(avatar):
    skeleton, reference = avatar.skeleton, avatar.weights
    used = np.zeros(len(skeleton), dtype=bool)
    used[reference.bones] = True
    bones = np.flatnonzero(used & (np.linalg.norm(skeleton.tails - skeleton.heads, axis=1) > 1e-6))
    volumes = fit_volumes(avatar.vertices.astype(np.float64), skeleton, bones)
    computed = influence_weights(avatar.vertices, skeleton, bones, volumes)
    overall = dominant_agreement(computed, reference)
    hands = dominant_agreement(computed, reference, np.isin(avatar.vertex_part(), [LEFT_HAND, RIGHT_HAND]))
    print(f"dominant bone agreement with MakeHuman weights: {overall:.1%} overall, {hands:.1%} on the hands")
    assert overall > 0.5 and hands > 0.75
    assert np.allclose(np.add.reduceat(computed.values, computed.indptr[:-1]), 1.0, atol=1e-5)


def test_missing_or_foreign_avatar_file_is_a_signcast_error(tmp_path):
    with pytest.raises(SigncastError, match=r"^avatar file not found: .*nowhere\.npz$"):
        load_avatar(tmp_path / "nowhere.npz")
    foreign = tmp_path / "foreign.npz"
    np.savez(foreign, vertices=np.zeros((3, 3)))
    with pytest.raises(SigncastError, match=r"^not a signcast avatar file: .*foreign\.npz \(.*bone_names.*\)$"):
        load_avatar(foreign)

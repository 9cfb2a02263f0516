"""MPEG-4 FBA: the BAP table, the avatar's BAP mapping, the predictive and DCT coders, .bap files."""
import numpy as np
import pytest

from comparisons import bap_table
from comparisons import param_coding as pc
from comparisons.bap_file import format_bap, parse_bap
from comparisons.fba_codec import decode_fba, encode_fba
from comparisons.fba_mapping import avatar_bap_map, baps_to_motion, motion_to_baps
from media import rotations
from media.avatar import load_avatar
from media.errors import SigncastError
from media.kinematics import joint_positions
from media.motion import Motion


def smooth_motion(n_frames=40, fps=10.0, seed=0, max_angle=0.6, bones=None):
    """Slerps between a few random poses of the avatar's BAP-carrying bones, plus a root drift."""
    rng = np.random.default_rng(seed)
    names = bones or tuple(b.bone for b in avatar_bap_map().bones)
    keys = rotations.from_axis_angle(rng.normal(size=(4, len(names), 3)), rng.uniform(-max_angle, max_angle, (4, len(names))))
    position = np.linspace(0, 3, n_frames)
    left = np.minimum(position.astype(int), 2)
    t = np.broadcast_to((position - left)[:, None], (n_frames, len(names)))
    q = rotations.slerp(keys[left], keys[left + 1], t)
    translation = np.stack([0.02 * np.sin(position), 0.01 * position, np.zeros(n_frames)], axis=1)
    return Motion(fps, names, q, translation)


def test_bap_table_holds_the_standard_set_groups_and_steps():
    assert len(bap_table.BAPS) == 296
    assert bap_table.bap(34).name == "l_shoulder_abduct" and bap_table.bap(34).group == 6
    assert bap_table.bap(67).step == 256 and bap_table.bap(72).step == 128      # visage|toolkit manual spot checks
    assert bap_table.bap(181).is_translation and bap_table.bap(181).step == 2
    assert [len(g) for g in bap_table.GROUP_MEMBERS[:19]] == [3, 4, 4, 6, 6, 5, 5, 7, 7, 12, 15, 18, 18, 12, 16, 16, 13, 13, 6]
    assert bap_table.bap(187).group == 20 and bap_table.bap(296).group == 24


def test_motion_to_baps_round_trip_keeps_joints_within_one_millimetre():
    skeleton = load_avatar().skeleton
    motion = smooth_motion(max_angle=2.5)
    back = baps_to_motion(motion_to_baps(motion), motion.fps)
    error_mm = 1000 * np.abs(joint_positions(skeleton, motion) - joint_positions(skeleton, back)).max()
    assert error_mm < 1.0


def test_mirrored_poses_give_equal_left_and_right_baps():
    left = avatar_bap_map().bones
    pairs = [(b, next(r for r in left if r.bone == b.bone[:-2] + ".R")) for b in left if b.bone.endswith(".L")]
    rng = np.random.default_rng(3)
    q_left = rotations.from_axis_angle(rng.normal(size=(len(pairs), 3)), rng.uniform(-1, 1, len(pairs)))
    q_right = q_left * np.array([1.0, 1.0, -1.0, -1.0])          # mirror x -> -x
    names = tuple(p[0].bone for p in pairs) + tuple(p[1].bone for p in pairs)
    values = motion_to_baps(Motion(10, names, np.concatenate([q_left, q_right])[None], np.zeros((1, 3))))[0]
    for lb, rb in pairs:
        assert np.all(np.abs(values[np.array(lb.baps) - 1] - values[np.array(rb.baps) - 1]) <= 2), lb.bone


def test_avatar_cannot_express_pelvis_midtarsal_and_unmapped_vertebrae():
    bap_map = avatar_bap_map()
    missing = bap_map.unexpressible_baps()
    assert {1, 2, 3, 20, 21}.issubset(missing)
    assert 32 not in missing and 186 not in missing
    assert "jaw" in bap_map.unmapped_bones()
    assert max(max(b.baps) for b in bap_map.bones) <= 296


def test_motion_rotating_a_face_bone_is_rejected():
    motion = Motion.rest(("jaw",), 2, 10)
    motion.rotations[:, 0] = rotations.from_axis_angle(np.array([1.0, 0, 0]), 0.3)
    with pytest.raises(SigncastError, match="no BAP"):
        motion_to_baps(motion)


@pytest.mark.parametrize("q", [1, 8, 31])
def test_predictive_fba_decodes_within_half_a_step(q):
    values = motion_to_baps(smooth_motion())
    decoded, fps = decode_fba(encode_fba(values, 10, q, "pred"))
    assert fps == 10 and decoded.shape == values.shape
    bound = bap_table.steps() * q // 2
    assert np.all(np.abs(decoded - values) <= bound)


def test_predictive_fba_sends_intra_planes_periodically_and_masks_static_baps():
    values = motion_to_baps(smooth_motion(n_frames=50))
    data = encode_fba(values, 10, 4, "pred", intra_period=20)
    assert data.count(b"\x00\x00\x01\xbb") == 3                    # frames 0, 20, 40
    static = np.zeros_like(values)
    static[:, 37] = 5000                                           # one BAP, held still
    assert len(encode_fba(static, 10, 4, "pred")) < 80          # 2 intra planes + 48 still P planes of 4 bits
    decoded, _ = decode_fba(encode_fba(static, 10, 4, "pred"))
    assert np.array_equal(decoded[:, 37], np.full(len(values), 5120)) and not decoded[:, :37].any()


def test_dct_fba_round_trip_error_is_bounded_and_rate_falls_with_q():
    values = motion_to_baps(smooth_motion(n_frames=37))
    sizes = []
    for q in (1, 4, 16, 31):
        data = encode_fba(values, 10, q, "dct")
        decoded, _ = decode_fba(data)
        sizes.append(len(data))
        assert decoded.shape == values.shape
        dc_step, ac_step = pc.dct_steps(bap_table.steps(), q)
        # orthonormal DCT: a coefficient error of at most step/2 each bounds the sample error
        bound = 0.5 * (dc_step / 4 + 15 * ac_step * np.sqrt(2 / 16)) + 1
        assert np.all(np.abs(decoded - values) <= bound)
    assert sizes == sorted(sizes, reverse=True)


@pytest.mark.parametrize("coding", ["pred", "dct"])
def test_fba_decoder_rejects_truncated_and_damaged_streams(coding):
    data = encode_fba(motion_to_baps(smooth_motion()), 10, 4, coding)
    for bad in (data[:len(data) // 2], data[:-1], b"\x00\x00\x01\xbc" + data[4:], data + b"\x00"):
        with pytest.raises(SigncastError):
            decode_fba(bad)


def test_fba_encoder_rejects_bad_q_and_shapes():
    with pytest.raises(SigncastError):
        encode_fba(np.zeros((3, 296), np.int64), 10, 0)
    with pytest.raises(SigncastError):
        encode_fba(np.zeros((3, 186), np.int64), 10, 1)


def test_bap_file_round_trips_version_3_2_and_reads_3_1():
    values = motion_to_baps(smooth_motion(n_frames=5))
    text = format_bap(values, 10, "letterA")
    back, fps, name = parse_bap(text)
    assert np.array_equal(back, values) and fps == 10 and name == "letterA"
    old = "# version 3.1\n3.1 old 25 2\n" + " ".join(["1"] * 3 + ["0"] * 183) + "\n0 10 -20 30\n" + \
        " ".join(["0"] * 185 + ["1"]) + "\n1 7\n"
    back, fps, _ = parse_bap(old)
    assert back.shape == (2, 296) and fps == 25
    assert back[1, :3].tolist() == [10, -20, 30] and back[1, 185] == 7


@pytest.mark.parametrize("text", ["3.3 x 10 0\n", "3.2 x 10 2\n" + " ".join(["0"] * 296) + "\n0\n",
                                  "3.1 x 10 1\n" + " ".join(["1"] * 186) + "\n0 1 2\n"])
def test_bap_file_reader_rejects_malformed_files(text):
    with pytest.raises(SigncastError):
        parse_bap(text)


def test_real_fingerspelling_maps_to_baps_and_back_within_one_millimetre():
    from media.fingerspelling import letter_motion

    skeleton = load_avatar().skeleton
    motion = letter_motion("ase", "J", 10)
    values = motion_to_baps(motion)
    back = baps_to_motion(values, motion.fps)
    error_mm = 1000 * np.abs(joint_positions(skeleton, motion) - joint_positions(skeleton, back)).max()
    assert error_mm < 1.0
    assert np.any(values[:, 32] != 0) or np.any(values[:, 33] != 0)     # a shoulder flexes

"""MPEG-4 FBA: the BAP table, the avatar's BAP mapping, the predictive and DCT coders, .bap files."""
import inspect
import tracemalloc
import zlib

import numpy as np
import pytest

from comparisons.params import bap_table
from comparisons.params import fba as fba_codec
from comparisons.params import coding as pc
from comparisons.params.bap_file import format_bap, parse_bap
from comparisons.params.bits import BitWriter
from comparisons.params.fba import decode_fba, encode_fba, write_group_masks, write_plane_header
from comparisons.params.fba_mapping import avatar_bap_map, baps_to_motion, motion_to_baps
from media import rotations
from media.avatar import load_avatar
from media.errors import SigncastError
from media.kinematics import joint_positions
from media.motion import Motion
from motion_samples import smooth_motion


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
    result = decode_fba(encode_fba(values, 10, q, "pred"))
    decoded, fps = result.baps, result.fps
    assert result.faps is None and result.face_frames is None
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
    decoded = decode_fba(encode_fba(static, 10, 4, "pred")).baps
    assert np.array_equal(decoded[:, 37], np.full(len(values), 5120)) and not decoded[:, :37].any()


def test_dct_fba_round_trip_error_is_bounded_and_rate_falls_with_q():
    values = motion_to_baps(smooth_motion(n_frames=37))
    sizes = []
    for q in (1, 4, 16, 31):
        data = encode_fba(values, 10, q, "dct")
        decoded = decode_fba(data).baps
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


@pytest.mark.parametrize("q", [1, 31])
def test_predictive_fba_codes_angles_crossing_pi_and_large_translation_jumps_within_half_a_step(q):
    values = np.zeros((8, 296), np.int64)
    values[:, 186 - 1] = [314000, 314100, -314100, -314000, -313000, 313000, 314159, -314159]   # root tilt, step 64
    values[:, 32 - 1] = [0, 300000, -300000, 0, 0, 0, 0, 0]                                    # shoulder, step 64
    values[:, 181 - 1] = [0, 15000, -15000, 0, 0, 0, 0, 0]                                     # root, mm, step 2
    decoded = decode_fba(encode_fba(values, 10, q, "pred")).baps
    assert np.all(np.abs(decoded - values) <= bap_table.steps() * q // 2)


@pytest.mark.parametrize("coding", ["pred", "dct"])
def test_fba_encoder_rejects_a_value_its_stream_cannot_carry(coding):
    values = np.zeros((3, 296), np.int64)
    values[1, 181 - 1] = 16000 if coding == "pred" else 10 ** 7     # pred: 16 m > an intra plane's 15.24 m at Q=1;
                                                                     # dct: 10 km, beyond the largest VLC category
    with pytest.raises(SigncastError, match="BAP 181" if coding == "pred" else "DCT level"):
        encode_fba(values, 10, 1, coding)
    values[1, 181 - 1] = np.iinfo(np.int64).min                       # would overflow the level arithmetic
    with pytest.raises(SigncastError, match="beyond"):
        encode_fba(values, 10, 1, coding)


def test_fba_decoder_refuses_a_stream_longer_than_its_frame_limit_before_allocating_the_frames():
    # a valid DCT stream of 400,000 still frames (25,000 empty 16-frame segments, ~15.6 kB)
    writer = BitWriter()
    writer.start_code(fba_codec.OBJECT_START_CODE)
    writer.start_code(fba_codec.PLANE_START_CODE)
    write_plane_header(writer, True, 25)
    writer.write(1, 5)
    write_group_masks(writer, np.zeros(296, bool))
    writer.write_bit(0)
    writer.write_bit(fba_codec.DCT)
    writer.write_bit(0)
    for k in range(1, 25_000):
        write_plane_header(writer, False, 25)
        writer.write_bit(int(k == 24_999))
        if k == 24_999:
            writer.write(15, 4)
    writer.start_code(fba_codec.END_CODE)
    data = writer.getvalue()
    data += zlib.crc32(data).to_bytes(4, "big")
    assert 15_000 < len(data) < 16_000
    tracemalloc.start()
    try:
        with pytest.raises(SigncastError, match="more than 2000 frames"):
            decode_fba(data, max_frames=2000)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < 4 * 2000 * 296 * 8                     # memory follows the limit, not the 400,000 frames
    assert inspect.signature(decode_fba).parameters["max_frames"].default == fba_codec.MAX_FRAMES < 400_000


def test_fba_frame_limit_allows_hours_of_signing_in_under_a_gigabyte_and_the_encoder_keeps_to_it():
    assert fba_codec.MAX_FRAMES >= 3600 * 60                         # an hour at 60 fps, two at 30
    assert fba_codec.MAX_FRAMES * 296 * 8 < 2 ** 29                  # decoded int64 values < 512 MiB
    limit = 50
    values = motion_to_baps(smooth_motion(n_frames=limit))
    decoded = decode_fba(encode_fba(values, 10, 4, "dct"), max_frames=limit).baps
    assert decoded.shape == (limit, 296)
    with pytest.raises(SigncastError, match=f"more than {limit - 1} frames"):
        decode_fba(encode_fba(values, 10, 4, "pred"), max_frames=limit - 1)
    too_long = np.zeros((fba_codec.MAX_FRAMES + 1, 296), np.int64)   # calloc'd pages, never touched
    for coding in ("pred", "dct"):
        with pytest.raises(SigncastError, match=f"at most {fba_codec.MAX_FRAMES} frames"):
            encode_fba(too_long, 25, 4, coding)


def test_values_that_jump_once_and_hold_get_a_one_frame_intra_plane_and_cost_less(monkeypatch):
    rng = np.random.default_rng(5)
    values = np.zeros((40, bap_table.N_BAPS), dtype=np.int64)
    values[:, 0:3] = np.cumsum(rng.integers(-300, 300, size=(40, 3)), axis=0)     # moving BAPs
    values[:, 40:60] = rng.integers(-20000, 20000, size=20)                        # a pose set once, then held
    settled = encode_fba(values, 25.0, 2)
    monkeypatch.setattr(fba_codec, "SETTLING_PARAMETERS", 10**6)                          # the rule off
    one_period = encode_fba(values, 25.0, 2)
    assert len(settled) < len(one_period)
    for data in (settled, one_period):
        decoded = decode_fba(data).baps
        steps = bap_table.steps() * 2
        assert np.all(np.abs(decoded - values) <= steps // 2 + 1)

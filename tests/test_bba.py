"""MPEG-4 BBA: stream round trips, bone masks, resynchronisation, muscles, key frames, XML form."""
from pathlib import Path

import numpy as np
import pytest

from comparisons.params import bba
from comparisons.params import keyframes as kf
from comparisons.params.bba_xml import from_xml, to_xml
from comparisons.params.bits import BitWriter, find_start_codes
from media import rotations
from media.avatar import load_avatar
from media.errors import SigncastError
from media.kinematics import joint_positions
from media.motion import Motion
from motion_samples import smooth_motion

ARM = ("clavicle.R", "shoulder01.R", "upperarm01.R", "upperarm02.R", "lowerarm01.R", "lowerarm02.R", "wrist.R",
       "finger2-1.R", "finger2-2.R", "finger2-3.R", "finger1-1.R")


def _values(stream):
    return [{b: list(v) for b, v in f.values.items()} for f in stream.frames]


@pytest.mark.parametrize("coding", ["pred", "dct"])
def test_bba_decodes_what_it_encodes_up_to_quantisation(coding):
    motion = smooth_motion(n_frames=37, bones=ARM, max_angle=1.0)
    stream = bba.motion_to_stream(motion, 2, coding)
    decoded, lost = bba.read_stream(bba.write_stream(stream))
    assert lost == [] and len(decoded.frames) == 37
    skeleton = load_avatar().skeleton
    for original, back in zip(stream.frames, decoded.frames):
        assert original.bones == back.bones
        for bone, values in original.values.items():
            step = bba.step_of(bone, 3, skeleton) * 2
            limit = step / 2 if coding == "pred" else 2.5 * step
            assert np.all(np.abs(np.subtract(values, back.values[bone])) <= limit)
    error_mm = 1000 * np.abs(joint_positions(skeleton, motion) - joint_positions(skeleton, bba.stream_to_motion(decoded))).max()
    assert error_mm < 6.0          # Q=2: steps of 1.3-2.6 mrad per angle along an 11-bone chain


def test_bone_mask_costs_two_bits_for_one_angle_and_21_for_everything():
    one = BitWriter()
    bba._write_bone_mask(one, 1 << 3, 1 << 3)
    full = BitWriter()
    bba._write_bone_mask(full, 0xFFFF, 0xFFFF)
    assert (one.n_bits, full.n_bits) == (2, 21)


def test_rotation_orders_follow_shoemake_packing():
    assert bba.ORDER_NAMES[0] == "XYZs" and bba.ORDER_NAMES[1] == "ZYXr" and bba.ORDER_NAMES[2] == "XYXs"
    assert len(set(bba.ORDER_NAMES)) == 24
    q = rotations.from_axis_angle(np.array([0.3, -0.5, 0.8]), 1.1)
    for order in bba.ORDER_NAMES:
        assert rotations.angle_between(rotations.from_euler(rotations.to_euler(q, order), order), q) < 1e-6


def _frame_chunks(data):
    codes = find_start_codes(data)
    return [(p, codes[k + 1][0]) for k, (p, c) in enumerate(codes[:-1]) if c == bba.FRAME_START_CODE]


def test_bba_stream_resyncs_after_damaged_frame():
    motion = smooth_motion(n_frames=40, bones=ARM)
    stream = bba.motion_to_stream(motion, 4, "pred", intra_period=10)
    data = bba.write_stream(stream)
    clean, _ = bba.read_stream(data)
    start, end = _frame_chunks(data)[5]
    damaged = data[:start + 6] + data[end - 1:]                      # frame 5 cut short by a server
    with pytest.raises(SigncastError):
        bba.read_stream(damaged)
    decoded, lost = bba.read_stream(damaged, resilient=True)
    assert lost == [5, 6, 7, 8, 9]                                    # P frames until the next intra frame
    assert len(decoded.frames) == 40
    assert _values(decoded)[10:] == _values(clean)[10:]
    assert _values(decoded)[:5] == _values(clean)[:5]
    assert _values(decoded)[5] == _values(clean)[4]                  # concealed: last good frame held


def test_bba_decoder_rejects_truncated_streams():
    data = bba.write_stream(bba.motion_to_stream(smooth_motion(n_frames=12, bones=ARM), 4, "pred"))
    for bad in (data[:-3], data[:len(data) // 2], data[:20]):
        with pytest.raises(SigncastError):
            bba.read_stream(bad)


def test_weak_terminal_skips_muscle_data_after_its_start_code():
    stream = bba.motion_to_stream(smooth_motion(n_frames=6, bones=ARM), 4, "pred")
    stream.frames[2].muscles = [bba.MuscleUpdate(7, 2, 1, [1, 0, 0, 1, 0, 1, 0, 0, 1], [120, -40, 33, 9])]
    data = bba.write_stream(stream)
    assert data.count(b"\x00\x00\x01\xd2") == 1
    full, _ = bba.read_stream(data)
    light, _ = bba.read_stream(data, skip_muscles=True)
    assert full.frames[2].muscles[0].values == [120, -40, 33, 9]
    assert light.frames[2].muscles == [] and _values(light) == _values(full)


def test_key_frame_analyser_drops_frames_interpolation_recovers():
    q0 = rotations.from_axis_angle(np.array([1.0, 0, 0]), 0.0)
    q1 = rotations.from_axis_angle(np.array([1.0, 0.2, 0]), 1.2)
    t = np.linspace(0, 1, 12)
    linear = Motion(10, ("upperarm01.R",), rotations.slerp(np.broadcast_to(q0, (12, 4)), np.broadcast_to(q1, (12, 4)), t)[:, None],
                    np.zeros((12, 3)))
    assert kf.key_frames(linear, 0.01).tolist() == [0, 11]
    motion = smooth_motion(n_frames=30, bones=ARM)
    keys = kf.key_frames(motion, 0.05)
    assert keys[0] == 0 and keys[-1] == 29 and len(keys) < 30
    plain = bba.write_stream(bba.motion_to_stream(motion, 4, "pred"))
    keyed_stream = bba.motion_to_stream(motion, 4, "pred", keyframes=True, threshold_rad=0.05)
    keyed = bba.write_stream(keyed_stream)
    assert len(keyed) < len(plain)
    decoded = bba.stream_to_motion(bba.read_stream(keyed)[0])
    assert decoded.n_frames == 30
    shared = [n for n in decoded.bone_names if n in motion.bone_names]
    error = rotations.angle_between(decoded.rotations[:, [decoded.bone_names.index(n) for n in shared]],
                                    motion.rotations[:, [motion.bone_names.index(n) for n in shared]])
    assert error.max() < 0.05 + 0.02          # threshold + quantisation


@pytest.mark.parametrize("coding,keyframes", [("pred", False), ("dct", False), ("pred", True)])
def test_bba_binary_to_xml_to_binary_is_identical(coding, keyframes):
    motion = smooth_motion(n_frames=21, bones=ARM)
    data = bba.write_stream(bba.motion_to_stream(motion, 8, coding, keyframes=keyframes))
    decoded, _ = bba.read_stream(data)
    text = to_xml(decoded)
    assert "urn:mpeg:mpeg4:bba:schema:2002" in text and "BoneAnimationMask" in text
    assert bba.write_stream(from_xml(text)) == data


def test_bba_xml_reader_rejects_inconsistent_documents():
    motion = smooth_motion(n_frames=3, bones=ARM)
    text = to_xml(bba.read_stream(bba.write_stream(bba.motion_to_stream(motion, 8, "pred")))[0])
    for bad in (text.replace('NSBB="', 'NSBB="9'), text.replace("RotationOnAxis1=", "RotationOnAxis9="),
                text[:len(text) // 2], text.replace("signcast:", "other:")):
        with pytest.raises(SigncastError):
            from_xml(bad)


def test_bba_rejects_bad_parameters():
    motion = smooth_motion(n_frames=3, bones=ARM)
    with pytest.raises(SigncastError):
        bba.motion_to_stream(motion, 32, "pred")
    with pytest.raises(SigncastError):
        bba.motion_to_stream(motion, 4, "dct", keyframes=True)


def test_bba_stream_resyncs_after_a_bit_error_inside_a_frame():
    motion = smooth_motion(n_frames=30, bones=ARM)
    data = bba.write_stream(bba.motion_to_stream(motion, 4, "pred", intra_period=10))
    clean, _ = bba.read_stream(data)
    start, end = _frame_chunks(data)[13]
    damaged = bytearray(data)
    damaged[(start + end) // 2] ^= 0x10
    decoded, lost = bba.read_stream(bytes(damaged), resilient=True)
    assert lost == [13, 14, 15, 16, 17, 18, 19]
    assert _values(decoded)[20:] == _values(clean)[20:] and _values(decoded)[:13] == _values(clean)[:13]


# ------------------------------------------------------------------ angles across +-pi, no clipping

def test_bba_pred_follows_an_angle_turning_through_pi():
    turns = np.array([3.10, 3.15, 3.20, 3.25])                       # Euler X: 3.10, then -3.13 ... (wrapped)
    q = rotations.from_axis_angle(np.tile([1.0, 0, 0], (4, 1)), turns)[:, None]
    motion = Motion(25.0, ("lowerarm01.R",), q, np.zeros((4, 3)))
    stream = bba.motion_to_stream(motion, 4, "pred")
    decoded, lost = bba.read_stream(bba.write_stream(stream))
    sent = np.array([f.values[64][0] for f in stream.frames])
    back = np.array([f.values[64][0] for f in decoded.frames])
    assert lost == [] and np.all(np.abs(bba.fold_angles(back - sent)) <= 128)      # half of step 64 x Q 4
    error = rotations.angle_between(bba.stream_to_motion(decoded).rotations[:, -1], q[:, 0])
    assert error.max() < 0.003


def test_bba_pred_decoded_stream_re_encodes_to_the_same_bytes_when_angles_turn_half_a_circle():
    turns = np.arange(6) * 3.1414                                     # nearly pi per frame: folded changes near +-pi
    q = rotations.from_axis_angle(np.tile([1.0, 0, 0], (6, 1)), turns)[:, None]
    data = bba.write_stream(bba.motion_to_stream(Motion(25.0, ("lowerarm01.R",), q, np.zeros((6, 3))), 1, "pred"))
    assert bba.write_stream(bba.read_stream(data)[0]) == data


def _root_motion(x_metres):
    n = len(x_metres)
    translation = np.zeros((n, 3))
    translation[:, 0] = x_metres
    return Motion(25.0, ("root",), np.tile([1.0, 0, 0, 0], (n, 1, 1)), translation)


def test_bba_pred_sends_an_intra_frame_where_a_change_does_not_fit_the_p_alphabet():
    stream = bba.motion_to_stream(_root_motion([-10.0, -10.0, 10.0, 10.0]), 1, "pred")   # a 20 m jump
    decoded, _ = bba.read_stream(bba.write_stream(stream))
    root = bba.load_avatar().skeleton.index("root")
    assert [f.values[root][0] for f in decoded.frames] == [-10000, -10000, 10000, 10000]


def test_bba_pred_refuses_a_value_its_intra_alphabet_cannot_hold():
    stream = bba.motion_to_stream(_root_motion([0.0, 16.0]), 1, "pred")                 # > 7620 levels x 2 mm
    with pytest.raises(SigncastError, match="cannot be sent"):
        bba.write_stream(stream)


def test_bone_values_beyond_20_bits_are_refused_by_the_encoder_and_the_decoder():
    stream = bba.motion_to_stream(_root_motion([0.0, 1.0]), 4, "pred")
    root = bba.load_avatar().skeleton.index("root")
    stream.frames[1].values[root][0] = bba.VALUE_LIMIT + 1
    with pytest.raises(SigncastError, match="beyond"):
        bba.write_stream(stream)
    found = Path(__file__).resolve().parent / "fuzz" / "corpus" / "bba-resilient" / "found-value-beyond-20-bits.bba"
    data = found.read_bytes()                       # a fuzzer's input: a P frame decodes to 596944 (1e-5 rad)
    with pytest.raises(SigncastError):
        bba.read_stream(data)
    decoded, lost = bba.read_stream(data, resilient=True)
    assert lost and all(abs(v) <= bba.VALUE_LIMIT for f in decoded.frames for vs in f.values.values() for v in vs)
    from_xml(to_xml(decoded))


def test_asl_letters_in_a_proper_euler_order_decode_within_a_few_milliradians():
    from media.fingerspelling import letter_motion
    motion = letter_motion("ase", "H", 10)                            # 1.39 rad off when angles were clipped
    decoded = bba.stream_to_motion(bba.read_stream(bba.write_stream(bba.motion_to_stream(motion, 1, "pred", rotation_order=2)))[0])
    index = [decoded.bone_names.index(n) for n in motion.bone_names if n in decoded.bone_names]
    shared = [motion.bone_names.index(n) for n in motion.bone_names if n in decoded.bone_names]
    assert rotations.angle_between(decoded.rotations[:, index], motion.rotations[:, shared]).max() < 0.01


# ------------------------------------------------------------------ recovery keeps frame timing

def _resilient_case(coding="pred", intra_period=10, keyframes=False, n_frames=40, header_period=0):
    motion = smooth_motion(n_frames=n_frames, bones=ARM)
    stream = bba.motion_to_stream(motion, 4, coding, intra_period=intra_period, keyframes=keyframes,
                                  threshold_rad=0.05 if keyframes else None, header_period=header_period)
    data = bba.write_stream(stream)
    return data, bba.read_stream(data)[0]


def test_bba_resilient_decoder_keeps_timing_after_a_damaged_start_code():
    data, clean = _resilient_case()
    start, _ = _frame_chunks(data)[5]
    damaged = data[:start + 3] + bytes([bba.END_CODE]) + data[start + 4:]          # frame 5's D1 -> D3
    decoded, lost = bba.read_stream(damaged, resilient=True)
    assert len(decoded.frames) == 40 and lost == [5, 6, 7, 8, 9]
    assert _values(decoded)[:5] == _values(clean)[:5] and _values(decoded)[10:] == _values(clean)[10:]
    assert all(v == _values(clean)[4] for v in _values(decoded)[5:10])           # frame 4 held


def test_bba_resilient_decoder_is_exact_from_the_next_intra_frame_on():
    n = 30
    bend = np.concatenate([np.linspace(0.0, 1.0, 10), np.full(n - 10, 1.0)])   # the elbow stops at frame 9
    elbow = rotations.from_axis_angle(np.tile([1.0, 0, 0], (n, 1)), bend)
    wrist = rotations.from_axis_angle(np.tile([0, 0, 1.0], (n, 1)), np.linspace(0.0, 1.5, n))
    motion = Motion(25.0, ("lowerarm01.R", "wrist.R"), np.stack([elbow, wrist], axis=1), np.zeros((n, 3)))
    data = bba.write_stream(bba.motion_to_stream(motion, 4, "pred", intra_period=10))
    start, end = _frame_chunks(data)[5]
    decoded, lost = bba.read_stream(data[:start] + data[end:], resilient=True)
    clean = bba.stream_to_motion(bba.read_stream(data)[0])
    assert lost == [5, 6, 7, 8, 9]
    assert np.array_equal(bba.stream_to_motion(decoded).rotations[10:], clean.rotations[10:])


def test_bba_resilient_decoder_keeps_timing_after_a_deleted_frame():
    data, clean = _resilient_case()
    start, end = _frame_chunks(data)[5]
    decoded, lost = bba.read_stream(data[:start] + data[end:], resilient=True)
    assert len(decoded.frames) == 40 and lost == [5, 6, 7, 8, 9]
    assert _values(decoded)[10:] == _values(clean)[10:]
    with pytest.raises(SigncastError):
        bba.read_stream(data[:start] + data[end:])


def test_bba_resilient_decoder_keeps_timing_after_a_lost_dct_segment():
    data, clean = _resilient_case("dct", intra_period=1, n_frames=45)
    start, end = _frame_chunks(data)[1]
    decoded, lost = bba.read_stream(data[:start] + data[end:], resilient=True)
    assert len(decoded.frames) == 45 and lost == list(range(16, 32))
    assert _values(decoded)[32:] == _values(clean)[32:] and _values(decoded)[:16] == _values(clean)[:16]


def test_bba_resilient_decoder_keeps_key_frame_timing_after_a_lost_key_frame():
    data, clean = _resilient_case(keyframes=True, intra_period=2, n_frames=60)
    clean_motion = bba.stream_to_motion(clean)
    numbers = bba.display_numbers(clean.frames)                                  # key frames 0, 20, 37, 40, 59
    start, end = _frame_chunks(data)[2]                                          # intra key 2 and P key 3 lost
    decoded, lost = bba.read_stream(data[:start] + data[end:], resilient=True)
    motion = bba.stream_to_motion(decoded)
    assert len(numbers) == 5 and motion.n_frames == clean_motion.n_frames == 60
    assert lost == list(range(numbers[1] + 1, numbers[4]))
    good = [t for t in range(60) if t not in lost]
    assert np.array_equal(motion.rotations[good], clean_motion.rotations[good])


def test_bba_resilient_decoder_conceals_a_lost_last_frame_and_a_damaged_end_code():
    data, clean = _resilient_case()
    start, _ = _frame_chunks(data)[-1]
    damaged = bytearray(data)
    damaged[start + 8] ^= 0x21                                                   # inside the last frame
    damaged[-2] ^= 0x01                                                          # the end code's 0x01
    decoded, lost = bba.read_stream(bytes(damaged), resilient=True)
    assert len(decoded.frames) == 40 and lost == [39]
    assert _values(decoded)[:39] == _values(clean)[:39] and _values(decoded)[39] == _values(clean)[38]


def test_bba_resilient_decoder_recovers_a_damaged_header_from_its_copy():
    data, clean = _resilient_case(header_period=1)
    assert data.count(b"\x00\x00\x01\xd0") == 4                                   # the header, then at intra 10, 20, 30
    damaged = bytearray(data)
    damaged[12] ^= 0x08
    decoded, lost = bba.read_stream(bytes(damaged), resilient=True)
    assert lost == [] and _values(decoded) == _values(clean) and decoded.header == clean.header
    with pytest.raises(SigncastError):
        bba.read_stream(bytes(damaged))
    plain, _ = _resilient_case()
    damaged = bytearray(plain)
    damaged[12] ^= 0x08
    with pytest.raises(SigncastError, match="header"):
        bba.read_stream(bytes(damaged), resilient=True)


def test_bba_header_copies_round_trip_through_xml():
    data, clean = _resilient_case(header_period=2)
    assert bba.write_stream(from_xml(to_xml(clean))) == data


# ------------------------------------------------------------------ memory bound

def _header_only_stream(n_frames, bones, animatable):
    writer = BitWriter()
    bba._write_header(writer, bba.BBAHeader("big", 25.0), n_frames, bones, animatable, None, False,
                      load_avatar().skeleton)
    writer.start_code(bba.END_CODE)
    return writer.getvalue()


def test_bba_decoder_refuses_a_stream_above_its_size_limit_before_decoding_frames():
    arm = [load_avatar().skeleton.index(n) for n in ARM]
    n_frames = bba.MAX_DECODED_VALUES // (3 * len(arm)) + 1
    data = _header_only_stream(n_frames, arm, {b: 0b111000 for b in arm})
    for resilient in (False, True):
        with pytest.raises(SigncastError, match="limit"):
            bba.read_stream(data, resilient=resilient)
    # one frame fewer is inside the limit: the same header is read, and the missing frames are the error
    with pytest.raises(SigncastError, match="of its"):
        bba.read_stream(_header_only_stream(n_frames - 1, arm, {b: 0b111000 for b in arm}))


def test_bba_encoder_and_motion_glue_refuse_streams_above_the_size_limit():
    bones = range(len(load_avatar().skeleton))                                   # every bone, three angles
    n_keys = bba.MAX_DECODED_VALUES // (32 * 3 * len(bones)) + 1                 # 32 display frames each
    frames = [bba.BBAFrame(0 if k == 0 else 31, {b: 0b111000 for b in bones}, {b: [0, 0, 0] for b in bones})
              for k in range(n_keys + 1)]
    stream = bba.BBAStream(bba.BBAHeader("big", 25.0), frames)
    with pytest.raises(SigncastError, match="limit"):
        bba.write_stream(stream)
    with pytest.raises(SigncastError, match="limit"):
        bba.stream_to_motion(stream)

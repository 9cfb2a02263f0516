"""MPEG-4 BBA: stream round trips, bone masks, resynchronisation, muscles, key frames, XML form."""
import numpy as np
import pytest

from comparisons import bba_codec as bba
from comparisons import keyframes as kf
from comparisons.bba_xml import from_xml, to_xml
from comparisons.bitstream import BitWriter, find_start_codes
from media import rotations
from media.avatar import load_avatar
from media.errors import SigncastError
from media.kinematics import joint_positions
from media.motion import Motion
from tests.test_fba import smooth_motion

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

"""The BBA decoder's fast paths against the plain code they replace: sparse predicted models
(comparisons/params/bba_units.py), the header's one-call reader (comparisons/params/bba_header.py) and the range-field
reader (comparisons/params/frames.py) give the same integers; the held-table Euler conversion
(media.rotations.from_euler_table) and the batched key-frame expansion (keyframes.expand, regenerate) give scipy's
/ media.rotations.slerp's rotations within 1e-12 per quaternion component (SLERP_TOLERANCE)."""
from __future__ import annotations

import numpy as np
import pytest

from comparisons.params import bap_table
from comparisons.params import bba as bba_codec
from comparisons.params import keyframes as kf
from comparisons.params.bits import BitReader, BitWriter
from comparisons.params import arithmetic as entropy_coding
from comparisons.params import frames as pf
from media import rotations
from media.fingerspelling import letter_motion
from media.errors import SigncastError
from media.motion import Motion


def _per_gap_expand(previous_q, previous_t, key_q, key_t, kfi: int):
    """keyframes.expand as it was, one gap per call."""
    x = np.arange(1, kfi + 1) / (kfi + 1)
    q0 = np.broadcast_to(previous_q, (kfi,) + previous_q.shape)
    q1 = np.broadcast_to(key_q, q0.shape)
    q = rotations.slerp(q0, q1, np.broadcast_to(x[:, None], q0.shape[:2]))
    t = (1 - x)[:, None] * previous_t + x[:, None] * key_t
    return q, t


SLERP_TOLERANCE = 1e-12


def _check_expand(previous_q, previous_t, key_q, key_t, gaps) -> None:
    q, t = kf.expand(previous_q, previous_t, key_q, key_t, np.array(gaps, dtype=np.int64))
    parts = [_per_gap_expand(previous_q[g], previous_t[g], key_q[g], key_t[g], gap) for g, gap in enumerate(gaps)]
    np.testing.assert_allclose(q, np.concatenate([p[0] for p in parts]), rtol=0, atol=SLERP_TOLERANCE)
    assert np.array_equal(t, np.concatenate([p[1] for p in parts]))


@pytest.mark.parametrize("fps", [10.0, 25.0])
def test_batched_expand_is_the_per_gap_expansion_on_real_key_frames(fps):
    for letter in "ABCDEFGHIJKLMN":
        motion = letter_motion("ase", letter, fps)
        keys = kf.key_frames(motion, kf.default_threshold_rad(8))
        gaps = (np.diff(keys) - 1).tolist()
        if not any(gaps):
            continue
        r, t = motion.rotations, motion.root_translation
        _check_expand(r[keys[:-1]], t[keys[:-1]], r[keys[1:]], t[keys[1:]], gaps)


def test_batched_expand_on_long_gaps_opposite_signs_and_equal_rotations():
    rng = np.random.default_rng(3)
    n_gaps, n_bones = 12, 81
    q0 = rotations.normalize(rng.normal(size=(n_gaps, n_bones, 4)))
    q1 = rotations.normalize(q0 + rng.normal(scale=0.3, size=q0.shape))
    q1[:, ::3] *= -1                                          # the shorter arc through -q1
    q1[:, 1::7] = q0[:, 1::7]                                 # sin(alpha) ~ 0: the linear fallback
    gaps = [31, 1, 2, 0, 30, 5, 31, 3, 17, 1, 8, 29]
    _check_expand(q0, rng.normal(size=(n_gaps, 3)), q1, rng.normal(size=(n_gaps, 3)), gaps)


@pytest.mark.parametrize("order", range(24))
def test_held_table_euler_conversion_is_scipys_from_euler(order):
    rng = np.random.default_rng(order)
    n_frames, n_rotated = 40, 9
    table = rng.integers(-400000, 400000, size=(n_frames, 3 * n_rotated + 3)).astype(np.float64)
    table[rng.random(table.shape) < 0.4] = 0.0
    table[rng.random(table.shape) < 0.05] = -0.0                  # sin(-0) = -0: the sign must survive
    held = rng.random(n_frames) < 0.5
    for f in np.flatnonzero(held[1:]) + 1:                    # held values: a frame repeating the one before
        table[f, : 3 * n_rotated : 2] = table[f - 1, : 3 * n_rotated : 2]
    name = bba_codec.ORDER_NAMES[order]
    got = rotations.from_euler_table(table, n_rotated, bap_table.ROTATION_UNIT_RAD, name)
    angles = (table[:, :3 * n_rotated] * bap_table.ROTATION_UNIT_RAD).reshape(n_frames, n_rotated, 3)
    expected = rotations.from_euler(angles, name)                 # scipy's from_euler, w >= 0
    assert np.all(got[..., 0] >= 0)
    # the same rotation (at w = 0, q and -q are both w >= 0)
    assert np.max(np.abs(1.0 - np.abs(np.sum(got * expected, axis=-1)))) < SLERP_TOLERANCE
    np.testing.assert_allclose(got[np.abs(expected[..., 0]) > 1e-6], expected[np.abs(expected[..., 0]) > 1e-6],
                               rtol=0, atol=SLERP_TOLERANCE)


def _range_fields_bit_by_bit(data, end_bit, state, fields, n_bits: int) -> int:
    """param_frames.read_range_fields as it was: every bit through entropy_coding.get_bit on the state array."""
    for r in range(fields.shape[0]):
        for j in range(fields.shape[1]):
            if j % 4 == 0:
                marker = entropy_coding.get_bit(data, end_bit, state, False)
                if marker < 0:
                    return pf.END_OF_DATA
                if marker != 1:
                    return pf.MISSING_MARKER
            value = entropy_coding.get_bits(data, end_bit, state, n_bits)
            if value < 0:
                return pf.END_OF_DATA
            fields[r, j] = value
    return 0


@pytest.mark.parametrize("seed", range(4))
def test_range_field_reader_reads_what_the_bit_by_bit_reader_reads(seed):
    """Fields with long zero runs (emulation-prevention bits inside them), then truncated and with a marker
    bit flipped: param_frames.read_range_fields (locals, fields at once) gives the same fields, statuses and
    reader state as reading every bit through the state array."""
    rng = np.random.default_rng(seed)
    fields = rng.integers(0, 128, size=(4, 61))
    fields[:, rng.random(61) < 0.5] = 0
    writer = BitWriter()
    writer.write(0, 5)
    pf.write_range_fields(writer.buffer, writer.state, fields, 7)
    writer.write(1, 1)
    data = writer.getvalue()
    cases = [(data, 8 * len(data)), (data, 8 * len(data) // 2)]
    flipped = bytearray(data)
    flipped[len(data) // 3] ^= 0xFF
    cases.append((bytes(flipped), 8 * len(data)))
    for stream, end_bit in cases:
        reader = BitReader(stream)
        array = reader.array
        expected_fields, got_fields = np.zeros((4, 61), dtype=np.int64), np.zeros((4, 61), dtype=np.int64)
        expected_state, got_state = np.array([5, 0, 0]), np.array([5, 0, 0])
        expected = _range_fields_bit_by_bit(array, end_bit, expected_state, expected_fields, 7)
        got = pf.read_range_fields(array, end_bit, got_state, got_fields, 7)
        assert got == expected
        if expected == 0:
            assert np.array_equal(got_fields, fields)
            assert np.array_equal(got_fields, expected_fields)
            assert got_state[:2].tolist() == expected_state[:2].tolist()


def _noisy_long_motion(letters: str, seed: int) -> Motion:
    """Letters one after the other, every rotation jittered (many distinct predicted levels per value)."""
    parts = [letter_motion("ase", letter, 25.0) for letter in letters]
    quaternions = np.concatenate([p.rotations for p in parts])
    noise = np.random.default_rng(seed).normal(scale=0.02, size=quaternions.shape)
    return Motion(25.0, parts[0].bone_names, rotations.normalize(quaternions + noise),
                  np.concatenate([p.root_translation for p in parts]))


@pytest.mark.parametrize("q", [1, 8])
def test_sparse_models_filling_up_decode_what_the_unit_by_unit_reader_decodes(avatar, q):
    """A value coding more distinct levels than a sparse model holds (SPARSE_CAPACITY) after an intra unit
    (intra period 63): the whole-stream kernel moves its models to the Fenwick bank and still decodes the
    unit-by-unit reader's values."""
    from comparisons.params.bba_units import SPARSE_CAPACITY

    data = bba_codec.write_stream(bba_codec.motion_to_stream(_noisy_long_motion("ABC", q), q, "pred", intra_period=63,
                                                             skeleton=avatar.skeleton), avatar.skeleton)
    fast = bba_codec._read_uniform(data)
    assert fast is not None
    _, records, lost = bba_codec._read_units(data, False, False)
    assert lost == []
    rows = np.concatenate([unit.rows for unit in records])
    assert np.array_equal(fast[2], rows)
    deltas = np.diff(rows[:63], axis=0)                 # the levels of the first intra period's predicted units
    assert max(len(np.unique(deltas[:, p])) for p in range(deltas.shape[1])) > SPARSE_CAPACITY
    decoded = bba_codec.decode_motion(data, avatar.skeleton)
    expected = bba_codec.stream_to_motion(bba_codec.read_stream(data)[0], avatar.skeleton)
    assert decoded.rotations.tobytes() == expected.rotations.tobytes()
    assert decoded.root_translation.tobytes() == expected.root_translation.tobytes()


@pytest.mark.parametrize("codec", ["bba-pred", "bba-dct", "bba-key"])
def test_decode_motion_is_the_stream_reader_motion(avatar, codec):
    from comparisons.params.codecs import get_codec

    for letter, q, fps in (("B", 1, 25.0), ("F", 31, 10.0), ("H", 8, 50.0)):
        data = get_codec(codec).encode(letter_motion("ase", letter, fps), q)
        decoded = bba_codec.decode_motion(data, avatar.skeleton)
        expected = bba_codec.stream_to_motion(bba_codec.read_stream(data)[0], avatar.skeleton)
        assert decoded.n_frames == expected.n_frames
        assert decoded.rotations.tobytes() == expected.rotations.tobytes()
        assert decoded.root_translation.tobytes() == expected.root_translation.tobytes()


def test_huffman_table_look_ups_read_what_the_bit_by_bit_reader_reads():
    """kernels/bba_units._read_dct_blocks (table look-ups, values read at once) against
    entropy_coding.read_dct_blocks (bit by bit) on random bits with long zero runs (emulation-prevention bits,
    codes longer than the table, the data's end): the same status, reader state and levels, block after block."""
    from comparisons.params import coding as pc
    from comparisons.params import bba_units
    from comparisons.params import arithmetic as entropy_coding

    rng = np.random.default_rng(11)
    tables = pc.vlc_tables()
    ac = tables["ac"].arrays()[2:]
    ac_lut = bba_units.huffman_lut(*ac)
    statuses = set()
    for name in ("dc_intra", "dc_inter"):
        dc = tables[name].arrays()[2:]
        dc_lut = bba_units.huffman_lut(*dc)
        for _ in range(300):
            data = rng.integers(0, 256, 96).astype(np.uint8)
            data[rng.random(96) < rng.choice([0.1, 0.3, 0.6])] = 0
            end_bit = int(rng.integers(1, 8 * 96))
            n_params, n_ac = int(rng.integers(1, 9)), int(rng.choice([0, 3, 15]))
            expected_dc, expected_ac = np.zeros(n_params, np.int64), np.zeros((n_ac, n_params), np.int64)
            state = np.zeros(3, np.int64)
            expected = entropy_coding.read_dct_blocks(data, end_bit, state, *dc, *ac, pc.N_CATEGORIES, expected_dc,
                                                      expected_ac)
            result_dc, result_ac = np.zeros(n_params, np.int64), np.zeros((n_ac, n_params), np.int64)
            status, pos, run = bba_units._read_dct_blocks(data, end_bit, 0, 0, dc, dc_lut, ac, ac_lut, pc.N_CATEGORIES,
                                                          result_dc, result_ac)
            assert (status, pos, run) == (expected, state[0], state[1])
            assert np.array_equal(result_dc, expected_dc) and np.array_equal(result_ac, expected_ac)
            statuses.add(status)
    assert statuses >= {0, -1, -3}              # decoded, truncated, an AC run past the segment (the tables are complete)


def _regenerate_reference(key_q, key_t, kfi):
    """The display frames as _motion_of_runs built them before keyframes.regenerate: keys placed, expand between."""
    gaps = kfi.copy()
    gaps[0] = 0
    place = np.arange(len(kfi)) + np.cumsum(gaps)
    quats, trans = np.empty((place[-1] + 1,) + key_q.shape[1:]), np.empty((place[-1] + 1, 3))
    quats[place], trans[place] = key_q, key_t
    f = np.flatnonzero(gaps)
    q_mid, t_mid = kf.expand(key_q[f - 1], key_t[f - 1], key_q[f], key_t[f], gaps[f])
    inner = np.ones(len(quats), dtype=bool)
    inner[place] = False
    quats[inner], trans[inner] = q_mid, t_mid
    return quats, trans


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_regenerate_is_the_placed_batched_expansion(seed):
    rng = np.random.default_rng(seed)
    n_keys, n_bones = 12, 7
    key_q = rng.normal(size=(n_keys, n_bones, 4))
    key_q /= np.linalg.norm(key_q, axis=-1, keepdims=True)
    key_q[3] = key_q[2]                         # equal rotations: sin(alpha) below 1e-9
    key_q[5] = -key_q[4]                        # opposite signs
    key_t = rng.normal(size=(n_keys, 3))
    kfi = rng.integers(0, 32, size=n_keys).astype(np.int64)
    kfi[1] = 0
    q, t = kf.regenerate(key_q, key_t, kfi)
    q_ref, t_ref = _regenerate_reference(key_q, key_t, kfi)
    np.testing.assert_allclose(q, q_ref, rtol=0, atol=SLERP_TOLERANCE)
    assert t.tobytes() == t_ref.tobytes()


def _states_equal(a, b) -> None:
    assert (a.header, a.n_frames, a.keys) == (b.header, b.n_frames, b.keys)
    assert list(a.bones.items()) == list(b.bones.items()) and a.exponents == b.exponents
    assert np.array_equal(a.animatable, b.animatable)
    assert (a.fields is None) == (b.fields is None) and (a.alphabets is None) == (b.alphabets is None)
    if a.fields is not None:
        assert np.array_equal(a.fields, b.fields)
        assert all(np.array_equal(x, y) and x.dtype == y.dtype for x, y in zip(a.alphabets, b.alphabets))


@pytest.mark.parametrize("codec", ["pred", "dct", "key"])
def test_one_call_header_reader_gives_the_checked_readers_state_and_errors(codec):
    """kernels/bba_header.read_header (bba_codec._read_header) against the field-by-field reader: the same
    state on good headers (tight and default ranges, every coding), and on damaged ones the same outcome (the
    same state, or the same SigncastError message)."""
    rng = np.random.default_rng(11)
    coding, keyframes = ("pred", True) if codec == "key" else (codec, False)
    for letter, q in zip("AFKPTZ", (1, 2, 4, 8, 16, 31)):
        data = bba_codec.encode_motion(letter_motion("ase", letter, 25.0), q, coding, keyframes=keyframes)
        _states_equal(bba_codec._read_header(data, 1), bba_codec._read_header_checked(data, 1))
        end = bba_codec.find_start_codes(data)[1][0]          # the header: bytes 1 .. the first unit's start code
        for _ in range(40):
            damaged = bytearray(data)
            damaged[rng.integers(5, end)] ^= 1 << int(rng.integers(8))
            if rng.random() < 0.3:
                damaged = damaged[:int(rng.integers(6, end))]
            outcomes = []
            for read in (bba_codec._read_header, bba_codec._read_header_checked):
                try:
                    outcomes.append(read(bytes(damaged), 1))
                except SigncastError as error:
                    outcomes.append(str(error))
            if isinstance(outcomes[0], str) or isinstance(outcomes[1], str):
                assert outcomes[0] == outcomes[1]
            else:
                _states_equal(*outcomes)

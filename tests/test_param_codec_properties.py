"""Properties of the parameter codecs (hypothesis): whatever the motion, decode(encode(x)) stays
within the codec's quantisation bound, at every Q, with nothing clipped.

Two levels:
- the FBA coder on BAP value series (encode_fba/decode_fba), angles near and across +-pi included;
- every codec in MOTION_BOUNDS through the public Motion -> stream -> Motion path of
  comparisons/params/codecs.py. To cover another codec, add its name and a bound function there.
"""
import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from comparisons.params import bap_table
from comparisons.params import coding as pc
from comparisons.params.fba import decode_fba, encode_fba
from comparisons.params.fba_mapping import avatar_bap_map, baps_to_motion
from comparisons.params.codecs import get_codec
from media import rotations
from media.motion import Motion

PI = bap_table.ROTATION_RANGE                       # 314159 x 1e-5 rad
TRANSLATION_MM = 15_000                             # inside an FBA intra plane's range at every Q (>= 15180 mm)
STEP_64_BAPS = [b.id for b in bap_table.BAPS if b.step == 64 and not b.is_translation]
FEW = settings(max_examples=40, deadline=None)


# --------------------------------------------------------------------------- bounds

def dct_error_bound(base_steps: np.ndarray, q: int, n: int) -> np.ndarray:
    """Largest |decoded - value| of a DCT-coded sample in a segment of n frames, per parameter.

    base_steps: (P,) base steps; returns (P,) in the parameter's units. The orthonormal DCT-II
    basis has |DC row| = 1/sqrt(n) and |AC rows| <= sqrt(2/n), so a sample's error is at most
    |DC error|/sqrt(n) + sum of the n-1 |AC errors| sqrt(2/n), with |DC error| <= DC step/2 and
    |AC error| <= AC step/2 (rounding to the nearest level), plus 1/2 for rounding the sample to
    an integer. A parameter left out of the mask holds a value within DC step/2 (<= the bound)."""
    dc_step, ac_step = pc.dct_steps(base_steps, q)
    return dc_step / (2 * np.sqrt(n)) + (n - 1) * ac_step / 2 * np.sqrt(2 / n) + 0.5


def fba_error_bound(coding: str, q: int, n_frames: int) -> np.ndarray:
    """(n_frames, 296) largest |decoded - value| per BAP value of encode_fba, BAP units.

    pred: half a step (step = BAP step x Q): intra levels are absolute and P levels code the
    residual against the decoder's own previous value. dct: dct_error_bound at the length of the
    16-frame segment each frame falls in (DCT intra periods are whole segments)."""
    steps = bap_table.steps()
    if coding == "pred":
        return np.broadcast_to(steps * q / 2, (n_frames, bap_table.N_BAPS))
    lengths = np.bincount(np.arange(n_frames) // pc.SEGMENT)[np.arange(n_frames) // pc.SEGMENT]
    return np.stack([dct_error_bound(steps, q, int(n)) for n in lengths])


def fba_motion_bound(coding: str):
    """bound(motion, q) -> (rotation bound (T, B) rad per bone of `motion`, translation bound (T, 3) m).

    motion_to_baps rounds each of a bone's three angles to 1e-5 rad and the codec moves each by at
    most its bound; composing three rotations each off by e_i turns the bone by at most sum(e_i)
    (the rotation angle is a bi-invariant metric). 1e-6 rad covers float error in the Euler maps."""
    def bound(motion: Motion, q: int) -> tuple[np.ndarray, np.ndarray]:
        per_bap = fba_error_bound(coding, q, motion.n_frames)
        baps = {b.bone: np.array(b.baps) - 1 for b in avatar_bap_map().bones}
        rotation = np.stack([(1.5 + per_bap[:, baps[name]].sum(axis=1)) * bap_table.ROTATION_UNIT_RAD + 1e-6
                             for name in motion.bone_names], axis=1)
        translation = (0.5 + per_bap[:, [182 - 1, 181 - 1, 183 - 1]]) * bap_table.TRANSLATION_UNIT_M   # x, y, z
        return rotation, translation
    return bound


# codec name (comparisons/params/codecs.py) -> bound(motion, q) as fba_motion_bound returns it
MOTION_BOUNDS = {"fba-pred": fba_motion_bound("pred"), "fba-dct": fba_motion_bound("dct")}


# --------------------------------------------------------------------------- series

def wrap_angle(units: np.ndarray) -> np.ndarray:
    """Integer angles (1e-5 rad) wrapped into [-PI, PI]: walking past +PI continues from -PI."""
    return (units + PI) % (2 * PI + 1) - PI


@st.composite
def angle_series(draw, n_frames: int, low: int = -PI, high: int = PI) -> np.ndarray:
    """(n_frames,) int64 angle in [low, high]: a random walk, often starting near +-pi, with small
    steps, large jumps, or jumps straight across +-pi (wrapped when the range is the full circle)."""
    full_circle = (low, high) == (-PI, PI)
    near_pi = st.tuples(st.integers(PI - 3000, PI), st.sampled_from([1, -1])).map(lambda t: t[0] * t[1])
    start = draw(st.one_of(near_pi, st.integers(low, high)) if full_circle else st.integers(low, high))
    jump = draw(st.sampled_from([300, 20_000, 2 * PI]))
    deltas = draw(st.lists(st.integers(-jump, jump), min_size=n_frames - 1, max_size=n_frames - 1))
    walk = start + np.concatenate([[0], np.cumsum(deltas, dtype=np.int64)])
    return wrap_angle(walk) if full_circle else np.clip(walk, low, high)


@st.composite
def bap_series(draw, max_frames: int = 40) -> np.ndarray:
    """(T, 296) int64 BAP values: a few BAPs move (step-64 angles and root translations are
    drawn often, since they are the ones whose residuals can outgrow the range fields)."""
    n_frames = draw(st.integers(1, max_frames))
    ids = st.one_of(st.sampled_from(STEP_64_BAPS), st.sampled_from(bap_table.TRANSLATION_BAPS),
                    st.integers(1, bap_table.N_BAPS))
    values = np.zeros((n_frames, bap_table.N_BAPS), dtype=np.int64)
    for bap_id in draw(st.lists(ids, min_size=1, max_size=4, unique=True)):
        if bap_table.bap(bap_id).is_translation:
            level = st.integers(-TRANSLATION_MM, TRANSLATION_MM)
            values[:, bap_id - 1] = draw(st.lists(level, min_size=n_frames, max_size=n_frames))
        else:
            values[:, bap_id - 1] = draw(angle_series(n_frames))
    return values


def _crossing_pi() -> np.ndarray:
    """The case hypothesis found (issue 10): BAP 186 crossing +-pi, once clipped to 11934 off."""
    values = np.zeros((4, bap_table.N_BAPS), dtype=np.int64)
    values[:, 186 - 1] = [314000, 314150, -314150, -314000]
    return values


@st.composite
def motions(draw, max_frames: int = 24) -> Motion:
    """A Motion of every BAP-carrying avatar bone, a few of them turning with angles near and
    across +-pi (root and arm bones with step-64 BAPs included), plus a root translation."""
    n_frames = draw(st.integers(1, max_frames))
    bones = avatar_bap_map().bones
    values = np.zeros((n_frames, bap_table.N_BAPS), dtype=np.int64)
    moving = st.one_of(st.sampled_from(["root", "upperarm01.L", "lowerarm01.R"]),    # step-64 BAPs
                       st.sampled_from([b.bone for b in bones]))
    for name in draw(st.lists(moving, min_size=1, max_size=3, unique=True)):
        flexion, abduction, twist = next(b.baps for b in bones if b.bone == name)
        values[:, flexion - 1] = draw(angle_series(n_frames))
        values[:, abduction - 1] = draw(angle_series(n_frames, -140_000, 140_000))   # middle Euler angle,
                                                                                    # off gimbal lock
        values[:, twist - 1] = draw(angle_series(n_frames))
    for bap_id in bap_table.TRANSLATION_BAPS:
        values[:, bap_id - 1] = draw(st.lists(st.integers(-TRANSLATION_MM, TRANSLATION_MM), min_size=n_frames,
                                              max_size=n_frames))
    fps = draw(st.sampled_from([10.0, 25.0]))
    return baps_to_motion(values, fps)


# --------------------------------------------------------------------------- properties

@pytest.mark.parametrize("coding", ["pred", "dct"])
@FEW
@given(values=bap_series(), q=st.integers(1, 31))
@example(values=_crossing_pi(), q=1)
@example(values=_crossing_pi(), q=31)
def test_fba_decodes_any_bap_series_within_its_quantisation_bound(coding, values, q):
    result = decode_fba(encode_fba(values, 25, q, coding))
    decoded, fps = result.baps, result.fps
    assert fps == 25 and decoded.shape == values.shape
    assert np.all(np.abs(decoded - values) <= fba_error_bound(coding, q, len(values)) + 1e-9)


@pytest.mark.parametrize("name", sorted(MOTION_BOUNDS))
@settings(max_examples=10, deadline=None)
@given(motion=motions(), q=st.integers(1, 31))
def test_codec_decodes_any_motion_within_its_quantisation_bound(name, motion, q):
    codec = get_codec(name)
    decoded = codec.decode(codec.encode(motion, q))
    assert decoded.fps == motion.fps and decoded.n_frames == motion.n_frames
    rotation_bound, translation_bound = MOTION_BOUNDS[name](motion, q)
    index = {bone: k for k, bone in enumerate(decoded.bone_names)}
    for k, bone in enumerate(motion.bone_names):
        error = rotations.angle_between(motion.rotations[:, k], decoded.rotations[:, index[bone]])
        assert np.all(error <= rotation_bound[:, k]), bone
    assert np.all(np.abs(decoded.root_translation - motion.root_translation) <= translation_bound + 1e-9)


# --------------------------------------------------------------------------- BBA (comparisons/params/bba.py)

BBA_BONES = ("root", "upperarm01.L", "lowerarm01.R", "wrist.R", "finger2-1.R", "spine03")


def bba_error_bound(stream, q: int) -> list[dict]:
    """Per stream frame, (boneID, bit) -> largest distance between a decoded value and the sent
    one (1e-5 rad, angles compared modulo ANGLE_PERIOD; mm).

    pred (and key frames, which are predictive frames): half a step, step = base step x Q (an
    intra level is absolute, a P level codes the change from the decoder's own previous value,
    angles folded). dct: dct_error_bound at the length of the 16-frame segment of the frame."""
    from comparisons.params import bba
    from media.avatar import load_avatar

    skeleton = load_avatar().skeleton
    n = len(stream.frames)
    lengths = np.bincount(np.arange(n) // pc.SEGMENT)[np.arange(n) // pc.SEGMENT]
    bounds = []
    for frame, length in zip(stream.frames, lengths):
        steps = {(b, bit): bba.step_of(b, bit, skeleton) for b in frame.bones for bit in bba._bits(frame.bones[b])}
        if stream.header.coding == "pred":
            bounds.append({key: step * q / 2 for key, step in steps.items()})
        else:
            bounds.append({key: float(dct_error_bound(np.array([step]), q, int(length))[0]) for key, step in steps.items()})
    return bounds


@st.composite
def bba_motions(draw, max_frames: int = 24) -> tuple[Motion, int]:
    """(Motion, rotation order 0..23): a few avatar bones whose Euler angles in that order are
    random walks near and across +-pi (the middle angle over its whole range, gimbal lock
    included), and a root translation within +-15 m."""
    from comparisons.params.bba import ORDER_NAMES

    order = draw(st.integers(0, 23))
    n_frames = draw(st.integers(1, max_frames))
    bones = tuple(draw(st.lists(st.sampled_from(BBA_BONES), min_size=1, max_size=3, unique=True)))
    middle = (0, PI) if ORDER_NAMES[order][0] == ORDER_NAMES[order][2] else (-PI // 2, PI // 2)
    angles = np.stack([np.stack([draw(angle_series(n_frames)), draw(angle_series(n_frames, *middle)),
                                 draw(angle_series(n_frames))], axis=1) for _ in bones], axis=1)   # (T, B, 3)
    q = rotations.from_euler(angles * bap_table.ROTATION_UNIT_RAD, ORDER_NAMES[order])
    translation = np.array(draw(st.lists(st.integers(-TRANSLATION_MM, TRANSLATION_MM), min_size=3 * n_frames,
                                         max_size=3 * n_frames))).reshape(n_frames, 3) * bap_table.TRANSLATION_UNIT_M
    return Motion(draw(st.sampled_from([10.0, 25.0])), bones, q, translation), order


def _bba_crossing_pi() -> tuple[Motion, int]:
    """The case of issue 10: a forearm turning through pi, once decoded 1.36 rad off."""
    q = rotations.from_axis_angle(np.tile([1.0, 0, 0], (4, 1)), np.array([3.10, 3.15, 3.20, 3.25]))[:, None]
    return Motion(25.0, ("lowerarm01.R",), q, np.zeros((4, 3))), 0


@pytest.mark.parametrize("coder", ["pred", "dct", "key"])
@settings(max_examples=20, deadline=None)
@given(motion_order=bba_motions(), q=st.integers(1, 31))
@example(motion_order=_bba_crossing_pi(), q=4)
@example(motion_order=_bba_crossing_pi(), q=1)
def test_bba_decodes_any_motion_within_its_quantisation_bound(coder, motion_order, q):
    from comparisons.params import bba

    motion, order = motion_order
    stream = bba.motion_to_stream(motion, q, "dct" if coder == "dct" else "pred", keyframes=coder == "key",
                                  rotation_order=order)
    decoded, lost = bba.read_stream(bba.write_stream(stream))
    assert lost == [] and len(decoded.frames) == len(stream.frames)
    assert bba.stream_to_motion(decoded).n_frames == motion.n_frames
    for sent, back, bound in zip(stream.frames, decoded.frames, bba_error_bound(stream, q)):
        assert back.bones == sent.bones
        for b, mask in sent.bones.items():
            for bit, value, got in zip(bba._bits(mask), sent.values[b], back.values[b]):
                error = bba.fold_angles(got - value) if bit in bba.ROTATION_BITS else got - value
                assert abs(int(error)) <= bound[(b, bit)] + 1e-9, (b, bit, value, got)

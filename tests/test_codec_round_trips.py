"""Issue 37: hypothesis round trips over random motions for every parameter codec (bba-dct included), and the
BBA-XML frame rate finding. A decoded motion keeps the length and frame rate; every bone of the input is either
in the decoded motion within the codec's error, or left out because it decodes to rest (the codec contract:
bones the stream does not carry stay at rest)."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from comparisons.params import codecs as param_codecs
from comparisons.params.bba import BBAStream
from comparisons.params.bba_xml import from_xml, to_xml
from media import rotations
from media.errors import SigncastError
from media.fingerspelling import fingerspell
from media.motion import Motion

LETTER = fingerspell("ase", "A", fps=25)
MPEG4 = ("fba-pred", "fba-dct", "bba-pred", "bba-dct", "bba-key")
# bounds on the decoded rotation's error at Q 1 and Q 8, radians: steps of 1e-5 rad x q x the codec's grid, DCT
# and key-frame interpolation being lossier; generous, a lost bone is a full turn of error
BOUND = {"fba-pred": 0.02, "fba-dct": 0.05, "bba-pred": 0.02, "bba-dct": 0.05, "bba-key": 0.3}


@st.composite
def motions(draw):
    """A smooth random motion of the letter's bones (those FBA carries): a random walk of small turns."""
    n = draw(st.integers(1, 24))
    seed = draw(st.integers(0, 2 ** 32 - 1))
    scale = draw(st.sampled_from([1e-4, 1e-2, 0.05]))
    rng = np.random.default_rng(seed)
    bones = len(LETTER.bone_names)
    start = LETTER.rotations[draw(st.integers(0, LETTER.n_frames - 1))]
    axis = rng.normal(size=(n, bones, 3))
    angle = np.cumsum(rng.normal(size=(n, bones)) * scale, axis=0)
    turn = rotations.from_axis_angle(axis / np.linalg.norm(axis, axis=-1, keepdims=True), angle)
    moved = rng.random(bones) < draw(st.sampled_from([0.1, 0.5, 1.0]))
    q = np.where(moved[None, :, None], rotations.multiply(np.broadcast_to(start, turn.shape), turn), start)
    root = np.cumsum(rng.normal(size=(n, 3)) * scale * 0.1, axis=0)
    return Motion(25.0, LETTER.bone_names, rotations.normalize(q), root)


def _angles(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return rotations.angle_between(rotations.normalize(a), rotations.normalize(b))


@pytest.mark.parametrize("codec", MPEG4)
@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(motion=motions(), q=st.sampled_from([1, 8]))
def test_every_codec_round_trips_random_motions(codec, motion, q):
    coder = param_codecs.get_codec(codec)
    decoded = coder.decode(coder.encode(motion, q))
    assert decoded.n_frames == motion.n_frames and decoded.fps == pytest.approx(motion.fps)
    where = {name: k for k, name in enumerate(decoded.bone_names)}
    rest = np.array([1.0, 0.0, 0.0, 0.0])
    for k, name in enumerate(motion.bone_names):
        got = decoded.rotations[:, where[name]] if name in where else np.broadcast_to(rest, (motion.n_frames, 4))
        error = float(_angles(got, motion.rotations[:, k]).max())
        assert error <= BOUND[codec] * (q if q > 1 else 1) ** 0.5 + 1e-9, (name, error, name in where)


@pytest.mark.parametrize("rate", ["00", "0", "-25", "nan", "0.5", "1e-300", "1000"])
def test_bba_xml_refuses_a_frame_rate_the_stream_cannot_have(rate):
    """Finding: BBA-XML accepted frameRate="00" (a stream at 0 fps)."""
    stream = _xml_stream()
    text = to_xml(stream).replace('frameRate="25"', f'frameRate="{rate}"')
    assert f'frameRate="{rate}"' in text
    with pytest.raises(SigncastError, match="frameRate|frame rate"):
        from_xml(text)


def test_bba_xml_keeps_a_signalled_frame_rate():
    stream = _xml_stream()
    assert from_xml(to_xml(stream)).header.fps == 25


def _xml_stream() -> BBAStream:
    from comparisons.params.bba import motion_to_stream
    return motion_to_stream(LETTER.frames(0, 3), 4, "pred")

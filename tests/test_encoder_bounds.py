"""The FBA encoders (fba-pred, fba-dct: body and face) and the shape coder by what a user relies on (issue 33):
the decoder reads what the encoder wrote, every value comes back within the bound stated in the encoder's
docstring, and the rate stays within RATE_TOLERANCE of the stored figure. Their bytes may differ between CPUs
(the DCT's float products, FMA or not; the Motion -> BAP split in front of them); the decoders are pinned by
tests/test_conformance.py. Rates are pinned on the stored letters (retargeted once); letters retargeted now and
hypothesis-generated tracks are held to the bounds alone.

Stated bounds, per parameter in its own unit (comparisons/params/fba.py encode_fba):
- predictive (BAPs and FAPs): half a quantiser step, step = bap_table.steps() x Q (FAPs: fap_table.steps() x
  fap_quant), rounded down to whole units: closed-loop levels, nothing clipped;
- DCT: each coefficient within half its step (DC step x Q, AC step x Q / 3) through the orthonormal inverse
  transform of an n-frame segment, plus the half unit of the final rounding:
  0.5 (s Q / sqrt(n) + (n - 1) (s Q / 3) sqrt(2 / n)) + 0.5 <= 1.01 s Q + 0.5 for n <= 16;
- shape (comparisons/video/shape.py encode_shape): lossless.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from comparisons.params import bap_table, fap_table
from comparisons.params import coding as pc
from comparisons.params.fba import decode_fba, encode_fba
from comparisons.params.fba_mapping import motion_to_baps
from comparisons.video.shape import decode_shape, encode_shape
from media.fingerspelling import letter_motion
from media.motion import Motion

RATE_TOLERANCE = 0.02
QS = (1, 8, 31)
# Stored sizes in bytes at 25 fps, measured 6 Dec 2026 on the stored ASL letters (tests/data/codec_letter_motions.npz,
# retargeted once, so a retargeting change does not move them): (letter, coding, Q) -> (the letter's body and face
# in one stream, its face alone), fap_quant = Q. An encoder change may move them by RATE_TOLERANCE; beyond it,
# re-measure deliberately and say why in the commit.
STORED_BYTES = {
    ('A', 'pred', 1): (1984, 803), ('A', 'pred', 8): (1013, 420), ('A', 'pred', 31): (502, 176),
    ('A', 'dct', 1): (1633, 651), ('A', 'dct', 8): (1009, 373), ('A', 'dct', 31): (616, 197),
    ('J', 'pred', 1): (2262, 923), ('J', 'pred', 8): (1328, 472), ('J', 'pred', 31): (765, 207),
    ('J', 'dct', 1): (2231, 776), ('J', 'dct', 8): (1407, 468), ('J', 'dct', 31): (904, 224),
}
# Letters retargeted now (media.fingerspelling.letter_motion), for the round-trip bounds only.
LIVE_LETTERS = (("ase", "H"), ("ase", "J"), ("bzs", "B"))


def round_trip_bound(steps: np.ndarray, q: int, coding: str) -> np.ndarray:
    """The stated bound (module docstring) per parameter, in its unit, for base steps (P,) at quantiser q."""
    steps = np.asarray(steps, dtype=np.float64)
    if coding == "pred":
        return np.floor(steps * q / 2)
    n = np.arange(1, pc.SEGMENT + 1)
    worst = np.max(0.5 / np.sqrt(n) + 0.5 * (n - 1) / 3 * np.sqrt(2 / n))      # over segment lengths 1..16
    return worst * steps * q + 0.5


def _check_round_trip(baps, faps, q: int, coding: str, fps: float = 25.0) -> bytes:
    data = encode_fba(baps, fps, q, coding, faps=faps)
    decoded = decode_fba(data)
    if baps is None:
        assert decoded.baps is None
    else:
        assert decoded.baps.shape == baps.shape
        assert np.all(np.abs(decoded.baps - baps) <= round_trip_bound(bap_table.steps(), q, coding))
    if faps is None:
        assert decoded.faps is None
    else:
        assert decoded.faps.shape == faps.shape
        assert np.all(np.abs(decoded.faps - faps) <= round_trip_bound(fap_table.steps(), q, coding))
    return data


def _stored_letter_motion(letter: str) -> Motion:
    """ASL `letter` at 25 fps with its face as stored in tests/data/codec_letter_motions.npz."""
    with np.load(Path(__file__).resolve().parent / "data" / "codec_letter_motions.npz") as stored:
        return Motion(float(stored[f"{letter}/fps"]), [str(n) for n in stored[f"{letter}/bone_names"]],
                      stored[f"{letter}/rotations"], stored[f"{letter}/root_translation"], stored[f"{letter}/faps"])


@pytest.mark.parametrize("coding", ["pred", "dct"])
def test_fba_streams_of_stored_letters_round_trip_within_the_bound_at_the_stored_rate(coding):
    """Body and face together, and the face alone (the FAP streams), of the stored letters at Q 1, 8, 31."""
    for letter in sorted({key[0] for key in STORED_BYTES}):
        motion = _stored_letter_motion(letter)
        baps = motion_to_baps(motion)
        for q in QS:
            both = _check_round_trip(baps, motion.faps, q, coding, motion.fps)
            face = _check_round_trip(None, motion.faps, q, coding, motion.fps)
            for data, stored in zip((both, face), STORED_BYTES[(letter, coding, q)]):
                assert abs(len(data) - stored) <= RATE_TOLERANCE * stored, (letter, coding, q, len(data), stored)


@pytest.mark.parametrize("coding", ["pred", "dct"])
def test_fba_streams_of_letters_retargeted_now_round_trip_within_the_bound(coding):
    for language, letter in LIVE_LETTERS:
        motion = letter_motion(language, letter, 25.0)
        assert motion.faps is not None
        baps = motion_to_baps(motion)
        for q in QS:
            _check_round_trip(baps, motion.faps, q, coding)
            _check_round_trip(None, motion.faps, q, coding)


def test_the_dct_bound_is_about_one_step():
    assert round_trip_bound(np.array([100.0]), 1, "dct")[0] == pytest.approx(101.4, abs=0.1)
    assert round_trip_bound(np.array([100.0]), 1, "pred")[0] == 50


@st.composite
def _tracks(draw, limits: np.ndarray):
    """(T, P) int64 tracks: a few parameters moving (random walks, steps and holds) within +-limits, the rest 0."""
    n_frames = draw(st.integers(1, 40))
    seed = draw(st.integers(0, 2 ** 32 - 1))
    rng = np.random.default_rng(seed)
    values = np.zeros((n_frames, len(limits)), np.int64)
    moving = rng.choice(np.flatnonzero(limits > 0), size=draw(st.integers(0, 12)), replace=False)
    for p in moving:
        scale = limits[p] * draw(st.sampled_from([1e-3, 0.05, 0.5]))
        walk = np.cumsum(rng.normal(size=n_frames) * scale) + rng.uniform(-1, 1) * limits[p] * 0.5
        if draw(st.booleans()):
            walk[rng.integers(0, n_frames):] += rng.uniform(-1, 1) * limits[p] * 0.5     # a jump, then held
        values[:, p] = np.clip(np.round(walk), -limits[p], limits[p])
    return values


_FAP_LIMITS = np.minimum(fap_table.limits(), 2000).astype(np.int64)
_FAP_LIMITS[:2] = 0                                              # FAPs 1-2 (viseme, expression) are never sent
# BAPs up to 3 rad (1e-5 rad units) or 3 m of root translation, within what an intra plane carries at every Q drawn
_BAP_LIMITS = np.minimum(300_000, min(pc.level_limit(q) * q for q in (1, 2, 8, 31)) * bap_table.steps()).astype(np.int64)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(baps=_tracks(_BAP_LIMITS), q=st.sampled_from([1, 2, 8, 31]), coding=st.sampled_from(["pred", "dct"]))
def test_generated_body_tracks_round_trip_within_the_bound(baps, q, coding):
    _check_round_trip(baps, None, q, coding)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(faps=_tracks(_FAP_LIMITS), q=st.sampled_from([1, 2, 8, 31]), coding=st.sampled_from(["pred", "dct"]))
def test_generated_face_tracks_round_trip_within_the_bound(faps, q, coding):
    _check_round_trip(None, faps, q, coding)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2 ** 32 - 1), frames=st.integers(1, 6), height=st.integers(1, 40),
       width=st.integers(1, 40), gop=st.integers(1, 5), density=st.sampled_from([0.0, 0.1, 0.5, 1.0]))
def test_generated_masks_code_losslessly(seed, frames, height, width, gop, density):
    """The shape coder is lossless (encode_shape's docstring): random masks, blobs that move and empty frames."""
    rng = np.random.default_rng(seed)
    masks = rng.random((frames, height, width)) < density
    yy, xx = np.mgrid[:height, :width]
    for t in range(frames):
        if rng.random() < 0.5:                               # a moving blob instead of noise
            masks[t] = (yy - height / 2) ** 2 + (xx - t - width / 3) ** 2 < (min(height, width) / 3) ** 2
    stream, _ = encode_shape(masks, gop)
    assert np.array_equal(decode_shape(stream), masks)

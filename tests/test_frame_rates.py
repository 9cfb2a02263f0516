"""Every frame rate a camera gives survives the parameter streams: the header signals it exactly (NTSC rates as
n x 1000/1001), and a decoded stream plays at the rate it was coded at."""
from __future__ import annotations

import dataclasses
from fractions import Fraction

import pytest

from comparisons.params.codecs import get_codec
from comparisons.params.coding import fps_from_fields, frame_rate_fields
from media.errors import SigncastError
from media.fingerspelling import letter_motion

CAMERA_RATES = {   # as a camera or container states it -> the exact rate
    29.97: Fraction(30000, 1001), 23.976: Fraction(24000, 1001), 59.94: Fraction(60000, 1001),
    25: Fraction(25), 15: Fraction(15), 12.5: Fraction(25, 2), 30: Fraction(30), 50: Fraction(50), 10: Fraction(10),
}


@pytest.mark.parametrize("stated, exact", CAMERA_RATES.items())
def test_camera_rates_are_signalled_exactly(stated, exact):
    for fps in (stated, float(exact)):
        assert fps_from_fields(*frame_rate_fields(fps)) == pytest.approx(float(exact), abs=1e-9)


def test_ntsc_rates_use_the_1000_1001_offset():
    assert frame_rate_fields(29.97) == (30, 0, 1)
    assert frame_rate_fields(23.976) == (24, 0, 1)
    assert frame_rate_fields(59.94) == (60, 0, 1)
    assert frame_rate_fields(12.5) == (12, 8, 0)


@pytest.mark.parametrize("fps", [0.5, 256.5, 29.5 + 1 / 64])
def test_rates_no_header_can_carry_are_refused(fps):
    with pytest.raises(SigncastError, match="cannot be signalled"):
        frame_rate_fields(fps)


@pytest.mark.parametrize("codec", ["fba-pred", "fba-dct", "bba-pred", "bba-dct", "bba-key"])
@pytest.mark.parametrize("fps", [29.97, 23.976, 59.94, 12.5])
def test_a_stream_plays_at_the_rate_it_was_coded_at(codec, fps):
    motion = letter_motion("ase", "B")
    motion = dataclasses.replace(motion, fps=fps, faps=None)
    decoded = get_codec(codec).decode(get_codec(codec).encode(motion, 4))
    assert decoded.fps == pytest.approx(float(CAMERA_RATES[fps]), abs=1e-9)
    assert decoded.n_frames == motion.n_frames

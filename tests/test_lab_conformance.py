"""The seed-002 motion coders against their conformance streams (tests/data/conformance/lab/, written by
tools/make_lab_conformance.py, whose docstring says when re-storing them is legitimate).

Decoders are pinned: every stored stream decodes to exactly the stored integers (LabCodec.decode_levels: the
levels, indices and key frames before dequantisation), on every CPU, since integer decoding is exact by
construction. The floats built from them are held to the encoder's stored error.

The letters are the stored ones the streams were coded from (tests/data/codec_letter_motions.npz, retargeted once,
through tools.make_lab_conformance.letter_dofs), not letters retargeted now: a retargeting change (31debf2's resting
hand and upright torso) moves the motion, not the coders, and must not move the error against "its letter".

Encoders are tested by what a user relies on, on the same letters: the decoder reads what they write and rebuilds
exactly the encoder's reconstruction; the rate stays within RATE_TOLERANCE of the stored stream's length; the error
stays within ERROR_TOLERANCE of the stored figure, and within the coder's stated bound where its docstring states
one (quant, deadreck, wavelet, wavelet-cx). Their bytes may differ from the stored ones (another CPU's rounding).
"""
from pathlib import Path

import numpy as np
import pytest

from comparisons.lab.codecs import LAB_CODEC_NAMES, LabCodec, make_coder
from tools.make_lab_conformance import LETTERS, letter_dofs, operating_points

DATA = Path(__file__).resolve().parent / "data" / "conformance" / "lab"
RATE_TOLERANCE = (0.03, 4)          # relative, plus bytes
ERROR_TOLERANCE = (0.05, 1e-6)      # relative, plus radians


def _cases(name: str) -> list[str]:
    with np.load(DATA / f"{name}.npz") as stored:
        return [key[:-len("/stream")] for key in stored.files if key.endswith("/stream")]


CASES = [(name, case) for name in LAB_CODEC_NAMES for case in _cases(name)]


def _stored(name: str, case: str) -> dict[str, np.ndarray]:
    with np.load(DATA / f"{name}.npz") as stored:
        return {key[len(case) + 1:]: stored[key] for key in stored.files if key.startswith(case + "/")}


def _q(case: str) -> int:
    return int(case.rpartition("_q")[2])


def test_every_coder_has_its_streams():
    for name in LAB_CODEC_NAMES:
        qs = operating_points(len(LabCodec(name).settings()))
        assert sorted(_cases(name)) == sorted(f"{letter}_q{q}" for letter in LETTERS for q in qs), name


@pytest.mark.parametrize("name, case", CASES, ids=lambda v: str(v))
def test_stored_stream_decodes_to_exactly_the_stored_integers(name, case):
    stored = _stored(name, case)
    levels, active, n_frames, fps = LabCodec(name).decode_levels(stored["stream"].tobytes())
    assert np.array_equal(active, stored["active"])
    assert n_frames == stored["n_frames"] and fps == stored["fps"]
    expected = {key[len("levels."):]: value for key, value in stored.items() if key.startswith("levels.")}
    assert sorted(levels) == sorted(expected)
    for key, value in expected.items():
        assert levels[key].dtype == np.int64 and np.array_equal(levels[key], value), key


@pytest.mark.parametrize("name, case", CASES, ids=lambda v: str(v))
def test_stored_stream_decodes_within_the_stored_error_of_its_letter(name, case):
    stored = _stored(name, case)
    decoded, fps = LabCodec(name).decode_dofs(stored["stream"].tobytes())
    dofs, _ = letter_dofs(case.partition("_")[0])
    assert decoded.shape == dofs.shape and fps == stored["fps"]
    assert np.all(decoded[:, ~stored["active"]] == 0.0)
    error = np.abs(decoded - dofs)[:, stored["active"]]
    relative, absolute = ERROR_TOLERANCE
    assert error.max() <= stored["max_rad"] * (1 + relative) + absolute


@pytest.mark.parametrize("case", _cases("wavelet-cx-container"))
def test_stored_container_stream_of_wavelet_cx_decodes_to_exactly_the_stored_integers(case):
    stored = _stored("wavelet-cx-container", case)
    coder = make_coder("wavelet-cx", stored["active"])
    levels, info = coder.read_levels(stored["stream"].tobytes())
    assert info.n_frames == stored["n_frames"] and info.fps == stored["fps"] and info.q == _q(case) - 1
    assert sorted(levels) == ["indices"] and np.array_equal(levels["indices"], stored["levels.indices"])


def _stated_bound(name: str, q: int, dofs: np.ndarray, recon: np.ndarray, active: np.ndarray) -> None:
    """The hard error bounds the coders' docstrings state."""
    coder = make_coder(name, active)
    setting = coder.settings[q - 1]
    x, y = dofs[:, active], recon[:, active]
    if name == "quant":             # half a cell, for the input clamped to the DOF range
        clamped = np.clip(x, coder.lower, coder.upper)
        assert np.all(np.abs(y - clamped) <= coder.width / setting / 2 * (1 + 1e-9))
    elif name == "deadreck":        # the threshold E, after the first frame (16-bit cells)
        assert np.abs(y[1:] - x[1:]).max() <= np.radians(setting) * (1 + 1e-9)
    elif name in ("wavelet", "wavelet-cx"):   # half a step per coefficient of an orthonormal 16-sample block
        assert np.abs(y - x).max() <= 2.0 * setting * (1 + 1e-9)


@pytest.mark.parametrize("name", LAB_CODEC_NAMES)
def test_encoder_round_trips_at_the_stored_rate_and_error(name):
    codec = LabCodec(name)
    for case in _cases(name):
        stored = _stored(name, case)
        letter, q = case.partition("_")[0], _q(case)
        dofs, fps = letter_dofs(letter)
        data, recon = codec.encode_dofs(dofs, fps, codec.index_of(q))
        decoded, got_fps = codec.decode_dofs(data)
        assert got_fps == fps and np.array_equal(decoded, recon), case
        relative, extra = RATE_TOLERANCE
        assert abs(len(data) - len(stored["stream"])) <= relative * len(stored["stream"]) + extra, case
        active = stored["active"]
        error = (recon - dofs)[:, active]
        relative, absolute = ERROR_TOLERANCE
        assert np.sqrt(np.mean(error ** 2)) <= stored["rms_rad"] * (1 + relative) + absolute, case
        _stated_bound(name, q, dofs, recon, active)

"""Decoder conformance: every stored stream in tests/data/conformance/ decodes to exactly the stored integers.

The streams and their integers (BAP/FAP levels, BBA KeyFrameIndex, bone lists and values, shape pixels) were
written by tools/make_conformance_streams.py (its docstring says when re-storing them is legitimate). Integer
decoding is exact by construction, so this holds on every CPU; the floats a decoder derives from the integers
(quaternions, slerp, the face rig) are tested with tolerances elsewhere (tests/test_param_codec_properties.py).
"""
from pathlib import Path

import numpy as np
import pytest

from comparisons.params import bba, bba_xml
from comparisons.params.fba import decode_fba
from comparisons.video.shape import decode_shape

DATA = Path(__file__).resolve().parent / "data" / "conformance"
KINDS = ("fba-pred", "fba-dct", "fap-pred", "fap-dct", "bba-pred", "bba-dct", "bba-key", "bba-xml", "shape-cae")


def _cases(kind: str) -> list[tuple[str, str]]:
    with np.load(DATA / f"{kind}.npz") as stored:
        return [(kind, key[:-len("/stream")]) for key in stored.files if key.endswith("/stream")]


CASES = [case for kind in KINDS for case in _cases(kind)]


def _stored(kind: str, case: str) -> dict[str, np.ndarray]:
    with np.load(DATA / f"{kind}.npz") as stored:
        return {key[len(case) + 1:]: stored[key] for key in stored.files if key.startswith(case + "/")}


def test_every_kind_has_streams():
    for kind in KINDS:
        assert len(_cases(kind)) >= 1, kind
    assert len(CASES) >= 30


@pytest.mark.parametrize("kind, case", CASES, ids=lambda v: str(v))
def test_stored_stream_decodes_to_the_stored_integers(kind, case):
    stored = _stored(kind, case)
    data = stored["stream"].tobytes()
    if kind.startswith(("fba", "fap")):
        decoded = decode_fba(data)
        assert decoded.fps == float(stored["fps"])
        assert np.array_equal(decoded.face_frames, stored["face_frames"])
        assert decoded.faps.dtype == np.int64 and np.array_equal(decoded.faps, stored["faps"])
        if kind.startswith("fba"):
            assert decoded.baps.dtype == np.int64 and np.array_equal(decoded.baps, stored["baps"])
        else:
            assert decoded.baps is None
    elif kind == "bba-xml":
        stream = bba_xml.from_xml(data.decode("utf-8"))
        frames = stream.frames
        assert stream.header.fps == float(stored["fps"]) and stream.header.q == int(stored["q"])
        assert [f.kfi for f in frames] == stored["kfi"].tolist()
        for frame, row in zip(frames, stored["values"], strict=True):
            assert sorted(frame.bones.items()) == list(zip(stored["bone_ids"].tolist(), stored["bone_masks"].tolist()))
            assert [v for b in sorted(frame.bones) for v in frame.values[b]] == row.tolist()
        # and the XML's binary form decodes to the same integers
        assert np.array_equal(bba.decode_levels(bba.write_stream(stream)).values, stored["values"])
    elif kind.startswith("bba"):
        levels = bba.decode_levels(data)
        assert levels.header.fps == float(stored["fps"]) and levels.header.q == int(stored["q"])
        assert levels.header.keyframes == (kind == "bba-key")
        for name in ("kfi", "bone_ids", "bone_masks", "values"):
            got = getattr(levels, name)
            assert got.dtype == np.int64 and np.array_equal(got, stored[name]), name
        # the unit-by-unit reader (damaged and mixed streams take it) returns the same integers
        stream, lost = bba.read_stream(data)
        assert lost == [] and [f.kfi for f in stream.frames] == stored["kfi"].tolist()
        assert np.array_equal([[v for b in sorted(f.bones) for v in f.values[b]] for f in stream.frames],
                              stored["values"])
        # the display frames: key frames expanded (bba-key) to the encoded motion's length
        assert bba.decode_motion(data).n_frames == int(stored["n_frames"])
    else:
        pixels = decode_shape(data)
        assert pixels.dtype == bool and np.array_equal(pixels, stored["pixels"])

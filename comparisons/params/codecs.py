"""Registry of animation-parameter codecs: name -> object with `encode(motion, q) -> bytes` and
`decode(data) -> Motion`.

The interface is deliberately small so other coders (e.g. the seed-002 waveform and model-based
coders) can register next to the MPEG-4 ones:

    class MyCodec:
        name = "my-codec"
        description = "one line"
        sends_face = False
        def encode(self, motion: Motion, q: int) -> bytes: ...
        def decode(self, data: bytes) -> Motion: ...
    register(MyCodec())

`q` is the codec's quality knob (for the MPEG-4 coders the global quantisation value 1..31). `sends_face`
says whether a motion's face (its FAPs) travels in the stream: the MPEG-4 coders send it (FBA as FAPs, BBA as
face bones); seed 002's coders carry the signing joints only, so a face decodes at rest.
`decode` must return a Motion of the same length and frame rate as the encoded one (bones the
stream does not carry stay at rest) and raise SigncastError on damaged data. A reported size is
len() of the bytes `encode` returned.
"""
from __future__ import annotations

from typing import Protocol

import numpy as np

from comparisons.params import bba as bba_codec
from comparisons.params import fap_table
from comparisons.params import fba as fba_codec
from comparisons.params.fba_mapping import baps_to_motion, motion_to_baps
from media.errors import SigncastError
from media.face_rig import with_face_bones
from media.motion import Motion


class ParamCodec(Protocol):
    name: str
    description: str
    sends_face: bool

    def encode(self, motion: Motion, q: int) -> bytes: ...

    def decode(self, data: bytes) -> Motion: ...


class FbaCodec:
    """MPEG-4 FBA stream (comparisons/params/fba.py) of the avatar's BAPs (fba_mapping), and of the
    motion's FAPs when it carries a face (fba_object_mask 3), saturated at their coded range
    (fap_table.saturated: a measured face's outliers)."""

    sends_face = True

    def __init__(self, coding: str) -> None:
        self.coding = coding
        self.name = f"fba-{coding}"
        self.description = ("FBA, frame-predictive + adaptive arithmetic coding" if coding == "pred"
                            else "FBA, 16-frame DCT + Huffman VLC")

    def encode(self, motion: Motion, q: int) -> bytes:
        return fba_codec.encode_fba(motion_to_baps(motion), motion.fps, q, self.coding,
                                   faps=None if motion.faps is None else _saturated(motion.faps))

    def decode(self, data: bytes) -> Motion:
        decoded = fba_codec.decode_fba(data)
        return baps_to_motion(decoded.baps_or_rest(), decoded.fps, faps=decoded.faps)


_FAP_BOUND = fap_table.limits()
_FAP_BOUND.flags.writeable = False


def _saturated(faps) -> np.ndarray:
    """fap_table.saturated (FAPs (T, 68) clipped to limits()), with the limits computed once."""
    return np.minimum(np.maximum(np.asarray(faps, dtype=np.int64), -_FAP_BOUND), _FAP_BOUND)


class BbaCodec:
    """MPEG-4 BBA stream (comparisons/params/bba.py) of the avatar's bones; a motion's face travels as the
    face bones' rotations (media.face_rig: the FAPs played on the avatar), so the decoded Motion has those
    bones and no FAPs."""

    sends_face = True

    def __init__(self, coding: str, keyframes: bool = False) -> None:
        self.coding = coding
        self.keyframes = keyframes
        self.name = "bba-key" if keyframes else f"bba-{coding}"
        self.description = {"pred": "BBA, frame-predictive + adaptive arithmetic coding",
                            "dct": "BBA, 16-frame DCT + Huffman VLC"}[coding] + (
            ", key frames + interpolation" if keyframes else "")

    def encode(self, motion: Motion, q: int) -> bytes:
        return bba_codec.encode_motion(with_face_bones(motion, keep_faps=False), q, self.coding, keyframes=self.keyframes)

    def decode(self, data: bytes) -> Motion:
        return bba_codec.decode_motion(data)


REGISTRY: dict[str, ParamCodec] = {}


def register(codec: ParamCodec) -> None:
    if not getattr(codec, "name", None):
        raise SigncastError("a parameter codec needs a name")
    REGISTRY[codec.name] = codec


def get_codec(name: str) -> ParamCodec:
    try:
        return REGISTRY[name]
    except KeyError:
        raise SigncastError(f"unknown parameter codec {name!r}; known: {', '.join(REGISTRY)}") from None


def codec_names() -> list[str]:
    return list(REGISTRY)


for _codec in (FbaCodec("pred"), FbaCodec("dct"), BbaCodec("pred"), BbaCodec("dct"), BbaCodec("pred", keyframes=True)):
    register(_codec)

# Seed-002 motion-coding laboratory (comparisons/lab/codecs.py): quant, nuquant, dpcm, adpcm, deadreck, dct,
# wavelet, svq, tvq, posture, gesture, hybrid; their q is the operating point 1..n (1 = lowest rate).
from comparisons.lab.codecs import lab_codecs as _lab_codecs  # noqa: E402

for _codec in _lab_codecs():
    register(_codec)

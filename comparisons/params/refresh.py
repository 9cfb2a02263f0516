"""The parameter streams' refresh period (issue 35, item 7: equal terms with video).

A video decoder can join, or recover, at every intra picture: the comparison's video is coded with a GOP of
comparisons.video.codecs.GOP frames (12). An FBA/BBA stream's refresh is its intra plane (intra unit): by default
every DEFAULT_INTRA_PERIOD frames (32) for the predictive coders, every DEFAULT_INTRA_SEGMENTS 16-frame segments
(64 frames) for the DCT coders. `encode(codec_name, motion, q, period)` codes a motion as the registered codec
does, with an intra plane every `period` frames instead (the DCT coders: every ceil(period / 16) segments, their
finest refresh being one 16-frame segment); `refresh_frames` says the period a codec really gets and
`default_refresh_frames` its default. Codecs without an intra period (the seed-002 laboratory's) have none: None.
"""
from __future__ import annotations

import math

from comparisons.params import bba as bba_codec
from comparisons.params import fba as fba_codec
from comparisons.params.codecs import BbaCodec, FbaCodec, _saturated, get_codec
from comparisons.params.coding import SEGMENT
from comparisons.params.fba_mapping import motion_to_baps
from media.face_rig import with_face_bones
from media.motion import Motion


def _period(coding: str, period: int) -> int:
    """The intra period field for a refresh of `period` frames: frames (predictive), segments (DCT)."""
    return max(1, int(period)) if coding == "pred" else max(1, math.ceil(int(period) / SEGMENT))


def refresh_frames(codec_name: str, period: int) -> int | None:
    """The refresh period in frames that codec_name gets when asked for `period` frames (None: no intra period)."""
    codec = get_codec(codec_name)
    if not isinstance(codec, (FbaCodec, BbaCodec)):
        return None
    field = _period(codec.coding, period)
    return field if codec.coding == "pred" else field * SEGMENT


def default_refresh_frames(codec_name: str) -> int | None:
    """The codec's own refresh period in frames (None: no intra period)."""
    codec = get_codec(codec_name)
    if isinstance(codec, FbaCodec):
        return fba_codec.DEFAULT_INTRA_PERIOD if codec.coding == "pred" else fba_codec.DEFAULT_INTRA_SEGMENTS * SEGMENT
    if isinstance(codec, BbaCodec):
        return bba_codec.DEFAULT_INTRA_PERIOD if codec.coding == "pred" else bba_codec.DEFAULT_INTRA_SEGMENTS * SEGMENT
    return None


def encode(codec_name: str, motion: Motion, q: int, period: int) -> bytes:
    """motion coded by codec_name at q with an intra plane (unit) every `period` frames (`refresh_frames`); a codec
    without an intra period codes it as it always does. The registered codec's decode() reads the stream."""
    codec = get_codec(codec_name)
    if isinstance(codec, FbaCodec):
        field = _period(codec.coding, period)
        periods = {"intra_period": field} if codec.coding == "pred" else {"intra_segments": field}
        return fba_codec.encode_fba(motion_to_baps(motion), motion.fps, q, codec.coding,
                                    faps=None if motion.faps is None else _saturated(motion.faps), **periods)
    if isinstance(codec, BbaCodec):
        skeleton = bba_codec.load_avatar().skeleton
        header, mask, kfi, values = bba_codec._motion_arrays(
            with_face_bones(motion, keep_faps=False), q, codec.coding, codec.keyframes, None,
            _period(codec.coding, period), 0, 0, "signcast", skeleton)
        return bba_codec._write_arrays(header, mask, kfi, values, skeleton)
    return codec.encode(motion, q)

"""signcast's domain types and limits, defined once: part labels, colours, the frame-rate, Q and frame-size
rules, the solutions (`Solution`) and which one a codec belongs to, and the one rate computation (`kbps`).

Every check raises the one error type (SigncastError) with a one-line message that names the bad value and
the allowed range; `what` names the option or field in that message (e.g. "--fps", "--q"). This module
imports only kernels (the bottom layer: the renderer's default palettes live in kernels/raster.py and are
taken from there), so media, comparisons and pipeline can all use it.
"""
from __future__ import annotations

import math
import numbers
from enum import StrEnum

from kernels.raster import FLAT_PALETTE, SHADED_ALBEDO, STUDIO_BACKGROUND
from media.errors import SigncastError

# --------------------------------------------------------------------------- part labels (DESIGN.md)
# One byte per pixel in every mask and label buffer, and one per avatar triangle. "Left" and "right" are the
# signer's own (the avatar's own): a signer facing the camera shows the left hand on the image's right.
BACKGROUND, BODY, HEAD, LEFT_HAND, RIGHT_HAND = 0, 1, 2, 3, 4
PART_NAMES = {BACKGROUND: "background", BODY: "body", HEAD: "head", LEFT_HAND: "left_hand",
              RIGHT_HAND: "right_hand"}
SKIN_PARTS = (HEAD, LEFT_HAND, RIGHT_HAND)          # skin = head and hands; body = clothes

# --------------------------------------------------------------------------- colours (RGB uint8)
# The kernels' default palettes, indexed by part label: FLAT_PALETTE (flat look, one pure colour per part),
# SHADED_ALBEDO (shaded look) and STUDIO_BACKGROUND. The renderer's named colours are read from them.
SKIN_TONE = tuple(int(c) for c in SHADED_ALBEDO[HEAD])
CLOTHES = tuple(int(c) for c in SHADED_ALBEDO[BODY])
EYE_WHITE = (236, 232, 226)
IRIS = (70, 48, 34)
# Tints of segmentation.overlay (mask pictures), chosen to stand out on natural video.
OVERLAY_COLOURS = {BODY: (40, 90, 255), HEAD: (255, 200, 0), LEFT_HAND: (0, 220, 80), RIGHT_HAND: (255, 40, 200)}

__all__ = ["BACKGROUND", "BODY", "HEAD", "LEFT_HAND", "RIGHT_HAND", "PART_NAMES", "SKIN_PARTS",
           "FLAT_PALETTE", "SHADED_ALBEDO", "STUDIO_BACKGROUND", "SKIN_TONE", "CLOTHES", "EYE_WHITE", "IRIS",
           "OVERLAY_COLOURS", "MAX_FPS", "check_fps", "MIN_Q", "MAX_Q", "check_q", "parse_qs", "MIN_SIDE", "MAX_SIDE", "SIZES",
           "DEFAULT_SIZE", "check_size", "parse_size", "FBA", "BBA", "MOTION_CODER", "VIDEO_SOLUTIONS",
           "PARAMETER_SOLUTIONS", "SOLUTION_ORDER", "WAVEFORM_NAMES", "MODEL_NAMES", "MOTION_CODER_NAMES",
           "solution_of", "Solution", "SOURCE_VIDEO", "LOSSLESS_RENDER", "is_mpeg4_parameters", "kbps"]

# --------------------------------------------------------------------------- frame rate
# One limit for every frame rate a user asks for (motion, rendering, coding, analysis). 240 fps is above any
# display or signing capture rate, and FBA/BBA streams can signal every rate up to it: their frame-rate field
# is 8 bits of whole frames plus sixteenths (comparisons.params.coding.frame_rate_fields: up to 255 15/16 fps).
# Readers of files and coded streams bound what a file may declare separately and more loosely
# (media.text_files, comparisons.lab.streams: 1000 fps), since those guard allocations, not requests.
MAX_FPS = 240.0


def check_fps(fps, what: str = "--fps") -> float:
    """A frame rate in (0, MAX_FPS] frames per second as float; NaN, infinities, non-numbers and booleans are
    refused with SigncastError."""
    if (isinstance(fps, bool) or not isinstance(fps, numbers.Real) or not math.isfinite(fps)
            or not 0 < fps <= MAX_FPS):
        raise SigncastError(f"bad {what} {fps}: choose a frame rate in (0, {MAX_FPS:g}] frames per second, "
                            f"e.g. 10, 15, 20 or 25")
    return float(fps)


# --------------------------------------------------------------------------- MPEG-4 quantiser
# The global quantisation value of MPEG-4 video (VOP quantiser) and of the FBA/BBA parameter coders
# (seed 004 "BAP Coding": Quantum(i) x Global_Quantization_Value): 5 bits, 1..31.
MIN_Q, MAX_Q = 1, 31


def check_q(q, what: str = "Q") -> int:
    """An MPEG-4 quantiser, an integer in MIN_Q..MAX_Q, as int; anything else raises SigncastError."""
    if isinstance(q, bool) or not isinstance(q, numbers.Integral) or not MIN_Q <= int(q) <= MAX_Q:
        raise SigncastError(f"bad {what} {q}: MPEG-4 quantisers are {MIN_Q}..{MAX_Q}, whole numbers")
    return int(q)


def parse_qs(text: str, what: str = "--q") -> list[int]:
    """'1,2,4' -> [1, 2, 4], each checked by check_q; empty or non-integer text raises SigncastError."""
    try:
        values = [int(part) for part in str(text).split(",") if part.strip()]
    except ValueError:
        values = []
    if not values:
        raise SigncastError(f"bad {what} {text!r}: give comma-separated integers in {MIN_Q}..{MAX_Q}")
    return [check_q(q, what) for q in values]


# --------------------------------------------------------------------------- frame size
MIN_SIDE, MAX_SIDE = 32, 1920         # pixels; even sizes only (4:2:0 video and the half-resolution sweep)
SIZES = {"cif": (352, 288), "qcif": (176, 144), "ssv": (400, 340)}
DEFAULT_SIZE = SIZES["cif"]
_SIZE_RULE = f"width and height must be even numbers in {MIN_SIDE}..{MAX_SIDE} pixels, e.g. 352x288, 400x340 or 176x144"


def _size_fits(width: int, height: int) -> bool:
    return MIN_SIDE <= width <= MAX_SIDE and MIN_SIDE <= height <= MAX_SIDE and not width % 2 and not height % 2


def check_size(width: int, height: int, what: str = "--size") -> tuple[int, int]:
    """(width, height) in pixels if both are even and within MIN_SIDE..MAX_SIDE, else SigncastError."""
    if not _size_fits(width, height):
        raise SigncastError(f"bad size {width}x{height} for {what}: {_SIZE_RULE}")
    return width, height


def parse_size(text: str, what: str = "--size") -> tuple[int, int]:
    """'352x288' (or a name: cif, qcif, ssv) -> (width, height) in pixels, within the check_size rule."""
    key = str(text).strip().lower()
    if key in SIZES:
        return SIZES[key]
    try:
        width, height = (int(part) for part in key.split("x"))
    except ValueError:
        raise SigncastError(f"bad size {text!r} for {what}: write WIDTHxHEIGHT, e.g. 352x288, 400x340 or "
                            f"176x144") from None
    if not _size_fits(width, height):
        raise SigncastError(f"bad size {text!r} for {what}: {_SIZE_RULE}")
    return width, height


# --------------------------------------------------------------------------- solutions and codecs
# The seed-002 motion-coding laboratory's coders (comparisons.lab.codecs): waveform coders of each degree of
# freedom and model-based coders. They code the same motion as FBA/BBA but are not MPEG-4 streams, so their
# records carry a solution of their own.
WAVEFORM_NAMES = ("quant", "nuquant", "dpcm", "adpcm", "deadreck", "dct", "wavelet", "wavelet-cx", "svq", "tvq")
MODEL_NAMES = ("posture", "gesture", "hybrid")
MOTION_CODER_NAMES = WAVEFORM_NAMES + MODEL_NAMES

SOURCE_VIDEO = "source video"          # reference: the signer's own video (message fidelity)
LOSSLESS_RENDER = "lossless render"    # reference: the avatar's lossless render (codec loss of an avatar solution)


class Solution(StrEnum):
    """The one list of solutions (DESIGN.md), in the order of tables and legends. A member is its name as a str
    (records and tables carry the name; `Solution("NSV3O+C")` reads one back, unknown names raise ValueError,
    `Solution.of` raises SigncastError).

    kind: "video" (pixels are sent; the objects are the study's choice, not the video codec's) or "parameters"
    (animation parameters the terminal renders). natural: codes the natural video (the NSV family). avatar: carries
    the synthetic signer (SSV, FBA, BBA). reference: what a point's codec loss is matched against: the source video
    for the NSV family, the lossless render for the avatar solutions (and the seed-002 motion coders)."""

    NSV = "NSV"
    NSV2O = "NSV2O"
    NSV3O = "NSV3O"
    NSV3O_C = "NSV3O+C"
    NSV_ROI = "NSV-ROI"      # one H.264 stream, lower quantiser on the face and hands (comparisons/video/roi.py)
    SSV = "SSV"
    FBA = "FBA"
    BBA = "BBA"
    MOTION_CODER = "motion coder"

    @property
    def kind(self) -> str:
        return "parameters" if self in (Solution.FBA, Solution.BBA, Solution.MOTION_CODER) else "video"

    @property
    def natural(self) -> bool:
        return self in (Solution.NSV, Solution.NSV2O, Solution.NSV3O, Solution.NSV3O_C, Solution.NSV_ROI)

    @property
    def roi(self) -> bool:
        """NSV-ROI: region-of-interest coding in one H.264 stream (libx264 only). The MPEG-4 Visual studies (the Q
        sweep, live delivery, compare's series) do not code it, so video() and natural_family() leave it out;
        `signcast video` lists it beside NSV2O/NSV3O when its codecs include libx264."""
        return self is Solution.NSV_ROI

    @property
    def avatar(self) -> bool:
        return self in (Solution.SSV, Solution.FBA, Solution.BBA)

    @property
    def mpeg4_parameters(self) -> bool:
        """FBA or BBA: an MPEG-4 animation stream (a parameter codec's fba-*/bba-* name)."""
        return self in (Solution.FBA, Solution.BBA)

    @property
    def reference(self) -> str:
        return SOURCE_VIDEO if self.natural else LOSSLESS_RENDER

    @classmethod
    def of(cls, name: str, what: str = "solution") -> "Solution":
        """The member named name; SigncastError naming the known ones otherwise."""
        try:
            return cls(str(name))
        except ValueError:
            raise SigncastError(f"unknown {what} {name!r}: choose {', '.join(cls)}") from None

    @classmethod
    def video(cls) -> tuple["Solution", ...]:
        return tuple(s for s in cls if s.kind == "video" and not s.roi)

    @classmethod
    def parameters(cls) -> tuple["Solution", ...]:
        return tuple(s for s in cls if s.kind == "parameters")

    @classmethod
    def natural_family(cls) -> tuple["Solution", ...]:
        return tuple(s for s in cls if s.natural and not s.roi)

    @classmethod
    def avatars(cls) -> tuple["Solution", ...]:
        return tuple(s for s in cls if s.avatar)


FBA, BBA, MOTION_CODER = Solution.FBA, Solution.BBA, Solution.MOTION_CODER
VIDEO_SOLUTIONS = Solution.video()
PARAMETER_SOLUTIONS = Solution.parameters()
SOLUTION_ORDER = tuple(Solution)          # the order of tables and legends


def is_mpeg4_parameters(solution: str) -> bool:
    """Whether a solution's name is FBA or BBA (a record's or a table's solution field)."""
    return solution in (Solution.FBA, Solution.BBA)


def kbps(bits: float, duration_s: float) -> float:
    """The rate of bits sent over duration_s seconds, in kbit/s (1 kbit = 1000 bits); ValueError for a duration
    that is not positive."""
    if not duration_s > 0:
        raise ValueError(f"a rate needs a positive duration, got {duration_s!r} s")
    return bits / duration_s / 1000.0


def solution_of(codec: str) -> Solution:
    """The solution a parameter codec's records belong to: fba-* -> FBA, bba-* -> BBA, a seed-002 motion coder
    -> MOTION_CODER. Video codecs (mpeg4, libx264, ...) serve several solutions, so they and unknown names raise
    SigncastError."""
    name = str(codec)
    if name.startswith("fba-"):
        return Solution.FBA
    if name.startswith("bba-"):
        return Solution.BBA
    if name in MOTION_CODER_NAMES:
        return Solution.MOTION_CODER
    raise SigncastError(f"no solution for codec {name!r}: parameter codecs are fba-*, bba-* or a motion coder "
                        f"({', '.join(MOTION_CODER_NAMES)}); a video codec's solution is the study's "
                        f"({', '.join(VIDEO_SOLUTIONS)})")

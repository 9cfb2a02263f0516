"""media.domain: one definition of the part labels, colours, frame-rate / Q / size rules and the codec -> solution
rule, and every command and coder using it with the same one-line messages."""
import math
from pathlib import Path

import numpy as np
import pytest

from kernels.raster import FLAT_PALETTE, SHADED_ALBEDO
from media import domain
from media.domain import (BACKGROUND, BBA, BODY, FBA, HEAD, LEFT_HAND, MOTION_CODER, PART_NAMES, RIGHT_HAND,
                          SKIN_PARTS, SOLUTION_ORDER, check_fps, check_q, check_size, parse_qs, parse_size,
                          solution_of)
from media.errors import SigncastError
from pipeline.cli import main

FPS_RULE = "choose a frame rate in (0, 240] frames per second, e.g. 10, 15, 20 or 25"
Q_RULE = "MPEG-4 quantisers are 1..31, whole numbers"
SIZE_RULE = "width and height must be even numbers in 32..1920 pixels, e.g. 352x288, 400x340 or 176x144"


def _tree(folder: Path) -> set[str]:
    return {str(p.relative_to(folder)) for p in folder.rglob("*")}


def _one_line_error(capsys, argv) -> str:
    code = main([str(a) for a in argv])
    error = capsys.readouterr().err.strip()
    assert code == 2 and len(error.splitlines()) == 1 and "Traceback" not in error, error
    prefix = f"signcast {argv[0]}: error: "
    assert error.startswith(prefix)
    return error[len(prefix):]


# --------------------------------------------------------------------------- part labels and colours

def test_part_labels_are_the_design_labels_and_every_module_uses_them():
    assert (BACKGROUND, BODY, HEAD, LEFT_HAND, RIGHT_HAND) == (0, 1, 2, 3, 4)
    assert PART_NAMES == {0: "background", 1: "body", 2: "head", 3: "left_hand", 4: "right_hand"}
    assert SKIN_PARTS == (2, 3, 4)
    from media import segmentation
    assert (segmentation.BACKGROUND, segmentation.BODY, segmentation.HEAD, segmentation.LEFT_HAND,
            segmentation.RIGHT_HAND, segmentation.SKIN_PARTS) == (0, 1, 2, 3, 4, SKIN_PARTS)
    import media.avatar
    assert not hasattr(media.avatar, "PART_HEAD") and not hasattr(media.avatar, "SKIN_PARTS")


def test_the_renderers_colours_are_the_kernels_palette_read_by_part_label():
    assert domain.SKIN_TONE == (226, 176, 146) == tuple(SHADED_ALBEDO[HEAD]) == tuple(SHADED_ALBEDO[LEFT_HAND])
    assert domain.CLOTHES == (46, 52, 70) == tuple(SHADED_ALBEDO[BODY])
    assert domain.FLAT_PALETTE is FLAT_PALETTE and len(FLAT_PALETTE) == len(PART_NAMES)
    assert set(domain.OVERLAY_COLOURS) == {BODY, *SKIN_PARTS}

    from media.avatar import load_avatar
    from media.render import triangle_colours
    avatar = load_avatar()
    colours = triangle_colours(avatar)
    not_eyes = avatar.triangle_shape == 0           # the skin (brows, lashes and hair are shapes of their own)
    assert np.all(colours[(avatar.triangle_part == BODY) & not_eyes] == domain.CLOTHES)
    assert np.all(colours[np.isin(avatar.triangle_part, SKIN_PARTS) & not_eyes] == domain.SKIN_TONE)
    eyes = colours[np.isin(avatar.triangle_shape, [avatar.shape_names.index(n) for n in ("left_eye", "right_eye")])]
    assert {tuple(c) for c in eyes} == {domain.EYE_WHITE, domain.IRIS}


# --------------------------------------------------------------------------- frame rate

@pytest.mark.parametrize("fps", [25, 0.5, 240, np.float32(10.0), np.int64(15)])
def test_check_fps_accepts_rates_in_the_range_as_float(fps):
    assert check_fps(fps) == float(fps) and type(check_fps(fps)) is float


@pytest.mark.parametrize("fps, shown", [(0, "0"), (-1.0, "-1.0"), (240.5, "240.5"), (1000.0, "1000.0"),
                                        (math.nan, "nan"), (math.inf, "inf"), ("25", "25"), (True, "True"),
                                        (None, "None")])
def test_check_fps_refuses_with_one_message_naming_value_and_range(fps, shown):
    with pytest.raises(SigncastError) as error:
        check_fps(fps, "--fps")
    assert str(error.value) == f"bad --fps {shown}: {FPS_RULE}"


def test_motion_and_fingerspelling_use_the_same_frame_rate_rule():
    from media.fingerspelling import fingerspell
    from media.motion import Motion, resample
    motion = Motion.rest(("root",), 3)
    for fps in (0, 241, math.nan):
        with pytest.raises(SigncastError, match=r"^bad frame rate .*: choose a frame rate in \(0, 240\] "):
            resample(motion, fps)
        with pytest.raises(SigncastError, match=r"^bad frame rate .*: choose a frame rate in \(0, 240\] "):
            fingerspell("ase", "A", fps)
    assert resample(motion, 240).fps == 240.0


# every command that takes one --fps, with arguments that keep its work small; {out} is the output
FPS_COMMANDS = {
    "analyze": ["analyze", "ase", "--out", "{out}"],
    "motion": ["motion", "ase", "A", "-o", "{out}.bvh"],
    "params": ["params", "ase", "A", "--codecs", "fba-pred", "--param-q", "31", "--out", "{out}"],
    "render": ["render", "ase", "A", "--size", "32x32", "-o", "{out}.mkv"],
    "video": ["video", "--video", "carphone", "--frames", "4", "--video-q", "12", "--video-codecs", "none", "--out", "{out}"],
    "video --ssv": ["video", "--ssv", "ase", "A", "--frames", "4", "--video-q", "12", "--video-codecs", "none", "--out", "{out}"],
}


@pytest.mark.parametrize("fps", ["0", "1000", "nan"])
@pytest.mark.parametrize("command", list(FPS_COMMANDS))
def test_every_command_refuses_a_bad_fps_with_the_same_message_before_writing(tmp_path, capsys, command, fps):
    argv = [a.format(out=tmp_path / "out") for a in FPS_COMMANDS[command]] + ["--fps", fps]
    assert _one_line_error(capsys, argv) == f"bad --fps {float(fps)}: {FPS_RULE}"
    assert _tree(tmp_path) == set()


def test_parameter_studies_take_the_same_frame_rates_as_everything_else(tmp_path, capsys):
    """No lower cap for `params`/`analyze` (it was 60): FBA streams signal 8-bit rates and sixteenths."""
    from comparisons.params.coding import fps_from_fields, frame_rate_fields
    assert fps_from_fields(*frame_rate_fields(domain.MAX_FPS)) == domain.MAX_FPS
    out = tmp_path / "out"
    assert main(["params", "ase", "A", "--codecs", "fba-pred", "--param-q", "31", "--fps", "100", "--out", str(out)]) == 0
    from comparisons.reports.records import read_records
    assert {r["fps"] for r in read_records(out / "records.jsonl")} == {100.0}


# --------------------------------------------------------------------------- quantiser

@pytest.mark.parametrize("q", [1, 12, 31, np.int64(4)])
def test_check_q_accepts_integers_1_to_31(q):
    assert check_q(q) == int(q) and type(check_q(q)) is int


@pytest.mark.parametrize("q", [0, 32, -3, 2.5, 12.0, True, "12", None])
def test_check_q_refuses_with_one_message_naming_value_and_range(q):
    with pytest.raises(SigncastError) as error:
        check_q(q, "--q")
    assert str(error.value) == f"bad --q {q}: {Q_RULE}"


def test_parameter_coders_use_the_same_q_rule():
    from comparisons.params import coding as param_coding
    from comparisons.params.codecs import get_codec
    from media.avatar import load_avatar
    from media.motion import Motion
    assert param_coding.check_q is check_q
    motion = Motion.rest(load_avatar().skeleton.names, 3)
    for name in ("fba-pred", "bba-dct"):
        with pytest.raises(SigncastError, match=rf"^bad Q 32: {Q_RULE}$"):
            get_codec(name).encode(motion, 32)


def test_q_lists_parse_and_name_the_first_bad_value():
    assert parse_qs("1, 2,31") == [1, 2, 31]
    for text in ("", " , ", "4,x", "2.5"):
        with pytest.raises(SigncastError) as error:
            parse_qs(text, "--fba-q")
        assert str(error.value) == f"bad --fba-q {text!r}: give comma-separated integers in 1..31"
    with pytest.raises(SigncastError, match=rf"^bad --q 40: {Q_RULE}$"):
        parse_qs("4,40,0")


@pytest.mark.parametrize("argv, option, q", [
    (["params", "ase", "A", "--codecs", "fba-pred", "--param-q", "4,0"], "--param-q", 0),
    (["lab", "ase", "--codecs", "dct", "--param-q", "32"], "--param-q", 32),
    (["video", "--video", "carphone", "--video-q", "12,0"], "--video-q", 0),
])
def test_commands_refuse_a_bad_q_with_the_same_message(tmp_path, capsys, argv, option, q):
    assert _one_line_error(capsys, [*argv, "--out", tmp_path / "out"]) == f"bad {option} {q}: {Q_RULE}"
    assert _tree(tmp_path) == set()


# --------------------------------------------------------------------------- frame size

def test_sizes_parse_by_name_or_width_x_height():
    assert parse_size("352x288") == (352, 288) and parse_size(" QCIF ") == (176, 144) and parse_size("ssv") == (400, 340)
    assert parse_size("32x1920") == (32, 1920)
    assert domain.DEFAULT_SIZE == (352, 288) and all(check_size(*size) == size for size in domain.SIZES.values())


@pytest.mark.parametrize("text, message", [
    ("352by288", "bad size '352by288' for --size: write WIDTHxHEIGHT, e.g. 352x288, 400x340 or 176x144"),
    ("353x288", f"bad size '353x288' for --size: {SIZE_RULE}"),
    ("30x30", f"bad size '30x30' for --size: {SIZE_RULE}"),
    ("1922x1080", f"bad size '1922x1080' for --size: {SIZE_RULE}"),
])
def test_bad_sizes_name_the_value_and_the_rule(text, message):
    with pytest.raises(SigncastError) as error:
        parse_size(text)
    assert str(error.value) == message
    with pytest.raises(SigncastError, match=f"^bad size 7x8 for --max-size: {SIZE_RULE}$"):
        check_size(7, 8, "--max-size")


def test_commands_and_renderer_share_the_one_size_rule():
    import media.render
    from pipeline import checks
    assert not hasattr(checks, "parse_size") and not hasattr(checks, "check_size")   # one rule: media.domain's
    assert not hasattr(media.render, "parse_size") and media.render.DEFAULT_SIZE == domain.DEFAULT_SIZE


# --------------------------------------------------------------------------- codec -> solution

def test_every_parameter_codec_belongs_to_one_solution():
    from comparisons.lab.codecs import LAB_CODEC_NAMES
    from comparisons.params.codecs import codec_names
    solutions = {name: solution_of(name) for name in codec_names()}
    assert {n for n, s in solutions.items() if s == FBA} == {"fba-pred", "fba-dct"}
    assert {n for n, s in solutions.items() if s == BBA} == {"bba-pred", "bba-dct", "bba-key"}
    assert {n for n, s in solutions.items() if s == MOTION_CODER} == set(LAB_CODEC_NAMES)
    assert solution_of("dpcm") == "motion coder" != FBA
    assert set(solutions.values()) <= set(SOLUTION_ORDER)


@pytest.mark.parametrize("codec", ["mpeg4", "libx264", "zip"])
def test_video_and_unknown_codecs_have_no_solution_of_their_own(codec):
    with pytest.raises(SigncastError, match=rf"^no solution for codec '{codec}': parameter codecs are fba-\*, bba-\*"):
        solution_of(codec)


def test_the_report_orders_every_solution_and_the_criteria_cover_the_sources_six():
    from comparisons.judging.criteria import SOLUTIONS
    from comparisons.reports.comparison import SOLUTION_ORDER as REPORT_ORDER
    assert REPORT_ORDER is SOLUTION_ORDER
    assert SOLUTION_ORDER == ("NSV", "NSV2O", "NSV3O", "NSV3O+C", "NSV-ROI", "SSV", "FBA", "BBA", "motion coder")
    assert [s for s in SOLUTION_ORDER if s in SOLUTIONS] == list(SOLUTIONS)

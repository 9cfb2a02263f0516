"""Every CLI error is one line on stderr and exit code 2, found before the work, with nothing left behind:
bad frame sizes, too much memory, unwritable output, an existing file as --out, a non-empty --out, unknown
codecs; and the smaller conventions (--version, --force, --no-progress, a sub-command's own usage)."""
import subprocess
import sys
from pathlib import Path

import pytest

from comparisons.reports.records import make_record, read_records

from pipeline.outputs import write_records
from media.errors import SigncastError
from pipeline.cli import main
from pipeline.outputs import MANIFEST, output_folder

ROOT = Path(__file__).resolve().parents[1]
READ_ONLY = Path("/sys")          # sysfs: creating a file or folder there fails, even for root

# every command that writes an --out folder, with arguments that keep its work small
FOLDER_COMMANDS = {
    "params": ["params", "ase", "AB", "--codecs", "fba-pred", "--param-q", "31"],
    "lab": ["lab", "ase", "--codecs", "dct", "--param-q", "1"],
    "analyze": ["analyze", "ase"],
    "video": ["video", "--video", "carphone", "--frames", "4", "--video-q", "12", "--video-codecs", "none", "--no-progress"],
    "video --ssv": ["video", "--ssv", "ase", "A", "--size", "64x64", "--frames", "4", "--video-q", "12", "--video-codecs",
                    "none", "--no-progress"],
    "compare": ["compare", "ase", "A", "--video-q", "12", "--frame-rates", "25", "--param-q", "31", "--codecs", "fba-pred",
                "--video-codecs", "none", "--size", "64x64", "--no-progress"],
    "demo": ["demo", "ase", "A", "--size", "64x64", "--no-progress"],
}


def _records_file(folder: Path) -> Path:
    return write_records(folder / "in.jsonl", [make_record("NSV", "clip", "mpeg4", 12, 25.0, 176, 144, 80_000, 2.0)])


# every output file a command writes: (arguments with {path}, suffix the file needs)
FILE_COMMANDS = {
    "render -o": (["render", "ase", "A", "--size", "32x32", "-o", "{path}"], ".mkv"),
    "render --labels": (["render", "ase", "A", "--size", "32x32", "-o", "{tmp}/a.mkv", "--labels", "{path}"], ".npz"),
    "render --preview": (["render", "ase", "A", "--size", "32x32", "-o", "{tmp}/a.mkv", "--preview", "{path}"], ".png"),
    "motion -o": (["motion", "ase", "A", "-o", "{path}"], ".bvh"),
    "report -o": (["report", "{records}", "-o", "{path}"], ".html"),
}


def _tree(folder: Path) -> set[str]:
    return {str(p.relative_to(folder)) for p in folder.rglob("*")}


def _fails_with_one_line(capsys, argv, *fragments) -> str:
    code = main([str(a) for a in argv])
    captured = capsys.readouterr()
    error = captured.err.strip()
    assert code == 2, captured
    assert len(error.splitlines()) == 1 and "Traceback" not in error
    assert error.startswith(f"signcast {argv[0]}: error: ")
    for fragment in fragments:
        assert fragment in error
    return error


def _file_argv(name: str, tmp_path: Path, path: Path) -> list[str]:
    arguments, _ = FILE_COMMANDS[name]
    records = _records_file(tmp_path) if name == "report -o" else ""
    return [a.format(path=path, tmp=tmp_path, records=records) for a in arguments]


@pytest.mark.parametrize("command", ["render", "video --ssv", "compare", "demo"])
@pytest.mark.parametrize("size", ["0x0", "7x7", "5000x5000", "353x288"])
def test_bad_frame_size_is_one_line_before_any_output(tmp_path, capsys, command, size):
    argv = {"render": ["render", "ase", "A", "-o", tmp_path / "a.mkv", "--size", size],
            "video --ssv": ["video", "--ssv", "ase", "A", "--size", size, "--out", tmp_path / "out"],
            "compare": ["compare", "ase", "A", "--size", size, "--out", tmp_path / "out"],
            "demo": ["demo", "ase", "A", "--size", size, "--out", tmp_path / "out"]}[command]
    _fails_with_one_line(capsys, argv, "bad size", "even numbers in 32..1920")
    assert _tree(tmp_path) == set()


@pytest.mark.parametrize("command", ["render", "video --ssv", "video --video", "pose", "compare", "demo"])
def test_work_beyond_the_memory_limit_is_refused_with_the_estimate(tmp_path, capsys, monkeypatch, command):
    monkeypatch.setenv("SIGNCAST_MEMORY_LIMIT_MB", "1")
    argv = {"render": ["render", "ase", "AB", "-o", tmp_path / "a.mkv", "--size", "352x288", "--no-progress"],
            "video --ssv": ["video", "--ssv", "ase", "AB", "--size", "352x288", "--video-q", "12", "--video-codecs", "none",
                            "--no-progress", "--out", tmp_path / "out"],
            "video --video": ["video", "--video", "carphone", "--video-q", "12", "--video-codecs", "none",
                              "--no-progress", "--out", tmp_path / "out"],
            "pose": ["pose", "carphone", "-o", tmp_path / "c.pose", "--no-progress"],
            "compare": [*FOLDER_COMMANDS["compare"], "--out", tmp_path / "out"],
            "demo": [*FOLDER_COMMANDS["demo"], "--out", tmp_path / "out"]}[command]
    error = _fails_with_one_line(capsys, argv, "GiB", "limit of 0.00 GiB", "SIGNCAST_MEMORY_LIMIT_MB")
    assert "frames of" in error
    assert _tree(tmp_path) == set()


@pytest.mark.parametrize("place", ["beneath a file", "read-only"])
@pytest.mark.parametrize("command", list(FOLDER_COMMANDS))
def test_unwritable_out_folder_is_one_line_before_the_work(tmp_path, capsys, command, place):
    (tmp_path / "a-file").write_text("not a folder")
    out = tmp_path / "a-file" / "out" if place == "beneath a file" else READ_ONLY / "signcast-out"
    _fails_with_one_line(capsys, [*FOLDER_COMMANDS[command], "--out", out], f"cannot create folder {out}")
    assert _tree(tmp_path) == {"a-file"} and not out.exists()


@pytest.mark.parametrize("command", list(FOLDER_COMMANDS))
def test_existing_folder_that_cannot_take_files_is_refused(tmp_path, capsys, command):
    out = READ_ONLY / "kernel"           # an existing, non-empty folder nobody may write in
    _fails_with_one_line(capsys, [*FOLDER_COMMANDS[command], "--out", out, "--force"], f"cannot write to {out}")


@pytest.mark.parametrize("place", ["beneath a file", "read-only"])
@pytest.mark.parametrize("name", list(FILE_COMMANDS))
def test_unwritable_output_file_is_one_line_before_the_work(tmp_path, capsys, name, place):
    suffix = FILE_COMMANDS[name][1]
    (tmp_path / "a-file").write_text("not a folder")
    path = (tmp_path / "a-file" if place == "beneath a file" else READ_ONLY) / f"signcast{suffix}"
    before = _tree(tmp_path) | ({"in.jsonl"} if name == "report -o" else set())
    _fails_with_one_line(capsys, _file_argv(name, tmp_path, path), "cannot write", str(path))
    assert _tree(tmp_path) == before and not path.exists()


@pytest.mark.parametrize("command", list(FOLDER_COMMANDS))
def test_an_existing_file_as_out_is_refused(tmp_path, capsys, command):
    taken = tmp_path / "taken"
    taken.write_text("mine")
    _fails_with_one_line(capsys, [*FOLDER_COMMANDS[command], "--out", taken], "is a file, not a folder")
    assert taken.read_text() == "mine" and _tree(tmp_path) == {"taken"}


@pytest.mark.parametrize("command", list(FOLDER_COMMANDS))
def test_a_non_empty_out_folder_is_refused_without_force(tmp_path, capsys, command):
    (tmp_path / "notes.txt").write_text("mine")
    _fails_with_one_line(capsys, [*FOLDER_COMMANDS[command], "--out", tmp_path], "is not empty", "--force")
    assert _tree(tmp_path) == {"notes.txt"}


@pytest.mark.parametrize("argv, fragment", [
    (["compare", "ase", "A", "--video-codecs", "bogus"], "bad --video-codecs 'bogus'"),
    (["compare", "ase", "A", "--codecs", "fba-zip"], "unknown parameter codec 'fba-zip'"),
    (["video", "--video", "carphone", "--video-codecs", "h263"], "bad --video-codecs 'h263'"),
    (["video", "--video", "carphone", "--video-codecs", "mpeg4"], "bad --video-codecs 'mpeg4'"),
    (["params", "ase", "AB", "--codecs", "zip"], "unknown parameter codec 'zip'"),
    (["lab", "ase", "--codecs", "zip"], "zip"),
])
def test_unknown_codec_is_one_line_before_the_work(tmp_path, capsys, argv, fragment):
    out = tmp_path / "out"
    _fails_with_one_line(capsys, [*argv, "--out", out], fragment)
    assert not out.exists()


def test_codecs_none_is_accepted_and_codes_no_other_codec(tmp_path, capsys):
    out = tmp_path / "out"
    assert main([str(a) for a in [*FOLDER_COMMANDS["video --ssv"], "--out", out]]) == 0
    points = [r for r in read_records(out / "records.jsonl") if r.get("kind") == "point"]
    assert points and {r["codec"] for r in points} == {"mpeg4"}


def test_a_rerun_needs_force_which_replaces_what_an_earlier_run_wrote_and_keeps_other_files(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["params", "ase", "ABC", "--codecs", "fba-pred", "--param-q", "31", "--out", str(out)]) == 0
    assert sorted(p.name for p in (out / "bap").iterdir()) == ["ase_A.bap", "ase_B.bap", "ase_C.bap"]
    assert "bap/ase_A.bap" in (out / MANIFEST).read_text().splitlines()
    capsys.readouterr()
    _fails_with_one_line(capsys, ["params", "ase", "D", "--out", out], "is not empty", "--force")
    assert sorted(p.name for p in (out / "bap").iterdir()) == ["ase_A.bap", "ase_B.bap", "ase_C.bap"]
    (out / "notes.txt").write_text("mine")
    assert main(["params", "ase", "D", "--codecs", "fba-pred", "--param-q", "31", "--out", str(out), "--force"]) == 0
    assert sorted(p.name for p in (out / "bap").iterdir()) == ["ase_D.bap"]     # an earlier run's files: replaced
    assert {r["clip"] for r in read_records(out / "records.jsonl") if r.get("kind") == "point"} == {"ase:D"}
    assert (out / "notes.txt").read_text() == "mine"
    assert not [p for p in tmp_path.iterdir() if p.name != "out"]                # no temporary folder left


def test_a_run_failing_midway_leaves_the_folder_as_it_was(tmp_path):
    out = tmp_path / "out"
    with pytest.raises(SigncastError):
        with output_folder(out) as partial:
            (partial / "plots").mkdir()
            (partial / "plots" / "half.png").write_bytes(b"\x89PNG")
            (partial / "table.csv").write_text("a,b\n")
            raise SigncastError("damaged stream")
    assert _tree(tmp_path) == set()
    out.mkdir()
    (out / "table.csv").write_text("old\n")
    with pytest.raises(KeyboardInterrupt):
        with output_folder(out, force=True) as partial:
            write_records(partial / "records.jsonl", [make_record("NSV", "clip", "mpeg4", 12, 25.0, 176, 144, 8000, 1.0)])
            (partial / "table.csv").write_text("a,b\n")
            raise KeyboardInterrupt
    assert _tree(tmp_path) == {"out", "out/table.csv"} and (out / "table.csv").read_text() == "old\n"


@pytest.mark.parametrize("name", list(FILE_COMMANDS))
def test_an_existing_output_file_needs_force(tmp_path, capsys, name):
    path = tmp_path / f"taken{FILE_COMMANDS[name][1]}"
    path.write_text("mine")
    _fails_with_one_line(capsys, _file_argv(name, tmp_path, path), f"{path} exists", "--force")
    assert path.read_text() == "mine"


def test_analyze_checks_every_language_before_writing_anything(tmp_path, capsys):
    out = tmp_path / "out"
    _fails_with_one_line(capsys, ["analyze", "ase,xxx", "--out", out], "unknown sign language 'xxx'")
    assert not out.exists()


def test_version_prints_the_installed_version(capsys):
    from importlib.metadata import version
    with pytest.raises(SystemExit) as stop:
        main(["--version"])
    assert stop.value.code == 0 and capsys.readouterr().out.strip() == f"signcast {version('signcast')}"


@pytest.mark.parametrize("argv", [
    ["render", "ase", "A", "-o", "{tmp}/a.mkv", "--bogus"],
    ["render", "ase", "A", "-o", "{tmp}/a.mkv", "--fps", "abc"],
    ["analyze", "ase", "--fps", "abc", "--out", "{tmp}/out"],
    ["video", "--out", "{tmp}/out"],
    ["pose"],
    ["sweep", "--out", "{tmp}/out"],
    ["receive", "--port", "x", "--out", "{tmp}/out"],
    ["lab", "--param-q"],
])
def test_argument_errors_are_one_line_naming_the_help(tmp_path, capsys, argv):
    with pytest.raises(SystemExit) as stop:
        main([a.format(tmp=tmp_path) for a in argv])
    lines = capsys.readouterr().err.strip().splitlines()
    assert stop.value.code == 2 and len(lines) == 1, lines
    assert lines[0].startswith(f"signcast {argv[0]}: error: ") and lines[0].endswith(f"(see signcast {argv[0]} --help)")


def test_every_command_that_can_show_progress_takes_no_progress():
    from pipeline.cli import build_parser
    commands = build_parser()._subparsers._group_actions[0].choices
    without = [name for name, parser in commands.items() if name not in ("lexicon", "report")   # nothing to show
               and "--no-progress" not in parser._option_string_actions]
    assert without == []


def test_render_without_progress_writes_nothing_to_stderr(tmp_path, capsys):
    video = tmp_path / "a.mkv"
    assert main(["render", "ase", "A", "-o", str(video), "--size", "32x32", "--backend", "numpy", "--no-progress"]) == 0
    assert capsys.readouterr().err == "" and video.stat().st_size > 0


def test_out_of_range_q_names_the_range_not_the_operating_point(tmp_path, capsys):
    _fails_with_one_line(capsys, ["video", "--video", "carphone", "--video-q", "0", "--out", tmp_path / "out"],
                         "bad --video-q 0: MPEG-4 quantisers are 1..31")


def test_a_missing_greek_capital_is_quoted_as_written(tmp_path, capsys):
    _fails_with_one_line(capsys, ["motion", "ase", "ΑΒ", "-o", tmp_path / "a.bvh"], "no letter 'Α'")


def test_unwritable_output_exits_2_without_a_traceback_from_the_shell(tmp_path):
    """The real process: exit status and stderr as a user sees them."""
    path = READ_ONLY / "a.mkv"
    result = subprocess.run([sys.executable, "-m", "pipeline.cli", "render", "ase", "A", "-o", str(path)],
                            cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert result.returncode == 2 and result.stdout == ""
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"signcast render: error: cannot write video {path}: ")


def test_a_letter_outside_the_alphabet_is_spelled_as_its_base_letter_with_a_notice(tmp_path, capsys):
    from media import lexicon
    assert lexicon.substitutions("ase", "HÉLLO") == [("É", "E")] and lexicon.substitutions("ase", "HELLO") == []
    assert main(["motion", "ase", "HÉLLO", "-o", str(tmp_path / "h.bvh")]) == 0
    assert "'É' is not a letter of the ase alphabet: spelled as 'E'" in capsys.readouterr().err


def test_render_to_mp4_is_refused_naming_mkv_and_a_pose_preview_in_mp4_is_h264(tmp_path, capsys):
    _fails_with_one_line(capsys, ["render", "ase", "A", "-o", tmp_path / "x.mp4"], "FFV1", "name it .mkv")
    assert _tree(tmp_path) == set()
    import av
    preview = tmp_path / "p.mp4"
    assert main(["pose", "carphone", "-o", str(tmp_path / "c.pose"), "--frames", "2", "--preview", str(preview),
                 "--no-progress"]) == 0
    with av.open(str(preview)) as container:
        assert container.streams.video[0].codec_context.name == "h264"


def test_max_size_is_an_upper_limit_accepting_anything_above_the_clip(tmp_path, capsys):
    from pipeline.commands.options import parse_max_size
    assert parse_max_size("5000x5000") == (5000, 5000) and parse_max_size("353x289") == (353, 289)
    assert parse_max_size("none") is None and parse_max_size("cif") == (352, 288)
    for bad, fragment in (("30x5000", "at least 32"), ("big", "write WIDTHxHEIGHT")):
        with pytest.raises(SigncastError, match=fragment):
            parse_max_size(bad)
    assert main(["pose", "carphone", "-o", str(tmp_path / "c.pose"), "--frames", "2", "--max-size", "5000x5000",
                 "--no-progress"]) == 0
    assert "176x144" in capsys.readouterr().out


def test_a_truncated_video_is_refused_in_words(tmp_path, capsys):
    import numpy as np

    from media.video_io import write_video
    whole = tmp_path / "whole.mp4"
    write_video(whole, np.zeros((10, 64, 64, 3), np.uint8), 25, codec="libx264")
    cut = tmp_path / "cut.mp4"
    cut.write_bytes(whole.read_bytes()[:whole.stat().st_size // 3])
    error = _fails_with_one_line(capsys, ["pose", cut, "-o", tmp_path / "c.pose"], f"cannot decode video {cut}: ",
                                 "damaged, truncated or not a video")
    assert "Errno" not in error and "InvalidDataError" not in error


def test_video_states_what_video_q_must_contain(tmp_path, capsys):
    from pipeline.commands.video import OPERATING_Q
    from pipeline.studies.video import VideoSweep
    assert OPERATING_Q == VideoSweep().operating_q
    _fails_with_one_line(capsys, ["video", "--video", "carphone", "--video-q", "6", "--out", tmp_path / "out"],
                         "--video-q must include 12", "(e.g. --video-q 6,12)")
    with pytest.raises(SystemExit):
        main(["video", "--help"])
    assert "must include 12" in " ".join(capsys.readouterr().out.split())
    assert "`--video-q` must include 12" in (ROOT / "README.md").read_text()


def test_param_q_limits_the_seed_002_coders_alike_in_lab_and_params(tmp_path, capsys):
    from comparisons.lab.codecs import codec_qs
    from pipeline.studies import lab, params
    assert codec_qs("dpcm", (2, 31)) == (2,) and codec_qs("fba-pred", (2, 31)) == (2, 31)
    assert codec_qs("dpcm", None) == tuple(range(1, 8))
    limited = lab.LabSettings(("ase",), ("dpcm", "fba-pred"), (2, 31), limit_coders=True)
    assert lab.total_points(limited) == 3
    assert lab.total_points(lab.LabSettings(("ase",), ("dpcm", "fba-pred"), (2, 31))) == 7 + 2   # lab's default
    assert params.count_points(params.ParamsSettings("ase", "AB", ("dpcm", "fba-pred"), (2, 31))) == 2 * 3
    for command in (["lab", "ase"], ["params", "ase", "A"]):
        _fails_with_one_line(capsys, [*command, "--codecs", "dpcm", "--param-q", "31", "--out", tmp_path / "out"],
                             "--param-q 31 holds none of dpcm's operating points 1..7")
    assert not (tmp_path / "out").exists()

"""Every `signcast` command builds the whole parser first: building it must not import the coders and
their SciPy dependencies (over a second before any command starts), only what the parsers show."""
import subprocess
import sys

HEAVY = ("comparisons.lab.codecs", "comparisons.lab.model", "scipy.signal", "scipy.stats", "warp", "av")


def test_building_the_command_line_imports_no_coder_nor_scipy():
    probe = ("import sys; from pipeline.cli import build_parser; build_parser(); "
             f"print(','.join(name for name in {HEAVY!r} if name in sys.modules))")
    result = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    assert result.stdout.strip() == ""


def test_the_lab_defaults_the_parser_shows_are_the_labs():
    from comparisons.lab import codecs as lab_codecs
    from comparisons.lab.settings import DEFAULT_CODECS, EVALUATION_LANGUAGES, MPEG4_CODECS
    from pipeline.cli import build_parser
    from pipeline.studies import lab

    assert lab.LabSettings().codecs == DEFAULT_CODECS == tuple(lab_codecs.LAB_CODEC_NAMES) + MPEG4_CODECS
    assert lab.LabSettings().languages == EVALUATION_LANGUAGES
    args = build_parser().parse_args(["lab", "--out", "unused"])
    assert args.languages == ",".join(EVALUATION_LANGUAGES) and args.codecs == ",".join(DEFAULT_CODECS)

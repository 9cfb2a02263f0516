"""Outputs are never lost (issue 38): a run writes into a temporary folder beside --out, moved into place only when
it succeeds; a failed or interrupted run (a real process sent SIGINT) leaves the old results as they were."""
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from media.errors import SigncastError
from pipeline.outputs import MANIFEST, PARTIAL, output_folder

ROOT = Path(__file__).resolve().parents[1]


def _contents(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def test_results_appear_only_when_the_run_succeeds(tmp_path):
    out = tmp_path / "a" / "out"
    with output_folder(out) as partial:
        assert partial.parent == out.parent.resolve() and partial.name.startswith(f".out{PARTIAL}")
        (partial / "sub").mkdir()
        (partial / "sub" / "x.csv").write_text("x")
        assert not out.exists()
    assert _contents(out) == {MANIFEST: b"sub/x.csv\n", "sub/x.csv": b"x"}
    assert sorted(p.name for p in out.parent.iterdir()) == ["out"]
    umask = os.umask(0)
    os.umask(umask)
    assert out.stat().st_mode & 0o777 == 0o777 & ~umask              # not mkdtemp's 0700


def test_force_replaces_an_earlier_runs_files_and_keeps_the_others(tmp_path):
    out = tmp_path / "out"
    with output_folder(out) as partial:
        (partial / "old.csv").write_text("old")
        (partial / "same.csv").write_text("old")
    (out / "notes.txt").write_text("mine")
    with pytest.raises(SigncastError, match="is not empty"):
        with output_folder(out):
            pass
    with output_folder(out, force=True) as partial:
        (partial / "same.csv").write_text("new")
    assert _contents(out) == {MANIFEST: b"same.csv\n", "notes.txt": b"mine", "same.csv": b"new"}


def test_an_empty_existing_folder_is_used_without_force(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    with output_folder(out) as partial:
        (partial / "a.csv").write_text("a")
    assert _contents(out) == {MANIFEST: b"a.csv\n", "a.csv": b"a"}


def _signcast(*argv) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "pipeline.cli", *map(str, argv)], cwd=ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def test_an_interrupted_rerun_leaves_the_old_results_intact(tmp_path):
    """A real `signcast params` over old results, sent SIGINT while it works: exit 130, the old files byte for byte,
    no temporary folder left."""
    out = tmp_path / "out"
    first = _signcast("params", "ase", "A", "--codecs", "fba-pred", "--param-q", "31", "--no-progress", "--out", out)
    assert first.wait(timeout=600) == 0, first.stderr.read()
    before = _contents(out)
    assert "records.jsonl" in before and "bap/ase_A.bap" in before
    rerun = _signcast("params", "ase", "ABCDEFGHIKLMNOPQRSTUVWXY", "--codecs", "fba-pred,fba-dct,bba-pred,bba-dct",
                      "--param-q", "1,2,4,8,16,31", "--no-progress", "--out", out, "--force")
    deadline = time.monotonic() + 300
    partial = None
    while time.monotonic() < deadline and rerun.poll() is None:      # wait until it has written new results
        partial = next((p for p in tmp_path.iterdir() if PARTIAL in p.name), None)
        if partial is not None and any(p.is_file() for p in partial.rglob("*")):
            break
        time.sleep(0.1)
    assert rerun.poll() is None and partial is not None, "the re-run ended before it could be interrupted"
    rerun.send_signal(signal.SIGINT)
    _, stderr = rerun.communicate(timeout=120)
    assert rerun.returncode == 130, stderr
    assert stderr.strip().splitlines()[-1] == "signcast params: interrupted"
    assert _contents(out) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]

"""`signcast sweep` on real lexicon clips: the local pool and Ray write the same records, an interrupted sweep
resumes without measuring a point twice, a failing point is recorded with its reason while the others complete,
the report is built from the records, and bad input is one line before any work."""
import json
import sys
from pathlib import Path

import pytest

from comparisons.reports import sweep as sweep_report
from comparisons.reports.records import make_record, read_records
from pipeline.outputs import write_records
from pipeline.cli import main
from pipeline.outputs import MANIFEST
from pipeline.studies import sweep

SMALL = ["sweep", "--languages", "ase", "--items", "A,B", "--codecs", "fba-pred,bba-pred", "--q", "4,16", "--fps", "10",
         "--no-progress"]


def _measured(folder: Path) -> list[dict]:
    """The point and failed records of a sweep folder."""
    return [r for r in read_records(folder / sweep.RECORDS) if r["kind"] in ("point", "failed")]


def _without_timing(records: list[dict]) -> dict[str, dict]:
    return {r["task"]: {k: v for k, v in r.items() if k not in sweep.TIMING_FIELDS} for r in records}


@pytest.mark.slow
def test_local_and_ray_executors_write_the_same_records(tmp_path, capsys, check_png):
    import ray
    assert main([*SMALL, "--executor", "local", "--workers", "2", "--out", str(tmp_path / "local")]) == 0
    assert main([*SMALL, "--executor", "ray", "--workers", "2", "--out", str(tmp_path / "ray")]) == 0
    assert not ray.is_initialized()                                   # shut down, no Ray left running
    local, on_ray = _measured(tmp_path / "local"), _measured(tmp_path / "ray")
    assert len(local) == 2 * 2 * 2 and all(r["kind"] == "point" for r in local)
    assert len({r["task"] for r in local}) == len(local)
    assert _without_timing(local) == _without_timing(on_ray)
    assert {r["solution"] for r in local} == {"FBA", "BBA"}
    runs = [r for r in read_records(tmp_path / "ray" / sweep.RECORDS) if r["kind"] == "run"]
    assert [r["executor"] for r in runs] == ["ray"] and runs[0]["workers"] == 2
    # the matched point of each item and codec lies between the kbps of the Q that brackets it
    for matched in sweep_report.matched_points(local):
        rates = {r["q"]: r["kbps"] for r in local if r["item"] == matched["item"] and r["codec"] == matched["codec"]}
        assert min(rates.values()) <= matched["kbps"] <= max(rates.values())
    page = (tmp_path / "local" / "report.html").read_text()
    assert "median kbps at the matched operating point" in page and "joint position error" in page
    assert "data:image/png;base64," in page
    check_png(tmp_path / "local" / "sweep_kbps.png", (700, 360))        # one frame rate: 7 x 3.6 in at 100 dpi
    assert "fba-pred" in capsys.readouterr().out


def test_an_interrupted_sweep_resumes_and_measures_each_point_once(tmp_path, capsys):
    out = tmp_path / "out"
    argv = ["sweep", "--languages", "ase", "--items", "A,B", "--codecs", "fba-pred", "--q", "4,16", "--fps", "10",
            "--workers", "1", "--no-progress", "--out", str(out)]
    assert main([*argv, "--max-units", "1"]) == 0
    first = _measured(out)
    assert len(first) == 2 and "2 left" in capsys.readouterr().out
    with (out / sweep.RECORDS).open("a") as records:                   # killed in the middle of a write
        records.write('{"schema": 2, "kind": "point", "solution": "FBA", "clip": "ase:')
    assert main(argv) == 0
    assert "2 points measured, 0 failed, 2 finished earlier" in capsys.readouterr().out
    resumed = _measured(out)
    assert len(resumed) == 4 and len({r["task"] for r in resumed}) == 4
    assert resumed[:2] == first                                          # kept as written, not measured again
    assert {(r["item"], r["q"]) for r in resumed} == {("A", 4), ("A", 16), ("B", 4), ("B", 16)}
    lines = (out / sweep.RECORDS).read_text()
    assert main(argv) == 0
    assert "0 points measured, 0 failed, 4 finished earlier" in capsys.readouterr().out
    assert _measured(out) == resumed
    assert (out / sweep.RECORDS).read_text() == lines                  # a re-run with nothing to do adds no line
    assert main([*argv, "--force"]) == 0                                   # starts over
    assert "4 points measured, 0 failed, 0 finished earlier" in capsys.readouterr().out
    assert len(_measured(out)) == 4


def test_a_failing_point_is_recorded_with_its_reason_and_the_others_complete(tmp_path, capsys):
    out = tmp_path / "out"
    argv = ["sweep", "--languages", "ase", "--items", "A", "--codecs", "fba-pred", "--q", "4", "--fps", "0.5,10",
            "--workers", "2", "--no-progress", "--out", str(out)]
    assert main(argv) == 0                       # FBA streams cannot signal 0.5 frames/s; 10 frames/s is measured
    records = _measured(out)
    failed = [r for r in records if r["kind"] == "failed"]
    assert [r["fps"] for r in failed] == [0.5] and "cannot be signalled" in failed[0]["reason"]
    assert [(r["kind"], r["fps"]) for r in records if r["kind"] == "point"] == [("point", 10.0)]
    assert "cannot be signalled" in (out / "report.html").read_text()
    assert main(argv) == 0                                                 # failed points are retried
    retried = _measured(out)
    assert sorted(r["kind"] for r in retried) == ["failed", "point"] and len({r["task"] for r in retried}) == 2
    capsys.readouterr()
    assert main([*argv, "--skip-failed"]) == 0
    assert "0 points measured, 0 failed, 2 finished earlier" in capsys.readouterr().out


def test_task_keys_are_stable_and_name_every_parameter():
    settings = sweep.SweepSettings(("ase", "gsg"), ("A", "B", "ab"), ("fba-pred", "bba-dct"), (4, 16), (10.0, 25.0))
    units = sweep.plan(settings, version="v1")
    keys = [p.task for u in units for p in u.points]
    assert len(units) == 2 * 3 and len(keys) == len(set(keys)) == 2 * 3 * 2 * 2 * 2
    assert keys == [p.task for u in sweep.plan(settings, version="v1") for p in u.points]
    assert set(keys).isdisjoint(p.task for u in sweep.plan(settings, version="v2") for p in u.points)
    assert [u.word for u in units[:3]] == [False, False, True]                          # "ab" is spelled
    assert [(p.fps, p.codec, p.q) for p in units[0].points][:3] == [(10.0, "fba-pred", 4), (10.0, "fba-pred", 16),
                                                                   (10.0, "bba-dct", 4)]
    assert sweep.task_key("ase", "A", "fba-pred", 4, 10, "FBA", "v1") == sweep.task_key("ase", "A", "fba-pred", 4,
                                                                                         10.0, "FBA", "v1")


@pytest.mark.parametrize("extra, fragment", [
    (["--languages", "xxx"], "unknown sign language 'xxx'"),
    (["--items", "A,Ω"], "cannot fingerspell 'Ω' in ase"),
    (["--codecs", "fba-zip"], "unknown parameter codec 'fba-zip'"),
    (["--q", "0"], "bad --q 0"),
    (["--q", "4,x"], "bad --q '4,x'"),
    (["--fps", "0"], "bad --fps 0"),
    (["--fps", "fast"], "bad --fps 'fast'"),
    (["--executor", "dask"], "unknown --executor 'dask'"),
    (["--address", "10.0.0.1:6379"], "--address joins a Ray cluster: use it with --executor ray"),
    (["--workers", "0"], "bad --workers '0'"),
    (["--max-units", "-1"], "bad --max-units '-1'"),
])
def test_bad_input_is_one_line_before_any_work(tmp_path, capsys, extra, fragment):
    out = tmp_path / "out"
    argv = ["sweep", "--languages", "ase", "--items", "A", "--out", str(out), *extra]
    assert main(argv) == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and error.startswith("signcast sweep: error: ") and fragment in error
    assert not out.exists()


def test_an_unwritable_or_foreign_out_is_refused_before_any_work(tmp_path, capsys):
    (tmp_path / "a-file").write_text("mine")
    cases = [(tmp_path / "a-file" / "out", "cannot create folder"), (tmp_path / "a-file", "is a file, not a folder"),
             (tmp_path, "is not empty")]
    signcast_folder = tmp_path / "params-run"                  # another command's records, listed in its manifest
    write_records(signcast_folder / sweep.RECORDS, [make_record("FBA", "ase:A", "fba-pred", 4, 10, 0, 0, 800, 1.0)])
    (signcast_folder / MANIFEST).write_text(f"{sweep.RECORDS}\n")
    cases.append((signcast_folder, "signcast sweep did not write"))
    for out, fragment in cases:
        assert main(["sweep", "--languages", "ase", "--items", "A", "--out", str(out)]) == 2
        error = capsys.readouterr().err.strip()
        assert len(error.splitlines()) == 1 and fragment in error, error
    assert json.loads((signcast_folder / sweep.RECORDS).read_text())["clip"] == "ase:A"


def test_an_unreachable_ray_cluster_is_one_line(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["sweep", "--languages", "ase", "--items", "A", "--executor", "ray", "--address", "127.0.0.1:9",
                 "--out", str(out)]) == 2
    error = capsys.readouterr().err.strip()
    assert error == "signcast sweep: error: cannot reach the Ray cluster at 127.0.0.1:9: Connection refused"
    assert not out.exists()


def test_a_sweep_larger_than_one_records_file_is_refused_before_any_work(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["sweep", "--languages", "all", "--q", "1,2,4,8,16,31", "--out", str(out)]) == 2
    error = capsys.readouterr().err.strip()
    assert "a sweep of 37560 points is more than one records file holds" in error and not out.exists()


def test_points_of_another_version_are_refused_before_any_work(tmp_path, capsys):
    """A records file the sweep cannot mix: points keyed under another code version (measured before TASK_VERSION
    changed what a point measures, or by another signcast) would sit in the report beside re-measured ones."""
    out = tmp_path / "out"
    old_key = sweep.task_key("ase", "A", "fba-pred", 4, 10.0, "FBA", "signcast 0.1, sweep task 1")
    write_records(out / sweep.RECORDS, [make_record("FBA", "ase:A", "fba-pred", 4, 10.0, 0, 0, 800, 1.0, task=old_key,
                                                    language="ase", item="A")])
    (out / MANIFEST).write_text(f"{sweep.RECORDS}\n")
    assert main(["sweep", "--languages", "ase", "--items", "A", "--codecs", "fba-pred", "--q", "4", "--fps", "10",
                 "--out", str(out)]) == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and "1 points measured by another version" in error, error
    assert len(read_records(out / sweep.RECORDS)) == 1                 # left as it was
    current = dict(read_records(out / sweep.RECORDS)[0], task=sweep.task_key(
        "ase", "A", "fba-pred", 4, 10.0, "FBA", sweep.code_version()))
    assert sweep.stale_records([current]) == [] and len(sweep.stale_records([current], "signcast 0.1")) == 1


def _item_points(codec: str, joint_mm: dict[int, float], face_mm: dict[int, float] | None, face_sent: bool = True
                 ) -> list[dict]:
    """Point records of one item and codec at Q 1, 4, 16, 31 (kbps falling with Q), with the given errors."""
    records = []
    for q, bits in ((1, 40_000), (4, 20_000), (16, 10_000), (31, 5_000)):
        fields = {"joint_error_mm_mean": joint_mm[q]}
        if face_mm is not None:
            fields |= {"face_sent": face_sent, "face_joint_error_mm_p90": face_mm[q]}
        records.append(make_record(sweep.solution_of(codec), "ase:A", codec, q, 25.0, 0, 0, bits, 1.0,
                                   language="ase", item="A", **fields))
    return records


def test_the_matched_point_holds_the_face_where_the_motion_has_one():
    """The body's mean joint error cannot see the face: the matched point also keeps each frame's worst face point
    within FACE_ERROR_MM (90th percentile over frames). A coder that does not send the face misses it wherever the
    face moves more than that, however good its body; a motion without a face is matched on the body alone."""
    body = {1: 0.2, 4: 0.8, 16: 1.6, 31: 4.0}                          # meets 2 mm down to Q 16
    face_binding = {1: 0.1, 4: 0.5, 16: 2.5, 31: 3.0}                  # the face misses from Q 16 on
    faceless = {q: 6.0 for q in body}                                  # the face at rest: 6 mm off
    records = (_item_points("fba-dct", body, face_binding) + _item_points("quant", body, faceless, face_sent=False)
               + [dict(r, item="B", clip="ase:B") for r in _item_points("fba-pred", body, None)])
    matched = {(m["item"], m["codec"]): m for m in sweep_report.matched_points(records)}
    face_bound = matched[("A", "fba-dct")]
    assert face_bound["reached"] and (face_bound["q_met"], face_bound["q_missed"]) == (4, 16)
    # linear in log-rate between Q 4 (0.5 mm, 20 kbps) and Q 16 (2.5 mm, 10 kbps): 2 mm three quarters of the way
    assert face_bound["kbps"] == pytest.approx(10 * 2 ** 0.25)
    assert not matched[("A", "quant")]["reached"]
    body_only = matched[("B", "fba-pred")]
    assert body_only["reached"] and (body_only["q_met"], body_only["q_missed"]) == (16, 31)
    assert sweep_report.criteria(records[:4]) == [sweep_report.CRITERION, sweep_report.FACE_CRITERION]
    assert "worst face point" in sweep_report.summary_text(sweep_report.cells(list(matched.values())))


def test_ray_is_an_optional_extra_and_its_absence_is_one_line(tmp_path, capsys, monkeypatch):
    """Issue 38: a first install for `signcast demo` needs no cluster engine; `--executor ray` says how to add it."""
    import tomllib
    project = tomllib.loads((Path(__file__).resolve().parents[1] / "pyproject.toml").read_text())["project"]
    assert not any(d.startswith("ray") for d in project["dependencies"])
    assert any(d.startswith("ray") for d in project["optional-dependencies"]["ray"])
    assert any(d.startswith("ray") for d in project["optional-dependencies"]["test"])
    monkeypatch.setitem(sys.modules, "ray", None)                  # as if Ray were not installed
    out = tmp_path / "out"
    assert main(["sweep", "--languages", "ase", "--items", "A", "--executor", "ray", "--out", str(out)]) == 2
    assert capsys.readouterr().err.strip() == ("signcast sweep: error: --executor ray needs Ray, an optional extra: "
                                               "pip install 'signcast[ray]'")
    assert not out.exists()

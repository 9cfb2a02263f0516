"""`signcast compare` end to end on a small sweep: one signing through the six solutions, intelligibility of every
point against its references, matched operating points, side-by-side video, re-made report; the video scenario on a
rendered-avatar clip; bad input refused in one line."""
import json
import shutil
import subprocess
import time

import numpy as np
import pytest

from comparisons.reports.records import INTELLIGIBILITY_FIELDS
from media.video_io import read_video, write_video
from pipeline.cli import main
from pipeline.studies.compare import CompareSettings, LOSSLESS, SOURCE, UNCODED_SUBJECTS, run as run_compare
from pipeline.studies.shared import VideoSweep

SMALL = CompareSettings(word="AB", video=VideoSweep(qs=(12, 31), frame_rates=(25.0, 10.0), other_codecs=()),
                        param_codecs=("fba-pred", "bba-key"), param_qs=(2, 31), size=(176, 144), max_clip_frames=48,
                        extractions=2, refinements=1, landmark_step=3)
SOLUTIONS = {"NSV", "NSV2O", "NSV3O", "NSV3O+C", "SSV", "FBA", "BBA"}
AVATAR = {"SSV", "FBA", "BBA"}


RUN_WALL_S = {}      # the fixture's own wall time, against which the run's stage times are checked


@pytest.fixture(scope="module")
def result(tmp_path_factory):
    started = time.perf_counter()
    done = run_compare(SMALL, tmp_path_factory.mktemp("compare"), progress=False)
    RUN_WALL_S["compare"] = time.perf_counter() - started
    return done


def _points(result, **match):
    return [r for r in result.records if r.get("kind") == "point" and all(r.get(k) == v for k, v in match.items())]


@pytest.mark.slow
def test_every_solution_carries_the_same_frames_over_the_same_duration(result):
    run = next(r for r in result.records if r.get("kind") == "run")
    full_rate = _points(result, sweep="q")
    assert {r["solution"] for r in full_rate} == SOLUTIONS
    assert all(r["duration_s"] == pytest.approx(run["clip_duration_s"]) for r in _points(result))
    assert {r["frames"] for r in full_rate} == {run["clip_frames"]}
    assert {(r["width"], r["height"]) for r in full_rate} == {(176, 144)}
    for record in _points(result):
        assert record["bits"] > 0 and record["kbps"] == pytest.approx(record["bits"] / record["duration_s"] / 1000)


@pytest.mark.slow
def test_every_point_is_read_against_the_source_and_avatar_points_also_against_the_lossless_render(result):
    for record in _points(result):
        assert record["reference"] in (SOURCE, LOSSLESS)
        # always defined where the reference shows the signing hand (errors are undefined where nothing is found;
        # ASL's left hand rests below the waist, unscored)
        assert {"hand_pck_20", "right_hand_found", "letter_top1", "letter_top3"} <= set(record)
        assert "left_hand_found" not in record
        assert 0 <= record["hand_pck_20"] <= 100 and 10 < record["skin_psnr"] < 60
    keys = {(r["solution"], r["codec"], r["q"], r["fps"]) for r in _points(result)}
    for solution, codec, q, fps in keys:
        references = {r["reference"] for r in _points(result, solution=solution, codec=codec, q=q, fps=fps)}
        assert references == ({SOURCE, LOSSLESS} if solution in AVATAR else {SOURCE})
    # the arm's joints carry only the arm's coding error, the hand's add the fingers' (measured: hand 0.4-6.9 mm,
    # arm 0.3-3.8 mm over Q 1-31 and 10-25 fps; 0.6 and 1.2 mm at Q 2)
    for record in _points(result, solution="FBA") + _points(result, solution="BBA"):
        assert 0 < record["arm_joint_error_mm"] < record["hand_joint_error_mm"] < 10.0
        if record["q"] <= 2 and record["fps"] == 25.0:
            assert record["hand_joint_error_mm"] < 2.0
    coarse, fine = (_points(result, codec="fba-pred", q=q, sweep="q", reference=LOSSLESS)[0] for q in (31, 2))
    assert coarse["hand_joint_error_mm"] > fine["hand_joint_error_mm"]
    # the terminal plays the face it was sent (FBA's FAPs, BBA's face bones); a face left at rest is ~0.9 mm
    for codec in ("fba-pred", "bba-key"):
        assert _points(result, codec=codec, q=2, sweep="q", reference=LOSSLESS)[0]["face_joint_error_mm"] < 0.3


@pytest.mark.slow
def test_the_uncoded_reference_resampled_by_half_a_pixel_is_the_ceiling(result):
    uncoded = [r for r in result.records if r.get("kind") == "uncoded"]
    source = next(r for r in uncoded if r["reference"] == SOURCE and r["subject"] == UNCODED_SUBJECTS[SOURCE])
    # an invisible resampling moves the extracted landmarks a little: the extractor's noise floor (at 176x144 the
    # signing hand is ~15 px: its PCK@0.2 ceiling is 73 %, against 94 % at the demo's 352x288)
    assert 65.0 < source["hand_pck_20"] <= 100.0 and 0.0 < source["face_error"] < 0.1
    assert source.get("left_hand_found") is None        # the resting left hand hangs below the waist: not scored
    assert 0 <= source["letter_top1"] <= source["letter_top3"] <= 100
    # the ceiling-tied threshold at 2 points (the sensitivity table's row; the matches themselves are taken on the
    # human anchor where it is measured)
    tied = [r for r in result.records if r.get("kind") == "sensitivity" and r["reference"] == SOURCE
            and r.get("pck_margin") == 2.0]
    assert tied and all(f"{source['hand_pck_20'] - 2.0:.4g}" in r["threshold"] for r in tied)
    # the ceiling and every point: the mean of two extractions under their sub-pixel shifts, with their spread
    run = next(r for r in result.records if r.get("kind") == "run")
    assert run["extractions"] == 2 and run["extraction_shifts"] == [[0.5, 0.5], [0.5, 0.0]]
    spread = 0
    for record in [source, *_points(result)]:
        assert record["extractions"] == 2
        first, second = record["draw_values"]["hand_pck_20"]     # two draws: mean their midpoint, sd (ddof 1) gap/sqrt 2
        assert record["hand_pck_20"] == pytest.approx((first + second) / 2)
        assert record["draw_sd"]["hand_pck_20"] == pytest.approx(abs(first - second) / 2 ** 0.5)
        spread += first != second
    assert spread > len(_points(result)) / 2         # a half-pixel shift moves most measures: the draws differ


@pytest.mark.slow
def test_each_solution_is_matched_between_its_bracketing_points(result):
    matched = [r for r in result.records if r.get("kind") == "matched"]
    assert {r["solution"] for r in matched} == SOLUTIONS
    assert {(r["solution"], r["codec"]) for r in matched} >= {("FBA", "fba-pred"), ("BBA", "bba-key")}
    for record in matched:
        low, high = record["bracket_kbps"]
        assert low - 1e-9 <= record["pooled_kbps"] <= high + 1e-9      # the match of the means lies in its bracket
        swept = {r["q"] for r in _points(result, solution=record["solution"], codec=record["codec"], sweep="q")}
        assert {record["q_low"], record["q_high"]} <= swept
        assert record["reference"] == (LOSSLESS if record["solution"] in AVATAR else SOURCE)
        assert "PCK@0.2" in record["threshold"] and "letter top-1" in record["threshold"]
        assert isinstance(record["reached"], bool)
        # judged on the monotone fit over Q: where reached with a cheaper bracket, the fit crosses the threshold there
        assert "monotone fit" in record["judged_on"] and {"hand_pck_20", "letter_top1"} <= set(record["measured"])
        if record["reached"] and record["q_low"] != record["q_high"]:
            threshold = float(record["threshold"].split(">=")[1].split()[0])
            assert record["hand_pck_20"] >= threshold - 0.01          # the fit at the match; the text rounds to 4 digits
        assert record["fps_holds"] is None or record["fps_holds"] in (25.0, 10.0)
        assert set(INTELLIGIBILITY_FIELDS) & set(record)
        # each extraction matched on its own: the rate is the median of the K matches, within their range; every
        # point of the series has at least the first two extractions (more where its matches disagreed)
        assert record["kbps_min"] <= record["kbps"] <= record["kbps_max"]
        assert record["extractions"] in (2,) and len(record["kbps_by_extraction"]) == record["extractions"]
        assert isinstance(record["verdict_clear"], bool)
        assert record["verdict_clear"] == (record["reached_extractions"] in (0, record["extractions"]))
    # one refinement: a Q inside the bracket where a series matched between two swept Q, or finer than the sweep
    # where even its dearest point missed (coarser where its cheapest met, but the sweep's coarsest is 31 here)
    refined = _points(result, refined=True)
    for record in refined:
        swept = SMALL.param_qs if record["solution"] in ("FBA", "BBA") else SMALL.video.qs
        assert record["sweep"] == "q" and 1 <= record["q"] < max(swept) and record["q"] not in swept
        if record["q"] < min(swept):
            assert record["q"] == round(min(swept) ** 0.5)
    assert len({(r["solution"], r["codec"]) for r in refined}) == len({(r["solution"], r["codec"], r["q"]) for r in refined})
    operating = {r["solution"] for r in result.operating}
    assert operating == SOLUTIONS
    stages = [r for r in result.records if r.get("kind") == "stage"]
    # the stages are the run: none empty, their times within the fixture's wall time and most of it. What follows the
    # last stage, records.jsonl and the report, is not a stage (the page cannot time itself, since `signcast report`
    # remakes the same page from the records): measured 1.4 of 23.1 s idle, 2.5 of 24.8 s on a loaded CI machine, so
    # the bound leaves it room on a slow one.
    total = sum(s["wall_s"] for s in stages)
    assert len(stages) >= 5 and all(s["wall_s"] > 0 for s in stages)
    assert 0.75 * RUN_WALL_S["compare"] <= total <= RUN_WALL_S["compare"]


@pytest.mark.slow
def test_lower_frame_rate_costs_fewer_bits_and_is_read_too(result):
    slow_points = _points(result, sweep="fps")
    assert slow_points
    for slow in slow_points:
        assert slow["fps"] == 10.0 and "hand_pck_20" in slow
        full = next(r for r in _points(result, solution=slow["solution"], sweep="q", reference=slow["reference"],
                                       codec=slow["codec"]) if r["q"] == slow["q"])
        assert slow["kbps"] < full["kbps"]
    # the frame rates run from the highest down and stop at the first miss: a series holding at its full rate has
    # its lower rate measured at the matched Q; one missing at its full rate has none
    for record in (r for r in result.records if r.get("kind") == "matched"):
        measured = [r for r in slow_points if (r["solution"], r["codec"], r["q"]) ==
                    (record["solution"], record["codec"], record["q_shown"])]
        assert bool(measured) == (record["fps_holds"] is not None), record["solution"]


@pytest.mark.slow
def test_side_by_side_video_tiles_every_solution_with_its_landmarks(result):
    frames, fps = read_video(result.side_by_side)
    assert fps == pytest.approx(25.0)
    assert frames.shape[1] == 2 * (288 + 18) and frames.shape[2] == 4 * 352      # 8 tiles, 4 columns
    assert frames.std() > 20
    # the landmark overlay: the hands' colours (orange and cyan) are drawn on the tiles
    orange = (frames[..., 0] > 200) & (frames[..., 1] > 90) & (frames[..., 1] < 170) & (frames[..., 2] < 60)
    assert orange.sum() > 100


@pytest.mark.slow
def test_report_command_remakes_the_report_from_records(result, tmp_path):
    remade = tmp_path / "again.html"
    assert main(["report", str(result.out_dir / "records.jsonl"), "-o", str(remade)]) == 0
    assert remade.read_text() == result.report.read_text()


@pytest.mark.slow
def test_compare_report_renders_in_headless_chromium(result):
    browser = shutil.which("chromium") or shutil.which("chromium-browser")
    if browser is None:
        pytest.skip("Chromium is not installed (Debian: apt-get install chromium); .ci/run installs it")
    dom = subprocess.run([browser, "--headless", "--no-sandbox", "--disable-gpu", "--virtual-time-budget=5000",
                          "--dump-dom", result.report.as_uri()], capture_output=True, text=True, timeout=120).stdout
    assert "all ok" in dom and "rendered 0/" not in dom


@pytest.fixture(scope="module")
def avatar_video(tmp_path_factory):
    """A short rendered-avatar video (hands visible) to use as a 'natural' input: 12 frames of 176x144 at 25 fps."""
    from media.avatar import load_avatar
    from media.fingerspelling import fingerspell
    from media.render import RenderSettings, render_motion
    motion = fingerspell("ase", "AB").frames(0, 12)
    frames, _ = render_motion(load_avatar(), motion, RenderSettings(width=176, height=144))
    path = tmp_path_factory.mktemp("clip") / "avatar.mp4"
    write_video(path, frames, 25.0, codec="libx264", options={"crf": 12})
    return path


@pytest.mark.slow
def test_compare_video_runs_end_to_end_on_a_rendered_avatar_clip(avatar_video, tmp_path, capsys):
    out = tmp_path / "out"
    # one of today's codecs (their series take the same path) and every 2nd frame measured: a third of the work
    assert main(["compare", "--video", str(avatar_video), "--video-q", "12,31", "--frame-rates", "25,12.5",
                 "--param-q", "4,31", "--codecs", "fba-pred,bba-key", "--video-codecs", "libx264",
                 "--landmark-step", "2", "--extractions", "2", "--refine", "1", "--no-progress", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "matched against the source video on: handshape PCK@0.2" in printed     # the person's message
    records = [json.loads(line) for line in (out / "records.jsonl").read_text().splitlines()]
    run = next(r for r in records if r["kind"] == "run")
    assert run["scenario"] == "video" and run["clip_size"] == [176, 144] and run["clip_frames"] == 12
    assert run["extractions"] == 2 and run["refinements"] == 1
    # the "person" is the avatar's full figure: framed like it, the avatar keeps about its own scale and place
    assert run["framing"]["framing"] == "source" and run["framing"]["scale"] == pytest.approx(1.0, abs=0.08)
    assert run["framing"]["turn_deg"] == 0.0 and np.abs(run["framing"]["shift"]).max() < 0.05
    points = [r for r in records if r["kind"] == "point"]
    assert {r["solution"] for r in points} == SOLUTIONS | {"NSV-ROI"}
    assert {r["solution"] for r in points if r["codec"] == "libx264"} == {"NSV", "NSV2O", "SSV", "NSV-ROI"}
    # NSV-ROI is swept on x264's CRF (addroi reaches x264 only in CRF mode), one stream with no shape
    roi = [r for r in points if r["solution"] == "NSV-ROI"]
    assert roi and all(r["rate_control"] == "crf" and r["shape_bits"] == 0 for r in roi)
    assert any(r["solution"] == "NSV-ROI" for r in records if r["kind"] == "matched")
    assert all(r["duration_s"] == pytest.approx(run["clip_duration_s"]) for r in points)
    source = next(r for r in records if r["kind"] == "uncoded" and r["subject"] == UNCODED_SUBJECTS[SOURCE])
    assert source["hand_pck_20"] > 60.0     # hands visible (about 11 px palms at 176x144): matched on the hands
    assert all("PCK@0.2" in r["threshold"] for r in records if r["kind"] == "matched")
    # every avatar row is matched on the person's message and keeps its codec loss against its own render
    avatar_rows = [r for r in records if r["kind"] == "matched" and r["solution"] in ("SSV", "FBA", "BBA")]
    assert avatar_rows and all(isinstance(r.get("codec_loss"), dict) and "reached" in r["codec_loss"]
                               for r in avatar_rows)
    retargeting = next(r for r in records if r["kind"] == "uncoded" and r["subject"] == "uncoded lossless render"
                       and r["reference"] == SOURCE)
    assert 0 <= retargeting["hand_pck_20"] <= 100
    assert (out / "side_by_side.mp4").exists()
    browser = shutil.which("chromium") or shutil.which("chromium-browser")
    if browser is not None:          # the video scenario's table has a threshold column per row: it still fits
        dom = subprocess.run([browser, "--headless", "--no-sandbox", "--disable-gpu", "--virtual-time-budget=5000",
                              "--dump-dom", (out / "report.html").as_uri()], capture_output=True, text=True,
                             timeout=120).stdout
        assert "; all ok" in dom, dom[-300:]


def test_compare_refuses_a_video_without_a_person(tmp_path, capsys):
    video = tmp_path / "grey.mp4"
    write_video(video, np.full((12, 144, 176, 3), 128, np.uint8), 25.0, codec="libx264")
    assert main(["compare", "--video", str(video), "--no-progress", "--out", str(tmp_path / "out")]) == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and "Traceback" not in error


def test_compare_refuses_a_corrupt_pose_before_any_work(tmp_path, capsys):
    pose = tmp_path / "bad.pose"
    pose.write_bytes(b"\x00\x01 not a pose file")
    assert main(["compare", "--pose", str(pose), "--no-progress", "--out", str(tmp_path / "out")]) == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and "bad.pose" in error
    assert not (tmp_path / "out").exists()


def test_report_command_rejects_missing_and_corrupt_records(tmp_path, capsys):
    assert main(["report", str(tmp_path / "none.jsonl")]) == 2
    assert "not found" in capsys.readouterr().err
    bad = tmp_path / "bad.jsonl"
    bad.write_text(json.dumps({"solution": "NSV", "fps": 25.0}) + "\n{broken\n")
    assert main(["report", str(bad)]) == 2
    assert "bad.jsonl:2:" in capsys.readouterr().err


def test_compare_rejects_bad_settings(tmp_path, capsys):
    assert main(["compare", "ase", "AB", "--video-q", "6,40", "--out", str(tmp_path)]) == 2
    assert "40" in capsys.readouterr().err
    assert main(["compare", "ase", "AB", "--codecs", "fba-zip", "--out", str(tmp_path)]) == 2
    assert "unknown parameter codec" in capsys.readouterr().err
    assert main(["compare", "ase", "AB", "--solutions", "NSV-ROI", "--video-codecs", "libsvtav1",
                 "--out", str(tmp_path)]) == 2
    assert "NSV-ROI is not coded with these codecs" in capsys.readouterr().err
    assert main(["compare", "ase", "AB", "--solutions", "NSV,BBA", "--codecs", "fba-pred", "--out", str(tmp_path)]) == 2
    assert "BBA is not coded with these codecs" in capsys.readouterr().err
    assert main(["compare", "xyz", "AB", "--out", str(tmp_path)]) == 2
    assert np.char.find(capsys.readouterr().err, "xyz") >= 0
    for option, count, fragment in (("--extractions", "0", "bad extraction count"),
                                    ("--extractions", "17", "bad extraction count"),
                                    ("--refine", "-1", "bad refinement count"), ("--refine", "6", "bad refinement count"),
                                    ("--landmark-step", "0", "bad landmark step"),
                                    ("--landmark-step", "26", "bad landmark step"),
                                    ("--solutions", "NSV,XYZ", "unknown solution 'XYZ'"),
                                    ("--solutions", ",", "give at least one solution")):
        assert main(["compare", "ase", "AB", option, count, "--out", str(tmp_path)]) == 2
        error = capsys.readouterr().err.strip()
        assert len(error.splitlines()) == 1 and fragment in error, error
    # a step that leaves fewer than two measured frames, refused before any work
    assert main(["compare", "ase", "AB", "--frames", "10", "--landmark-step", "10", "--out", str(tmp_path)]) == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and "fewer than 2 of the 10 frames" in error, error


def test_a_refinement_measures_the_geometric_middle_of_a_reached_bracket_or_beyond_the_sweep():
    from comparisons.judging.matching import Match
    from comparisons.judging.operating import q_to_refine

    def bracket(low_q, high_q, reached=True):
        return Match(10.0, {"q": high_q, "kbps": 20.0}, {"q": low_q, "kbps": 5.0}, 0.5, reached)

    def alone(q, reached):
        return Match(20.0, {"q": q, "kbps": 20.0}, None, 1.0, reached)
    assert q_to_refine(bracket(12, 4), {4, 12, 31}) == 7                 # sqrt(48) = 6.9
    assert q_to_refine(bracket(31, 4), {4, 31}) == 11
    assert q_to_refine(bracket(5, 4), {4, 5}) is None                    # adjacent
    assert q_to_refine(bracket(6, 4), {4, 5, 6}) is None                 # the middle measured already
    # not reached: finer than the finest swept Q, towards Q 1
    assert q_to_refine(alone(4, reached=False), {4, 12, 31}) == 2
    assert q_to_refine(alone(12, reached=False), {4, 12, 31}) == 2
    assert q_to_refine(alone(4, reached=False), {2, 4, 12, 31}) == 1   # sqrt(2) = 1.4: still finer than 2
    assert q_to_refine(alone(4, reached=False), {1, 4, 31}) is None    # Q 1 measured: nothing finer
    # reached at the cheapest swept point: coarser, towards Q 31
    assert q_to_refine(alone(4, reached=True), {1, 2, 4}) == 11
    assert q_to_refine(alone(30, reached=True), {4, 30}) == 31
    assert q_to_refine(alone(31, reached=True), {4, 31}) is None       # nothing coarser


def test_the_threshold_follows_the_ceiling_and_drops_letters_the_ceiling_cannot_read():
    from comparisons.judging.operating import criteria_for
    hands = criteria_for({"hand_pck_20": 98.5, "face_error": 0.03, "letter_top1": 80.0}, 0.9, 5)
    assert [(c.field, c.threshold, c.higher_is_better) for c in hands] == [
        ("hand_pck_20", pytest.approx(96.5), True), ("letter_top1", pytest.approx(70.0), True)]   # half a letter of 5
    face = criteria_for({"hand_pck_20": 98.5, "face_error": 0.03}, 0.05, 0)               # hands in 5 % of frames
    assert [(c.field, c.threshold, c.higher_is_better) for c in face] == [("face_error", pytest.approx(0.05), False)]
    # a word cut short (--frames) whose ceiling reads no letter: no letter criterion, not "letter top-1 >= -50"
    assert [c.field for c in criteria_for({"hand_pck_20": 80.5, "letter_top1": 0.0}, 0.9, 1)] == ["hand_pck_20"]


# ------------------------------------------------------------------------------------------------------------
# issue 36: only what decides the match is measured, once per distinct picture, on both cores

def _fit_points(readings):
    """Hand-made Q-sweep points: {q: hand PCK} with kbps falling as Q rises (kbps = 1000 / q)."""
    return [{"q": q, "kbps": 1000.0 / q, "fps": 25.0, "hand_pck_20": pck} for q, pck in readings.items()]


def test_the_q_search_runs_coarse_to_fine_and_stops_once_the_fit_has_crossed_between_neighbours():
    from comparisons.judging.matching import Criterion
    from comparisons.judging.schedule import next_swept_q
    swept, criteria = (2, 6, 12, 24, 31), [Criterion("hand_pck_20", 90.0)]
    assert next_swept_q(swept, [], criteria) == 12                               # the middle first
    # Q 12 meets: coarser (of 24 and 31 the coarser first); 31 misses: between them, 24; 24 meets: neighbours, stop
    assert next_swept_q(swept, _fit_points({12: 95.0}), criteria) == 31
    assert next_swept_q(swept, _fit_points({12: 95.0, 31: 80.0}), criteria) == 24
    assert next_swept_q(swept, _fit_points({12: 95.0, 31: 80.0, 24: 91.0}), criteria) is None
    # 24 misses instead: the crossing lies between 12 and 24, neighbours of the sweep: stop (3 of 5 points measured)
    assert next_swept_q(swept, _fit_points({12: 95.0, 31: 80.0, 24: 85.0}), criteria) is None
    # Q 12 misses: finer, then finer again until it meets; Q 2 missing too: nothing left to sweep (refinement's turn)
    assert next_swept_q(swept, _fit_points({12: 85.0}), criteria) == 6
    assert next_swept_q(swept, _fit_points({12: 85.0, 6: 88.0}), criteria) == 2
    assert next_swept_q(swept, _fit_points({12: 85.0, 6: 88.0, 2: 89.0}), criteria) is None
    # judged on the monotone fit: Q 6 reads 92 but the dearer Q 2 reads 86, pooled to 89 < 90: not met, so no
    # coarser point is asked for (there is none left finer either)
    assert next_swept_q(swept, _fit_points({12: 85.0, 6: 92.0, 2: 86.0}), criteria) is None
    # a cheaper point meeting by chance below a dearer miss does not stop the search: pooled, 12 and 6 miss
    assert next_swept_q(swept, _fit_points({12: 91.0, 6: 87.0}), criteria) == 2
    # every extraction's own fit must have crossed too: the means meet at Q 12 and miss at 24 and 31, but one
    # extraction alone misses at 12 (on a second criterion, say), so the search goes on finer, to Q 6
    crossed = _fit_points({12: 95.0, 31: 80.0, 24: 85.0})
    missed = _fit_points({12: 89.0, 31: 80.0, 24: 85.0})
    assert next_swept_q(swept, crossed, criteria, [(crossed, criteria)]) is None
    assert next_swept_q(swept, crossed, criteria, [(crossed, criteria), (missed, criteria)]) == 6


def test_frame_rates_run_from_the_highest_down_and_stop_at_the_first_miss():
    from comparisons.judging.matching import Criterion
    from comparisons.judging.schedule import next_frame_rate
    criteria, rates = [Criterion("hand_pck_20", 90.0)], [20.0, 15.0, 10.0]

    def at(readings):
        return [{"q": 4, "kbps": fps, "fps": fps, "hand_pck_20": pck} for fps, pck in readings.items()]
    assert next_frame_rate(rates, at({25.0: 95.0}), criteria) == 20.0
    assert next_frame_rate(rates, at({25.0: 95.0, 20.0: 93.0}), criteria) == 15.0
    assert next_frame_rate(rates, at({25.0: 95.0, 20.0: 86.0}), criteria) is None      # 20 misses: 15, 10 cannot hold
    assert next_frame_rate(rates, at({25.0: 85.0}), criteria) is None                   # the full rate misses
    assert next_frame_rate(rates, at({25.0: 95.0, 20.0: 93.0, 15.0: 91.0, 10.0: 90.5}), criteria) is None


def test_extractions_are_added_only_where_the_per_extraction_matches_disagree():
    from comparisons.judging.matching import Criterion
    from comparisons.judging.operating import extraction_matches
    from comparisons.judging.schedule import extractions_agree

    def point(q, draws):
        return {"q": q, "kbps": 1000.0 / q, "hand_pck_20": sum(draws) / len(draws), "extractions": len(draws),
                "draw_values": {"hand_pck_20": draws}}
    ceiling = {"hand_pck_20": 95.0, "extractions": 2, "draw_values": {"hand_pck_20": [95.0, 95.0]}}

    def criteria_of(record):
        return [Criterion("hand_pck_20", record["hand_pck_20"] - 5.0)]
    clear = [point(4, [96.0, 97.0]), point(12, [80.0, 82.0])]           # both draws: met at 4, missed at 12
    assert extractions_agree(extraction_matches(clear, ceiling, criteria_of, 2))
    unclear = [point(4, [96.0, 97.0]), point(12, [91.0, 85.0])]         # draw 0 meets at 12, draw 1 does not
    assert not extractions_agree(extraction_matches(unclear, ceiling, criteria_of, 2))


def test_landmarks_are_extracted_once_per_distinct_picture_and_reused_for_identical_subjects(monkeypatch):
    from comparisons.judging.judge import distinct_frames
    from media.lexicon import SignClip
    from pipeline.studies import shared
    calls = []

    def fake_extract(frames, fps, label="", progress=True, **_):
        calls.append(len(frames))
        value = frames.reshape(len(frames), -1)[:, :1].astype(float)        # each picture's first byte
        return SignClip(fps, {"POSE_LANDMARKS": np.repeat(value[:, None, :], 3, axis=2)},
                        {"POSE_LANDMARKS": np.ones((len(frames), 1))})
    monkeypatch.setattr(shared, "extract_landmarks", fake_extract)
    monkeypatch.setattr(shared, "shifted", lambda frames, shift: frames)
    frames = np.zeros((5, 4, 4, 3), np.uint8)
    frames[1] = 7                       # pictures 0, 7, 0, 9, 7: three distinct
    frames[3] = 9
    frames[4] = 7
    first, inverse = distinct_frames(frames)
    assert list(first) == [0, 1, 3] and list(inverse) == [0, 1, 0, 2, 1]
    cache = shared.ExtractionCache()
    draws = shared.extract_draws(frames, 25.0, 2, "x", False, cache=cache)
    assert calls == [3, 3]                                              # two shifts, three pictures each
    for draw in draws:                  # every frame has its own picture's landmarks (unshifted by the half pixel)
        seen = draw.points["POSE_LANDMARKS"][:, 0, 2]
        assert list(seen) == [0.0, 7.0, 0.0, 9.0, 7.0]
    # a subject byte-identical to one extracted before (another point decoding alike) takes its landmarks
    again = shared.extract_draws(frames.copy(), 25.0, 2, "y", False, cache=cache)
    assert calls == [3, 3] and cache.hits == 2
    assert all(np.array_equal(a.points["POSE_LANDMARKS"], b.points["POSE_LANDMARKS"]) for a, b in zip(draws, again))
    # one picture changed: extracted again; the cache is keyed by shift too (a third shift is new)
    frames[2] = 1
    shared.extract_draws(frames, 25.0, 1, "z", False, cache=cache)
    shared.extract_draws(frames, 25.0, 1, "z", False, shifts=(2,), cache=cache)
    assert calls == [3, 3, 4, 4]


@pytest.mark.slow
def test_the_pool_measures_what_a_serial_run_measures():
    """The same jobs (two ceilings, a video point, a parameter point, extractions added to a point) on two pool
    workers (LiteRT one thread each) and here in order: the same fields, draw by draw."""
    from pipeline.studies import compare, shared
    settings = CompareSettings(word="AB", size=(176, 144), max_clip_frames=12, landmark_step=3, extractions=3)
    scenario = shared.load_scenario(settings.signing, shared.renderers("auto"), progress=False)
    recogniser = shared.letter_recogniser(scenario)
    jobs = [compare.CeilingJob("source", 0), compare.CeilingJob("source", 1),
            compare.PointJob("NSV", "mpeg4", 24, 25.0, (0, 1)), compare.PointJob("FBA", "fba-pred", 8, 25.0, (0, 1)),
            compare.PointJob("FBA", "fba-pred", 8, 25.0, (2,), quality=False),
            compare.PointJob("NSV", "mpeg4", 24, 10.0, (0,))]
    results = {}
    for workers in (1, 2):
        with shared.StudyPool(workers, compare._start_measurer, (settings, scenario, recogniser),
                              preload=("pipeline.studies.compare",)) as pool:
            results[workers] = pool.run(compare._run_job, jobs)
    for serial, pooled in zip(results[1], results[2]):
        assert serial.get("base") == pooled.get("base") and serial.get("draws") == pooled.get("draws")
        for a, b in ((serial["observed"], pooled["observed"]),) if serial["observed"] is not None else ():
            assert all(np.array_equal(a.points[k], b.points[k]) for k in a.points)
    assert results[1][2]["base"]["kbps"] > 0 and len(results[1][2]["draws"]["source video"]) == 2


def test_the_pool_streams_the_jobs_each_finished_job_leads_to():
    """StudyPool.stream: every job a finished one leads to runs, with no barrier, on two workers and here in
    order; each result reaches follow once, with its own job."""
    from pipeline.studies import shared
    seen = {}
    for workers in (1, 2):
        finished = []

        def follow(job, result):
            assert result == abs(job)
            finished.append(job)
            return [job - 1] if job > 0 else []       # a chain per start: 3 -> 2 -> 1 -> 0

        with shared.StudyPool(workers, int, ()) as pool:
            pool.stream(abs, [3, -1, 5], follow)
        seen[workers] = sorted(finished)
    assert seen[1] == seen[2] == sorted([3, 2, 1, 0, -1, 5, 4, 3, 2, 1, 0])


"""Wall time of `signcast compare --video` and `signcast demo`, stage by stage, with the share spent in landmark
extraction (issue 36).

- "video": `compare --video` with the defaults on a 2-second clip at 320x240: the avatar fingerspelling ASL HELLO,
  rendered at 320x240 and 25 fps (the first 50 frames), written with libx264 at CRF 12 (there is no bundled video
  of a person at that size);
- "demo": `signcast demo` (CompareSettings.demo()).

Printed: each stage's wall time (the run's "stage" records), the whole run's, the load average before and after,
and the landmark extraction's seconds: the Holistic graph's own calls, timed in this process and, where the study
runs points on a process pool, in its workers (the run record's `extraction_s`); its share is those seconds over
wall time x the processes that ran it. Appended as one JSON line to --out.

    .venv/bin/python benchmarks/compare_time.py [--runs video,demo] [--frames N] [--clip NAME] [--full]
                                                [--out FILE] [--label TEXT]

--full runs the schedule before issue 36 (every swept Q, frame rate and extraction) on today's code: the
matched rates of the faster schedule are checked against its per-extraction ranges.

Run from another checkout (e.g. a worktree at an older commit) with PYTHONPATH set to it to time the code before.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

CLIP_SIZE = (320, 240)
CLIP_FRAMES = 50            # 2 s at 25 fps


def make_clip(folder: Path, frames: int = CLIP_FRAMES) -> Path:
    """The avatar fingerspelling ASL HELLO, rendered at CLIP_SIZE and 25 fps, first `frames` frames, as an H.264
    file (CRF 12): a stand-in for a 2-second clip of a person."""
    from media.avatar import load_avatar
    from media.fingerspelling import fingerspell
    from media.render import RenderSettings, render_motion
    from media.video_io import write_video
    motion = fingerspell("ase", "HELLO", fps=25.0)
    motion = motion.frames(0, min(frames, motion.n_frames))
    pictures, _ = render_motion(load_avatar(), motion, RenderSettings(width=CLIP_SIZE[0], height=CLIP_SIZE[1]))
    path = folder / "avatar-hello-320x240.mp4"
    write_video(path, pictures, 25.0, codec="libx264", options={"crf": 12})
    return path


class ExtractionTimer:
    """Times every call of media.landmarks.holistic.extract_landmarks made in this process."""

    def __init__(self) -> None:
        import media.landmarks.holistic as holistic
        self.module, self.original, self.seconds, self.frames = holistic, holistic.extract_landmarks, 0.0, 0

        def timed(frames, *args, **kwargs):
            started = time.perf_counter()
            try:
                return self.original(frames, *args, **kwargs)
            finally:
                self.seconds += time.perf_counter() - started
                self.frames += len(frames) if hasattr(frames, "__len__") else 0
        holistic.extract_landmarks = timed

    def close(self) -> None:
        self.module.extract_landmarks = self.original


def timed_run(name: str, settings, out_dir: Path) -> dict:
    from pipeline.studies.compare import run
    import resource
    load_before = os.getloadavg()
    timer = ExtractionTimer()

    def cpu() -> float:
        return sum(getattr(resource.getrusage(who), field) for who in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN)
                   for field in ("ru_utime", "ru_stime"))
    cpu_before = cpu()
    started = time.perf_counter()
    try:
        result = run(settings, out_dir, progress=False)
    finally:
        timer.close()
    wall = time.perf_counter() - started
    cpu_s = cpu() - cpu_before
    load_after = os.getloadavg()
    records = result.records
    run_record = next(r for r in records if r.get("kind") == "run")
    stages = {r["stage"]: r["wall_s"] for r in records if r.get("kind") == "stage"}
    points = [r for r in records if r.get("kind") == "point"]
    workers = int(run_record.get("workers") or 1)
    # the study's own count (every process it ran) where it keeps one, else this process's calls
    extraction = float(run_record["extraction_s"]) if run_record.get("extraction_s") is not None else timer.seconds
    matched = {f"{r['solution']} {r['codec']} / {r.get('reference')}": {
                   "kbps": r["kbps"], "kbps_se": r.get("kbps_se"), "reached": r["reached"],
                   "q": [r["q_low"], r["q_high"]], "kbps_min": r.get("kbps_min"), "kbps_max": r.get("kbps_max"),
                   "pooled_kbps": r.get("pooled_kbps"), "extractions": r.get("extractions")}
               for r in records if r.get("kind") == "matched"}
    # CPU seconds: this process and its waited-for children, plus the pool workers' jobs (the study's count);
    # on an idle machine of `cpus` cores the run takes about max(cpu_s / min(workers, cpus), the serial stages)
    cpu_s += float(run_record.get("worker_cpu_s") or 0.0)
    return {"run": name, "wall_s": round(wall, 1), "cpu_s": round(cpu_s, 1), "stages": stages, "workers": workers,
            "extraction_s": round(extraction, 1),
            "extraction_share": round(extraction / (wall * min(workers, os.cpu_count() or 1)), 3),
            "points": len({(r["solution"], r["codec"], r["q"], r["fps"]) for r in points}),
            "load_before": [round(v, 2) for v in load_before], "load_after": [round(v, 2) for v in load_after],
            "cpus": os.cpu_count(), "matched": matched, "rounds": run_record.get("rounds"),
            "point_extractions": sorted(int(r.get("extractions") or 0) for r in points)}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", default="video,demo", help="comma-separated: video, demo")
    parser.add_argument("--frames", type=int, default=CLIP_FRAMES, help="frames of the video run's clip")
    parser.add_argument("--out", default="compare_time.jsonl", help="JSON lines appended here")
    parser.add_argument("--label", default="", help="a label for this checkout (e.g. before, after)")
    parser.add_argument("--full", action="store_true",
                        help="the full schedule (every swept Q, frame rate and extraction): the figures to check the "
                             "faster schedule's against")
    parser.add_argument("--clip", default=None, help="the video run's clip instead of the avatar render "
                                                     "(e.g. carphone), with --frames frames")
    args = parser.parse_args()
    from pipeline.studies.compare import CompareSettings
    results = []
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        for name in args.runs.split(","):
            if name == "video":
                clip = args.clip if args.clip is not None else str(make_clip(folder, args.frames))
                settings = CompareSettings(clip=clip, max_clip_frames=args.frames if args.clip else None)
            elif name == "demo":
                settings = CompareSettings.demo()
            else:
                raise SystemExit(f"unknown run {name!r}: choose video or demo")
            if args.full:
                from dataclasses import replace
                settings = replace(settings, full_schedule=True)
            result = dict(timed_run(name, settings, folder / name), label=args.label)
            results.append(result)
            with open(args.out, "a") as out:
                out.write(json.dumps(result) + "\n")
            print(f"{args.label} {name}: {result['wall_s']:.0f} s wall, {result['cpu_s']:.0f} CPU s, {result['points']} points, extraction "
                  f"{result['extraction_s']:.0f} s ({100 * result['extraction_share']:.0f} % of {result['workers']} "
                  f"process(es) x wall); load {result['load_before']} -> {result['load_after']}")
            for stage, seconds in result["stages"].items():
                print(f"  {seconds:8.1f} s  {stage}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

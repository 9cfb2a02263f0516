"""The lexicon sweep on this machine with both executors: wall time, CPU use, per-task times, the overhead of Ray
against the local process pool, and a projection to N nodes from the measured times.

For each executor (the same sweep, started over in OUT/EXECUTOR with pipeline.studies.sweep.run):
- wall time, split into start (planning, the folder, starting the pool or Ray), the loop (first unit handed out to
  last unit written) and the end (shutting the executor down);
- CPU seconds of this process and of every process below it (pool workers and the forkserver; Ray's daemons and
  workers), from /proc/PID/stat sampled every 0.5 s, by process name; the utilisation cpu / (wall x workers); and how
  busy the whole machine was (/proc/stat, load average): other work on the machine slows the sweep down but
  does not change its CPU seconds, so the comparison of executors is made in CPU seconds;
- per-point and per-unit times as the workers measured them (records: wall_s and cpu_s per point, retarget_s and
  retarget_cpu_s per item and frame rate; a unit is one item with all its frame rates, codecs and Q);
- the executor's overhead: CPU seconds of the whole tree during the loop minus the work the workers measured,
  per unit (handing out, pickling, Ray's daemons, worker start and imports).

The model of the projection, for N nodes of c cores each (every number measured here, on dedicated cores a unit
takes its CPU time):
    T(N) = S + max(n (w + o) / (N c), n d) + w_max
S: the serial part, the run's start and end (wall); n: work units; w: mean CPU seconds of a unit's work; o: the
executor's overhead per unit (CPU seconds); d: the driver's CPU per unit (receiving and appending records: one
process, so the sweep cannot go faster than n d); w_max: the longest unit (the last to finish may start just
before the others end). Amdahl's serial fraction is S / T(1 core).

    python benchmarks/sweep.py [--languages all] [--items A] [--codecs fba-pred,fba-dct,bba-pred,bba-dct,bba-key]
        [--q 1,4,16,31] [--fps 10,25] [--workers 2] [--executors local,ray] [--out DIR] [--json FILE]
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import sys
import threading
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from media import lexicon  # noqa: E402
from media.errors import SigncastError  # noqa: E402
from pipeline.studies import sweep  # noqa: E402

TICKS = os.sysconf("SC_CLK_TCK")
NODES = (1, 2, 4, 8, 16, 32, 64)
CORES_PER_NODE = 16


def _processes() -> dict[int, tuple[int, int, str, float]]:
    """pid -> (parent pid, start time in ticks, name, CPU seconds used so far) of every process /proc shows."""
    found = {}
    for name in os.listdir("/proc"):
        if not name.isdigit():
            continue
        try:
            text = Path(f"/proc/{name}/stat").read_text()
        except OSError:
            continue
        command = text[text.index("(") + 1:text.rindex(")")]
        fields = text[text.rindex(")") + 2:].split()
        found[int(name)] = (int(fields[1]), int(fields[19]), command, (int(fields[11]) + int(fields[12])) / TICKS)
    return found


def _machine_busy() -> tuple[float, float]:
    """(busy, total) CPU seconds of the whole machine since boot, from /proc/stat."""
    values = [int(v) for v in Path("/proc/stat").read_text().splitlines()[0].split()[1:]]
    idle = values[3] + values[4]
    return (sum(values) - idle) / TICKS, sum(values) / TICKS


def _role(command: str) -> str:
    """A process's role in the sweep from its name: Ray's workers name themselves ray::TASK or ray::IDLE."""
    return "ray workers" if command.startswith("ray::") else command


class TreeCpu:
    """CPU seconds of this process's descendants, sampled every interval_s in a thread: the last sample of each
    process (keyed by pid and start time) counts, so a process that ends loses at most interval_s of its time."""

    def __init__(self, interval_s: float = 0.5) -> None:
        self.interval_s = interval_s
        self.latest: dict[tuple[int, int], tuple[str, float]] = {}
        self.own_cpu_s = 0.0                      # the sampling thread's own CPU time, not the sweep's
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._loop, daemon=True)

    def sample(self) -> None:
        table = _processes()
        children = defaultdict(list)
        for pid, (parent, _, _, _) in table.items():
            children[parent].append(pid)
        stack = list(children[os.getpid()])
        while stack:
            pid = stack.pop()
            _, started, command, cpu = table[pid]
            self.latest[(pid, started)] = (_role(command), cpu)
            stack.extend(children[pid])

    def _loop(self) -> None:
        while not self.stop.wait(self.interval_s):
            self.sample()
            self.own_cpu_s = time.thread_time()

    def __enter__(self) -> TreeCpu:
        self.thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self.sample()
        self.stop.set()
        self.thread.join()

    @property
    def seconds(self) -> float:
        return sum(cpu for _, cpu in self.latest.values())

    def by_role(self) -> dict[str, float]:
        roles: dict[str, float] = defaultdict(float)
        for role, cpu in self.latest.values():
            roles[role] += cpu
        return dict(sorted(roles.items(), key=lambda item: -item[1]))


def _self_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def _spread(values) -> dict:
    values = np.asarray(values, dtype=float)
    if not len(values):
        return {}
    p10, p50, p90 = np.percentile(values, [10, 50, 90])
    return {"n": int(len(values)), "mean": float(values.mean()), "p10": float(p10), "median": float(p50),
            "p90": float(p90), "max": float(values.max()), "sum": float(values.sum())}


def unit_times(points: list[dict], wall: str, retarget: str) -> np.ndarray:
    """Seconds per unit (language, item): its points' `wall` field plus its motions' `retarget` field."""
    per_unit: dict[tuple, float] = defaultdict(float)
    for record in points:
        per_unit[(record["language"], record["item"])] += record[wall]
    for (language, item, _), seconds in {(r["language"], r["item"], r["fps"]): r[retarget] for r in points}.items():
        per_unit[(language, item)] += seconds
    return np.array(list(per_unit.values()))


def measure(settings: sweep.SweepSettings, out: Path) -> dict:
    """Run the sweep from scratch in out and measure it (see the module's description)."""
    tree = TreeCpu()
    marks: dict[str, tuple[float, float, float]] = {}       # (wall, driver CPU, tree CPU)

    def progress(state: sweep.SweepState) -> None:
        mark = (time.perf_counter(), _self_cpu() - tree.own_cpu_s, tree.seconds)
        marks.setdefault("first", mark)
        if state.done + state.failed:
            marks["last"] = mark

    busy_before, total_before = _machine_busy()
    load_before = os.getloadavg()[0]
    start = time.perf_counter()
    with tree:
        tree.sample()
        result = sweep.run(settings, out, force=True, progress=progress, report=False)
    wall = time.perf_counter() - start
    driver_cpu = _self_cpu() - tree.own_cpu_s
    busy_after, total_after = _machine_busy()
    state = result.state
    points = [r for r in result.records if r["kind"] == "point"]
    unit_wall = unit_times(points, "wall_s", "retarget_s")
    unit_cpu = unit_times(points, "cpu_s", "retarget_cpu_s")
    slots = next(r["workers"] for r in reversed(result.records) if r["kind"] == "run")
    (first_wall, first_driver, first_tree), (last_wall, last_driver, last_tree) = marks["first"], marks["last"]
    loop_cpu = (last_driver - first_driver) + (last_tree - first_tree)
    n_units = len(unit_cpu)
    return {
        "executor": settings.executor, "workers": slots, "units": n_units, "points": state.done,
        "failed": state.failed, "wall_s": wall, "start_s": first_wall - start, "loop_s": last_wall - first_wall,
        "end_s": wall - (last_wall - start), "cpu_s": tree.seconds + driver_cpu, "cpu_driver_s": driver_cpu,
        "cpu_by_process": tree.by_role(), "utilisation": (tree.seconds + driver_cpu) / (wall * slots),
        "machine_busy": (busy_after - busy_before) / max(total_after - total_before, 1e-9),
        "load_before": load_before, "load_after": os.getloadavg()[0],
        "unit_wall_s": _spread(unit_wall), "unit_cpu_s": _spread(unit_cpu),
        "point_wall_s": _spread([r["wall_s"] for r in points]), "point_cpu_s": _spread([r["cpu_s"] for r in points]),
        "retarget_cpu_s": _spread(list({(r["language"], r["item"], r["fps"]): r["retarget_cpu_s"]
                                        for r in points}.values())),
        "loop_cpu_s": loop_cpu, "work_cpu_s": float(unit_cpu.sum()),
        "overhead_cpu_per_unit_s": (loop_cpu - float(unit_cpu.sum())) / n_units,
        "driver_cpu_per_unit_s": (last_driver - first_driver) / n_units,
    }


def project(run: dict, n_units: int, nodes: tuple[int, ...] = NODES, cores: int = CORES_PER_NODE) -> list[dict]:
    """T(N) of the module's model for n_units units of the run's measured times."""
    serial = run["start_s"] + run["end_s"]
    per_unit = run["unit_cpu_s"]["mean"] + max(run["overhead_cpu_per_unit_s"], 0.0)
    tail = run["unit_cpu_s"]["max"]
    one_core = serial + n_units * per_unit + tail
    rows = []
    for n in nodes:
        compute = n_units * per_unit / (n * cores)
        driver = n_units * run["driver_cpu_per_unit_s"]
        total = serial + max(compute, driver) + tail
        rows.append({"nodes": n, "cores": n * cores, "seconds": total, "speedup_vs_1_core": one_core / total,
                     "serial_fraction": (serial + tail) / total, "bound": "driver" if driver > compute else "workers"})
    return rows


def _has_letters(language: str, letters: tuple[str, ...]) -> bool:
    try:
        return all(not word for _, word in sweep.resolve_items(language, letters))
    except SigncastError:
        return False


def _print_run(run: dict) -> None:
    print(f"\n{run['executor']}: {run['units']} units, {run['points']} points ({run['failed']} failed), "
          f"{run['workers']} workers")
    print(f"  wall {run['wall_s']:.1f} s = start {run['start_s']:.1f} + loop {run['loop_s']:.1f} + end "
          f"{run['end_s']:.1f}")
    roles = ", ".join(f"{role} {cpu:.1f}" for role, cpu in run["cpu_by_process"].items() if cpu >= 0.05)
    print(f"  CPU {run['cpu_s']:.1f} s (driver {run['cpu_driver_s']:.1f}; {roles}): utilisation "
          f"{100 * run['utilisation']:.0f} % of {run['workers']} cores; the machine was {100 * run['machine_busy']:.0f} % "
          f"busy (load {run['load_before']:.1f} -> {run['load_after']:.1f})")
    for name in ("unit_cpu_s", "unit_wall_s", "point_cpu_s", "point_wall_s", "retarget_cpu_s"):
        s = run[name]
        print(f"  {name:<15} n {s['n']:>5}  mean {s['mean']:7.3f}  p10 {s['p10']:7.3f}  median {s['median']:7.3f}  "
              f"p90 {s['p90']:7.3f}  max {s['max']:7.3f}")
    print(f"  loop CPU {run['loop_cpu_s']:.1f} s, of which the workers' measured work {run['work_cpu_s']:.1f} s: "
          f"overhead {run['overhead_cpu_per_unit_s']:.3f} CPU s/unit "
          f"({100 * run['overhead_cpu_per_unit_s'] / run['unit_cpu_s']['mean']:.1f} % of a unit); driver "
          f"{1000 * run['driver_cpu_per_unit_s']:.1f} ms/unit")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--languages", default="all")
    parser.add_argument("--items", default=None,
                        help="letters, comma-separated (default every letter); languages lacking one are left out")
    parser.add_argument("--codecs", default="fba-pred,fba-dct,bba-pred,bba-dct,bba-key")
    parser.add_argument("--q", default="1,4,16,31")
    parser.add_argument("--fps", default="10,25")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--executors", default="local,ray")
    parser.add_argument("--out", type=Path, default=Path("/tmp/signcast-sweep-benchmark"))
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args()
    languages = lexicon.languages() if args.languages == "all" else args.languages.split(",")
    items = None if args.items is None else tuple(args.items.split(","))
    if items is not None:
        languages = [language for language in languages if _has_letters(language, items)]
    base = dict(languages=tuple(languages), items=items, codecs=tuple(args.codecs.split(",")),
                qs=tuple(int(q) for q in args.q.split(",")), frame_rates=tuple(float(f) for f in args.fps.split(",")),
                workers=args.workers)
    all_clips = sum(len(lexicon.entries(language)) for language in lexicon.languages())
    runs = []
    for executor in args.executors.split(","):
        print(f"running the sweep on {executor} ({len(languages)} languages, {args.workers} workers) ...",
              file=sys.stderr)
        runs.append(measure(sweep.SweepSettings(**base, executor=executor), args.out / executor))
    for run in runs:
        _print_run(run)
    by_executor = {run["executor"]: run for run in runs}
    if set(by_executor) == {"local", "ray"}:
        local, ray = by_executor["local"], by_executor["ray"]
        print(f"\nray / local: CPU {ray['cpu_s'] / local['cpu_s']:.3f}, loop CPU {ray['loop_cpu_s'] / local['loop_cpu_s']:.3f}, "
              f"overhead {ray['overhead_cpu_per_unit_s']:.3f} vs {local['overhead_cpu_per_unit_s']:.3f} CPU s/unit, "
              f"start {ray['start_s']:.1f} vs {local['start_s']:.1f} s; wall {ray['wall_s'] / local['wall_s']:.3f} "
              f"(on a machine {100 * ray['machine_busy']:.0f} % / {100 * local['machine_busy']:.0f} % busy)")
    reference = by_executor.get("ray", runs[-1])
    points_per_unit = len(base["codecs"]) * len(base["qs"]) * len(base["frame_rates"])
    serial = reference["start_s"] + reference["end_s"]
    print(f"\nprojection for the whole lexicon ({all_clips} clips = units, {points_per_unit} points each) on N nodes "
          f"of {CORES_PER_NODE} cores, from {reference['executor']}'s measured times:")
    print(f"  T(N) = S + max(n (w + o) / (N c), n d) + w_max; S {serial:.1f} s, w {reference['unit_cpu_s']['mean']:.2f} s, "
          f"o {max(reference['overhead_cpu_per_unit_s'], 0):.3f} s, d {1000 * reference['driver_cpu_per_unit_s']:.1f} ms, "
          f"w_max {reference['unit_cpu_s']['max']:.1f} s")
    projection = project(reference, all_clips)
    for row in projection:
        print(f"  N {row['nodes']:>3} ({row['cores']:>4} cores): {row['seconds']:8.1f} s  speed-up "
              f"{row['speedup_vs_1_core']:6.1f} x one core, serial share {100 * row['serial_fraction']:4.1f} % "
              f"({row['bound']}-bound)")
    here = project(reference, all_clips, nodes=(1,), cores=reference["workers"])[0]["seconds"]
    print(f"  this machine, {reference['workers']} dedicated cores: {here / 60:.1f} min")
    if args.json:
        args.json.write_text(json.dumps({"runs": runs, "projection": projection}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())

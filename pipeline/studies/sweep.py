"""The lexicon sweep (`signcast sweep`): languages x items x codecs x Q x fps of parameter transmission, each point
measured as in the params study (comparisons.params.study.measure_point), run on a local process pool or on Ray,
and resumable.

- A point is (language, item, codec, Q, fps); its solution follows from the codec (fba-* -> FBA, bba-* -> BBA).
  Its task key is a stable hash of those, the solution and TASK_VERSION (task_key); records carry it as "task".
- A work unit is one (language, item) at every frame rate: the item is retargeted to the avatar once, inside the
  worker (media.fingerspelling caches the retargeted clip at its own rate and resamples it to each frame rate), and
  coded with every codec at every Q of the points it holds. Retargeting costs about as much as 15 coded points, so
  a unit per frame rate would retarget again wherever its frame rates land on different workers. Both executors run
  the same pure function, measure_unit, so they write the same records (timing fields, TIMING_FIELDS, aside).
- An item is a lexicon unit of the language (a letter, or a multi-letter unit such as CH), retargeted from its
  clip (media.fingerspelling.letter_motion), or else a word fingerspelled from the language's units
  (media.fingerspelling.fingerspell).
- Each finished unit's records are appended to OUT/records.jsonl at once (the file is closed, so flushed), so a
  killed sweep loses only the units that were running. On start the finished keys of records.jsonl are skipped;
  a truncated last line (a kill during a write) is dropped; failed points are retried unless skip_failed.
- A point that fails (a clip whose motion cannot be built, a codec that refuses a frame rate, ...) is recorded as
  kind "failed" with its reason; the other points carry on.
- At most one unit per worker is in flight, so "running" counts points that are being measured and Ctrl-C stops
  after those finish (their records are kept).
- Unlike the other commands' --out (pipeline.outputs.output_folder), a rerun does not clear the folder: it resumes.
  --force starts over. The sweep's files are listed in the folder's manifest from the start, so a killed sweep's
  folder is still recognised as signcast's.
- One records file holds at most comparisons.reports.records.MAX_RECORD_VALUES JSON values; a point record holds up to
  VALUES_PER_POINT, so a sweep (with the records already in --out) may hold at most MAX_POINTS points: the whole
  lexicon with 5 codecs x 4 Q x 2 frame rates is 25 040. A larger sweep is refused before any work.
"""
from __future__ import annotations

import hashlib
import json
import os
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path

from comparisons.params.codecs import codec_names, get_codec
from comparisons.params.study import measure_point
from comparisons.reports.records import MAX_RECORD_VALUES, make_record, read_records, read_typed_records, versions
from pipeline.outputs import write_outputs, write_records
from comparisons.reports.sweep import language_item
from media import lexicon
from media.domain import check_fps, check_q, solution_of
from media.errors import SigncastError
from media.motion import Motion
from pipeline.outputs import MANIFEST, check_folder

EXECUTORS = ("local", "ray")
# bump when a point's measurement changes meaning (2: face_joint_error_mm_p90, which the report's face threshold reads)
TASK_VERSION = 2
RECORDS = "records.jsonl"
REPORT_FILES = ("report.html", "sweep_table.csv", "sweep_kbps.png")
SWEEP_FILES = (RECORDS, RECORDS + ".tmp", *REPORT_FILES)
# differ from run to run, nothing else does: seconds (wall and CPU) to measure a point and to build its motion
TIMING_FIELDS = ("wall_s", "cpu_s", "retarget_s", "retarget_cpu_s", "encode_fps", "decode_fps")
MAX_REASON_CHARS = 300
VALUES_PER_POINT = 70              # JSON values in one point record (measured: 57 on average, 65 at most)
MAX_POINTS = MAX_RECORD_VALUES // VALUES_PER_POINT


@dataclass(frozen=True)
class SweepSettings:
    """languages: sign language codes; items: letters or words (None: every unit of each language); codecs:
    parameter codecs; qs: quantisation values; frame_rates: coding frame rates, frames per second; executor:
    "local" (process pool) or "ray"; workers: processes (local) or Ray CPUs (None: every CPU of this machine;
    ignored when joining a Ray cluster at address); skip_failed: leave points recorded as failed alone."""

    languages: tuple[str, ...]
    items: tuple[str, ...] | None = None
    codecs: tuple[str, ...] = ("fba-pred", "fba-dct", "bba-pred", "bba-dct", "bba-key")
    qs: tuple[int, ...] = (1, 4, 16, 31)
    frame_rates: tuple[float, ...] = (10.0, 25.0)
    executor: str = "local"
    workers: int | None = None
    address: str | None = None
    skip_failed: bool = False


@dataclass(frozen=True)
class Point:
    """One measured point of a unit: its task key, frame rate (frames per second), codec and Q."""
    task: str
    fps: float
    codec: str
    q: int


@dataclass(frozen=True)
class Unit:
    """One work unit: an item of a language with the points to measure on it (ordered by frame rate). word: the item
    is fingerspelled from several lexicon units rather than taken from one clip."""
    language: str
    item: str
    word: bool
    points: tuple[Point, ...]


@dataclass
class SweepState:
    """Where a sweep stands, in points: total of the sweep, finished before this run (skipped), done and failed in
    this run, running now; units_left: work units not yet finished this run; stopping: interrupted, waiting for
    the running units."""
    total: int
    skipped: int
    done: int = 0
    failed: int = 0
    running: int = 0
    units_left: int = 0
    stopping: bool = False

    @property
    def finished(self) -> int:
        return self.skipped + self.done + self.failed


@dataclass
class SweepResult:
    """state: the counts at the end; records: every record of records.jsonl; wall_s: seconds the run took."""
    state: SweepState
    records: list[dict] = field(default_factory=list)
    wall_s: float = 0.0


def code_version() -> str:
    """The version tag in every task key: signcast's version and TASK_VERSION."""
    try:
        package = metadata.version("signcast")
    except metadata.PackageNotFoundError:
        package = "unknown"
    return f"signcast {package}, sweep task {TASK_VERSION}"


def task_key(language: str, item: str, codec: str, q: int, fps: float, solution: str, version: str) -> str:
    """A stable 20-hex-digit key of one point (sha-256 of its parameters as JSON)."""
    text = json.dumps([language, item, codec, int(q), float(fps), solution, version], ensure_ascii=False)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:20]


def resolve_items(language: str, items: tuple[str, ...] | None) -> list[tuple[str, bool]]:
    """(item as the lexicon writes it, is a word) for each item of one language; None: every unit of the language.
    An item that is no unit of the language is a word, split into units (SigncastError when it cannot be) and
    written as they are, so "hello" and "HELLO" are one item."""
    if items is None:
        return [(unit, False) for unit in lexicon.units(language)]
    resolved = []
    for item in items:
        try:
            resolved.append((lexicon.lookup(language, item).unit, False))
        except SigncastError:
            units = lexicon.split_word(language, item)
            if len(units) == 1:        # an accented letter spelled as its base letter
                resolved.append((units[0], False))
            else:                      # a word, written with the lexicon's units ("hello" -> "HELLO")
                resolved.append(("".join(units), True))
    return list(dict.fromkeys(resolved))


RAY_MISSING = "--executor ray needs Ray, an optional extra: pip install 'signcast[ray]'"


def ray_installed() -> bool:
    """Whether Ray (the optional extra signcast[ray]) can be imported, without importing it."""
    import importlib.util
    try:
        return importlib.util.find_spec("ray") is not None
    except (ImportError, ValueError):         # ValueError: sys.modules["ray"] is None
        return False


def check(settings: SweepSettings) -> list[tuple[str, list[tuple[str, bool]]]]:
    """Refuse bad settings before any work (one-line SigncastError); returns each language (as stored) with its
    items (resolve_items)."""
    if settings.executor not in EXECUTORS:
        raise SigncastError(f"unknown --executor {settings.executor!r}; choose {' or '.join(EXECUTORS)}")
    if settings.address and settings.executor != "ray":
        raise SigncastError("--address joins a Ray cluster: use it with --executor ray")
    if settings.executor == "ray" and not ray_installed():
        raise SigncastError(RAY_MISSING)
    if settings.workers is not None and (isinstance(settings.workers, bool) or not isinstance(settings.workers, int)
                                         or settings.workers < 1):
        raise SigncastError(f"bad --workers {settings.workers}: give a whole number of processes, at least 1")
    if not settings.languages:
        raise SigncastError(f"no language given; the lexicon has: {', '.join(lexicon.languages())}")
    if settings.items is not None and not settings.items:
        raise SigncastError("no item given: name letters or words, e.g. --items A,B,C, or leave --items out for "
                            "every letter")
    if not settings.codecs:
        raise SigncastError(f"no codec given; known: {', '.join(codec_names())}")
    for name in settings.codecs:
        get_codec(name)
        solution_of(name)
    if not settings.qs:
        raise SigncastError("no Q given: e.g. --q 1,4,16,31")
    for q in settings.qs:
        check_q(q, "--q")
    if not settings.frame_rates:
        raise SigncastError("no frame rate given: e.g. --fps 10,25")
    for fps in settings.frame_rates:
        check_fps(fps, "--fps")
    languages = list(dict.fromkeys(lexicon.check_language(language) for language in settings.languages))
    resolved = [(language, resolve_items(language, settings.items)) for language in languages]
    _check_size(sum(len(items) for _, items in resolved) * len(set(settings.codecs)) * len(set(settings.qs))
                * len(set(settings.frame_rates)))
    return resolved


def _check_size(n_points: int, held: int = 0) -> None:
    """Refuse a sweep whose records would not fit in one records file (see the module's description)."""
    if n_points + held > MAX_POINTS:
        already = f" with the {held} records already in --out" if held else ""
        raise SigncastError(f"a sweep of {n_points} points{already} is more than one records file holds "
                            f"({MAX_POINTS} points): split it over several --out folders, e.g. by --languages")


def plan(settings: SweepSettings, version: str | None = None) -> list[Unit]:
    """Every work unit of the sweep with all its points, in the order they are handed out."""
    version = version or code_version()
    units = []
    for language, items in check(settings):
        for item, word in items:
            points = tuple(Point(task_key(language, item, codec, q, fps, solution_of(codec), version), fps, codec, q)
                           for fps in dict.fromkeys(float(f) for f in settings.frame_rates)
                           for codec in dict.fromkeys(settings.codecs) for q in dict.fromkeys(settings.qs))
            units.append(Unit(language, item, word, points))
    return units


# --------------------------------------------------------------------------- the work (runs in the workers)

def _reason(error: BaseException) -> str:
    """One line naming what went wrong: the message of a SigncastError, type and message of anything else."""
    text = str(error) if isinstance(error, SigncastError) else f"{type(error).__name__}: {error}"
    line = " ".join(text.split()) or type(error).__name__
    return line if len(line) <= MAX_REASON_CHARS else line[:MAX_REASON_CHARS - 3] + "..."


def failed_record(unit: Unit, point: Point, reason: str) -> dict:
    """The record of a point that could not be measured: its parameters, task key and reason."""
    return {"kind": "failed", "solution": solution_of(point.codec), "clip": f"{unit.language}:{unit.item}",
            "codec": point.codec, "q": point.q, "fps": point.fps, "task": point.task,
            "language": unit.language, "item": unit.item, "reason": reason}


def unit_motion(unit: Unit, fps: float) -> tuple[Motion, float | None]:
    """The avatar's Motion of a unit's item at fps frames per second, and the kbps of its lexicon .pose file
    (None for a word)."""
    from media.fingerspelling import fingerspell, letter_motion
    from pipeline.studies.shared import pose_file_kbps
    if unit.word:
        return fingerspell(unit.language, unit.item, fps), None
    return letter_motion(unit.language, unit.item, fps), pose_file_kbps(unit.language, unit.item)


def measure_unit(unit: Unit) -> list[dict]:
    """Retarget a unit's item (once: later frame rates resample the cached clip) and measure each of its points;
    one record per point, a kind "failed" one (with the reason) for a point that could not be measured. Pure: the
    same unit gives the same records on any worker, timing fields (TIMING_FIELDS) aside."""
    records = []
    for fps in dict.fromkeys(point.fps for point in unit.points):
        points = [point for point in unit.points if point.fps == fps]
        start, start_cpu = time.perf_counter(), time.process_time()
        try:
            motion, pose_kbps = unit_motion(unit, fps)
        except Exception as error:                   # noqa: BLE001 -- a bad clip fails its points, not the sweep
            records += [failed_record(unit, point, _reason(error)) for point in points]
            continue
        timing = {"retarget_s": time.perf_counter() - start, "retarget_cpu_s": time.process_time() - start_cpu}
        records += [_measured_record(unit, point, motion, pose_kbps, timing) for point in points]
    return records


def _measured_record(unit: Unit, point: Point, motion: Motion, pose_kbps: float | None, timing: dict) -> dict:
    """One point's record (or its failed record); timing: retarget_s and retarget_cpu_s, the wall and CPU seconds
    it took to build the motion at the point's frame rate."""
    start, start_cpu = time.perf_counter(), time.process_time()
    try:
        measured = measure_point(motion, point.codec, point.q)
        record = make_record(solution_of(point.codec), f"{unit.language}:{unit.item}", point.codec, point.q,
                             point.fps, 0, 0, measured.pop("bits"), motion.duration_s, **measured,
                             task=point.task, language=unit.language, item=unit.item)
        if pose_kbps is not None:
            record["pose_kbps"] = pose_kbps
        record.update(wall_s=time.perf_counter() - start, cpu_s=time.process_time() - start_cpu, **timing)
    except Exception as error:                       # noqa: BLE001 -- one point's failure is recorded, not raised
        record = failed_record(unit, point, _reason(error))
    return record


# --------------------------------------------------------------------------- the output folder and resuming

def prepare_folder(out: Path, *, force: bool = False) -> list[Path]:
    """Check, create and probe the --out folder before any work; list the sweep's files in its MANIFEST (so a
    killed sweep's folder is still recognised as signcast's). force: remove what an earlier sweep wrote there (start
    over); other files are kept. Returns the folders created (outermost first)."""
    out = Path(out)
    check_folder(out, force=force, resumable=True)
    created = []
    for folder in reversed([out, *out.parents]):
        if folder.is_dir():
            continue
        try:
            folder.mkdir()
        except OSError as error:
            for made in reversed(created):
                made.rmdir()
            raise SigncastError(f"cannot create folder {out}: {error.strerror or error}") from None
        created.append(folder)
    try:
        with tempfile.NamedTemporaryFile(dir=out, prefix=".signcast-probe-"):
            pass
    except OSError as error:
        for made in reversed(created):
            made.rmdir()
        raise SigncastError(f"cannot write to {out}: {error.strerror or error}") from None
    if force:
        for name in SWEEP_FILES:
            (out / name).unlink(missing_ok=True)
    manifest = out / MANIFEST
    listed = manifest.read_text(encoding="utf-8").splitlines() if manifest.is_file() else []
    manifest.write_text("".join(f"{name}\n" for name in dict.fromkeys([*listed, *SWEEP_FILES]) if name.strip()),
                        encoding="utf-8")
    return created


def _replace_records(path: Path, records: list[dict]) -> None:
    """Rewrite records.jsonl with records, atomically (a kill leaves the old file or the new one)."""
    temporary = path.with_name(path.name + ".tmp")
    write_records(temporary, records)
    os.replace(temporary, path)


def load_finished(path: Path, *, skip_failed: bool = False) -> tuple[list[dict], set[str]]:
    """The records of an earlier sweep in path and the task keys not to measure again (done points, and failed
    ones with skip_failed). A truncated last line is dropped and failed records to retry are removed (the file is
    rewritten); records without a task key mean the file is not a sweep's (SigncastError)."""
    path = Path(path)
    if not path.is_file():
        return [], set()
    raw = path.read_bytes()
    rewrite = False
    if raw and not raw.endswith(b"\n"):
        head, _, last = raw.rpartition(b"\n")
        try:
            json.loads(last)
            raw += b"\n"                                 # complete, only the newline was lost
        except ValueError:
            raw = head + b"\n" if head else b""
        rewrite = True
    if rewrite:
        path.write_bytes(raw)
    records = read_records(path) if raw else []
    sweep_kinds = ("point", "failed")
    foreign = [r for r in records if r.get("kind") in sweep_kinds and not r.get("task")]
    if foreign:
        raise SigncastError(f"{path} holds records that signcast sweep did not write (no task key): choose a new "
                            f"--out, or pass --force to start over")
    stale = stale_records(records)
    if stale:
        raise SigncastError(f"{path} holds {len(stale)} points measured by another version than this one "
                            f"({code_version()}), which the report cannot mix: choose a new --out, or pass --force "
                            f"to start over")
    done = {r["task"] for r in records if r.get("kind") == "point"}
    failed = {r["task"] for r in records if r.get("kind") == "failed"} - done
    if skip_failed:
        return records, done | failed
    kept = [r for r in records if r.get("kind") != "failed"]
    if len(kept) != len(records):
        _replace_records(path, kept)
    return kept, done


def stale_records(records: list[dict], version: str | None = None) -> list[dict]:
    """The point and failed records whose task key is not the one their parameters give under this code version
    (`code_version`): measured by another signcast, or before TASK_VERSION changed what a point measures."""
    version = version or code_version()
    return [r for r in records if r.get("kind") in ("point", "failed") and r.get("task") != _record_key(r, version)]


def _record_key(record: dict, version: str) -> str | None:
    """The task key of a point or failed record's parameters under version (None: the record lacks them)."""
    try:
        return task_key(*language_item(record), record["codec"], record["q"], record["fps"], record["solution"],
                        version)
    except (KeyError, TypeError, ValueError):
        return None


def pending_units(units: list[Unit], finished: set[str]) -> list[Unit]:
    """The units with the points not yet finished (units with none left dropped)."""
    left = []
    for unit in units:
        points = tuple(p for p in unit.points if p.task not in finished)
        if points:
            left.append(Unit(unit.language, unit.item, unit.word, points))
    return left


# --------------------------------------------------------------------------- executors

class LocalExecutor:
    """A process pool on this machine (forkserver: workers start from a process that imported the study once)."""

    name = "local"

    def __init__(self, workers: int | None) -> None:
        self.slots = workers or len(os.sched_getaffinity(0))
        self.pool = self._new_pool()

    def _new_pool(self):
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        context = multiprocessing.get_context("forkserver")
        context.set_forkserver_preload(["pipeline.studies.sweep", "comparisons.params.study",
                                        "media.fingerspelling", "media.pose_file"])
        return ProcessPoolExecutor(max_workers=self.slots, mp_context=context, initializer=_ignore_interrupts)

    def submit(self, unit: Unit):
        from concurrent.futures.process import BrokenProcessPool
        try:
            return self.pool.submit(measure_unit, unit)
        except BrokenProcessPool:          # a worker died (its units are recorded as failed): start a new pool
            self.pool.shutdown(wait=False, cancel_futures=True)
            self.pool = self._new_pool()
            return self.pool.submit(measure_unit, unit)

    def wait(self, handles: list, timeout: float) -> list:
        from concurrent.futures import FIRST_COMPLETED, wait
        finished, _ = wait(handles, timeout=timeout, return_when=FIRST_COMPLETED)
        return list(finished)

    def result(self, handle) -> list[dict]:
        return handle.result()

    def close(self, *, now: bool = False) -> None:
        self.pool.shutdown(wait=not now, cancel_futures=True)


def _ignore_interrupts() -> None:
    """Workers leave Ctrl-C to the driver, which lets the running units finish."""
    import signal
    signal.signal(signal.SIGINT, signal.SIG_IGN)


class RayExecutor:
    """Ray: a local Ray instance (ray.init()), or the cluster at address. One CPU per unit."""

    name = "ray"

    def __init__(self, workers: int | None, address: str | None) -> None:
        import logging
        try:
            import ray
        except ImportError:
            raise SigncastError(RAY_MISSING) from None
        if address:
            _probe_cluster(address)
        try:
            ray.init(address=address or None, num_cpus=None if address else workers, include_dashboard=False,
                     log_to_driver=False, logging_level=logging.ERROR, configure_logging=True)
        except Exception as error:                   # noqa: BLE001 -- Ray's own error types vary by cause
            ray.shutdown()
            first = _reason(error).split(". ")[0]
            where = f"the Ray cluster at {address}" if address else "a local Ray instance"
            raise SigncastError(f"cannot start {where}: {first}") from None
        self.ray = ray
        self.slots = max(1, int(ray.cluster_resources().get("CPU", workers or 1)))
        self.remote = ray.remote(num_cpus=1, max_retries=1)(measure_unit)

    def submit(self, unit: Unit):
        return self.remote.remote(unit)

    def wait(self, handles: list, timeout: float) -> list:
        ready, rest = self.ray.wait(handles, num_returns=1, timeout=timeout)
        if ready and rest:
            more, _ = self.ray.wait(rest, num_returns=len(rest), timeout=0)
            ready += more
        return ready

    def result(self, handle) -> list[dict]:
        return self.ray.get(handle)

    def close(self, *, now: bool = False) -> None:
        self.ray.shutdown()


def _probe_cluster(address: str, timeout_s: float = 10.0) -> None:
    """Refuse a HOST:PORT (or ray://HOST:PORT) cluster address nothing answers at: ray.init would retry forever."""
    import socket

    target = address.removeprefix("ray://")
    host, _, port = target.rpartition(":")
    if not host or not port.isdigit():
        if address == "auto":
            return
        raise SigncastError(f"bad --address {address!r}: give HOST:PORT of the Ray head node (its GCS port, "
                            f"6379 by default), ray://HOST:PORT for Ray Client, or auto")
    try:
        socket.create_connection((host.strip("[]"), int(port)), timeout=timeout_s).close()
    except OSError as error:
        raise SigncastError(f"cannot reach the Ray cluster at {address}: {error.strerror or error}") from None


def start_executor(settings: SweepSettings):
    if settings.executor == "ray":
        return RayExecutor(settings.workers, settings.address)
    return LocalExecutor(settings.workers)


# --------------------------------------------------------------------------- the driver

def run(settings: SweepSettings, out: str | Path, *, force: bool = False,
        progress: Callable[[SweepState], object] | None = None, max_units: int | None = None,
        report: bool = True) -> SweepResult:
    """Measure every point of the sweep not finished in out/records.jsonl; append each unit's records as it
    finishes; write the report (comparisons.reports.sweep) unless report is False.

    progress: called with the SweepState after every change (and about twice a second). max_units: stop after this
    many units (the rest is left for a later run, as after Ctrl-C). A KeyboardInterrupt stops handing out units,
    waits for the running ones (a second one stops at once) and is raised again once their records are written."""
    started = time.perf_counter()
    units = plan(settings)
    out = Path(out)
    created = prepare_folder(out, force=force)
    path = out / RECORDS
    executor = None
    try:
        existing, finished = load_finished(path, skip_failed=settings.skip_failed)
        todo = pending_units(units, finished)
        _check_size(sum(len(u.points) for u in todo), held=len(existing))
        if todo and max_units != 0:
            executor = start_executor(settings)
    except BaseException:
        if not path.exists():                        # nothing measured: leave no trace
            (out / MANIFEST).unlink(missing_ok=True)
            for made in reversed(created):
                made.rmdir()
        raise
    total = sum(len(u.points) for u in units)
    state = SweepState(total=total, skipped=total - sum(len(u.points) for u in todo), units_left=len(todo))
    if max_units is not None:
        todo = todo[:max(0, max_units)]
    measuring = executor is not None and bool(todo)  # a re-run with nothing left to measure appends no line
    if measuring:
        write_records(path, [{"kind": "run", "executor": settings.executor, "workers": getattr(executor, "slots", 0),
                              "versions": versions(), "task_version": TASK_VERSION}], append=True)
    interrupted = False
    try:
        if executor is not None:
            interrupted = _drive(executor, todo, path, state, progress)
    finally:
        if executor is not None:
            executor.close(now=interrupted)
    wall_s = time.perf_counter() - started
    if measuring:
        write_records(path, [{"kind": "stage", "stage": f"sweep ({settings.executor})", "wall_s": round(wall_s, 3),
                              "points_done": state.done, "points_failed": state.failed,
                              "points_skipped": state.skipped}], append=True)
    typed = read_typed_records(path) if path.exists() else []
    records = [record.to_json() for record in typed]
    if report:
        from comparisons.reports.sweep import report_outputs
        write_outputs(out, report_outputs(typed))
    if interrupted:
        raise KeyboardInterrupt
    return SweepResult(state, records, wall_s=wall_s)


def _drive(executor, todo: list[Unit], path: Path, state: SweepState,
           progress: Callable[[SweepState], object] | None) -> bool:
    """Hand out units, at most one per slot; write each unit's records as it finishes. Returns whether a
    KeyboardInterrupt stopped it (after the running units finished)."""
    queue = list(reversed(todo))
    running: dict = {}
    interrupted = False

    def report() -> None:
        state.running = sum(len(u.points) for u in running.values())
        if progress:
            progress(state)

    report()
    while queue or running:
        try:
            while queue and not interrupted and len(running) < executor.slots:
                unit = queue.pop()
                running[executor.submit(unit)] = unit
            report()
            if not running:
                break
            for handle in executor.wait(list(running), timeout=0.5):
                unit = running.pop(handle)
                try:
                    records = executor.result(handle)
                except Exception as error:           # noqa: BLE001 -- a worker that died fails its unit only
                    records = [failed_record(unit, p, f"worker failed: {_reason(error)}") for p in unit.points]
                write_records(path, records, append=True)
                state.done += sum(1 for r in records if r["kind"] == "point")
                state.failed += sum(1 for r in records if r["kind"] == "failed")
                state.units_left -= 1
                report()
        except KeyboardInterrupt:
            if interrupted or not running:
                return True
            interrupted = state.stopping = True
            queue.clear()
    return interrupted


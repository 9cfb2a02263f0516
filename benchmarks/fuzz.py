"""Coverage-guided fuzzing of every decoder and reader (atheris / libFuzzer), one subprocess per target.

Targets and their oracles: tests/fuzz/fuzz_targets.py; seed corpora: tests/fuzz/corpus/<target>/
(regenerate with tools/make_fuzz_corpus.py). comparisons, media and pose_format are instrumented, except the
modules that import Numba (compiled_modules: Numba cannot type instrumented bytecode); their Python callers are.
The corpora are copied to a temporary folder so the repository is never written. Each target runs for
--seconds under libFuzzer with -rss_limit_mb=1024 (and an address-space limit 1.5 GB above the warmed-up
process, so that one huge allocation fails at once as MemoryError instead of swapping the machine).

A finding is any outcome but a clean rejection (SigncastError) or a correct decode: another
exception type (crash), DecodeMismatch (a decode that fails its oracle), a timeout, or memory
(oom: libFuzzer's RSS limit or MemoryError). A timeout is an input that takes over 1 s of CPU
time: measured per input, since on a shared machine wall-clock time also counts other people's
jobs; libFuzzer's wall-clock -timeout (10 s, --wall-timeout) catches endless loops. Python
exceptions and slow inputs are recorded and fuzzing goes on (one reproducer per exception type
and place, one slow input); libFuzzer's timeout or oom ends that target's run. Each
reproducer is written to FINDINGS/<target>/ with its checksums already repaired, so it reproduces
with the plain decoder. Prints a table (target, execs, coverage, features, findings); the exit
status is 1 if any target found something.

    python benchmarks/fuzz.py --targets all --seconds 60 [--jobs 2] [--findings /tmp/fuzz-findings]
    python benchmarks/fuzz.py --targets fba,bba --total-seconds 600
    python benchmarks/fuzz.py --targets live --total-seconds 600 --jobs 2   # the live receiver's parsers
"""
from __future__ import annotations

import argparse
import dataclasses
import hashlib
import json
import math
import re
import shutil
import subprocess
import sys
import tempfile
import time
import traceback
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FUZZ_DIR = ROOT / "tests" / "fuzz"
INSTRUMENTED = ["comparisons", "media", "pose_format", "pipeline.live"]
_IMPORTS_NUMBA = re.compile(r"^\s*(import numba|from numba[ .])", re.M)
HANG_CPU_S = 1.0                                # a hang: one input takes more CPU time than this
WALL_TIMEOUT_S = 10                             # libFuzzer's -timeout: the backstop for endless loops
RSS_LIMIT_MB = 1024
ADDRESS_SPACE_MARGIN = 3 << 29                  # 1.5 GiB over the warmed-up process
FINDINGS_FILE = "findings.jsonl"
ENCODER_ORACLE_EVERY = 4                        # run the costly encoder oracles on a quarter of the inputs


@dataclass
class Result:
    """What one target's run found. execs: inputs run; cov, ft: libFuzzer's coverage and features."""
    target: str
    seconds: float
    execs: int = 0
    cov: int | None = None
    ft: int | None = None
    findings: list[dict] = field(default_factory=list)
    exit_code: int | None = None


# ---------------------------------------------------------------------------------- the worker

def compiled_modules(packages: list[str] = INSTRUMENTED) -> list[str]:
    """Dotted names of the modules of `packages` (those inside this repository) that import Numba.

    atheris rewrites a module's bytecode to trace its branches, and Numba cannot type the rewritten
    functions (a TypingError at their first call), so these modules are imported plain: their
    compiled loops are fuzzed through the instrumented Python that calls them."""
    names = []
    for package in packages:
        folder = ROOT.joinpath(*package.split("."))
        for path in sorted(folder.rglob("*.py")) if folder.is_dir() else ():
            if _IMPORTS_NUMBA.search(path.read_text(encoding="utf-8", errors="replace")):
                parts = path.relative_to(ROOT).with_suffix("").parts
                names.append(".".join(parts[:-1] if parts[-1] == "__init__" else parts))
    return names


def _where(error: BaseException) -> tuple[str, str]:
    """(innermost frame in signcast's code, innermost frame overall), as 'path:line in function'."""
    frames = traceback.extract_tb(error.__traceback__)
    helpers = {"_expect", "_same", "_check_array", "_check_fps", "run", "one_input"}

    def text(frame) -> str:
        name = Path(frame.filename)
        shown = name.relative_to(ROOT) if name.is_relative_to(ROOT) and ".venv" not in name.parts else name
        return f"{shown}:{frame.lineno} in {frame.name}"
    ours = [f for f in frames if Path(f.filename).is_relative_to(ROOT) and ".venv" not in Path(f.filename).parts
            and f.name not in helpers and Path(f.filename).name != "fuzz.py"]
    return (text(ours[-1]) if ours else "?"), (text(frames[-1]) if frames else "?")


def _worker(target: str, findings: Path, libfuzzer_args: list[str]) -> None:
    import atheris

    sys.path.insert(0, str(ROOT))
    sys.path.insert(0, str(FUZZ_DIR))
    findings.mkdir(parents=True, exist_ok=True)
    seen: set[tuple] = set()
    with atheris.instrument_imports(include=INSTRUMENTED, exclude=compiled_modules()):
        import fuzz_targets
        # warm up inside the instrumented import: the targets import their decoders and load their
        # tables on first use, which must neither escape instrumentation nor count against -timeout
        for path in fuzz_targets.corpus_files(target):
            try:
                fuzz_targets.run(target, path.read_bytes())
            except Exception:
                pass
    seal = fuzz_targets.TARGETS[target].seal
    fuzz_targets.ENCODER_ORACLE_EVERY = ENCODER_ORACLE_EVERY

    def record(signature: tuple, kind: str, data: bytes, **fields) -> None:
        """Save the reproducer (checksums repaired) and a findings line, once per signature."""
        if signature in seen:
            return
        seen.add(signature)
        try:
            sealed = seal(data)
        except Exception:
            sealed = data
        reproducer = findings / f"{kind}-{hashlib.sha1(sealed).hexdigest()[:16]}"
        reproducer.write_bytes(sealed)
        line = json.dumps({"kind": kind, **fields, "reproducer": str(reproducer), "size": len(sealed)})
        with (findings / FINDINGS_FILE).open("a") as handle:
            handle.write(line + "\n")
        print(f"FINDING {line}", file=sys.stderr, flush=True)

    def one_input(data: bytes) -> None:
        started = time.process_time()
        try:
            fuzz_targets.run(target, data)
        except Exception as error:
            where, innermost = _where(error)
            message = str(error).splitlines()[0][:300] if str(error) else ""
            mismatch = isinstance(error, fuzz_targets.DecodeMismatch)
            kind = "oom" if isinstance(error, MemoryError) else "mismatch" if mismatch else "crash"
            signature = (type(error).__name__, where, re.sub(r"\d+", "N", message)[:60] if mismatch else "")
            record(signature, kind, data, type=type(error).__name__, message=message, where=where, innermost=innermost)
        cpu_s = time.process_time() - started
        if cpu_s > HANG_CPU_S:
            record(("timeout",), "timeout", data, type=f"{cpu_s:.1f} s of CPU for one input")

    _limit_address_space()
    atheris.Setup([sys.argv[0], *libfuzzer_args], one_input)
    atheris.Fuzz()


def _limit_address_space() -> None:
    import resource
    with open("/proc/self/status") as status:
        size_kb = next(int(line.split()[1]) for line in status if line.startswith("VmSize:"))
    limit = size_kb * 1024 + ADDRESS_SPACE_MARGIN
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))


# ---------------------------------------------------------------------------------- the parent

_STATUS = re.compile(r"^#(\d+)\s+\w+\s+cov: (\d+) ft: (\d+)", re.M)
_EXECS = re.compile(r"stat::number_of_executed_units: (\d+)")
_ARTIFACT = re.compile(r"Test unit written to (\S+)")


def run_target(target: str, seconds: int, findings_root: Path, wall_timeout_s: int = WALL_TIMEOUT_S) -> Result:
    """Fuzz one target in its own subprocess for `seconds` (plus start-up); its findings go to findings_root/target."""
    findings = findings_root / target
    findings.mkdir(parents=True, exist_ok=True)
    (findings / FINDINGS_FILE).unlink(missing_ok=True)
    result = Result(target, seconds)
    sys.path.insert(0, str(FUZZ_DIR))
    import fuzz_targets  # the corpus location only; the decoders stay unimported here
    with tempfile.TemporaryDirectory(prefix=f"fuzz-{target}-") as work:
        corpus = Path(work) / "corpus"
        corpus.mkdir()
        for path in fuzz_targets.corpus_files(target):
            shutil.copy(path, corpus / path.name)
        command = [sys.executable, str(Path(__file__).resolve()), "--worker", target, "--findings", str(findings),
                   "--", str(corpus), f"-max_total_time={seconds}", f"-timeout={wall_timeout_s}",
                   f"-rss_limit_mb={RSS_LIMIT_MB}", f"-artifact_prefix={findings}/", "-print_final_stats=1"]
        try:
            done = subprocess.run(command, cwd=work, capture_output=True, text=True, errors="replace",
                                  timeout=seconds + 120 + wall_timeout_s)
            output, result.exit_code = done.stderr + done.stdout, done.returncode
        except subprocess.TimeoutExpired as expired:
            output = expired.stderr or ""
            output = output.decode(errors="replace") if isinstance(output, bytes) else output
            result.findings.append({"kind": "timeout", "type": "worker did not finish",
                                    "message": f"no result after {seconds + 120} s", "reproducer": ""})
    statuses = _STATUS.findall(output)
    if statuses:
        result.execs, result.cov, result.ft = (int(v) for v in statuses[-1])
    execs = _EXECS.search(output)
    if execs:
        result.execs = int(execs.group(1))
    if (findings / FINDINGS_FILE).exists():
        result.findings += [json.loads(line) for line in (findings / FINDINGS_FILE).read_text().splitlines()]
    artifact = _ARTIFACT.search(output)
    if artifact and Path(artifact.group(1)).is_file():
        # libFuzzer saved the raw input: repair its checksums as the target does, so the plain decoder reproduces it
        path = Path(artifact.group(1))
        path.write_bytes(fuzz_targets.TARGETS[target].seal(path.read_bytes()))
    if "libFuzzer: timeout" in output or "ALARM: working on the last Unit" in output:
        result.findings.append({"kind": "timeout", "type": f"over {wall_timeout_s} s wall-clock",
                                "reproducer": artifact.group(1) if artifact else ""})
    elif "libFuzzer: out-of-memory" in output:
        result.findings.append({"kind": "oom", "type": f"over {RSS_LIMIT_MB} MB",
                                "reproducer": artifact.group(1) if artifact else ""})
    elif result.exit_code not in (0, None) and not result.findings:
        tail = " | ".join(output.strip().splitlines()[-3:])[:300]
        result.findings.append({"kind": "error", "type": f"worker exit {result.exit_code}", "message": tail,
                                "reproducer": artifact.group(1) if artifact else ""})
    (findings / "output.txt").write_text(output)
    return result


def run_targets(targets: list[str], seconds: int, findings_root: Path, jobs: int = 1,
                wall_timeout_s: int = WALL_TIMEOUT_S) -> list[Result]:
    """Fuzz every target, `jobs` subprocesses at a time; results in the order of `targets`."""
    with ThreadPoolExecutor(max_workers=max(1, jobs)) as pool:
        return list(pool.map(lambda t: run_target(t, seconds, findings_root, wall_timeout_s), targets))


def table(results: list[Result]) -> str:
    lines = [f"{'target':18s} {'seconds':>7s} {'execs':>9s} {'cov':>6s} {'ft':>7s}  findings"]
    for r in results:
        found = "; ".join(f"{f['kind']}: {f['type']}" + (f" at {f['where']}" if f.get("where") else "")
                          + (f" -> {f['reproducer']}" if f.get("reproducer") else "") for f in r.findings) or "none"
        lines.append(f"{r.target:18s} {r.seconds:7d} {r.execs:9d} {r.cov if r.cov is not None else '-':>6} "
                     f"{r.ft if r.ft is not None else '-':>7}  {found}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["--worker"]:
        split = argv.index("--")
        _worker(argv[1], Path(argv[argv.index("--findings") + 1]), argv[split + 1:])
        return 0
    sys.path.insert(0, str(FUZZ_DIR))
    import fuzz_targets
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--targets", default="all",
                        help=f"all, or comma-separated from: {', '.join(fuzz_targets.TARGETS)}")
    parser.add_argument("--seconds", type=int, default=60, help="fuzzing time per target (start-up not counted)")
    parser.add_argument("--total-seconds", type=int, help="instead of --seconds: this budget split across the targets")
    parser.add_argument("--jobs", type=int, default=1, help="targets fuzzed at the same time")
    parser.add_argument("--findings", type=Path, default=Path(tempfile.gettempdir()) / "fuzz-findings",
                        help="reproducers go to FINDINGS/<target>/")
    parser.add_argument("--wall-timeout", type=int, default=WALL_TIMEOUT_S,
                        help="libFuzzer's -timeout, seconds of wall-clock time per input (1 on an idle machine)")
    parser.add_argument("--json", type=Path, help="also write the results to this file (one object per target)")
    args = parser.parse_args(argv)
    targets = (list(fuzz_targets.TARGETS) if args.targets == "all" else list(fuzz_targets.LIVE_TARGET_NAMES)
               if args.targets == "live" else args.targets.split(","))
    unknown = sorted(set(targets) - set(fuzz_targets.TARGETS))
    if unknown:
        parser.error(f"unknown targets {', '.join(unknown)}")
    seconds = args.seconds
    if args.total_seconds:
        seconds = max(1, math.floor(args.total_seconds / math.ceil(len(targets) / max(1, args.jobs))))
    started = time.monotonic()
    results = run_targets(targets, seconds, args.findings, args.jobs, args.wall_timeout)
    print(table(results))
    if args.json:
        args.json.write_text(json.dumps([dataclasses.asdict(r) for r in results], indent=1))
    print(f"{len(targets)} targets, {time.monotonic() - started:.0f} s; findings under {args.findings}")
    return 1 if any(r.findings for r in results) else 0


if __name__ == "__main__":
    sys.exit(main())

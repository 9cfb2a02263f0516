"""The short fuzzing pass of CI: every decoder and reader under atheris for a few seconds, every seed
of the corpora decoded cleanly, and a fixed set of damaged seeds (hypothesis, derandomised) decoded
or rejected cleanly (benchmarks/fuzz.py, tests/fuzz/fuzz_targets.py)."""
import json
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "fuzz"))

import fuzz_targets  # noqa: E402

SHORT_SECONDS = 3          # per target; two targets at a time
CORPUS_LIMIT_BYTES = 1 << 20


@pytest.fixture(scope="module")
def short_pass(tmp_path_factory) -> dict[str, dict]:
    """Fuzz every target for SHORT_SECONDS (one subprocess each); results by target name."""
    folder = tmp_path_factory.mktemp("fuzz")
    results = folder / "results.json"
    subprocess.run([sys.executable, str(ROOT / "benchmarks" / "fuzz.py"), "--targets", "all",
                    "--seconds", str(SHORT_SECONDS), "--jobs", "2", "--findings", str(folder / "findings"),
                    "--json", str(results)], cwd=ROOT, capture_output=True, text=True, timeout=600)
    return {r["target"]: r for r in json.loads(results.read_text())}


@pytest.mark.slow
@pytest.mark.parametrize("target", list(fuzz_targets.TARGETS))
def test_short_fuzz_pass_finds_nothing(short_pass, target):
    result = short_pass[target]
    assert result["execs"] > 0, f"{target} never ran an input"
    assert result["findings"] == []


@pytest.mark.parametrize("target", list(fuzz_targets.TARGETS))
def test_every_seed_decodes_correctly(target):
    seeds = fuzz_targets.corpus_files(target)
    assert seeds, f"no seed corpus for {target}: run tools/make_fuzz_corpus.py"
    for path in seeds:
        assert fuzz_targets.run(target, path.read_bytes()) == "decoded", path.name


def test_seed_corpora_stay_small():
    total = sum(p.stat().st_size for t in fuzz_targets.TARGETS for p in fuzz_targets.corpus_files(t))
    assert 0 < total < CORPUS_LIMIT_BYTES


def test_motion_targets_are_the_lab_coders():
    from comparisons.lab.codecs import LAB_CODEC_NAMES
    assert fuzz_targets.MOTION_CODERS == LAB_CODEC_NAMES
    assert {f"motion-{name}" for name in LAB_CODEC_NAMES} <= set(fuzz_targets.TARGETS)


def _checksum_bytes(target: str) -> list[int]:
    """Offsets of checksum bytes: FBA's trailing CRC, the shape header's CRC (its last field), both
    CRCs of a motion-coder clip (the inner stream's ends 4 bytes before the clip's)."""
    if target == "shape":
        from comparisons.video.shape import _HEADER
        return [_HEADER.size - 1]
    return [-1] if target == "fba" else [-1, -5]


@pytest.mark.parametrize("target", ["fba", "shape", "motion-quant", "motion-hybrid"])
def test_seal_repairs_damaged_checksums_and_keeps_a_valid_stream(target):
    seal = fuzz_targets.TARGETS[target].seal
    seed = fuzz_targets.corpus_files(target)[0].read_bytes()
    assert seal(seed) == seed
    damaged = bytearray(seed)
    for offset in _checksum_bytes(target):
        damaged[offset] ^= 0x5A
    assert fuzz_targets.run(target, bytes(damaged)) == "decoded"
    assert bytes(damaged) != seed and seal(bytes(damaged)) == seed


def test_oracle_rejects_a_decode_with_nan():
    import numpy as np
    with pytest.raises(fuzz_targets.DecodeMismatch, match="NaN"):
        fuzz_targets._check_array(np.array([[1.0, np.nan]]), (None, 2), np.float64)


def test_damaged_seed_is_rejected_with_signcast_error_not_decoded():
    seed = fuzz_targets.corpus_files("bba")[0].read_bytes()
    assert fuzz_targets.run("bba", seed[: len(seed) // 2]) == "rejected"


@st.composite
def _mutated_seed(draw, target: str) -> bytes:
    """A seed of `target` with a few bytes overwritten, inserted or cut (what a damaged channel does)."""
    data = bytearray(draw(st.sampled_from(fuzz_targets.corpus_files(target))).read_bytes())
    for _ in range(draw(st.integers(1, 4))):
        where = draw(st.integers(0, max(0, len(data) - 1)))
        action = draw(st.sampled_from(["set", "insert", "cut"]))
        if action == "set" and data:
            data[where] = draw(st.integers(0, 255))
        elif action == "insert":
            data[where:where] = draw(st.binary(min_size=1, max_size=8))
        else:
            del data[where:where + draw(st.integers(1, 16))]
    return bytes(data)


@pytest.mark.parametrize("target", list(fuzz_targets.TARGETS))
def test_mutated_seeds_decode_or_are_rejected_cleanly(target):
    @settings(max_examples=15, deadline=None, derandomize=True, database=None,
              suppress_health_check=list(HealthCheck))
    @given(_mutated_seed(target))
    def decodes_or_rejects(data):
        assert fuzz_targets.run(target, data) in ("decoded", "rejected")
    decodes_or_rejects()

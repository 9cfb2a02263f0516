"""The fuzzing corpora in pytest: every seed of the corpora decoded cleanly, a fixed set of damaged seeds
(hypothesis, derandomised) decoded or rejected cleanly, and the fuzzer's set-up (benchmarks/fuzz.py,
tests/fuzz/fuzz_targets.py). The short coverage-guided pass itself (atheris, every target for a few
seconds; each pays for an instrumented import) is its own CI step in .ci/run, failing CI on a finding."""
import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "fuzz"))

import fuzz_targets  # noqa: E402

CORPUS_LIMIT_BYTES = 1 << 20


@pytest.mark.parametrize("target", list(fuzz_targets.TARGETS))
def test_every_seed_decodes_correctly(target):
    seeds = fuzz_targets.corpus_files(target)
    assert seeds, f"no seed corpus for {target}: run tools/make_fuzz_corpus.py"
    for path in seeds:
        assert fuzz_targets.run(target, path.read_bytes()) == "decoded", path.name


def test_the_fuzzer_leaves_every_numba_module_uninstrumented():
    """atheris rewrites bytecode that Numba then cannot type: every module that imports Numba is excluded."""
    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))
    from benchmarks import fuzz
    excluded = set(fuzz.compiled_modules())
    assert {"comparisons.params.arithmetic", "comparisons.video.shape_cae", "media.face_rig_solve"} <= excluded
    for name in excluded:
        path = ROOT.joinpath(*name.split(".")).with_suffix(".py")
        assert path.is_file() and "numba" in path.read_text(), name
    assert not any(name.startswith("pose_format") for name in excluded)     # installed, not in this tree


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

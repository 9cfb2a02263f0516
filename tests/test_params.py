"""The parameter codec registry and `signcast params` on real fingerspelling."""
import csv
import json

import numpy as np
import pytest

from comparisons.params.codecs import REGISTRY, get_codec, register
from media.avatar import load_avatar
from media.face_rig import with_face_bones
from media.errors import SigncastError
from media.fingerspelling import letter_motion
from media.kinematics import joint_positions
from pipeline.cli import main


def test_registry_lists_the_five_mpeg4_codecs_and_rejects_unknown_names():
    assert {"fba-pred", "fba-dct", "bba-pred", "bba-dct", "bba-key"} <= set(REGISTRY)
    with pytest.raises(SigncastError, match="unknown parameter codec"):
        get_codec("fba-wavelet")
    with pytest.raises(SigncastError):
        register(object())


@pytest.mark.parametrize("name", ["fba-pred", "fba-dct", "bba-pred", "bba-dct", "bba-key"])
def test_every_codec_decodes_real_fingerspelling_close_to_the_original(name):
    motion = letter_motion("ase", "B", 10)
    codec = get_codec(name)
    fine = codec.encode(motion, 1)
    coarse = codec.encode(motion, 31)
    assert len(coarse) < len(fine)
    decoded = codec.decode(fine)
    assert decoded.n_frames == motion.n_frames and decoded.fps == motion.fps
    skeleton = load_avatar().skeleton
    # the face as the avatar plays it: FAPs through the face rig (FBA), face bones as sent (BBA)
    played, received = with_face_bones(motion), with_face_bones(decoded)
    error_mm = 1000 * np.linalg.norm(joint_positions(skeleton, played) - joint_positions(skeleton, received), axis=-1)
    limit = 60.0 if name == "bba-key" else 5.0                 # key frames trade accuracy for rate
    assert error_mm.max() < limit
    with pytest.raises(SigncastError):
        codec.decode(fine[:-5])


@pytest.mark.slow
def test_params_command_writes_records_table_and_plot(tmp_path, capsys):
    out = tmp_path / "params"
    assert main(["params", "ase", "AB", "--codecs", "fba-pred,bba-dct", "--param-q", "2,16", "--fps", "10", "--out", str(out)]) == 0
    records = [json.loads(line) for line in (out / "records.jsonl").read_text().splitlines()]
    assert len(records) == 2 * 2 * 2
    for record in records:
        assert record["bits"] > 0 and record["kbps"] == pytest.approx(record["bits"] / record["duration_s"] / 1000)
        assert record["pose_kbps"] > 100 and record["distortion"] >= 0
    rows = list(csv.reader((out / "params_table.csv").open()))
    assert rows[0][:4] == ["sign", "frames", "pose_kbps", "Q=2 fba-pred kbps"] and [r[0] for r in rows[1:]] == ["A", "B"]
    assert (out / "params_rate.png").stat().st_size > 1000
    assert sorted(p.name for p in (out / "bap").iterdir()) == ["ase_A.bap", "ase_B.bap"]
    assert "fba-pred" in capsys.readouterr().out


@pytest.mark.parametrize("args", [["--param-q", "0"], ["--codecs", "fba-nope"], ["--fps", "0"]])
def test_params_command_rejects_bad_arguments_with_exit_code_2(tmp_path, args, capsys):
    assert main(["params", "ase", "A", "--out", str(tmp_path)] + args) == 2
    assert "error" in capsys.readouterr().err


@pytest.mark.parametrize("name", ["fba-pred", "fba-dct", "bba-pred", "bba-dct", "bba-key"])
def test_every_codec_rejects_single_bit_errors(name):
    codec = get_codec(name)
    data = codec.encode(letter_motion("ase", "C", 10), 4)
    rng = np.random.default_rng(7)
    for _ in range(25):
        damaged = bytearray(data)
        damaged[rng.integers(len(damaged))] ^= 1 << int(rng.integers(8))
        with pytest.raises(SigncastError):
            codec.decode(bytes(damaged))


def test_params_alphabet_draws_the_seed_002_charts(tmp_path):
    from pipeline.cli import main
    assert main(["params", "ase", "--alphabet", "--codecs", "dpcm,fba-pred", "--param-q", "4", "--out", str(tmp_path)]) == 0
    assert (tmp_path / "lab_waveform_psnr.png").stat().st_size > 10_000
    from comparisons.reports.records import read_records
    points = [r for r in read_records(tmp_path / "records.jsonl") if r.get("kind", "point") == "point"]
    assert {r["codec"] for r in points} == {"dpcm", "fba-pred"}
    # dpcm is a seed-002 motion coder, not an MPEG-4 FBA stream: its records say so
    assert {(r["codec"], r["solution"]) for r in points} == {("dpcm", "motion coder"), ("fba-pred", "FBA")}


def test_params_without_letters_or_alphabet_is_a_clear_error(tmp_path, capsys):
    from pipeline.cli import main
    assert main(["params", "ase", "--out", str(tmp_path)]) == 2
    assert "LETTERS" in capsys.readouterr().err

"""Write the motion lab's conformance streams, tests/data/conformance/lab/<coder>.npz: small streams of every
seed-002 coder with the exact integers its decoder must return (tests/test_lab_conformance.py checks them).

    .venv/bin/python tools/make_lab_conformance.py [--out tests/data/conformance/lab] [--coders quant dct ...]

Inputs: ASL letters "A" (21 frames) and "J" (25 frames) at 25 fps as stored in tests/data/codec_letter_motions.npz
(media.fingerspelling.letter_motion retargeted them once, tools/make_codec_letter_motions.py), as
comparisons.lab.codecs.LabCodec codes them (the signing DOFs, comparisons.lab.codecs.motion_dofs), at q 1, the
middle operating point and the finest. The stored letters, not letters retargeted now: a retargeting change (the
relaxed resting hand and upright torso of 31debf2 moved every letter) is not a coder change, and the figures below
are measured against the motion the streams were coded from. The stored streams were written from letters retargeted
before 31debf2, which are the stored ones: re-encoding these reproduces every stored stream byte for byte. Each case
<letter>_q<q> of a coder's file holds

- `<case>/stream`: uint8, the LabCodec stream's bytes (SCL1 wrapper, or the compact layout of wavelet-cx);
- the decoder's integers (LabCodec.decode_levels): `<case>/active` (D,) bool active-DOF mask of the signing layout,
  `<case>/n_frames`, `<case>/fps`, and `<case>/levels.<name>` int64 for each name the coder's `_read` returns
  (comparisons/lab/waveform.py, vq.py, model.py document them);
- the encoder's figures on that motion when the stream was stored: `<case>/rms_rad` and `<case>/max_rad`, the
  reconstruction's RMS and largest error over the active DOFs (radians). The stream's length is the stored rate.
  tests/test_lab_conformance.py re-encodes the letter and checks the rate and the error against these within
  stated tolerances (an encoder may write other bytes on another CPU or after a change that keeps its quality).

wavelet-cx-container.npz holds the same cases of wavelet-cx's other layout, the SCM1 container with one b"C"
section and untrained models (ContextWaveletCoder.encode over the letter's active DOFs; `<case>/stream` is that
SCM1 stream, decoded by DofCoder.read_levels; no figures).

When re-storing is legitimate: only when a stream format changes on purpose (another table, context model, binarisation,
header field or entropy stage: the decoder then reads other integers from the same bytes, and the stored streams
stop decoding as before). Say so in the commit and re-measure the figures of docs/motion-lab.md that change. An
encoder change that writes other bytes for the same motion (other rounding in the analysis, a faster fit) does
not call for re-storing: the stored streams stay decodable and pinned, and the encoder is held to the stored rate
and error by the tolerances of tests/test_lab_conformance.py; if it leaves them, that is a finding to explain,
not a fixture to refresh. Retrained tables (tools/train_vq_codebooks.py, tools/train_context_priors.py) are a
format change: the decoder's tables are part of what the stream means. Review the diff of the integers, not only
the bytes.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

DEFAULT_OUT = ROOT / "tests" / "data" / "conformance" / "lab"
LETTER_MOTIONS = ROOT / "tests" / "data" / "codec_letter_motions.npz"
LETTERS = ("A", "J")


def operating_points(n_settings: int) -> tuple[int, ...]:
    """q 1, the middle one and the finest."""
    return tuple(sorted({1, (n_settings + 1) // 2, n_settings}))


def letter_dofs(letter: str) -> tuple[np.ndarray, float]:
    """(T, D) signing DOFs (radians) of the stored ASL letter (LETTER_MOTIONS) as LabCodec codes it, and its fps."""
    from comparisons.lab.codecs import motion_dofs
    from media.motion import Motion
    with np.load(LETTER_MOTIONS) as stored:
        motion = Motion(float(stored[f"{letter}/fps"]), [str(n) for n in stored[f"{letter}/bone_names"]],
                        stored[f"{letter}/rotations"], stored[f"{letter}/root_translation"], stored[f"{letter}/faps"])
    return motion_dofs(motion), motion.fps


def case_entries(name: str, letter: str, q: int) -> dict[str, np.ndarray]:
    from comparisons.lab.codecs import LabCodec
    codec = LabCodec(name)
    dofs, fps = letter_dofs(letter)
    data, recon = codec.encode_dofs(dofs, fps, codec.index_of(q))
    levels, active, n_frames, got_fps = codec.decode_levels(data)
    error = (recon - dofs)[:, active]
    case = f"{letter}_q{q}"
    entries = {f"{case}/stream": np.frombuffer(data, dtype=np.uint8).copy(), f"{case}/active": active,
               f"{case}/n_frames": np.int64(n_frames), f"{case}/fps": np.float64(got_fps),
               f"{case}/rms_rad": np.float64(np.sqrt(np.mean(error ** 2))),
               f"{case}/max_rad": np.float64(np.abs(error).max())}
    for key, value in levels.items():
        entries[f"{case}/levels.{key}"] = np.asarray(value, dtype=np.int64)
    return entries


def main(argv: list[str] | None = None) -> None:
    from comparisons.lab.codecs import LAB_CODEC_NAMES, LabCodec
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT)
    parser.add_argument("--coders", nargs="*", default=list(LAB_CODEC_NAMES), choices=LAB_CODEC_NAMES)
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    for name in args.coders:
        entries = {}
        for letter in LETTERS:
            for q in operating_points(len(LabCodec(name).settings())):
                entries.update(case_entries(name, letter, q))
        _save(args.out / f"{name}.npz", entries)
        if name == "wavelet-cx":
            entries = {}
            for letter in LETTERS:
                for q in operating_points(len(LabCodec(name).settings())):
                    entries.update(container_entries(letter, q))
            _save(args.out / "wavelet-cx-container.npz", entries)


def container_entries(letter: str, q: int) -> dict[str, np.ndarray]:
    """wavelet-cx's SCM1 layout (ContextWaveletCoder.encode) of the letter's active DOFs."""
    from comparisons.lab.codecs import make_coder
    dofs, fps = letter_dofs(letter)
    active = np.any(dofs != 0.0, axis=0)
    coder = make_coder("wavelet-cx", active)
    data, _ = coder.encode(dofs[:, active], fps, q - 1)
    levels, info = coder.read_levels(data)
    case = f"{letter}_q{q}"
    entries = {f"{case}/stream": np.frombuffer(data, dtype=np.uint8).copy(), f"{case}/active": active,
               f"{case}/n_frames": np.int64(info.n_frames), f"{case}/fps": np.float64(info.fps)}
    for key, value in levels.items():
        entries[f"{case}/levels.{key}"] = np.asarray(value, dtype=np.int64)
    return entries


def _save(path: Path, entries: dict[str, np.ndarray]) -> None:
    np.savez_compressed(path, **entries)
    sizes = [len(v) for k, v in entries.items() if k.endswith("/stream")]
    print(f"{path.relative_to(ROOT) if path.is_relative_to(ROOT) else path}: {len(sizes)} streams, "
          f"{min(sizes)}-{max(sizes)} bytes")


if __name__ == "__main__":
    main()

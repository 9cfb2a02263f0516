"""Write the conformance streams of tests/data/conformance/: small parameter and shape streams with the exact
integers their decoders must return (tests/test_conformance.py checks every stored stream against them).

    .venv/bin/python tools/make_conformance_streams.py [--out tests/data/conformance]

One .npz per stream kind; each case <clip>_q<Q> holds `<case>/stream` (uint8, the stream's bytes) and the
decoder's integers:

- fba-pred, fba-dct (comparisons/params/fba.py, body and face, fba_object_mask 3): baps (T, 296) int64 BAP units,
  faps (T, 68) int64 FAP units, face_frames (T,) bool; fps;
- fap-pred, fap-dct (a face-only FBA stream, fba_object_mask 1): faps, face_frames, fps;
- bba-pred, bba-dct, bba-key (comparisons/params/bba.py, the avatar's bones with the face bones of the letter's
  FAPs, as comparisons/params/codecs.BbaCodec encodes): kfi (F,), bone_ids (B,), bone_masks (B,), values (F, P)
  int64 (bba.decode_levels), q, n_frames (display frames), fps;
- bba-xml (comparisons/params/bba_xml.py, the XML form of the bba-pred stream of "A" at Q 31, UTF-8): the same integers from
  from_xml;
- shape-cae (comparisons/video/shape.py): pixels (T, H, W) bool.

Inputs: ASL letters "A" (21 frames) and "J" (25 frames) at 25 fps from media.fingerspelling.letter_motion with
their FAPs, Q 4 and 31; the shape streams code two moving-ellipse mask sequences (a head and a hand).

Re-storing is legitimate only when the stream format itself changes on purpose (a new field, table or context
model: the decoder then reads other integers from the same bytes, and old streams stop decoding as before), and
the commit must say so. An encoder change that writes other bytes for the same motion (other rounding, faster
analysis, another retargeting) does not call for re-storing: the stored streams stay decodable and pinned, and
the encoder is tested by round trip and rate (tests/test_param_codec_properties.py). Regenerating with a changed
encoder or retargeting rewrites every stream; review the diff of the integers, not only the bytes.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_OUT = ROOT / "tests" / "data" / "conformance"
LETTERS = ("A", "J")
QS = (4, 31)
FPS = 25.0


def moving_ellipses(frames: int, height: int, width: int, seed: int) -> np.ndarray:
    """(frames, height, width) bool: a head-like ellipse drifting right and a 'hand' moving down, ragged edge."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[:height, :width]
    masks = np.zeros((frames, height, width), bool)
    for t in range(frames):
        head = ((yy - 18) / 11.0) ** 2 + ((xx - 16 - 2 * t) / 8.0) ** 2
        hand = ((yy - 6 - 3 * t) / 4.0) ** 2 + ((xx - 44) / 5.0) ** 2 <= 1.0
        masks[t] = (head <= 1.0) | hand
        masks[t] ^= (rng.random((height, width)) < 0.05) & (np.abs(head - 1.0) < 0.2)
    return masks


def _bytes(data: bytes) -> np.ndarray:
    return np.frombuffer(bytes(data), dtype=np.uint8).copy()


def _bba_entries(case: str, data: bytes, levels) -> dict[str, np.ndarray]:
    return {f"{case}/stream": _bytes(data), f"{case}/kfi": levels.kfi, f"{case}/bone_ids": levels.bone_ids,
            f"{case}/bone_masks": levels.bone_masks, f"{case}/values": levels.values,
            f"{case}/fps": np.float64(levels.header.fps), f"{case}/q": np.int64(levels.header.q)}


def build() -> dict[str, dict[str, np.ndarray]]:
    """{kind: {npz key: array}} of every conformance stream, encoded by today's encoders."""
    from comparisons.params import bba, bba_xml
    from comparisons.params.codecs import BbaCodec, FbaCodec, _saturated
    from comparisons.params.fba import decode_fba, encode_fba
    from comparisons.video.shape import decode_shape, encode_shape
    from media.fingerspelling import letter_motion

    kinds: dict[str, dict[str, np.ndarray]] = {}
    for letter in LETTERS:
        motion = letter_motion("ase", letter, FPS)
        for q in QS:
            case = f"ase_{letter}_q{q}"
            for coding in ("pred", "dct"):
                data = FbaCodec(coding).encode(motion, q)
                decoded = decode_fba(data)
                kinds.setdefault(f"fba-{coding}", {}).update({
                    f"{case}/stream": _bytes(data), f"{case}/baps": decoded.baps, f"{case}/faps": decoded.faps,
                    f"{case}/face_frames": decoded.face_frames, f"{case}/fps": np.float64(decoded.fps)})
                data = encode_fba(None, motion.fps, q, coding, faps=_saturated(motion.faps))
                decoded = decode_fba(data)
                kinds.setdefault(f"fap-{coding}", {}).update({
                    f"{case}/stream": _bytes(data), f"{case}/faps": decoded.faps,
                    f"{case}/face_frames": decoded.face_frames, f"{case}/fps": np.float64(decoded.fps)})
            for name, codec in (("bba-pred", BbaCodec("pred")), ("bba-dct", BbaCodec("dct")),
                                ("bba-key", BbaCodec("pred", keyframes=True))):
                data = codec.encode(motion, q)
                levels = bba.decode_levels(data)
                entries = _bba_entries(case, data, levels)
                entries[f"{case}/n_frames"] = np.int64(motion.n_frames)
                kinds.setdefault(name, {}).update(entries)
                if name == "bba-pred" and q == QS[-1] and letter == LETTERS[0]:
                    text = bba_xml.to_xml(bba.read_stream(data)[0])
                    xml_levels = _levels_of_stream(bba_xml.from_xml(text))
                    entries = _bba_entries(case, text.encode("utf-8"), xml_levels)
                    kinds.setdefault("bba-xml", {}).update(entries)
    for seed, (frames, height, width, gop) in enumerate(((8, 40, 56, 12), (14, 48, 64, 6))):
        masks = moving_ellipses(frames, height, width, seed)
        data, _ = encode_shape(masks, gop=gop)
        pixels = decode_shape(data)
        assert np.array_equal(pixels, masks)
        kinds.setdefault("shape-cae", {}).update({f"ellipses_{seed}/stream": _bytes(data),
                                                  f"ellipses_{seed}/pixels": pixels})
    return kinds


def _levels_of_stream(stream):
    """bba.BBALevels of a BBAStream whose frames share one bone list (the XML reader's output)."""
    from comparisons.params import bba
    bones = stream.frames[0].bones
    ids = np.array(sorted(bones), dtype=np.int64)
    masks = np.array([bones[b] for b in sorted(bones)], dtype=np.int64)
    values = np.array([[v for b in sorted(f.bones) for v in f.values[b]] for f in stream.frames], dtype=np.int64)
    kfi = np.array([f.kfi for f in stream.frames], dtype=np.int64)
    return bba.BBALevels(stream.header, kfi, ids, masks, values)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT)
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    for kind, entries in build().items():
        path = args.out / f"{kind}.npz"
        np.savez_compressed(path, **entries)
        streams = sum(v.size for k, v in entries.items() if k.endswith("/stream"))
        print(f"{path.relative_to(ROOT) if path.is_relative_to(ROOT) else path}: "
              f"{sum(k.endswith('/stream') for k in entries)} streams, {streams} bytes")


if __name__ == "__main__":
    main()

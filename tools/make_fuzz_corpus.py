"""Regenerate the fuzzers' seed corpora, tests/fuzz/corpus/<target>/, from real bundled data.

Every seed is a small valid input written by signcast's own encoders (so it must decode cleanly;
tests/test_fuzz_short.py checks that): the ASL letter "A" (and "AB") fingerspelled by the avatar
through the FBA, BBA (binary and XML), .bap and the twelve seed-002 motion coders (FBA and .fap
seeds add a synthetic face track, comparisons/fap_rates.synthetic_faps, until real FAPs exist); the
carphone clip's signer masks (first frames, subsampled) through the shape coder; an arm chain of the avatar's
skeleton as BVH; lexicon clips trimmed to a frame or two as .pose; records of a real FBA measurement.
Re-run it whenever a stream format changes; it replaces each target's folder.

    python tools/make_fuzz_corpus.py [--targets fba,bba,...]
"""
from __future__ import annotations

import argparse
import io
import shutil
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests" / "fuzz"))

from comparisons.params import bap_table  # noqa: E402

import fuzz_targets  # noqa: E402

ARM_CHAIN_END = "finger2-3.R"   # the BVH seed's skeleton: root down to the tip of the right index finger


def _letter(word: str = "A", fps: float = 10.0):
    from media.fingerspelling import fingerspell
    return fingerspell("ase", word, fps)


def _baps(motion) -> np.ndarray:
    from comparisons.params.fba_mapping import motion_to_baps
    return motion_to_baps(motion)


def _face(motion, seed: int = 0) -> np.ndarray:
    """A synthetic signer's face track (FAPs) as long as the motion (comparisons/params/fap_rates.py)."""
    from comparisons.params.fap_rates import synthetic_faps
    return synthetic_faps(motion.n_frames, motion.fps, seed)


def fba_seeds() -> dict[str, bytes]:
    from comparisons.params.fba import encode_fba
    a, ab = _letter("A"), _letter("AB")
    first_half = np.arange(ab.n_frames) < ab.n_frames // 2
    return {"A-pred-q1.fba": encode_fba(_baps(a), a.fps, 1, "pred"),
            "A-pred-q8.fba": encode_fba(_baps(a), a.fps, 8, "pred"),
            "A-dct-q8.fba": encode_fba(_baps(a), a.fps, 8, "dct"),
            "AB-pred-q4-intra4.fba": encode_fba(_baps(ab), ab.fps, 4, "pred", intra_period=4),
            "AB-dct-q4-intra1.fba": encode_fba(_baps(ab), ab.fps, 4, "dct", intra_segments=1),
            "A-face-pred-q8.fba": encode_fba(_baps(a), a.fps, 8, "pred", faps=_face(a)),
            "A-face-dct-q8-fq2.fba": encode_fba(_baps(a), a.fps, 8, "dct", faps=_face(a), fap_quant=2),
            "A-face-only-pred-q4.fba": encode_fba(None, a.fps, 4, "pred", faps=_face(a, 1)),
            "AB-face-first-half-pred-q4.fba": encode_fba(_baps(ab), ab.fps, 4, "pred", faps=_face(ab),
                                                         face_frames=first_half),
            "AB-face-first-half-dct-q4.fba": encode_fba(_baps(ab), ab.fps, 4, "dct", faps=_face(ab),
                                                        face_frames=first_half)}


def fap_seeds() -> dict[str, bytes]:
    from comparisons.params.fap_file import format_fap
    a = _letter("A")
    return {"A-face.fap": format_fap(_face(a)[:6], a.fps, "face-A").encode()}


def _right_index_motion(frames: int = 4):
    """The letter A on the bones of the right index finger only (small BBA streams)."""
    from media.motion import Motion
    motion = _letter("A")
    keep = [k for k, name in enumerate(motion.bone_names) if name.startswith("finger2-") and name.endswith(".R")]
    return Motion(motion.fps, tuple(motion.bone_names[k] for k in keep), motion.rotations[:frames, keep],
                  motion.root_translation[:frames])


def _muscle_update():
    """An update of the avatar's first muscle: its profiled control points at full bulge, mm."""
    from comparisons.params.bba import MuscleUpdate
    from media.avatar import load_avatar
    muscle = load_avatar().muscles[0]
    n_points, n_knots = len(muscle.control_points), len(muscle.knots)
    profile = muscle.bulge_profile if muscle.bulge_profile is not None else np.ones(n_points)
    direction = muscle.bulge_direction if muscle.bulge_direction is not None else np.array([0.0, 0.0, 1.0])
    mask, values = [], []
    for share in profile:
        moved = share > 0
        mask += [int(moved)] * 3 + [0]                   # x, y, z moved; the NURBS weight kept
        if moved:
            values += [int(round(v)) for v in direction * muscle.max_bulge * share * 1000.0]
    return MuscleUpdate(0, n_points, n_knots, mask + [0] * n_knots, values)


def _bba_streams() -> dict[str, object]:
    from comparisons.params.bba import motion_to_stream
    a, small = _letter("A"), _right_index_motion()
    with_muscle = motion_to_stream(small, 4, "pred")
    with_muscle.frames[1].muscles = [_muscle_update()]
    return {"A-pred-q8": motion_to_stream(a, 8, "pred"),
            "A-dct-q8": motion_to_stream(a, 8, "dct"),
            "A-keyframes-q8": motion_to_stream(a, 8, "pred", keyframes=True),
            "index-pred-q4-muscle": with_muscle,
            "index-dct-q2": motion_to_stream(small, 2, "dct"),
            "index-pred-q4-intra2-headers": motion_to_stream(small, 4, "pred", intra_period=2, header_period=1)}


def bba_seeds() -> dict[str, bytes]:
    from comparisons.params.bba import write_stream
    return {f"{name}.bba": write_stream(stream) for name, stream in _bba_streams().items()}


def bba_xml_seeds() -> dict[str, bytes]:
    from comparisons.params.bba_xml import to_xml
    return {f"{name}.xml": to_xml(stream).encode() for name, stream in _bba_streams().items()
            if name.startswith("index-")}


def bap_seeds() -> dict[str, bytes]:
    from comparisons.params.bap_file import format_bap
    a = _letter("A")
    values = _baps(a)
    # version 3.1 carries the 186 standard BAPs only: the same frames, cut to them
    standard = format_bap(values[:3], a.fps, "letter-A").splitlines()
    v31 = ["3.1 letter-A 10 3"]
    for mask_line, value_line in zip(standard[2::2], standard[3::2]):
        flags = mask_line.split()
        kept = sum(f == "1" for f in flags[:bap_table.N_STANDARD_BAPS])
        v31 += [" ".join(flags[:bap_table.N_STANDARD_BAPS]), " ".join(value_line.split()[:1 + kept])]
    return {"A.bap": format_bap(values, a.fps, "letter-A").encode(), "A-v3.1.bap": ("\n".join(v31) + "\n").encode()}


def shape_seeds() -> dict[str, bytes]:
    from comparisons.video.shape import encode_shape
    from media.segmentation import segment_signer
    from media.video_io import bundled_clip_path, read_video
    frames, _ = read_video(bundled_clip_path("carphone"), max_frames=3)
    masks = segment_signer(frames)
    # small frames keep a seed's decode far under the fuzzer's 1 s limit, even instrumented
    return {"carphone-3-half-gop2.shape": encode_shape(masks[:, ::2, ::2], gop=2)[0],
            "carphone-1-quarter.shape": encode_shape(masks[:1, ::4, ::4], gop=1)[0]}


def motion_seeds(name: str) -> dict[str, bytes]:
    from comparisons.lab.codecs import LabCodec
    codec, motion = LabCodec(name), _letter("A")
    top = len(codec.settings())
    return {f"A-q1.{name}": codec.encode(motion, 1), f"A-q{top}.{name}": codec.encode(motion, top)}


def bvh_seeds() -> dict[str, bytes]:
    from media.avatar import Skeleton, load_avatar
    from media.bvh import write_bvh
    from media.motion import Motion
    skeleton = load_avatar().skeleton
    chain = [skeleton.index(ARM_CHAIN_END)]
    while skeleton.parents[chain[-1]] >= 0:
        chain.append(int(skeleton.parents[chain[-1]]))
    chain.reverse()                                  # root first: parents before children
    arm = Skeleton(tuple(skeleton.names[b] for b in chain), np.arange(-1, len(chain) - 1, dtype=np.int32),
                   skeleton.heads[chain], skeleton.tails[chain])
    motion = _letter("A")
    keep = [motion.bone_names.index(n) for n in arm.names if n in motion.bone_names]
    arm_motion = Motion(motion.fps, tuple(motion.bone_names[k] for k in keep), motion.rotations[:3, keep],
                        motion.root_translation[:3])
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "arm.bvh"
        write_bvh(path, arm_motion, arm)
        return {"A-right-arm.bvh": path.read_bytes()}


def pose_seeds() -> dict[str, bytes]:
    from pose_format import Pose
    from media import lexicon
    seeds = {}
    for language, letter, frames in (("ase", "A", 1), ("ise", "A", 2)):
        pose = Pose.read(lexicon.lookup(language, letter).path.read_bytes())
        pose.body = pose.body[:frames]
        buffer = io.BytesIO()
        pose.write(buffer)
        seeds[f"{language}-{letter}-{frames}frames.pose"] = buffer.getvalue()
    return seeds


def records_seeds() -> dict[str, bytes]:
    from comparisons.params.fba import encode_fba
    from comparisons.reports.records import make_record, versions
    from pipeline.outputs import write_records
    a = _letter("A")
    records = [{"kind": "run", "backend": "numpy", "versions": versions()}]
    for q in (1, 8, 31):
        data = encode_fba(_baps(a), a.fps, q, "pred")
        records.append(make_record("FBA", "ase-A", "fba-pred", q, a.fps, 0, 0, 8 * len(data), a.n_frames / a.fps,
                                   param_psnr=None, letters=["A"]))
    with tempfile.TemporaryDirectory() as folder:
        return {"fba-A.jsonl": write_records(Path(folder) / "records.jsonl", records).read_bytes()}


# ------------------------------------------------------------------------------- live delivery (issue 37)

def _live_stream(codec: str = "fba-pred", frames: int = 5, units: str = "frame", refresh: int = 4) -> list[bytes]:
    """The units a live sender sends for the first frames of ASL A (each one unit's bytes)."""
    from pipeline.live import endpoints
    motion = _letter("A").frames(0, frames)
    solution = "FBA" if codec.startswith("fba") else "BBA"
    _, source = endpoints.source_for(solution, codec, 8, motion=motion, fps=motion.fps, refresh=refresh, units=units)
    return [part for index in range(frames) for unit in source.capture(index) for part in unit.data]


def live_units_seeds() -> dict[str, bytes]:
    return {"A-pred-frame-units.bin": b"".join(_live_stream("fba-pred", 5, "frame", 4)),
            "A-dct-period-units.bin": b"".join(_live_stream("fba-dct", 6, "period", 3))}


def delta_unit_seeds() -> dict[str, bytes]:
    from comparisons.transport.fba_units import DELTA_PREFIX, HEADER_BYTES
    out = {}
    for codec in ("fba-pred", "bba-pred"):
        deltas = [unit[HEADER_BYTES:] for unit in _live_stream(codec, 4, "frame", 4)
                  if unit[HEADER_BYTES:].startswith(DELTA_PREFIX)]
        if deltas:
            out[f"A-{codec}-delta.bin"] = deltas[0]
    return out


def shape_units_seeds() -> dict[str, bytes]:
    from comparisons.transport.shape_units import encode_shape_units
    masks = np.zeros((3, 32, 32), bool)
    masks[:, 8:20, 6:22] = True
    masks[1, 4:10, 10:14] = True
    return {"box-gop1.bin": b"".join(u.data for u in encode_shape_units(masks, 1)),
            "box-gop2.bin": b"".join(u.data for u in encode_shape_units(masks, 2))}


def _datagrams(packets, head: bytes = b"") -> bytes:
    return b"".join(head + len(p).to_bytes(2, "big") + p for p in packets)


def _video_access_units(codec: str) -> list[bytes]:
    from comparisons.transport.video import LiveEncoder
    encoder = LiveEncoder(codec, 64, 48, 25.0, 8 if codec == "mpeg4" else 30, gop=12, b_frames=0)
    frames = np.zeros((3, 48, 64, 3), np.uint8)
    frames[:, 10:30, 20:40] = 200
    packets = [p for k, frame in enumerate(frames) for p in encoder.encode(frame, k)] + list(encoder.flush())
    return [p.data for p in packets]


def rtp_seeds() -> dict[str, bytes]:
    from comparisons.transport import rtp
    out = {}
    units = rtp.ParameterPacketizer(seed=1)
    packets = [p.to_bytes() for k, unit in enumerate(_live_stream("fba-pred", 3, "frame", 4))
               for p in units.packetize_units([unit], rtp.timestamp_of(k, 25.0))]
    out["fba-units.bin"] = bytes([0 | 4]) + units.first_sequence.to_bytes(2, "big") + _datagrams(packets)
    for selector, codec, packetizer in ((1, "libx264", rtp.H264Packetizer(mtu=200, seed=2)),
                                        (2, "mpeg4", rtp.Mp4vPacketizer(mtu=200, seed=3))):
        packets = [p.to_bytes() for k, au in enumerate(_video_access_units(codec))
                   for p in packetizer.packetize(au, rtp.timestamp_of(k, 25.0))]
        out[f"{codec}.bin"] = (bytes([selector | 4]) + packetizer.first_sequence.to_bytes(2, "big")
                               + _datagrams(packets))
    return out


def jitter_buffer_seeds() -> dict[str, bytes]:
    from comparisons.transport import rtp
    packetizer = rtp.ParameterPacketizer(seed=1)
    packetizer.ssrc = 0x5EED
    packets = [p.to_bytes() for k, unit in enumerate(_live_stream("fba-pred", 4, "frame", 4))
               for p in packetizer.packetize_units([unit], rtp.timestamp_of(k, 25.0))]
    head = packetizer.first_sequence.to_bytes(2, "big")
    return {"in-order.bin": head + _datagrams(packets, b"\x0a"),
            "reordered.bin": head + _datagrams(packets[1:2] + packets[:1] + packets[2:], b"\x05")}


def ts_demux_seeds() -> dict[str, bytes]:
    from comparisons.transport import ts
    frames = np.zeros((4, 48, 64, 3), np.uint8)
    frames[:, 10:30, 20:40] = 180
    programme = ts.encode_programme(frames, 25.0)
    track = ts.ParameterTrack("fba", 25.0, [(k, unit) for k, unit in enumerate(_live_stream("fba-pred", 4, "frame", 4))])
    return {"programme-fba.ts": ts.mux_transport_stream(programme, [], [track])}


def session_description_seeds() -> dict[str, bytes]:
    from pipeline.live.session import SessionDescription
    fba = SessionDescription("FBA", "fba-pred", "units", 4, 25.0, 80, 352, 288, clip="ase-HELLO",
                             details={"refresh": 25, "units": "frame"},
                             streams=[{"name": "FBA", "payload": "units", "ssrc": 12345, "first_sequence": 7}])
    ssv = SessionDescription("SSV", "mpeg4", "objects", 4, 25.0, 80, 176, 144, clip="ase-HELLO",
                             details={"shape_gop": 1},
                             streams=[{"name": f"{name}/{part}", "payload": payload, "ssrc": 100 + k,
                                       "first_sequence": k}
                                      for k, (name, part, payload) in enumerate(
                                          [("head", "texture", "mp4v"), ("head", "shape", "units")])])
    return {"fba.json": fba.to_line(), "ssv.json": ssv.to_line()}


def live_report_seeds() -> dict[str, bytes]:
    from comparisons.reports.records import make_record
    from pipeline.outputs import write_records
    records = [{"kind": "run", "clip": "ase-A", "clip_fps": 25.0, "clip_frames": 21, "burst": 2.0, "jitter_ms": 0.0,
                "seed": 1, "repeats": 1, "refresh": 25, "units": "frame"}]
    for solution, codec, loss, p50, p95 in (("FBA", "fba-pred", 0.0, 60.0, 120.0), ("FBA", "fba-pred", 0.05, 80.0, 450.0),
                                            ("NSV", "mpeg4", 0.0, 10.0, 30.0)):
        records.append(make_record(solution, "ase-A", codec, 4, 25.0, 176, 144, 30000, 0.84, sweep="loss",
                                   loss_rate=loss, delivered_kbps=40.0, packet_loss=loss, frames_lost=1,
                                   frames_concealed=1, latency_ms_p50=p50, latency_ms_p95=p95, hand_pck_20=90.0,
                                   encode_ms_p50=2.0, encode_ms_p95=4.0, network_ms_p50=0.2, network_ms_p95=1.0))
    with tempfile.TemporaryDirectory() as folder:
        return {"loss-points.jsonl": write_records(Path(folder) / "records.jsonl", records).read_bytes()}


def seeds(target: str) -> dict[str, bytes]:
    """File name -> bytes of the target's seeds."""
    if target.startswith("motion-"):
        return motion_seeds(target.removeprefix("motion-"))
    makers = {"fba": fba_seeds, "bba": bba_seeds, "bba-resilient": bba_seeds, "bba-xml": bba_xml_seeds,
              "bap": bap_seeds, "fap": fap_seeds, "shape": shape_seeds, "bvh": bvh_seeds, "pose": pose_seeds,
              "records": records_seeds, "live-units": live_units_seeds, "delta-unit": delta_unit_seeds,
              "shape-units": shape_units_seeds, "rtp": rtp_seeds, "jitter-buffer": jitter_buffer_seeds,
              "ts-demux": ts_demux_seeds, "session-description": session_description_seeds,
              "live-report": live_report_seeds}
    return makers[target]()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--targets", default="all", help="comma-separated target names, or all")
    args = parser.parse_args(argv)
    names = list(fuzz_targets.TARGETS) if args.targets == "all" else args.targets.split(",")
    unknown = sorted(set(names) - set(fuzz_targets.TARGETS))
    if unknown:
        parser.error(f"unknown targets {', '.join(unknown)}; choose from {', '.join(fuzz_targets.TARGETS)}")
    for name in names:
        folder = fuzz_targets.CORPUS_DIR / name
        made = seeds(name)
        shutil.rmtree(folder, ignore_errors=True)
        folder.mkdir(parents=True)
        for file_name, data in made.items():
            (folder / file_name).write_bytes(data)
            try:
                outcome = fuzz_targets.run(name, data)
            except Exception as error:  # a seed that does not decode is reported, and kept for inspection
                outcome = f"FAILS: {type(error).__name__}: {error}"
            print(f"{name:18s} {file_name:32s} {len(data):7d} B  {outcome}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

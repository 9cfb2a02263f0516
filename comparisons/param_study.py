"""The parameter-transmission study: code each fingerspelled letter with each parameter codec at each
Q, decode it, and measure rate and distortion (the measurements behind seed 000 Tables 2.1/3.1/3.2).

Per point: bits = 8 x len(coded bytes); kbps over the clip's duration at the coding frame rate;
distortion eq. 2.6 over the rotation BAP vectors in rad^2 (both original and decoded motion mapped
to BAPs, so FBA and BBA are scored alike); mean PSNR and VPSNR over the BAPs that move; per
BAP group the normalised weighted vector error and its maximum form; joint position error (mm) by
forward kinematics; and the size of the letter's `.pose` file as kbps, the
baseline of today's pose tools.
"""
from __future__ import annotations

import csv
import time
from pathlib import Path

import numpy as np

from comparisons import bap_table, metrics
from comparisons.bap_file import write_bap
from comparisons.fba_mapping import motion_to_baps
from comparisons.param_codecs import get_codec
from comparisons.records import make_record, write_records
from media import lexicon
from media.avatar import load_avatar
from media.fingerspelling import letter_motion
from media.motion import Motion

ROTATION_COLUMNS = np.array([b.id - 1 for b in bap_table.BAPS if not b.is_translation])


def solution_of(codec_name: str) -> str:
    """The solution a parameter codec belongs to: FBA, BBA, or a seed-002 motion coder."""
    if codec_name.startswith("fba"):
        return "FBA"
    if codec_name.startswith("bba"):
        return "BBA"
    return "motion coder"


def pose_file_kbps(language: str, unit: str) -> float:
    """Size of the lexicon clip's .pose file over the clip's duration, kbit/s."""
    entry = lexicon.lookup(language, unit)
    clip = lexicon.read_clip(entry)
    return entry.path.stat().st_size * 8 / (clip.n_frames / clip.fps) / 1000.0


def measure_point(motion: Motion, codec_name: str, q: int) -> dict:
    """Code and decode one motion; rate, distortion and timing fields."""
    codec = get_codec(codec_name)
    start = time.perf_counter()
    data = codec.encode(motion, q)
    encode_s = time.perf_counter() - start
    start = time.perf_counter()
    decoded = codec.decode(data)
    decode_s = time.perf_counter() - start
    original_all, decoded_all = motion_to_baps(motion), motion_to_baps(decoded)
    original_baps = original_all[:, ROTATION_COLUMNS] * bap_table.ROTATION_UNIT_RAD
    decoded_baps = decoded_all[:, ROTATION_COLUMNS] * bap_table.ROTATION_UNIT_RAD
    moving = metrics.value_range(original_baps) > 0
    joint_mm = metrics.joint_position_error_mm(load_avatar().skeleton, motion, decoded)
    return {"bits": 8 * len(data), "distortion": metrics.distortion(original_baps, decoded_baps),
            "psnr": metrics.mean_db(metrics.psnr(original_baps[:, moving], decoded_baps[:, moving])),
            "vpsnr": metrics.mean_db(metrics.vpsnr(original_baps[:, moving], decoded_baps[:, moving], motion.fps)),
            "joint_error_mm_mean": float(joint_mm.mean()), "joint_error_mm_max": float(joint_mm.max()),
            "group_errors": metrics.bap_group_errors(original_all, decoded_all),
            "encode_fps": motion.n_frames / encode_s, "decode_fps": motion.n_frames / decode_s,
            "frames": motion.n_frames}


def run_study(language: str, units: list[str], codecs: list[str], qs: list[int], fps: float, out_dir: Path,
              progress=None) -> list[dict]:
    """Measure every (unit, codec, Q); writes records.jsonl, params_table.csv and PNG plots in out_dir,
    and each letter's full-precision BAPs as a version 3.2 .bap file in out_dir/bap/ (for other
    MPEG-4 body animation tools)."""
    for name in codecs:
        get_codec(name)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    records = []
    for unit in units:
        motion = letter_motion(language, unit, fps)
        pose_kbps = pose_file_kbps(language, unit)
        (out_dir / "bap").mkdir(exist_ok=True)
        write_bap(out_dir / "bap" / f"{language}_{unit}.bap", motion_to_baps(motion), fps, f"{language}_{unit}")
        for name in codecs:
            solution = solution_of(name)
            for q in qs:
                point = measure_point(motion, name, q)
                records.append(make_record(solution, f"{language}:{unit}", name, q, fps, 0, 0, point.pop("bits"),
                                           motion.duration_s, pose_kbps=pose_kbps, **point))
                if progress:
                    progress(1)
    write_records(out_dir / "records.jsonl", records)
    write_table(out_dir / "params_table.csv", records, codecs, qs)
    write_plots(out_dir, records, codecs)
    return records


def write_table(path: Path, records: list[dict], codecs: list[str], qs: list[int]) -> Path:
    """Rows: letters; columns: pose-file kbps, then kbps and distortion per (Q, codec), like Tables 2.1/3.1/3.2."""
    clips = list(dict.fromkeys(r["clip"] for r in records))
    lookup = {(r["clip"], r["codec"], r["q"]): r for r in records}
    header = ["sign", "frames", "pose_kbps"]
    for q in qs:
        for name in codecs:
            header += [f"Q={q} {name} kbps", f"Q={q} {name} D"]
    with Path(path).open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(header)
        for clip in clips:
            first = next(r for r in records if r["clip"] == clip)
            row = [clip.split(":", 1)[-1], first["frames"], f"{first['pose_kbps']:.2f}"]
            for q in qs:
                for name in codecs:
                    r = lookup.get((clip, name, q))
                    row += [f"{r['kbps']:.2f}", f"{r['distortion']:.3g}"] if r else ["", ""]
            writer.writerow(row)
    return Path(path)


def write_plots(out_dir: Path, records: list[dict], codecs: list[str]) -> None:
    """kbps vs Q and distortion vs kbps, averaged over letters, one line per codec."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, (rate_axes, rd_axes) = plt.subplots(1, 2, figsize=(11, 4.2))
    for name in codecs:
        mine = [r for r in records if r["codec"] == name]
        qs = sorted({r["q"] for r in mine})
        kbps = [np.mean([r["kbps"] for r in mine if r["q"] == q]) for q in qs]
        distortion = [np.mean([r["distortion"] for r in mine if r["q"] == q]) for q in qs]
        rate_axes.plot(qs, kbps, marker="o", label=name)
        rd_axes.plot(kbps, distortion, marker="o", label=name)
    rate_axes.set(xlabel="global quantisation Q", ylabel="kbit/s (mean over letters)", xscale="log", title="rate vs Q")
    rd_axes.set(xlabel="kbit/s", ylabel="distortion eq. 2.6 (rad$^2$)", yscale="log", title="distortion vs rate")
    for axes in (rate_axes, rd_axes):
        axes.grid(True, alpha=0.3)
        axes.legend()
    figure.tight_layout()
    figure.savefig(out_dir / "params_rate.png", dpi=110)
    plt.close(figure)

"""The pieces of the parameter-transmission study (pipeline.studies.params, seed 000 Tables 2.1/3.1/3.2): one
point measured (code a motion with a parameter codec at Q, decode it), and the table and plots of its records.

Per point: bits = 8 x len(coded bytes); kbps over the clip's duration at the coding frame rate;
distortion eq. 2.6 over the rotation BAP vectors in rad^2 (both original and decoded motion mapped
to BAPs, so FBA and BBA are scored alike); mean PSNR and VPSNR over the BAPs that move; per
BAP group the normalised weighted vector error and its maximum form; joint position error (mm) by
forward kinematics, and for a motion with a face the face bones' error in the head's frame (mm). The study
adds the size of the letter's `.pose` file as kbps, the baseline of today's pose tools.
"""
from __future__ import annotations

import time

import numpy as np

from media.domain import kbps
from comparisons.params import bap_table
from comparisons.judging import metrics
from comparisons.params.fba_mapping import motion_to_baps
from comparisons.params.codecs import get_codec
from media.avatar import Avatar, load_avatar
from media.face_rig import face_bone_names, with_face_bones
from media.motion import Motion

ROTATION_COLUMNS = np.array([b.id - 1 for b in bap_table.BAPS if not b.is_translation])


def measure_point(motion: Motion, codec_name: str, q: int) -> dict:
    """Code and decode one motion; rate, distortion and timing fields (and the face's, when it has FAPs)."""
    codec = get_codec(codec_name)
    start = time.perf_counter()
    data = codec.encode(motion, q)
    encode_s = time.perf_counter() - start
    start = time.perf_counter()
    decoded = codec.decode(data)
    decode_s = time.perf_counter() - start
    original_all, decoded_all = motion_to_baps(motion), motion_to_baps(decoded, strict=False)   # BBA: + face bones
    original_baps = original_all[:, ROTATION_COLUMNS] * bap_table.ROTATION_UNIT_RAD
    decoded_baps = decoded_all[:, ROTATION_COLUMNS] * bap_table.ROTATION_UNIT_RAD
    moving = metrics.value_range(original_baps) > 0
    # the face is compared as the avatar plays it: FAPs (FBA) through the face rig, face bones (BBA) as sent
    played, played_decoded = with_face_bones(motion), with_face_bones(decoded)
    joint_mm = metrics.joint_position_error_mm(load_avatar().skeleton, played, played_decoded)
    return {"bits": 8 * len(data), "distortion": metrics.distortion(original_baps, decoded_baps),
            "param_psnr": metrics.mean_db(metrics.psnr(original_baps[:, moving], decoded_baps[:, moving])),
            "vpsnr": metrics.mean_db(metrics.vpsnr(original_baps[:, moving], decoded_baps[:, moving], motion.fps)),
            "joint_error_mm_mean": float(joint_mm.mean()), "joint_error_mm_max": float(joint_mm.max()),
            "group_errors": metrics.bap_group_errors(original_all, decoded_all),
            "encode_fps": motion.n_frames / encode_s, "decode_fps": motion.n_frames / decode_s,
            "frames": motion.n_frames, **_face_fields(motion, decoded, codec, q, 8 * len(data)),
            **face_joint_fields(motion, played, played_decoded)}


def face_joint_fields(motion: Motion, played: Motion, played_decoded: Motion, avatar: Avatar | None = None) -> dict:
    """For a motion with a face, from metrics.face_joint_error_mm (the face bones' tails in the head's frame: the
    face's own movement), mm: face_joint_error_mm, the mean over frames and face bones; face_joint_error_mm_max, the
    largest; face_joint_error_mm_p90, the 90th percentile over frames of each frame's worst face point (a face's
    message is local: one lip or brow wrong for a few frames, which a mean over 44 points dilutes). played,
    played_decoded: the motion and its decoded form with their faces played on the avatar's face bones
    (media.face_rig.with_face_bones); avatar: default the vendored one."""
    if motion.faps is None:
        return {}
    avatar = avatar or load_avatar()
    face_mm = metrics.face_joint_error_mm(avatar.skeleton, played, played_decoded, face_bone_names(avatar))
    return {"face_joint_error_mm": float(face_mm.mean()), "face_joint_error_mm_max": float(face_mm.max()),
            "face_joint_error_mm_p90": float(np.percentile(face_mm.max(axis=1), 90))}


def _face_fields(motion: Motion, decoded: Motion, codec, q: int, bits: int) -> dict:
    """For a motion with a face: face_sent, whether the codec sends it (`sends_face`; seed 002's coders do not,
    and their face decodes at rest, which face_joint_fields measures); where it is sent, face_kbps, the bits the
    face adds over the same body coded alone (kbit/s), and fap_error, the mean |decoded - original| FAP value
    over the FAPs that move, FAP units (only for codecs that carry FAPs: BBA carries the face bones instead)."""
    if motion.faps is None:
        return {}
    if not codec.sends_face:
        return {"face_sent": False}
    body_bits = 8 * len(codec.encode(motion.without_face(), q))
    fields = {"face_sent": True, "face_kbps": kbps(bits - body_bits, motion.duration_s)}
    moving = np.ptp(motion.faps, axis=0) > 0
    if decoded.faps is not None and moving.any():
        fields["fap_error"] = float(np.abs(decoded.faps[:, moving] - motion.faps[:, moving]).mean())
    return fields


def table_rows(records: list[dict], codecs: list[str], qs: list[int]) -> list[list]:
    """CSV rows, the header first. Rows: letters; columns: pose-file kbps, then kbps and distortion per (Q, codec),
    like Tables 2.1/3.1/3.2."""
    clips = list(dict.fromkeys(r["clip"] for r in records))
    lookup = {(r["clip"], r["codec"], r["q"]): r for r in records}
    header = ["sign", "frames", "pose_kbps"]
    for q in qs:
        for name in codecs:
            header += [f"Q={q} {name} kbps", f"Q={q} {name} D"]
    rows = [header]
    for clip in clips:
        first = next(r for r in records if r["clip"] == clip)
        row = [clip.split(":", 1)[-1], first["frames"], f"{first['pose_kbps']:.2f}"]
        for q in qs:
            for name in codecs:
                r = lookup.get((clip, name, q))
                row += [f"{r['kbps']:.2f}", f"{r['distortion']:.3g}"] if r else ["", ""]
        rows.append(row)
    return rows


def rate_figure(records: list[dict], codecs: list[str]):
    """A matplotlib figure: kbps vs Q and distortion vs kbps, averaged over letters, one line per codec."""
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
    return figure

"""What the face costs in an FBA stream: the bytes and kbps FAPs add to a body (BAP) stream, and
the size of a face-only stream; and a synthetic face track to measure it on until real FAPs exist.

The synthetic track (`synthetic_faps`) moves the FAPs a signer's face moves, at realistic
amplitudes (FAP units: 1/1024 of the face's FAPU, or 1e-5 rad): mouthing (open_jaw 0..600 at a
syllable rate of 3-5 Hz, inner and outer lips following it, lip stretch and corners drifting),
brows (smooth drift within +-300), blinks (every 2-6 s a 100-200 ms pulse of +1024 on the upper
eyelids), gaze (saccades between held eyeball angles within +-0.1 rad) and head rotation (smooth
within +-0.08 rad). Tongue, nose, ears and pupils stay still, as a face tracker that cannot see
them leaves them.
"""
from __future__ import annotations

import numpy as np
from scipy.ndimage import gaussian_filter1d

from media.domain import kbps
from comparisons.params import bap_table
from comparisons.params import fap_table
from comparisons.params.fba import encode_fba
from media.errors import SigncastError


def _drift(rng: np.random.Generator, n_frames: int, fps: float, amplitude: float, seconds: float) -> np.ndarray:
    """(T,) smooth random walk scaled to +-amplitude, varying over about `seconds`."""
    walk = gaussian_filter1d(np.cumsum(rng.normal(size=n_frames + 1)), sigma=max(seconds * fps / 4, 1.0))[1:]
    walk -= walk.mean()
    peak = np.abs(walk).max()
    return walk * (amplitude / peak) if peak > 0 else walk


def synthetic_faps(n_frames: int, fps: float, seed: int = 0) -> np.ndarray:
    """(T, 68) int64 FAP values (index = FAP id - 1) of a synthetic signer's face at `fps`."""
    if n_frames < 1:
        raise SigncastError(f"a face track needs at least one frame, got {n_frames}")
    rng = np.random.default_rng(seed)
    t = np.arange(n_frames) / fps
    faps = np.zeros((n_frames, fap_table.N_FAPS), dtype=np.float64)
    column = {f.name: f.id - 1 for f in fap_table.FAPS}
    mouthing = np.clip(0.5 + _drift(rng, n_frames, fps, 0.8, 1.5), 0.0, 1.0)   # how much the signer mouths
    jaw = 300.0 * (1 - np.cos(2 * np.pi * rng.uniform(3, 5) * t + rng.uniform(0, 2 * np.pi))) * mouthing
    faps[:, column["open_jaw"]] = jaw
    stretch = _drift(rng, n_frames, fps, 150, 1.0)
    corners = _drift(rng, n_frames, fps, 100, 2.0)
    for suffix, outer in (("", 0.0), ("_o", 1.0)):
        faps[:, column["lower_t_midlip" + suffix]] = -0.15 * jaw - 20 * outer
        faps[:, column["raise_b_midlip" + suffix]] = -0.35 * jaw + 20 * outer
        for side in ("l", "r"):
            faps[:, column[f"stretch_{side}_cornerlip" + suffix]] = stretch
            faps[:, column[f"raise_{side}_cornerlip" + suffix]] = corners
            faps[:, column[f"lower_t_lip_{side}m" + suffix]] = -0.12 * jaw
            faps[:, column[f"raise_b_lip_{side}m" + suffix]] = -0.3 * jaw
    for side in ("l", "r"):
        faps[:, column[f"lift_{side}_cheek"]] = np.maximum(corners, 0) * 0.5
    brows = _drift(rng, n_frames, fps, 300, 2.0)
    for part in ("i", "m", "o"):
        for side in ("l", "r"):
            faps[:, column[f"raise_{side}_{part}_eyebrow"]] = brows * (1.2 if part == "i" else 1.0) / 1.2
    blink_at = np.cumsum(rng.uniform(2.0, 6.0, size=int(t[-1] / 2.0) + 2)) - 1.0
    for start in blink_at:
        closed = (t >= start) & (t < start + rng.uniform(0.1, 0.2))
        faps[closed, column["close_t_l_eyelid"]] = 1024
        faps[closed, column["close_t_r_eyelid"]] = 1024
    saccades = np.cumsum(rng.uniform(0.3, 1.2, size=int(t[-1] / 0.3) + 2))
    held = np.searchsorted(saccades, t)
    gaze = rng.uniform(-10000, 10000, size=(len(saccades) + 1, 2))[held]
    for side in ("l", "r"):
        faps[:, column[f"yaw_{side}_eyeball"]] = gaze[:, 0]
        faps[:, column[f"pitch_{side}_eyeball"]] = gaze[:, 1]
    for name in ("head_pitch", "head_yaw", "head_roll"):
        faps[:, column[name]] = _drift(rng, n_frames, fps, 8000, 2.0)
    return np.round(faps).astype(np.int64)


def fap_bits(faps: np.ndarray, fps: float, q: int, coding: str = "pred", *, baps: np.ndarray | None = None,
             fap_quant: int | None = None) -> dict:
    """The bytes and kbps FAPs (T, 68) add to an FBA stream at `fps`, Q = q, coding "pred" or "dct".

    baps: (T, 296) BAP values the face rides with (default: the body at rest, all 0); fap_quant
    defaults to q. Returns {"frames", "duration_s", "body_bytes" (paramset 2), "face_body_bytes"
    (paramset 3), "added_bytes" (their difference), "added_kbps", "face_only_bytes" (paramset 1),
    "face_only_kbps"}."""
    faps = np.asarray(faps)
    baps = np.zeros((len(faps), bap_table.N_BAPS), dtype=np.int64) if baps is None else baps
    duration_s = len(faps) / fps
    body = len(encode_fba(baps, fps, q, coding))
    both = len(encode_fba(baps, fps, q, coding, faps=faps, fap_quant=fap_quant))
    face_only = len(encode_fba(None, fps, q, coding, faps=faps, fap_quant=fap_quant))
    return {"frames": len(faps), "duration_s": duration_s, "body_bytes": body, "face_body_bytes": both,
            "added_bytes": both - body, "added_kbps": kbps(8 * (both - body), duration_s),
            "face_only_bytes": face_only, "face_only_kbps": kbps(8 * face_only, duration_s)}

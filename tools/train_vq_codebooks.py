"""Train the tables of the seed-002 motion coders on the training split of the lexicon.

Training split: every lexicon language except comparisons.lab.codecs.EVALUATION_LANGUAGES (the
charted ones), each fingerspelling its whole alphabet at 25 fps on the avatar. Writes
  comparisons/tables/lab_dof_ranges.npz  DOF quantiser ranges (training min/max widened by 25 %)
  comparisons/tables/vq_codebooks.npz    spatial VQ codebooks per group, temporal VQ codebooks (LBG)
  comparisons/tables/model_tables.npz    posture tables (LBG, 1024 postures: the clustering alternative of
                                       seed 002 §8.4.1) and gesture tables (greedy D-spaced, eq. 8-11) per group
(tables stored as float16: their resolution, ~0.002 rad, is far below the coders' errors)
Run: python tools/train_vq_codebooks.py   (a few minutes on 2 cores; deterministic)
"""
from __future__ import annotations

import sys

import numpy as np
from tqdm import tqdm

from comparisons.lab.codecs import (RANGES_PATH, alphabet_motion, dof_layout, motion_dofs, training_languages)
from comparisons.lab.model import MODEL_TABLE_PATH, N_NORM, GestureCoder, _frames, gesture_boundaries, warp
from comparisons.lab.vq import (CODEBOOK_SIZES, VQ_TABLE_PATH, temporal_vectors, train_codebooks)

FPS = 25.0
MAX_POSTURES = 1024
MAX_GESTURES = 256
MIN_HALF_WIDTH = 0.1  # radians, for DOFs that never move in training


def greedy_spaced(vectors: np.ndarray, distance: float, limit: int) -> np.ndarray | None:
    """Indices of vectors kept by a greedy pass: a vector is kept if it is >= distance from all kept
    (seed 002 eq. 8-11); None as soon as more than `limit` would be kept."""
    flat = vectors.reshape(len(vectors), -1)
    table = np.empty((limit + 1, flat.shape[1]))
    table[0] = flat[0]
    kept = [0]
    for i in range(1, len(flat)):
        if np.min(np.sum((table[:len(kept)] - flat[i]) ** 2, axis=1)) >= distance * distance:
            if len(kept) == limit:
                return None
            table[len(kept)] = flat[i]
            kept.append(i)
    return np.array(kept)


def spaced_table(vectors: np.ndarray, limit: int, distance: float) -> tuple[np.ndarray, float]:
    while True:
        kept = greedy_spaced(vectors, distance, limit)
        if kept is not None:
            return vectors[kept], distance
        distance *= 1.25


def main() -> int:
    layout = dof_layout()
    sequences = []
    for language in tqdm(training_languages(), desc="fingerspelling training alphabets", file=sys.stderr):
        sequences.append(motion_dofs(alphabet_motion(language, FPS)))
    frames = np.concatenate(sequences)
    print(f"training: {len(sequences)} languages, {len(frames)} frames, {layout.n_dofs} DOFs", file=sys.stderr)

    low, high = frames.min(axis=0), frames.max(axis=0)
    centre, half = (low + high) / 2, np.maximum((high - low) / 2 * 1.25, MIN_HALF_WIDTH)
    lower, upper = np.maximum(centre - half, -np.pi), np.minimum(centre + half, np.pi)
    np.savez_compressed(RANGES_PATH, names=np.array(layout.names), lower=lower, upper=upper)

    vq = {"svq_groups": np.array(list(layout.groups))}
    model = {"model_groups": np.array(list(layout.groups))}
    for group, idx in layout.groups.items():
        names = np.array([layout.names[i] for i in idx])
        vq[f"svq_{group}_names"] = names
        model[f"model_{group}_names"] = names
        data = frames[:, idx]
        for size, book in train_codebooks(data, CODEBOOK_SIZES).items():
            vq[f"svq_{group}_{size}"] = book.astype(np.float16)
        postures = train_codebooks(data, [MAX_POSTURES])[MAX_POSTURES]
        model[f"posture_{group}"] = postures.astype(np.float16)
        segments = []
        for sequence in sequences:
            x = sequence[:, idx]
            for setting in GestureCoder.settings:
                n_min, n_max = (_frames(v, FPS) for v in setting[:2])
                bounds = gesture_boundaries(x, FPS, n_min, n_max, beta=setting[2])
                segments += [warp(x[a:b + 1], N_NORM) for a, b in zip(bounds[:-1], bounds[1:])]
        gestures, dg = spaced_table(np.array(segments), MAX_GESTURES, 0.1 * np.sqrt(N_NORM))
        model[f"gesture_{group}"] = gestures.astype(np.float16)
        print(f"{group}: {len(idx)} DOFs, {len(postures)} postures, "
              f"{len(gestures)} gestures of {len(segments)} (D = {dg:.3f})", file=sys.stderr)

    vectors = np.concatenate([temporal_vectors(s[:, np.ptp(s, axis=0) > 1e-4]) for s in sequences])
    for size, book in train_codebooks(vectors, CODEBOOK_SIZES).items():
        vq[f"tvq_{size}"] = book.astype(np.float16)
    np.savez_compressed(VQ_TABLE_PATH, **vq)
    np.savez_compressed(MODEL_TABLE_PATH, **model)
    print(f"wrote {RANGES_PATH.name}, {VQ_TABLE_PATH.name}, {MODEL_TABLE_PATH.name}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())

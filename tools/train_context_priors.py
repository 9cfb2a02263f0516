"""Trains the initial model states of wavelet-cx's compact streams: comparisons/tables/context_priors.npz.

Clips: every fingerspelled unit of every training language (comparisons.lab.codecs.training_languages(): never
the charted ASL/DGS/TSM clips the benchmarks measure), one clip per unit (media.fingerspelling.letter_motion at
25 fps, and the same motion resampled to 10 fps, media.motion.resample), the signing DOFs as LabCodec codes them
(comparisons.lab.codecs.motion_dofs; the active mask = DOFs not exactly 0 in the clip).

Inter-DOF predictors (ContextPriors.predictor / .weight, comparisons/waveform_coders.predict_dofs) come first: for
each DOF of the layout, the earlier DOF and weight (in 1/64, |w| <= 3) whose prediction leaves the fewest estimated
bits (sum of log2(1 + |residual|) over the clips' coded coefficients at q = 9; candidates: the 6 earlier DOFs most
correlated with it), kept when it saves at least 5 % of them. For each operating point q the clips' coefficients,
with that prediction, are binarised exactly as the coder does (comparisons/lab/context.py,
with a tally of the bits each context codes); a context's prior is P(0) = (zeros + 1) / (bits + 2) (Laplace) and
its count (how many bits the prior weighs, i.e. how slowly the model leaves it) min(bits, cap). The mask's models
(one bin per DOF, context: the previous DOF's bit) are trained the same way, on the 25 fps clips. cap is chosen
on held-out languages: predictors and priors trained on every other training language, scored by the compact
streams' total bytes on the rest (printed with the bytes of untrained models and of streams without prediction).

    python tools/train_context_priors.py [--dofs-cache /tmp/train_dofs.npz] [--out comparisons/tables/context_priors.npz]
"""
from __future__ import annotations

import argparse
import datetime
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from comparisons.lab.codecs import dof_layout, motion_dofs, training_languages
from comparisons.lab.waveform import (MAX_PREDICTION_WEIGHT, PRIORS_PATH, ContextWaveletCoder, predict_dofs,
                                         prediction_pairs, weighted_prediction)
from comparisons.lab import context as lab_context

CAPS = (4, 8, 12, 16, 24, 32, 62)
FPS = (25.0, 10.0)
PREDICTOR_Q = 9            # the step the inter-DOF predictors are chosen at (0.32 / 2^9 rad)
PREDICTOR_CANDIDATES = 6   # earlier DOFs tried per DOF: the most correlated ones
PREDICTOR_MIN_GAIN = 0.05  # a predictor is kept when it cuts the DOF's estimated bits by at least this share


def training_clips(cache: Path | None) -> dict[str, np.ndarray]:
    """{"language/k/fps": (T, D) DOFs} of every training language's units."""
    if cache is not None and cache.exists():
        with np.load(cache) as stored:
            return {key: stored[key] for key in stored.files}
    from media import lexicon
    from media.fingerspelling import letter_motion
    from media.motion import resample
    clips = {}
    for language in training_languages():
        for k, unit in enumerate(lexicon.units(language)):
            motion = letter_motion(language, unit, 25.0)
            clips[f"{language}/{k}/25"] = motion_dofs(motion)
            clips[f"{language}/{k}/10"] = motion_dofs(resample(motion, 10.0))
        print(f"{language}: {len(clips)} clips", file=sys.stderr)
    if cache is not None:
        np.savez_compressed(cache, **clips)
    return clips


def _unpredicted(dofs: np.ndarray, q: int) -> tuple[np.ndarray, np.ndarray]:
    """(active mask (D,) bool, coded coefficients (n_active, n_blocks, 16) of the active DOFs before the inter-DOF
    prediction) as LabCodec and the coder make them."""
    active = np.any(dofs != 0.0, axis=0)
    if not active.any():
        active[0] = True
    coder = ContextWaveletCoder(np.zeros(int(active.sum())), np.ones(int(active.sum())))
    return active, coder._coded(dofs[:, active], coder.settings[q])[1]


def _coded(dofs: np.ndarray, q: int, predictors: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """(active mask (D,) int64, the coefficients the compact stream codes: inter-DOF residuals)."""
    active, coded = _unpredicted(dofs, q)
    return active.astype(np.int64), predict_dofs(coded, prediction_pairs(active, *predictors))


def _estimated_bits(values: np.ndarray) -> np.ndarray:
    """A stand-in for the coder's bits of integer values (..., N): sum of log2(1 + |v|) over the last axis."""
    return np.log2(1.0 + np.abs(values)).sum(axis=-1)


def train_predictors(clips: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """(predictor, weight) (D,) int64 of the layout (ContextPriors): for each DOF d, of the PREDICTOR_CANDIDATES
    earlier DOFs whose coded coefficients (at PREDICTOR_Q, every clip's blocks side by side, a still DOF as 0) are
    most correlated with d's, and every weight w / 2^PREDICTION_SHIFT within MAX_PREDICTION_WEIGHT, the pair that
    leaves the fewest estimated bits, if it saves at least PREDICTOR_MIN_GAIN of them."""
    n_layout = dof_layout().n_dofs
    columns = []
    for dofs in clips:
        active, coded = _unpredicted(dofs, PREDICTOR_Q)
        full = np.zeros((n_layout, coded.shape[1] * coded.shape[2]), dtype=np.int64)
        full[active] = coded.reshape(len(coded), -1)
        columns.append(full)
    values = np.concatenate(columns, axis=1)
    weights = np.arange(-MAX_PREDICTION_WEIGHT, MAX_PREDICTION_WEIGHT + 1)
    predictor, weight = np.full(n_layout, -1, dtype=np.int64), np.zeros(n_layout, dtype=np.int64)
    for d in range(1, n_layout):
        bits = (1.0 - PREDICTOR_MIN_GAIN) * _estimated_bits(values[d])
        earlier = values[:d].astype(np.float64)
        energy = (earlier ** 2).sum(axis=1)
        correlation = np.where(energy > 0, (earlier @ values[d]) ** 2 / np.maximum(energy, 1.0), 0.0)
        for source in np.argsort(-correlation, kind="stable")[:PREDICTOR_CANDIDATES]:
            if energy[source] == 0:
                continue
            predicted = weighted_prediction(weights[:, None], values[source])
            residual_bits = _estimated_bits(values[d] - predicted)
            best = int(np.argmin(residual_bits))
            if residual_bits[best] < bits:
                bits, predictor[d], weight[d] = residual_bits[best], source, weights[best]
    return predictor, weight


def tallies(clips: list[np.ndarray], q: int, predictors: tuple[np.ndarray, np.ndarray]
            ) -> tuple[np.ndarray, np.ndarray]:
    """Bits coded per context and value: coefficient contexts (N_CONTEXTS, 2), mask contexts (2 D, 2)."""
    coeff = np.zeros((lab_context.N_CONTEXTS, 2), dtype=np.int64)
    mask_tally = np.zeros((2 * dof_layout().n_dofs, 2), dtype=np.int64)
    for dofs in clips:
        mask, coded = _coded(dofs, q, predictors)
        out = np.zeros(lab_context.payload_capacity(coded.size) + len(mask), dtype=np.uint8)
        state = lab_context.encoder_state()
        lab_context.code_mask(False, state, out, mask, *lab_context.uniform_models(len(mask_tally)), mask_tally)
        lab_context.code_coefficients(False, state, out, coded, *lab_context.uniform_models(lab_context.N_CONTEXTS),
                                      coeff)
    return coeff, mask_tally


def models(tally: np.ndarray, cap: int) -> tuple[np.ndarray, np.ndarray]:
    """(probs, counts) int64 from a tally (n, 2): Laplace P(0) x 65536 within the kernel's limits, min(bits, cap)."""
    total = tally.sum(axis=1)
    probs = np.rint(lab_context.PROB_ONE * (tally[:, 0] + 1) / (total + 2)).astype(np.int64)
    probs = np.clip(probs, lab_context.PROB_MIN, lab_context.PROB_ONE - lab_context.PROB_MIN)
    return probs, np.minimum(total, cap).astype(np.int64)


def coded_bytes(clips: list[np.ndarray], q: int, coeff: tuple, mask: tuple, predictors: tuple) -> int:
    """Payload bytes of the clips with these initial models and inter-DOF predictors."""
    total = 0
    none = np.zeros((0, 2), dtype=np.int64)
    for dofs in clips:
        active, coded = _coded(dofs, q, predictors)
        out = np.zeros(lab_context.payload_capacity(coded.size) + len(active), dtype=np.uint8)
        state = lab_context.encoder_state()
        lab_context.code_mask(False, state, out, active, mask[0].copy(), mask[1].copy(), none)
        lab_context.code_coefficients(False, state, out, coded, coeff[0].copy(), coeff[1].copy(), none)
        total += lab_context.finish_encoder(state, out)
    return total


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dofs-cache", type=Path, help="npz of the training clips' DOFs (written if missing)")
    parser.add_argument("--out", type=Path, default=PRIORS_PATH)
    args = parser.parse_args(argv)
    clips = training_clips(args.dofs_cache)
    languages = sorted({key.split("/")[0] for key in clips})
    held_out = set(languages[1::2])
    n_settings = len(ContextWaveletCoder.settings)

    def subset(fps: tuple[float, ...], languages_in=None) -> list[np.ndarray]:
        return [v for k, v in sorted(clips.items()) if float(k.split("/")[2]) in fps
                and (languages_in is None or (k.split("/")[0] in held_out) == languages_in)]

    train, test = subset(FPS, False), subset(FPS, True)
    predictors = train_predictors(train)
    no_predictors = (np.full(len(predictors[0]), -1), np.zeros(len(predictors[0]), dtype=np.int64))
    scores = {cap: 0 for cap in CAPS}
    for q in range(n_settings):
        coeff, mask = tallies(train, q, predictors)
        for cap in CAPS:
            scores[cap] += coded_bytes(test, q, models(coeff, cap), models(mask, cap), predictors)
        untrained = coded_bytes(test, q, lab_context.uniform_models(lab_context.N_CONTEXTS),
                                lab_context.uniform_models(len(mask)), predictors)
        unpredicted = coded_bytes(test, q, *(models(t, 24) for t in tallies(train, q, no_predictors)), no_predictors)
        print(f"q {q + 1}: held-out payload bytes untrained {untrained}, without inter-DOF prediction (cap 24) "
              f"{unpredicted}, " + ", ".join(f"cap {cap}: {coded_bytes(test, q, models(coeff, cap), models(mask, cap), predictors)}"
                                             for cap in CAPS[::2]), file=sys.stderr)
    cap = min(scores, key=scores.get)
    print(f"cap {cap} (held-out bytes over all q: {scores})", file=sys.stderr)

    everything = subset(FPS)
    predictors = train_predictors(everything)
    coeff_probs, coeff_counts = [], []
    for q in range(n_settings):
        probs, counts = models(tallies(everything, q, predictors)[0], cap)
        coeff_probs.append(probs)
        coeff_counts.append(counts)
    mask_probs, mask_counts = models(tallies(subset((25.0,)), 0, predictors)[1], cap)
    provenance = (f"tools/train_context_priors.py, {datetime.date.today().isoformat()}: {len(everything)} clips "
                  f"(letter_motion of every unit at 25 fps and resampled to 10 fps) of the training languages "
                  f"{', '.join(languages)}; count cap {cap} chosen on held-out languages {', '.join(sorted(held_out))}; "
                  f"{int((predictors[0] >= 0).sum())} DOFs predicted from another")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(args.out, coeff_probs=np.array(coeff_probs, dtype=np.uint16),
                        coeff_counts=np.array(coeff_counts, dtype=np.uint8),
                        mask_probs=mask_probs.astype(np.uint16), mask_counts=mask_counts.astype(np.uint8),
                        predictor=predictors[0].astype(np.int16), weight=predictors[1].astype(np.int16),
                        dof_names=np.array(dof_layout().names), provenance=np.array(provenance))
    print(f"wrote {args.out}: {provenance}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

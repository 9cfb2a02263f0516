"""Statistics of signing motion, per DOF and per joint group (seed 002 ch. 5, on the retargeted lexicon).

Input: DOF trajectories (T, D) radians at `fps` (comparisons.lab.codecs: the avatar's signing BAPs)
with their names and joint groups. Measured, for the DOFs that move (range > 1e-4 rad):
- spatial content (§5.2.2): min, max, range, mean, standard deviation;
- temporal content (§5.2.3): frame differences d(n) = theta(n) - theta(n-1): mean, standard deviation,
  mean absolute value (the Laplacian scale b), excess kurtosis (3 for a Laplacian, 0 for a Gaussian),
  and the lag-1 autocorrelation coefficient of the mean-removed values;
- frequency content (§5.2.4): the power spectral density of the mean-removed signal (Welch, Hann
  windows of up to 128 samples, half overlap; the seed's Blackman-Tukey estimate is likewise a smoothed
  transform of the autocovariance), the share of energy below 1, 3, 7 and 15 Hz (capped at fs/2), and
  the frequency beyond which the PSD stays more than 50 dB below its peak;
- cross-dependence (fig. 5-9 to 5-11): the correlation matrix of the signing hand's finger flexions.
Per group the PSD is averaged over its moving DOFs (the seed's long-term PSD per body section).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import welch

from comparisons.reports.figures import suptitle

BAND_EDGES_HZ = (1.0, 3.0, 7.0, 15.0)
DOWN_DB = 50.0
MOVING = 1e-4


@dataclass
class MotionAnalysis:
    """dof_rows / group_rows: one dict per moving DOF / per group (CSV rows);
    frequencies (F,) Hz with group_psd {group: (F,)}; finger_names and finger_correlation (K, K);
    values and differences {group: 1-D arrays of the moving DOFs' values / frame differences}."""
    fps: float
    n_frames: int
    dof_rows: list[dict]
    group_rows: list[dict]
    frequencies: np.ndarray
    group_psd: dict[str, np.ndarray]
    finger_names: list[str]
    finger_correlation: np.ndarray
    values: dict[str, np.ndarray]
    differences: dict[str, np.ndarray]


def power_spectrum(signals: np.ndarray, fps: float) -> tuple[np.ndarray, np.ndarray]:
    """Welch PSD of each mean-removed column of (T, K): frequencies (F,), psd (F, K)."""
    signals = np.asarray(signals, dtype=np.float64)
    segment = min(len(signals), 128)
    frequencies, psd = welch(signals - signals.mean(axis=0), fs=fps, window="hann", nperseg=segment,
                             noverlap=segment // 2, detrend=False, axis=0)
    return frequencies, psd


def energy_shares(frequencies: np.ndarray, psd: np.ndarray) -> dict[str, float]:
    """Share of the (non-DC) energy at or below each band edge."""
    total = psd[1:].sum()
    shares = {}
    for edge in BAND_EDGES_HZ:
        inside = (frequencies > 0) & (frequencies <= edge)
        shares[f"share_below_{edge:g}Hz"] = float(psd[inside].sum() / total) if total > 0 else float("nan")
    return shares


def frequency_down(frequencies: np.ndarray, psd: np.ndarray, down_db: float = DOWN_DB) -> float:
    """Lowest frequency above which the PSD stays more than down_db below its peak (Hz); fs/2 when it never does."""
    if psd.max() <= 0:
        return float("nan")
    above = np.flatnonzero(psd >= psd.max() * 10 ** (-down_db / 10))
    last = above[-1]
    return float(frequencies[min(last + 1, len(frequencies) - 1)])


def _excess_kurtosis(x: np.ndarray) -> float:
    centred = x - x.mean()
    variance = np.mean(centred ** 2)
    return float(np.mean(centred ** 4) / variance ** 2 - 3.0) if variance > 0 else float("nan")


def analyze(dofs: np.ndarray, fps: float, names: list[str], groups: dict[str, np.ndarray],
            finger_flexions: list[str] | None = None) -> MotionAnalysis:
    """Statistics of (T, D) radians; groups: {name: DOF indices}; finger_flexions: DOF names whose
    correlation matrix is wanted (default: names containing a finger and 'flexion', of the hand that moves most)."""
    dofs = np.asarray(dofs, dtype=np.float64)
    spread = np.ptp(dofs, axis=0)
    frequencies, psd = power_spectrum(dofs, fps)
    group_of = {int(i): g for g, idx in groups.items() for i in idx}
    dof_rows = []
    for j in np.flatnonzero(spread > MOVING):
        x = dofs[:, j]
        d = np.diff(x)
        centred = x - x.mean()
        row = {"dof": names[j], "group": group_of.get(int(j), ""), "min": x.min(), "max": x.max(),
               "range": spread[j], "mean": x.mean(), "std": x.std(), "diff_mean": d.mean(), "diff_std": d.std(),
               "diff_mean_abs": np.abs(d).mean(), "diff_excess_kurtosis": _excess_kurtosis(d),
               "lag1_autocorrelation": float(np.dot(centred[1:], centred[:-1]) / np.dot(centred, centred))}
        row.update(energy_shares(frequencies, psd[:, j]))
        row["freq_50dB_down_Hz"] = frequency_down(frequencies, psd[:, j])
        dof_rows.append(row)

    group_rows, group_psd, values, differences = [], {}, {}, {}
    for group, idx in groups.items():
        idx = np.asarray(idx)
        moving = idx[spread[idx] > MOVING]
        row = {"group": group, "dofs": len(idx), "moving_dofs": len(moving)}
        if len(moving):
            mean_psd = psd[:, moving].mean(axis=1)
            group_psd[group] = mean_psd
            d = np.diff(dofs[:, moving], axis=0)
            values[group], differences[group] = dofs[:, moving].ravel(), d.ravel()
            row.update({"mean_range": spread[moving].mean(), "max_range": spread[moving].max(),
                        "diff_std": d.std(), "diff_mean_abs": np.abs(d).mean(),
                        "diff_excess_kurtosis": _excess_kurtosis(d.ravel()),
                        "speed_rms_rad_s": float(np.sqrt(np.mean(np.sum(d ** 2, axis=1))) * fps)})
            row.update(energy_shares(frequencies, mean_psd))
            row["freq_50dB_down_Hz"] = frequency_down(frequencies, mean_psd)
        group_rows.append(row)

    if finger_flexions is None:
        candidates = [i for i, n in enumerate(names) if "flexion" in n and any(
            f in n for f in ("thumb", "index", "middle", "ring", "pinky"))]
        by_side = {side: [i for i in candidates if names[i].startswith(side)] for side in ("l_", "r_")}
        side = max(by_side, key=lambda s: spread[by_side[s]].sum() if by_side[s] else -1.0)
        finger_idx = [i for i in by_side[side] if spread[i] > MOVING]
    else:
        finger_idx = [names.index(n) for n in finger_flexions if spread[names.index(n)] > MOVING]
    correlation = np.corrcoef(dofs[:, finger_idx].T) if len(finger_idx) > 1 else np.ones((len(finger_idx),) * 2)
    return MotionAnalysis(fps, len(dofs), dof_rows, group_rows, frequencies, group_psd,
                          [names[i] for i in finger_idx], np.atleast_2d(correlation), values, differences)


def _rows(rows: list[dict]) -> list[list]:
    """dict rows as CSV rows, the header (every key, in order of appearance) first; floats to 6 digits."""
    fields = list(dict.fromkeys(k for row in rows for k in row))
    return [fields] + [[(lambda v: f"{v:.6g}" if isinstance(v, (float, np.floating)) else ("" if v is None else v))(
        row.get(k)) for k in fields] for row in rows]


def analysis_outputs(prefix: str, analysis: MotionAnalysis) -> dict:
    """The CSV tables (lists of rows, the header first) and PNG plots (matplotlib figures) of one analysis, by file
    name ({prefix}_dofs.csv, _groups.csv, _finger_correlation.csv, _histograms.csv, _distributions.png, _psd.png,
    _finger_correlation.png with more than one moving finger flexion); the study layer writes them
    (pipeline.outputs.write_outputs)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    outputs: dict = {f"{prefix}_dofs.csv": _rows(analysis.dof_rows), f"{prefix}_groups.csv": _rows(analysis.group_rows)}
    outputs[f"{prefix}_finger_correlation.csv"] = [[""] + analysis.finger_names] + [
        [name] + [f"{v:.4f}" for v in row] for name, row in zip(analysis.finger_names, analysis.finger_correlation)]
    histogram = [["group", "quantity", "bin_low_deg", "bin_high_deg", "density_per_deg"]]
    for group in analysis.values:
        for quantity, samples in (("value", analysis.values[group]), ("difference", analysis.differences[group])):
            density, edges = np.histogram(np.degrees(samples), bins=60, density=True)
            for low, high, value in zip(edges[:-1], edges[1:], density):
                histogram.append([group, quantity, f"{low:.4g}", f"{high:.4g}", f"{value:.6g}"])
    outputs[f"{prefix}_histograms.csv"] = histogram

    groups = list(analysis.group_psd)
    figure, axes = plt.subplots(2, max(len(groups), 1), figsize=(3.6 * max(len(groups), 1), 6.2), squeeze=False,
                             dpi=100)
    for k, group in enumerate(groups):
        axes[0][k].hist(np.degrees(analysis.values[group]), bins=60, density=True, color="tab:blue")
        axes[0][k].set(title=f"{group}: values", xlabel="degrees")
        d = np.degrees(analysis.differences[group])
        axes[1][k].hist(d, bins=80, density=True, color="tab:orange", log=True)
        b = np.abs(d - d.mean()).mean()
        grid = np.linspace(d.min(), d.max(), 200)
        if b > 0:
            axes[1][k].plot(grid, np.exp(-np.abs(grid - d.mean()) / b) / (2 * b), "k--", lw=1, label="Laplacian fit")
            axes[1][k].legend(fontsize=7)
        axes[1][k].set(title=f"{group}: frame differences", xlabel="degrees per frame")
    suptitle(figure, f"{prefix}: distributions of values and frame differences (moving DOFs)", fontsize=11)
    figure.tight_layout()
    outputs[f"{prefix}_distributions.png"] = figure

    figure, axis = plt.subplots(figsize=(7, 4.5), dpi=100)
    for group in groups:
        psd = analysis.group_psd[group]
        axis.plot(analysis.frequencies[1:], 10 * np.log10(psd[1:] / psd.max()), label=group)
    axis.axhline(-DOWN_DB, color="k", ls=":", lw=1, label=f"-{DOWN_DB:g} dB")
    for edge in BAND_EDGES_HZ:
        axis.axvline(edge, color="grey", lw=0.5)
    axis.set(xlabel="Hz", ylabel="dB below peak", title=f"{prefix}: long-term PSD per joint group", ylim=(-90, 3))
    axis.grid(True, alpha=0.3)
    axis.legend(fontsize=8)
    figure.tight_layout()
    outputs[f"{prefix}_psd.png"] = figure

    if len(analysis.finger_names) > 1:
        figure, axis = plt.subplots(figsize=(6.5, 5.5), dpi=100)
        image = axis.imshow(analysis.finger_correlation, vmin=-1, vmax=1, cmap="coolwarm")
        axis.set_xticks(range(len(analysis.finger_names)), analysis.finger_names, rotation=90, fontsize=7)
        axis.set_yticks(range(len(analysis.finger_names)), analysis.finger_names, fontsize=7)
        figure.colorbar(image, ax=axis, label="correlation")
        axis.set_title(f"{prefix}: correlation between finger flexions")
        figure.tight_layout()
        outputs[f"{prefix}_finger_correlation.png"] = figure
    return outputs

"""The tables and charts of seed 002 ch. 9, made from the records of the lab study (pipeline.studies.lab: every
coder on the whole-alphabet sequence of each language, 25 fps; rate from the coded bytes, PSNR and VPSNR averaged
over the rotation BAPs that move, joint position error). What the study writes with them:
  records.jsonl         one record per point (solution FBA, BBA or motion coder: media.domain.solution_of;
                        clip "<language>:alphabet", codec, q)
  lab_points.csv        the points as a table
  lab_ranges.csv        per codec and language: the operating range (kbps, PSNR, VPSNR)
  lab_waveform_psnr.png PSNR vs kbps, waveform coders and FBA/BBA (seed 002 figs 9-1)
  lab_model_vpsnr.png   VPSNR vs kbps, model-based coders, hybrid and FBA/BBA (seed 002 figs 9-2)
The seed's own points (conversational sequence, whole body, 30 Hz; vanderelst-digest.md) are drawn
in grey for reference.
"""
from __future__ import annotations


import numpy as np

from comparisons.lab.codecs import MODEL_NAMES, WAVEFORM_NAMES, LabCodec
from comparisons.lab.settings import MPEG4_CODECS, MPEG4_Q
from comparisons.reports.figures import suptitle


# Seed 002 Appendix III, conversational sequence (kb/s, dB): PSNR for waveform, VPSNR for model-based coders.
SEED_POINTS = {
    "quant": [(4.455, 9.9), (6.136, 16.7), (7.813, 23.0), (9.476, 29.1), (11.062, 35.2), (12.526, 41.3)],
    "dpcm": [(2.357, 13.4), (3.549, 24.1), (5.285, 31.1), (7.091, 38.1), (8.898, 44.7)],
    "adpcm": [(2.940, 10.7), (3.325, 23.2), (4.048, 31.4), (5.268, 38.7), (6.785, 44.1)],
    "deadreck": [(2.567, 4.4), (4.049, 9.2), (5.967, 13.5), (8.345, 18.3), (10.885, 22.4)],
    "dct": [(1.670, 20.0), (2.508, 24.8), (3.296, 28.3), (4.019, 30.5), (4.785, 31.1)],
    "svq": [(0.747, -0.8), (0.960, 0.5), (1.519, 1.7), (2.145, 3.2), (2.570, 4.6), (2.910, 6.1)],
    "tvq": [(0.988, 7.5), (1.255, 10.0), (1.587, 12.7), (1.973, 15.3), (2.412, 18.4), (2.906, 22.0)],
    "posture": [(0.0209, 6.8), (0.0552, 9.1), (0.0884, 10.7), (0.1245, 11.6), (0.1567, 12.1), (0.1921, 12.5),
                (0.2255, 12.9)],
    "gesture": [(0.0821, 5.8), (0.0895, 6.5), (0.1055, 8.5), (0.1408, 12.3), (0.1558, 14.1), (0.1673, 15.3)],
    "hybrid": [(0.3954, 11.2), (0.5325, 13.5), (0.6227, 14.4), (0.6907, 14.7), (0.7460, 15.0), (0.7851, 15.4),
               (0.8208, 15.6), (0.8495, 15.7)],
}


def count_points(codecs: list[str], mpeg4_q=MPEG4_Q) -> int:
    return sum(len(LabCodec(n).settings()) if n in WAVEFORM_NAMES + MODEL_NAMES else len(mpeg4_q) for n in codecs)


def points_rows(records: list[dict]) -> list[list]:
    """lab_points.csv: one row per operating point (the header first)."""
    columns = ["clip", "codec", "q", "setting", "frames", "bits", "kbps", "param_psnr", "vpsnr", "joint_error_mm_mean"]
    return [columns] + [[r.get(c, "") if not isinstance(r.get(c), float) else f"{r[c]:.4g}" for c in columns]
                        for r in records]


def operating_ranges(records: list[dict]) -> list[dict]:
    """Per (codec, clip): min/max of kbps, PSNR and VPSNR over the operating points."""
    rows = []
    for key in dict.fromkeys((r["codec"], r["clip"]) for r in records):
        mine = [r for r in records if (r["codec"], r["clip"]) == key]
        row = {"codec": key[0], "clip": key[1], "points": len(mine)}
        for field in ("kbps", "param_psnr", "vpsnr"):
            values = [r[field] for r in mine]
            row[f"{field}_min"], row[f"{field}_max"] = min(values), max(values)
        rows.append(row)
    return rows


def ranges_rows(records: list[dict]) -> list[list]:
    """lab_ranges.csv: `operating_ranges` as CSV rows (the header first)."""
    rows = operating_ranges(records)
    return [list(rows[0])] + [[f"{v:.4g}" if isinstance(v, float) else v for v in row.values()] for row in rows]


def _chart(records: list[dict], names: list[str], quality: str, title: str):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    clips = list(dict.fromkeys(r["clip"] for r in records))
    figure, axes = plt.subplots(1, len(clips), figsize=(5.2 * len(clips), 4.6), squeeze=False, dpi=110)
    colours = plt.get_cmap("tab20")
    for axis, clip in zip(axes[0], clips):
        for k, name in enumerate(names):
            mine = sorted((r for r in records if r["clip"] == clip and r["codec"] == name), key=lambda r: r["kbps"])
            if not mine:
                continue
            style = "--" if name in MPEG4_CODECS else "-"
            axis.plot([r["kbps"] for r in mine], [r[quality] for r in mine], style, marker="o", markersize=3,
                      color=colours(k % 20), label=name)
            if name in SEED_POINTS:
                seed = np.array(SEED_POINTS[name])
                axis.plot(seed[:, 0], seed[:, 1], ":", marker="x", markersize=4, color=colours(k % 20), alpha=0.45)
        axis.set(xscale="log", xlabel="kbit/s", ylabel=f"{quality.replace('param_', '').upper()} (dB, mean over moving BAPs)",
                 title=f"{clip.split(':')[0]}: whole alphabet, 25 fps")
        axis.grid(True, which="both", alpha=0.3)
    axes[0][0].legend(fontsize=7, ncol=2, title="dotted x: seed 002 (conv., 30 Hz)", title_fontsize=7)
    suptitle(figure, title, fontsize=11)
    figure.tight_layout()
    return figure


def charts(records: list[dict]) -> dict:
    """The two charts (matplotlib figures) by file name: lab_waveform_psnr.png and lab_model_vpsnr.png."""
    return {"lab_waveform_psnr.png": _chart(records, list(WAVEFORM_NAMES) + list(MPEG4_CODECS), "param_psnr",
                                            "Waveform coders (seed 002 ch. 7) and MPEG-4 FBA/BBA: PSNR vs rate"),
            "lab_model_vpsnr.png": _chart(records, list(MODEL_NAMES) + ["dpcm", "dct"] + list(MPEG4_CODECS), "vpsnr",
                                          "Model-based coders (seed 002 ch. 8), two waveform coders and MPEG-4 FBA/BBA: "
                                          "VPSNR vs rate")}

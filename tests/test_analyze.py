"""Motion analysis (seed 002 ch. 5) and `signcast analyze`."""
import numpy as np
import pytest

from comparisons.lab.motion_analysis import analyze, energy_shares, frequency_down, power_spectrum
from pipeline.studies.analyze import write_analysis
from pipeline.cli import main

FPS = 25.0


def test_energy_of_a_two_hertz_sinusoid_lies_between_one_and_three_hertz():
    t = np.arange(500) / FPS
    frequencies, psd = power_spectrum(np.sin(2 * np.pi * 2.0 * t)[:, None], FPS)
    shares = energy_shares(frequencies, psd[:, 0])
    assert shares["share_below_1Hz"] < 0.02
    assert shares["share_below_3Hz"] > 0.98
    assert 2.0 < frequency_down(frequencies, psd[:, 0]) < 5.0


def test_analysis_reports_ranges_laplacian_differences_and_finger_correlation():
    rng = np.random.default_rng(0)
    n = 2000
    walk = np.cumsum(rng.laplace(0.0, 0.01, size=n))
    names = ["r_index1_flexion", "r_index2_flexion", "r_middle1_flexion", "vc2roll"]
    dofs = np.column_stack([walk, 0.8 * walk, rng.normal(0, 0.1, n), np.zeros(n)])
    groups = {"right_hand": np.array([0, 1, 2]), "torso_head": np.array([3])}
    result = analyze(dofs, FPS, names, groups)
    rows = {r["dof"]: r for r in result.dof_rows}
    assert set(rows) == {"r_index1_flexion", "r_index2_flexion", "r_middle1_flexion"}  # the still DOF is left out
    assert rows["r_index1_flexion"]["range"] == pytest.approx(np.ptp(walk))
    assert rows["r_index1_flexion"]["diff_mean_abs"] == pytest.approx(0.01, rel=0.1)
    assert rows["r_index1_flexion"]["diff_excess_kurtosis"] == pytest.approx(3.0, abs=1.0)  # Laplacian
    assert rows["r_middle1_flexion"]["lag1_autocorrelation"] < 0.2 < rows["r_index1_flexion"]["lag1_autocorrelation"]
    assert result.finger_names == names[:3]
    assert result.finger_correlation[0, 1] == pytest.approx(1.0)
    assert abs(result.finger_correlation[0, 2]) < 0.3
    groups_by_name = {r["group"]: r for r in result.group_rows}
    assert groups_by_name["torso_head"]["moving_dofs"] == 0
    assert groups_by_name["right_hand"]["moving_dofs"] == 3


def test_write_analysis_writes_tables_and_plots(tmp_path, check_png):
    rng = np.random.default_rng(1)
    dofs = np.cumsum(rng.normal(0, 0.02, size=(300, 3)), axis=0)
    result = analyze(dofs, FPS, ["r_index1_flexion", "r_ring1_flexion", "vt1roll"],
                     {"right_hand": np.array([0, 1]), "torso_head": np.array([2])})
    paths = write_analysis(tmp_path, "test", result)
    names = {p.name for p in paths}
    assert {"test_dofs.csv", "test_groups.csv", "test_finger_correlation.csv", "test_histograms.csv", "test_psd.png",
            "test_distributions.png", "test_finger_correlation.png"} <= names
    assert all(p.stat().st_size > 0 for p in paths if p.suffix == ".csv")
    for png in (p for p in paths if p.suffix == ".png"):
        check_png(png, ((300, 3000), (200, 2000)))            # a real, non-blank chart of a plausible size


@pytest.mark.slow
def test_analyze_command_on_the_asl_alphabet(tmp_path, capsys, check_png):
    assert main(["analyze", "ase", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "right_hand" in out
    table = (tmp_path / "ase_groups.csv").read_text()
    assert "right_hand" in table and "share_below_3Hz" in table
    check_png(tmp_path / "ase_psd.png", ((300, 3000), (200, 2000)))


def test_analyze_command_rejects_an_unknown_language(tmp_path, capsys):
    assert main(["analyze", "xxx", "--out", str(tmp_path)]) == 2
    assert "error" in capsys.readouterr().err

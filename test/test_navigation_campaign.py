"""The rotational_ins_navigation experiment campaign: gimbal-campaign routes the name to the
core engine, the CEP table's median interval is the order-statistics one."""
import json

import numpy as np
import pytest
from scipy import stats

from gimbal_sim.campaign_cli import main as campaign_main
from gimbal_sim.experiments.navigation import cep_summary, main as navigation_main, median_interval


def test_median_interval_is_the_distribution_free_order_statistics_interval():
    """n = 20: [x_(6), x_(15)] (binomial coverage 95.9 %, the textbook table), and Monte
    Carlo coverage of the true median of a skewed law is at least 95 %."""
    med, lo, hi = median_interval(np.arange(1.0, 21.0))
    assert (med, lo, hi) == (10.5, 6.0, 15.0)
    assert stats.binom.cdf(14, 20, 0.5) - stats.binom.cdf(5, 20, 0.5) >= 0.95
    rng = np.random.default_rng(3)
    true_median = np.log(2.0)  # exponential(1)
    hits = sum(lo <= true_median <= hi for _, lo, hi in (median_interval(rng.exponential(size=20))
                                                         for _ in range(2000)))
    assert hits / 2000 >= 0.945


def test_gimbal_campaign_runs_the_experiment_on_the_core_engine(tmp_path, capsys):
    out = tmp_path / "c"
    # align_then_navigate's 600 s alignment at 1 kHz is too long for a test (test_navigation_hand_off)
    assert campaign_main(["rotational_ins_navigation", "--variant", "rotation_on", "--variant", "rotation_off",
                          "--seeds", "1", "--duration", "20", "--serial",
                          "--no-progress", "--out", str(out)]) == 0
    runs = sorted(out.glob("runs/*/report/metrics.json"))
    assert len(runs) == 2
    metrics = [json.loads(p.read_text())["navigation"] for p in runs]
    assert sorted(m["rotate"] for m in metrics) == [False, True]
    assert all(m["duration_s"] == 20.0 and m["gimbal_lock_events"] == 0 for m in metrics)
    summary = cep_summary({"rotation_on": [m for m in metrics if m["rotate"]],
                           "rotation_off": [m for m in metrics if not m["rotate"]]})
    assert summary["rotation_on"]["runs"] == 1
    printed = capsys.readouterr().out  # gimbal-campaign prints the CEP50 table itself, as its report carries it
    assert "CEP50" in printed and "ratio rotation_off / rotation_on" in printed
    assert "CEP50" in json.loads((out / "report" / "summary.json").read_text())["experiment_table"]
    # a graph run's report names the rate final_radial_rate_nmi_h and has no servo figures
    assert cep_summary({"rotation_on": [{"final_radial_rate_nmi_h": 0.2}]})["rotation_on"]["cep50_nmi_h"] == 0.2
    assert navigation_main(["cep", str(out)]) == 0
    assert "rotation_off" in capsys.readouterr().out
    # per seed: the seed's row carries each variant's radial rate, as in metrics.json
    assert navigation_main(["cep", str(out), "--per-seed"]) == 0
    row = capsys.readouterr().out.splitlines()[-1].split()
    assert row[0] == "1" and sorted(float(v) for v in row[1:]) == pytest.approx(
        sorted(m["radial_rate_nmi_h"] for m in metrics), abs=1e-3)
    assert navigation_main(["cep", str(tmp_path / "none")]) == 2
    assert campaign_main(["rotational_ins_navigation", "--sweep", "a.b=1:2:2", "--out", str(tmp_path / "x")]) == 2

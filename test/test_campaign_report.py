"""Campaign statistics and the results table, checked against scipy, Monte Carlo and files
read back with pyarrow and the csv module."""
from __future__ import annotations

import csv
import math

import numpy as np
import pyarrow.parquet as pq
import pytest
from scipy import stats as sps

from gimbal_sim.campaign.results import flatten_metrics, write_results
from gimbal_sim.campaign.report import nees_verdict, stats, summarize, text_summary


def test_stats_match_scipys_t_interval():
    x = [0.3, -0.1, 0.25, 0.4, 0.05, None, math.nan]
    s = stats(x)
    finite = np.array(x[:5])
    assert s["n"] == 5 and s["n_nonfinite"] == 2
    assert s["mean"] == pytest.approx(finite.mean(), abs=1e-15)
    assert s["std"] == pytest.approx(np.std(finite, ddof=1), rel=1e-12)
    lo, hi = sps.t.interval(0.95, 4, loc=finite.mean(), scale=sps.sem(finite))
    assert s["ci95"] == pytest.approx([lo, hi], rel=1e-12)


def test_t_interval_covers_the_true_mean_95_percent_of_the_time():
    rng = np.random.default_rng(11)
    trials = 4000
    hits = sum(lo <= 2.0 <= hi for lo, hi in (stats(list(rng.normal(2.0, 3.0, 6)))["ci95"] for _ in range(trials)))
    # binomial: 95 % +- 3 sigma of 4000 trials (0.34 %)
    assert abs(hits / trials - 0.95) < 0.011


def test_nees_verdict_band_holds_95_percent_of_consistent_averages():
    rng = np.random.default_rng(5)
    n, dof, trials = 20, 2, 4000
    verdicts = [nees_verdict(list(rng.chisquare(dof, n)), dof)["verdict"] for _ in range(trials)]
    assert abs(verdicts.count("consistent") / trials - 0.95) < 0.011
    assert nees_verdict(list(rng.chisquare(dof, n) * 3.0), dof)["verdict"] == "optimistic"
    assert nees_verdict(list(rng.chisquare(dof, n) / 3.0), dof)["verdict"] == "pessimistic"
    assert nees_verdict([math.nan, None], dof)["n"] == 0


def test_flatten_keeps_numeric_leaves_by_dotted_path():
    metrics = {"bag": "/x", "plots": ["a.png"], "topics": {"/t": {"count": 3}}, "closed_cleanly": True,
               "sighting": {"final_drift_deg": {"azimuth": -0.1, "elevation": 0.2}, "nees": None, "label": "x"},
               "estimators": {"kf": {"rms": [1.0, 2.0, 3.0]}}, "n": 4}
    assert flatten_metrics(metrics) == {"closed_cleanly": 1.0, "sighting.final_drift_deg.azimuth": -0.1,
                                        "sighting.final_drift_deg.elevation": 0.2, "sighting.nees": None,
                                        "estimators.kf.rms.0": 1.0, "estimators.kf.rms.1": 2.0,
                                        "estimators.kf.rms.2": 3.0, "n": 4.0}


def _rows():
    rng = np.random.default_rng(2)
    rows = []
    for variant in ("off", "on"):
        for seed in range(1, 6):
            rows.append({"run_id": f"{variant}{seed}", "scenario": "s", "variant": variant, "seed": seed,
                         "engine": "core", "status": "ok", "reason": "", "wall_s": 1.0, "host": "h", "log_tail": "",
                         "values": {"n.gain": 2.0}, "metrics": {"a.drift": float(rng.normal()),
                                                                "a.bias_nees_mean_after_30s": float(rng.chisquare(2))}})
    rows.append({**rows[0], "run_id": "bad", "seed": 9, "status": "failed", "reason": "timed out after 5 s",
                 "log_tail": "line 1\nline 2", "metrics": {}})
    return rows


def test_results_table_reads_back_with_pyarrow_and_csv(tmp_path):
    rows = _rows()
    path = write_results(tmp_path, rows, ["n.gain"])
    table = pq.read_table(path)
    assert table.num_rows == len(rows)
    assert table.column_names[:10] == ["run_id", "scenario", "variant", "seed", "engine", "status", "reason",
                                       "wall_s", "host", "log_tail"]
    assert table.column("seed").to_pylist() == [r["seed"] for r in rows]
    assert table.column("sweep.n.gain").to_pylist() == [2.0] * len(rows)
    assert table.column("a.drift").to_pylist()[:10] == [r["metrics"]["a.drift"] for r in rows[:10]]
    assert table.column("a.drift").to_pylist()[10] is None  # the failed run has no metrics
    assert table.column("log_tail").to_pylist()[10] == "line 1\nline 2"
    with open(tmp_path / "results.csv", newline="") as f:
        read = list(csv.DictReader(f))
    assert [r["run_id"] for r in read] == [r["run_id"] for r in rows]
    assert float(read[3]["a.drift"]) == rows[3]["metrics"]["a.drift"]  # repr round trip: exact


def test_summary_groups_by_variant_and_sweep_point_and_lists_failures(tmp_path):
    rows = _rows()
    write_results(tmp_path, rows, ["n.gain"])
    summary = summarize(pq.read_table(tmp_path / "results.parquet").to_pylist())
    assert [g["label"] for g in summary["groups"]] == ["off, gain=2", "on, gain=2"]
    off = summary["groups"][0]
    assert off["runs"] == 5 and off["seeds"] == [1, 2, 3, 4, 5]
    drift = [r["metrics"]["a.drift"] for r in rows[:5]]
    assert off["metrics"]["a.drift"]["mean"] == pytest.approx(np.mean(drift), abs=1e-15)
    nees = off["nees"]["a.bias_nees_mean_after_30s"]
    assert nees["dof"] == 2 and nees["n"] == 5
    assert nees["band95"] == pytest.approx(list(sps.chi2.ppf([0.025, 0.975], 10) / 5))
    assert summary["failed"][0]["reason"] == "timed out after 5 s"
    text = text_summary(summary)
    assert "FAILED bad (off, seed 9): timed out after 5 s" in text and "NEES a.bias_nees_mean_after_30s" in text

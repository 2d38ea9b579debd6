"""Campaigns that answer a design review: order-statistics verdicts, binomial intervals,
dispersions, Sobol and Morris sensitivity, paired comparison, bad input.

Every figure is checked against something the code under test does not compute: closed
forms (Wilks' run count, the Ishigami and linear Sobol indices), scipy (binomial and
Student t intervals, distributions) and numpy order statistics.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from gimbal_sim.campaign import sensitivity
from gimbal_sim.campaign.dispersion import parse_distribution, unit_points
from gimbal_sim.campaign.order_stats import (Requirement, clopper_pearson, quantile_interval, upper_bound_rank,
                                             verdict, wilks_runs)
from gimbal_sim.campaign.report import diff_results
from gimbal_sim.campaign.results import write_results
from gimbal_sim.campaign_cli import main as campaign_main


def test_wilks_run_counts_are_the_closed_form():
    assert wilks_runs(0.99, 0.9) == 230 and wilks_runs(0.9, 0.9) == 22
    for p, c in ((0.99, 0.9), (0.9, 0.9), (0.95, 0.95), (0.999, 0.5)):
        n = wilks_runs(p, c)
        assert 1 - p ** n >= c > 1 - p ** (n - 1)  # the largest of n runs bounds q_p at c; n - 1 do not
    # one run allowed above the bound: the smallest n with P(B(n, 1 - p) <= 1) <= 1 - c
    n = wilks_runs(0.9, 0.9, failures=1)
    assert stats.binom.cdf(1, n, 0.1) <= 0.1 < stats.binom.cdf(1, n - 1, 0.1)


def test_the_verdict_flips_at_the_order_statistic_wilks_names():
    req = Requirement("m", 0.0, p=0.9, c=0.9)
    x = np.arange(1.0, 39.0)  # 38 runs: one may exceed (P(B(38, 0.9) <= 36) >= 0.9 > P(B(38, 0.9) <= 35))
    assert stats.binom.cdf(36, 38, 0.9) >= 0.9 > stats.binom.cdf(35, 38, 0.9)
    assert upper_bound_rank(38, 0.9, 0.9) == 37
    assert verdict(Requirement("m", 37.0, 0.9, 0.9), x)["verdict"] == "met"        # x_(37) = 37 <= 37
    v = verdict(Requirement("m", 36.999, 0.9, 0.9), x)
    assert v["verdict"] == "not met" and v["order_statistic"] == 37.0 and "upper 0.9-confidence bound" in v["quantile"]
    assert verdict(req, x[:21])["verdict"] == "too few runs" and "needs 22" in verdict(req, x[:21])["detail"]
    # a lower bound is the same rule mirrored; a NaN run counts against the requirement
    assert verdict(Requirement("m", 2.0, 0.9, 0.9, upper=False), x)["verdict"] == "met"
    assert verdict(Requirement("m", 2.001, 0.9, 0.9, upper=False), x)["verdict"] == "not met"
    assert verdict(Requirement("m", 100.0, 0.9, 0.9), [*x[:37], math.nan])["exceeded"] == 1
    assert verdict(Requirement("m", 1.5, 0.9, 0.9, absolute=True), -x[:22] / 22 * 1.5)["verdict"] == "met"


def test_clopper_pearson_and_quantile_intervals_match_scipy_and_binomial_coverage():
    for k, n in ((0, 22), (21, 22), (7, 30), (30, 30)):
        ci = stats.binomtest(k, n).proportion_ci(confidence_level=0.9, method="exact")
        assert clopper_pearson(k, n, 0.9) == pytest.approx((ci.low, ci.high), abs=1e-9)
    x = np.random.default_rng(3).exponential(size=60)
    q, lo, hi = quantile_interval(x, 0.9, 0.95)
    assert q == pytest.approx(np.quantile(x, 0.9))
    srt = np.sort(x)
    l, u = int(np.searchsorted(srt, lo)) + 1, int(np.searchsorted(srt, hi)) + 1  # their ranks
    assert stats.binom.cdf(l - 1, 60, 0.9) <= 0.025 < stats.binom.cdf(l, 60, 0.9)
    assert stats.binom.sf(u - 1, 60, 0.9) <= 0.025 < stats.binom.sf(u - 2, 60, 0.9)


def test_distributions_are_scipys_and_the_samplings_are_seeded():
    u = unit_points("lhs", 400, 4, seed=7)
    assert np.array_equal(u, unit_points("lhs", 400, 4, seed=7))
    assert all(np.array_equal(np.sort(np.floor(u[:, j] * 400)), np.arange(400)) for j in range(4))  # one per stratum
    normal = parse_distribution("normal(100, 30)", "x").ppf(u[:, 0])
    assert stats.kstest(normal, stats.norm(100, 30).cdf).pvalue > 0.01
    trunc = np.array(parse_distribution({"dist": "truncnormal", "mean": 0, "std": 1, "low": 0.5, "high": 3},
                                        "x").ppf(u[:, 1]))
    assert trunc.min() >= 0.5 and trunc.max() <= 3
    assert stats.kstest(trunc, stats.truncnorm(0.5, 3).cdf).pvalue > 0.01
    picks = parse_distribution("choice(rate: 3, hold: 1)", "x").ppf(u[:, 2])
    assert picks.count("rate") == 300 and picks.count("hold") == 100  # LHS: the weights exactly
    assert unit_points("sobol", 64, 3, seed=1).shape == (64, 3)
    with pytest.raises(ValueError, match="power of 2"):
        unit_points("sobol", 48, 3, seed=1)


def _sobol(f, dists: list[str], n: int, seed: int = 1) -> dict:
    names = [f"x{i + 1}" for i in range(len(dists))]
    rows = sensitivity.design("sobol", n, names, seed)
    x = np.array([parse_distribution(d, n).ppf(rows[:, i]) for i, (n, d) in enumerate(zip(names, dists))])
    return sensitivity.analyze("sobol", names, rows, f(x), seed)["factors"]


def test_sobol_indices_of_the_ishigami_function_are_the_analytic_ones():
    a, b = 7.0, 0.1
    pi = "uniform(-3.141592653589793, 3.141592653589793)"
    got = _sobol(lambda x: np.sin(x[0]) + a * np.sin(x[1]) ** 2 + b * x[2] ** 4 * np.sin(x[0]), [pi] * 3, 2**12)
    v = a**2 / 8 + b * math.pi**4 / 5 + b**2 * math.pi**8 / 18 + 0.5
    v1, v2, v13 = 0.5 * (1 + b * math.pi**4 / 5) ** 2, a**2 / 8, b**2 * math.pi**8 * (1 / 18 - 1 / 50)
    s1 = {"x1": v1 / v, "x2": v2 / v, "x3": 0.0}
    st = {"x1": (v1 + v13) / v, "x2": v2 / v, "x3": v13 / v}
    for name in s1:
        assert got[name]["S1"] == pytest.approx(s1[name], abs=0.05)
        assert got[name]["ST"] == pytest.approx(st[name], abs=0.05)
    assert abs(got[sensitivity.SEED_FACTOR]["ST"]) < 1e-12  # the function has no noise


def test_first_order_indices_of_a_linear_metric_are_its_variance_shares_within_their_interval():
    coeff, sigma = np.array([1.0, -2.0, 0.5]), np.array([3.0, 1.0, 2.0])
    got = _sobol(lambda x: coeff @ x, [f"normal({m}, {s})" for m, s in zip((10, 0, -5), sigma)], 2**12, seed=4)
    share = coeff**2 * sigma**2 / np.sum(coeff**2 * sigma**2)
    for i, name in enumerate(("x1", "x2", "x3")):
        assert abs(got[name]["S1"] - share[i]) <= got[name]["S1_conf"], (name, got[name], share[i])
        assert 0 < got[name]["S1_conf"] < 0.1


def test_a_morris_screen_ranks_a_linear_metrics_parameters():
    names = ["x1", "x2", "x3"]
    rows = sensitivity.design("morris", 20, names, 2)
    u = sensitivity.unit_values("morris", rows)
    x = np.array([parse_distribution("uniform(0, 1)", n).ppf(u[:, i]) for i, n in enumerate(names)])
    res = sensitivity.analyze("morris", names, rows, 4 * x[0] + 1 * x[1] + 0 * x[2], 2)["factors"]
    # effects per unit of probability: the coefficient itself for a uniform(0, 1) input
    assert res["x1"]["mu_star"] == pytest.approx(4.0) and res["x2"]["mu_star"] == pytest.approx(1.0)
    assert res["x3"]["mu_star"] == 0.0


def _table(directory, changes: dict[int, float], variant: str) -> None:
    rows = [{"run_id": f"{variant}{s}", "scenario": "x", "variant": variant, "seed": s, "engine": "core",
             "status": "ok", "reason": "", "wall_s": 1.0, "host": "", "log_tail": "", "values": {},
             "metrics": {"m.err": float(v)}} for s, v in changes.items()]
    directory.mkdir()
    write_results(directory, rows, [])


def test_diff_pairs_runs_by_seed_with_the_paired_t_interval(tmp_path):
    rng = np.random.default_rng(0)
    base = rng.normal(size=12)
    _table(tmp_path / "a", dict(enumerate(base)), "v1")
    _table(tmp_path / "b", {s: v + 0.3 + 0.05 * rng.normal() for s, v in enumerate(base)}, "v2")
    m = diff_results(tmp_path / "a", tmp_path / "b")["metrics"]["m.err"]
    b = [v + 0 for v in base]
    from gimbal_sim.campaign.results import read_results

    after = [r["m.err"] for r in sorted(read_results(tmp_path / "b"), key=lambda r: r["seed"])]
    ci = stats.ttest_rel(after, b).confidence_interval(0.95)
    assert m["pairs"] == 12 and m["interval"] == pytest.approx([ci.low, ci.high]) and m["significant"]


@pytest.mark.parametrize("args, message", [
    (["--disperse", "sensor_models.ins_heading_rms_deg=lognormal(0, 1)"], "unknown distribution 'lognormal'"),
    (["--disperse", "sensor_models.ins_heading_rms_deg=truncnormal(0.2, 0.01, 5, 6)"], "outside the support"),
    (["--disperse", "sensor_models.ins_heading_rms_deg=truncnormal(0.2, 0.1, -1, 0.5)"], "a value the node refuses"),
    (["--require", "sighting.no_such_metric<=1,p=0.9,c=0.9"], "do not report this metric"),
    (["--require", "sighting.final_drift_deg.azimuth<=1,p=1.0,c=0.9"], "p must lie in (0, 1)"),
    (["--require", "sighting.final_drift_deg.azimuth<=1,p=0.9,c=0"], "c must lie in (0, 1)"),
    (["--disperse", "sensor_models.ins_heading_rms_deg=uniform(0.1, 0.3)", "--sensitivity", "sobol",
      "--samples", "12"], "must be a power of 2"),
])
def test_bad_review_input_exits_2_naming_it_before_any_run(args, message, tmp_path, capsys):
    out = tmp_path / "campaign"
    code = campaign_main(["sighting_land_vehicle", "--variant", "ekf_off", "--engine", "core", "--duration", "2",
                          *args, "--out", str(out), "--no-progress", "--serial"])
    assert code == 2
    assert message in capsys.readouterr().err
    assert not out.exists()

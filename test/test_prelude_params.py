"""A prelude's own parameters (``prelude.node.param``): the same sensors in both runs of a
chain, and the platform gyros' in-run drift (``platform_gyro_bi_deg_h``, a first-order
Gauss-Markov bias) carried by them.

* ``--set prelude.sensor_models.X=V`` (gimbal-run, gimbal-campaign) reaches the prelude's
  run and only it; a scenario without a prelude, or a parameter its prelude does not have,
  is refused naming it.
* A short chain on the engine with the in-run drift set in both runs: each run's recorded
  true gyro bias wanders, and its one-second increments have the variance of the exact
  Gauss-Markov step, 2σ²(1 − e^{−Δt/τ}) (a χ² bound); the hand-off still finds the
  navigation run's sensors to be the alignment's.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
import yaml
from scipy.stats import chi2

from gimbal_sim.campaign.spec import CampaignError, CampaignSpec, plan
from gimbal_sim.experiments.engine_runs import prelude_scenario, run_on_engine
from gimbal_sim.graph.scenario import ScenarioError, apply_set, builtin_scenarios, load, validate, variant
from gimbal_sim.reports.platform_servo import stream_columns

BI = "sensor_models.platform_gyro_bi_deg_h"
DEG_H = math.pi / 180.0 / 3600.0


def test_a_prelude_parameter_reaches_the_prelude_run_only():
    single = apply_set(variant(load("rotational_ins_navigation"), "original_system"), f"prelude.{BI}=0.03")
    assert single.prelude["params"] == {BI: 0.03}
    assert "platform_gyro_bi_deg_h" not in single.nodes["sensor_models"]["params"]
    first = prelude_scenario(single)
    assert first.name == "rotational_ins_alignment:gyrocompass"
    assert first.nodes["sensor_models"]["params"]["platform_gyro_bi_deg_h"] == 0.03
    assert validate(yaml.safe_load(single.to_yaml())).prelude == single.prelude  # what a --jobs child reads
    with pytest.raises(ScenarioError, match="nope"):
        apply_set(single, "prelude.sensor_models.nope=1")
    with pytest.raises(ScenarioError, match="has none"):
        apply_set(load("rotational_ins_navigation"), f"prelude.{BI}=0.03")


def test_a_campaign_sets_each_variants_own_prelude_and_refuses_one_without():
    path = str(builtin_scenarios()["rotational_ins_navigation"])
    spec = CampaignSpec(scenario=path, seeds=(1, 2), variants=("original_system", "upgraded"), engine="core",
                        overrides=((BI, 0.03), (f"prelude.{BI}", 0.03)))
    runs = plan(spec).runs
    assert len(runs) == 4
    for run in runs:
        assert run.scenario.nodes["sensor_models"]["params"]["platform_gyro_bi_deg_h"] == 0.03
        assert run.scenario.prelude["params"] == {BI: 0.03}
        assert run.scenario.prelude["variant"] == {"original_system": "gyrocompass",
                                                   "upgraded": "rotation_on"}[run.variant]
    with pytest.raises(CampaignError, match="has none"):
        plan(CampaignSpec(scenario=path, seeds=(1,), variants=("rotation_on",),
                          engine="core", overrides=((f"prelude.{BI}", 0.03),)))


#: fast, so that a short run shows the process, and small, so that its first step (20 ms) moves
#: the bias by far less than the hand-off's 1e-3 °/h (σ√(2Δt/τ) = 1.8e-4)
SIGMA_DEG_H, TAU_S = 0.004, 20.0


def _bias_increments(run_dir) -> np.ndarray:
    cols, _ = stream_columns(run_dir, {"/truth/platform/gyro_bias": lambda m: (m.vector.x, m.vector.y, m.vector.z)})
    t, bias = cols["/truth/platform/gyro_bias"]
    assert np.allclose(np.diff(t), 1.0)  # recorded at 1 Hz
    return np.diff(np.asarray(bias), axis=0) / DEG_H


def test_the_in_run_drift_wanders_as_the_gauss_markov_step_says_in_both_runs_of_a_chain(tmp_path):
    data = yaml.safe_load(builtin_scenarios()["rotational_ins_navigation"].read_text())
    step = data["variants"]["original_system"]
    step["prelude"]["duration_s"] = 30.0
    data["variants"] = {"original_system": step}
    data["duration_s"] = 60.0
    path = tmp_path / "short.yaml"
    path.write_text(yaml.safe_dump(data))
    single = variant(load(str(path)), "original_system")
    for target in (BI, f"prelude.{BI}"):
        single = apply_set(single, f"{target}={SIGMA_DEG_H}")
        single = apply_set(single, f"{target.replace('bi_deg_h', 'bi_tau_s')}={TAU_S}")
    metrics = run_on_engine(single, tmp_path / "run")
    assert metrics["hand_off"]["sensor_biases_carried"] is True
    var = 2.0 * SIGMA_DEG_H ** 2 * -math.expm1(-1.0 / TAU_S)  # b(t+1) − b(t), stationary, exact
    for run_dir in (tmp_path / "run" / "prelude", tmp_path / "run"):
        d = _bias_increments(run_dir).ravel()
        n = d.size
        assert n >= 80
        stat = float(np.sum(d ** 2)) / var  # χ²(n) for zero-mean increments of that variance
        assert chi2.ppf(0.0005, n) < stat < chi2.ppf(0.9995, n), (stat, n)

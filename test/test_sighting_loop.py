"""Paper 1's headline experiment (scenarios sighting_land_vehicle and sighting_los_hold on the
engine, the figures read back from their bags by the sighting report) and the LOS-hold outer
loop: LOS drift against the integral of the true gyro bias, the EKF's effect."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from gimbal_control.los_hold import LosHold, LosHoldParams
from gimbal_sim.core.engine_run import run_engine
from gimbal_sim.experiments.bias_ekf import GENERAL_GIMBAL_GYRO, ekf_params_from_sensors
from gimbal_sim.graph.scenario import apply_set, load, variant
from gimbal_sim.reports.sighting import analyse
from gimbal_sim.world.sensor_suite import SensorSuiteConfig

DEG = math.pi / 180.0


def _quat(C) -> np.ndarray:
    return Rotation.from_matrix(C).as_quat()


def test_los_hold_commands_towards_the_target_with_the_right_signs():
    hold = LosHold(LosHoldParams(gain_1_s=2.0, max_rate_deg_s=10.0, capture_s=0.0, earth_rate=False))
    C0 = Rotation.from_euler("ZYX", [30.0, 10.0, 5.0], degrees=True).as_matrix()
    np.testing.assert_allclose(hold.update(0.0, _quat(C0)), (0.0, 0.0), atol=1e-15)  # captured: no error
    # The LOS has turned right (about m-z) by 0.01 rad and up (about m-y) by 0.02 rad:
    # to return, the loop must command negative r and negative q.
    C1 = C0 @ Rotation.from_euler("ZY", [0.01, 0.02]).as_matrix()
    q_md, r_md = hold.update(1.0, _quat(C1))
    target_in_m1 = C1.T @ C0[:, 0]
    expected = (2.0 * math.atan2(-target_in_m1[2], target_in_m1[0]), 2.0 * math.atan2(target_in_m1[1], target_in_m1[0]))
    np.testing.assert_allclose((q_md, r_md), expected, rtol=1e-12)
    assert q_md < -0.039 and r_md < -0.019


def test_los_hold_target_is_inertial_and_capture_undoes_the_drift_let_through():
    lat = 45.0
    hold = LosHold(LosHoldParams(gain_1_s=1.0, capture_s=2.0, lat_deg=lat))
    w_ie = np.array([math.cos(lat * DEG), 0.0, -math.sin(lat * DEG)]) * 7.292115e-5
    C0 = Rotation.from_euler("ZYX", [10.0, 5.0, 0.0], degrees=True).as_matrix()
    b = (2e-4, -3e-4)  # bias estimate the rate loop used: LOS drift −b t about m-y, m-z
    hold.update(0.0, _quat(C0), b)
    assert hold.target_i is None
    # at capture the LOS has drifted by −b·2 s; the estimate says so: target = LOS at t0
    hold2 = LosHold(LosHoldParams(gain_1_s=1.0, capture_s=2.0, lat_deg=lat))
    hold2.update(0.0, _quat(C0), (0.0, 0.0))
    # the loop used b̂ = 0 for 2 s and now believes b̂ = b: drift D = −b·2 s
    drifted = C0 @ Rotation.from_euler("ZY", [-b[1] * 2.0, -b[0] * 2.0]).as_matrix()
    hold2.update(2.0, _quat(drifted), b)
    np.testing.assert_allclose(hold2.target_i, C0[:, 0], atol=1e-7)
    # an inertially fixed LOS seen from NED turns by exp(−[ω×]t): no error, no command
    t = 3600.0
    C_t = Rotation.from_rotvec(-w_ie * (t - 2.0)).as_matrix() @ C0
    assert np.max(np.abs(hold2.update(t, _quat(C_t), b))) < 1e-9


#: The general gyro (30 °/h bias, 10 °/h Gauss-Markov with τ = 300 s) in the sensors, and the EKF's
#: bias model from its datasheet values (``ekf_params_from_sensors``), as scenario values.
_GENERAL = ekf_params_from_sensors(SensorSuiteConfig(gimbal_gyro=GENERAL_GIMBAL_GYRO), ins_error_states=False)
GENERAL = (f"sensor_models.gimbal_gyro_bias_deg_h={list(GENERAL_GIMBAL_GYRO.bias_deg_h)}",
           f"sensor_models.gimbal_gyro_bi_deg_h={GENERAL_GIMBAL_GYRO.bias_instability_deg_h}",
           f"sensor_models.gimbal_gyro_bi_tau_s={GENERAL_GIMBAL_GYRO.bias_instability_tau_s}",
           f"gyro_bias_ekf.gyro_bias_sigma_deg_h={_GENERAL.gyro_bias_sigma_deg_h}",
           f"gyro_bias_ekf.gyro_bias_instability_deg_h={_GENERAL.gyro_bias_instability_deg_h}",
           f"gyro_bias_ekf.gyro_bias_tau_s={_GENERAL.gyro_bias_tau_s}")


def _engine_run(tmp_path, name: str, case: str | None, seed: int, duration_s: float, sets=()) -> dict:
    """The scenario's run on the engine, its bag read back by the sighting report."""
    from dataclasses import replace

    scenario = load(name) if case is None else variant(load(name), case)
    scenario = replace(scenario, seed=seed, duration_s=duration_s)
    for assignment in sets:
        scenario = apply_set(scenario, assignment)
    run_engine(scenario, tmp_path / f"{name}_{case}", compress=False)
    return analyse(tmp_path / f"{name}_{case}")


@pytest.mark.slow
def test_without_feedback_the_los_drifts_by_the_integral_of_the_true_bias(tmp_path):
    r = _engine_run(tmp_path, "sighting_land_vehicle", "ekf_off", 2, 20.0)
    # paper 1: the rate loop nulls the measured rate, so the LOS turns by −∫b dt (within 5 %)
    np.testing.assert_allclose(r["drift"][-1], r["bias_integral"][-1], rtol=0.05)
    assert np.all(np.abs(np.degrees(r["bias_integral"][-1])) > 0.3)


@pytest.mark.slow
@pytest.mark.parametrize("general", [False, True], ids=["paper1_gyro", "general_gyro"])
def test_ekf_feedback_and_los_hold_remove_the_drift(general, tmp_path):
    sets = GENERAL if general else ()
    runs = {mode: _engine_run(tmp_path, name, case, 3, 30.0, sets)
            for mode, name, case in (("off", "sighting_land_vehicle", "ekf_off"),
                                     ("feedback", "sighting_land_vehicle", "ekf_on"),
                                     ("los_hold", "sighting_los_hold", None))}
    off = np.abs(runs["off"]["drift"][-1])
    on = np.abs(runs["feedback"]["drift"][-1])
    # the convergence transient dominates 30 s; still ≥ 5× less than without the EKF
    assert np.all(on < off / 5.0), (on, off)
    hold = runs["los_hold"]["drift"][-1]
    assert math.hypot(*hold) < 0.05 * DEG * (1.0 if not general else 0.5)
    fb = runs["feedback"]
    late = fb["t_ekf"] >= 10.0
    err = np.abs(fb["bias_est"][late, 1:] - fb["bias_true"][late, 1:])
    assert np.mean(err <= 3.0 * fb["bias_sigma"][late, 1:]) >= 0.95

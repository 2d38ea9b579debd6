"""The simulated operator on the truth and its report: the inertial
target seen from NED, the report's figures from the recorded series against the model's
own bookkeeping, and the scenario on the no-ROS engine.

References: scipy's Rotation (the earth turning NED under an inertially fixed LOS), the
closed-form angle of a LOS fixed in NED (sin(ε/2) = |k × u| sin(Ωt/2)), OperatorModel.statistics (kept by
the model while it runs, not from the series the report reads).
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from gimbal_kinematics.maths.earth import OMEGA_IE
from gimbal_kinematics.params.table import ParameterError
from gimbal_sim.core.core_loop import run_core_loop
from gimbal_sim.graph.scenario import load, variant
from gimbal_sim.nodes.operator_params import PARAMS
from gimbal_sim.reports.core_metrics import SightingOperatorCollector
from gimbal_sim.reports.operator import operator_figures
from gimbal_sim.world.operator_model import OperatorModel, OperatorModelParams, SightOperator

LAT = math.radians(40.0)
W_N = OMEGA_IE * np.array([math.cos(LAT), 0.0, -math.sin(LAT)])


def _quat_nm(t: float, C0: Rotation, inertial: bool) -> tuple[float, ...]:
    """A sight whose LOS is fixed inertially (NED turns under it) or fixed in NED."""
    R = Rotation.from_rotvec(-W_N * t) * C0 if inertial else C0
    return tuple(R.as_quat())  # scipy: (x, y, z, w)


@pytest.mark.parametrize("inertial", [True, False])
def test_target_is_inertially_fixed_seen_from_a_turning_ned(inertial):
    C0 = Rotation.from_euler("ZYX", [0.7, 0.2, 0.0])  # yaw, pitch, roll of C(n,m)
    op = SightOperator(OperatorModelParams(tolerance_mrad=100.0, settle_band_mrad=50.0), capture_s=1.0,
                       lat_deg=40.0)
    u = C0.as_matrix()[:, 0]
    k = W_N / OMEGA_IE
    for step in range(0, 101):
        t = float(step)
        op.step(step * 10**9, _quat_nm(t, C0, inertial))
        if t < 1.0:
            assert op.target_i is None
            continue
        # u turned by θ about k: sin(ε/2) = |k × u| sin(θ/2)
        want = 0.0 if inertial else 2.0 * math.asin(np.linalg.norm(np.cross(k, u)) * math.sin(OMEGA_IE * (t - 1.0) / 2))
        assert op.model.error == pytest.approx(want, abs=1e-12 + 1e-9 * want)
    assert op.model.corrections == 0


def _drift_run(drift_qr, seconds=120.0, dt=0.01):
    """The model correcting a LOS error that drifts at ``drift_qr`` [rad/s] and moves with
    its command (a stabilised sight commanded in rate: ė = drift − ω); the series the
    node would publish, and the model."""
    model = OperatorModel()
    e = np.zeros(2)
    t_s, err, cmd = [], [], []
    for k in range(int(seconds / dt) + 1):
        eps = float(np.hypot(*e))
        # a sight looking along +x with the target off by e (about m-y, m-z)
        C = Rotation.from_rotvec([0.0, e[0], e[1]]).as_matrix().T
        q, r = model.step(int(round(k * dt * 1e9)), C, (1.0, 0.0, 0.0))
        t_s.append(k * dt)
        err.append((model.error, *model.error_qr))
        cmd.append((0.0, q, r))
        assert model.error == pytest.approx(eps, rel=1e-9, abs=1e-12)
        e = e + (np.asarray(drift_qr) - (q, r)) * dt
    return np.array(t_s), np.array(err), np.array(cmd), model


def test_report_figures_agree_with_the_models_bookkeeping():
    t, err, cmd, model = _drift_run((2e-4, -4e-4))
    fig = operator_figures(t, err, cmd, 1e-3)
    stats = model.statistics()
    assert fig["corrections"] == stats["corrections"] > 10
    assert fig["corrections_per_min"] == pytest.approx(stats["corrections_per_min"], rel=1e-9)
    assert fig["time_on_target_fraction"] == pytest.approx(stats["time_on_target_fraction"], rel=1e-9)
    assert fig["mean_time_between_corrections_s"] == pytest.approx(stats["mean_time_between_corrections_s"],
                                                                   rel=1e-9)
    # the module docstring's period for a constant drift d from the band, with ḋ exact
    d = math.hypot(2e-4, 4e-4)
    p = model.params
    period = ((p.tolerance_mrad - p.settle_band_mrad) * 1e-3 / d + p.reaction_time_s
              + math.log((p.tolerance_mrad * 1e-3 + d * p.reaction_time_s) / (p.settle_band_mrad * 1e-3)) / p.gain_1_s)
    assert fig["mean_time_between_corrections_s"] == pytest.approx(period, rel=0.03)


def _synthetic(moving_at: set[int]) -> dict:
    """operator_figures on samples at t = 0, 1, ..., 20 s, the target captured at 1 s (ε NaN
    at 0 s, 0.5 mrad after), the stick moved (q = r = 1 mrad/s) at the seconds in ``moving_at``."""
    t = np.arange(21.0)
    err = np.array([[math.nan if k == 0 else 5e-4, 0.0, 0.0] for k in range(21)])
    cmd = np.array([[0.0, 1e-3, 1e-3] if k in moving_at else [0.0, 0.0, 0.0] for k in range(21)])
    return operator_figures(t, err, cmd, 1e-3)


def test_observed_time_per_correction_against_a_hand_count_and_pooled_over_runs():
    """Three runs of 19 s observed (1 s to 20 s): corrections starting at 2, 9 and 15 s; none;
    one at 5 s. The censored mean between corrections sees only the first run (gaps 7 and
    6 s: 6.5 s); the pooled figure, Σ observed / Σ corrections = 57 / 4 = 14.25 s, counts
    the calm ones, and equals 60 / (mean corrections per minute) as every run is 19 s."""
    busy, calm, one = _synthetic({2, 3, 9, 15, 16, 17}), _synthetic(set()), _synthetic({5, 6})
    assert (busy["corrections"], calm["corrections"], one["corrections"]) == (3, 0, 1)
    assert busy["observed_s"] == calm["observed_s"] == one["observed_s"] == 19.0
    assert busy["mean_time_between_corrections_s"] == pytest.approx(6.5, rel=1e-15)
    assert math.isnan(calm["mean_time_between_corrections_s"]) and math.isnan(one["mean_time_between_corrections_s"])
    assert busy["observed_time_per_correction_s"] == pytest.approx(19.0 / 3.0, rel=1e-15)
    assert one["observed_time_per_correction_s"] == 19.0
    assert calm["observed_time_per_correction_s"] == math.inf  # none in 19 s: longer than the run
    runs = (busy, calm, one)
    pooled = sum(r["observed_s"] for r in runs) / sum(r["corrections"] for r in runs)
    assert pooled == 14.25
    assert 60.0 / np.mean([r["corrections_per_min"] for r in runs]) == pytest.approx(14.25, rel=1e-12)


def test_figures_without_enough_samples_are_nan_not_an_error():
    fig = operator_figures(np.array([0.0]), np.array([[math.nan] * 3]), np.zeros((1, 3)), 1e-3)
    assert fig["corrections"] == 0 and math.isnan(fig["corrections_per_min"])
    assert math.isnan(fig["observed_time_per_correction_s"])


def test_bad_operator_params_refused_naming_them():
    values = {p.name: p.default for p in PARAMS}
    with pytest.raises(ParameterError, match="settle_band_mrad"):
        OperatorModelParams.from_values({**values, "settle_band_mrad": 2.0})
    with pytest.raises(ParameterError, match="reaction_time_s"):
        OperatorModelParams.from_values({**values, "reaction_time_s": -0.1})
    with pytest.raises(ValueError, match="capture_s"):
        SightOperator(capture_s=math.nan)


def test_scenario_on_the_core_engine_corrects_the_drift_without_the_ekf():
    scenario = dataclasses.replace(variant(load("sighting_operator"), "ekf_off"), duration_s=6.0)
    collector = SightingOperatorCollector(scenario)
    run_core_loop(scenario, observer=collector)
    t = np.array(collector.to_ns) * 1e-9
    np.testing.assert_allclose(np.diff(t), 0.01, atol=1e-12)  # the operator's 100 Hz steps
    fig = operator_figures(t, np.array(collector.err), np.array(collector.cmd), 1e-3)
    assert fig["corrections"] >= 1
    assert fig["pointing_error_peak_mrad"] < 2.0  # corrected before it runs away


@pytest.mark.slow
def test_graph_computes_what_the_core_engine_computes(ros_domain_env, tmp_path):
    """The operator node and the controller's waited-for operator input in the real graph:
    the torque commands equal the core engine's bit for bit (read with mcap_ros2, not our
    reader), and the operator did correct. 3 s: this seeded run's first correction starts at
    2.37 s, so the operator's commands are tested both at rest and correcting."""
    import subprocess

    from mcap_ros2.reader import read_ros2_messages

    from conftest import VENV_BIN

    out = tmp_path / "run"
    result = subprocess.run([str(VENV_BIN / "gimbal-run"), "sighting_operator", "--variant", "ekf_off",
                             "--duration", "3", "--mode", "container", "--out", str(out), "--no-progress"],
                            env=ros_domain_env, capture_output=True, text=True, timeout=900)
    assert result.returncode == 0, result.stderr[-3000:]
    (path,) = (out / "ekf_off").glob("*.mcap")
    torque = np.array([tuple(m.ros_msg.effort) for m in read_ros2_messages(str(path), topics=["/gimbal/torque_cmd"])])
    ops = np.array([(m.ros_msg.vector.y, m.ros_msg.vector.z)
                    for m in read_ros2_messages(str(path), topics=["/operator/los_rate"])])
    scenario = dataclasses.replace(variant(load("sighting_operator"), "ekf_off"), duration_s=3.0)
    core = np.array(run_core_loop(scenario, keep_commands=True).commands)
    assert torque.shape == core.shape == (3001, 2)
    np.testing.assert_array_equal(torque, core)
    assert len(ops) == 301 and np.any(ops != 0.0) and np.all(ops[0] == 0.0)

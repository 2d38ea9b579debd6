"""The ``rotational_ins_navigation`` scenario through the node graph (paper 3 §4.3): the
navigator in the servo's loop, its bag read back by the navigation report.

The short graph run (20 s, rotation off, perfectly aligned) must show the navigator
integrating the true accelerometer bias: over 20 s the Schuler feedback (ω_s²t²/6 ≈ 1e-4
relative) and the gyro drift (gεt²/2 ≈ 3e-4 m/s) are small, so the velocity error is b·t to
within the accelerometer noise (50 µg/√Hz: σ_v = q·g·√t ≈ 2.2e-3 m/s at 20 s, taken at 3σ)
and the servo's level tracking error (pickoffs ~0.1″: g·5e-7·t ≈ 1e-4 m/s). The report's
Schuler-period reader is checked on a synthetic oscillation, and the local period against
2π√(R/g) from WGS-84 closed forms written here.
"""
from __future__ import annotations

import json
import math
import subprocess

import numpy as np
import pytest

from conftest import VENV_BIN
from gimbal_sim.experiments.navigation import PAPER3_NAV_ACCEL, PAPER3_NAV_GYRO
from gimbal_sim.experiments.platform_servo import ALIGNMENT_ACCEL_NOISE_UG_RT_HZ, ALIGNMENT_GYRO_ARW_DEG_RT_H
from gimbal_sim.graph.scenario import load
from gimbal_sim.reports.navigation import fitted_period_s, navigation_errors, schuler_period_s

DURATION_S = 20.0
G0 = 9.80665  # m/s² per g (the CGPM's standard gravity): µg to SI


def test_schuler_period_reader_finds_a_known_oscillation_under_a_trend_and_noise():
    rng = np.random.default_rng(3)
    t = np.arange(0.0, 3 * 3600.0, 1.0)
    period = 84.4 * 60.0
    v = np.column_stack([0.3 * np.sin(2 * math.pi * t / period + 0.4) + 1e-5 * t,
                         0.1 * np.cos(2 * math.pi * t / period)]) + rng.normal(0.0, 0.01, (len(t), 2))
    assert fitted_period_s(t, v) == pytest.approx(period, abs=12.0)
    assert fitted_period_s(t[:1000], v[:1000]) is None  # shorter than the scan's shortest period


@pytest.mark.parametrize("lat_deg", [0.0, 40.0, 75.0])
def test_local_schuler_period_is_2pi_sqrt_r_over_g_on_wgs84(lat_deg):
    """Reference in other closed forms than the code's: the Gaussian radius a²b/(a²c² + b²s²)
    and Somigliana's gravity from the published equatorial and polar values,
    (aγ_e c² + bγ_p s²)/√(a²c² + b²s²) (NIMA TR8350.2 §4)."""
    a, b = 6378137.0, 6356752.3142
    gamma_e, gamma_p = 9.7803253359, 9.8321849378
    lat = math.radians(lat_deg)
    c2, s2 = math.cos(lat) ** 2, math.sin(lat) ** 2
    radius = a * a * b / (a * a * c2 + b * b * s2)
    gravity = (a * gamma_e * c2 + b * gamma_p * s2) / math.sqrt(a * a * c2 + b * b * s2)
    assert schuler_period_s(lat) == pytest.approx(2 * math.pi * math.sqrt(radius / gravity), rel=1e-8)
    if lat_deg == 40.0:
        assert schuler_period_s(lat) / 60.0 == pytest.approx(84.4, abs=0.2)  # the report's "84.4 min"


def test_scenario_latitudes_and_rates_agree():
    import yaml

    nodes = load("rotational_ins_navigation").nodes
    profile = yaml.safe_load(nodes["vehicle_dynamics"]["params"]["profile_params"])
    servo, nav = nodes["platform_servo"]["params"], nodes["platform_navigator"]["params"]
    assert profile["lat_deg"] == servo["lat_deg"] == nav["lat_deg"]
    assert servo["command_source"] == "navigator"
    assert servo["imu_rate_hz"] == nav["imu_rate_hz"] == nodes["sensor_models"]["params"]["platform_imu_rate_hz"]


def test_navigation_and_alignment_scenarios_share_the_noise_of_the_grade():
    """Both scenarios and the hand-built runs draw the same white noise (ALIGNMENT_*), so a
    chained run's alignment and navigation see one sensor."""
    for name in ("rotational_ins_navigation", "rotational_ins_alignment"):
        sensors = load(name).nodes["sensor_models"]["params"]
        assert sensors["platform_gyro_arw_deg_rt_h"] == ALIGNMENT_GYRO_ARW_DEG_RT_H == PAPER3_NAV_GYRO.arw_deg_rt_h
        assert sensors["platform_accel_noise_ug_rt_hz"] == ALIGNMENT_ACCEL_NOISE_UG_RT_HZ == \
            PAPER3_NAV_ACCEL.noise_ug_rt_hz


@pytest.mark.ros
def test_graph_run_integrates_the_true_accelerometer_bias(ros_domain_env, tmp_path):
    out = tmp_path / "run"
    result = subprocess.run([str(VENV_BIN / "gimbal-run"), "rotational_ins_navigation", "--variant", "rotation_off",
                             "--duration", str(DURATION_S), "--out", str(out), "--mode", "container", "--no-progress"],
                            env=ros_domain_env, capture_output=True, text=True, timeout=900)
    assert result.returncode == 0, result.stdout + result.stderr
    bag = out / "rotation_off"
    e = navigation_errors(bag)
    assert len(e["t"]) == DURATION_S + 1 and e["t"][-1] == pytest.approx(DURATION_S)  # one fix a second
    b_ne = e["accel_bias"][0][:2]  # platform x, y = north, east: heading 0, no rotation
    v_ne = e["vel"][-1, :2]
    q = load("rotational_ins_navigation").nodes["sensor_models"]["params"]["platform_accel_noise_ug_rt_hz"] * 1e-6 * G0
    sigma_v, sigma_p = q * math.sqrt(DURATION_S), q * DURATION_S**1.5 / math.sqrt(3.0)
    assert np.all(np.abs(v_ne - b_ne * DURATION_S) < 3 * sigma_v), (v_ne, b_ne * DURATION_S, sigma_v)
    assert np.max(np.abs(b_ne)) * DURATION_S > 2 * 3 * sigma_v  # the seed's bias is well above the tolerance
    metrics = json.loads((bag / "report" / "metrics.json").read_text())["navigation"]
    # position b·t²/2 (noise: the integrated velocity random walk, σ = q·t^1.5/√3)
    assert metrics["final_position_error_m"]["north"] == pytest.approx(b_ne[0] * DURATION_S**2 / 2, abs=3 * sigma_p)
    assert metrics["final_position_error_m"]["east"] == pytest.approx(b_ne[1] * DURATION_S**2 / 2, abs=3 * sigma_p)
    level = metrics["control_error_arcsec"]
    assert level["inner_roll"]["max"] < 5.0 and level["pitch"]["max"] < 5.0


def test_servo_rate_command_runs_the_scenarios_rate_gains_and_substeps(capsys):
    from gimbal_sim.experiments.navigation import main as navigation_main

    assert navigation_main(["servo-rate", "--duration", "5"]) == 0
    header, *rows = capsys.readouterr().out.splitlines()
    assert "1000 Hz, 12/12/4 Hz, 4 substeps" in header and "50 Hz, 1.2/1.2/0.8 Hz, 10 substeps" in header
    level = next(r for r in rows if r.startswith("level error")).split()[-2:]
    assert all(0.0 < float(v) < 20.0 for v in level)  # arc-seconds, under a 100 µg bias's 20″ of tilt


@pytest.mark.parametrize("name", ["rotation_on_1khz", "rotation_off_1khz", "original_system_1khz", "upgraded_1khz"])
def test_the_paper_rate_systems_run_every_node_at_1_khz_on_the_servos_own_design(name):
    """Paper 3's systems as the CEP campaign runs them (§4.1: the loop at 1 kHz): every rate
    1 kHz, the servo's loops and the plant's substeps those its nodes are designed with for
    1 kHz (their defaults, not the 50 Hz scenario's re-placed ones), and each aligned system's
    prelude the same alignment as at 50 Hz (same seed, same sensors)."""
    import dataclasses

    from gimbal_control.platform_servo_params import PlatformServoNodeParams
    from gimbal_sim.experiments.navigation import CAMPAIGN, SCENARIO_VARIANTS
    from gimbal_sim.graph.scenario import variant
    from gimbal_sim.nodes.vehicle_dynamics_params import VehicleDynamicsNodeParams

    def default(cls, field):
        return next(f.default for f in dataclasses.fields(cls) if f.name == field)

    scenario = variant(load("rotational_ins_navigation"), name)
    nodes = {node: spec["params"] for node, spec in scenario.nodes.items()}
    servo, nav, sensors = nodes["platform_servo"], nodes["platform_navigator"], nodes["sensor_models"]
    rates = {scenario.sim_rate_hz, servo["imu_rate_hz"], servo["resolver_rate_hz"], nav["imu_rate_hz"],
             nav["joint_rate_hz"], sensors["platform_imu_rate_hz"], sensors["resolver_rate_hz"]}
    assert rates == {1000.0}
    for loop in ("azimuth_bandwidth_hz", "level_bandwidth_hz", "outer_roll_bandwidth_hz"):
        assert servo[loop] == default(PlatformServoNodeParams, loop), loop
    assert nodes["vehicle_dynamics"]["platform_substeps"] == default(VehicleDynamicsNodeParams, "platform_substeps")
    assert servo["rotation"] == ("off" if name.startswith(("original", "rotation_off")) else "bidirectional")
    at_50_hz = {"original_system_1khz": "original_system", "upgraded_1khz": "upgraded"}.get(name)
    if at_50_hz:
        assert scenario.prelude == variant(load("rotational_ins_navigation"), at_50_hz).prelude
    if name != "rotation_off_1khz":  # the scale-factor study's, not the campaign's
        assert name in {SCENARIO_VARIANTS[label] for label in CAMPAIGN.default_variants}


def test_the_ship_variants_navigate_on_phi_z_with_the_servo_a_step_ahead_and_both_go_together():
    """ship_rotation_on/off: paper 5's ship (base motion on) under the 1 kHz system, the
    navigator on the servo's φz, which the servo then publishes a step ahead; one without the
    other would wait for ever in lockstep, so the scenario check refuses it before anything
    starts."""
    from gimbal_sim.graph.plan import check_nodes
    from gimbal_sim.graph.scenario import ScenarioError, apply_set, variant
    base = load("rotational_ins_navigation")
    for name, rotation in (("ship_rotation_on", "bidirectional"), ("ship_rotation_off", "off")):
        ship = variant(base, name)
        check_nodes(ship)
        p = {node: ship.nodes[node]["params"] for node in ship.nodes}
        assert ship.sim_rate_hz == 1000.0 and p["platform_servo"]["rotation"] == rotation
        assert p["vehicle_dynamics"]["profile"] == "paper5_ship" and p["vehicle_dynamics"]["platform_base_motion"]
        assert p["platform_navigator"]["azimuth_source"] == "servo" and p["platform_servo"]["modulation_next"]
        for assignment in ("platform_servo.modulation_next=false", "platform_navigator.azimuth_source=resolver"):
            with pytest.raises(ScenarioError, match="modulation_next"):
                check_nodes(apply_set(ship, assignment))

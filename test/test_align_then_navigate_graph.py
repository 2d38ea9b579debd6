"""``rotational_ins_navigation`` variant ``upgraded`` through the node graph: the
alignment run (the variant's prelude), its hand-off as a parameter file, the navigation run.

One short chained run (a 4 s alignment with the platform held, so that the navigation's
modulation starts where the azimuth gimbal is; 20 s of navigation with rotation on), then,
against things the hand-off code does not compute:

* the command the navigator publishes is the closed form of paper 3 eq. 2–4 with the handed
  estimates: WGS-84 earth rate Ω(cos L, 0, −sin L), the transport rate of its own published
  velocity (v_E/R, −v_N/R, −v_E tan L/R), minus the drift estimates (ε̂_N north, ε̂_s resolved
  through the azimuth ψ̂ = θ_a + the handed base heading) and, for the first torque_out_s, the
  pulse −φⁿ/T with φⁿ = (δφN, δφE, −δφU) of the handed misalignment;
* the plant starts at the alignment run's last truth (its bag), and after the pulse the
  platform's true tilt is the residual the report gives (truth − estimate), plus the east
  tilt the azimuth residual makes of the earth rate: the pulse went through the servo to the
  stable element;
* the residual equals minus the alignment report's own estimate error, and the navigation
  run's true sensor biases are the alignment run's.
"""
from __future__ import annotations

import json
import math
import subprocess

import numpy as np
import pytest
import yaml

from conftest import VENV_BIN
from gimbal_kinematics.maths.four_gimbal import dcm_bs, platform_misalignment_enu
from gimbal_kinematics.maths.rotations import euler321_to_dcm
from gimbal_sim.graph.scenario import ScenarioError, builtin_scenarios, load, validate, variant
from gimbal_sim.reports.platform_servo import stream_columns
from imu_grades import no_grade

ARCSEC = math.pi / (180.0 * 3600.0)
OMEGA_IE = 7.292115e-5  # WGS-84 [rad/s]
R_EARTH = 6371.0e3  # mean radius [m]: the transport rate here is ~1e-10 rad/s, 0.3 % of it is far below the tolerance
ALIGN_S, NAV_S, TORQUE_S = 4.0, 20.0, 10.0
VEC = lambda msg: (msg.vector.x, msg.vector.y, msg.vector.z)  # noqa: E731


def test_the_variant_carries_its_prelude_and_a_bad_prelude_is_refused():
    single = variant(load("rotational_ins_navigation"), "upgraded")
    assert single.prelude == {"scenario": "rotational_ins_alignment", "variant": "rotation_on",
                              "hand_off": "alignment_to_navigation", "duration_s": 600.0}
    assert validate(yaml.safe_load(single.to_yaml())).prelude == single.prelude  # what a --jobs child reads
    data = yaml.safe_load(builtin_scenarios()["rotational_ins_navigation"].read_text())
    data["variants"]["upgraded"]["prelude"] = {"scenario": "rotational_ins_alignment"}
    with pytest.raises(ScenarioError, match="hand_off"):
        validate(data)


def test_gimbal_run_refuses_an_unknown_hand_off_before_starting_anything(tmp_path):
    data = yaml.safe_load(builtin_scenarios()["rotational_ins_navigation"].read_text())
    data["variants"]["upgraded"]["prelude"]["hand_off"] = "nonesuch"
    spec = tmp_path / "s.yaml"
    spec.write_text(yaml.safe_dump(data))
    result = subprocess.run([str(VENV_BIN / "gimbal-run"), str(spec), "--variant", "upgraded",
                             "--out", str(tmp_path / "run")], capture_output=True, text=True, timeout=120)
    assert result.returncode == 2 and "nonesuch" in result.stderr and "Traceback" not in result.stderr
    assert not (tmp_path / "run").exists()


@pytest.fixture(scope="module")
def chained(module_ros_domain_env, tmp_path_factory):
    tmp = tmp_path_factory.mktemp("upgraded")
    data = yaml.safe_load(builtin_scenarios()["rotational_ins_navigation"].read_text())
    step = data["variants"]["upgraded"]
    step["prelude"].update(duration_s=ALIGN_S, variant="rotation_off")
    # the closed forms below have no rate-coupled sensor errors: the grade is off in both runs
    zeros = {item.partition("=")[0]: 0.0 for item in no_grade("platform_gyro", "platform_accel")}
    step["prelude"]["params"] = zeros
    data["nodes"]["sensor_models"]["params"].update({k.partition(".")[2]: v for k, v in zeros.items()})
    data["variants"] = {"upgraded": step}
    assert "/platform_navigator/command_rate" in data["record"]  # the scenario records it
    data["record"] += ["/truth/platform/joint_states"]
    spec = tmp / "short.yaml"
    spec.write_text(yaml.safe_dump(data))
    out = tmp / "run"
    result = subprocess.run([str(VENV_BIN / "gimbal-run"), str(spec), "--duration", str(NAV_S),
                             "--set", "platform_navigator.fix_every_samples=1", "--out", str(out),
                             "--mode", "container", "--no-progress"],
                            env=module_ros_domain_env, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stdout + result.stderr
    run = out / "upgraded"
    handed = yaml.safe_load((run / "prelude" / "hand_off.yaml").read_text())
    return {"run": run, "stdout": result.stdout, "handed": handed,
            "metrics": json.loads((run / "report" / "metrics.json").read_text()),
            "prelude_metrics": json.loads((run / "prelude" / "report" / "metrics.json").read_text())}


@pytest.mark.ros
def test_the_navigator_commands_the_handed_drifts_and_torque_out_pulse(chained):
    p = chained["handed"]["platform_navigator"]["ros__parameters"]
    cols, _ = stream_columns(chained["run"], {"/platform_navigator/command_rate": VEC,
                                              "/platform_navigator/velocity": VEC,
                                              "/truth/platform/joint_states": lambda msg: tuple(msg.position)})
    tc, command = cols["/platform_navigator/command_rate"]
    tv, vel = cols["/platform_navigator/velocity"]
    tj, joints = cols["/truth/platform/joint_states"]
    assert len(tc) == NAV_S * 50 + 1
    lat = math.radians(p["lat_deg"])
    earth = OMEGA_IE * np.array([math.cos(lat), 0.0, -math.sin(lat)])
    v = np.column_stack([np.interp(tc, tv, vel[:, i]) for i in range(3)])
    transport = np.column_stack([v[:, 1], -v[:, 0], -v[:, 1] * math.tan(lat)]) / R_EARTH
    psi = np.interp(tc, tj, joints[:, 0]) + math.radians(p["base_heading_deg"])
    ex, ey, _ = (d * ARCSEC for d in p["gyro_drift_deg_h"])  # 1 °/h = 1″/s
    drift = np.column_stack([p["north_drift_deg_h"] * ARCSEC + np.cos(psi) * ex - np.sin(psi) * ey,
                             np.sin(psi) * ex + np.cos(psi) * ey, 0.0 * psi])
    e, n, u = (a * ARCSEC for a in p["misalignment_arcsec"])
    pulse = -np.array([n, e, -u]) / TORQUE_S
    during = (tc - tc[0]) < TORQUE_S - 1e-9
    expected = earth + transport - drift + np.where(during[:, None], pulse, 0.0)
    size = np.max(np.linalg.norm(drift[:, :2], axis=1))
    assert size > 1e-9 and np.linalg.norm(pulse) > 1e-5  # this seed's estimates are well above the tolerances
    assert np.max(np.abs(command - expected)) < 0.02 * size, np.max(np.abs(command - expected), axis=0)
    # without the handed drifts the command would miss by their size
    assert np.max(np.abs(command - expected - drift)) > 0.5 * size


@pytest.mark.ros
def test_the_platform_starts_where_the_alignment_left_it_and_the_pulse_levels_it_to_the_residual(chained):
    hand_off = chained["metrics"]["hand_off"]
    vd = chained["handed"]["vehicle_dynamics"]["ros__parameters"]
    cols, _ = stream_columns(chained["run"] / "prelude", {"/truth/platform/joint_states": lambda m: tuple(m.position)})
    tj, joints = cols["/truth/platform/joint_states"]
    last = joints[int(np.argmin(np.abs(tj - hand_off["hand_off_s"])))]
    assert np.allclose(np.radians(vd["initial_platform_deg"]), last, rtol=0.0, atol=1e-12)
    cols, _ = stream_columns(chained["run"], {"/truth/platform/joint_states": lambda m: tuple(m.position)})
    tn, nav_joints = cols["/truth/platform/joint_states"]
    yaw = yaml.safe_load(vd["profile_params"])["yaw_deg"]
    C_nb = euler321_to_dcm(0.0, 0.0, math.radians(yaw))
    tilt = lambda q: np.array(platform_misalignment_enu(C_nb @ dcm_bs(q), q[0])[:2]) / ARCSEC  # noqa: E731
    assert np.allclose(tilt(nav_joints[0]), hand_off["misalignment_truth_arcsec"][:2], atol=0.05)
    # The last second, 10 s after the pulse (its transient has decayed): the residual, the east
    # tilt growing at −Ω cos L δφU (the azimuth residual of a 4 s alignment, ~1000″, turns the
    # earth rate into the east axis: ~0.07″/s); 0.6″ for the residual level drift over 20 s.
    e, n, u = hand_off["residual_misalignment_arcsec"]
    lat = math.radians(yaml.safe_load(vd["profile_params"])["lat_deg"])
    mask = tn >= tn[-1] - 1.0
    expected = np.column_stack([e - OMEGA_IE * math.cos(lat) * u * (tn[mask] - tn[0]), np.full(mask.sum(), n)])
    miss = np.mean([tilt(q) for q in nav_joints[mask]], axis=0) - np.mean(expected, axis=0)
    assert np.all(np.abs(miss) < 0.6), (miss, hand_off["residual_misalignment_arcsec"])


@pytest.mark.ros
def test_the_report_carries_the_residuals_and_the_biases_are_the_alignments(chained):
    hand_off, nav = chained["metrics"]["hand_off"], chained["metrics"]["navigation"]
    alignment_error = chained["prelude_metrics"]["alignment"]["current_misalignment_error_arcsec"]  # estimate − truth
    assert np.allclose(hand_off["residual_misalignment_arcsec"], -np.array(alignment_error), atol=1e-9)
    assert hand_off["sensor_biases_carried"] is True
    assert np.allclose(nav["true_gyro_bias_deg_h"], hand_off["true_gyro_bias_deg_h"], atol=1e-12)
    assert math.isfinite(nav["final_position_error_m"]["radial"]) and nav["duration_s"] == pytest.approx(NAV_S)
    assert "hand-off" in chained["stdout"] and "residual misalignment" in chained["stdout"]


@pytest.mark.ros
def test_the_engine_runs_the_same_chain_to_the_same_hand_off_and_navigation(chained, tmp_path):
    """gimbal-run --engine core chains the prelude as the graph does: the same parameter file
    from the alignment, the same navigation figures."""
    spec = chained["run"].parent.parent / "short.yaml"
    out = tmp_path / "engine"
    result = subprocess.run([str(VENV_BIN / "gimbal-run"), str(spec), "--duration", str(NAV_S), "--engine", "core",
                             "--set", "platform_navigator.fix_every_samples=1", "--out", str(out), "--no-progress"],
                            capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stdout + result.stderr
    run = out / "upgraded"
    assert yaml.safe_load((run / "prelude" / "hand_off.yaml").read_text()) == chained["handed"]
    engine = json.loads((run / "report" / "metrics.json").read_text())
    assert engine["navigation"]["final_position_error_m"] == pytest.approx(
        chained["metrics"]["navigation"]["final_position_error_m"], rel=0.0, abs=1e-6)
    assert engine["hand_off"]["sensor_biases_carried"] is True

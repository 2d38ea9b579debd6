"""Paper 3's servo on its DTGs as nodes: ``rotational_platform_servo`` variant ``dtg``
(``sensor_models``' ``dtg`` sensor, ``platform_servo`` with ``gyro_source: dtg``).

One short run (a 6° sweep at 1.2 °/s and back, 8 s) on the engine and, marked ``ros``, the
same through the node graph, then:

* the graph's bag and the engine's hold the same data, byte for byte (the torquer currents
  cross between two nodes with a one-step hold; the engine hands them over on its bus);
* read with ``rosbags`` (a reader we did not write), at every servo tick the azimuth torquer
  current is the closed form (φ̇z + Ω_D)/S: the modulation rate the same tick publishes plus
  the vertical (down) component of the WGS-84 earth rate, −Ω sin L, over the nominal scale
  factor S = 72 (°/h)/mA; the level currents' magnitude is Ω cos L / S whatever the azimuth;
* the default (rate triad) path is the scenario as it was, and publishes no torquer or
  pickoff topic; the compiled chain takes a DTG servo only with the DTG pair among the sensors;
* in ``rotational_ins_navigation`` (variant ``dtg_1khz``) the navigator's command rate
  becomes the torquer currents: each recorded azimuth current is (φ̇z + ω_c,D)/S, ω_c,D the
  down component of the command the navigator published at the same stamp (the platform
  level), recorded at 1 Hz as the paper's voltmeter sampled it; the navigation report's legs
  are those currents;
* paper 3's two systems on the DTGs (``upgraded_dtg``, ``original_system_dtg``) align on them,
  hand off, and navigate with the command in the torquers;
* bad DTG parameters, and the DTGs without the servo on them (or the reverse), are refused
  before anything starts, naming the parameter (exit 2).
"""
from __future__ import annotations

import json
import math
import subprocess
from pathlib import Path

import pytest
import yaml
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore

from conftest import VENV_BIN
from gimbal_control.platform_servo_params import PARAMS as SERVO_PARAMS
from gimbal_sim.bag.compare import compare_bags
from gimbal_sim.core import compiled
from gimbal_sim.core.core_loop import node_values
from gimbal_sim.graph.scenario import apply_set, load, variant

SCENARIO = "rotational_platform_servo"
SHORT = ("--set", "platform_servo.sweep_deg=6", "--duration", "8", "--no-progress")
TORQUER = "/platform_servo/torquer_current"
PICKOFFS = "/platform/dtg_pickoffs"
MODULATION = "/platform_servo/modulation"
OMEGA_IE = 7.292115e-5  # WGS-84 earth rate [rad/s]
LAT = math.radians(45.0)  # the scenario's site
SCALE_A = 72.0 * math.pi / 180.0 / 3600.0 * 1000.0  # 72 (°/h)/mA as rad/s per A
RATE = math.radians(1.2)  # the modulation rate [rad/s]


def _run(env, out: Path, *args: str) -> Path:
    result = subprocess.run([str(VENV_BIN / "gimbal-run"), SCENARIO, "--out", str(out), *args, *SHORT],
                            env=env, capture_output=True, text=True, timeout=900)
    assert result.returncode == 0, result.stderr[-3000:]
    return out


@pytest.fixture(scope="module")
def engine_bag(module_ros_domain_env, tmp_path_factory) -> Path:
    out = _run(module_ros_domain_env, tmp_path_factory.mktemp("engine") / "run", "--variant", "dtg",
               "--engine", "core")
    return out / "dtg"


def _stamp(msg) -> int:
    return msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec


def _read(bag: Path, topics: set[str]) -> dict[str, dict[int, object]]:
    """topic -> {header stamp [ns]: message}, deserialised by rosbags."""
    store = get_typestore(Stores.ROS2_JAZZY)
    out: dict[str, dict[int, object]] = {t: {} for t in topics}
    with Reader(bag) as reader:
        for conn, _, raw in reader.messages(connections=[c for c in reader.connections if c.topic in topics]):
            msg = store.deserialize_cdr(raw, conn.msgtype)
            out[conn.topic][_stamp(msg)] = msg
    return out


@pytest.mark.ros
def test_the_graph_and_the_engine_record_the_same_bag(module_ros_domain_env, tmp_path, engine_bag):
    graph = _run(module_ros_domain_env, tmp_path / "graph", "--variant", "dtg", "--mode", "container") / "dtg"
    diff = compare_bags(graph, engine_bag)
    assert diff.identical and diff.byte_identical, "\n".join(diff.lines())
    assert {TORQUER, PICKOFFS} <= set(diff.topics)
    assert diff.topics[TORQUER].count_a == diff.topics[PICKOFFS].count_a == 8001  # every step of 8 s at 1 kHz


def test_the_azimuth_torquer_current_is_the_command_rate_over_the_scale_factor(engine_bag):
    series = _read(engine_bag, {TORQUER, MODULATION, PICKOFFS})
    currents, modulation = series[TORQUER], series[MODULATION]
    assert len(currents) == len(series[PICKOFFS]) == 8001 and len(modulation) > 7900
    legs = {1.0: [], -1.0: []}
    for stamp, mod in modulation.items():
        msg = currents[stamp]  # the same tick's currents
        i = dict(zip(msg.name, msg.effort))
        phi_rate = mod.velocity[0]
        assert abs(abs(phi_rate) - RATE) < 1e-12 * RATE  # a constant rate, reversed at once
        expected = (phi_rate - OMEGA_IE * math.sin(LAT)) / SCALE_A
        assert i["dtg_torquer_z"] == pytest.approx(expected, rel=1e-12, abs=0.0)
        assert math.hypot(i["dtg_torquer_x"], i["dtg_torquer_y"]) == pytest.approx(
            OMEGA_IE * math.cos(LAT) / SCALE_A, rel=1e-9, abs=0.0)
        legs[math.copysign(1.0, phi_rate)].append(i["dtg_torquer_z"])
    assert len(legs[1.0]) > 4000 and len(legs[-1.0]) > 2000  # out for 5 s and back for 3 s
    # the outward leg carries the vertical earth rate against it: 59.85 mA, the return 60.15 mA
    assert 1e3 * max(legs[1.0]) < 60.0 < -1e3 * max(legs[-1.0])


def test_the_default_path_is_the_scenario_as_it_was_and_has_no_torquer(module_ros_domain_env, tmp_path):
    base = load(SCENARIO)
    triad = variant(base, "rate_triad")
    assert triad.nodes == base.nodes and triad.record == base.record
    assert base.nodes["platform_servo"]["params"] == {"lat_deg": 45.0, "rotation": "bidirectional",
                                                      "rate_deg_s": 1.2, "sweep_deg": 360.0}
    assert base.nodes["sensor_models"]["params"]["sensors"] == ["platform_imu", "resolvers"]
    assert next(p.default for p in SERVO_PARAMS if p.name == "gyro_source") == "rate_triad"
    bag = _run(module_ros_domain_env, tmp_path / "triad", "--variant", "rate_triad", "--engine", "core") / "rate_triad"
    with Reader(bag) as reader:
        topics = {c.topic for c in reader.connections}
        counts = {c.topic: c.msgcount for c in reader.connections}
    assert TORQUER not in topics and PICKOFFS not in topics
    assert counts["/platform/voltage_cmd"] == counts[MODULATION] == 8001


def test_the_navigators_command_becomes_the_torquer_currents(module_ros_domain_env, tmp_path):
    out = tmp_path / "nav"
    result = subprocess.run([str(VENV_BIN / "gimbal-run"), "rotational_ins_navigation", "--variant", "dtg_1khz",
                             "--engine", "core", "--duration", "12", "--no-progress", "--out", str(out)],
                            env=module_ros_domain_env, capture_output=True, text=True, timeout=900)
    assert result.returncode == 0, result.stderr[-3000:]
    command = "/platform_navigator/command_rate"
    series = _read(out / "dtg_1khz", {TORQUER, command})
    currents = series[TORQUER]
    assert sorted(currents) == [k * 1_000_000_000 for k in range(13)]  # 1 Hz, every second of 12 s
    for stamp, msg in currents.items():
        i = dict(zip(msg.name, msg.effort))
        down = series[command][stamp].vector.z
        assert abs(down + OMEGA_IE * math.sin(math.radians(40.0))) < 1e-7  # earth rate at 40° N, and a little
        assert i["dtg_torquer_z"] == pytest.approx((RATE + down) / SCALE_A, rel=1e-12, abs=0.0)
    report = json.loads((out / "dtg_1khz" / "report" / "metrics.json").read_text())
    leg = report["navigation"]["dtg_torquer_current"]["azimuth"]["positive_rate"]
    steady = [1e3 * dict(zip(m.name, m.effort))["dtg_torquer_z"] for s, m in currents.items() if s >= 5e9]
    assert leg["samples"] == len(steady) == 8
    assert leg["mean_ma"] == pytest.approx(sum(steady) / len(steady), rel=1e-12)


def test_the_compiled_chain_takes_a_dtg_servo_only_with_the_dtg_pair():
    nav = variant(load("rotational_ins_navigation"), "rotation_off")
    assert compiled.compiled_runner(node_values(nav)) is compiled._platform_run
    on_dtg = variant(load("rotational_ins_navigation"), "dtg_1khz")
    assert compiled.compiled_runner(node_values(on_dtg)) is compiled._platform_run
    assert compiled.compiled_runner(node_values(apply_set(nav, "platform_servo.gyro_source=dtg"))) is None


@pytest.mark.parametrize("run, assignment, named", [
    ("dtg", "platform_servo.gyro_source=fibre", "gyro_source"),
    ("dtg", "platform_servo.dtg_max_current_ma=0", "dtg_max_current_ma"),
    ("dtg", "sensor_models.dtg_scale_error_ppm=[1.0, 2.0]", "dtg_scale_error_ppm"),
    ("dtg", "sensor_models.dtg_lat_deg=95", "dtg_lat_deg"),
    # the DTGs without the servo that torques them, and the servo on DTGs that are not there
    ("rate_triad", "sensor_models.sensors=[platform_imu, resolvers, dtg]", "gyro_source"),
    ("rate_triad", "platform_servo.gyro_source=dtg", "sensors"),
])
def test_bad_dtg_parameters_are_refused_before_anything_starts(module_ros_domain_env, tmp_path, run, assignment,
                                                               named):
    result = subprocess.run([str(VENV_BIN / "gimbal-run"), SCENARIO, "--variant", run, "--engine", "core",
                             "--duration", "1", "--set", assignment, "--out", str(tmp_path / "bad")],
                            env=module_ros_domain_env, capture_output=True, text=True, timeout=300)
    assert result.returncode == 2 and f"'{named}'" in result.stderr, result.stderr[-2000:]
    assert not (tmp_path / "bad" / run).exists()


def test_paper_3s_two_systems_align_and_navigate_on_the_dtgs(module_ros_domain_env, tmp_path):
    """``upgraded_dtg`` and ``original_system_dtg``, each chained short (a 10 s alignment on the
    DTGs, its hand-off, 20 s of navigation on the compiled chain): both phases' servos close on
    the pickoffs, and each recorded azimuth torquer current is (φ̇z + ω_c,D)/S, rotating at
    1.2 °/s (upgraded) or held still (original), ω_c,D the navigator's command at that stamp,
    which carries the alignment's drift estimates and, for its first 10 s, the pulse that
    torques the handed misalignment out; the report's legs leave that pulse out."""
    data = yaml.safe_load(load("rotational_ins_navigation").to_yaml())
    chains = {"upgraded_dtg": RATE, "original_system_dtg": 0.0}
    data["variants"] = {v: dict(data["variants"][v]) for v in chains}
    for v in chains:
        data["variants"][v]["prelude"] = dict(data["variants"][v]["prelude"], duration_s=10.0)
    spec = tmp_path / "chains.yaml"
    spec.write_text(yaml.safe_dump(data))
    out = tmp_path / "runs"
    result = subprocess.run([str(VENV_BIN / "gimbal-run"), str(spec), "--engine", "core", "--duration", "20",
                             "--no-progress", "--out", str(out)],
                            env=module_ros_domain_env, capture_output=True, text=True, timeout=900)
    assert result.returncode == 0, result.stderr[-3000:]
    command = "/platform_navigator/command_rate"
    for v, rate in chains.items():
        for phase in (out / v / "prelude", out / v):
            nodes = yaml.safe_load((phase / "scenario.yaml").read_text())["nodes"]
            assert nodes["platform_servo"]["params"]["gyro_source"] == "dtg", phase
            assert "dtg" in nodes["sensor_models"]["params"]["sensors"], phase
        assert json.loads((out / v / "prelude" / "hand_off.json").read_text())["hand_off_s"] == pytest.approx(10.0)
        series = _read(out / v, {TORQUER, command})
        assert sorted(series[TORQUER]) == [k * 1_000_000_000 for k in range(21)]
        i_z = {}
        for stamp, msg in series[TORQUER].items():
            i_z[stamp] = dict(zip(msg.name, msg.effort))["dtg_torquer_z"]
            down = series[command][stamp].vector.z
            assert i_z[stamp] == pytest.approx((rate + down) / SCALE_A, rel=1e-12, abs=1e-15), (v, stamp)
        if rate:
            # the pulse: the handed azimuth estimate over the 10 s, through the scale factor
            up = json.loads((out / v / "prelude" / "hand_off.json").read_text())["misalignment_estimate_arcsec"][2]
            assert abs(i_z[5_000_000_000] - i_z[15_000_000_000]) == pytest.approx(
                abs(math.radians(up / 3600.0)) / 10.0 / SCALE_A, rel=0.02)
            leg = json.loads((out / v / "report" / "metrics.json").read_text())[
                "navigation"]["dtg_torquer_current"]["azimuth"]["positive_rate"]
            steady = [1e3 * i for s, i in i_z.items() if s >= 15e9]
            assert leg["samples"] == len(steady) == 6
            assert leg["mean_ma"] == pytest.approx(sum(steady) / len(steady), rel=1e-12)

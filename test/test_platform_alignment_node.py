"""Paper 3's rotation-modulated alignment as the ``platform_alignment`` node: startup
refusals, its outputs against an independent rotation-matrix truth (message conventions:
NED components, σ companions, not-estimated markers), bad input rejected and counted,
pacing, and a short ``rotational_ins_alignment`` graph run read back with ``rosbags`` that
must equal the same closed loop run in one process."""
from __future__ import annotations

import math
import subprocess
from collections import defaultdict
from contextlib import contextmanager

import numpy as np
import pytest
import rclpy
from geometry_msgs.msg import Vector3Stamped
from rclpy.context import Context
from rclpy.serialization import deserialize_message

from conftest import VENV_BIN
from gimbal_estimators.platform_alignment_node import OUTPUTS, PlatformAlignmentNode
from gimbal_estimators.rotation_alignment import RotationAlignmentParams
from gimbal_kinematics.timing.sync import StepGroups
from gimbal_kinematics.maths.four_gimbal import BidirectionalRotation
from gimbal_kinematics.ros import messages as m
from kinematic_alignment import KinematicPlatformTruth
from gimbal_sim.core.engine_run import run_engine
from gimbal_sim.experiments.platform_servo import (
    ALIGNMENT_ACCEL_NOISE_UG_RT_HZ, ALIGNMENT_GYRO_ARW_DEG_RT_H, alignment_setup,
)
from gimbal_sim.graph.scenario import load, variant
from ros_harness import ros_args, start_refused

pytestmark = pytest.mark.ros
ARCSEC = math.radians(1.0 / 3600.0)
ARCMIN = math.radians(1.0 / 60.0)
DEG_H = ARCSEC
LAT_DEG = 40.0
SIM_HZ = 1000.0
IMU_HZ = 10.0  # the in-process tests feed 10 Hz samples: 600 s of alignment in ~1 s


@pytest.mark.parametrize("args,named", [
    ({"imu_rate_hz": 300.0}, "imu_rate_hz"),
    ({"joint_rate_hz": 0.0}, "joint_rate_hz"),
    ({"lat_deg": 90.0}, "lat_deg"),
    ({"block_s": 0.0}, "block_s"),
    ({"azimuth_scale_deg": -1.0}, "azimuth_scale_deg"),
])
def test_bad_parameters_are_refused_naming_them(args, named, ros_domain_env):
    result = start_refused("platform_alignment", args, ros_domain_env)
    assert result.returncode == 2 and named in result.stderr, result.stderr


def test_step_groups_release_complete_steps_in_order_whatever_the_arrival():
    """Inputs due at different steps (a every step, b every 2nd): a step is released once its
    due inputs are in, in step order; stale input is rejected; a far jump back restarts."""
    needs = lambda k: ("a", "b") if k % 2 == 0 else ("a",)  # noqa: E731
    sync = StepGroups(needs, backjump_steps=5)
    assert sync.add("a", 0, "a0") == []
    assert sync.add("a", 1, "a1") == []          # step 1 is complete but waits behind step 0
    assert sync.add("b", 0, "b0") == [(0, {"a": "a0", "b": "b0"}), (1, {"a": "a1"})]
    assert sync.add("b", 2, "b2") == [] and sync.add("a", 2, "a2") == [(2, {"b": "b2", "a": "a2"})]
    assert sync.add("a", 1, "late") == [] and sync.rejected == 1
    for k in range(3, 10):
        sync.add("a", k, k)
        if k % 2 == 0:
            sync.add("b", k, k)
    assert sync.rejected == 1 and sync.last_step == 9 and sync.add("a", 0, "again") == [] and sync.restarts == 1
    assert sync.add("b", 0, "b") == [(0, {"a": "again", "b": "b"})]


@contextmanager
def alignment_node(domain_env, params: dict | None = None):
    """The node in this process on its own context; its publications are captured and its
    inputs handed to its subscription callbacks directly (exact, no discovery)."""
    context = Context()
    rclpy.init(context=context, domain_id=int(domain_env["ROS_DOMAIN_ID"]))
    params = {"timing": "lockstep", "lat_deg": LAT_DEG, "imu_rate_hz": IMU_HZ, "joint_rate_hz": IMU_HZ,
              **(params or {})}
    node = PlatformAlignmentNode(context=context, cli_args=ros_args(params), use_global_arguments=False)
    sent = defaultdict(list)
    for name, pub in ((n, node.edge.pubs[f"~/{n}"]) for n in OUTPUTS):
        # serialized by the node (gimbal_estimators.wire): decoded by rclpy's own deserializer
        pub.publish = lambda data, out=sent[name]: out.append(deserialize_message(data, Vector3Stamped))
    node.edge.pubs["~/progress"].publish = lambda data: sent["progress"].append(m.clock_from_cdr(data))
    try:
        yield node, sent
    finally:
        node.destroy_node()
        rclpy.shutdown(context=context)


def _feed(node, k: int, psi: float, rate: float, f_s, joint_name: str = "platform_azimuth") -> None:
    t_ns = m.step_stamp_ns(k, SIM_HZ)
    node._on_input("joint", m.joint_state_msg(t_ns, (joint_name,), (psi,), (rate,)))
    node._on_input("imu", m.imu_msg(t_ns, "platform_frd", linear_acceleration=tuple(f_s)))


def _vec(msg) -> np.ndarray:
    return np.array([msg.vector.x, msg.vector.y, msg.vector.z])


def test_outputs_follow_an_independent_truth_in_ned_with_sigma(ros_domain_env):
    """A rotation-matrix platform (KinematicPlatformTruth) with misalignment, level gyro drifts
    and accelerometer biases, noise-free: after 600 s the published initial and current
    misalignment, drifts and biases match the truth in the message conventions."""
    lat = math.radians(LAT_DEG)
    g = RotationAlignmentParams(lat_deg=LAT_DEG).gravity
    eps_s = np.array([0.02, -0.03, 0.0]) * DEG_H
    bias = np.array([60e-6, -90e-6, 0.0]) * 9.80665
    truth = KinematicPlatformTruth(lat, np.array([-25.0, -36.0, 1020.0]) * ARCSEC, eps_s,
                                   rotation=BidirectionalRotation(), gravity=g)
    phi0 = truth.misalignment_enu()
    every = int(SIM_HZ / IMU_HZ)
    with alignment_node(ros_domain_env) as (node, sent):
        for i in range(6001):
            if i:
                truth.step(1.0 / IMU_HZ)
            _feed(node, i * every, *truth.psi_state(truth.t), truth.specific_force_s() + bias)
        assert len(sent["status"]) == 600 and all(len(sent[name]) == 600 for name in OUTPUTS)
        age, updates, converged = _vec(sent["status"][-1])
        assert age == pytest.approx(600.0) and updates == 600 and converged == 1.0
        assert sent["status"][-1].header.stamp == m.time_msg(m.step_stamp_ns(600_000, SIM_HZ))
        # NED components: (N, E, D) = (δφN, δφE, −δφU)
        init, init_sigma = _vec(sent["initial_misalignment"][-1]), _vec(sent["initial_misalignment_sigma"][-1])
        assert sent["initial_misalignment"][-1].header.frame_id == "map_ned"
        expected = np.array([phi0[1], phi0[0], -phi0[2]])
        assert np.all(np.abs(init[:2] - expected[:2]) < 0.2 * ARCSEC)
        assert abs(init[2] - expected[2]) < 0.25 * ARCMIN
        assert np.all(init_sigma > 0.0) and init_sigma[2] > init_sigma[0]  # azimuth is the weak one
        now = _vec(sent["misalignment"][-1])
        phi_t = truth.misalignment_enu()
        assert np.all(np.abs(now[:2] - np.array([phi_t[1], phi_t[0]])) < 0.3 * ARCSEC)
        # drifts and biases in platform axes, z not estimated (σ = −1)
        assert np.allclose(_vec(sent["gyro_drift"][-1])[:2], eps_s[:2], atol=1e-3 * DEG_H)
        assert np.allclose(_vec(sent["accel_bias"][-1])[:2], bias[:2], atol=0.5e-6 * 9.80665)
        for name in ("gyro_drift_sigma", "accel_bias_sigma"):
            s = _vec(sent[name][-1])
            assert s[2] == -1.0 and np.all(s[:2] > 0.0)
        north, north_sigma = _vec(sent["north_drift"][-1]), _vec(sent["north_drift_sigma"][-1])
        assert abs(north[0]) < 5e-4 * DEG_H and north[1:].tolist() == [0.0, 0.0]
        assert north_sigma[0] > 0.0 and north_sigma[1:].tolist() == [-1.0, -1.0]
        # pacing: ready is announced by the timer (not spun here); then every 10 steps the
        # next step needed, which at 10 Hz in a 1 kHz run is the next sample's step
        steps = [m.step_of_stamp(c, SIM_HZ) for c in sent["progress"]]
        assert steps[:3] == [100, 200, 300] and steps[-1] == 600_100


def test_bad_input_is_rejected_counted_and_a_loop_restarts(ros_domain_env):
    g = 9.80
    with alignment_node(ros_domain_env, {"clock_jump_s": 0.5}) as (node, sent):
        for i in range(12):
            f = (math.nan, 0.0, -g) if i == 4 else (0.0, 0.0, -g)
            _feed(node, 100 * i, 0.0, 0.0, f)
        core = node.core
        assert core.counters.rejected_nonfinite == 1 and core.counters.accepted == 11
        assert len(sent["status"]) == 1  # the NaN sample is skipped, the block closes at 1.0 s
        # a stale stamp is rejected, not fused; one off the 10 Hz grid is rejected too
        node._on_input("imu", m.imu_msg(m.step_stamp_ns(1000, SIM_HZ), "platform_frd", linear_acceleration=(0, 0, -g)))
        node._on_input("imu", m.imu_msg(m.step_stamp_ns(1150, SIM_HZ), "platform_frd", linear_acceleration=(0, 0, -g)))
        assert node.policy.sync.rejected == 1 and node.policy.off_grid == 1 and core.counters.accepted == 11
        # a joint message without the azimuth joint is counted (the step's accelerometer
        # sample then uses the previous joint sample, 0.1 s old, within max_joint_age_s)
        _feed(node, 1200, 0.0, 0.0, (0.0, 0.0, -g), joint_name="elsewhere")
        assert node.edge.counts["rejected_joints"] == 1 and core.counters.accepted == 12
        # the bag loops: everything restarts at t = 0
        _feed(node, 0, 0.0, 0.0, (0.0, 0.0, -g))
        assert node.policy.sync.restarts == 1 and core.counters.resets == 1
        assert core.started and core.n_updates == 0


def test_scenario_starts_the_platform_where_alignment_setup_puts_it():
    """rotational_ins_alignment's base heading and gimbal angles are alignment_setup()'s, its
    sensor noise the ALIGNMENT_* budget's, and the three latitudes agree."""
    import yaml

    nodes = load("rotational_ins_alignment").nodes
    vehicle = nodes["vehicle_dynamics"]["params"]
    profile = yaml.safe_load(vehicle["profile_params"])
    heading, joints = alignment_setup()
    assert profile["yaw_deg"] == pytest.approx(heading, abs=1e-12)
    assert vehicle["initial_platform_deg"] == pytest.approx(list(joints), abs=1e-15)
    assert profile["lat_deg"] == nodes["platform_servo"]["params"]["lat_deg"] == \
        nodes["platform_alignment"]["params"]["lat_deg"] == LAT_DEG
    sensors = nodes["sensor_models"]["params"]
    assert sensors["platform_gyro_arw_deg_rt_h"] == ALIGNMENT_GYRO_ARW_DEG_RT_H
    assert sensors["platform_accel_noise_ug_rt_hz"] == ALIGNMENT_ACCEL_NOISE_UG_RT_HZ == \
        nodes["platform_alignment"]["params"]["accel_noise_ug_rt_hz"]


# ------------------------------------------------------------------------------- graph run
#: Three of the alignment's 1 s blocks, so three RLS updates to compare graph and engine on
#: (exact equality: the number of updates does not change what is checked).
DURATION_S = 3.0


@pytest.fixture(scope="module")
def graph_run(module_ros_domain_env, tmp_path_factory):
    out = tmp_path_factory.mktemp("alignment") / "run"
    result = subprocess.run([str(VENV_BIN / "gimbal-run"), "rotational_ins_alignment", "--variant", "rotation_on",
                             "--duration", str(DURATION_S), "--out", str(out), "--mode", "container", "--no-progress"],
                            env=module_ros_domain_env, capture_output=True, text=True, timeout=1800)
    assert result.returncode == 0, result.stdout + result.stderr
    return out / "rotation_on"


def _alignment_messages(run_dir):
    from rosbags.highlevel import AnyReader

    with AnyReader([run_dir]) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
        msgs = defaultdict(list)
        for connection, _, raw in reader.messages():
            if connection.topic.startswith("/platform_alignment/"):
                msgs[connection.topic].append(reader.deserialize(raw, connection.msgtype))
    return counts, msgs


@pytest.mark.slow
def test_graph_run_equals_the_engine_run(graph_run, tmp_path):
    """The graph's alignment and the one engine's (the campaign's ``engine: core`` runs) give
    the same estimates, read from each bag by rosbags; the report's errors are the same."""
    import dataclasses
    import json

    counts, msgs = _alignment_messages(graph_run)
    rates = load("rotational_ins_alignment").record_rates_hz  # a topic's first message, then one per period
    for topic in ("/clock", "/truth/platform/joint_states"):
        assert counts[topic] == int(DURATION_S * min(rates.get(topic, SIM_HZ), SIM_HZ)) + 1, topic
    assert counts["/platform_alignment/status"] == int(DURATION_S)  # one RLS update per 1 s block
    scenario = dataclasses.replace(variant(load("rotational_ins_alignment"), "rotation_on"), duration_s=DURATION_S)
    run_engine(scenario, tmp_path / "engine")
    _, ref = _alignment_messages(tmp_path / "engine")
    for topic in ("/platform_alignment/initial_misalignment", "/platform_alignment/accel_bias",
                  "/platform_alignment/misalignment_sigma"):
        v = lambda m: np.array([[x.vector.x, x.vector.y, x.vector.z] for x in m[topic]])  # noqa: E731
        np.testing.assert_allclose(v(msgs), v(ref), rtol=1e-6, atol=1e-12)
    metrics = json.loads((graph_run / "report" / "metrics.json").read_text())["alignment"]
    assert metrics["truth_initial_misalignment_arcsec"] == pytest.approx([-25.0, -36.0, 1020.0], abs=0.2)
    assert metrics["updates"] == int(DURATION_S)


@pytest.mark.slow
def test_campaign_and_rotation_comparison_read_the_runs(graph_run, tmp_path):
    """The Table 2 and on/off functions over run directories (here the one short run twice:
    identical runs, so zero spread)."""
    from gimbal_sim.reports.alignment import alignment_campaign, final_errors, alignment_series, rotation_comparison

    runs = {"a": graph_run, "b": graph_run}
    table = alignment_campaign(runs, tmp_path)
    single = final_errors(alignment_series(graph_run))
    east = table["statistics"]["east_tilt_error_arcsec"]
    assert east["mean"] == pytest.approx(single["tilt_error_arcsec"]["east"]) and east["std"] == 0.0
    assert set(table["acceptance"]) == {"horizontal_below_3_arcsec", "azimuth_below_1.5_arcmin",
                                        "north_drift_below_0.006_deg_h"}
    cmp = rotation_comparison({"rotation_on": graph_run}, tmp_path)
    assert cmp["final"]["rotation_on"] == single
    assert (tmp_path / "alignment_campaign.png").is_file() and (tmp_path / "alignment_rotation_on_off.png").is_file()

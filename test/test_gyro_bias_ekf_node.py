"""The gyro_bias_ekf node: bad input, the headline scenario through the graph against the
pure-Python loop, and replay of a recorded run into a fresh node."""
from __future__ import annotations

import math
import subprocess

import numpy as np
import pytest
import yaml
from mcap_ros2.reader import read_ros2_messages

from conftest import VENV_BIN
from gimbal_sim.graph.orchestrator import stop_processes
from ros_harness import harness_node, spin_until

pytestmark = pytest.mark.ros

BIAS = "/gyro_bias_ekf/bias"


@pytest.mark.parametrize("args, named", [
    (["-p", "gate_probability:=1.5"], "gate_probability"),
    (["-p", "lat_deg:=95.0"], "lat_deg"),
    (["-p", "ins_error_states:=true", "-p", "ins_heading_rms_deg:=0.0"], "ins_heading_rms_deg"),
    (["-p", "velocity_n_m_s:=[1.0, 2.0]"], "velocity_n_m_s"),
])
def test_bad_parameters_are_refused_by_name(ros_domain_env, args, named):
    result = subprocess.run([str(VENV_BIN / "gyro_bias_ekf"), "--ros-args", *args], env=ros_domain_env,
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 2 and named in result.stderr, result.stderr


def _static_inputs(k: int, rate: float = 1000.0):
    """Messages of step k for a gimbal at rest on a level, north-facing vehicle at the
    equator: gyro (q, r) = 100 °/h bias + earth rate, INS every 10 steps."""
    from gimbal_kinematics.ros import messages as sm

    t_ns = sm.step_stamp_ns(k, rate)
    w_ie = 7.292115e-5
    b = math.radians(100.0 / 3600.0)
    gyro = sm.imu_msg(t_ns, "gimbal_inner_frd", angular_velocity=(0.0, b, b))
    enc = sm.joint_state_msg(t_ns, ("turret_azimuth", "gimbal_azimuth", "gimbal_elevation"), (0.0,) * 3, (0.0,) * 3)
    ins = sm.imu_msg(t_ns, "base_link_frd", orientation=(0.0, 0.0, 0.0, 1.0), angular_velocity=(w_ie, 0.0, 0.0)) \
        if k % 10 == 0 else None
    return gyro, enc, ins


def test_node_rejects_nan_and_out_of_order_and_resets_on_a_clock_jump(ros_domain_env):
    from rclpy.parameter import Parameter
    from geometry_msgs.msg import Vector3Stamped
    from sensor_msgs.msg import Imu, JointState

    from gimbal_estimators.gyro_bias_ekf_node import GyroBiasEkfNode
    from gimbal_kinematics.ros.qos import GRAPH_QOS

    with harness_node(int(ros_domain_env["ROS_DOMAIN_ID"])) as (harness, executor):
        ekf = GyroBiasEkfNode(context=harness.context,
                              parameter_overrides=[Parameter("timing", value="lockstep"),
                                                   Parameter("ins_error_states", value=False),
                                                   Parameter("clock_jump_s", value=0.03)])
        executor.add_node(ekf)
        try:
            pub_g = harness.create_publisher(Imu, "/gimbal/imu", GRAPH_QOS)
            pub_e = harness.create_publisher(JointState, "/gimbal/joint_states", GRAPH_QOS)
            pub_i = harness.create_publisher(Imu, "/ins/imu", GRAPH_QOS)
            stamps = []
            harness.create_subscription(Vector3Stamped, BIAS, lambda msg: stamps.append(
                msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec), GRAPH_QOS)
            assert spin_until(executor, lambda: ekf.edge.pubs["~/bias"].get_subscription_count() > 0
                              and pub_g.get_subscription_count() > 0, 30.0)

            def send(k, gyro_q=None, ins_nan=False):
                gyro, enc, ins = _static_inputs(k)
                if gyro_q is not None:
                    gyro.angular_velocity.y = gyro_q
                pub_e.publish(enc)
                if ins is not None:
                    if ins_nan:
                        ins.orientation.x = math.nan
                    pub_i.publish(ins)
                pub_g.publish(gyro)
                spin_until(executor, lambda: False, 0.002)

            for k in range(41):
                send(k, gyro_q=math.nan if k == 25 else None)
            # one estimate per INS stamp, in order, whatever happened to the gyro at step 25
            assert spin_until(executor, lambda: len(stamps) >= 5, 30.0)
            assert stamps[:5] == [k * 10**7 for k in range(5)]
            before = ekf.core.counters
            assert before.rejected_nonfinite == 1 and before.resets == 0
            # an INS sample with NaN angles: rejected, counted, and still answered with the
            # current estimate so a waiting controller carries on
            for k in range(41, 51):
                send(k, ins_nan=k == 50)
            ok = spin_until(executor, lambda: 5 * 10**7 in stamps, 30.0)
            assert ok, (ekf.core.counters, stamps[-3:])
            assert ekf.core.counters.rejected_nonfinite == 2
            # a stale gyro stamp (19 steps back, less than clock_jump_s): out of order
            send(21)
            assert spin_until(executor, lambda: ekf.policy.rejected >= 1, 30.0)
            # the bag loops: stamps go back 40 ms to 0, more than clock_jump_s -> reset, logged, realigned
            for k in range(0, 12):
                send(k)
            assert spin_until(executor, lambda: ekf.core.counters.resets == 1, 30.0)
            assert "clock jumped back" in ekf.core.reset_log[-1][1]
            assert spin_until(executor, lambda: ekf.core.aligned, 30.0)
            assert np.all(np.isfinite(ekf.core.bias)) and np.all(np.linalg.eigvalsh(ekf.core.P) > 0.0)
        finally:
            executor.remove_node(ekf)
            ekf.destroy_node()


def _bag_estimates(run_dir, topic=BIAS) -> np.ndarray:
    """(stamp ns, x, y, z) rows read with mcap_ros2 (not our reader)."""
    (path,) = run_dir.glob("*.mcap")
    rows = [(m.ros_msg.header.stamp.sec * 10**9 + m.ros_msg.header.stamp.nanosec, m.ros_msg.vector.x,
             m.ros_msg.vector.y, m.ros_msg.vector.z) for m in read_ros2_messages(str(path), topics=[topic])]
    return np.array(rows)


#: Simulated length of the headline run: 101 EKF estimates at its 100 Hz, each compared with
#: the engine's to 1e-12 and with a replay's to 1e-9 (the checks do not need a longer run).
HEADLINE_S = 1.0


@pytest.fixture(scope="module")
def headline_run(module_ros_domain_env, tmp_path_factory):
    """A short ekf_on run of the main-job scenario, in processes mode."""
    out = tmp_path_factory.mktemp("sighting") / "run"
    result = subprocess.run([str(VENV_BIN / "gimbal-run"), "sighting_land_vehicle", "--variant", "ekf_on",
                             "--duration", str(HEADLINE_S), "--out", str(out), "--no-progress"],
                            env=module_ros_domain_env, capture_output=True, text=True, timeout=900)
    assert result.returncode == 0, result.stderr[-3000:]
    return out / "ekf_on"


@pytest.mark.slow
def test_graph_computes_what_the_engine_computes(headline_run, tmp_path):
    from dataclasses import replace

    from gimbal_sim.core.engine_run import run_engine
    from gimbal_sim.graph.scenario import load, variant

    run_engine(replace(variant(load("sighting_land_vehicle"), "ekf_on"), duration_s=HEADLINE_S), tmp_path / "engine")
    core = _bag_estimates(tmp_path / "engine")
    bag = _bag_estimates(headline_run)
    assert len(bag) == len(core) == int(HEADLINE_S * 100) + 1
    np.testing.assert_array_equal(bag[:, 0], core[:, 0])
    np.testing.assert_allclose(bag[:, 1:], core[:, 1:], rtol=0, atol=1e-12)
    assert np.all(np.isfinite(bag[:, 1:]))


@pytest.mark.slow
def test_replaying_the_sensors_into_a_fresh_node_reproduces_the_estimates(headline_run, module_ros_domain_env,
                                                                         tmp_path):
    """ros2-run-style: the executable with the run's parameter file and a remapped INS topic,
    fed by the bag player; the estimates must equal the recorded ones to 1e-9. The file holds
    the node's configuration, not the orchestrator's lockstep timing: the node started alone
    runs in its default, free timing (SensorDataQoS inputs, default-QoS outputs)."""
    from geometry_msgs.msg import Vector3Stamped
    from rclpy.qos import QoSProfile

    saved = yaml.safe_load((headline_run / "params" / "gyro_bias_ekf.yaml").read_text())
    assert "timing" not in saved["gyro_bias_ekf"]["ros__parameters"]
    recorded = _bag_estimates(headline_run)
    env = module_ros_domain_env
    log = open(tmp_path / "replay.log", "w")
    ekf = subprocess.Popen([str(VENV_BIN / "gyro_bias_ekf"), "--ros-args", "--params-file",
                            str(headline_run / "params" / "gyro_bias_ekf.yaml"), "-r", "/ins/imu:=/replay/ins/imu"],
                           env=env, stdout=log, stderr=subprocess.STDOUT)
    player = None
    try:
        with harness_node(int(env["ROS_DOMAIN_ID"]), "replay_listener") as (node, executor):
            got = []
            node.create_subscription(Vector3Stamped, BIAS, lambda msg: got.append(
                (msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec, msg.vector.x, msg.vector.y, msg.vector.z)),
                QoSProfile(depth=10000))  # reliable, volatile: the free node's outputs
            assert spin_until(executor, lambda: node.count_publishers(BIAS) > 0, 60.0)
            player = subprocess.Popen([str(VENV_BIN / "gimbal-bag"), "play", str(headline_run), "--rate", "0",
                                       "--topics", "/gimbal/imu", "/gimbal/joint_states", "/ins/imu",
                                       "--remap", "/ins/imu:=/replay/ins/imu", "--wait-for-subscribers", "1",
                                       "--pace", "/gyro_bias_ekf/progress"],
                                      env=env, stdout=log, stderr=subprocess.STDOUT)
            done = spin_until(executor, lambda: len(got) >= len(recorded), 300.0)
            assert done, (len(got), len(recorded), (tmp_path / "replay.log").read_text()[-2000:])
    finally:
        stop_processes([player, ekf])
        log.close()
    replayed = np.array(got[:len(recorded)])
    np.testing.assert_array_equal(replayed[:, 0], recorded[:, 0])
    np.testing.assert_allclose(replayed[:, 1:], recorded[:, 1:], rtol=0, atol=1e-9)

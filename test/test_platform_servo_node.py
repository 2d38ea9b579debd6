"""Paper 3's four-gimbal servo as the ``platform_servo`` node: startup refusals, per-step
input sync, bad input held and counted, and the ``rotational_platform_servo`` scenario
whose bag (read with the ``mcap`` library) must reproduce the pure-Python closed loop
(run_platform_servo) command for command and meet the servo's acceptance figures."""
from __future__ import annotations

import json
import math
import subprocess
from collections import defaultdict
from contextlib import contextmanager

import numpy as np
import pytest
import rclpy
from sensor_msgs.msg import JointState
from rclpy.context import Context
from rclpy.serialization import deserialize_message

from conftest import VENV_BIN
from gimbal_control.platform_servo import PlatformServo, PlatformServoParams
from gimbal_control.platform_servo_node import PlatformServoNode
from gimbal_control.platform_servo_params import PARAMS as SERVO_PARAMS
from gimbal_kinematics.ros import messages as m
from gimbal_sim.experiments.platform_servo import run_platform_servo
from gimbal_sim.world.sensor_suite import PlatformImuSample, ResolverSample, SensorSuite, SensorSuiteConfig
from imu_grades import no_grade_args
from gimbal_kinematics.maths.frames import PLATFORM_JOINTS
from gimbal_sim.world.vehicle import VehicleConfig, VehicleCore
from ros_harness import ros_args, start_refused

pytestmark = pytest.mark.ros
ARCSEC = math.pi / (180.0 * 3600.0)
RATE = 1000.0


@pytest.mark.parametrize("args,named", [
    ({"rotation": "spin"}, "rotation"),
    ({"imu_rate_hz": 300.0}, "imu_rate_hz"),
    ({"azimuth_bandwidth_hz": 50.0}, "azimuth_bandwidth_hz"),
    ({"level_bandwidth_hz": -1.0}, "level_bandwidth_hz"),
    ({"drift_deg_h": [0.1, 0.2]}, "drift_deg_h"),
    ({"lat_deg": 95.0}, "lat_deg"),
    ({"reversal_time_s": 700.0}, "reversal_time_s"),
])
def test_bad_parameters_are_refused_naming_them(args, named, ros_domain_env):
    result = start_refused("platform_servo", args, ros_domain_env)
    assert result.returncode == 2 and named in result.stderr, result.stderr


@contextmanager
def servo_node(domain_env, params: dict | None = None):
    """The node in this process on its own context; its publications are captured
    (inputs are handed to its subscription callbacks directly, so the test is exact)."""
    context = Context()
    rclpy.init(context=context, domain_id=int(domain_env["ROS_DOMAIN_ID"]))
    node = PlatformServoNode(context=context, cli_args=ros_args({"timing": "lockstep", **(params or {})}), use_global_arguments=False)
    sent = defaultdict(list)
    for name, pub in (("cmd", node.edge.pubs["/platform/voltage_cmd"]), ("error", node.edge.pubs["~/control_error"]),
                      ("mod", node.edge.pubs["~/modulation"])):
        # serialized by the node (gimbal_control.wire): decoded by rclpy's own deserializer
        pub.publish = lambda data, out=sent[name]: out.append(deserialize_message(data, JointState))
    try:
        yield node, sent
    finally:
        node.destroy_node()
        rclpy.shutdown(context=context)


def _inputs(k: int, omega=(0.0, 0.0, 0.0), angles=(0.0, 0.0, 0.0, 0.0)):
    t_ns = m.step_stamp_ns(k, RATE)
    imu = m.imu_msg(t_ns, "platform_frd", angular_velocity=omega)
    res = m.joint_state_msg(t_ns, PLATFORM_JOINTS, angles)
    return imu, res


def _volts(msg) -> tuple[float, ...]:
    assert list(msg.name) == list(PLATFORM_JOINTS)
    return tuple(msg.effort)


def test_one_command_per_step_whatever_the_arrival_order_and_nan_holds(ros_domain_env):
    """Each step's command waits for that step's gyro and resolvers, in either order; a NaN
    gyro sample holds the last command (counted); a stale stamp is rejected (counted)."""
    rng = np.random.default_rng(5)
    omegas = rng.normal(0.0, 1e-4, (8, 3))
    omegas[5, 1] = math.nan
    runs = []
    for imu_first in (False, True):
        with servo_node(ros_domain_env) as (node, sent):
            for k in range(8):
                imu, res = _inputs(k, omegas[k])
                first, second = (("imu", imu), ("res", res)) if imu_first else (("res", res), ("imu", imu))
                node._on_input(*first)
                if k == 3:
                    assert len(sent["cmd"]) == 3  # half of step 3 is in: nothing yet
                node._on_input(*second)
            stale, _ = _inputs(2)
            node._on_input("imu", stale)
            assert [m.step_of_stamp(m.stamp_ns(c.header.stamp), RATE) for c in sent["cmd"]] == list(range(8))
            volts = [_volts(c) for c in sent["cmd"]]
            assert volts[5] == volts[4] and volts[6] != volts[5]
            assert node.core.held_commands == 1 and node.core.rejected_nonfinite == 1
            assert node.policy.sync.rejected == 1
            # diagnostics every tick (the held one repeats its signals); φz starts at 0, +1.2 °/s
            assert len(sent["error"]) == len(sent["mod"]) == 8
            assert sent["error"][5].position == sent["error"][4].position
            assert sent["mod"][0].position[0] == 0.0
            assert sent["mod"][1].velocity[0] == pytest.approx(math.radians(1.2))
            runs.append(volts)
    assert runs[0] == runs[1]


def test_bad_resolver_message_is_ignored_and_counted(ros_domain_env):
    with servo_node(ros_domain_env) as (node, sent):
        imu, res = _inputs(0)
        node._on_input("res", res)
        node._on_input("imu", imu)
        imu, _ = _inputs(1, (1e-4, 0.0, 0.0))
        node._on_input("res", m.joint_state_msg(m.step_stamp_ns(1, RATE), ("a", "b"), (0.0, 0.0)))
        node._on_input("imu", imu)
        assert node.edge.counts["rejected_joint_names"] == 1 and len(sent["cmd"]) == 2
        _, res = _inputs(2, angles=(0.0, math.inf, 0.0, 0.0))
        imu, _ = _inputs(2)
        node._on_input("res", res)
        node._on_input("imu", imu)
        assert node.core.rejected_nonfinite == 1 and len(sent["cmd"]) == 3


def test_slower_gyro_holds_the_command_on_clock_ticks_and_a_loop_restarts(ros_domain_env):
    """imu_rate_hz = sim/2: odd steps have only /clock and repeat the last command. A bag
    looping back restarts the servo."""
    params = {"imu_rate_hz": 500.0, "resolver_rate_hz": 500.0, "clock_jump_s": 0.002}
    with servo_node(ros_domain_env, params) as (node, sent):
        for k in range(6):
            if k % 2 == 0:
                imu, res = _inputs(k, (0.0, 2e-4 * k, 0.0))
                node._on_input("res", res)
                node._on_input("imu", imu)
            node._on_input("clock", m.clock_msg(m.step_stamp_ns(k, RATE)))
        assert len(sent["cmd"]) == 6
        volts = [_volts(c) for c in sent["cmd"]]
        assert volts[1] == volts[0] and volts[3] == volts[2] and volts[2] != volts[0]
        assert len(sent["mod"]) == 3
        # back to the start (a replayed bag looping): the servo restarts
        imu, res = _inputs(0)
        node._on_input("res", res)
        node._on_input("imu", imu)
        node._on_input("clock", m.clock_msg(0))
        assert node.policy.sync.rejected == 0 and len(sent["cmd"]) == 7
        assert any("jumped back" in r for r in node.core.reset_reasons)


def test_resolver_sensor_reads_quantised_gimbal_angles_before_the_imu():
    """The resolvers publish the plant's gimbal angles quantised to 19 bits (multi-turn
    azimuth), at each step ahead of the platform IMU (the order the servo consumes them in)."""
    core = VehicleCore(VehicleConfig(profile="static", profile_params={"lat_deg": 45.0, "yaw_deg": 20.0},
                                     plant="four_gimbal_platform", initial_joints_deg=(355.0, 0.1, -0.2, 1.0),
                                     duration_s=1.0))
    suite = SensorSuite(SensorSuiteConfig(sensors=("platform_imu", "resolvers"), platform_imu_rate_hz=1000.0))
    quantum = 2 * math.pi / 2 ** 19
    for _ in range(200):
        truth = core.truth()
        samples = suite.update(truth)
        assert [type(s) for s in samples] == [ResolverSample, PlatformImuSample]
        assert samples[0].names == PLATFORM_JOINTS
        assert all(abs(a - b) <= quantum / 2 + 1e-15 for a, b in zip(samples[0].angles, truth.joint_position))
        assert all(abs(round(a / quantum) * quantum - a) < 1e-12 for a in samples[0].angles)
        core.step((20.0, 0.0, 0.0, 0.0))
    assert samples[0].angles[0] > 2 * math.pi  # turned past 360°, not wrapped


def test_drift_compensation_takes_the_platform_drift_which_is_minus_the_gyro_bias():
    """Gyros with rate bias b on a platform that moves exactly as commanded: with
    drift_deg_h = −b (the drift platform_alignment estimates) the pickoffs stay null, so the
    servo leaves the platform on its command; uncompensated they integrate b."""
    from gimbal_kinematics.maths.earth import earth_rate_n
    from gimbal_kinematics.maths.rotations import rot3

    b = np.array([0.02, -0.03, 0.01])  # [deg/h]
    w_ie = earth_rate_n(math.radians(40.0))
    picks = []
    for drift in (tuple(-b), (0.0, 0.0, 0.0)):
        params = PlatformServoParams(lat_deg=40.0, drift_deg_h=drift)
        servo, sched = PlatformServo(params), params.schedule()
        for k in range(2000):
            phi, rate, _ = sched.state(k * 1e-3)
            omega = rot3(phi) @ w_ie + np.array([0.0, 0.0, rate]) + np.radians(b) / 3600.0
            servo.on_resolvers(k * 1e-3, (phi, 0.0, 0.0, 0.0))
            servo.on_gyro(k * 1e-3, omega)
        picks.append(np.array(servo.pickoff) / ARCSEC)
    assert np.max(np.abs(picks[0])) < 1e-6
    assert np.max(np.abs(picks[1])) > 0.005  # 0.03 °/h over 2 s = 0.06″, spread over the turning axes


# ------------------------------------------------------------------------------- graph run
DURATION_S = 6.5
SWEEP_DEG = 6.0  # one reversal at 5 s


@pytest.fixture(scope="module")
def graph_run(module_ros_domain_env, tmp_path_factory):
    out = tmp_path_factory.mktemp("servo") / "run"
    result = subprocess.run([str(VENV_BIN / "gimbal-run"), "rotational_platform_servo", "--variant", "rate_triad",
                             "--duration", str(DURATION_S), "--set", f"platform_servo.sweep_deg={SWEEP_DEG}",
                             # the hand-built loop it is compared with has sensors without the grade
                             *no_grade_args("platform_gyro", "platform_accel"),
                             "--out", str(out), "--mode", "container", "--no-progress"], env=module_ros_domain_env,
                            capture_output=True, text=True, timeout=900)
    assert result.returncode == 0, result.stdout + result.stderr
    return out / "rate_triad"


def _read_bag(out):
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    series = defaultdict(list)
    with open(next(out.glob("*.mcap")), "rb") as f:
        for _, channel, _, msg in make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages():
            stamp = msg.clock if channel.topic == "/clock" else msg.header.stamp
            series[channel.topic].append((stamp.sec * 10**9 + stamp.nanosec, msg))
    return series


@pytest.mark.slow
def test_graph_run_reproduces_the_closed_loop_and_meets_the_figures(graph_run):
    series = _read_bag(graph_run)
    steps = int(DURATION_S * RATE)
    cmds = series["/platform/voltage_cmd"]
    assert [t for t, _ in cmds] == [m.step_stamp_ns(k, RATE) for k in range(steps + 1)]
    # the node is a thin wrapper: the same core on the same plant and sensors (same seed)
    ref = run_platform_servo(DURATION_S, seed=0, params=PlatformServoParams(lat_deg=45.0, sweep_deg=SWEEP_DEG),
                             record_every=1)
    volts = np.array([list(msg.effort) for _, msg in cmds])
    np.testing.assert_allclose(volts, ref["series"]["voltages_v"], rtol=1e-6, atol=1e-9)
    # the servo's acceptance figures, recomputed here from the bag: azimuth truth vs the commanded φz
    mod = np.array([(msg.position[0], msg.velocity[0]) for _, msg in series["/platform_servo/modulation"]])
    az = np.array([msg.position[0] for _, msg in series["/truth/platform/joint_states"]])
    t = np.arange(steps + 1) / RATE
    err = (az - az[0] - mod[:, 0]) / ARCSEC
    reversal = (t >= 5.0) & (t < 7.0)
    steady = (t >= 2.0) & ~reversal
    assert np.max(np.abs(err[steady])) < 20.0 and np.max(np.abs(err[reversal])) < 120.0
    assert np.max(np.abs(err[reversal])) > 5.0  # the transient is there to be measured
    metrics = json.loads((graph_run / "report" / "metrics.json").read_text())
    assert metrics["reversal_times_s"] == [pytest.approx(5.0, abs=2e-3)]
    assert all(metrics["acceptance"].values()), metrics["acceptance"]
    sensed = np.array([msg.position[0] for _, msg in series["/platform_servo/control_error"]]) / ARCSEC
    assert metrics["control_error_arcsec"]["sensed"]["reversal"]["max"] == pytest.approx(
        np.max(np.abs(sensed[reversal])), rel=1e-9)
    # the torque current: friction T_c/k_t ≈ 48 mA while turning at 1.2 °/s (paper: tens of mA)
    assert metrics["torque_current"]["steady_mean_abs_ma"] == pytest.approx(ref["steady_mean_abs_current_a"] * 1e3,
                                                                           rel=0.02)
    assert {p.name for p in (graph_run / "report").glob("*.png")} >= {"rotation_angle.png", "control_error.png"}


def test_following_the_navigator_each_step_waits_for_its_command_rate(ros_domain_env):
    """command_source navigator: a step's command waits for the navigator's rate stamped like
    it and equals the core fed that rate before the gyro sample; the
    rate changes the command (a rate of 0.1 °/s about north, far from the earth rate)."""
    rng = np.random.default_rng(11)
    omegas = rng.normal(0.0, 1e-4, (6, 3))
    rates_n = [(math.radians(0.1), 0.0, -7.292115e-5 * math.sin(math.radians(40.0)))] * 6
    params = {"command_source": "navigator", "lat_deg": 40.0}
    with servo_node(ros_domain_env, params) as (node, sent):
        for k, (omega, w_n) in enumerate(zip(omegas, rates_n)):
            imu, res = _inputs(k, tuple(omega))
            node._on_input("res", res)
            node._on_input("imu", imu)
            assert len(sent["cmd"]) == k  # waiting for the navigator
            node._on_input("nav", m.vector3_msg(m.step_stamp_ns(k, RATE), "map_ned", w_n))
            assert len(sent["cmd"]) == k + 1
        ref = PlatformServo(PlatformServoParams.from_values(node_values(node)))
        internal = PlatformServo(PlatformServoParams.from_values({**node_values(node), "command_source": "internal"}))
        for k, (omega, w_n) in enumerate(zip(omegas, rates_n)):
            t = k / RATE
            for core in (ref, internal):
                core.on_resolvers(t, (0.0, 0.0, 0.0, 0.0))
            ref.on_command_rate(t, w_n)
            out, out_internal = ref.on_gyro(t, tuple(omega)).output, internal.on_gyro(t, tuple(omega)).output
            assert _volts(sent["cmd"][k]) == pytest.approx(out.voltages, rel=1e-12, abs=1e-15)
        assert out.voltages != pytest.approx(out_internal.voltages, rel=1e-3)


def node_values(node) -> dict:
    """The servo node's declared parameter values, by name."""
    return {p.name: node.get_parameter(p.name).value for p in SERVO_PARAMS}

"""The paper 1 controller as a node closes the loop through the ROS graph."""
from __future__ import annotations

import json
import subprocess

import pytest

from conftest import VENV_BIN
from gimbal_sim.bag.reader import scan

pytestmark = pytest.mark.ros


def test_los_stabilization_scenario_holds_the_los(ros_domain_env, tmp_path):
    out = tmp_path / "run"
    result = subprocess.run([str(VENV_BIN / "gimbal-run"), "los_stabilization", "--duration", "2", "--out", str(out),
                             "--mode", "container", "--no-progress"], env=ros_domain_env, capture_output=True,
                            text=True, timeout=600)
    assert result.returncode == 0, result.stderr
    contents = scan(out)
    # one command per published step (the one for the last step is never integrated)
    assert contents.topics["/gimbal/torque_cmd"].count == contents.topics["/clock"].count == 2001
    pointing = json.loads((out / "report" / "metrics.json").read_text())["pointing_error_urad"]
    # acceptance: < 20 µrad RMS with an ideal gyro (the 1 s start-up transient stops 0.12 rad/s of turret motion)
    assert pointing["rms_after_1s"] < 20.0
    assert pointing["max"] < 1000.0


def test_bad_controller_parameters_are_refused(ros_domain_env):
    for args, named in ((["-p", "omega_n_hz:=400.0"], "omega_n_hz"), (["-p", "ins_rate_hz:=300.0"], "ins_rate_hz"),
                        (["-p", "anti_windup:=magic"], "anti_windup")):
        result = subprocess.run([str(VENV_BIN / "los_rate_controller"), "--ros-args", *args], env=ros_domain_env,
                                capture_output=True, text=True, timeout=60)
        assert result.returncode == 2 and named in result.stderr, result.stderr


def test_nan_holds_the_command_malformed_bytes_are_counted_and_each_step_waits(ros_domain_env):
    """In-process node fed serialized inputs as its raw subscriptions deliver them: a step's
    command waits for its gyro and encoders (and the INS at INS steps); a NaN gyro holds the
    last command and is counted; bytes that are not the message are ignored and counted."""
    import math

    import rclpy
    from rclpy.context import Context

    from gimbal_control.los_rate_controller_node import LosRateControllerNode
    from gimbal_kinematics.ros import messages as m
    from ros_harness import ros_args

    rate = 1000.0
    enc_names = ("turret_azimuth", "gimbal_azimuth", "gimbal_elevation")
    joints = m.joint_state_from_cdr
    context = Context()
    rclpy.init(context=context, domain_id=int(ros_domain_env["ROS_DOMAIN_ID"]))
    node = LosRateControllerNode(context=context, cli_args=ros_args({"timing": "lockstep"}), use_global_arguments=False)
    sent = []
    node.pub.publish = sent.append
    try:
        for k in range(6):
            t_ns = m.step_stamp_ns(k, rate)
            q = math.nan if k == 3 else 1e-3 * k
            node.edge.take("enc", m.joint_state_cdr(t_ns, enc_names, (0.0, 0.1, 0.2), (0.0, 0.0, 0.0)))
            if k == 0:
                assert sent == []  # step 0 is an INS step: it waits for the INS too
                node.edge.take("ins", m.imu_cdr(t_ns, "base_link_frd", orientation=(0.0, 0.0, 0.0, 1.0),
                                                angular_velocity=(0.0, 0.0, 0.0)))
            assert len(sent) == k  # the gyro of step k is still missing
            node.edge.take("gyro", m.imu_cdr(t_ns, "gimbal_inner_frd", angular_velocity=(0.0, q, -q)))
        node.edge.take("gyro", b"\x00\x01\x00\x00garbage")
        commands = [joints(data) for data in sent]
        assert [m.step_of_stamp(c.stamp_ns, rate) for c in commands] == list(range(6))
        assert commands[3].effort == commands[2].effort and commands[4].effort != commands[3].effort
        assert node.core.rejected_inputs == 1 and sum(node.edge.counts.values()) == 2
    finally:
        node.destroy_node()
        rclpy.shutdown(context=context)

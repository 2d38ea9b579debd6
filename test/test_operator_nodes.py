"""The controller node's operator input, in-process (serialized inputs as its raw
subscriptions deliver them): in free timing bad operator commands and joystick messages
are counted in /diagnostics and never acted on, and a command that stops arriving stops the
slew (``operator_deadman_stops``); in lockstep with ``operator_rate_hz`` a step waits for
the operator's command of that step. Also the operator node refuses bad parameters."""
from __future__ import annotations

import math
import subprocess

import pytest

from conftest import VENV_BIN

ENC = ("turret_azimuth", "gimbal_azimuth", "gimbal_elevation")
AZ = math.radians(5.0)


@pytest.fixture
def controller(ros_domain_env):
    import rclpy
    from rclpy.context import Context

    from gimbal_control.los_rate_controller_node import LosRateControllerNode
    from ros_harness import ros_args

    made = []

    def make(params):
        context = Context()
        rclpy.init(context=context, domain_id=int(ros_domain_env["ROS_DOMAIN_ID"]))
        node = LosRateControllerNode(context=context, cli_args=ros_args(params), use_global_arguments=False)
        made.append((node, context))
        return node

    yield make
    for node, context in made:
        node.destroy_node()
        rclpy.shutdown(context=context)


def _feed(node, k, t_ns, m, ins=True):
    node.edge.take("enc", m.joint_state_cdr(t_ns, ENC, (0.0, 0.1, 0.2), (0.0, 0.0, 0.0)))
    if ins:
        node.edge.take("ins", m.imu_cdr(t_ns, "base_link_frd", orientation=(0.0, 0.0, 0.0, 1.0),
                                        angular_velocity=(0.0, 0.0, 0.0)))
    node.edge.take("gyro", m.imu_cdr(t_ns, "gimbal_inner_frd", angular_velocity=(0.0, 0.0, 0.0)))


def test_free_timing_counts_bad_commands_and_the_deadman_in_diagnostics(controller):
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import Joy

    from gimbal_kinematics.ros import messages as m

    node = controller({"joy_topic": "/joy"})
    diags, sent = [], []
    node.edge.pubs["/diagnostics"].publish = diags.append
    operator_topic = node.get_parameter("operator_topic").value
    node.pub.publish = sent.append
    t0 = 10 * 10**9
    for k in range(1500):
        t_ns = t0 + k * 10**6
        if k == 5:
            node.edge.take(operator_topic, m.vector3_cdr(t_ns, "gimbal_inner_frd", (0.0, math.nan, 0.0)))
            node.edge.take(operator_topic, m.vector3_cdr(t_ns + 1, "gimbal_inner_frd", (0.0, 0.0, math.radians(11.0))))
            joy = Joy()
            joy.header.stamp = m.time_msg(t_ns)
            joy.axes = [0.5]  # the elevation axis (1) is missing
            node.edge.take("/joy", serialize_message(joy))
        if 10 <= k <= 100 and k % 50 == 0:  # at k = 50, 100 (20 Hz), then nothing
            node.edge.take(operator_topic, m.vector3_cdr(t_ns, "gimbal_inner_frd", (0.0, 0.0, AZ)))
        _feed(node, k, t_ns, m, ins=k % 10 == 0)
        if k == 400:  # slewing: the shaped command is in the reference
            assert node.operator.output == (0.0, AZ)
    op = node.operator
    assert (op.rejected_nonfinite, op.rejected_over_limit, op.rejected_joy, node.commands.counts["commands_accepted"]) == (1, 1, 1, 2)
    assert op.deadman_stops == 1 and op.holding
    assert op.last_stop_ns == pytest.approx(t0 + (100 + 500) * 10**6 + AZ / op.max_accel * 1e9, abs=1e3)
    assert len(sent) == 1500
    values = {kv.key: kv.value for kv in diags[-1].status[0].values}
    assert values["operator_deadman_stops"] == "1" and values["operator_rejected_over_limit"] == "1"
    assert values["operator_rejected_nonfinite"] == "1" and values["operator_rejected_joy"] == "1"


def test_lockstep_step_waits_for_the_operators_command(controller):
    from gimbal_kinematics.ros import messages as m

    node = controller({"timing": "lockstep", "operator_rate_hz": 100.0})
    sent = []
    node.pub.publish = sent.append
    for k in range(12):
        t_ns = m.step_stamp_ns(k, 1000.0)
        _feed(node, k, t_ns, m, ins=k % 10 == 0)
        if k % 10 == 0:
            assert len(sent) == k  # the operator's step: waits for its command
            node.edge.take("op", m.vector3_cdr(t_ns, "gimbal_inner_frd", (0.0, 0.0, AZ)))
        assert len(sent) == k + 1
    assert node.commands.counts["commands_accepted"] == 2 and node.operator.output[1] > 0.0


def test_operator_node_refuses_bad_parameters(ros_domain_env):
    for args, named in ((["-p", "settle_band_mrad:=2.0"], "settle_band_mrad"),
                        (["-p", "rate_hz:=300.0"], "rate_hz")):
        result = subprocess.run([str(VENV_BIN / "operator"), "--ros-args", *args], env=ros_domain_env,
                                capture_output=True, text=True, timeout=60)
        assert result.returncode == 2 and named in result.stderr, result.stderr

"""Free-timing controller input checks, in process (callbacks fed serialized messages as
their raw subscriptions deliver them): the three gyro covariance forms a reader must accept
(REP 145 large-variance marking, the older -1 with y/z variances, a driver's all-zero
"unknown"), and each kind of bad input counted and never fused."""
from __future__ import annotations

import math
from collections import ChainMap

import pytest
import rclpy
from rclpy.context import Context

from gimbal_kinematics.ros import messages as m
from ros_harness import ros_args

pytestmark = pytest.mark.ros
EPOCH_NS = 1_800_000_000_000_000_000
T_NS = 5_000_000
JOINTS = ("turret_azimuth", "gimbal_azimuth", "gimbal_elevation")
VAR = 1e-6


def test_gyro_marking_forms():
    assert m.gyro_qr_provided(m.gimbal_gyro_covariance(VAR, VAR))
    assert m.gyro_qr_provided((-1.0, 0, 0, 0, VAR, 0, 0, 0, VAR))     # older bags
    assert m.gyro_qr_provided(m.ZERO_COV)                            # a driver: "unknown"
    assert not m.gyro_qr_provided(m.NOT_PROVIDED)                    # no angular velocity at all
    assert m.gimbal_gyro_covariance(VAR, 2 * VAR) == (1e6, 0, 0, 0, VAR, 0, 0, 0, 2 * VAR)


def test_bad_inputs_are_counted_and_not_fused(ros_domain_env):
    from gimbal_control.los_rate_controller_node import LosRateControllerNode

    context = Context()
    rclpy.init(context=context, domain_id=int(ros_domain_env["ROS_DOMAIN_ID"]))
    node = LosRateControllerNode(context=context, cli_args=ros_args({"sim_rate_hz": 200.0, "ins_rate_hz": 50.0}),
                                 use_global_arguments=False)
    sent: list[bytes] = []
    node.pub.publish = sent.append
    node.edge.pubs["/diagnostics"].publish = lambda msg: None
    feed = node.edge.take

    def gyro(k, cov, q=1e-3):
        feed("gyro", m.imu_cdr(EPOCH_NS + k * T_NS, "gimbal_inner_frd", angular_velocity=(0.0, q, 0.0),
                               angular_velocity_cov=cov))

    def enc(k, names=JOINTS, angle=0.1):
        feed("enc", m.joint_state_cdr(EPOCH_NS + k * T_NS, names, (0.0, angle, 0.05), (0.0, 0.0, 0.0)))

    def ins(k, rate=0.0, cov=m.diag_cov((VAR,) * 3)):
        feed("ins", m.imu_cdr(EPOCH_NS + k * T_NS, "base_link_frd", orientation=(0, 0, 0, 1),
                              angular_velocity=(rate, 0.0, 0.0), angular_velocity_cov=cov))

    try:
        c = ChainMap(node.edge.counts, node.policy.counts)
        gate = node.policy.gate
        enc(0)
        ins(0)
        # the three accepted forms: one command each, none zeroed (inputs fresh)
        for k, cov in enumerate((m.gimbal_gyro_covariance(VAR, VAR), (-1.0, 0, 0, 0, VAR, 0, 0, 0, VAR), m.ZERO_COV)):
            gyro(k, cov)
        assert len(sent) == 3 and c["stale_commands"] == 0
        core_steps_before = node.core.last_t
        gyro(3, m.NOT_PROVIDED)                                   # covariance[0] = -1 where rates are needed
        assert c["rejected_no_rates"] == 1 and len(sent) == 3 and node.core.last_t == core_steps_before
        enc(3, names=("a", "b", "c"))                             # JointState without the expected joints
        assert c["rejected_joint_names"] == 1
        enc(4, angle=math.nan)                                    # a NaN in a field
        ins(4, rate=math.inf)
        assert c["rejected_nonfinite"] == 2 and gate.accepted["enc"] == 1 and gate.accepted["ins"] == 1
        ins(5, cov=m.NOT_PROVIDED)                                # INS without angular velocity
        assert c["rejected_no_rates"] == 2
        gyro(2, m.gimbal_gyro_covariance(VAR, VAR))               # a duplicate stamp
        gyro(1, m.gimbal_gyro_covariance(VAR, VAR))               # a stamp going backwards
        assert gate.duplicates == 1 and gate.out_of_order == 1 and len(sent) == 3
        gyro(6, m.gimbal_gyro_covariance(VAR, VAR), q=math.nan)   # NaN gyro: the core holds the command
        assert c["rejected_nonfinite"] == 3 and node.core.rejected_inputs == 1
        assert m.joint_state_from_cdr(sent[-1]).effort == m.joint_state_from_cdr(sent[-2]).effort
        feed("gyro", b"\x00\x01")                            # not a message at all
        assert c["malformed"] == 1
    finally:
        node.destroy_node()
        rclpy.shutdown(context=context)

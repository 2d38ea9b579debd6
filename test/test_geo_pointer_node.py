"""The geo_pointer node: bad targets refused at start-up by name, and in lockstep one command
per INS step equal to its core's, with a NaN target message counted and never used."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from ros_harness import harness_node, spin_until, start_refused

pytestmark = pytest.mark.ros

VEHICLE = [39.9, 32.8, 900.0]
TARGET = [39.913504, 32.829234, 1050.7]


def test_a_target_at_the_vehicle_is_refused_at_startup(ros_domain_env):
    result = start_refused("geo_pointer", {"target_llh_deg": VEHICLE, "vehicle_llh_deg": VEHICLE}, ros_domain_env)
    assert result.returncode == 2 and "target_llh_deg" in result.stderr, result.stderr


def test_lockstep_commands_match_the_core_and_a_nan_target_is_counted(ros_domain_env):
    from geometry_msgs.msg import Vector3Stamped
    from rclpy.parameter import Parameter
    from sensor_msgs.msg import Imu, JointState, NavSatFix

    from gimbal_control.geo_pointer import GeoPointer, GeoPointerParams
    from gimbal_control.geo_pointer_node import GeoPointerNode
    from gimbal_control.geo_pointer_params import PARAMS
    from gimbal_kinematics.params import defaults
    from gimbal_kinematics.ros import messages as sm
    from gimbal_kinematics.ros.qos import GRAPH_QOS

    with harness_node(int(ros_domain_env["ROS_DOMAIN_ID"])) as (harness, executor):
        with pytest.raises(ValueError, match="target_llh_deg"):
            GeoPointerNode(context=harness.context, parameter_overrides=[
                Parameter("target_llh_deg", value=[math.nan, 32.8, 900.0]),
                Parameter("vehicle_llh_deg", value=VEHICLE)])
        node = GeoPointerNode(context=harness.context, parameter_overrides=[
            Parameter("timing", value="lockstep"), Parameter("target_llh_deg", value=TARGET),
            Parameter("vehicle_llh_deg", value=VEHICLE)])
        executor.add_node(node)
        try:
            pubs = {t: harness.create_publisher(c, t, GRAPH_QOS) for t, c in (
                ("/gyro_bias_ekf/attitude", Imu), ("/ins/imu", Imu), ("/gimbal/joint_states", JointState))}
            pub_target = harness.create_publisher(NavSatFix, "/geo_pointer/target", GRAPH_QOS)
            got = []
            harness.create_subscription(Vector3Stamped, "/operator/los_rate", lambda m: got.append(
                (m.header.stamp.sec * 10**9 + m.header.stamp.nanosec, m.vector.y, m.vector.z)), GRAPH_QOS)
            assert spin_until(executor, lambda: node.pub_cmd.get_subscription_count() > 0
                              and all(p.get_subscription_count() > 0 for p in pubs.values())
                              and pub_target.get_subscription_count() > 0, 30.0)
            pub_target.publish(sm.navsat_fix_msg(0, "earth", math.nan, 0.5, 10.0))
            assert spin_until(executor, lambda: node.core.counts["rejected_targets"] == 1, 30.0)
            core = GeoPointer(GeoPointerParams.from_values(
                defaults(PARAMS) | {"target_llh_deg": TARGET, "vehicle_llh_deg": VEHICLE}))
            rng = np.random.default_rng(5)
            expected = []
            for k in range(0, 30):  # encoders every step, attitude and INS every 10th (1 kHz, 100 Hz)
                t_ns = sm.step_stamp_ns(k, 1000.0)
                psi_t = 0.01 * k
                pubs["/gimbal/joint_states"].publish(sm.joint_state_msg(
                    t_ns, ("turret_azimuth", "gimbal_azimuth", "gimbal_elevation"), (psi_t, 1.0, 0.05), (0.0,) * 3))
                if k % 10:
                    continue
                q_nm = Rotation.from_euler("ZYX", rng.normal(0.0, 0.5, 3)).as_quat()
                q_nb = Rotation.from_euler("ZYX", rng.normal(0.0, 0.03, 3)).as_quat()
                pubs["/gyro_bias_ekf/attitude"].publish(sm.imu_msg(t_ns, "map_ned", orientation=q_nm))
                pubs["/ins/imu"].publish(sm.imu_msg(t_ns, "base_link_frd", orientation=q_nb,
                                                    angular_velocity=(0.0, 0.0, 0.0)))
                out = core.step(q_nm, Rotation.from_quat(q_nb).as_matrix(), psi_t)
                expected.append((t_ns, *out.command))
            assert spin_until(executor, lambda: len(got) >= 3, 30.0)
            assert [g[0] for g in got] == [e[0] for e in expected]
            assert np.allclose([g[1:] for g in got], [e[1:] for e in expected], rtol=0.0, atol=1e-12)
        finally:
            executor.remove_node(node)
            node.destroy_node()

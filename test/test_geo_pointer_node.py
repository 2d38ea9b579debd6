"""The geo_pointer node: bad targets refused at start-up by name, and in lockstep one command
per INS step equal to its core's, with a NaN target message counted and never used; in free
timing the vehicle's INS position (NavSatFix) used, and bad fixes counted and never used."""
from __future__ import annotations

import contextlib
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
    from gimbal_kinematics.params.table import defaults
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
            assert spin_until(executor, lambda: node.edge.pubs[node.operator_topic].get_subscription_count() > 0
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


@contextlib.contextmanager
def _free_pointer(env, extra: dict):
    """A free-timing geo_pointer taking the vehicle's fix from /ins/fix (and ``extra``), a
    source node on its context to publish to it, and the executor; the command and
    /diagnostics publishers captured (``node.sent``, ``node.diags``)."""
    import rclpy
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node

    from gimbal_control.geo_pointer_node import GeoPointerNode
    from ros_harness import ros_args

    params = {"timing": "free", "target_llh_deg": TARGET, "vehicle_llh_deg": VEHICLE, "vehicle_fix_topic": "/ins/fix",
              "diagnostics_period_s": 0.001, **extra}
    context = Context()
    rclpy.init(context=context, domain_id=int(env["ROS_DOMAIN_ID"]))
    node = GeoPointerNode(context=context, cli_args=ros_args(params), use_global_arguments=False)
    source = Node("vehicle_source", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    try:
        node.sent, node.diags = [], []
        node.edge.pubs[node.operator_topic].publish = node.sent.append
        node.edge.pubs["/diagnostics"].publish = node.diags.append
        yield node, source, executor
    finally:
        executor.shutdown()
        source.destroy_node()
        node.destroy_node()
        rclpy.shutdown(context=context)


def _reference():
    from gimbal_control.geo_pointer import GeoPointer, GeoPointerParams
    from gimbal_control.geo_pointer_params import PARAMS
    from gimbal_kinematics.params.table import defaults

    return GeoPointer(GeoPointerParams.from_values(defaults(PARAMS) | {"target_llh_deg": TARGET,
                                                                      "vehicle_llh_deg": VEHICLE}))


def _measurements(node, sm, t_ns: int) -> None:
    """The step's encoders and INS attitude, serialized as the raw subscriptions deliver them."""
    node.edge.take("enc", sm.joint_state_cdr(t_ns, ("turret_azimuth", "gimbal_azimuth", "gimbal_elevation"),
                                             (0.0, 1.0, 0.05), (0.0,) * 3))
    node.edge.take("ins", sm.imu_cdr(t_ns, "base_link_frd", orientation=(0.0, 0.0, 0.0, 1.0),
                                     angular_velocity=(0.0, 0.0, 0.0)))


def _commands(node, sm) -> list[tuple[int, float, float]]:
    return [(c.stamp_ns, c.vector[1], c.vector[2]) for c in map(sm.vector3_stamped_from_cdr, node.sent)]


P1 = (math.radians(39.905), math.radians(32.81), 905.0)  # 1 km from vehicle_llh_deg
P2 = (math.radians(39.906), math.radians(32.812), 906.0)
Q_NM = Rotation.from_euler("ZYX", [1.0, 0.05, 0.0]).as_quat()


def test_free_timing_bad_fixes_are_counted_and_never_used(ros_domain_env):
    """The vehicle's INS position over a plain rclpy publisher; the attitude, INS and encoders
    handed in serialized, so each step is taken in a known order. Each command equals a
    core's stepped on the good fixes only; a NaN fix, a STATUS_NO_FIX one, one out of order
    and one stale on arrival are counted in /diagnostics; with no fresh fix the node
    publishes nothing."""
    from sensor_msgs.msg import NavSatFix, NavSatStatus

    from gimbal_kinematics.ros import messages as sm
    from gimbal_kinematics.ros.qos import GRAPH_QOS

    with _free_pointer(ros_domain_env, {}) as (node, source, executor):
        pub = source.create_publisher(NavSatFix, "/ins/fix", GRAPH_QOS)
        assert spin_until(executor, lambda: pub.get_subscription_count() > 0, 30.0)
        ref, fixed_site = _reference(), _reference()
        counts = lambda: (node.edge.counts["fixes_no_fix"], node.edge.counts["fixes_out_of_order"],  # noqa: E731
                          node.edge.counts["stale_fixes"], node.core.counts["rejected_fixes"])

        def fix(t_ns, llh, status=NavSatStatus.STATUS_FIX):
            msg = sm.navsat_fix_msg(t_ns, "earth", *llh)
            msg.status.status = status
            before = (node.arrivals.last("fix"), counts())
            pub.publish(msg)
            assert spin_until(executor, lambda: (node.arrivals.last("fix"), counts()) != before, 30.0)

        t0, expected = 10 * 10**9, []
        for k in range(27):
            t_ns = t0 + k * 10**7  # 100 Hz
            _measurements(node, sm, t_ns)
            position = P1
            if k == 0:
                fix(t_ns, P1)
            elif k == 1:
                fix(t_ns, (math.nan, P2[1], P2[2]))  # not finite
            elif k == 2:
                fix(t_ns, P2, NavSatStatus.STATUS_NO_FIX)
            elif k == 3:
                fix(t0, P2)  # the stamp of the fix in use again: out of order
            elif k == 25:
                fix(t0 + 2 * 10**7, P2)  # after the last fix, 0.23 s before the newest estimate: stale
            elif k == 26:
                fix(t_ns, P2)
                position = P2
            node.edge.take("att", sm.imu_cdr(t_ns, "map_ned", orientation=Q_NM))
            if k <= 20 or k == 26:  # the fix of k = 0 is 0.21 s old at k = 21: stale, no command
                assert ref.set_vehicle(position)
                expected.append((t_ns, *ref.step(Q_NM, np.eye(3), 0.0).command))
        assert counts() == (1, 1, 1, 1)
        got = _commands(node, sm)
        assert [g[0] for g in got] == [e[0] for e in expected]
        assert np.allclose([g[1:] for g in got], [e[1:] for e in expected], rtol=0.0, atol=1e-12)
        site = fixed_site.step(Q_NM, np.eye(3), 0.0).command  # the fix moved the LOS: not the parameter's site
        assert abs(got[0][2] - site[1]) > 1e-3
        values = {kv.key: kv.value for kv in node.diags[-1].status[0].values}
        assert (values["fixes_no_fix"], values["fixes_out_of_order"], values["stale_fixes"],
                values["rejected_fixes"]) == ("1", "1", "1", "1")
        assert int(values["stale_commands"]) == 5  # k = 21..25


def test_free_timing_the_velocity_is_fed_forward_and_a_bad_one_counted(ros_domain_env):
    """With vehicle_velocity_topic, no command before the first velocity; then each command
    is the core's with the fix and the velocity; a non-finite velocity is counted, not used."""
    from geometry_msgs.msg import Vector3Stamped
    from sensor_msgs.msg import NavSatFix

    from gimbal_kinematics.ros import messages as sm
    from gimbal_kinematics.ros.qos import GRAPH_QOS

    with _free_pointer(ros_domain_env, {"vehicle_velocity_topic": "/ins/velocity"}) as (node, source, executor):
        pub_fix = source.create_publisher(NavSatFix, "/ins/fix", GRAPH_QOS)
        pub_vel = source.create_publisher(Vector3Stamped, "/ins/velocity", GRAPH_QOS)
        assert spin_until(executor, lambda: pub_fix.get_subscription_count() > 0
                          and pub_vel.get_subscription_count() > 0, 30.0)
        ref, expected, v_good = _reference(), [], (3.0, 15.0, 0.0)
        t0 = 10 * 10**9
        for k, vel in enumerate((None, v_good, (math.inf, 0.0, 0.0))):
            t_ns = t0 + k * 10**7
            _measurements(node, sm, t_ns)
            before = (node.arrivals.last("fix"), node.arrivals.last("vel"), node.edge.counts["rejected_velocities"])
            pub_fix.publish(sm.navsat_fix_msg(t_ns, "earth", *P1))
            if vel is not None:
                pub_vel.publish(sm.vector3_msg(t_ns, "ned", vel))
            assert spin_until(executor, lambda: (node.arrivals.last("fix"), node.arrivals.last("vel"),
                                                 node.edge.counts["rejected_velocities"]) != before
                              and node.arrivals.last("fix") == t_ns and (vel is None or node.arrivals.last("vel") == t_ns
                                                                    or node.edge.counts["rejected_velocities"]), 30.0)
            node.edge.take("att", sm.imu_cdr(t_ns, "map_ned", orientation=Q_NM))
            if k >= 1:  # k = 0: no velocity yet, no command; k = 2: the good one of k = 1 (10 ms old)
                assert ref.set_vehicle(P1, v_good)
                expected.append((t_ns, *ref.step(Q_NM, np.eye(3), 0.0).command))
        got = _commands(node, sm)
        assert node.edge.counts["rejected_velocities"] == 1
        assert [g[0] for g in got] == [e[0] for e in expected]
        assert np.allclose([g[1:] for g in got], [e[1:] for e in expected], rtol=0.0, atol=1e-12)
        still = _reference()
        assert still.set_vehicle(P1)
        assert abs(got[0][2] - still.step(Q_NM, np.eye(3), 0.0).command[1]) > 1e-4  # the velocity mattered


def test_vehicle_fix_in_lockstep_or_a_velocity_alone_is_refused_at_startup(ros_domain_env):
    for extra, named in (({"timing": "lockstep", "vehicle_fix_topic": "/ins/fix"}, "vehicle_fix_topic"),
                         ({"vehicle_velocity_topic": "/ins/velocity"}, "vehicle_velocity_topic")):
        result = start_refused("geo_pointer", {"target_llh_deg": TARGET, "vehicle_llh_deg": VEHICLE, **extra},
                               ros_domain_env)
        assert result.returncode == 2 and named in result.stderr, result.stderr

"""The ``platform_navigator`` node (paper 3 §4.3) through the ROS graph.

The node runs in this process on the harness's Context; plain rclpy publishers send it the
platform accelerometers and the azimuth resolver as sensor_models publishes them. Its
outputs are checked against closed forms written here from the WGS-84 constants (not from
gimbal_kinematics.maths.earth): at rest the command rate is the earth rate; a constant north
specific force ∇ on a platform turning at 1.2 °/s gives v_N = ∇t, ΔL = ∇t²/2R_M and a
transport rate −v_N/R_M about east, which only holds if the node resolves the
accelerometers through the resolver angle. Bad input (NaN, repeated and backward stamps,
a resolver message without the azimuth joint) is counted and never integrated.
"""
from __future__ import annotations

import math

import pytest
from geometry_msgs.msg import Vector3Stamped
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, JointState, NavSatFix

from gimbal_estimators.platform_navigator_node import PlatformNavigatorNode
from gimbal_kinematics.ros import messages as m
from gimbal_kinematics.ros.qos import GRAPH_QOS
from ros_harness import harness_node, spin_until, start_refused

pytestmark = pytest.mark.ros

RATE = 10.0
LAT_DEG, LON_DEG = 40.0, 116.0
NODE = "/platform_navigator"
OUTPUTS = {"fix": NavSatFix, "velocity": Vector3Stamped, "command_rate": Vector3Stamped, "progress": Clock}
# WGS-84 (NIMA TR8350.2): semi-major axis, first eccentricity², earth rate, Somigliana gravity
A_WGS84, E2 = 6378137.0, 6.69437999014e-3
OMEGA = 7.292115e-5
GAMMA_E, K_SOMIGLIANA = 9.7803253359, 0.00193185265241
RATE_DEG_S = 1.2


def meridian_radius_ref(lat: float) -> float:
    return A_WGS84 * (1 - E2) / (1 - E2 * math.sin(lat) ** 2) ** 1.5


def prime_vertical_ref(lat: float) -> float:
    return A_WGS84 / math.sqrt(1 - E2 * math.sin(lat) ** 2)


def gravity_ref(lat: float) -> float:
    s2 = math.sin(lat) ** 2
    return GAMMA_E * (1 + K_SOMIGLIANA * s2) / math.sqrt(1 - E2 * s2)


def specific_force_s(psi: float, f_n) -> tuple[float, float, float]:
    """f_s = rot3(ψ) f_n: a level platform at azimuth ψ about NED down."""
    c, s = math.cos(psi), math.sin(psi)
    return c * f_n[0] + s * f_n[1], -s * f_n[0] + c * f_n[1], f_n[2]


class Rig:
    """The node under test and a harness node (publishers of its inputs, subscribers of its
    outputs) on one Context and executor."""

    def __init__(self, node, harness, executor, joint_topic: str = "/platform/resolvers"):
        self.node, self.executor = node, executor
        self.pub_joint = harness.create_publisher(JointState, joint_topic, GRAPH_QOS)
        self.pub_imu = harness.create_publisher(Imu, "/platform/imu", GRAPH_QOS)
        self.got: dict[str, list] = {k: [] for k in OUTPUTS}
        for name, typ in OUTPUTS.items():
            harness.create_subscription(typ, f"{NODE}/{name}", lambda msg, n=name: self.got[n].append(msg), GRAPH_QOS)
        assert spin_until(executor, lambda: self.pub_joint.get_subscription_count()
                          and self.pub_imu.get_subscription_count(), 30.0)

    def send(self, k: int, psi: float, f_s, joint: str = "platform_azimuth", wait: bool = True) -> None:
        """Step ``k``: the resolver (θ_a, its rate) then the accelerometers; spin until the
        node has answered with its command rate for the step."""
        t_ns = m.step_stamp_ns(k, RATE)
        want = len(self.got["command_rate"]) + 1
        self.pub_joint.publish(m.joint_state_msg(t_ns, (joint,), (psi,), (math.radians(RATE_DEG_S),)))
        self.pub_imu.publish(m.imu_msg(t_ns, "platform_frd", linear_acceleration=tuple(f_s)))
        if wait:
            assert spin_until(self.executor, lambda: len(self.got["command_rate"]) >= want, 30.0)
        else:
            for _ in range(5):
                self.executor.spin_once(timeout_sec=0.01)


@pytest.fixture
def rig(ros_domain_env, request):
    values = {"timing": "lockstep", "sim_rate_hz": RATE, "imu_rate_hz": RATE, "joint_rate_hz": RATE,
              "progress_every_steps": 1, "lat_deg": LAT_DEG, "lon_deg": LON_DEG, "max_joint_age_s": 0.05,
              **getattr(request, "param", {})}
    with harness_node(int(ros_domain_env["ROS_DOMAIN_ID"])) as (harness, executor):
        node = PlatformNavigatorNode(context=harness.context,
                                     parameter_overrides=[Parameter(k, value=v) for k, v in values.items()])
        executor.add_node(node)
        try:
            servo = values.get("azimuth_source") == "servo"
            yield Rig(node, harness, executor, "/platform_servo/modulation" if servo else "/platform/resolvers")
        finally:
            executor.remove_node(node)
            node.destroy_node()


def _vec(msg) -> tuple[float, float, float]:
    return msg.vector.x, msg.vector.y, msg.vector.z


def test_a_north_force_on_a_turning_platform_integrates_to_the_closed_forms(rig):
    """60 s at 10 Hz, azimuth turning at 1.2 °/s, f_n = (∇, 0, −γ(L)): v_N = ∇t exactly (the
    first sample only starts the clock), ΔL = ∇t²/(2R_M), v_E = Ω sin L ∇t² from the
    Coriolis term; the command rate is earth rate plus transport rate; NavSatFix in degrees,
    covariance unknown."""
    lat = math.radians(LAT_DEG)
    nabla = 1e-3
    f_n = (nabla, 0.0, -gravity_ref(lat))
    n = 601
    for k in range(n):
        psi = math.radians(RATE_DEG_S) * k / RATE
        rig.send(k, psi, specific_force_s(psi, f_n))
    assert spin_until(rig.executor, lambda: len(rig.got["fix"]) == n and len(rig.got["velocity"]) == n, 30.0)
    t = (n - 1) / RATE
    vn, ve, vd = _vec(rig.got["velocity"][-1])
    assert vn == pytest.approx(nabla * t, rel=1e-4)
    assert ve == pytest.approx(OMEGA * math.sin(lat) * nabla * t**2, rel=0.02)  # deflected to the right
    assert abs(vd) < 1e-4
    fix = rig.got["fix"][-1]
    rm, rn = meridian_radius_ref(lat), prime_vertical_ref(lat)
    assert math.radians(fix.latitude - LAT_DEG) * rm == pytest.approx(nabla * t**2 / 2, rel=1e-3)
    assert abs(math.radians(fix.longitude - LON_DEG) * rn * math.cos(lat)) < 0.05 * nabla * t**2
    assert abs(fix.altitude) < 1e-2
    assert fix.header.frame_id == "map_ned" and m.stamp_ns(fix.header.stamp) == m.step_stamp_ns(n - 1, RATE)
    assert fix.position_covariance_type == NavSatFix.COVARIANCE_TYPE_UNKNOWN
    wn, we, wd = _vec(rig.got["command_rate"][-1])
    lat_now = math.radians(fix.latitude)
    assert wn == pytest.approx(OMEGA * math.cos(lat_now) + ve / rn, rel=1e-6)
    assert we == pytest.approx(-vn / rm, rel=1e-3)
    assert wd == pytest.approx(-OMEGA * math.sin(lat_now) - ve * math.tan(lat_now) / rn, rel=1e-6)
    # pacing: every step names the next one it needs
    assert spin_until(rig.executor, lambda: m.stamp_ns(rig.got["progress"][-1].clock) == m.step_stamp_ns(n, RATE),
                      30.0)


def test_at_rest_the_command_is_the_earth_rate_and_bad_input_is_never_integrated(rig):
    """Level and at rest: velocity stays 0 and the command is (Ω cos L, 0, −Ω sin L). A NaN
    sample, a repeated stamp, a backward stamp and a resolver message without the azimuth
    joint (the step's sample then has no angle within max_joint_age_s) are counted and not
    integrated; each refused step still gets a command rate, so a waiting servo never stalls."""
    lat = math.radians(LAT_DEG)
    f_n = (0.0, 0.0, -gravity_ref(lat))
    rest = lambda k: specific_force_s(0.0, f_n)  # noqa: E731
    for k in range(4):
        rig.send(k, 0.0, rest(k))
    rig.send(4, 0.0, (math.nan, 0.0, -9.8))
    rig.send(5, 0.0, rest(5), joint="elsewhere")
    for k in range(6, 10):
        rig.send(k, 0.0, rest(k))
    rig.send(9, 0.0, (5.0, 5.0, -9.8), wait=False)  # step 9 again (repeated stamps): refused
    rig.send(2, 0.0, (5.0, 5.0, -9.8), wait=False)  # back to step 2: refused
    node, core = rig.node, rig.node.core
    assert core.rejected_nonfinite == 1 and core.rejected_no_resolver == 1 and node.edge.counts["rejected_joints"] == 1
    assert node.policy.sync.rejected >= 2 and core.accepted == 8 and core.resets == 0
    assert len(rig.got["command_rate"]) == 10 and len(rig.got["velocity"]) == 8
    for msg in rig.got["velocity"]:
        assert max(abs(v) for v in _vec(msg)[:2]) < 1e-12 and abs(msg.vector.z) < 1e-6
    wn, we, wd = _vec(rig.got["command_rate"][-1])
    assert (wn, we, wd) == pytest.approx((OMEGA * math.cos(lat), 0.0, -OMEGA * math.sin(lat)), rel=1e-9, abs=1e-15)
    assert rig.got["fix"][-1].latitude == pytest.approx(LAT_DEG, abs=1e-12)


def test_free_timing_reports_the_counters_on_diagnostics(ros_domain_env):
    """timing free: epoch stamps, a repeated and a NaN sample; /diagnostics carries the core's
    and the streams' counters and warns."""
    from diagnostic_msgs.msg import DiagnosticStatus

    with harness_node(int(ros_domain_env["ROS_DOMAIN_ID"])) as (harness, _):
        node = PlatformNavigatorNode(context=harness.context, parameter_overrides=[
            Parameter("timing", value="free"), Parameter("lat_deg", value=LAT_DEG),
            Parameter("max_sync_wait_s", value=0.0)])
        try:
            g = gravity_ref(math.radians(LAT_DEG))
            t0 = 1_764_000_000_000_000_000
            for i in range(6):
                t_ns = t0 + i * 10_000_000
                f = (math.nan, 0.0, -g) if i == 3 else (0.0, 0.0, -g)
                node._on_input("joint", m.joint_state_msg(t_ns, ("platform_azimuth",), (0.0,), (0.0,)))
                node._on_input("imu", m.imu_msg(t_ns, "platform_frd", linear_acceleration=f))
            node._on_input("imu", m.imu_msg(t0 + 50_000_000, "platform_frd", linear_acceleration=(0, 0, -g)))
            status = node.health(t0 + 60_000_000).status[0]
            values = {kv.key: kv.value for kv in status.values}
            assert values["accepted"] == "5" and values["rejected_nonfinite"] == "1"
            assert values["imu_duplicates"] == "1" and values["rejected_out_of_order"] == "1"
            assert status.level == DiagnosticStatus.WARN
            # a bag looping (a minute back): the input policy resets the core to the hand-off
            for i in range(4):
                t_ns = t0 - 60 * 10**9 + i * 10_000_000
                node._on_input("joint", m.joint_state_msg(t_ns, ("platform_azimuth",), (0.0,), (0.0,)))
                node._on_input("imu", m.imu_msg(t_ns, "platform_frd", linear_acceleration=(0.0, 0.0, -g)))
            assert node.core.resets == 1 and "clock jumped back" in node.core.reset_reasons[0]
        finally:
            node.destroy_node()


@pytest.mark.parametrize("args,named", [
    ({"imu_rate_hz": 300.0}, "imu_rate_hz"),
    ({"lat_deg": 89.5}, "lat_deg"),
    ({"vertical_tau_s": 0.0}, "vertical_tau_s"),
    ({"accel_bias_ug": [1.0, 2.0]}, "accel_bias_ug"),
    ({"fix_every_samples": 0}, "fix_every_samples"),
    ({"azimuth_source": "gyro"}, "azimuth_source"),
    ({"odom_frame_id": " "}, "odom_frame_id"),
    ({"odom_child_frame_id": "odom"}, "odom_child_frame_id"),
    ({"odom_cep_rate_nmi_h": -1.0}, "odom_cep_rate_nmi_h"),
])
def test_bad_parameters_are_refused_naming_them(args, named, ros_domain_env):
    result = start_refused("platform_navigator", args, ros_domain_env)
    assert result.returncode == 2 and named in result.stderr, result.stderr


@pytest.mark.parametrize("rig", [{"timing": "free", "azimuth_source": "servo", "base_heading_deg": 30.0}],
                         indirect=True)
def test_azimuth_from_the_servo_angle(rig):
    """azimuth_source servo (free timing): ψ̂ = φz from /platform_servo/modulation (joint
    modulation_angle) + base_heading_deg; a north force on the platform turning at 1.2 °/s
    from 30° integrates to v_N = ∇t, nothing east beyond the Coriolis term (the core's state:
    the harness's reliable subscriptions do not match free timing's outputs)."""
    lat = math.radians(LAT_DEG)
    nabla = 1e-3
    f_n = (nabla, 0.0, -gravity_ref(lat))
    n = 51
    for k in range(n):
        phi = math.radians(RATE_DEG_S) * k / RATE
        rig.send(k, phi, specific_force_s(phi + math.radians(30.0), f_n), joint="modulation_angle", wait=False)
    core = rig.node.core
    assert spin_until(rig.executor, lambda: core.accepted == n, 30.0), core.counters()
    t = (n - 1) / RATE
    assert core.vn == pytest.approx(nabla * t, rel=1e-4)
    assert abs(core.ve) < 1e-3 * nabla * t  # Coriolis: Ω sin L ∇t² is 1.2e-5 of ∇t here
    assert core.rejected_no_resolver == 0 and rig.node.edge.counts["rejected_joints"] == 0


def _ship_samples(duration_s: float) -> list[tuple]:
    """Per step of ``ship_rotation_on`` on the engine: the platform accelerometers' sample,
    the servo's φz made for the next step (``~/modulation_next``: stamp, φz, φ̇z), the true
    platform attitude (x, y, z, w) and azimuth resolver angle."""
    import dataclasses

    from gimbal_sim.core.core_loop import core_plan, run_stages
    from gimbal_sim.graph.scenario import load, variant
    scenario = dataclasses.replace(variant(load("rotational_ins_navigation"), "ship_rotation_on"), duration_s=duration_s)
    vehicle, controlled, stages = core_plan(scenario)
    rows = []
    run_stages(vehicle, stages, controlled=controlled, observer=lambda bus: rows.append((
        bus.platform_imu.specific_force, bus.modulation_next, tuple(bus.truth.quat_nm.tolist()),
        bus.truth.joint_position[0])))
    return rows


def test_in_lockstep_on_the_ship_the_azimuth_is_the_servos_phi_z(ros_domain_env):
    """``azimuth_source: servo`` in lockstep on paper 5's ship (roll 5°/10 s, pitch 3°/6 s,
    heading 3°/15 s): the engine's 1 kHz run of ship_rotation_on gives the node its
    accelerometers and the servo's ``~/modulation_next`` as the graph does (φz of step k made
    by the servo's step k − 1, stamped k). The first sample has no φz and is refused,
    counted; every later ψ̂ is within 40″ of the true platform azimuth (the yaw of the
    stable element's attitude, from the quaternion here; 29.8″ in the servo's start
    transient), within 2″ after 0.3 s (0.95″: the servo's azimuth error), while the
    resolver's θ_a is off by the hull's heading (1.76° at the end)."""
    rate, n = 1000.0, 1500
    rows = _ship_samples(n / rate)
    values = {"timing": "lockstep", "sim_rate_hz": rate, "imu_rate_hz": rate, "joint_rate_hz": rate,
              "progress_every_steps": 1, "lat_deg": 40.0, "lon_deg": 0.0, "azimuth_source": "servo"}
    from gimbal_estimators import navigator_kernels as nk
    errors = []
    with harness_node(int(ros_domain_env["ROS_DOMAIN_ID"])) as (harness, executor):
        node = PlatformNavigatorNode(context=harness.context,
                                     parameter_overrides=[Parameter(k, value=v) for k, v in values.items()])
        executor.add_node(node)
        try:
            pub_joint = harness.create_publisher(JointState, "/platform_servo/modulation_next", GRAPH_QOS)
            pub_imu = harness.create_publisher(Imu, "/platform/imu", GRAPH_QOS)
            assert spin_until(executor, lambda: pub_joint.get_subscription_count() and pub_imu.get_subscription_count(),
                              30.0)
            core = node.core
            for k, (f, _, q, _) in enumerate(rows[:n]):
                if k > 0:
                    stamp, phi, phi_rate = rows[k - 1][1]
                    assert stamp == m.step_stamp_ns(k, rate)
                    pub_joint.publish(m.joint_state_msg(stamp, ("modulation_angle",), (phi,), (phi_rate,)))
                pub_imu.publish(m.imu_msg(m.step_stamp_ns(k, rate), "platform_frd", linear_acceleration=tuple(f)))
                assert spin_until(executor, lambda: core.accepted + core.rejected_no_resolver == k + 1, 30.0)
                if k > 0:
                    x, y, z, w = q
                    truth = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
                    errors.append(math.remainder(core.state[nk.N_PSI] - truth, 2.0 * math.pi))
        finally:
            executor.remove_node(node)
            node.destroy_node()
    assert core.rejected_no_resolver == 1 and core.accepted == n - 1
    arcsec = [abs(e) * 180.0 / math.pi * 3600.0 for e in errors]  # errors[i]: step i + 1
    assert max(arcsec) < 40.0 and max(arcsec[299:]) < 2.0, (max(arcsec), max(arcsec[299:]))
    x, y, z, w = rows[n - 1][2]
    truth = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    assert abs(rows[n - 1][3] - truth) > math.radians(1.0)  # θ_a + a fixed heading: off by the hull's heading

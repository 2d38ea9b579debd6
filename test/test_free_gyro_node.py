"""The ``free_gyro_positioning`` node (paper 4) through the ROS graph.

In-process tests run the node on the harness's own Context and feed it read-outs made by
the free-gyro sensor core, published as the sensor_models node publishes them; its
outputs must equal the core's for the same stream (NaN and out-of-order inputs included),
degenerate geometry must yield no NavSatFix, and a clock jump back must reset it. The
slow test runs the ``free_gyro_positioning`` scenario and reads the bag back with rosbags
and mcap.
"""
from __future__ import annotations

import math
import subprocess

import numpy as np
import pytest
import yaml
from geometry_msgs.msg import Vector3Stamped
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rclpy.parameter import Parameter
from rosbags.highlevel import AnyReader
from rosgraph_msgs.msg import Clock
from scipy.spatial.transform import Rotation
from sensor_msgs.msg import Imu, NavSatFix

from conftest import VENV_BIN
from gimbal_estimators.free_gyro_positioning import FreeGyroPositioning, FreeGyroPositioningParams
from gimbal_estimators.free_gyro_positioning_node import VELOCITY, FreeGyroPositioningNode
from gimbal_kinematics.maths.earth import OMEGA_IE, meridian_radius, prime_vertical_radius
from gimbal_kinematics.maths.rotations import euler321_from_quat, euler321_to_quat
from gimbal_kinematics.ros import messages as m
from gimbal_kinematics.ros.qos import GRAPH_QOS
from gimbal_sim.experiments.free_gyro import make_spin_axes, simulate_truth
from gimbal_sim.experiments.free_gyro_errors import DEFAULTS
from gimbal_sim.graph.scenario import BUILTIN_DIR, load
from gimbal_sim.nodes import sensor_models_node
from gimbal_sim.world.sensors.free_gyro_sensor import FreeGyroSensor, FreeGyroSensorParams
from imu_grades import no_grade_args
from ros_harness import harness_node, spin_until

pytestmark = pytest.mark.ros

LAT, LON = 35.0, 129.0
RATE = 10.0
NADIR, AZIMUTH = (60.0, 50.0), (-40.0, 50.0)
NODE = "/free_gyro_positioning"
ARCSEC = math.radians(1.0 / 3600.0)
OUTPUTS = {"fix": NavSatFix, "heading": Vector3Stamped, "geometry": Vector3Stamped, "nadir": Vector3Stamped,
           "heading_earth_rate": Vector3Stamped, "progress": Clock, "predicted_nadir": Vector3Stamped,
           "predicted_position": Vector3Stamped, "predicted_heading": Vector3Stamped}


def node_params(**overrides) -> list[Parameter]:
    values = {"timing": "lockstep", "sim_rate_hz": RATE, "progress_every_steps": 1, "spin_nadir_deg": list(NADIR),
              "spin_azimuth_deg": list(AZIMUTH), "spin_reference_lat_deg": LAT, "spin_reference_lon_deg": LON,
              "heading_window_s": 20.0, **overrides}
    return [Parameter(k, value=v) for k, v in values.items()]


def readouts(duration_s: float, azimuth=AZIMUTH, seed: int = 7) -> list:
    """Free-gyro sensor samples on the rolling paper5_ship at (LAT, LON)."""
    truth = simulate_truth("paper5_ship", LAT, LON, duration_s, RATE, {"mean_heading_deg": 40.0})
    u_a, u_b = make_spin_axes(LAT, LON, 0.0, NADIR, azimuth)
    sensor = FreeGyroSensor(FreeGyroSensorParams(u_a, u_b, pickoff_noise_arcsec=5.0),
                            np.random.default_rng(seed), 1.0 / RATE)
    return [sensor.update_from_truth(tr, math.radians(LAT), math.radians(LON), 1.0 / RATE) for tr in truth]


def messages_of(s, t_ns: int) -> tuple:
    """(spin_a, spin_b, imu) as sensor_models publishes them."""
    return (m.vector3_msg(t_ns, "base_link_frd", s.spin_a_b), m.vector3_msg(t_ns, "base_link_frd", s.spin_b_b),
            m.imu_msg(t_ns, "base_link_frd", orientation=euler321_to_quat(s.roll, s.pitch, 0.0),
                      angular_velocity=s.omega_ib_b))


class Rig:
    """The node under test and a harness node (publishers of its inputs, subscribers of its
    outputs) on one Context and executor."""

    def __init__(self, node, harness, executor):
        self.node, self.executor = node, executor
        self.pubs = [harness.create_publisher(Vector3Stamped, "/free_gyro/spin_axis_a", GRAPH_QOS),
                     harness.create_publisher(Vector3Stamped, "/free_gyro/spin_axis_b", GRAPH_QOS),
                     harness.create_publisher(Imu, "/free_gyro/imu", GRAPH_QOS)]
        if node.velocity_input:
            self.pubs.append(harness.create_publisher(Vector3Stamped, "/free_gyro/velocity", GRAPH_QOS))
        self.got: dict[str, list] = {k: [] for k in OUTPUTS}
        for name, typ in OUTPUTS.items():
            harness.create_subscription(typ, f"{NODE}/{name}", lambda msg, n=name: self.got[n].append(msg), GRAPH_QOS)
        assert spin_until(executor, lambda: all(p.get_subscription_count() for p in self.pubs), 30.0)
        assert spin_until(executor, lambda: self.got["progress"], 30.0)  # ready

    def send(self, msgs) -> None:
        """Publish the (spin_a, spin_b, imu) triples in order (None: not sent); after each
        full triple, spin until the node reports progress (it reports every read-out, as
        the lockstep pacing protocol has it), so no queue ever overflows."""
        for triple in msgs:
            want = len(self.got["progress"]) + 1
            for pub, msg in zip(self.pubs, triple):
                if msg is not None:
                    pub.publish(msg)
            if None in triple:
                for _ in range(5):
                    self.executor.spin_once(timeout_sec=0.01)
            else:
                assert spin_until(self.executor, lambda: len(self.got["progress"]) >= want, 30.0)


@pytest.fixture
def rig(ros_domain_env, request):
    overrides = getattr(request, "param", {})
    with harness_node(int(ros_domain_env["ROS_DOMAIN_ID"])) as (harness, executor):
        node = FreeGyroPositioningNode(context=harness.context, parameter_overrides=node_params(**overrides))
        executor.add_node(node)
        try:
            yield Rig(node, harness, executor)
        finally:
            executor.remove_node(node)
            node.destroy_node()


def test_node_equals_the_core_and_rejects_nan_and_out_of_order_inputs(rig):
    """31 s of read-outs with a NaN spin axis at step 57 and a stale spin_b message replayed
    after step 120: the node counts both, and its NavSatFix / heading / geometry equal the
    core fed the same stream (the NaN read-out rejected there too)."""
    samples = readouts(31.0)
    msgs = [messages_of(s, m.step_stamp_ns(k, RATE)) for k, s in enumerate(samples)]
    bad = list(msgs[57])
    bad[0] = m.vector3_msg(m.step_stamp_ns(57, RATE), "base_link_frd", (math.nan, 0.0, 1.0))
    msgs[57] = tuple(bad)
    stale = m.vector3_msg(m.step_stamp_ns(118, RATE), "base_link_frd", samples[118].spin_b_b)
    rig.send(msgs[:121] + [(None, stale, None)] + msgs[121:])
    assert rig.node.rejected == 2
    assert rig.node.core.counters.rejected_nonfinite == 1 and rig.node.policy.sync.rejected == 1

    core = FreeGyroPositioning(rig.node.core.params)
    fixes = []
    for k, s in enumerate(samples):
        t = m.step_stamp_ns(k, RATE) * 1e-9  # the node's stamp arithmetic
        roll, pitch, _ = euler321_from_quat(euler321_to_quat(s.roll, s.pitch, 0.0))  # the message's round trip
        core.on_level(t, roll, pitch)
        core.on_body_rates(t, s.omega_ib_b)
        spin_a = (math.nan, 0.0, 1.0) if k == 57 else s.spin_a_b
        fix = core.on_spin_axes(t, spin_a, s.spin_b_b).output
        if fix is not None:
            fixes.append(fix)
    assert len(fixes) == 3 and all(f.valid for f in fixes)
    assert fixes[0].n_samples == fixes[1].n_samples - 1  # the NaN read-out was not integrated
    assert spin_until(rig.executor, lambda: len(rig.got["fix"]) == 3 and len(rig.got["heading"]) == 3, 30.0)
    rm = meridian_radius(math.radians(LAT))
    for fix, nav, hd, geo in zip(fixes, rig.got["fix"], rig.got["heading"], rig.got["geometry"]):
        assert m.stamp_ns(nav.header.stamp) == round(fix.t * 1e9)
        assert nav.latitude == pytest.approx(math.degrees(fix.lat), abs=1e-12)
        assert nav.longitude == pytest.approx(math.degrees(fix.lon), abs=1e-12)
        assert nav.position_covariance_type == NavSatFix.COVARIANCE_TYPE_KNOWN
        assert (nav.position_covariance[4], nav.position_covariance[0]) == pytest.approx(
            (fix.cov_ne_m[0, 0], fix.cov_ne_m[1, 1]), rel=1e-12)
        # FDOP √2, σ = 5″/√n per nadir angle: each axis σ = 5″·R/√n
        sigma_n = 5.0 * math.radians(1 / 3600) / math.sqrt(fix.n_samples) * rm
        assert math.sqrt(nav.position_covariance[4]) == pytest.approx(sigma_n, rel=2e-3)
        assert abs(math.radians(nav.latitude - LAT) * rm) < 5.0 * sigma_n
        assert (hd.vector.x, hd.vector.y) == pytest.approx((fix.heading, fix.heading_sigma), abs=1e-15)
        assert (geo.vector.x, geo.vector.z) == (pytest.approx(math.sqrt(2.0), rel=1e-3), 0.0)
    # earth-rate heading windows of 20 s: one completed, against the true mean heading over it
    assert len(rig.got["heading_earth_rate"]) == 1
    er = rig.got["heading_earth_rate"][0]
    assert er.vector.x == pytest.approx(fixes[-1].heading_earth_rate, abs=1e-15)
    t_er = m.stamp_ns(er.header.stamp) * 1e-9
    yaws = [s.true_euler[2] for s in samples if abs(s.t - t_er) <= 0.5 * er.vector.z]
    mean_yaw = math.atan2(sum(map(math.sin, yaws)), sum(map(math.cos, yaws)))
    assert abs(math.remainder(er.vector.x - mean_yaw, math.tau)) < 4.0 * er.vector.y


@pytest.mark.parametrize("rig", [{"velocity_input": True, "predict_error": True, "triad_arw_deg_rt_h": 0.002}],
                         indirect=True)
def test_sailing_velocity_input_and_predicted_errors(rig):
    """A ship sailing 10 m/s on 70°, its velocity sent with each read-out: the earth-rate
    heading equals the core's given the same velocities, and the predicted errors (no bias
    source set) are FDOP²σ² with σ = 5″/√n per axis and eq. 29's (N/√T)/(Ω cos φ)."""
    truth = simulate_truth("paper5_ship", LAT, LON, 31.0, RATE, {"mean_heading_deg": 40.0})
    u_a, u_b = make_spin_axes(LAT, LON, 0.0, NADIR, AZIMUTH)
    sp = FreeGyroSensorParams(u_a, u_b, pickoff_noise_arcsec=5.0, speed_m_s=10.0, course_deg=70.0)
    sensor = FreeGyroSensor(sp, np.random.default_rng(3), 1.0 / RATE)
    samples = [sensor.update_from_truth(tr, math.radians(LAT), math.radians(LON), 1.0 / RATE) for tr in truth]
    msgs = [messages_of(s, m.step_stamp_ns(k, RATE)) + (m.vector3_msg(m.step_stamp_ns(k, RATE), "base_link_frd",
                                                                       s.velocity_n),) for k, s in enumerate(samples)]
    rig.send(msgs)
    core = FreeGyroPositioning(rig.node.core.params)
    fixes = []
    for k, s in enumerate(samples):
        t = m.step_stamp_ns(k, RATE) * 1e-9
        roll, pitch, _ = euler321_from_quat(euler321_to_quat(s.roll, s.pitch, 0.0))
        core.on_velocity(t, s.velocity_n)
        core.on_level(t, roll, pitch)
        core.on_body_rates(t, s.omega_ib_b)
        fix = core.on_spin_axes(t, s.spin_a_b, s.spin_b_b).output
        fixes += [fix] if fix is not None else []
    assert spin_until(rig.executor, lambda: len(rig.got["predicted_heading"]) == 3, 30.0)
    assert rig.got["heading_earth_rate"][0].vector.x == pytest.approx(fixes[-1].heading_earth_rate, abs=1e-15)
    lat = math.radians(LAT)
    arw = 0.002 * math.radians(1.0) / 60.0 / math.sqrt(20.0) / (OMEGA_IE * math.cos(lat))
    for fix, pos, head in zip(fixes, rig.got["predicted_position"], rig.got["predicted_heading"]):
        sigma = 5.0 * ARCSEC / math.sqrt(fix.n_samples) * meridian_radius(lat)  # FDOP √2: σ·R per axis
        assert (pos.vector.x, pos.vector.y) == pytest.approx((sigma, sigma), rel=1e-2)
        assert head.vector.y == pytest.approx(arw, rel=1e-2)
        assert head.vector.z == pytest.approx(math.sqrt(2.0) * sigma, rel=1e-2)  # eq. 38: FDOP σ_θ


@pytest.mark.parametrize("rig", [{"spin_azimuth_deg": [30.0, 30.0]}], indirect=True)
def test_degenerate_geometry_is_reported_and_no_fix_is_published(rig):
    """Spin axes set in one vertical plane: the nadir circles are tangent at the ship. Each
    window is reported on geometry with status 1 and counted; no NavSatFix, no heading."""
    samples = readouts(25.5, azimuth=(30.0, 30.0))
    rig.send([messages_of(s, m.step_stamp_ns(k, RATE)) for k, s in enumerate(samples)])
    assert spin_until(rig.executor, lambda: len(rig.got["geometry"]) >= 2, 30.0)
    for _ in range(20):  # grace for anything still in flight (there must be nothing)
        rig.executor.spin_once(timeout_sec=0.01)
    assert [g.vector.z for g in rig.got["geometry"]] == [1.0, 1.0]
    assert rig.got["fix"] == [] and rig.got["heading"] == []
    assert rig.node.degenerate == 2 and rig.node.core.counters.fixes == 0
    # with noise, nearly tangent circles either cross at a huge FDOP or miss each other
    assert any(word in rig.node.core.last_fix.reason for word in ("tangent", "FDOP", "intersect"))


def test_clock_jump_back_resets_and_fixes_resume(rig):
    """A bag loop: after 15 s the stamps start again at 0. The node resets once (counted,
    nothing rejected) and fixes the next window of the new pass."""
    samples = readouts(15.0)
    msgs = [messages_of(s, m.step_stamp_ns(k, RATE)) for k, s in enumerate(samples)]
    rig.send(msgs)
    assert spin_until(rig.executor, lambda: len(rig.got["fix"]) == 1, 30.0) and rig.node.resets == 0
    rig.send(msgs)
    assert rig.node.resets == 1 and rig.node.rejected == 0
    assert spin_until(rig.executor, lambda: len(rig.got["fix"]) == 2, 30.0)
    first, second = rig.got["fix"]
    assert (second.latitude, second.longitude) == (first.latitude, first.longitude)


@pytest.mark.parametrize("exe, args, named", [
    ("free_gyro_positioning", ["-p", "spin_nadir_deg:=[60.0]"], "spin_nadir_deg"),
    ("free_gyro_positioning", ["-p", "spin_azimuth_deg:=[10.0, .nan]"], "spin_azimuth_deg"),
    ("free_gyro_positioning", ["-p", "spin_nadir_deg:=[60.0,60.0]", "-p", "spin_azimuth_deg:=[30.0,30.0]"],
     "spin_nadir_deg"),
    ("free_gyro_positioning", ["-p", "max_fdop:=1.2"], "max_fdop"),
    ("free_gyro_positioning", ["-p", "fix_interval_s:=-1.0"], "fix_interval_s"),
    ("sensor_models", ["-p", "free_gyro_nadir_deg:=[0.0,50.0]"], "free_gyro_nadir_deg"),
    ("sensor_models", ["-p", "free_gyro_site_lat_deg:=95.0"], "free_gyro_site_lat_deg"),
])
def test_bad_parameters_are_refused_naming_them(ros_domain_env, exe, args, named):
    result = subprocess.run([str(VENV_BIN / exe), "--ros-args", *args], env=ros_domain_env,
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 2 and named in result.stderr, result.stderr


def test_scenario_puts_sensor_site_and_vehicle_site_together():
    """The vehicle does not publish its position: the scenario must give the sensors the
    same site, and the estimator the spin axes the sensors were set to."""
    nodes = yaml.safe_load((BUILTIN_DIR / "free_gyro_positioning.yaml").read_text())["nodes"]
    site = yaml.safe_load(nodes["vehicle_dynamics"]["params"]["profile_params"])
    sensor, est = nodes["sensor_models"]["params"], nodes["free_gyro_positioning"]["params"]
    assert (sensor["free_gyro_site_lat_deg"], sensor["free_gyro_site_lon_deg"]) == (site["lat_deg"], site["lon_deg"])
    assert (est["spin_reference_lat_deg"], est["spin_reference_lon_deg"]) == (site["lat_deg"], site["lon_deg"])
    assert (est["spin_nadir_deg"], est["spin_azimuth_deg"]) == (sensor["free_gyro_nadir_deg"],
                                                                sensor["free_gyro_azimuth_deg"])
    assert est["nadir_noise_arcsec"] == sensor["free_gyro_pickoff_noise_arcsec"]



def test_sailing_scenario_sensor_and_estimator_agree():
    """free_gyro_sailing: the sensors' site is the vehicle's and the estimator's reference, the
    spin axes, pickoff noise and triad ARW are the same on both sides, the ship sails the
    course and speed of the free_gyro_errors ``sailing`` variant (the Monte Carlo the docs set
    the graph run against), the sensors publish the velocity the estimator takes
    (velocity_input on, the one topic both use), and the model inputs of predict_error are 0
    like the sensors' sources (no triad bias, levelling error or spin drift)."""
    raw = yaml.safe_load((BUILTIN_DIR / "free_gyro_sailing.yaml").read_text())["nodes"]
    nodes = load("free_gyro_sailing").nodes
    site = yaml.safe_load(nodes["vehicle_dynamics"]["params"]["profile_params"])
    sensor, est = nodes["sensor_models"]["params"], nodes["free_gyro_positioning"]["params"]
    assert (sensor, est) == (raw["sensor_models"]["params"], raw["free_gyro_positioning"]["params"])
    assert (sensor["free_gyro_site_lat_deg"], sensor["free_gyro_site_lon_deg"]) == (site["lat_deg"], site["lon_deg"])
    assert (est["spin_reference_lat_deg"], est["spin_reference_lon_deg"]) == (site["lat_deg"], site["lon_deg"])
    assert (est["spin_nadir_deg"], est["spin_azimuth_deg"]) == (sensor["free_gyro_nadir_deg"],
                                                                sensor["free_gyro_azimuth_deg"])
    assert est["nadir_noise_arcsec"] == sensor["free_gyro_pickoff_noise_arcsec"]
    assert est["triad_arw_deg_rt_h"] == sensor["free_gyro_triad_arw_deg_rt_h"]
    assert (site["lat_deg"], site["lon_deg"]) == (DEFAULTS["lat_deg"], DEFAULTS["lon_deg"])
    assert sensor["free_gyro_speed_m_s"] == DEFAULTS["speed_m_s"] > 0.0
    assert sensor["free_gyro_course_deg"] == DEFAULTS["course_deg"]
    assert sensor["free_gyro_publish_velocity"] is True and est["velocity_input"] is True
    assert (VELOCITY, "geometry_msgs/msg/Vector3Stamped") in sensor_models_node.SENSOR_TOPICS["free_gyro"]
    assert est["predict_error"] is True
    assert all(est.get(k, 0.0) == 0.0 for k in ("error_triad_bias_deg_h", "error_level_arcsec",
                                                 "error_spin_drift_deg_h"))
    assert not any(k in sensor for k in ("free_gyro_triad_bias_deg_h", "free_gyro_triad_bias_sigma_deg_h",
                                         "free_gyro_level_bias_arcsec", "free_gyro_level_noise_arcsec",
                                         "free_gyro_spin_drift_sigma_deg_h"))


TRIAD_BIAS_DEG_H = (0.05, -0.03, 0.02)


def finite_difference_heading_error(attitude: list, t_c: float, span: float, bias: np.ndarray) -> float:
    """Mean over the window of ψ(ω + δω) − ψ(ω), ψ = atan2(−ω_ly, ω_lx) of the earth rate
    levelled with scipy rotations (an exact difference, not eq. 29's linearisation)."""
    w_n = np.array([math.cos(math.radians(LAT)), 0.0, -math.sin(math.radians(LAT))]) * OMEGA_IE
    out = []
    for t, q in attitude:
        if abs(t - t_c) > 0.5 * span + 1e-6:
            continue
        yaw, pitch, roll = Rotation.from_quat(q).as_euler("ZYX")
        R_nb, R_lb = Rotation.from_euler("ZYX", [yaw, pitch, roll]), Rotation.from_euler("YX", [pitch, roll])
        psi = lambda w_b: math.atan2(-R_lb.apply(w_b)[1], R_lb.apply(w_b)[0])  # noqa: E731
        w_b = R_nb.inv().apply(w_n)
        out.append(math.remainder(psi(w_b + bias) - psi(w_b), math.tau))
    return float(np.mean(out))


@pytest.mark.slow
def test_scenario_run_read_back_with_rosbags_and_mcap(ros_domain_env, tmp_path):
    """A 70 s run of the scenario with a biased, noise-free body triad: 7 NavSatFix
    messages, each equal to the core fed the recorded read-outs (decoded by rosbags) and
    within 5σ of the true position (covariance FDOP²σ², σ = 5″/√n); the earth-rate heading
    error of both 30 s windows equals the bias's effect (exact finite difference) and paper
    4's eq. 29 (the report's first-order prediction) to 1 %."""
    out = tmp_path / "run"
    bias = "[" + ",".join(map(str, TRIAD_BIAS_DEG_H)) + "]"
    result = subprocess.run([str(VENV_BIN / "gimbal-run"), "free_gyro_positioning", "--duration", "70",
                             "--set", "free_gyro_positioning.heading_window_s=30.0",
                             "--set", "sensor_models.free_gyro_triad_arw_deg_rt_h=0.0",
                             "--set", f"sensor_models.free_gyro_triad_bias_deg_h={bias}",
                             *no_grade_args("free_gyro_triad"),  # the bias alone, as the closed form has it
                             "--out", str(out), "--mode", "container", "--no-progress"],
                            env=ros_domain_env, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr
    by_topic: dict[str, list] = {}
    with AnyReader([out]) as reader:
        for conn, _, raw in reader.messages():
            by_topic.setdefault(conn.topic, []).append(reader.deserialize(raw, conn.msgtype))
    with open(next(out.glob("*.mcap")), "rb") as f:
        mcap_fixes = [d for _, c, _, d in make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages()
                      if c.topic == f"{NODE}/fix"]
    fixes = by_topic[f"{NODE}/fix"]
    assert len(fixes) == len(mcap_fixes) == 7
    assert [f.latitude for f in fixes] == [f.latitude for f in mcap_fixes]
    assert len(by_topic["/free_gyro/imu"]) == 701

    scenario = yaml.safe_load((BUILTIN_DIR / "free_gyro_positioning.yaml").read_text())
    p = scenario["nodes"]["free_gyro_positioning"]["params"]
    u_a, u_b = make_spin_axes(LAT, LON, 0.0, tuple(p["spin_nadir_deg"]), tuple(p["spin_azimuth_deg"]))
    core = FreeGyroPositioning(FreeGyroPositioningParams(u_a, u_b, nadir_noise_arcsec=p["nadir_noise_arcsec"],
                                                         fix_interval_s=p["fix_interval_s"]))
    expected = []
    stamp = lambda msg: msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec  # noqa: E731
    for a, b, imu in zip(by_topic["/free_gyro/spin_axis_a"], by_topic["/free_gyro/spin_axis_b"],
                         by_topic["/free_gyro/imu"]):
        t = stamp(imu)
        assert stamp(a) == stamp(b) == t
        q = imu.orientation
        roll = math.atan2(2 * (q.w * q.x + q.y * q.z), 1 - 2 * (q.x * q.x + q.y * q.y))
        pitch = math.asin(2 * (q.w * q.y - q.z * q.x))
        core.on_level(t, roll, pitch)
        core.on_body_rates(t, (imu.angular_velocity.x, imu.angular_velocity.y, imu.angular_velocity.z))
        fix = core.on_spin_axes(t, (a.vector.x, a.vector.y, a.vector.z), (b.vector.x, b.vector.y, b.vector.z)).output
        if fix is not None:
            expected.append(fix)
    assert len(expected) == 7
    rm, rn = meridian_radius(math.radians(LAT)), prime_vertical_radius(math.radians(LAT)) * math.cos(math.radians(LAT))
    for nav, fix in zip(fixes, expected):
        assert nav.latitude == pytest.approx(math.degrees(fix.lat), abs=1e-9)
        assert nav.longitude == pytest.approx(math.degrees(fix.lon), abs=1e-9)
        north, east = math.radians(nav.latitude - LAT) * rm, math.radians(nav.longitude - LON) * rn
        assert abs(north) < 5 * math.sqrt(nav.position_covariance[4])
        assert abs(east) < 5 * math.sqrt(nav.position_covariance[0])
    truth = by_topic["/truth/free_gyro/position"][0]
    assert (truth.latitude, truth.longitude) == (LAT, LON)
    metrics = yaml.safe_load((out / "report" / "metrics.json").read_text())["free_gyro"]
    assert metrics["fixes"] == 7 and metrics["degenerate_windows"] == 0
    assert metrics["position"]["n_fixes"] == 7 and metrics["heading"]["n"] == 7

    # earth-rate heading with a triad bias (paper 4 eq. 29)
    attitude = [(stamp(msg), (msg.orientation.x, msg.orientation.y, msg.orientation.z, msg.orientation.w))
                for msg in by_topic["/truth/host/imu"]]
    bias_b = np.radians(TRIAD_BIAS_DEG_H) / 3600.0
    windows = by_topic[f"{NODE}/heading_earth_rate"]
    assert len(windows) == 2
    er = metrics["heading_earth_rate"]
    for msg, measured_arcsec, eq29_arcsec in zip(windows, er["errors_arcsec"], er["eq29_predicted_arcsec"]):
        exact = finite_difference_heading_error(attitude, stamp(msg), msg.vector.z, bias_b) / ARCSEC
        assert abs(exact) > 60.0  # a clear effect: minutes of arc
        assert measured_arcsec == pytest.approx(exact, rel=0.01)
        assert measured_arcsec == pytest.approx(eq29_arcsec, rel=0.01)

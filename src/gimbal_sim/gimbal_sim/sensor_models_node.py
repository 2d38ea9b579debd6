"""``sensor_models`` node: the :class:`.sensor_suite.SensorSuite` on the vehicle's truth.

It gathers the truth topics of each step (exact stamp match), runs the enabled sensors and
publishes their measurements stamped with the step's time. See the README topic table.
"""
from __future__ import annotations

import math
import sys

from gimbal_kinematics.rotations import euler321_from_quat, euler321_to_quat, quat_canonical, quat_from_euler321
from geometry_msgs.msg import Vector3Stamped
from rclpy.node import Node
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, JointState, NavSatFix

from . import messages as m
from .cdr import CdrError
from .node_main import run_node
from .qos import GRAPH_QOS
from .readiness import announce_when_connected
from .ros_params import Param, ParameterError, declare_and_read
from .sensor_suite import (
    SENSORS, EncoderSample, GimbalGyroSample, InsSample, LguSample, PlatformImuSample, ResolverSample,
    SensorSuite, SensorSuiteConfig,
)
from .sensors import AccelerometerParams, EncoderParams, FlexureParams, GyroParams, InsParams
from .sensors.free_gyro_sensor import FreeGyroSample, FreeGyroSensorParams, spin_axes_for_site_deg
from .stamp_sync import StampSync
from .vehicle import VehicleTruth

DESCRIPTION = (
    "Sensor models: subscribes to the vehicle's truth topics and publishes the INS, the "
    "two-axis gimbal gyro, the encoders, the paper 5 LGUs, the paper 3 platform IMU and gimbal resolvers and "
    "the paper 4 free gyros, each at its own rate with the papers' error models, plus the error truth (biases, "
    "flexure, the ship's position)."
)
INF = math.inf

PARAMS = (
    Param("sensors", ["ins", "gimbal_gyro", "encoders"], f"enabled sensors, any of {list(SENSORS)}"),
    Param("sim_rate_hz", 1000.0, "simulation rate [Hz]; must equal vehicle_dynamics'", 1.0, 100000.0),
    Param("seed", 0, "seed of every sensor's random stream", 0, 2**31 - 1),
    Param("progress_every_steps", 10, "report on ~/progress (time of the next step needed) every N steps; "
          "vehicle_dynamics waits for and paces on it", 1, 10**6),
    Param("wait_for_subscribers", 0, "matched subscriptions each output needs before ~/progress reports ready",
          0, 1000),
    Param("ins_rate_hz", 100.0, "INS output rate [Hz]", 1e-3, 100000.0),
    Param("gimbal_gyro_rate_hz", 1000.0, "gimbal gyro output rate [Hz]", 1e-3, 100000.0),
    Param("encoder_rate_hz", 1000.0, "encoder output rate [Hz]", 1e-3, 100000.0),
    Param("lgu_rate_hz", 100.0, "LGU output rate [Hz]", 1e-3, 100000.0),
    Param("platform_imu_rate_hz", 100.0, "platform IMU output rate [Hz]", 1e-3, 100000.0),
    Param("gimbal_gyro_bias_deg_h", [100.0, 100.0], "gimbal gyro fixed bias (q_m, r_m) [deg/h]"),
    Param("gimbal_gyro_bias_sigma_deg_h", 0.0, "gimbal gyro run-to-run bias 1-sigma [deg/h]", 0.0, INF),
    Param("gimbal_gyro_arw_deg_rt_h", 0.15, "gimbal gyro angle random walk [deg/sqrt(h)]", 0.0, INF),
    Param("gimbal_gyro_bi_deg_h", 30.0, "gimbal gyro Gauss-Markov bias instability RMS [deg/h]", 0.0, INF),
    Param("gimbal_gyro_bi_tau_s", 100.0, "its correlation time [s] (inf: random constant)", 1e-9, INF),
    Param("gimbal_gyro_rrw_deg_h_rt_h", 0.0, "gimbal gyro rate random walk [deg/h/sqrt(h)]", 0.0, INF),
    Param("gimbal_gyro_quantum_deg", 0.0, "gimbal gyro incremental-angle quantum (LSB) [deg] (0: none); IEEE 952 "
          "quantisation noise Q = quantum / sqrt(12)", 0.0, INF),
    Param("gimbal_gyro_scale_factor_ppm", [0.0, 0.0], "gimbal gyro scale-factor error (q_m, r_m) [ppm]"),
    Param("gimbal_gyro_range_deg_s", 0.0, "gimbal gyro measurement range +-[deg/s] (0: unlimited)", 0.0, INF),
    Param("ins_roll_pitch_rms_deg", 0.05, "INS roll/pitch error RMS [deg]", 0.0, INF),
    Param("ins_heading_rms_deg", 0.2, "INS heading error RMS [deg]", 0.0, INF),
    Param("ins_attitude_tau_s", 300.0, "INS attitude error correlation time [s]", 1e-9, INF),
    Param("ins_gyro_bias_sigma_deg_h", 1.0, "INS gyro run-to-run bias 1-sigma [deg/h]", 0.0, INF),
    Param("ins_gyro_bi_deg_h", 1.0, "INS gyro Gauss-Markov bias RMS [deg/h]", 0.0, INF),
    Param("ins_gyro_bi_tau_s", 60.0, "its correlation time [s]", 1e-9, INF),
    Param("ins_gyro_arw_deg_rt_h", 0.1, "INS gyro angle random walk [deg/sqrt(h)]", 0.0, INF),
    Param("ins_gyro_rrw_deg_h_rt_h", 0.0, "INS gyro rate random walk [deg/h/sqrt(h)]", 0.0, INF),
    Param("ins_gyro_quantum_deg", 0.0, "INS gyro incremental-angle quantum (LSB) [deg] (0: none); IEEE 952 "
          "quantisation noise Q = quantum / sqrt(12)", 0.0, INF),
    Param("encoder_noise_deg", 0.05, "encoder angle noise RMS [deg]", 0.0, INF),
    Param("encoder_lines_per_rev", 0, "encoder lines per revolution (0: no quantisation)", 0, 10**9),
    Param("encoder_quadrature", 1, "edges counted per line (1, 2 or 4)", 1, 4),
    Param("encoder_velocity_gate_s", 0.01, "pulse-counting gate time of the encoder rate [s]", 1e-9, INF),
    Param("lgu1_bias_deg_h", 0.05, "LGU1 fixed bias [deg/h]"),
    Param("lgu2_bias_deg_h", -0.05, "LGU2 fixed bias [deg/h]"),
    Param("lgu_arw_deg_rt_h", 0.001, "LGU angle random walk [deg/sqrt(h)]", 0.0, INF),
    Param("flexure_initial_deg", 0.1, "quasi-static flexure at t0, each axis [deg]"),
    Param("flexure_linear_rate_deg_h", 0.2, "quasi-static linear flexure rate [deg/h]"),
    Param("flexure_slow_amplitude_arcsec", 90.0, "slow sinusoidal flexure amplitude [arcsec]", 0.0, INF),
    Param("flexure_slow_period_s", 3600.0, "its period [s]", 1e-9, INF),
    Param("flexure_helm_amplitude_deg", 0.1, "helm-induced flexure amplitude [deg]", 0.0, INF),
    Param("flexure_helm_period_s", 200.0, "its period [s]", 1e-9, INF),
    Param("flexure_dynamic_rms_arcsec", [20.0, 60.0, 40.0], "dynamic flexure RMS (roll, pitch, yaw) [arcsec]"),
    Param("flexure_dynamic_beta_per_s", [0.2146, 0.2146, 0.2146], "dynamic flexure 2nd-order Markov decay "
          "rate beta (roll, pitch, yaw) [1/s], > 0; critically damped: 2.146 / (1/e correlation time), "
          "default 10 s; paper 5 gives none (README: the dynamic-flexure band)"),
    Param("flexure_dynamic_freq_rad_s", [0.0, 0.0, 0.0], "dynamic flexure damped frequency lambda (roll, pitch, "
          "yaw) [rad/s], >= 0; 0 (default): the textbook critically damped 2nd-order Markov, > 0: a band "
          "peaked at lambda (sea waves)"),
    Param("platform_gyro_bias_sigma_deg_h", 0.03, "platform gyro run-to-run bias 1-sigma [deg/h]", 0.0, INF),
    Param("platform_gyro_arw_deg_rt_h", 0.003, "platform gyro angle random walk [deg/sqrt(h)]", 0.0, INF),
    Param("platform_accel_bias_sigma_ug", 100.0, "platform accelerometer bias 1-sigma [micro-g]", 0.0, INF),
    Param("platform_accel_noise_ug_rt_hz", 50.0, "platform accelerometer noise density [micro-g/sqrt(Hz)]", 0.0, INF),
    Param("free_gyro_rate_hz", 10.0, "free-gyro read-out rate (spin axes, triad, vertical reference) [Hz]",
          1e-3, 100000.0),
    Param("free_gyro_site_lat_deg", 35.0, "ship's true geodetic latitude [deg]; must equal vehicle_dynamics' "
          "profile_params lat_deg (the vehicle does not publish its position)", -90.0, 90.0),
    Param("free_gyro_site_lon_deg", 129.0, "ship's true longitude [deg]; must equal vehicle_dynamics' "
          "profile_params lon_deg", -180.0, 180.0),
    Param("free_gyro_nadir_deg", [60.0, 50.0], "nadir angles (gyro a, gyro b) the spin axes are set to at the "
          "ship's site at t = 0 [deg], each in (0, 180)"),
    Param("free_gyro_azimuth_deg", [-40.0, 50.0], "azimuths from north toward east (gyro a, gyro b) of the spin "
          "axes at the site at t = 0 [deg]; fix geometry FDOP = sqrt(2)/|sin(difference)|"),
    Param("free_gyro_pickoff_noise_arcsec", 5.0, "spin-axis pickoff white noise per axis, per sample [arcsec]",
          0.0, INF),
    Param("free_gyro_spin_drift_sigma_deg_h", 0.0, "spin-axis random-constant drift 1-sigma per axis [deg/h] "
          "(0: ideal free gyro)", 0.0, INF),
    Param("free_gyro_level_noise_arcsec", 0.0, "vertical reference roll/pitch white noise [arcsec]", 0.0, INF),
    Param("free_gyro_level_bias_arcsec", [0.0, 0.0], "vertical reference fixed (roll, pitch) error [arcsec]"),
    Param("free_gyro_triad_arw_deg_rt_h", 0.002, "body gyro triad angle random walk [deg/sqrt(h)]", 0.0, INF),
    Param("free_gyro_triad_bias_deg_h", [0.0, 0.0, 0.0], "body gyro triad fixed bias (x, y, z) [deg/h]"),
    Param("free_gyro_triad_bias_sigma_deg_h", 0.0, "body gyro triad run-to-run bias 1-sigma [deg/h]", 0.0, INF),
    Param("resolver_rate_hz", 1000.0, "platform gimbal resolver output rate [Hz]", 1e-3, 100000.0),
    Param("resolver_bits", 19, "resolver-to-digital converter resolution [bits per turn] (0: unquantised)", 0, 30),
    Param("resolver_noise_arcsec", 0.0, "resolver white readout noise RMS [arcsec]", 0.0, INF),
    Param("resolver_velocity_gate_s", 0.01, "gate of the resolver count-difference velocity [s]", 1e-9, INF),
)


def free_gyro_params_from(v: dict) -> FreeGyroSensorParams:
    """The free-gyro sensor parameters; ``ValueError`` naming the parameter at fault."""
    u_a, u_b = spin_axes_for_site_deg(v["free_gyro_site_lat_deg"], v["free_gyro_site_lon_deg"],
                                      v["free_gyro_nadir_deg"], v["free_gyro_azimuth_deg"],
                                      names=("free_gyro_nadir_deg", "free_gyro_azimuth_deg"))
    level_bias = v["free_gyro_level_bias_arcsec"]
    if len(level_bias) != 2 or not all(math.isfinite(x) for x in level_bias):
        raise ValueError(f"parameter 'free_gyro_level_bias_arcsec' needs two finite values (roll, pitch), "
                         f"got {list(level_bias)}")
    try:
        triad = GyroParams(bias_deg_h=tuple(v["free_gyro_triad_bias_deg_h"]),
                           arw_deg_rt_h=v["free_gyro_triad_arw_deg_rt_h"],
                           bias_sigma_deg_h=v["free_gyro_triad_bias_sigma_deg_h"])
    except ValueError as exc:
        raise ValueError(f"parameter 'free_gyro_triad_bias_deg_h': {exc}") from exc
    try:
        return FreeGyroSensorParams(
            u_a, u_b, pickoff_noise_arcsec=v["free_gyro_pickoff_noise_arcsec"],
            spin_drift_sigma_deg_h=v["free_gyro_spin_drift_sigma_deg_h"],
            level_noise_arcsec=v["free_gyro_level_noise_arcsec"], level_bias_arcsec=tuple(level_bias), triad=triad)
    except ValueError as exc:  # what is left to refuse is the pair of spin axes (parallel)
        raise ValueError(f"parameters 'free_gyro_nadir_deg', 'free_gyro_azimuth_deg': {exc}") from exc


def config_from_params(v: dict) -> SensorSuiteConfig:
    """The suite's frozen config from parameter values; raises naming the parameter."""
    try:
        return SensorSuiteConfig(
            sensors=tuple(v["sensors"]), sim_rate_hz=v["sim_rate_hz"], seed=v["seed"],
            ins_rate_hz=v["ins_rate_hz"], gimbal_gyro_rate_hz=v["gimbal_gyro_rate_hz"],
            encoder_rate_hz=v["encoder_rate_hz"], lgu_rate_hz=v["lgu_rate_hz"],
            platform_imu_rate_hz=v["platform_imu_rate_hz"],
            gimbal_gyro=GyroParams(bias_deg_h=tuple(v["gimbal_gyro_bias_deg_h"]),
                                   bias_sigma_deg_h=v["gimbal_gyro_bias_sigma_deg_h"],
                                   arw_deg_rt_h=v["gimbal_gyro_arw_deg_rt_h"],
                                   bias_instability_deg_h=v["gimbal_gyro_bi_deg_h"],
                                   bias_instability_tau_s=v["gimbal_gyro_bi_tau_s"],
                                   rrw_deg_h_rt_h=v["gimbal_gyro_rrw_deg_h_rt_h"],
                                   quantisation_rad=math.radians(v["gimbal_gyro_quantum_deg"]),
                                   scale_factor_ppm=tuple(v["gimbal_gyro_scale_factor_ppm"]),
                                   saturation_deg_s=v["gimbal_gyro_range_deg_s"] or INF),
            ins=InsParams(roll_pitch_rms_deg=v["ins_roll_pitch_rms_deg"], heading_rms_deg=v["ins_heading_rms_deg"],
                          attitude_tau_s=v["ins_attitude_tau_s"],
                          gyro=GyroParams(bias_sigma_deg_h=v["ins_gyro_bias_sigma_deg_h"],
                                          bias_instability_deg_h=v["ins_gyro_bi_deg_h"],
                                          bias_instability_tau_s=v["ins_gyro_bi_tau_s"],
                                          arw_deg_rt_h=v["ins_gyro_arw_deg_rt_h"],
                                          rrw_deg_h_rt_h=v["ins_gyro_rrw_deg_h_rt_h"],
                                          quantisation_rad=math.radians(v["ins_gyro_quantum_deg"]))),
            encoder=EncoderParams(noise_deg=v["encoder_noise_deg"], lines_per_rev=v["encoder_lines_per_rev"],
                                  quadrature=v["encoder_quadrature"], velocity_gate_s=v["encoder_velocity_gate_s"]),
            lgu1=GyroParams(bias_deg_h=v["lgu1_bias_deg_h"], arw_deg_rt_h=v["lgu_arw_deg_rt_h"]),
            lgu2=GyroParams(bias_deg_h=v["lgu2_bias_deg_h"], arw_deg_rt_h=v["lgu_arw_deg_rt_h"]),
            flexure=FlexureParams(initial_deg=v["flexure_initial_deg"],
                                  linear_rate_deg_h=v["flexure_linear_rate_deg_h"],
                                  slow_amplitude_arcsec=v["flexure_slow_amplitude_arcsec"],
                                  slow_period_s=v["flexure_slow_period_s"],
                                  helm_amplitude_deg=v["flexure_helm_amplitude_deg"],
                                  helm_period_s=v["flexure_helm_period_s"],
                                  dynamic_rms_arcsec=tuple(v["flexure_dynamic_rms_arcsec"]),
                                  dynamic_beta_per_s=tuple(v["flexure_dynamic_beta_per_s"]),
                                  dynamic_freq_rad_s=tuple(v["flexure_dynamic_freq_rad_s"])),
            platform_gyro=GyroParams(bias_sigma_deg_h=v["platform_gyro_bias_sigma_deg_h"],
                                     arw_deg_rt_h=v["platform_gyro_arw_deg_rt_h"]),
            platform_accel=AccelerometerParams(bias_sigma_ug=v["platform_accel_bias_sigma_ug"],
                                               noise_ug_rt_hz=v["platform_accel_noise_ug_rt_hz"]),
            free_gyro_rate_hz=v["free_gyro_rate_hz"],
            free_gyro_site_deg=(v["free_gyro_site_lat_deg"], v["free_gyro_site_lon_deg"]),
            free_gyro=free_gyro_params_from(v),
            resolver_rate_hz=v["resolver_rate_hz"],
            resolver=EncoderParams(noise_deg=v["resolver_noise_arcsec"] / 3600.0,
                                   lines_per_rev=2 ** v["resolver_bits"] if v["resolver_bits"] else 0,
                                   velocity_gate_s=v["resolver_velocity_gate_s"]),
        )
    except ValueError as exc:
        raise ParameterError(str(exc)) from exc


#: Truth topic -> message type; which ones a run needs follows from the enabled sensors.
TRUTH_TOPICS = {
    "/truth/host/imu": Imu,
    "/truth/host/delta_angle": Vector3Stamped,
    "/truth/gimbal/imu": Imu,
    "/truth/gimbal/joint_states": JointState,
    "/truth/platform/imu": Imu,
    "/truth/platform/joint_states": JointState,
}
_DECODERS = {Imu: m.imu_from_cdr, JointState: m.joint_state_from_cdr, Vector3Stamped: m.vector3_stamped_from_cdr}
NEEDS = {
    "ins": ("/truth/host/imu",),
    "gimbal_gyro": ("/truth/gimbal/imu",),
    "encoders": ("/truth/gimbal/joint_states",),
    "lgu": ("/truth/host/delta_angle",),
    "platform_imu": ("/truth/platform/imu",),
    "free_gyro": ("/truth/host/imu", "/truth/host/delta_angle"),
    "resolvers": ("/truth/platform/joint_states",),
}


def truth_from_group(k: int, t: float, group: dict) -> VehicleTruth:
    """A :class:`VehicleTruth` holding what the subscribed truth topics carry."""
    host = group.get("/truth/host/imu")
    plant = group.get("/truth/gimbal/imu") or group.get("/truth/platform/imu")
    joints = group.get("/truth/gimbal/joint_states") or group.get("/truth/platform/joint_states")
    delta = group.get("/truth/host/delta_angle")
    return VehicleTruth(
        k=k, t=t,
        euler=euler321_from_quat(m.quat_of(host)) if host is not None else (0.0, 0.0, 0.0),
        quat_nb=m.quat_of(host) if host is not None else None,
        omega_ib_b=m.vec_of(host.angular_velocity) if host is not None else None,
        specific_force_b=m.vec_of(host.linear_acceleration) if host is not None else None,
        delta_angle_b=m.vec_of(delta.vector) if delta is not None else None,
        joint_names=tuple(joints.name) if joints is not None else (),
        joint_position=tuple(joints.position) if joints is not None else (),
        joint_velocity=tuple(joints.velocity) if joints is not None else (),
        joint_effort=tuple(joints.effort) if joints is not None else (),
        quat_nm=m.quat_of(plant) if plant is not None else None,
        omega_im_m=m.vec_of(plant.angular_velocity) if plant is not None else None,
        specific_force_m=m.vec_of(plant.linear_acceleration) if plant is not None else None,
    )


class SensorModelsNode(Node):
    def __init__(self, **node_kwargs) -> None:
        super().__init__("sensor_models", **node_kwargs)
        values = declare_and_read(self, PARAMS)
        self.config = config_from_params(values)
        self.suite = SensorSuite(self.config)
        self.rate = self.config.sim_rate_hz
        topics = sorted({t for s in self.config.sensors for t in NEEDS[s]})
        self.sync = StampSync(topics)
        self.rejected_truth = 0
        # taken serialized and decoded here (messages.*_from_cdr): no message objects per step
        self.subs = [self.create_subscription(TRUTH_TOPICS[t], t, lambda data, t=t: self._on_truth(t, data), GRAPH_QOS,
                                              raw=True) for t in topics]
        on = set(self.config.sensors)
        pub = lambda typ, topic: self.create_publisher(typ, topic, GRAPH_QOS)  # noqa: E731
        self.pubs = {}
        if "ins" in on:
            self.pubs["ins"] = (pub(Imu, "/ins/imu"), pub(Vector3Stamped, "/truth/ins/gyro_bias"))
        if "gimbal_gyro" in on:
            self.pubs["gimbal_gyro"] = (pub(Imu, "/gimbal/imu"), pub(Vector3Stamped, "/truth/gimbal/gyro_bias"))
        if "encoders" in on:
            self.pubs["encoders"] = (pub(JointState, "/gimbal/joint_states"),)
        if "lgu" in on:
            self.pubs["lgu"] = (pub(Imu, "/ship/lgu1/imu"), pub(Imu, "/ship/lgu2/imu"),
                                pub(Vector3Stamped, "/truth/ship/flexure"),
                                pub(Vector3Stamped, "/truth/ship/flexure_quasi_static"))
        if "platform_imu" in on:
            self.pubs["platform_imu"] = (pub(Imu, "/platform/imu"), pub(Vector3Stamped, "/truth/platform/accel_bias"),
                                         pub(Vector3Stamped, "/truth/platform/gyro_bias"))
        if "free_gyro" in on:
            self.pubs["free_gyro"] = (pub(Vector3Stamped, "/free_gyro/spin_axis_a"),
                                      pub(Vector3Stamped, "/free_gyro/spin_axis_b"), pub(Imu, "/free_gyro/imu"),
                                      pub(NavSatFix, "/truth/free_gyro/position"),
                                      pub(Vector3Stamped, "/truth/free_gyro/triad_bias"))
        if "resolvers" in on:
            self.pubs["resolvers"] = (pub(JointState, "/platform/resolvers"),)
        self._noise_cov = self._white_noise_covariances()
        self.progress_every = values["progress_every_steps"]
        self.wait_for_subscribers = values["wait_for_subscribers"]
        self.pub_progress = self.create_publisher(Clock, "~/progress", GRAPH_QOS)
        announce_when_connected(self, self.pub_progress, outputs=(p for group in self.pubs.values() for p in group),
                                readers=self.wait_for_subscribers)

    def _white_noise_covariances(self) -> dict:
        """Per-sample variances of the white noise each measurement carries (for the
        covariance fields; biases are not white and are not in them)."""
        c = self.config
        deg = math.pi / 180.0
        arw = lambda deg_rt_h, rate_hz: (deg_rt_h * deg / 60.0) ** 2 * rate_hz  # noqa: E731
        return {
            "ins_att": m.diag_cov([(c.ins.roll_pitch_rms_deg * deg) ** 2] * 2 + [(c.ins.heading_rms_deg * deg) ** 2]),
            "ins_rate": m.diag_cov([arw(c.ins.gyro.arw_deg_rt_h, c.ins_rate_hz)] * 3),
            "gyro": (-1.0, 0.0, 0.0, 0.0, arw(c.gimbal_gyro.arw_deg_rt_h, c.gimbal_gyro_rate_hz), 0.0,
                     0.0, 0.0, arw(c.gimbal_gyro.arw_deg_rt_h, c.gimbal_gyro_rate_hz)),
            "lgu": m.diag_cov([arw(c.lgu1.arw_deg_rt_h, c.lgu_rate_hz)] * 3),
            "p_gyro": m.diag_cov([arw(c.platform_gyro.arw_deg_rt_h, c.platform_imu_rate_hz)] * 3),
            "p_accel": m.diag_cov([(c.platform_accel.noise_ug_rt_hz * 9.80665e-6) ** 2 * c.platform_imu_rate_hz] * 3),
            "fg_rate": m.diag_cov([arw(c.free_gyro.triad.arw_deg_rt_h, c.free_gyro_rate_hz)] * 3),
            # roll, pitch from the vertical reference; the heading is not measured: its variance
            # is that of a heading uniform on (−π, π], π²/3
            "fg_level": m.diag_cov([(c.free_gyro.level_noise_arcsec * deg / 3600.0) ** 2] * 2 + [math.pi**2 / 3.0]),
        }

    def _on_truth(self, topic: str, data: bytes) -> None:
        try:
            msg = _DECODERS[TRUTH_TOPICS[topic]](data)
        except CdrError as exc:
            self.rejected_truth += 1
            self.get_logger().warning(f"malformed truth on {topic}: {exc} ({self.rejected_truth} rejected)",
                                      throttle_duration_sec=1.0)
            return
        t_ns = msg.stamp_ns
        group = self.sync.add(topic, t_ns, msg)
        if group is None:
            return
        k = m.step_of_stamp(t_ns, self.rate)
        try:
            samples = self.suite.update(truth_from_group(k, k / self.rate, group))
        except ValueError as exc:
            self.rejected_truth += 1
            self.get_logger().warning(f"truth rejected: {exc} ({self.rejected_truth} rejected)",
                                      throttle_duration_sec=1.0)
            return
        for sample in samples:
            self._publish(t_ns, sample)
        if (k + 1) % self.progress_every == 0:
            self.pub_progress.publish(m.clock_cdr(m.step_stamp_ns(k + 1, self.rate)))

    def _publish(self, t_ns: int, s) -> None:
        # serialized by hand (messages.*_cdr): the same messages, without message objects
        cov = self._noise_cov
        if isinstance(s, GimbalGyroSample):
            imu, bias = self.pubs["gimbal_gyro"]
            imu.publish(m.imu_cdr(t_ns, "gimbal_inner_frd", angular_velocity=(0.0, s.q_m, s.r_m),
                                  angular_velocity_cov=cov["gyro"]))
            bias.publish(m.vector3_cdr(t_ns, "gimbal_inner_frd", (0.0, *s.true_bias)))
        elif isinstance(s, EncoderSample):
            self.pubs["encoders"][0].publish(m.joint_state_cdr(t_ns, s.names, s.angles, s.rates))
        elif isinstance(s, InsSample):
            imu, bias = self.pubs["ins"]
            imu.publish(m.imu_cdr(t_ns, "base_link_frd", orientation=quat_canonical(quat_from_euler321(*s.euler)),
                                  orientation_cov=cov["ins_att"], angular_velocity=s.omega_b,
                                  angular_velocity_cov=cov["ins_rate"]))
            bias.publish(m.vector3_cdr(t_ns, "base_link_frd", s.true_gyro_bias))
        elif isinstance(s, LguSample):
            lgu1, lgu2, flex, flex_qs = self.pubs["lgu"]
            # angular_velocity carries the increment over the sample interval divided by it
            lgu1.publish(m.imu_cdr(t_ns, "lgu1_frd", angular_velocity=[d / s.dt for d in s.dalpha1],
                                   angular_velocity_cov=cov["lgu"]))
            lgu2.publish(m.imu_cdr(t_ns, "lgu2_frd", angular_velocity=[d / s.dt for d in s.dalpha2],
                                   angular_velocity_cov=cov["lgu"]))
            flex.publish(m.vector3_cdr(t_ns, "lgu1_frd", s.flexure))
            flex_qs.publish(m.vector3_cdr(t_ns, "lgu1_frd", s.flexure_quasi_static))
        elif isinstance(s, ResolverSample):
            self.pubs["resolvers"][0].publish(m.joint_state_cdr(t_ns, s.names, s.angles, s.rates))
        elif isinstance(s, PlatformImuSample):
            imu, accel_bias, gyro_bias = self.pubs["platform_imu"]
            imu.publish(m.imu_cdr(t_ns, "platform_frd", angular_velocity=s.omega, angular_velocity_cov=cov["p_gyro"],
                                  linear_acceleration=s.specific_force, linear_acceleration_cov=cov["p_accel"]))
            accel_bias.publish(m.vector3_cdr(t_ns, "platform_frd", s.true_accel_bias))
            gyro_bias.publish(m.vector3_cdr(t_ns, "platform_frd", s.true_gyro_bias))
        elif isinstance(s, FreeGyroSample):
            spin_a, spin_b, imu, position, bias = self.pubs["free_gyro"]
            spin_a.publish(m.vector3_msg(t_ns, "base_link_frd", s.spin_a_b))
            spin_b.publish(m.vector3_msg(t_ns, "base_link_frd", s.spin_b_b))
            # orientation = the vertical reference: roll and pitch, heading 0 (not measured)
            imu.publish(m.imu_msg(t_ns, "base_link_frd", orientation=euler321_to_quat(s.roll, s.pitch, 0.0),
                                  orientation_cov=cov["fg_level"], angular_velocity=s.omega_ib_b,
                                  angular_velocity_cov=cov["fg_rate"]))
            lat, lon = (math.radians(x) for x in self.config.free_gyro_site_deg)
            position.publish(m.navsat_fix_msg(t_ns, "base_link_frd", lat, lon, 0.0, m.ZERO_COV))
            bias.publish(m.vector3_msg(t_ns, "base_link_frd", s.true_triad_bias))


def main(argv: list[str] | None = None) -> int:
    return run_node(SensorModelsNode, "sensor_models", DESCRIPTION, argv)


if __name__ == "__main__":
    sys.exit(main())

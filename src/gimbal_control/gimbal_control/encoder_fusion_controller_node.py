"""``encoder_fusion_controller`` node: paper 2's two-axis PID stabilizer with encoder/gyro fusion.

A thin wrapper around :class:`.encoder_fusion.EncoderFusionController`. Per lockstep step k
it waits for exactly the inputs stamped k: the gimbal gyro (``/gimbal/imu``, q_m and r_m),
and at the steps where they sample, the encoders (``/gimbal/joint_states``) and the UAV
autopilot's body rates (``/truth/host/imu`` angular_velocity, remap it to your autopilot's
topic). It then publishes the torque command stamped k on ``/gimbal/torque_cmd``. Waiting
for exactly those inputs keeps a run deterministic.

Diagnostics (``geometry_msgs/Vector3Stamped``, (0, q, r) in ``gimbal_inner_frd``, rad/s):

* ``~/feedback_velocity``, stamped k every step: the velocity the PIDs feed back (encoder,
  raw gyro or fused, by ``mode``);
* ``~/drift_correction``, stamped at each filter update (``fused`` mode, every
  ``encoder_gate_s``): the accumulated drift correction E. It converges to −(gyro bias),
  which is how the bias leaves the feedback velocity.

Bad input: a NaN/inf measurement holds the last command (counted, warned at most once a
second); invalid modes, gains and rates are refused at startup naming the parameter.
"""
from __future__ import annotations

import sys

from geometry_msgs.msg import Vector3Stamped
from rclpy.node import Node
from sensor_msgs.msg import Imu, JointState

from gimbal_kinematics.ros.node_main import run_node
from gimbal_kinematics.ros.qos import GRAPH_QOS
from gimbal_kinematics.params import Param, ParameterError, steps_per_sample
from gimbal_kinematics.ros.params import declare_and_read
from gimbal_kinematics.sync import EagerStepGroups

from . import messages as m
from .encoder_fusion import (
    ENCODER_LOOP_BANDWIDTH_HZ, LOOP_BANDWIDTH_HZ, MODES, TORQUE_LIMIT_NM, UAV_AZIMUTH_INERTIA_KG_M2,
    UAV_ELEVATION_INERTIA_KG_M2, EncoderFusionController, EncoderFusionParams,
)
from .fusion_kf import FusionKfParams
from .pid import pole_placement_gains

DESCRIPTION = (
    "Paper 2 two-axis gimbal stabilization: a PID per axis whose feedback velocity is the encoder "
    "pulse-count rate (mode encoder), the raw MEMS gyro (gyro) or the gyro corrected by the "
    "closed-loop complementary Kalman filter on encoder-minus-gyro (fused). Publishes "
    "/gimbal/torque_cmd for each step, plus ~/feedback_velocity and ~/drift_correction."
)
INF = float("inf")
_KF = FusionKfParams()
_CORE = EncoderFusionParams()
#: A triple-pole loop crosses over at about 3 x its bandwidth; at sim_rate_hz / 25 the
#: zero-order hold's half-sample delay leaves >= 45 deg of phase margin (49 deg measured).
_BANDWIDTH_PER_RATE = 1.0 / 25.0
#: An incomplete step this many steps older than a complete one is given up.
_STALE_STEPS = 1000

PARAMS = (
    Param("mode", "fused", "feedback velocity: encoder (pulse-count rate), gyro (raw MEMS gyro) or fused "
          "(gyro corrected by the complementary KF)", choices=MODES),
    Param("sim_rate_hz", 1000.0, "lockstep rate [Hz]; the controller runs once per step on the gyro sample",
          1.0, 100000.0),
    Param("encoder_rate_hz", 1000.0, "encoder output rate [Hz] (must divide sim_rate_hz)", 1e-3, 100000.0),
    Param("base_rate_hz", 1000.0, "UAV autopilot body-rate output rate [Hz] (must divide sim_rate_hz)",
          1e-3, 100000.0),
    Param("encoder_gate_s", _CORE.encoder_gate_s, "pulse-count gate T_g of the encoder velocity and of the "
          "filter updates [s] (paper 2 eq. 1: 1024 lines and 0.2 s give ~2 deg/s resolution)", 1e-4, 100.0),
    Param("loop_bandwidth_hz", LOOP_BANDWIDTH_HZ, "triple-pole bandwidth of the gyro/fused PID loops [Hz] "
          "(at most sim_rate_hz / 25)", 1e-3, 4000.0),
    Param("encoder_loop_bandwidth_hz", ENCODER_LOOP_BANDWIDTH_HZ, "triple-pole bandwidth of the encoder-mode "
          "PID loops [Hz] (the pulse-count velocity lags ~encoder_gate_s: keep it slow)", 1e-3, 4000.0),
    Param("azimuth_inertia_kg_m2", UAV_AZIMUTH_INERTIA_KG_M2, "azimuth-loop inertia the gains are placed for "
          "[kg m^2]", 1e-9, 1e4),
    Param("elevation_inertia_kg_m2", UAV_ELEVATION_INERTIA_KG_M2, "elevation-loop inertia the gains are "
          "placed for [kg m^2]", 1e-9, 1e4),
    Param("torque_limit_nm", TORQUE_LIMIT_NM, "PID output clip (anti-windup by conditional integration) "
          "[N m]", 1e-9, 1e6),
    Param("derivative_tau_s", 0.0, "low-pass time constant of the PID's measured-rate D term [s] (0: none)",
          0.0, 10.0),
    Param("min_cos_elevation", _CORE.min_cos_elevation, "floor of cos(theta_m) in tau_a = u_r / cos(theta_m) [-]",
          1e-3, 1.0),
    Param("max_gap_s", _CORE.max_gap_s, "a longer gap between gyro samples restarts the gate and D term [s]",
          1e-6, 1e3),
    Param("backward_jump_s", _CORE.backward_jump_s, "a stamp this far behind the last resets the controller "
          "(bag loop) [s]", 1e-6, 1e6),
    Param("kf_q_angle_deg_rt_s", _KF.q_angle_deg_rt_s, "KF Q: gyro angle-random-walk density [deg/sqrt(s)]",
          0.0, 1e3),
    Param("kf_q_scale_rt_s", _KF.q_scale_rt_s, "KF Q: scale-factor random-walk density [1/sqrt(s)]", 0.0, 1e3),
    Param("kf_q_drift_deg_s_rt_s", _KF.q_drift_deg_s_rt_s, "KF Q: gyro drift random-walk density "
          "[deg/s/sqrt(s)]", 0.0, 1e3),
    Param("kf_r_deg", _KF.r_deg, "KF R: sigma of z, the encoder-minus-gyro angle over a gate [deg]", 1e-9, 1e3),
    Param("kf_p0_angle_deg", _KF.p0_angle_deg, "KF initial sigma of the angle error [deg]", 1e-9, 1e3),
    Param("kf_p0_scale", _KF.p0_scale, "KF initial sigma of the scale-factor error [-]", 1e-9, 10.0),
    Param("kf_p0_drift_deg_s", _KF.p0_drift_deg_s, "KF initial sigma of the gyro drift [deg/s]", 1e-9, 1e3),
    Param("kf_gate_sigma", 0.0, "KF innovation gate [sigma] (0: no gate)", 0.0, 1e3),
)


def params_from_values(v: dict) -> tuple[EncoderFusionParams, int, int]:
    """The core's params and the encoder / base-rate decimations (steps per sample) from
    parameter values; raises :class:`ParameterError` naming the parameter."""
    rate = v["sim_rate_hz"]
    every = {name: steps_per_sample(v, name) for name in ("encoder_rate_hz", "base_rate_hz")}
    if v["loop_bandwidth_hz"] > rate * _BANDWIDTH_PER_RATE:
        raise ParameterError(f"parameter 'loop_bandwidth_hz' = {v['loop_bandwidth_hz']} Hz exceeds sim_rate_hz / 25 "
                             f"= {rate * _BANDWIDTH_PER_RATE:g} Hz (the sampled loop would lose its phase margin)")
    if v["encoder_gate_s"] * rate < 1.0 - 1e-9:
        raise ParameterError(f"parameter 'encoder_gate_s' = {v['encoder_gate_s']} s is shorter than one step")

    def gains(inertia: str, bandwidth: str):
        return pole_placement_gains(v[inertia], v[bandwidth], output_limit=v["torque_limit_nm"],
                                    derivative_tau_s=v["derivative_tau_s"])

    try:
        kf = FusionKfParams(q_angle_deg_rt_s=v["kf_q_angle_deg_rt_s"], q_scale_rt_s=v["kf_q_scale_rt_s"],
                            q_drift_deg_s_rt_s=v["kf_q_drift_deg_s_rt_s"], r_deg=v["kf_r_deg"],
                            p0_angle_deg=v["kf_p0_angle_deg"], p0_scale=v["kf_p0_scale"],
                            p0_drift_deg_s=v["kf_p0_drift_deg_s"], gate_sigma=v["kf_gate_sigma"] or INF)
        core = EncoderFusionParams(
            mode=v["mode"], encoder_gate_s=v["encoder_gate_s"],
            elevation_pid=gains("elevation_inertia_kg_m2", "loop_bandwidth_hz"),
            azimuth_pid=gains("azimuth_inertia_kg_m2", "loop_bandwidth_hz"),
            encoder_elevation_pid=gains("elevation_inertia_kg_m2", "encoder_loop_bandwidth_hz"),
            encoder_azimuth_pid=gains("azimuth_inertia_kg_m2", "encoder_loop_bandwidth_hz"),
            kf=kf, min_cos_elevation=v["min_cos_elevation"], max_gap_s=v["max_gap_s"],
            backward_jump_s=v["backward_jump_s"])
    except ValueError as exc:
        raise ParameterError(str(exc)) from exc
    return core, every["encoder_rate_hz"], every["base_rate_hz"]


class EncoderFusionControllerNode(Node):
    def __init__(self, **node_kwargs) -> None:
        super().__init__("encoder_fusion_controller", **node_kwargs)
        v = declare_and_read(self, PARAMS)
        params, self.enc_every, self.base_every = params_from_values(v)
        self.rate = v["sim_rate_hz"]
        self.core = EncoderFusionController(params)
        self.sync = EagerStepGroups(self._needs, _STALE_STEPS)
        self._omega_b: tuple[float, float, float] | None = None
        self._angles: tuple[float, float] | None = None
        self._kf_updates = 0
        self.held = 0  # steps whose command was held (bad or missing input)
        self.pub_cmd = self.create_publisher(JointState, "/gimbal/torque_cmd", GRAPH_QOS)
        self.pub_feedback = self.create_publisher(Vector3Stamped, "~/feedback_velocity", GRAPH_QOS)
        self.pub_correction = self.create_publisher(Vector3Stamped, "~/drift_correction", GRAPH_QOS)
        self.create_subscription(Imu, "/gimbal/imu", lambda msg: self._on_input("gyro", msg), GRAPH_QOS)
        self.create_subscription(JointState, "/gimbal/joint_states", lambda msg: self._on_input("enc", msg),
                                 GRAPH_QOS)
        self.create_subscription(Imu, "/truth/host/imu", lambda msg: self._on_input("base", msg), GRAPH_QOS)

    def _hold(self, k: int, why: str) -> None:
        self.held += 1
        self.get_logger().warning(f"step {k}: {why}; holding the last command ({self.held} held)",
                                  throttle_duration_sec=1.0)

    def _needs(self, step: int) -> tuple[str, ...]:
        """The inputs step ``step`` waits for: the gyro, and the encoders and base rates at
        the steps where they sample."""
        return (("gyro",) + (("enc",) if step % self.enc_every == 0 else ())
                + (("base",) if step % self.base_every == 0 else ()))

    def _on_input(self, kind: str, msg) -> None:
        k = m.step_of_stamp(m.stamp_ns(msg.header.stamp), self.rate)
        # A complete step runs at once: an older step still waiting for an input (lost, or a
        # stray message from another graph) must not stall the loop behind it. In lockstep the
        # steps complete in order anyway. Steps that stay incomplete are forgotten after a while.
        group = self.sync.add(kind, k, msg, self.get_logger())
        if group is not None:
            self._control(k, group)

    def _control(self, k: int, group: dict) -> None:
        t_ns = m.step_stamp_ns(k, self.rate)
        if "base" in group:
            self._omega_b = m.vec_of(group["base"].angular_velocity)
        if "enc" in group:
            readings = m.encoder_readings(group["enc"])
            self._angles = None if readings is None else (readings[0][1], readings[0][2])
        if self._omega_b is None or self._angles is None:
            self._hold(k, "encoder joints or base rates missing")
            tau = self.core.command
        else:
            gyro = group["gyro"].angular_velocity
            out = self.core.step(t_ns * 1e-9, self._omega_b, *self._angles, gyro.y, gyro.z)
            if out is None:
                self._hold(k, "input rejected (stamp out of order)")
                tau = self.core.command
            else:
                if out.held:
                    self._hold(k, "non-finite measurement")
                tau = (out.torque_azimuth, out.torque_elevation)
                self.pub_feedback.publish(m.gimbal_axes_msg(t_ns, out.velocity_q, out.velocity_r))
        self.pub_cmd.publish(m.torque_command_msg(t_ns, tau))
        updates = self.core.kf_q.updates
        if updates != self._kf_updates:
            self._kf_updates = updates
            self.pub_correction.publish(m.gimbal_axes_msg(t_ns, *self.core.corrections))


def main(argv: list[str] | None = None) -> int:
    return run_node(EncoderFusionControllerNode, "encoder_fusion_controller", DESCRIPTION, argv)


if __name__ == "__main__":
    sys.exit(main())

"""``gyro_bias_ekf`` node: paper 1's gyro-bias EKF (:class:`.gyro_bias_ekf.GyroBiasEkf`).

Inputs: the gimbal gyro (``/gimbal/imu``, q_m and r_m), the encoders
(``/gimbal/joint_states``) and the INS (``/ins/imu``, orientation and body rates). Remap
them to run against other topics, e.g. a bag played back under other names.

Outputs, one of each per INS sample (stamped like it), so a controller can wait for the
estimate of its step:

* ``~/bias`` and ``~/bias_sigma`` (Vector3Stamped, rad/s, frame ``gimbal_inner_frd``): the
  bias estimate (x: roll channel, i.e. the INS-rate part of paper 1 eq. 4; y, z: the
  gimbal gyro's q, r) and its 1σ;
* ``~/attitude`` (Imu): the estimated C(n,m) as orientation, with the 3×3 covariance of
  the attitude error resolved in the navigation frame (``map_ned``, the frame the small
  rotation is about), and the bias-corrected inertial rate of the inner gimbal;
* ``/diagnostics`` (diagnostic_msgs/DiagnosticArray): the health counters (updates,
  gated, rejected, resets, re-alignments) once per simulated second and after each reset.

The three streams are fed to the filter in stamp order (:class:`gimbal_kinematics.sync.StampOrder`), the encoders
and INS of a stamp before its gyro sample, whatever order the middleware delivers them in;
so a replay at any speed computes exactly what the run computed.

An INS sample whose estimate cannot be produced (non-finite, or before alignment) still
gets an output: the current estimate with that stamp, so a waiting controller never
stalls. The node reports on ``~/progress`` (rosgraph_msgs/Clock) the next gyro step it
needs, so the vehicle or the bag player does not outrun it.
"""
from __future__ import annotations

import sys

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.node import Node
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, JointState

from gimbal_kinematics.ros.node_main import run_node
from gimbal_kinematics.ros.qos import GRAPH_QOS
from gimbal_kinematics.ros.readiness import announce_when_connected
from gimbal_kinematics.ros.params import declare_and_read
from gimbal_kinematics.sync import StampOrder

from . import messages as m
from .gyro_bias_ekf import EkfOutput, GyroBiasEkf
from .gyro_bias_ekf_params import DESCRIPTION, PARAMS, GyroBiasEkfParams


class GyroBiasEkfNode(Node):
    def __init__(self, **node_kwargs) -> None:
        super().__init__("gyro_bias_ekf", **node_kwargs)
        values = declare_and_read(self, PARAMS)
        self.core = GyroBiasEkf(GyroBiasEkfParams.from_values(values))
        self.rate = values["sim_rate_hz"]
        self.progress_every = values["progress_every_steps"]
        self.diag_period_ns = int(round(values["diagnostics_period_s"] * 1e9))
        self._next_diag_ns = 0
        self._resets_seen = 0
        self._warned = 0
        self.rejected_no_rates = 0  # gyro messages whose rates are marked not provided (REP 145)
        self.pub_bias = self.create_publisher(m.Vector3Stamped, "~/bias", GRAPH_QOS)
        self.pub_sigma = self.create_publisher(m.Vector3Stamped, "~/bias_sigma", GRAPH_QOS)
        self.pub_attitude = self.create_publisher(Imu, "~/attitude", GRAPH_QOS)
        self.pub_diag = self.create_publisher(DiagnosticArray, "/diagnostics", GRAPH_QOS)
        self.pub_progress = self.create_publisher(Clock, "~/progress", GRAPH_QOS)
        # Encoders and INS before the gyro of the same stamp: the gyro sample completes a step.
        self._handlers = {"encoders": self._on_encoders, "ins": self._on_ins, "gyro": self._on_gyro}
        self.order = StampOrder(tuple(self._handlers), int(round(values["max_sync_wait_s"] * 1e9)))
        self.subs = [
            self.create_subscription(Imu, "/gimbal/imu", lambda msg: self._on_input("gyro", msg), GRAPH_QOS),
            self.create_subscription(JointState, "/gimbal/joint_states", lambda msg: self._on_input("encoders", msg),
                                     GRAPH_QOS),
            self.create_subscription(Imu, "/ins/imu", lambda msg: self._on_input("ins", msg), GRAPH_QOS),
        ]
        announce_when_connected(self, self.pub_progress, inputs=self.subs)

    # ----------------------------------------------------------------- inputs
    def _on_input(self, stream: str, msg) -> None:
        for kind, item in self.order.add(stream, m.stamp_ns(msg.header.stamp), msg):
            self._handlers[kind](item)

    def _on_gyro(self, msg: Imu) -> None:
        t_ns = m.stamp_ns(msg.header.stamp)
        w = msg.angular_velocity
        if m.gyro_qr_provided(msg.angular_velocity_covariance):
            self._after(self.core.on_gyro(t_ns * 1e-9, w.y, w.z))
        else:
            self.rejected_no_rates += 1
            self._warn("gyro message marks its angular velocity not provided (covariance[0] = -1 without "
                       "y, z variances); not fused")
        k = m.step_of_stamp(t_ns, self.rate)
        if (k + 1) % self.progress_every == 0:
            self.pub_progress.publish(m.clock_msg(m.step_stamp_ns(k + 1, self.rate)))

    def _on_encoders(self, msg: JointState) -> None:
        readings = m.encoder_readings(msg)
        if readings is None:
            self._warn("encoder message without the three gimbal joints ignored")
            return
        self._after(self.core.on_encoders(m.stamp_ns(msg.header.stamp) * 1e-9, *readings))

    def _on_ins(self, msg: Imu) -> None:
        t_ns = m.stamp_ns(msg.header.stamp)
        euler = m.euler_of_imu(msg)
        before = self.core.counters
        out = self.core.on_ins(t_ns * 1e-9, euler, m.vec_of(msg.angular_velocity))
        after = self.core.counters
        if out is not None:
            self._after(out)
        elif euler is None or after.rejected_nonfinite > before.rejected_nonfinite \
                or after.rejected_out_of_order > before.rejected_out_of_order:
            # No update will come for this stamp: publish the current estimate so a controller
            # waiting for it carries on. (An accepted sample whose gyro has not arrived yet
            # is answered by the update, when it does.)
            self._warn(f"INS sample at {t_ns * 1e-9:.3f} s rejected or without attitude; "
                       "publishing the current estimate")
            self._publish_current(t_ns)

    # ----------------------------------------------------------------- outputs
    def _warn(self, text: str) -> None:
        self._warned += 1
        self.get_logger().warning(f"{text} ({self._warned} warnings)", throttle_duration_sec=1.0)

    def _after(self, out: EkfOutput | None) -> None:
        c = self.core.counters
        if c.resets + c.realignments > self._resets_seen:
            self._resets_seen = c.resets + c.realignments
            t, reason = self.core.reset_log[-1]
            self.get_logger().warning(f"filter reset at {t:.3f} s: {reason}")
            self._next_diag_ns = 0
        if out is None:
            return
        t_ns = int(round(out.t * 1e9))
        self._publish(t_ns, out.bias, out.bias_sigma, out.quat_nm, out.attitude_cov)

    def _publish_current(self, t_ns: int) -> None:
        core = self.core
        if core.aligned:
            self._publish(t_ns, core.bias, core.bias_sigma, core.quat_nm, core.P[:3, :3])
        else:
            self._publish(t_ns, core.bias, core.bias_sigma, None, None)

    def _publish(self, t_ns: int, bias, sigma, quat, att_cov) -> None:
        self.pub_bias.publish(m.vector3_msg(t_ns, m.GIMBAL_FRAME, bias))
        self.pub_sigma.publish(m.vector3_msg(t_ns, m.GIMBAL_FRAME, sigma))
        rate = self.core.corrected_rate
        self.pub_attitude.publish(m.attitude_msg(t_ns, quat, att_cov, rate))
        if t_ns >= self._next_diag_ns:
            self._next_diag_ns = t_ns + self.diag_period_ns
            self.pub_diag.publish(m.health_msg(t_ns, self.get_name(), self.core.counters, self.core.aligned))


def main(argv: list[str] | None = None) -> int:
    return run_node(GyroBiasEkfNode, "gyro_bias_ekf", DESCRIPTION, argv)


if __name__ == "__main__":
    sys.exit(main())

"""``gyro_bias_ekf`` node: paper 1's gyro-bias EKF (:class:`.gyro_bias_ekf.GyroBiasEkf`).

Inputs: the gimbal gyro (``/gimbal/imu``, q_m and r_m), the encoders
(``/gimbal/joint_states``) and the INS (``/ins/imu``, orientation and body rates). Remap
them to run against other topics, e.g. a driver's or a bag played back under other names.

Outputs, one of each per INS sample (stamped like it), so a controller can wait for the
estimate of its step:

* ``~/bias`` and ``~/bias_sigma`` (Vector3Stamped, rad/s, frame ``gimbal_inner_frd``): the
  bias estimate (x: roll channel, i.e. the INS-rate part of paper 1 eq. 4; y, z: the
  gimbal gyro's q, r) and its 1σ;
* ``~/attitude`` (Imu): the estimated C(n,m) as orientation, with the 3×3 covariance of
  the attitude error resolved in the navigation frame (``map_ned``, the frame the small
  rotation is about), and the bias-corrected inertial rate of the inner gimbal;
* ``/diagnostics`` (diagnostic_msgs/DiagnosticArray): the health counters (updates,
  gated, rejected, resets, re-alignments) once per ``diagnostics_period_s`` of stamp time
  and after each reset; in free timing also the input counters, the incompatible-QoS
  peers and the NIS window (below).

Timing (parameter ``timing``, :mod:`gimbal_kinematics.ros.node_io`):

* ``lockstep`` (what ``gimbal-run`` sets): inputs and outputs with ``GRAPH_QOS``; the node
  reports on ``~/progress`` (rosgraph_msgs/Clock) the next lockstep step it needs, so the
  vehicle or the bag player does not outrun it. /diagnostics carries the filter counters
  only, so scenario bags stay byte-identical.
* ``free`` (the default when started alone): SensorDataQoS inputs, default-QoS outputs.
  The node never waits on a step grid, ``/clock`` or a progress topic: the filter
  propagates on each gyro sample with dt from consecutive gyro stamps, and updates on each
  INS attitude sample. Stamps may be wall-clock or epoch times: they are kept as integer
  nanoseconds and the filter runs on seconds relative to the first stamp seen (a float64
  near 1.8e9 s resolves only 2.4e-7 s), converted back to absolute stamps on output.
  Duplicate stamps and samples older than their stream's last one (by less than
  ``clock_jump_s``) are dropped and counted; gaps (dropped samples) and the interval
  jitter are counted (:class:`gimbal_kinematics.stream_stats.StreamStats`); ±30 % jitter
  needs nothing else, since every step uses its own dt. A stream whose stamps jump back by
  more than ``clock_jump_s`` (a bag loop, a restarted driver) resets the filter and
  re-bases the relative time, once 3 stamps in a row agree on the jump; a single stamp that
  far off (3 years ahead, zero) is an outlier, dropped and counted (``<stream>_outliers``),
  and the filter goes on (:mod:`gimbal_kinematics.stamps`). ``~/progress`` still reports the newest gyro stamp
  processed (absolute), every ``progress_every_steps`` gyro samples, for a pacing player.

The node chooses its input policy once, in its constructor
(:mod:`gimbal_kinematics.input_policy`: :class:`~gimbal_kinematics.input_policy.LockstepOrder`
or :class:`~gimbal_kinematics.input_policy.FreeOrder`); the rest of the node is the same in
both timings. In both the three streams are fed to the filter in stamp order, the encoders
and INS of a stamp before its gyro sample, whatever order the middleware delivers them in;
so a replay at any speed computes exactly what the run computed, and a bag replayed into
the node gives what its messages fed to the core in stamp order give. Outputs are
serialized by the struct encoders (:mod:`gimbal_kinematics.ros.messages`, ``*_cdr``):
building rclpy message objects took a third of the node's time on a bag replayed at full
speed.

Encoder readings are linearly interpolated, to each gyro stamp (for eq. 4's roll rate) and
to each INS stamp (for the measured attitude), never taken at the nearest stamp: the
gimbal moves between samples, and at a 100 Hz encoder and a 50 Hz INS with independent
clocks the nearest sample can be 5 ms off, 5 mrad at 1 rad/s, far above the 0.05° encoder
noise the filter assumes; interpolation leaves an error of order ¼·θ̈·dt², negligible.
The INS body rates are interpolated to the gyro stamps the same way.

Input checks (counted on /diagnostics, never fused): non-finite values and stamps (the
core's ``rejected_nonfinite``), backward and duplicate stamps, a ``/gimbal/imu`` whose
angular velocity is marked not provided (``[0] = -1`` without y, z variances: the older
``[0] = -1`` with positive ``[4]``, ``[8]`` marking only the roll axis is accepted, as are
this project's large x variance and a driver's all-zero "unknown"), an INS message whose
angular velocity is marked not provided (eq. 4 needs it), an INS message without
orientation (its rates are used, there is nothing to fuse), and a JointState that lacks
one of the three gimbal joints (other joints may be present).

An INS sample whose estimate cannot be produced (non-finite, or before alignment) still
gets an output: the current estimate with that stamp, so a waiting controller never stalls.

``use_sim_time`` works as usual: the filter runs on message stamps only; the node's clock
(ROS time, or /clock with ``use_sim_time``) serves logging alone, and the readiness check
runs on a steady timer, so nothing waits for a /clock that a driver graph does not have.
"""
from __future__ import annotations

import sys

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.node import Node
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, JointState

from gimbal_kinematics.input_policy import Step, order_policy
from gimbal_kinematics.ros.wire import clock_cdr
from gimbal_kinematics.ros.diagnostics import health_msg
from gimbal_kinematics.ros.node_io import NodeIo
from gimbal_kinematics.ros.node_main import run_node
from gimbal_kinematics.ros.params import declare_and_read
from gimbal_kinematics.ros.readiness import announce_when_connected
from gimbal_kinematics.ros.views import decoder

from . import messages as m
from .gyro_bias_ekf import GyroBiasEkf
from .gyro_bias_ekf_model import PSI
from .gyro_bias_ekf_params import DESCRIPTION, PARAMS, GyroBiasEkfParams
from .nis import NisWindow
from .wire import ekf_messages

#: The input streams, in the order the filter takes them within one stamp: encoders and
#: INS before the gyro sample that completes the step.
STREAMS = ("encoders", "ins", "gyro")
#: Filter counters whose increase is a WARN on /diagnostics (with the input-check counters).
WARN_COUNTERS = ("resets", "realignments", "gated", "rejected_nonfinite", "rejected_out_of_order",
                 *m.BAD_INPUT_KEYS, "incompatible_qos", "wrong_type")


class GyroBiasEkfNode(Node):
    def __init__(self, **node_kwargs) -> None:
        super().__init__("gyro_bias_ekf", **node_kwargs)
        values = declare_and_read(self, PARAMS)
        self.core = GyroBiasEkf(GyroBiasEkfParams.from_values(values))
        timing = values["timing"]
        # the one choice of timing (module docstring)
        self.policy = order_policy(timing, STREAMS, max_wait_ns=int(round(values["max_sync_wait_s"] * 1e9)),
                                   rate_hz=values["sim_rate_hz"], progress_every=values["progress_every_steps"],
                                   clock_jump_ns=int(round(values["clock_jump_s"] * 1e9)),
                                   on_restart=lambda reason: self.core.reset(reason, 0.0))
        self.diag_period_ns = int(round(values["diagnostics_period_s"] * 1e9))
        self._next_diag_ns = 0
        self._resets_seen = 0
        self._warned = 0
        self.bad = {k: 0 for k in m.BAD_INPUT_KEYS}
        self.nis = NisWindow(3, window=values["nis_window"])
        self.io = io = NodeIo(self)
        self.pub_bias = io.advertise(m.Vector3Stamped, "~/bias", timing)
        self.pub_sigma = io.advertise(m.Vector3Stamped, "~/bias_sigma", timing)
        self.pub_attitude = io.advertise(Imu, "~/attitude", timing)
        self.pub_diag = io.advertise(DiagnosticArray, "/diagnostics", timing)
        self.pub_progress = io.advertise(Clock, "~/progress", timing)
        self._validate = {"encoders": self._encoders, "ins": self._ins, "gyro": self._gyro}
        imu, joint_state = decoder(Imu), decoder(JointState)
        self.subs = [
            # raw bytes decoded into views with the messages' field names (gimbal_kinematics.ros.views):
            # rclpy's message objects cost more than the filter on a bag replayed at full speed
            io.subscribe(Imu, "/gimbal/imu", lambda data: self._on_input("gyro", imu(data)), timing, raw=True),
            io.subscribe(JointState, "/gimbal/joint_states",
                         lambda data: self._on_input("encoders", joint_state(data)), timing, raw=True),
            io.subscribe(Imu, "/ins/imu", lambda data: self._on_input("ins", imu(data)), timing, raw=True),
        ]
        announce_when_connected(self, self.pub_progress, inputs=self.subs)

    # ----------------------------------------------------------------- inputs
    def _on_input(self, stream: str, msg) -> None:
        for step in self.policy.add(stream, m.stamp_ns(msg.header.stamp), msg):
            self._validate[step.kind](step)

    def _gyro(self, step: Step) -> None:
        msg = step.msg
        if not m.gyro_rates_provided(msg):
            self.bad["gyro_not_provided"] += 1
            self._warn("gimbal gyro message with angular velocity marked not provided ignored")
            return
        w = msg.angular_velocity
        self.core.on_gyro(step.t, w.y, w.z)
        self._after()
        progress = self.policy.progress(step)
        if progress is not None:
            self.pub_progress.publish(clock_cdr(progress))

    def _encoders(self, step: Step) -> None:
        readings = m.encoder_angles(step.msg)
        if readings is None:
            self.bad["joint_names_missing"] += 1
            self._warn(f"encoder message without the joints {list(m.GIMBAL_ENCODER_JOINTS)} ignored")
            return
        self.core.on_encoders(step.t, *readings)
        self._after()

    def _ins(self, step: Step) -> None:
        msg, t_ns = step.msg, step.stamp_ns
        if not m.field_provided(msg.angular_velocity_covariance):
            self.bad["ins_rates_not_provided"] += 1
            self._warn(f"INS sample at {t_ns * 1e-9:.3f} s without body rates (eq. 4 needs them) ignored; "
                       "publishing the current estimate")
            self._publish_current(t_ns)
            return
        euler = m.euler_of_imu(msg)
        if euler is None:
            self.bad["ins_attitude_not_provided"] += 1
        before = self.core.counters
        self.core.on_ins(step.t, euler, m.vec_of(msg.angular_velocity))
        after = self.core.counters
        if not self._after() and (euler is None or after.rejected_nonfinite > before.rejected_nonfinite
                                  or after.rejected_out_of_order > before.rejected_out_of_order):
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

    def _after(self) -> bool:
        """Log a reset; publish every output the last core call produced; whether any."""
        c = self.core.counters
        if c.resets + c.realignments > self._resets_seen:
            self._resets_seen = c.resets + c.realignments
            t, reason = self.core.reset_log[-1]
            self.get_logger().warning(f"filter reset at {t:.3f} s: {reason}")
            self._next_diag_ns = 0
        outs = self.core.take_outputs()
        for out in outs:
            if out.d2 > 0.0 or not out.accepted:
                self.nis.add(out.d2)  # an update (accepted or gated), not an alignment
            self._publish(self.policy.stamp_of(out.t), out.bias, out.bias_sigma, out.quat_nm, out.attitude_cov)
        return bool(outs)

    def _publish_current(self, t_ns: int) -> None:
        core = self.core
        if core.aligned:
            self._publish(t_ns, core.bias, core.bias_sigma, core.quat_nm, core.P[PSI, PSI])
        else:
            self._publish(t_ns, core.bias, core.bias_sigma, None, None)

    def _publish(self, t_ns: int, bias, sigma, quat, att_cov) -> None:
        # serialized by gimbal_estimators.wire (the engine writes the same bytes into its bag)
        for (_, _, data), pub in zip(ekf_messages(t_ns, bias, sigma, quat, att_cov, self.core.corrected_rate),
                                     (self.pub_bias, self.pub_sigma, self.pub_attitude)):
            pub.publish(data)
        if t_ns >= self._next_diag_ns:
            self._next_diag_ns = t_ns + self.diag_period_ns
            self.pub_diag.publish(self.health(t_ns))

    def health(self, t_ns: int) -> DiagnosticArray:
        """The /diagnostics message: what the input policy reports (module docstring)."""
        fields, nis_verdict = self.policy.report(self.core.counters._asdict(),
                                                 {**self.bad, **self.io.counters()},
                                                 self.nis.as_dict(), self.nis.verdict().verdict)
        return health_msg(t_ns, self.get_name(), fields, ready=self.core.aligned, warn=WARN_COUNTERS,
                          nis_verdict=nis_verdict)


def main(argv: list[str] | None = None) -> int:
    return run_node(GyroBiasEkfNode, "gyro_bias_ekf", DESCRIPTION, argv)


if __name__ == "__main__":
    sys.exit(main())

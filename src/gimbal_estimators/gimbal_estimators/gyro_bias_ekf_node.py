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
  jitter are counted (:class:`gimbal_kinematics.timing.stream_stats.StreamStats`); ±30 % jitter
  needs nothing else, since every step uses its own dt. A stream whose stamps jump back by
  more than ``clock_jump_s`` (a bag loop, a restarted driver) resets the filter and
  re-bases the relative time, once 3 stamps in a row agree on the jump; a single stamp that
  far off (3 years ahead, zero) is an outlier, dropped and counted (``<stream>_outliers``),
  and the filter goes on (:mod:`gimbal_kinematics.timing.stamps`). ``~/progress`` still reports the newest gyro stamp
  processed (absolute), every ``progress_every_steps`` gyro samples, for a pacing player.

The node is the shape every node copies (:mod:`gimbal_kinematics.ros.node_edge`: inputs,
checks, warnings and the diagnostics throttle). It chooses its input policy once, in its constructor
(:mod:`gimbal_kinematics.timing.input_policy`: :class:`~gimbal_kinematics.timing.input_policy.LockstepOrder`
or :class:`~gimbal_kinematics.timing.input_policy.FreeOrder`); the rest of the node is the same in
both timings. In both the three streams are fed to the filter in stamp order, the encoders
and INS of a stamp before its gyro sample, whatever order the middleware delivers them in;
so a replay at any speed computes exactly what the run computed, and a bag replayed into
the node gives what its messages fed to the core in stamp order give. Outputs are
serialized by the struct encoders (:mod:`gimbal_kinematics.ros.messages`, ``*_cdr``) and
inputs decoded into views (:mod:`gimbal_kinematics.ros.views`): rclpy message objects took
a third of the node's time on a bag replayed at full speed.

Encoder readings are linearly interpolated, to each gyro stamp (for eq. 4's roll rate) and
to each INS stamp (for the measured attitude), never taken at the nearest stamp: the
gimbal moves between samples, and at a 100 Hz encoder and a 50 Hz INS with independent
clocks the nearest sample can be 5 ms off, 5 mrad at 1 rad/s, far above the 0.05° encoder
noise the filter assumes; interpolation leaves an error of order ¼·θ̈·dt², negligible.
The INS body rates are interpolated to the gyro stamps the same way.

Input checks (counted on /diagnostics, never fused): non-finite values and stamps (the
core's ``rejected_nonfinite``), backward and duplicate stamps (dropped by the input policy,
``rejected_out_of_order``; the core sees only ordered samples), malformed messages, a ``/gimbal/imu`` whose
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

from rclpy.node import Node
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, JointState

from gimbal_kinematics.ros.node_edge import NodeEdge
from gimbal_kinematics.ros.node_main import run_node
from gimbal_kinematics.ros.params import declare_and_read
from gimbal_kinematics.ros.readiness import announce_when_connected
from gimbal_kinematics.timing.input_policy import Step, order_policy
from gimbal_kinematics.timing.sync import RateSync

from . import messages as m
from .gyro_bias_ekf import EkfOutput, Fed, GyroBiasEkf
from .gyro_bias_ekf_params import DESCRIPTION, PARAMS, GyroBiasEkfParams
from .gyro_bias_ekf_stamp import EkfInput
from .nis import NisWindow
from .wire import ekf_messages

#: The input streams, in the order the filter takes them within a stamp (the gyro completes the step).
STREAMS = ("encoders", "ins", "gyro")
INPUTS = (("gyro", Imu, "/gimbal/imu"), ("encoders", JointState, "/gimbal/joint_states"), ("ins", Imu, "/ins/imu"))
OUTPUTS = ((m.Vector3Stamped, "~/bias"), (m.Vector3Stamped, "~/bias_sigma"), (Imu, "~/attitude"), (Clock, "~/progress"))
#: The filter's counters on /diagnostics, in order (``rejected_out_of_order``: the input policy's).
HEALTH = ("updates", "gated", "rejected_nonfinite", "rejected_out_of_order", "resets", "realignments",
          "singular_elevation")
#: Counters whose increase is a WARN on /diagnostics (with the input-check counters).
WARN_COUNTERS = ("resets", "realignments", "gated", "rejected_nonfinite", "rejected_out_of_order",
                 *m.BAD_INPUT_KEYS, "malformed", "incompatible_qos", "wrong_type")


class GyroBiasEkfNode(Node):
    def __init__(self, **node_kwargs) -> None:
        super().__init__("gyro_bias_ekf", **node_kwargs)
        values = declare_and_read(self, PARAMS)
        self.core = EkfInput(GyroBiasEkf(GyroBiasEkfParams.from_values(values)), RateSync)  # checks, then grouping
        self.edge = edge = NodeEdge(self, values, m.BAD_INPUT_KEYS)
        # the one choice of timing (module docstring)
        self.policy = order_policy(values["timing"], STREAMS, max_wait_ns=int(round(values["max_sync_wait_s"] * 1e9)),
                                   rate_hz=values["sim_rate_hz"], progress_every=values["progress_every_steps"],
                                   clock_jump_ns=int(round(values["clock_jump_s"] * 1e9)), on_restart=self._restart)
        self.nis = NisWindow(3, window=values["nis_window"])
        edge.advertise_all(OUTPUTS)
        edge.advertise_diagnostics()
        self._take = {"encoders": self._encoders, "ins": self._ins, "gyro": self._gyro}
        self.subs = edge.subscribe_all(INPUTS, self._on_input)
        announce_when_connected(self, edge.pubs["~/progress"], inputs=self.subs)

    def _on_input(self, stream: str, msg) -> None:
        for step in self.policy.add(stream, m.stamp_ns(msg.header.stamp), msg):
            self._take[step.kind](step)

    def _gyro(self, step: Step) -> None:
        if not m.gyro_rates_provided(step.msg):
            return self.edge.reject("gyro_not_provided", "gimbal gyro message without its y, z rates ignored")
        w = step.msg.angular_velocity
        self._fed(self.core.on_gyro(step.t, w.y, w.z))
        self.edge.progress(self.policy.progress(step))

    def _encoders(self, step: Step) -> None:
        readings = m.encoder_angles(step.msg)
        if readings is None:
            return self.edge.reject("joint_names_missing",
                                    f"encoder message without the joints {list(m.GIMBAL_ENCODER_JOINTS)} ignored")
        self._fed(self.core.on_encoders(step.t, *readings))

    def _ins(self, step: Step) -> None:
        msg, at = step.msg, f"INS sample at {step.stamp_ns * 1e-9:.3f} s"
        if not m.field_provided(msg.angular_velocity_covariance):
            self.edge.reject("ins_rates_not_provided", f"{at} without body rates (eq. 4 needs them) ignored; "
                             "publishing the current estimate")
            return self._publish(step.stamp_ns)
        euler = m.euler_of_imu(msg)
        self.edge.counts["ins_attitude_not_provided"] += euler is None
        fed = self.core.on_ins(step.t, euler, m.vec_of(msg.angular_velocity))
        if not self._fed(fed) and fed.why is not None:
            self.edge.warn(f"{at}: {fed.why}; publishing the current estimate")
            self._publish(step.stamp_ns)

    def _restart(self, reason: str) -> None:  # the input policy saw the clock jump back: a new run
        self.core.reset(reason, 0.0)
        self.get_logger().warning(f"filter reset: {reason}")
        self.edge.diagnostics_now()

    def _fed(self, fed: Fed) -> bool:
        """Log the core's re-alignments; publish every output it completed; whether any."""
        for t, reason in fed.realigned:
            self.get_logger().warning(f"filter reset at {t:.3f} s: {reason}")
            self.edge.diagnostics_now()
        outs = self.core.take_outputs()
        for out in outs:
            if out.nis is not None:
                self.nis.add(out.nis)
            self._publish(self.policy.stamp_of(out.t), out)
        return bool(outs)

    def _publish(self, t_ns: int, out: EkfOutput | None = None) -> None:
        """An output, or (None) the current estimate; serialized by gimbal_estimators.wire (the
        engine writes the same bytes into its bag)."""
        e = self.core if out is None else out
        self.edge.publish(ekf_messages(t_ns, e.bias, e.bias_sigma, e.quat_nm, e.attitude_cov, self.core.corrected_rate))
        self.edge.diagnostics(t_ns, lambda: self.health(t_ns))

    def health(self, t_ns: int):
        """The /diagnostics message: what the input policy reports (module docstring)."""
        counts = {**self.core.counters._asdict(), "rejected_out_of_order": self.policy.rejected}
        return self.edge.health(t_ns, self.policy, {k: counts[k] for k in HEALTH}, self.nis, ready=self.core.aligned,
                                warn=WARN_COUNTERS)


def main(argv: list[str] | None = None) -> int:
    return run_node(GyroBiasEkfNode, "gyro_bias_ekf", DESCRIPTION, argv)


if __name__ == "__main__":
    sys.exit(main())

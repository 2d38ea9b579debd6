"""``platform_alignment`` node: paper 3's rotation-modulated fine alignment (8-state RLS,
:class:`.rotation_alignment.RotationAlignmentRls`) on a static base.

Inputs, per lockstep step k at the steps where each samples: the platform accelerometers
(``/platform/imu`` linear_acceleration, stable-element axes) and the azimuth joint of the
platform (``joint_topic``, joint ``azimuth_joint``: the resolver angle θ_a about the platform
vertical, and its rate). The platform azimuth the filter believes is ψ = θ_a +
``base_heading_deg`` (the heading the base is taken to have, e.g. from coarse alignment);
paper 3's rotation angle is φz = −ψ (ENU up). A step's joint sample is applied before its
accelerometer sample, so the result does not depend on arrival order.

Outputs, once per averaging block (``block_s``), stamped with the sample that closed it
(topics under the node's namespace; misalignment = the rotation vector from the platform
frame the filter believes to the true one, NED components, frame ``map_ned``):

* ``~/misalignment`` (+ ``~/misalignment_sigma``): now, i.e. what the platform must be
  torqued back by;
* ``~/initial_misalignment`` (+ ``_sigma``): at the alignment start, paper 3's
  (δφE0, δφN0, δφU0) as NED components;
* ``~/north_drift`` (+ ``_sigma``): the n-fixed north gyro drift ε_N [rad/s] as an NED vector
  (east and down are not estimated: 0, σ = −1);
* ``~/gyro_drift`` and ``~/accel_bias`` (+ ``_sigma``): the level platform drifts
  (ε_x, ε_y) [rad/s] — the rates the gyro-stabilized platform drifts at, i.e. the negative
  of the gyros' rate biases, as platform_servo's ``drift_deg_h`` takes them — and the
  accelerometer biases (∇x, ∇y) [m/s²], frame ``platform_frd`` (z not estimated: 0, σ = −1);
* ``~/status`` (Vector3Stamped): x = estimate age [s] since the alignment start, y = RLS
  updates so far, z = 1 when converged (misalignment σ under the thresholds) else 0.

It must see every sample, so it takes part in pacing: ``~/progress`` (rosgraph_msgs/Clock)
carries the next step it needs. Bad input: NaN/inf samples and stamps at or before the last
step are rejected and counted (warned at most once a second); a stamp more than
``clock_jump_s`` back (a bag looping) restarts the alignment.

Timing (parameter ``timing``, :mod:`gimbal_kinematics.ros.node_io`), chosen once in the
constructor as the input policy (:func:`gimbal_kinematics.timing.input_policy.grouped_policy`); the
node's body is the same in both:

* ``lockstep`` (what ``gimbal-run`` sets): ``GRAPH_QOS``, inputs grouped by step on the
  ``sim_rate_hz`` grid (off-grid stamps rejected), ``~/progress`` on the grid, no
  /diagnostics (byte-identical bags).
* ``free`` (the default when started alone): SensorDataQoS inputs, default-QoS outputs, no
  step grid, no wait on ``/clock`` or a progress topic. The two streams are fed to the core
  in stamp order (:class:`gimbal_kinematics.timing.sync.StampOrder`, the joint before the
  accelerometer of the same stamp, a sample waiting at most ``max_sync_wait_s`` for the
  other stream); the core holds the newest joint angle and extrapolates it with its rate
  to each accelerometer stamp (its ``max_joint_age_s`` bounds how old). Stamps are integer
  nanoseconds and the core runs on seconds relative to the first stamp seen (its
  integrals need the interval, and a float64 near 1.8e9 s resolves only 2.4e-7 s); outputs
  carry the absolute stamps. /diagnostics, every ``diagnostics_period_s`` of stamp time
  after an output: the core's counters, the node's (``rejected_joints``: a JointState
  without ``azimuth_joint``), per stream StreamStats (``imu_*``, ``joint_*``: received,
  duplicates, out_of_order, clock_jumps, dropped, jitter_rms), ``incompatible_qos`` and
  the NIS window of the block updates (``nis_*``, 2 dof). ``~/progress`` reports the
  newest accelerometer stamp every ``progress_every_steps`` samples.
"""
from __future__ import annotations

import math
import sys

from geometry_msgs.msg import Vector3Stamped
from rclpy.node import Node
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, JointState

from gimbal_kinematics.ros.node_edge import NodeEdge, grouped_policy_of, input_warnings
from gimbal_kinematics.ros.node_main import run_node
from gimbal_kinematics.ros.params import declare_and_read
from gimbal_kinematics.ros.readiness import announce_when_connected
from gimbal_kinematics.timing.input_policy import Step

from . import messages as m
from .nis import NisWindow
from .platform_alignment_params import DESCRIPTION, PARAMS
from .rotation_alignment import RotationAlignmentParams, RotationAlignmentRls
from .wire import alignment_messages

#: Output topics, under the node's namespace (module docstring).
OUTPUTS = ("misalignment", "misalignment_sigma", "initial_misalignment", "initial_misalignment_sigma",
           "north_drift", "north_drift_sigma", "gyro_drift", "gyro_drift_sigma", "accel_bias", "accel_bias_sigma",
           "status")
#: The core's counters on /diagnostics.
CORE_COUNTERS = ("accepted", "rejected_nonfinite", "rejected_no_joint", "rejected_stale_joint",
                 "joint_rejected_nonfinite", "resets")
#: Counters whose non-zero value is a WARN on /diagnostics.
WARN_COUNTERS = ("rejected_nonfinite", "rejected_no_joint", "rejected_stale_joint", "joint_rejected_nonfinite",
                 "resets", "rejected_joints", *input_warnings("imu", "joint"))


class PlatformAlignmentNode(Node):
    def __init__(self, **node_kwargs) -> None:
        super().__init__("platform_alignment", **node_kwargs)
        values = declare_and_read(self, PARAMS)
        self.core = RotationAlignmentRls(RotationAlignmentParams.from_values(values))
        self.azimuth_joint = values["azimuth_joint"]
        self.heading = math.radians(values["base_heading_deg"])
        # the one choice of timing (module docstring); within a step the joint goes first
        self.policy = grouped_policy_of(self, values, ("joint", "imu"), "imu", self.core.reset)
        self.nis = NisWindow(2, window=values["nis_window"])
        self.edge = edge = NodeEdge(self, values, ("rejected_joints",))
        edge.advertise_all([(Vector3Stamped, f"~/{name}") for name in OUTPUTS] + [(Clock, "~/progress")])
        edge.advertise_diagnostics(self.policy)
        self.subs = edge.subscribe_all((("imu", Imu, "/platform/imu"), ("joint", JointState, values["joint_topic"])),
                                       self._on_input)
        announce_when_connected(self, edge.pubs["~/progress"], self.subs,
                                [edge.pubs[f"~/{name}"] for name in OUTPUTS], values["wait_for_subscribers"])

    def _on_input(self, kind: str, msg) -> None:
        for step in self.policy.add(kind, m.stamp_ns(msg.header.stamp), msg):
            self._step(step)

    def _step(self, step: Step) -> None:
        where = f"{step.stamp_ns * 1e-9:.6f} s"
        if step.kind == "joint":
            fed = self._validate_joint(step.t, step.msg, where)
        else:
            fed = self.core.on_accel(step.t, m.vec_of(step.msg.linear_acceleration))
        if fed is not None and fed.why is not None:
            self._warn_rejected(where, fed.why)
        if fed is not None and fed.nis is not None:
            self.nis.add(fed.nis)
        if fed is not None and fed.output is not None:
            # serialized by gimbal_estimators.wire (the engine writes the same bytes into its bag)
            self.edge.publish(alignment_messages(step.stamp_ns, fed.output))
            self.edge.diagnostics(step.stamp_ns, lambda: self.health(step.stamp_ns))
        self.edge.progress(self.policy.progress(step))

    def health(self, t_ns: int):
        """/diagnostics: what the input policy reports (module docstring)."""
        c = self.core.counters
        core = {k: getattr(c, k) for k in CORE_COUNTERS}
        core.update(updates=self.core.n_updates)
        return self.edge.health(t_ns, self.policy, core, self.nis, ready=self.core.n_updates > 0,
                                not_ready="no estimate yet", warn=WARN_COUNTERS)

    def _validate_joint(self, t: float, msg, where: str):
        joint = m.joint_position_velocity(msg, self.azimuth_joint)
        if joint is None:
            return self.edge.reject("rejected_joints", f"{where}: no joint {self.azimuth_joint!r} with a position: ignored")
        return self.core.on_joint_state(t, joint[0] + self.heading, joint[1])

    def _warn_rejected(self, where: str, why: str) -> None:
        c = self.core.counters
        self.edge.warn(f"{where}: sample rejected: {why} (so far: accelerometer {c.rejected_nonfinite} non-finite, "
                       f"{c.rejected_no_joint + c.rejected_stale_joint} without a joint angle; joint "
                       f"{c.joint_rejected_nonfinite} non-finite)")


def main(argv: list[str] | None = None) -> int:
    return run_node(PlatformAlignmentNode, "platform_alignment", DESCRIPTION, argv)


if __name__ == "__main__":
    sys.exit(main())

"""``platform_navigator`` node: paper 3's local-level platform INS
(:class:`.platform_navigator.PlatformNavigator`; docs/spec.md §3.3).

Inputs: the stable element's accelerometers (``/platform/imu`` linear_acceleration,
platform axes) and the azimuth angle: the resolver angle θ_a (``joint_topic``, joint
``azimuth_joint``) or, with ``azimuth_source: servo`` (a moving base), the servo's rotation
angle φz (joint ``modulation_angle``; remap the topic for another servo): in free timing
``/platform_servo/modulation``; in lockstep ``/platform_servo/modulation_next``, the servo's
φz of a step published by its previous step (servo ``modulation_next: true``), since the
servo's φz of a step follows the navigator's command of that step. So in lockstep the first
accelerometer sample has no φz: it is refused and counted, and the grid of that input starts
a sample later. The newest joint sample is extrapolated with its rate to each
accelerometer stamp (a joint sample older than ``max_joint_age_s``, or none, leaves the
sample without a resolver angle: the core refuses and counts it). Within one stamp the joint
goes before the accelerometer, so the result does not depend on arrival order.

Outputs, per accepted accelerometer sample, stamped like it:

* ``~/command_rate`` (Vector3Stamped, rad/s, NED, frame ``map_ned``): ω_c^n, the rate the
  platform must turn at (earth rate + transport rate − drift compensation, the hand-off
  torquing pulse); ``platform_servo`` (``command_source: navigator``) follows it. A refused
  sample still gets one, the last command repeated, so a servo waiting for its step never
  stalls;
* ``~/fix`` (NavSatFix, REP 103/105: latitude and longitude in degrees, height above the
  WGS-84 ellipsoid, frame ``map_ned``; covariance type unknown: the core is a mechanisation
  without a filter, it has no covariance to give) and ``~/velocity`` (Vector3Stamped, NED
  m/s), every ``fix_every_samples`` accepted samples;
* ``~/odom`` (nav_msgs/Odometry, REP 105), with each fix: the position in a local ENU frame
  (``odom_frame_id``) whose origin is the first fix, the twist in ``odom_child_frame_id``,
  with covariance (:mod:`.navigator_odometry` says how each part is defined);
* ``/diagnostics`` (free timing): the core's counters (accepted, rejected_nonfinite,
  rejected_out_of_order: the stamps the input policy dropped, rejected_no_resolver, resets),
  the node's ``rejected_joints`` (a JointState without ``azimuth_joint``) and the input
  policy's stream statistics.

Bad input is counted and never integrated: stamps at or before the last one (the input
policy drops them), NaN/inf values, a missing resolver angle (the core); a stamp more than
``clock_jump_s`` back (a bag looping) makes the policy restart navigation from the hand-off.

Timing (parameter ``timing``), chosen once in the constructor as the input policy
(:func:`gimbal_kinematics.timing.input_policy.grouped_policy`), as ``platform_alignment`` does:
``lockstep`` groups the inputs by step on the ``sim_rate_hz`` grid and reports on
``~/progress`` the next step it needs (no /diagnostics: bags stay byte-identical);
``free`` feeds the two streams in stamp order, never waits on a grid, ``/clock`` or a
progress topic, and publishes /diagnostics every ``diagnostics_period_s`` of stamp time.
The core runs on integer-nanosecond stamps in both.
"""
from __future__ import annotations

import sys

from geometry_msgs.msg import Vector3Stamped
from rclpy.node import Node
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, JointState, NavSatFix

from gimbal_kinematics.maths.frames import MODULATION_JOINT
from gimbal_kinematics.timing.input_policy import Step
from gimbal_kinematics.params.table import ParameterError
from gimbal_kinematics.ros.wire import UNMEASURED_VARIANCE
from gimbal_kinematics.ros.node_edge import NodeEdge, grouped_policy_of, input_warnings
from gimbal_kinematics.ros.node_main import run_node
from gimbal_kinematics.ros.params import declare_and_read
from gimbal_kinematics.ros.readiness import announce_when_connected

from . import messages as m
from .navigator_odometry import NavigatorOdometry, OdometryModel
from .platform_navigator import NavigatorOutput, PlatformNavigator
from .platform_navigator_params import DESCRIPTION, PARAMS, PlatformNavigatorParams
from .wire import navigator_messages

#: ``platform_servo``'s φz (joint ``modulation_angle``) for ``azimuth_source: servo``, by timing:
#: its ``~/modulation`` (free), its ``~/modulation_next`` (lockstep: the step's φz made a step ahead)
SERVO_MODULATION_TOPICS = {"free": "/platform_servo/modulation", "lockstep": "/platform_servo/modulation_next"}
#: Counters whose non-zero value is a WARN on /diagnostics.
WARN_COUNTERS = ("rejected_nonfinite", "rejected_out_of_order", "rejected_no_resolver", "resets",
                 "rejected_joints", *input_warnings("imu", "joint"))


class PlatformNavigatorNode(Node):
    def __init__(self, **node_kwargs) -> None:
        super().__init__("platform_navigator", **node_kwargs)
        values = declare_and_read(self, PARAMS)
        self.core = PlatformNavigator(PlatformNavigatorParams.from_values(values))
        from_servo = values["azimuth_source"] == "servo"
        frames = (values["odom_frame_id"], values["odom_child_frame_id"])
        for name, frame in zip(("odom_frame_id", "odom_child_frame_id"), frames):
            if not isinstance(frame, str) or not frame.strip():
                raise ParameterError(f"parameter '{name}' must name a frame, got {frame!r}")
        if frames[0] == frames[1]:
            raise ParameterError(f"parameter 'odom_child_frame_id' = {frames[1]!r} must differ from odom_frame_id")
        self.odom_frames = frames
        self.odometry = NavigatorOdometry(OdometryModel.from_values(values, heading_known=not from_servo),
                                          UNMEASURED_VARIANCE)
        joint_topic = SERVO_MODULATION_TOPICS.get(values["timing"]) if from_servo else values["joint_topic"]
        self.azimuth_joint = MODULATION_JOINT if from_servo else values["azimuth_joint"]
        self.max_joint_age_ns = int(round(values["max_joint_age_s"] * 1e9))
        self.fix_every = values["fix_every_samples"]
        # the one choice of timing (module docstring); within a step the joint goes first
        self.policy = grouped_policy_of(self, values, ("joint", "imu"), "imu", self.core.reset,
                                        ahead=("joint",) if from_servo else ())
        self._joint: tuple[int, float, float] | None = None  # (stamp ns, θ_a, rate) of the newest sample
        self._last_command: tuple[float, float, float] | None = None
        self.edge = edge = NodeEdge(self, values, ("rejected_joints",))
        outputs = ((NavSatFix, "~/fix"), (Vector3Stamped, "~/velocity"), (Odometry, "~/odom"),
                   (Vector3Stamped, "~/command_rate"))
        edge.advertise_all(outputs + ((Clock, "~/progress"),))
        edge.advertise_diagnostics(self.policy)
        self.subs = edge.subscribe_all((("imu", Imu, "/platform/imu"), ("joint", JointState, joint_topic)),
                                       self._on_input)
        announce_when_connected(self, edge.pubs["~/progress"], self.subs,
                                tuple(edge.pubs[topic] for _, topic in outputs), values["wait_for_subscribers"])

    def _on_input(self, kind: str, msg) -> None:
        for step in self.policy.add(kind, m.stamp_ns(msg.header.stamp), msg):
            self._step(step)

    def _step(self, step: Step) -> None:
        if step.kind == "joint":
            self._validate_joint(step)
        else:
            fed = self.core.step(step.stamp_ns, m.vec_of(step.msg.linear_acceleration), self._theta_at(step.stamp_ns))
            if fed.why is not None:
                self._warn_refused(step.stamp_ns, fed.why)
            self._publish(step.stamp_ns, fed.output)
        self.edge.progress(self.policy.progress(step))

    def _validate_joint(self, step: Step) -> None:
        joint = m.joint_position_velocity(step.msg, self.azimuth_joint)
        if joint is None:
            return self.edge.reject("rejected_joints", f"{step.stamp_ns * 1e-9:.6f} s: no joint "
                                    f"{self.azimuth_joint!r} with a position: ignored")
        self._joint = (step.stamp_ns, joint[0], joint[1] or 0.0)

    def _theta_at(self, t_ns: int) -> float | None:
        """θ_a extrapolated to ``t_ns`` from the newest joint sample; None when there is none
        within ``max_joint_age_s`` (a non-finite one passes, for the core to count)."""
        if self._joint is None:
            return None
        t_j, theta, rate = self._joint
        age_ns = t_ns - t_j
        if not 0 <= age_ns <= self.max_joint_age_ns:
            return None
        return theta + rate * age_ns * 1e-9 if age_ns else theta

    def _warn_refused(self, t_ns: int, why: str) -> None:
        c = self.core
        self.edge.warn(f"{t_ns * 1e-9:.6f} s: sample refused: {why} (so far: {c.rejected_nonfinite} non-finite, "
                       f"{self.policy.rejected} out of order, {c.rejected_no_resolver} without a resolver angle; "
                       f"{c.resets} restarts)")

    def _publish(self, t_ns: int, out: NavigatorOutput | None) -> None:
        if out is not None:
            self._last_command = out.command_rate_n
        fix = out if out is not None and (self.core.accepted - 1) % self.fix_every == 0 else None
        odom = None if fix is None else (*self.odom_frames, *self.odometry(fix))
        # serialized by gimbal_estimators.wire (the engine writes the same bytes into its bag)
        self.edge.publish(navigator_messages(t_ns, fix, self._last_command, odom))
        self.edge.diagnostics(t_ns, lambda: self.health(t_ns))

    def health(self, t_ns: int):
        """/diagnostics: what the input policy reports (module docstring)."""
        return self.edge.health(t_ns, self.policy, self.core.counters(self.policy.rejected), ready=self.core.accepted > 0,
                                not_ready="not navigating yet", warn=WARN_COUNTERS)


def main(argv: list[str] | None = None) -> int:
    return run_node(PlatformNavigatorNode, "platform_navigator", DESCRIPTION, argv)


if __name__ == "__main__":
    sys.exit(main())

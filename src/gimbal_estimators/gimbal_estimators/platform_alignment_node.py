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
``reset_backjump_s`` back (a bag looping) restarts the alignment.
"""
from __future__ import annotations

import math
import sys

from geometry_msgs.msg import Vector3Stamped
from rclpy.node import Node
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, JointState

from gimbal_kinematics.ros.node_main import run_node
from gimbal_kinematics.ros.qos import GRAPH_QOS
from gimbal_kinematics.ros.readiness import announce_when_connected
from gimbal_kinematics.params import steps_per_sample
from gimbal_kinematics.ros.params import declare_and_read
from gimbal_kinematics.sync import StepGroups

from . import messages as m
from .platform_alignment_params import DESCRIPTION, PARAMS
from .rotation_alignment import AlignmentEstimate, RotationAlignmentParams, RotationAlignmentRls

#: Output topics, under the node's namespace (module docstring).
OUTPUTS = ("misalignment", "misalignment_sigma", "initial_misalignment", "initial_misalignment_sigma",
           "north_drift", "north_drift_sigma", "gyro_drift", "gyro_drift_sigma", "accel_bias", "accel_bias_sigma",
           "status")


class PlatformAlignmentNode(Node):
    def __init__(self, **node_kwargs) -> None:
        super().__init__("platform_alignment", **node_kwargs)
        v = declare_and_read(self, PARAMS)
        self.rate = v["sim_rate_hz"]
        self.imu_every = steps_per_sample(v, "imu_rate_hz")
        self.joint_every = steps_per_sample(v, "joint_rate_hz")
        self.core = RotationAlignmentRls(RotationAlignmentParams.from_values(v))
        self.azimuth_joint = v["azimuth_joint"]
        self.heading = math.radians(v["base_heading_deg"])
        self.sync = StepGroups(self._needs, v["reset_backjump_s"] * self.rate)
        self.progress_every = v["progress_every_steps"]
        self.wait_for_subscribers = v["wait_for_subscribers"]
        self.rejected_off_grid = 0
        self.rejected_joints = 0
        self._seen: tuple[int, ...] = ()
        self.pubs = {name: self.create_publisher(Vector3Stamped, f"~/{name}", GRAPH_QOS) for name in OUTPUTS}
        self.pub_progress = self.create_publisher(Clock, "~/progress", GRAPH_QOS)
        self.subs = [
            self.create_subscription(Imu, "/platform/imu", lambda msg: self._on_input("imu", msg), GRAPH_QOS),
            self.create_subscription(JointState, v["joint_topic"], lambda msg: self._on_input("joint", msg),
                                     GRAPH_QOS),
        ]
        announce_when_connected(self, self.pub_progress, self.subs, self.pubs.values(), self.wait_for_subscribers)

    # --- readiness and pacing ------------------------------------------------------------
    def _needs(self, k: int) -> tuple[str, ...]:
        return (("joint",) if k % self.joint_every == 0 else ()) + (("imu",) if k % self.imu_every == 0 else ())

    def _next_due(self, k: int) -> int:
        """The first step after ``k`` at which an input samples."""
        return min(k - k % self.imu_every + self.imu_every, k - k % self.joint_every + self.joint_every)

    # --- inputs ----------------------------------------------------------------------------
    def _warn(self, text: str) -> None:
        self.get_logger().warning(text, throttle_duration_sec=1.0)

    def _on_input(self, kind: str, msg) -> None:
        k = m.step_of_stamp(m.stamp_ns(msg.header.stamp), self.rate)
        if kind not in self._needs(k):
            self.rejected_off_grid += 1
            self._warn(f"{kind} stamped for step {k}, not one of its sample steps: ignored "
                       f"({self.rejected_off_grid} off the rate grid)")
            return
        groups = self.sync.add(kind, k, msg, self.get_logger())
        for step, group in groups:
            self._process(step, group)

    def _process(self, k: int, group: dict) -> None:
        t = k / self.rate
        core = self.core
        if "joint" in group:
            joint = m.joint_position_velocity(group["joint"], self.azimuth_joint)
            if joint is None:
                self.rejected_joints += 1
                self._warn(f"step {k}: no joint {self.azimuth_joint!r} with a position: ignored "
                           f"({self.rejected_joints} rejected)")
            else:
                core.on_joint_state(t, joint[0] + self.heading, joint[1])
        est = None
        if "imu" in group:
            est = core.on_accel(t, m.vec_of(group["imu"].linear_acceleration))
        c = core.counters
        seen = (c.rejected_nonfinite, c.rejected_out_of_order, c.rejected_no_joint, c.rejected_stale_joint,
                c.joint_rejected_nonfinite, c.joint_rejected_out_of_order)
        if seen != self._seen and any(seen):
            self._warn(f"step {k}: samples rejected so far: accelerometer {seen[0]} non-finite, {seen[1]} out of "
                       f"order, {seen[2] + seen[3]} without a joint angle; joint {seen[4]} non-finite, "
                       f"{seen[5]} out of order")
        self._seen = seen
        if est is not None:
            self._publish(m.step_stamp_ns(k, self.rate), est)
        nxt = self._next_due(k)
        if nxt // self.progress_every > k // self.progress_every:
            self.pub_progress.publish(m.clock_msg(m.step_stamp_ns(nxt, self.rate)))

    # --- outputs ---------------------------------------------------------------------------
    def _publish(self, t_ns: int, e: AlignmentEstimate) -> None:
        nav, plat = m.NAV_FRAME, m.PLATFORM_FRAME
        out = {
            "misalignment": (nav, m.enu_to_ned(e.misalignment_enu)),
            "misalignment_sigma": (nav, m.sigma_enu_to_ned(e.misalignment_sigma_enu)),
            "initial_misalignment": (nav, m.enu_to_ned(e.misalignment0_enu)),
            "initial_misalignment_sigma": (nav, m.sigma_enu_to_ned(e.misalignment0_sigma_enu)),
            "north_drift": (nav, m.north_only(e.north_drift)),
            "north_drift_sigma": (nav, m.north_only(e.north_drift_sigma, sigma=True)),
            "gyro_drift": (plat, m.planar(e.gyro_drift_xy)),
            "gyro_drift_sigma": (plat, m.planar(e.gyro_drift_sigma_xy, sigma=True)),
            "accel_bias": (plat, m.planar(e.accel_bias_xy)),
            "accel_bias_sigma": (plat, m.planar(e.accel_bias_sigma_xy, sigma=True)),
            "status": (plat, (e.age_s, float(e.n_updates), 1.0 if e.converged else 0.0)),
        }
        for name, (frame, vec) in out.items():
            self.pubs[name].publish(m.vector3_msg(t_ns, frame, vec))


def main(argv: list[str] | None = None) -> int:
    return run_node(PlatformAlignmentNode, "platform_alignment", DESCRIPTION, argv)


if __name__ == "__main__":
    sys.exit(main())

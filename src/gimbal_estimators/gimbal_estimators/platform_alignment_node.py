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

Timing (parameter ``timing``, :mod:`gimbal_kinematics.ros.node_io`):

* ``lockstep`` (what ``gimbal-run`` sets): ``GRAPH_QOS``, inputs grouped by step on the
  ``sim_rate_hz`` grid (off-grid stamps rejected), ``~/progress`` on the grid, no
  /diagnostics: the behaviour before free timing existed (byte-identical bags).
* ``free`` (the default when started alone): SensorDataQoS inputs, default-QoS outputs, no
  step grid, no wait on ``/clock`` or a progress topic. The two streams are fed to the core
  in stamp order (:class:`gimbal_kinematics.sync.StampOrder`, the joint before the
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

from diagnostic_msgs.msg import DiagnosticArray

from gimbal_kinematics.ros.diagnostics import health_msg
from gimbal_kinematics.ros.node_io import NodeIo
from gimbal_kinematics.ros.node_main import run_node
from gimbal_kinematics.stamps import Stamp
from gimbal_kinematics.stream_stats import StreamStats
from gimbal_kinematics.ros.readiness import announce_when_connected
from gimbal_kinematics.params import steps_per_sample
from gimbal_kinematics.ros.params import declare_and_read
from gimbal_kinematics.sync import StampOrder, StepGroups

from . import messages as m
from .nis import NisWindow
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
        self.sync = StepGroups(self._needs, v["clock_jump_s"] * self.rate)
        self.progress_every = v["progress_every_steps"]
        self.wait_for_subscribers = v["wait_for_subscribers"]
        self.rejected_off_grid = 0
        self.rejected_joints = 0
        self._seen: tuple[int, ...] = ()
        timing = v["timing"]
        self.free = timing == "free"
        self.t0_ns: int | None = None  # free timing: the first stamp (the core's time origin)
        self.order = StampOrder(("joint", "imu"), int(round(v["max_sync_wait_s"] * 1e9)))
        jump_ns = int(round(v["clock_jump_s"] * 1e9))
        self.stats = {s: StreamStats(jump_ns) for s in ("imu", "joint")}
        self.nis = NisWindow(2, window=v["nis_window"])
        self._updates_seen = 0
        self._imu_samples = 0
        self.diag_period_ns = int(round(v["diagnostics_period_s"] * 1e9))
        self._next_diag_ns = 0
        self.io = io = NodeIo(self)
        self.pubs = {name: io.advertise(Vector3Stamped, f"~/{name}", timing) for name in OUTPUTS}
        self.pub_progress = io.advertise(Clock, "~/progress", timing)
        # lockstep publishes no /diagnostics (its bags stay as they were)
        self.pub_diag = io.advertise(DiagnosticArray, "/diagnostics", timing) if self.free else None
        on_input = self._on_free_input if self.free else self._on_input
        self.subs = [
            io.subscribe(Imu, "/platform/imu", lambda msg: on_input("imu", msg), timing),
            io.subscribe(JointState, v["joint_topic"], lambda msg: on_input("joint", msg), timing),
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

    def _on_free_input(self, kind: str, msg) -> None:
        """Free timing: judge the stamp, then feed the core in stamp order (module docstring)."""
        t_ns = m.stamp_ns(msg.header.stamp)
        verdict = self.stats[kind].offer(t_ns)
        if verdict is Stamp.DUPLICATE or verdict is Stamp.OUT_OF_ORDER:
            self._warn(f"{kind} sample at {t_ns * 1e-9:.6f} s dropped: {verdict.value} stamp (counted)")
            return
        if self.t0_ns is None:
            self.t0_ns = t_ns
        for stream, item in self.order.add(kind, t_ns, msg):
            self._process_free(stream, item)

    def _process_free(self, kind: str, msg) -> None:
        t_ns = m.stamp_ns(msg.header.stamp)
        t = (t_ns - self.t0_ns) * 1e-9
        est = None
        if kind == "joint":
            self._feed_joint(t, msg, f"{t_ns * 1e-9:.6f} s")
        else:
            est = self.core.on_accel(t, m.vec_of(msg.linear_acceleration))
            self._imu_samples += 1
            if self._imu_samples % self.progress_every == 0:
                self.pub_progress.publish(m.clock_msg(t_ns))
        self._warn_counters(f"{t_ns * 1e-9:.6f} s")
        if self.core.n_updates != self._updates_seen:
            if self.core.n_updates > self._updates_seen:
                self.nis.add(self.core.last_nis)
            self._updates_seen = self.core.n_updates
        if est is not None:
            self._publish(t_ns, est)
            if t_ns >= self._next_diag_ns:
                self._next_diag_ns = t_ns + self.diag_period_ns
                self.pub_diag.publish(self.health(t_ns))

    def health(self, t_ns: int) -> DiagnosticArray:
        """Free-timing /diagnostics (module docstring)."""
        c = self.core.counters
        fields: dict = {k: getattr(c, k) for k in (
            "accepted", "rejected_nonfinite", "rejected_out_of_order", "rejected_no_joint", "rejected_stale_joint",
            "joint_rejected_nonfinite", "joint_rejected_out_of_order", "resets")}
        fields.update(updates=self.core.n_updates, rejected_joints=self.rejected_joints)
        for name, st in self.stats.items():
            fields.update(st.as_dict(name))
        fields["incompatible_qos"] = self.io.incompatible_qos
        fields.update(self.nis.as_dict())
        warn = ("rejected_nonfinite", "rejected_out_of_order", "rejected_no_joint", "rejected_stale_joint",
                "joint_rejected_nonfinite", "joint_rejected_out_of_order", "resets", "rejected_joints",
                "imu_duplicates", "imu_out_of_order", "joint_duplicates", "joint_out_of_order", "incompatible_qos")
        return health_msg(t_ns, self.get_name(), fields, ready=self.core.n_updates > 0, not_ready="no estimate yet",
                          warn=warn, nis_verdict=self.nis.verdict().verdict)

    def _feed_joint(self, t: float, msg, where: str) -> None:
        joint = m.joint_position_velocity(msg, self.azimuth_joint)
        if joint is None:
            self.rejected_joints += 1
            self._warn(f"{where}: no joint {self.azimuth_joint!r} with a position: ignored "
                       f"({self.rejected_joints} rejected)")
        else:
            self.core.on_joint_state(t, joint[0] + self.heading, joint[1])

    def _warn_counters(self, where: str) -> None:
        c = self.core.counters
        seen = (c.rejected_nonfinite, c.rejected_out_of_order, c.rejected_no_joint, c.rejected_stale_joint,
                c.joint_rejected_nonfinite, c.joint_rejected_out_of_order)
        if seen != self._seen and any(seen):
            self._warn(f"{where}: samples rejected so far: accelerometer {seen[0]} non-finite, {seen[1]} out of "
                       f"order, {seen[2] + seen[3]} without a joint angle; joint {seen[4]} non-finite, "
                       f"{seen[5]} out of order")
        self._seen = seen

    def _process(self, k: int, group: dict) -> None:
        t = k / self.rate
        core = self.core
        if "joint" in group:
            self._feed_joint(t, group["joint"], f"step {k}")
        est = None
        if "imu" in group:
            est = core.on_accel(t, m.vec_of(group["imu"].linear_acceleration))
        self._warn_counters(f"step {k}")
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

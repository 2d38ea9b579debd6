"""``free_gyro_positioning`` node: paper 4's free-gyro position fix and heading.

A thin wrapper around :class:`.free_gyro_positioning.FreeGyroPositioning`. Inputs, all
stamped with the read-out time and grouped by exact stamp (one group per read-out):

* ``/free_gyro/spin_axis_a``, ``/free_gyro/spin_axis_b`` (geometry_msgs/Vector3Stamped):
  the two spin axes read out in the body FRD frame (unit vectors);
* ``/free_gyro/imu`` (sensor_msgs/Imu): the body triad ω_ib^b (``angular_velocity``, the
  average over the interval ending at the stamp) and the vertical reference (roll and pitch
  of ``orientation``; its heading is ignored).

Every read-out is integrated into the current fix window; when a window closes the node
publishes (topics under ``/free_gyro_positioning/``):

* ``fix`` (sensor_msgs/NavSatFix) at the window's mean time: latitude/longitude and the
  ENU covariance FDOP-scaled by the window's nadir-angle σ — only for a valid fix;
* ``heading`` (Vector3Stamped): x = window-mean heading ψ = α − ζ [rad] (paper Fig. 4),
  y = its 1σ [rad], z = the window's span [s] (valid fixes only);
* ``geometry`` (Vector3Stamped): x = FDOP (NaN when not computable), y = crossing angle
  Δα = ζ_b − ζ_a [rad], z = status: 0 fix published, 1 degenerate geometry (no fix);
* ``nadir`` (Vector3Stamped): x, y = integrated nadir angles θ_a, θ_b [rad], z = their σ [rad];
* ``heading_earth_rate`` (Vector3Stamped), each time an earth-rate window completes (Fig. 3,
  eq. 3–4): x = ψ [rad], y = 1σ [rad], z = the window length [s], stamped at its centre.

With ``velocity_input`` the node also takes ``/free_gyro/velocity`` (Vector3Stamped, the
ship's NED ground velocity [m/s], in the read-out group: one per read-out, same stamp) for
the transport rate the earth-rate heading removes. With ``predict_error`` it publishes, with
each valid fix, the linear error model's σ
(:class:`.free_gyro_error_model.FixPredictor`, paper 4 eq. 19–38; inputs the ``error_*``
parameters, the pickoff noise and the triad ARW), all Vector3Stamped at the fix's stamp:

* ``predicted_nadir``: x, y = σ of θ_a, θ_b [rad], z = their correlation;
* ``predicted_position``: x, y = σ north, σ east [m], z = their correlation;
* ``predicted_heading``: x = σ of the free-gyro heading [rad], y = σ of the earth-rate
  heading [rad], z = eq. 38's fd = FDOP σ_θ [m].

Degenerate geometry (parallel spin axes, tangent or non-intersecting nadir circles, FDOP
above ``max_fdop``) is counted, warned about at most once a second, reported on
``geometry`` with status 1, and no fix is published. Out-of-order stamps and non-finite or
non-unit inputs are rejected and counted; a stamp more than ``clock_jump_s`` behind the
last read-out (a bag looping) resets the node. The node must see every read-out, so it
reports the next step it needs on ``~/progress`` (the lockstep pacing protocol).

Timing (parameter ``timing``, :mod:`gimbal_kinematics.ros.node_io`), chosen once in the
constructor as the input policy (:func:`gimbal_kinematics.timing.input_policy.synced_policy`):

* ``lockstep`` (what ``gimbal-run`` sets): ``GRAPH_QOS`` everywhere, ``~/progress`` on the
  step grid, no /diagnostics (byte-identical bags).
* ``free`` (the default when started alone): SensorDataQoS inputs, default-QoS outputs, no
  wait on a step grid, ``/clock`` or a progress topic: read-outs are grouped by exact stamp
  and processed as they complete. The core keeps absolute seconds here (unlike the filters):
  its earth-rotation angle is referred to ``spin_reference_time_s``, so the time origin is
  physical, and float seconds near 1.8e9 s (resolution 2.4e-7 s) move the earth by
  1.7e-11 rad, far below the arcsecond read-out noise. ``~/progress`` reports the newest
  completed read-out's stamp every ``progress_every_steps`` read-outs. /diagnostics (one
  status per fix window) carries the core's counters, the node's (``rejected_stamps``:
  duplicate or out-of-order stamps of one topic; ``degenerate``; ``node_resets``) and
  ``incompatible_qos``. There is no NIS: a fix is a least-squares geometric solution per
  window, with no predicted measurement to innovate against; its consistency shows in
  ``geometry`` (FDOP) and the window's nadir σ.
"""
from __future__ import annotations

import math
import sys

from geometry_msgs.msg import Vector3Stamped
from rclpy.node import Node
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, NavSatFix

from gimbal_kinematics.timing.input_policy import Step, synced_policy
from gimbal_kinematics.ros.node_edge import NodeEdge, input_warnings
from gimbal_kinematics.ros.node_main import run_node
from gimbal_kinematics.ros.readiness import announce_when_connected
from gimbal_kinematics.ros.params import declare_and_read

from . import messages as m
from .free_gyro_error_model import fix_predictor
from .free_gyro_positioning import FreeGyroFix, FreeGyroPositioning, FreeGyroPositioningParams
from .free_gyro_positioning_params import DESCRIPTION, PARAMS
from .wire import free_gyro_fix_messages

SPIN_A, SPIN_B, IMU = "/free_gyro/spin_axis_a", "/free_gyro/spin_axis_b", "/free_gyro/imu"
VELOCITY = "/free_gyro/velocity"
OUTPUTS = ((NavSatFix, "~/fix"), *((Vector3Stamped, f"~/{k}") for k in ("heading", "geometry", "nadir",
                                                                        "heading_earth_rate")))
PREDICTIONS = tuple((Vector3Stamped, f"~/predicted_{k}") for k in ("nadir", "position", "heading"))
CORE_COUNTERS = ("spin_accepted", "rates_accepted", "rejected_nonfinite", "rejected_not_unit", "rejected_no_level",
                 "rejected_stale_level", "fixes", "degenerate", "resets")
WARN_COUNTERS = ("rejected_nonfinite", "rejected_not_unit", "rejected_no_level",
                 "rejected_stale_level", "degenerate", "rejected_stamps", "node_resets", *input_warnings())


class FreeGyroPositioningNode(Node):
    def __init__(self, **node_kwargs) -> None:
        super().__init__("free_gyro_positioning", **node_kwargs)
        values = declare_and_read(self, PARAMS)
        self.core = FreeGyroPositioning(FreeGyroPositioningParams.from_values(values))
        self.height_m = values["height_m"]
        self.height_sigma_m = values["height_sigma_m"]
        self.velocity_input = values["velocity_input"]
        inputs = ((SPIN_A, Vector3Stamped, SPIN_A), (SPIN_B, Vector3Stamped, SPIN_B), (IMU, Imu, IMU)) + (
            ((VELOCITY, Vector3Stamped, VELOCITY),) if self.velocity_input else ())
        # the one choice of timing (module docstring); a read-out stamp jumping back restarts
        self.policy = synced_policy(values["timing"], tuple(topic for topic, *_ in inputs),
                                    rate_hz=values["sim_rate_hz"], progress_every=values["progress_every_steps"],
                                    clock_jump_ns=int(round(values["clock_jump_s"] * 1e9)), on_restart=self._reset)
        self.predictor = fix_predictor(values, self.core.params)
        self.degenerate = 0
        self.resets = 0
        self._er_t: float | None = None        # stamp of the last earth-rate heading published
        self.edge = edge = NodeEdge(self, values)
        outputs = OUTPUTS + (PREDICTIONS if self.predictor is not None else ())
        edge.advertise_all(outputs + ((Clock, "~/progress"),))
        edge.advertise_diagnostics(self.policy)
        self.subs = edge.subscribe_all(inputs, self._on_input)
        announce_when_connected(self, edge.pubs["~/progress"], outputs=[edge.pubs[t] for _, t in outputs],
                                readers=values["wait_for_subscribers"])

    # -- readiness and bookkeeping ---------------------------------------------------------
    @property
    def rejected(self) -> int:
        """Inputs rejected so far: stamps out of order and non-finite/non-unit/unlevelled data."""
        c = self.core.counters
        return (self.policy.rejected + c.rejected_nonfinite + c.rejected_not_unit
                + c.rejected_no_level + c.rejected_stale_level)

    def _reset(self, reason: str) -> None:  # the input policy saw the read-out stamps jump back
        self.resets += 1
        self.core.reset(reason)
        if self.predictor is not None:
            self.predictor.clear()
        self._er_t = None
        self.get_logger().info(f"reset: {reason}")

    # -- inputs ----------------------------------------------------------------------------
    def _on_input(self, topic: str, msg) -> None:
        for step in self.policy.add(topic, m.stamp_ns(msg.header.stamp), msg):
            self._step(step)

    def _step(self, step: Step) -> None:
        t_ns, t, group = step.stamp_ns, step.t, step.msg
        imu = group[IMU]
        roll, pitch = m.level_of(imu)
        fed = [self.core.on_velocity(t, m.vec_of(group[VELOCITY].vector))] if self.velocity_input else []
        fed.append(self.core.on_level(t, roll, pitch))
        if self.predictor is not None:
            self.predictor.add_level(roll, pitch)
        fed.append(self.core.on_body_rates(t, m.vec_of(imu.angular_velocity)))
        fed.append(self.core.on_spin_axes(t, m.vec_of(group[SPIN_A].vector), m.vec_of(group[SPIN_B].vector)))
        why = "; ".join(f.why for f in fed if f.why is not None)
        if why:
            self.edge.warn(f"read-out at {t:.3f} s: input rejected: {why}")
        fix = fed[-1].output
        if fix is not None:
            self._publish_fix(fix, t)
            self.edge.pubs["/diagnostics"].publish(self.health(t_ns))  # each fix: no throttle
        self.edge.progress(self.policy.progress(step))

    def health(self, t_ns: int):
        """/diagnostics: what the input policy reports (module docstring)."""
        c = self.core.counters
        return self.edge.health(t_ns, self.policy, {k: getattr(c, k) for k in CORE_COUNTERS}, ready=c.fixes > 0,
                                node={"rejected_stamps": self.policy.rejected, "node_resets": self.resets},
                                not_ready="no estimate yet", warn=WARN_COUNTERS)

    # -- outputs ---------------------------------------------------------------------------
    def _publish_fix(self, fix: FreeGyroFix, t_close: float) -> None:
        prediction = None
        if fix.valid and self.predictor is not None:
            prediction = self.predictor.predict(fix.lat, fix.lon, fix.t, fix.heading, fix.n_samples)
        if not fix.valid:
            self.degenerate += 1
            self.edge.warn(f"degenerate fix geometry, no fix published: {fix.reason} "
                           f"({self.degenerate} windows so far)")
        t_er = fix.heading_earth_rate_t
        earth_rate = math.isfinite(fix.heading_earth_rate) and (self._er_t is None or t_er > self._er_t)
        if earth_rate:
            self._er_t = t_er
        # serialized by gimbal_estimators.wire (the engine writes the same bytes into its bag)
        self.edge.publish(free_gyro_fix_messages(fix, t_close, self.height_m, self.height_sigma_m, prediction,
                                                 self.core.params.heading_window_s if earth_rate else None))


def main(argv: list[str] | None = None) -> int:
    return run_node(FreeGyroPositioningNode, "free_gyro_positioning", DESCRIPTION, argv)


if __name__ == "__main__":
    sys.exit(main())

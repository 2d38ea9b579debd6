"""``geo_pointer`` node: points the LOS at a geographic target (:mod:`.geo_pointer`).

Per INS sample it takes the gyro-bias EKF's attitude estimate (``attitude_topic``, Imu with
C(n,m)), the INS attitude (``/ins/imu``) and the encoders' turret angle
(``/gimbal/joint_states``), all stamped like the INS sample, and publishes, stamped the same:

* the LOS rate command on ``operator_topic`` (Vector3Stamped, sight frame, rad/s: x = 0,
  y = q, z = r), the ``los_rate_controller``'s operator input (that node's
  ``operator_rate_hz`` = ``ins_rate_hz`` makes it wait for each command in lockstep);
* ``~/budget`` (Vector3Stamped [rad]): x the 1σ pointing-error budget (RMS of the error
  angle), y and z its two semi-axes;
* ``~/aim`` (Vector3Stamped, ``map_ned``): the LOS it steers to, a unit vector in NED (what
  ``mavlink_gimbal_manager`` sends to a MAVLink gimbal);
* ``/diagnostics`` every ``diagnostics_period_s`` with the counters: inputs that could not
  be used, rejected targets, steps at a gimbal limit.

The target is ``target_llh_deg`` until a ``sensor_msgs/NavSatFix`` arrives on
``target_topic``. NavSatFix rather than a WGS-84 PointStamped: its fields *are* latitude,
longitude [deg] and height above the WGS-84 ellipsoid [m], so no convention rides on x, y, z,
and it carries a position covariance and a status (a fix with ``STATUS_NO_FIX`` is refused).
A non-finite target, or one within ``min_range_m`` of the vehicle, is refused at start-up
(exit 2) and counted and ignored as a message.

The vehicle is at ``vehicle_llh_deg`` (a fixed site) unless ``vehicle_fix_topic`` names its
INS position (``sensor_msgs/NavSatFix``), and ``vehicle_velocity_topic`` its velocity over the
ground (``geometry_msgs/Vector3Stamped``, NED [m/s]) for the feed-forward. A fix is refused
and counted, never used, when: its status is ``STATUS_NO_FIX`` (``fixes_no_fix``); it is not
finite, out of range or within ``min_range_m`` of the target (the core's ``rejected_fixes``);
its stamp is not after the last fix's (``fixes_out_of_order``); or it is older than
``vehicle_fix_max_age_s`` against the newest attitude estimate when it arrives
(``stale_fixes``). A velocity likewise (``rejected_velocities``). A step whose newest fix or
velocity is older than ``vehicle_fix_max_age_s`` publishes nothing (``stale_commands``), so
the controller's dead-man stops the slew; before the first fix, likewise. Free timing only:
no simulated INS publishes a position, and a lockstep step cannot wait for one (refused at
start-up).

``timing: lockstep`` (the orchestrator's) waits for the three inputs of each INS step;
``timing: free`` steps on each attitude estimate with the newest INS and encoder samples no
older than 0.1 s, and publishes nothing while they are stale (counted): the controller's
dead-man then stops the slew.
"""
from __future__ import annotations

import math
import sys

import numpy as np
from geometry_msgs.msg import Vector3Stamped
from rclpy.node import Node
from sensor_msgs.msg import Imu, JointState, NavSatFix, NavSatStatus

from gimbal_kinematics.maths.rotations import quat_to_dcm
from gimbal_kinematics.params.table import ParameterError, steps_per_sample
from gimbal_kinematics.ros.diagnostics import health_msg
from gimbal_kinematics.ros.input_kinds import InputKind
from gimbal_kinematics.ros.node_edge import NodeEdge
from gimbal_kinematics.ros.node_main import run_node
from gimbal_kinematics.ros.params import declare_and_read
from gimbal_kinematics.timing.control_policy import ArrivalCheck, ControlStep, FreeControl, LockstepControl, control_policy
from gimbal_kinematics.timing.input_policy import SampleGrid

from . import messages as m
from .geo_pointer import GeoPointer, GeoPointerParams
from .geo_pointer_params import DESCRIPTION, PARAMS, vehicle_inputs as requested_vehicle_inputs
from .wire import geo_pointer_messages

COUNTERS = ("malformed", "rejected_inputs", "held_commands", "fixes_no_fix", "fixes_out_of_order", "stale_fixes",
            "rejected_velocities")
MAX_INPUT_AGE_S = 0.1
CLOCK_JUMP_S = 0.5
#: a refused fix's counter, by the arrival check's verdict
FIX_VERDICTS = {"out_of_order": "fixes_out_of_order", "stale": "stale_fixes"}


class GeoPointerNode(Node):
    def __init__(self, **node_kwargs) -> None:
        super().__init__("geo_pointer", **node_kwargs)
        values = declare_and_read(self, PARAMS)
        try:
            self.core = GeoPointer(GeoPointerParams.from_values(values))
        except ParameterError as exc:
            raise ValueError(str(exc)) from exc
        self.command = (0.0, 0.0)
        vehicle_inputs = requested_vehicle_inputs(values)
        self.edge = edge = NodeEdge(self, values, COUNTERS)
        self.operator_topic = values["operator_topic"]
        edge.advertise_all(((Vector3Stamped, self.operator_topic), (Vector3Stamped, "~/budget"),
                            (Vector3Stamped, "~/aim")))
        edge.advertise_diagnostics()
        # lockstep: the three inputs of each INS step
        grid = SampleGrid(dict.fromkeys((InputKind.ATTITUDE, InputKind.INS, InputKind.ENCODERS),
                                        steps_per_sample(values, "ins_rate_hz")))
        self.policy = control_policy(
            values["timing"],
            lockstep=lambda: LockstepControl(grid.needs, values["sim_rate_hz"], CLOCK_JUMP_S, logger=self.get_logger()),
            free=lambda: FreeControl(InputKind.ATTITUDE, {**dict.fromkeys((InputKind.INS, InputKind.ENCODERS),
                                                                          MAX_INPUT_AGE_S),
                                             **dict.fromkeys(vehicle_inputs, values["vehicle_fix_max_age_s"])},
                                     1.0 / values["ins_rate_hz"], CLOCK_JUMP_S, warn=edge.warn))
        edge.subscribe_all(((InputKind.ATTITUDE, Imu, values["attitude_topic"]), (InputKind.INS, Imu, "/ins/imu"),
                            (InputKind.ENCODERS, JointState, "/gimbal/joint_states")), self._on_input)
        if values["target_topic"]:
            edge.subscribe(NavSatFix, values["target_topic"], self._on_target)
        # a fix or velocity is judged as it arrives: in stamp order, fresh against the attitude
        self.arrivals = ArrivalCheck(InputKind.ATTITUDE, vehicle_inputs,
                                     int(round(values["vehicle_fix_max_age_s"] * 1e9)))
        if InputKind.FIX in vehicle_inputs:
            edge.subscribe(NavSatFix, values["vehicle_fix_topic"], self._on_fix)
        if InputKind.VELOCITY in vehicle_inputs:
            edge.subscribe(Vector3Stamped, values["vehicle_velocity_topic"], self._on_velocity)

    def _vehicle_sample(self, kind: str, stamp_ns: int, value, counter: str) -> None:
        """A validated fix or velocity (None: refused, counted in ``counter``) to the policy,
        unless its arrival check refuses it (out of order or stale; counted)."""
        verdict = None if value is None else self.arrivals.verdict(kind, stamp_ns)
        if verdict is not None:
            counter, value = (FIX_VERDICTS[verdict] if kind == InputKind.FIX else counter), None
        if value is None:
            if counter in COUNTERS:
                return self.edge.reject(counter, f"vehicle {kind} stamped {stamp_ns} ns refused")
            return self.edge.warn(f"vehicle {kind} stamped {stamp_ns} ns refused ({counter})")
        for step in self.policy.add(kind, stamp_ns, value):
            self._step(step)

    def _on_fix(self, msg: NavSatFix) -> None:
        llh = (math.radians(msg.latitude), math.radians(msg.longitude), msg.altitude)
        stamp = m.stamp_ns(msg.header.stamp)
        if msg.status.status == NavSatStatus.STATUS_NO_FIX:
            self._vehicle_sample(InputKind.FIX, stamp, None, "fixes_no_fix")
        else:
            self._vehicle_sample(InputKind.FIX, stamp, llh if self.core.check_fix(llh) else None, "rejected_fixes")

    def _on_velocity(self, msg: Vector3Stamped) -> None:
        vel = tuple(msg.vector)
        self._vehicle_sample(InputKind.VELOCITY, m.stamp_ns(msg.header.stamp),
                             vel if all(map(math.isfinite, vel)) else None, "rejected_velocities")

    def _on_target(self, msg: NavSatFix) -> None:
        llh = (math.radians(msg.latitude), math.radians(msg.longitude), msg.altitude)
        if not self.core.take_target(llh, msg.status.status != NavSatStatus.STATUS_NO_FIX):
            self.edge.warn(f"target {msg.latitude}, {msg.longitude}, {msg.altitude} refused "
                           f"({self.core.counts['rejected_targets']} rejected_targets)")

    def _on_input(self, kind: str, msg) -> None:
        stamp_ns = m.stamp_ns(msg.header.stamp)
        self.arrivals.heard(kind, stamp_ns)
        for step in self.policy.add(kind, stamp_ns, self._validate(kind, msg)):
            self._step(step)

    def _validate(self, kind: str, msg):
        """What the step takes from an input: a quaternion, or the turret angle; None
        (counted) when it cannot be used."""
        if kind == InputKind.ENCODERS:
            readings = m.encoder_readings(msg)
            value = None if readings is None else (readings[0][0],)
        else:
            value = tuple(msg.orientation) if m.field_provided(msg.orientation_covariance) else None
        if value is None or not all(map(math.isfinite, value)):
            return self.edge.reject("rejected_inputs", f"{kind} sample without a usable attitude or turret angle; "
                                    "not used")
        return value

    def _step(self, step: ControlStep) -> None:
        inputs = step.inputs
        # an encoder-only step between INS samples, or stale inputs
        if InputKind.ATTITUDE not in inputs or step.zero_command:
            return
        att, ins, enc = inputs.get(InputKind.ATTITUDE), inputs.get(InputKind.INS), inputs.get(InputKind.ENCODERS)
        budget = aim = None
        fix, vel = inputs.get(InputKind.FIX), inputs.get(InputKind.VELOCITY)
        if att is None or ins is None or enc is None or (fix is not None and not self.core.set_vehicle(
                fix.value, None if vel is None else vel.value)):
            self.edge.counts["held_commands"] += 1
        else:
            out = self.core.step(att.value, quat_to_dcm(np.asarray(ins.value)), enc.value[0])
            self.command, budget, aim = out.command, out.budget, tuple(out.aim_n)
        figures = None if budget is None else (budget.total_rad, *budget.principal_sigmas_rad)
        # serialized by gimbal_control.wire (the engine writes the same bytes into its bag)
        self.edge.publish(geo_pointer_messages(step.stamp_ns, self.operator_topic, self.command, figures, aim))
        self.edge.diagnostics(step.stamp_ns, lambda: health_msg(step.stamp_ns, self.get_name(), {
            **self.policy.counters(), **self.edge.counts, **self.core.counts, **self.edge.io.counters()}))


def main(argv: list[str] | None = None) -> int:
    return run_node(GeoPointerNode, "geo_pointer", DESCRIPTION, argv)


if __name__ == "__main__":
    sys.exit(main())

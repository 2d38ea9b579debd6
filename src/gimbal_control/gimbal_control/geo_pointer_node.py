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
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import Vector3Stamped
from rclpy.node import Node
from sensor_msgs.msg import Imu, JointState, NavSatFix, NavSatStatus

from gimbal_kinematics.control_policy import ControlStep, FreeControl, LockstepControl, control_policy
from gimbal_kinematics.params import ParameterError, steps_per_sample
from gimbal_kinematics.ros.input_kinds import InputKind
from gimbal_kinematics.ros.cdr import CdrError
from gimbal_kinematics.ros.diagnostics import health_msg
from gimbal_kinematics.ros.node_io import NodeIo
from gimbal_kinematics.ros.node_main import run_node
from gimbal_kinematics.ros.params import declare_and_read
from gimbal_kinematics.rotations import quat_to_dcm

from . import messages as m
from .geo_pointer import GeoPointer, GeoPointerParams
from .geo_pointer_params import DESCRIPTION, PARAMS
from .wire import geo_pointer_messages

COUNTERS = ("malformed", "rejected_inputs", "held_commands", "fixes_no_fix", "fixes_out_of_order", "stale_fixes",
            "rejected_velocities")
MAX_INPUT_AGE_S = 0.1
CLOCK_JUMP_S = 0.5


class GeoPointerNode(Node):
    def __init__(self, **node_kwargs) -> None:
        super().__init__("geo_pointer", **node_kwargs)
        values = declare_and_read(self, PARAMS)
        timing = values["timing"]
        rate = values["sim_rate_hz"]
        try:
            self.core = GeoPointer(GeoPointerParams.from_values(values))
        except ParameterError as exc:
            raise ValueError(str(exc)) from exc
        self.counts = dict.fromkeys(COUNTERS, 0)
        self.command = (0.0, 0.0)
        vehicle_inputs = self._vehicle_inputs(values)
        self.io = NodeIo(self)
        self.operator_topic = values["operator_topic"]
        self.pub_cmd = self.io.advertise(Vector3Stamped, self.operator_topic, timing)
        self.pub_budget = self.io.advertise(Vector3Stamped, "~/budget", timing)
        self.pub_aim = self.io.advertise(Vector3Stamped, "~/aim", timing)
        self.pubs = {"~/budget": self.pub_budget, "~/aim": self.pub_aim}
        self.pub_diag = self.io.advertise(DiagnosticArray, "/diagnostics", timing)
        self.diag_period_ns = int(round(values["diagnostics_period_s"] * 1e9))
        self._next_diag_ns = 0
        ins_every = steps_per_sample(values, "ins_rate_hz")
        step_needs = (InputKind.ATTITUDE, InputKind.INS, InputKind.ENCODERS)

        def needs(k: int) -> tuple[str, ...]:
            return step_needs if k % ins_every == 0 else ()

        self.policy = control_policy(
            timing,
            lockstep=lambda: LockstepControl(needs, rate, CLOCK_JUMP_S, logger=self.get_logger()),
            free=lambda: FreeControl(InputKind.ATTITUDE, {**dict.fromkeys((InputKind.INS, InputKind.ENCODERS),
                                                                          MAX_INPUT_AGE_S),
                                             **dict.fromkeys(vehicle_inputs, values["vehicle_fix_max_age_s"])},
                                     1.0 / values["ins_rate_hz"], CLOCK_JUMP_S, warn=self._log))
        inputs = ((InputKind.ATTITUDE, Imu, values["attitude_topic"], m.imu_from_cdr),
                  (InputKind.INS, Imu, "/ins/imu", m.imu_from_cdr),
                  (InputKind.ENCODERS, JointState, "/gimbal/joint_states", m.joint_state_from_cdr))
        for kind, msg_type, topic, decode in inputs:
            self.io.subscribe(msg_type, topic, lambda data, k=kind, d=decode: self._on_input(k, data, d), timing,
                              raw=True)
        if values["target_topic"]:
            self.io.subscribe(NavSatFix, values["target_topic"], self._on_target, timing)
        self._last_ns = {InputKind.FIX: None, InputKind.VELOCITY: None, InputKind.ATTITUDE: None}
        self.max_fix_age_ns = int(round(values["vehicle_fix_max_age_s"] * 1e9))
        if InputKind.FIX in vehicle_inputs:
            self.io.subscribe(NavSatFix, values["vehicle_fix_topic"], self._on_fix, timing)
        if InputKind.VELOCITY in vehicle_inputs:
            self.io.subscribe(Vector3Stamped, values["vehicle_velocity_topic"], self._on_velocity, timing)

    @staticmethod
    def _vehicle_inputs(values: dict) -> tuple[str, ...]:
        """The vehicle's inputs the parameters ask for; ValueError naming the parameter when
        they cannot be had (a velocity without a position, or either in lockstep)."""
        inputs = tuple(kind for kind, name in ((InputKind.FIX, "vehicle_fix_topic"),
                                               (InputKind.VELOCITY, "vehicle_velocity_topic")) if values[name])
        if InputKind.VELOCITY in inputs and InputKind.FIX not in inputs:
            raise ValueError("parameter vehicle_velocity_topic needs vehicle_fix_topic (a moving vehicle's position)")
        if inputs and values["timing"] == "lockstep":
            raise ValueError("parameter vehicle_fix_topic: free timing only (a lockstep step cannot wait for a "
                             "position no simulated INS publishes)")
        return inputs

    def _vehicle_sample(self, kind: str, stamp_ns: int, value, counter: str) -> None:
        """A validated fix or velocity (None: refused, counted in ``counter``) to the policy,
        unless its stamp is not after the last one's or it is stale on arrival (counted)."""
        last, newest_att = self._last_ns[kind], self._last_ns[InputKind.ATTITUDE]
        if value is not None and last is not None and stamp_ns <= last:
            counter, value = ("fixes_out_of_order" if kind == InputKind.FIX else counter), None
        elif value is not None and newest_att is not None and newest_att - stamp_ns > self.max_fix_age_ns:
            counter, value = ("stale_fixes" if kind == InputKind.FIX else counter), None
        if value is None:
            if counter in self.counts:
                self.counts[counter] += 1
            self._log(f"vehicle {kind} stamped {stamp_ns} ns refused ({counter})")
            return
        self._last_ns[kind] = stamp_ns
        for step in self.policy.add(kind, stamp_ns, value):
            self._step(step)

    def _on_fix(self, msg: NavSatFix) -> None:
        llh = (math.radians(msg.latitude), math.radians(msg.longitude), msg.altitude)
        stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        if msg.status.status == NavSatStatus.STATUS_NO_FIX:
            self._vehicle_sample(InputKind.FIX, stamp, None, "fixes_no_fix")
        elif self.core.fix_error(llh) is not None:
            self.core.counts["rejected_fixes"] += 1
            self._vehicle_sample(InputKind.FIX, stamp, None, "rejected_fixes")
        else:
            self._vehicle_sample(InputKind.FIX, stamp, llh, "rejected_fixes")

    def _on_velocity(self, msg: Vector3Stamped) -> None:
        vel = (msg.vector.x, msg.vector.y, msg.vector.z)
        stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        self._vehicle_sample(InputKind.VELOCITY, stamp, vel if all(map(math.isfinite, vel)) else None,
                             "rejected_velocities")

    def _log(self, text: str) -> None:
        self.get_logger().warning(text, throttle_duration_sec=1.0)

    def _on_target(self, msg: NavSatFix) -> None:
        llh = (math.radians(msg.latitude), math.radians(msg.longitude), msg.altitude)
        if msg.status.status == NavSatStatus.STATUS_NO_FIX or not self.core.set_target(llh):
            if msg.status.status == NavSatStatus.STATUS_NO_FIX:
                self.core.counts["rejected_targets"] += 1
            self._log(f"target {msg.latitude}, {msg.longitude}, {msg.altitude} refused "
                      f"({self.core.counts['rejected_targets']} rejected_targets)")

    def _on_input(self, kind: str, data: bytes, decode) -> None:
        try:
            msg = decode(data)
        except CdrError as exc:
            self.counts["malformed"] += 1
            self._log(f"malformed {kind} message ignored: {exc}")
            return
        if kind == InputKind.ATTITUDE:
            self._last_ns[InputKind.ATTITUDE] = max(msg.stamp_ns, self._last_ns[InputKind.ATTITUDE] or msg.stamp_ns)
        for step in self.policy.add(kind, msg.stamp_ns, self._validate(kind, msg)):
            self._step(step)

    def _validate(self, kind: str, msg):
        """What the step takes from an input: a quaternion, or the turret angle; None
        (counted) when it cannot be used."""
        if kind == InputKind.ENCODERS:
            readings = m.encoder_readings(msg)
            value = None if readings is None else (readings[0][0],)
        elif m.field_provided(msg.orientation_covariance):
            value = msg.orientation
        else:
            value = None
        if value is None or not all(map(math.isfinite, value)):
            self.counts["rejected_inputs"] += 1
            self._log(f"{kind} sample without a usable attitude or turret angle; not used")
            return None
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
            self.counts["held_commands"] += 1
        else:
            out = self.core.step(att.value, quat_to_dcm(np.asarray(ins.value)), enc.value[0])
            self.command, budget, aim = out.command, out.budget, tuple(out.aim_n)
        figures = None if budget is None else (budget.total_rad, *budget.principal_sigmas_rad)
        # serialized by gimbal_control.wire (the engine writes the same bytes into its bag)
        for topic, _, data in geo_pointer_messages(step.stamp_ns, self.operator_topic, self.command, figures, aim):
            self.pubs.get(topic, self.pub_cmd).publish(data)
        if step.stamp_ns >= self._next_diag_ns:
            self._next_diag_ns = step.stamp_ns + self.diag_period_ns
            fields = {**self.policy.counters(), **self.counts, **self.core.counts,
                      **self.io.counters()}
            self.pub_diag.publish(health_msg(step.stamp_ns, self.get_name(), fields))


def main(argv: list[str] | None = None) -> int:
    return run_node(GeoPointerNode, "geo_pointer", DESCRIPTION, argv)


if __name__ == "__main__":
    sys.exit(main())

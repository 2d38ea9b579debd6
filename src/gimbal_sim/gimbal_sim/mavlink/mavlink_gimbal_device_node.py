"""``mavlink_gimbal_device`` node: the simulated gimbal as a MAVLink Gimbal Protocol v2
device (:mod:`.device_core`) on a UDP socket (:mod:`.link`).

The graph side, in free timing (the shape of ``geo_pointer_node`` on the controllers'
``FreeControl`` policy): it steps on each attitude estimate (``attitude_topic``, Imu with
C(n,m)) with the newest encoder (``/gimbal/joint_states``) and gimbal gyro (``/gimbal/imu``)
samples no older than ``max_input_age_s``, and publishes the core's LOS rate command on
``operator_topic`` stamped like the estimate; with a stale encoder sample it publishes
nothing, so the controller's operator dead-man stops the slew (a stale gyro only makes the
reported rates unknown). ``/diagnostics`` carries the protocol
counters every ``diagnostics_period_s`` of stamp time.

The MAVLink side runs on the wall clock (steady timers): the socket is drained every
10 ms, ``HEARTBEAT`` goes out at 1 Hz and ``GIMBAL_DEVICE_ATTITUDE_STATUS`` at
``status_rate_hz``, to every address heard from and to ``peers``. Everything runs in the
node's one executor thread, so the core needs no lock. ``timing: lockstep`` is refused: a
ground station cannot wait for the step grid.
"""
from __future__ import annotations

import math
import sys
import time

from geometry_msgs.msg import Vector3Stamped
from sensor_msgs.msg import Imu, JointState

from gimbal_kinematics.timing.control_policy import ControlStep, FreeControl
from gimbal_kinematics.maths.frames import GIMBAL_FRAME
from gimbal_kinematics.params.table import ParameterError
from gimbal_kinematics.ros.input_kinds import InputKind
from gimbal_kinematics.ros import messages as m
from gimbal_kinematics.ros.diagnostics import health_msg
from gimbal_kinematics.ros.node_edge import NodeEdge
from gimbal_kinematics.ros.node_main import run_node
from gimbal_kinematics.ros.params import declare_and_read

from .device_core import DeviceParams, GimbalDevice
from .link import open_link
from .link_node import LinkNode
from .mavlink_gimbal_device_params import DESCRIPTION, PARAMS

CLOCK_JUMP_S = 0.5
NODE_COUNTERS = ("malformed_ros", "rejected_inputs", "no_command_steps")


class MavlinkGimbalDeviceNode(LinkNode):
    def __init__(self, **node_kwargs) -> None:
        super().__init__("mavlink_gimbal_device", **node_kwargs)
        values = declare_and_read(self, PARAMS)
        if values["timing"] != "free":
            raise ValueError("parameter timing: free only (the MAVLink side runs against the wall clock)")
        try:
            self.core = GimbalDevice(DeviceParams.from_values(values))
        except ParameterError as exc:
            raise ValueError(str(exc)) from exc
        self.link = open_link(values, self.get_logger())
        self.edge = edge = NodeEdge(self, values, NODE_COUNTERS, malformed="malformed_ros")
        self.pub_cmd = edge.advertise(Vector3Stamped, values["operator_topic"])
        edge.advertise_diagnostics()
        age = values["max_input_age_s"]
        # the gyro only feeds the reported rates: stale, they are reported unknown (NaN)
        self.policy = FreeControl(InputKind.ATTITUDE, {InputKind.ENCODERS: age, InputKind.GYRO: age},
                                  1.0 / values["ins_rate_hz"], CLOCK_JUMP_S, held=(InputKind.GYRO,), warn=edge.warn)
        edge.subscribe_all(((InputKind.ATTITUDE, Imu, values["attitude_topic"]), (InputKind.GYRO, Imu, "/gimbal/imu"),
                            (InputKind.ENCODERS, JointState, "/gimbal/joint_states")), self._on_input)
        steady = self.start_link(self._poll)
        self.create_timer(1.0 / values["status_rate_hz"], self._send_status, clock=steady)

    def _poll(self) -> None:
        for datagram in self.link.receive():
            for reply in self.core.receive(datagram, time.monotonic()):
                self.link.send(reply)

    def _send_status(self) -> None:
        status = self.core.status()
        if status is not None:
            self.link.send(status)

    def _on_input(self, kind: str, msg) -> None:
        for step in self.policy.add(kind, m.stamp_ns(msg.header.stamp), self._validate(kind, msg)):
            self._step(step)

    def _validate(self, kind: str, msg):
        """What a step takes from an input (a quaternion, the sight's azimuth relative to the
        vehicle, body rates); None (counted) when it cannot be used."""
        if kind == InputKind.ENCODERS:
            readings = m.encoder_readings(msg)
            value = None if readings is None else (readings[0][0] + readings[0][1],)
        elif kind == InputKind.ATTITUDE:
            value = tuple(msg.orientation) if m.field_provided(msg.orientation_covariance) else None
        else:
            value = tuple(msg.angular_velocity) if m.field_provided(msg.angular_velocity_covariance) else None
        if value is None or not all(map(math.isfinite, value)):
            return self.edge.reject("rejected_inputs", f"{kind} sample without a usable value; not used")
        return value

    def _step(self, step: ControlStep) -> None:
        att, enc, gyro = (step.inputs.get(k) for k in (InputKind.ATTITUDE, InputKind.ENCODERS, InputKind.GYRO))
        if InputKind.ATTITUDE not in step.inputs or step.zero_command or att is None or enc is None:
            self.edge.counts["no_command_steps"] += 1
            return
        q, r = self.core.step(step.stamp_ns * 1e-9, att.value, enc.value[0], time.monotonic(),
                              None if gyro is None else gyro.value)
        self.pub_cmd.publish(m.vector3_cdr(step.stamp_ns, GIMBAL_FRAME, (0.0, q, r)))
        self.edge.diagnostics(step.stamp_ns, lambda: health_msg(step.stamp_ns, self.get_name(), {
            **self.policy.counters(), **self.edge.counts, **self.core.counts, "status_flags": self.core.status_flags(),
            "send_errors": self.link.send_errors, "incompatible_qos": self.edge.io.incompatible_qos},
            warn=("malformed", "rejected_setpoints", "earth_lock_drops")))


def main(argv: list[str] | None = None) -> int:
    return run_node(MavlinkGimbalDeviceNode, "mavlink_gimbal_device", DESCRIPTION, argv)


if __name__ == "__main__":
    sys.exit(main())

"""``mavlink_gimbal_manager`` node: drives a real MAVLink gimbal (:mod:`.manager_core`) on a
UDP socket (:mod:`.link`).

In: ``aim_topic`` (geo_pointer's ``~/aim``, a LOS direction in NED) or ``rate_topic`` (an
operator LOS rate), never both. The newest command is sent at most ``max_send_rate_hz``
(wall clock), so a 1 kHz graph does not flood a serial-bridged gimbal; a command replaced
before it was sent is counted (``superseded``). A message that is not finite is counted and
not sent. The node sends a ``HEARTBEAT`` (an onboard controller) at 1 Hz, which gimbal
devices and managers use to find their controllers.

Out: each ``GIMBAL_DEVICE_ATTITUDE_STATUS`` of the gimbal as ``~/attitude``
(``sensor_msgs/Imu`` in ``map_ned``, stamped with the node's ROS time on arrival: the
device's ``time_boot_ms`` is its own clock): orientation C(n,m) in the earth frame (a
vehicle-frame report without ``delta_yaw`` is counted, not published), its covariance from
``attitude_sigma_deg``; angular velocity in the sight frame when the report has all three
Euler rates, else marked not provided (REP 145, covariance[0] = -1); no acceleration.
"""
from __future__ import annotations

import math
import sys
import time

import numpy as np
from geometry_msgs.msg import Vector3Stamped
from sensor_msgs.msg import Imu

from gimbal_kinematics.maths.frames import NAV_FRAME
from gimbal_kinematics.params.table import ParameterError
from gimbal_kinematics.ros import messages as m
from gimbal_kinematics.ros.node_main import run_node
from gimbal_kinematics.ros.node_io import NodeIo
from gimbal_kinematics.ros.params import declare_and_read
from gimbal_kinematics.maths.rotations import euler_rates_to_body_rates, quat_to_euler321

from .link import open_link
from .link_node import LinkNode
from .manager_core import GimbalManagerClient, ManagerParams, Report
from .mavlink_gimbal_manager_params import DESCRIPTION, PARAMS



class MavlinkGimbalManagerNode(LinkNode):
    def __init__(self, **node_kwargs) -> None:
        super().__init__("mavlink_gimbal_manager", **node_kwargs)
        values = declare_and_read(self, PARAMS)
        if bool(values["aim_topic"]) == bool(values["rate_topic"]):
            raise ValueError("parameter aim_topic / rate_topic: exactly one must be set (one source of setpoints), "
                             f"got {values['aim_topic']!r} and {values['rate_topic']!r}")
        try:
            self.core = GimbalManagerClient(ManagerParams.from_values(values))
        except ParameterError as exc:
            raise ValueError(str(exc)) from exc
        self.link = open_link(values, self.get_logger())
        sigma = math.radians(values["attitude_sigma_deg"])
        self.orientation_cov = tuple(float(x) for x in (np.eye(3) * sigma * sigma).ravel())
        self.counts = {"superseded": 0, "rejected_inputs": 0, "unpublished_reports": 0}
        self._pending: bytes | None = None
        self._next_send = 0.0
        self.send_period = 1.0 / values["max_send_rate_hz"]
        self.io = NodeIo(self)
        self.pub_attitude = self.io.advertise(Imu, "~/attitude", "free")
        topic, handler = ((values["aim_topic"], self._on_aim) if values["aim_topic"]
                          else (values["rate_topic"], self._on_rate))
        self.io.subscribe(Vector3Stamped, topic, handler, "free")
        self.start_link(self._poll)

    def _queue(self, datagram: bytes | None) -> None:
        if datagram is None:
            self.counts["rejected_inputs"] += 1
            return
        self.counts["superseded"] += int(self._pending is not None)
        self._pending = datagram
        self._flush()

    def _flush(self) -> None:
        now = time.monotonic()
        if self._pending is not None and now >= self._next_send:
            self.link.send(self._pending)
            self._pending, self._next_send = None, now + self.send_period

    def _on_aim(self, msg: Vector3Stamped) -> None:
        self._queue(self.core.point((msg.vector.x, msg.vector.y, msg.vector.z)))

    def _on_rate(self, msg: Vector3Stamped) -> None:
        q, r = msg.vector.y, msg.vector.z
        if not (math.isfinite(q) and math.isfinite(r)):
            self._queue(None)
            return
        datagram = self.core.rate(q, r)
        if datagram is not None:
            self._queue(datagram)

    def _poll(self) -> None:
        self._flush()
        for datagram in self.link.receive():
            for report in self.core.receive(datagram):
                self._publish(report)

    def _publish(self, report: Report) -> None:
        if report.quat_earth is None:
            self.counts["unpublished_reports"] += 1
            return
        omega = None  # not provided unless the report has every Euler rate
        if all(map(math.isfinite, report.euler_rates)):
            roll, pitch, _ = quat_to_euler321(np.array(report.quat_earth))
            omega = tuple(euler_rates_to_body_rates(roll, pitch, np.array(report.euler_rates)))
        t_ns = self.get_clock().now().nanoseconds
        self.pub_attitude.publish(m.imu_cdr(t_ns, NAV_FRAME, orientation=report.quat_earth,
                                            orientation_cov=self.orientation_cov, angular_velocity=omega))


def main(argv: list[str] | None = None) -> int:
    return run_node(MavlinkGimbalManagerNode, "mavlink_gimbal_manager", DESCRIPTION, argv)


if __name__ == "__main__":
    sys.exit(main())
